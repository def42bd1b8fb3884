//! Round trips and range checks of the scene records.

use super::*;

#[test]
fn records_round_trip() {
    let m = MaterialModel {
        diffuse_model: DiffuseModel::OrenNayar,
        specular_model: SpecularModel::TorranceSparrow,
        reflect_mode: ReflectMode::Conductor,
        texture: TextureKind::Marble,
        mapping: Mapping::Spherical,
        tex_seed: 77,
        ..MaterialModel::default()
    };
    assert_eq!(MaterialModel::parse(&m.to_bytes()), Ok(m));
    let o =
        ObjectRecord { kind: ObjectKind::Cone, material: 3, first_prim: 9, prim_count: 1, world_to_object: [1.5; 12] };
    assert_eq!(ObjectRecord::parse(&o.to_bytes()), Ok(o));
    let l = LightingRecord {
        max_depth: 2,
        falloff: Falloff::InverseSquare,
        cos_outer: 0.7,
        cos_inner: 0.85,
        ..LightingRecord::default()
    };
    assert_eq!(LightingRecord::parse(&l.to_bytes()), Ok(l));
    let p = PrimRecord { kind: PrimKind::Cylinder, prim: 5, material: 2, world_to_object: [0.25; 12] };
    assert_eq!(PrimRecord::from_words(&p.to_words()), Some(p));
}

#[test]
fn bad_enums_and_values_are_rejected() {
    let mut b = MaterialModel::default().to_bytes();
    b[3] = 9;
    assert_eq!(MaterialModel::parse(&b), Err(SceneError::BadRecord));
    let mut b = MaterialModel::default().to_bytes();
    b[6] = 13;
    assert_eq!(MaterialModel::parse(&b), Err(SceneError::BadRecord));
    let mut b = LightingRecord::default().to_bytes();
    b[1] = 0;
    assert_eq!(LightingRecord::parse(&b), Err(SceneError::BadRecord));
    let mut b = LightingRecord::default().to_bytes();
    b[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
    assert_eq!(LightingRecord::parse(&b), Err(SceneError::NonFinite));
    assert_eq!(PrimRecord::from_words(&[0; PRIM_WORDS]), None);
}

#[test]
fn affine_helpers() {
    // Scale 2 then translate (1, 0, 0): x' = 2x + 1.
    let m: Affine = [2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0];
    assert_eq!(affine_point(&m, [1.0, 1.0, 1.0]), [3.0, 2.0, 2.0]);
    assert_eq!(affine_vector(&m, [1.0, 1.0, 1.0]), [2.0, 2.0, 2.0]);
    let r: Affine = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    assert_eq!(affine_transpose_vector(&r, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0]);
}

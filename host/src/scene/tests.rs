//! Loader tests: OBJ, MTL and PLY parsing, malformed input, degenerate geometry.

use super::*;
use gridrt_shared::scene::Material;
use std::path::PathBuf;

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
}

fn obj(text: &str) -> Result<Mesh, SceneLoadError> {
    load_obj_bytes(Path::new("test.obj"), text.as_bytes(), &|_| Err(std::io::ErrorKind::NotFound.into()))
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n";

#[test]
fn obj_quad_is_triangulated() {
    let m = obj(QUAD).unwrap();
    assert_eq!(m.triangles.len(), 2);
    assert_eq!(m.materials, vec![DEFAULT_MATERIAL]);
    assert_eq!(m.stats.dropped_degenerate, 0);
}

#[test]
fn obj_nan_vertex_names_its_line() {
    let err = obj("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(3), .. }), "{err}");
    assert!(err.to_string().contains("test.obj:line 3"), "{err}");
    let err = obj("v 0 0 0\nv 1 0 0\nv inf 1 0\nf 1 2 3\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(3), .. }), "{err}");
}

#[test]
fn obj_out_of_range_index_names_its_line() {
    let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n").unwrap_err();
    assert!(
        matches!(err, SceneLoadError::IndexOutOfRange { at: Location::Line(4), index: 4, vertex_count: 3, .. }),
        "{err}"
    );
    let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::IndexOutOfRange { index: 0, .. }), "{err}");
    let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::IndexOutOfRange { index: -4, .. }), "{err}");
    // Relative indices in range are fine.
    assert_eq!(obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap().triangles.len(), 1);
}

#[test]
fn obj_garbage_is_malformed_not_panic() {
    for text in ["v 1 2\nf 1 1 1\n", "v a b c\n", "v 0 0 0\nf x y z\n", "f\n", "v 1 1 1 0\n", "\u{0}\u{1}junk"] {
        assert!(obj(text).is_err(), "{text:?} should fail");
    }
    let err = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::Malformed { at: Location::Line(4), .. }), "{err}");
    assert!(obj("").is_err());
}

#[test]
fn obj_degenerate_triangles_are_dropped_and_counted() {
    let m = obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 2\n").unwrap();
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(m.stats.dropped_degenerate, 2);
    assert_eq!(m.stats.triangles_read, 3);
}

#[test]
fn obj_only_degenerate_is_empty_mesh_error() {
    let err = obj("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n").unwrap_err();
    assert!(matches!(err, SceneLoadError::EmptyMesh { dropped: 1, .. }), "{err}");
    assert!(matches!(obj("v 0 0 0\n").unwrap_err(), SceneLoadError::EmptyMesh { dropped: 0, .. }));
}

#[test]
fn obj_missing_mtl_is_a_warning() {
    let m = obj(&format!("mtllib nope.mtl\nusemtl red\n{QUAD}")).unwrap();
    assert_eq!(m.materials.len(), 1);
    assert!(m.triangles.iter().all(|t| t.material == 0));
    assert!(!m.stats.warnings.is_empty());
}

#[test]
fn obj_malformed_mtl_names_mtl_line() {
    let mtl = b"newmtl red\nKd 1 0\n".to_vec();
    let err = load_obj_bytes(Path::new("dir/a.obj"), format!("mtllib m.mtl\nusemtl red\n{QUAD}").as_bytes(), &|_| {
        Ok(mtl.clone())
    })
    .unwrap_err();
    assert!(
        matches!(&err, SceneLoadError::Malformed { at: Location::Line(2), path, .. } if path.ends_with("m.mtl")),
        "{err}"
    );
}

#[test]
fn cornell_box_keeps_mtl_diffuse_colours() {
    let m = load_mesh(&scenes().join("cornell_box.obj")).unwrap();
    // white, red, green, blue, light after the default.
    assert_eq!(m.materials.len(), 6);
    assert!(m.materials.contains(&Material { diffuse: [1.0, 0.0, 0.0], reflect: 0.0 }));
    assert!(m.triangles.iter().any(|t| m.materials[t.material as usize].diffuse == [0.0, 1.0, 0.0]));
    assert!(m.triangles.iter().all(|t| t.material != 0));
    assert!(m.triangles.len() >= 30, "{}", m.triangles.len());
}

#[test]
fn bunny_res4_ply_and_obj_agree() {
    let ply = load_mesh(&scenes().join("bun_zipper_res4.ply")).unwrap();
    let obj = load_mesh(&scenes().join("bun_zipper_res4.obj")).unwrap();
    assert_eq!(ply.stats.triangles_read, 946);
    assert_eq!(ply.triangles.len(), obj.triangles.len());
    assert_eq!(ply.triangles[0].v, obj.triangles[0].v);
    assert_eq!(ply.bounds(), obj.bounds());
}

#[test]
fn suzanne_quads_are_triangulated() {
    let m = load_mesh(&scenes().join("suzanne.obj")).unwrap();
    assert!(m.triangles.len() > 500);
}

fn ply_header(format: &str, nv: usize, nf: usize) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {nf}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

#[test]
fn ply_binary_little_endian_loads() {
    let mut b = ply_header("binary_little_endian", 3, 1).into_bytes();
    for v in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b.push(3);
    for i in [0i32, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    let m = load_ply_bytes(Path::new("t.ply"), &b).unwrap();
    assert_eq!(m.triangles.len(), 1);
    assert_eq!(m.triangles[0].v[1], [1.0, 0.0, 0.0]);
    // Truncated: names the element.
    let err = load_ply_bytes(Path::new("t.ply"), &b[..b.len() - 2]).unwrap_err();
    assert!(matches!(err, SceneLoadError::Malformed { at: Location::Element("face", 0), .. }), "{err}");
}

#[test]
fn ply_ascii_errors_name_the_line() {
    let h = ply_header("ascii", 3, 1);
    let ok = format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
    assert_eq!(load_ply_bytes(Path::new("t.ply"), ok.as_bytes()).unwrap().triangles.len(), 1);
    // The header has 9 lines; vertex 2 is on line 12.
    let nan = format!("{h}0 0 0\n1 0 0\n0 nan 0\n3 0 1 2\n");
    let err = load_ply_bytes(Path::new("t.ply"), nan.as_bytes()).unwrap_err();
    assert!(matches!(err, SceneLoadError::NonFinite { at: Location::Line(12), .. }), "{err}");
    let oob = format!("{h}0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    let err = load_ply_bytes(Path::new("t.ply"), oob.as_bytes()).unwrap_err();
    assert!(matches!(err, SceneLoadError::IndexOutOfRange { at: Location::Line(13), index: 7, .. }), "{err}");
    let short = format!("{h}0 0 0\n1 0\n0 1 0\n3 0 1 2\n");
    let err = load_ply_bytes(Path::new("t.ply"), short.as_bytes()).unwrap_err();
    assert!(matches!(err, SceneLoadError::Malformed { at: Location::Line(11), .. }), "{err}");
}

#[test]
fn ply_garbage_never_panics() {
    let cases: [&[u8]; 6] = [
        b"",
        b"ply\n",
        b"ply\nformat ascii 1.0\nelement vertex 1\nend_header\n0 0 0\n",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 99999999999\nproperty float x\nproperty float y\nproperty float z\nend_header\n",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n200 0 1 2\n",
        b"ply\nformat weird 1.0\nend_header\n",
    ];
    for c in cases {
        assert!(load_ply_bytes(Path::new("t.ply"), c).is_err());
    }
}

#[test]
fn unknown_extension_is_rejected() {
    assert!(matches!(load_mesh(Path::new("x.stl")), Err(SceneLoadError::UnsupportedFormat { .. })));
    assert!(matches!(load_mesh(Path::new("/nonexistent/x.obj")), Err(SceneLoadError::Io { .. })));
}

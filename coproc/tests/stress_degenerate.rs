//! Stress: degenerate inputs — zero-area triangles, grazing and axis-aligned rays, zero
//! direction components, NaN/±∞ coordinates, and random bit patterns — through every kernel
//! in every number format and through the co-processor model. They are either rejected with
//! a clear error (the model's LOAD and RAY validation) or handled (a miss, or a reported
//! fixed-point overflow); never a panic, a hang, or a hit with a non-finite or non-positive t.

mod common;

use common::*;
use gridrt_coproc::{
    exact, CoprocConfig, Coprocessor, FixedFrame, FslError, Intersector, KernelKind, ListEntry, NumberFormat, RayKind,
    RecordStatus, TimingProfile,
};
use gridrt_shared::math::{Ray, Vec3};
use gridrt_shared::scene::{TriangleRecord, PE_IMAGE_TAG};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

fn all() -> Vec<Intersector> {
    intersectors(v(-2.0, -2.0, -2.0), v(2.0, 2.0, 2.0))
}

/// A kernel answer is sane: a miss, a reported overflow, or a finite positive t.
fn sane(is: &Intersector, r: Result<Option<f32>, gridrt_coproc::Overflow>, what: &str) {
    if let Ok(Some(t)) = r {
        assert!(t.is_finite() && t > 0.0, "{is:?} {what}: t = {t}");
    }
}

#[test]
fn zero_area_triangles_never_hit() {
    let degenerate = [
        ("collinear", [v(0.0, 0.0, 0.0), v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0)]),
        ("two equal vertices", [v(0.0, 0.0, 0.0), v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)]),
        ("a point", [v(0.5, 0.5, 0.0); 3]),
        ("collinear on an axis", [v(-1.0, 0.0, 0.0), v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0)]),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(0xDE6E);
    for is in all() {
        for (name, tri) in degenerate {
            let rec = is.precompute(&tri);
            if matches!(is.kind, KernelKind::Wald | KernelKind::HanikaKeller) {
                assert_eq!(rec.status, RecordStatus::Degenerate, "{is:?} {name}");
            }
            for _ in 0..2_000 {
                let o = v(rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0));
                let target = tri[0] + (tri[2] - tri[0]) * rng.gen_range(0.0..1.0);
                let ray = aim(o, target);
                assert_eq!(is.intersect(&ray, &rec, f32::INFINITY), Ok(None), "{is:?} {name} {ray:?}");
            }
        }
    }
}

#[test]
fn grazing_axis_aligned_and_zero_component_rays_are_handled() {
    let tri = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
    let mut rays = Vec::new();
    // In the triangle's plane (grazing), through its interior, along and across its edges.
    for dir in [v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(1.0, 1.0, 0.0), v(-1.0, 0.5, 0.0)] {
        rays.push(Ray { origin: v(-0.5, 0.25, 0.0), dir });
        rays.push(Ray { origin: v(0.25, 0.25, 0.0), dir });
    }
    // Axis-aligned rays (two zero components) hitting the interior, an edge and a vertex,
    // from both sides, and rays with one zero component.
    for (x, y) in [(0.25f32, 0.25f32), (0.5, 0.0), (0.0, 0.0), (0.5, 0.5)] {
        rays.push(Ray { origin: v(x, y, 1.0), dir: v(0.0, 0.0, -1.0) });
        rays.push(Ray { origin: v(x, y, -1.0), dir: v(0.0, 0.0, 3.0) });
        rays.push(Ray { origin: v(x - 1.0, y, -1.0), dir: v(1.0, 0.0, 1.0) });
    }
    // Nearly grazing: 1 ulp out of the plane.
    rays.push(Ray { origin: v(-0.5, 0.25, f32::EPSILON), dir: v(1.0, 0.0, -f32::EPSILON) });
    rays.push(Ray { origin: v(-0.5, 0.25, 1e-30), dir: v(1.0, 0.0, -1e-30) });
    for is in all() {
        let rec = is.precompute(&tri);
        for ray in &rays {
            let r = is.intersect(ray, &rec, f32::INFINITY);
            sane(&is, r, "grazing/axis");
            // Rays lying in the plane are misses for every kernel (as for the exact test).
            if ray.origin.z == 0.0 && ray.dir.z == 0.0 {
                assert_eq!(r, Ok(None), "{is:?} in-plane {ray:?}");
                assert_eq!(exact::classify(ray, &tri), exact::Classification::Miss);
            }
            // Interior axis-aligned hits are found by every kernel at the exact t (f32: the
            // correctly rounded value; fixed point: to its resolution).
            if ray.dir.x == 0.0 && ray.dir.y == 0.0 && ray.origin.x == 0.25 && ray.origin.y == 0.25 {
                let t = exact::intersect(ray, &tri).unwrap();
                let got = r.unwrap().unwrap_or_else(|| panic!("{is:?} {ray:?}")) as f64;
                let tol = match is.format {
                    NumberFormat::F32 => 0.0,
                    NumberFormat::Fixed64Q23 => 1e-6,
                    _ => 1e-4,
                };
                assert!((got - (t as f32) as f64).abs() <= tol * t, "{is:?} {ray:?}: {got} vs {t}");
            }
        }
    }
}

#[test]
fn non_finite_coordinates_are_misses_or_reported_overflows() {
    let good = [v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0)];
    let probe = Ray { origin: v(0.25, 0.25, -1.0), dir: v(0.0, 0.0, 1.0) };
    let bad_values = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, f32::MIN_POSITIVE / 4.0];
    for is in all() {
        for bad in bad_values {
            for slot in 0..9 {
                let mut tri = good;
                tri[slot / 3][slot % 3] = bad;
                let rec = is.precompute(&tri);
                let r = is.intersect(&probe, &rec, f32::INFINITY);
                sane(&is, r, "bad triangle");
                if !bad.is_finite() {
                    assert!(matches!(r, Ok(None) | Err(_)), "{is:?} {tri:?}: {r:?}");
                    if is.format.is_fixed() {
                        assert_ne!(rec.status, RecordStatus::Ok, "{is:?} {tri:?}");
                    }
                }
            }
            for slot in 0..6 {
                let mut ray = probe;
                if slot < 3 {
                    ray.origin[slot] = bad;
                } else {
                    ray.dir[slot - 3] = bad;
                }
                let r = is.intersect_tri(&ray, &good, f32::INFINITY);
                sane(&is, r, "bad ray");
                if !bad.is_finite() {
                    assert_eq!(r, Ok(None), "{is:?} {ray:?}: invalid rays are never tested");
                }
            }
        }
        // Zero direction.
        let zero = Ray { origin: probe.origin, dir: Vec3::ZERO };
        assert_eq!(is.intersect_tri(&zero, &good, f32::INFINITY), Ok(None));
    }
}

/// Random bit patterns (NaN, ±∞, subnormals, huge values) for every coordinate: no panic,
/// no hang, every hit finite and positive.
#[test]
fn random_bit_patterns_never_panic_or_produce_garbage() {
    let mut rng = ChaCha8Rng::seed_from_u64(0xB175);
    let f = |rng: &mut ChaCha8Rng| match rng.gen_range(0..4) {
        0 => f32::from_bits(rng.gen()),
        1 => rng.gen_range(-4.0..4.0),
        2 => rng.gen_range(-1.0..1.0) * 10f32.powi(rng.gen_range(-40..39)),
        _ => [0.0, -0.0, 1.0, -1.0][rng.gen_range(0..4)],
    };
    let cases: Vec<(Ray, [Vec3; 3])> = (0..20_000)
        .map(|_| {
            let mut p = || v(f(&mut rng), f(&mut rng), f(&mut rng));
            (Ray { origin: p(), dir: p() }, [p(), p(), p()])
        })
        .collect();
    for is in all() {
        for (ray, tri) in &cases {
            sane(&is, is.intersect_tri(ray, tri, f32::INFINITY), "random bits");
        }
    }
    for (ray, tri) in cases.iter().take(5_000) {
        let _ = exact::classify(ray, tri);
    }
}

/// The co-processor model rejects non-finite scene data at LOAD and non-finite rays at the
/// request, with clear errors, in every kernel and format; zero-area triangles load (counted
/// as degenerate records by the projection kernels) and never hit.
#[test]
fn coprocessor_rejects_non_finite_data_and_handles_degenerate_triangles() {
    let rec = |a: Vec3, b: Vec3, c: Vec3, prim: u32| TriangleRecord {
        vertices: [a.to_array(), b.to_array(), c.to_array()],
        prim,
        material: 0,
    };
    let image = |tris: &[TriangleRecord]| {
        let mut w = vec![PE_IMAGE_TAG, tris.len() as u32, 1, tris.len() as u32, 0, 0, 0, tris.len() as u32];
        w.extend(0..tris.len() as u32);
        for t in tris {
            w.extend(t.to_words());
        }
        w
    };
    let good = rec(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0), 0);
    let flat = rec(v(0.0, 0.0, 0.5), v(1.0, 1.0, 0.5), v(2.0, 2.0, 0.5), 1);
    let nan = rec(v(0.0, f32::NAN, 0.0), v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0), 2);
    let entry = [ListEntry { voxel: 0, pe: 0, t_exit: 10.0 }];
    for kernel in KernelKind::ALL {
        for format in NumberFormat::ALL {
            let cfg =
                CoprocConfig { pe_count: 1, pe_mem_words: 256, max_list: 8, timing: TimingProfile::GRIDRT, kernel };
            let mut backing = vec![0; cfg.required_backing_words()];
            let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
            cp.set_number_format(format, FixedFrame::for_box([-1.0; 3], [2.0; 3], format).unwrap());
            assert_eq!(cp.load_pe(0, &image(&[good, nan])), Err(FslError::PeImageMalformed), "{kernel:?} {format:?}");
            cp.load_pe(0, &image(&[flat, good])).unwrap();
            if !kernel.uses_image(format) && matches!(kernel, KernelKind::Wald | KernelKind::HanikaKeller) {
                assert_eq!(cp.stats().degenerate_records, 1, "{kernel:?} {format:?}");
            }
            // Straight through the flat triangle's line onto the good one.
            let ray = Ray { origin: v(0.25, 0.25, 1.0), dir: v(0.0, 0.0, -1.0) };
            let r = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &entry).unwrap();
            assert!(r.hit && r.prim == 0 && r.t == 1.0, "{kernel:?} {format:?}: {r:?}");
            for bad in [
                Ray { origin: v(f32::NAN, 0.0, 1.0), dir: v(0.0, 0.0, -1.0) },
                Ray { origin: v(0.0, 0.0, 1.0), dir: v(0.0, f32::INFINITY, -1.0) },
                Ray { origin: v(0.0, 0.0, 1.0), dir: Vec3::ZERO },
            ] {
                assert_eq!(cp.trace(RayKind::Closest, &bad, f32::INFINITY, &entry), Err(FslError::NonFiniteRay));
            }
            assert_eq!(cp.trace(RayKind::Any, &ray, f32::NAN, &entry), Err(FslError::NonFiniteRay));
            assert_eq!(cp.stats().overflows, 0);
            // A ray from far outside the fixed-point frame: every test is reported as an
            // overflow (and the answer is a miss), never a wrapped hit.
            let far = Ray { origin: v(0.25, 0.25, 1.0e15), dir: v(0.0, 0.0, -1.0) };
            let far_entry = [ListEntry { voxel: 0, pe: 0, t_exit: f32::INFINITY }];
            let r = cp.trace(RayKind::Closest, &far, f32::INFINITY, &far_entry).unwrap();
            if format.is_fixed() {
                assert!(!r.hit, "{kernel:?} {format:?}");
                assert_eq!(cp.stats().overflows, 2, "{kernel:?} {format:?}");
            } else {
                assert_eq!(cp.stats().overflows, 0);
            }
        }
    }
}

//! Seeded property tests on the random 2×2×2 scene.

use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// `trace` over the grid equals a brute-force nearest hit over every triangle, for 10⁴ random
/// rays per kernel. Allowed differences: exact ties (same t, another prim) and near-ties
/// within the documented t_exit tolerance (t ≤ t*·(1 + 2⁻¹¹)), which must stay rare.
#[test]
fn trace_equals_brute_force_nearest_hit_on_2x2x2_scene() {
    let scene = GridScene::random(0x2222, 40);
    let map = |id: u32| (id % 4) as u8;
    let images = scene.images(4, map);
    for kernel in KernelKind::ALL {
        let mut backing = Vec::new();
        let mut cp = loaded(CoprocConfig { kernel, ..config(4, 4096) }, &mut backing, &images);
        let mut rng = ChaCha8Rng::seed_from_u64(0xB0B + kernel as u64);
        let (mut hits, mut near_ties) = (0, 0);
        for i in 0..10_000 {
            let (ray, t_max) = random_ray(&mut rng);
            let list = scene.list(&ray, map);
            let r = cp.trace(RayKind::Closest, &ray, t_max, &list).unwrap();
            let u = cp.trace_untimed(RayKind::Closest, &ray, t_max, &list).unwrap();
            assert_eq!(
                (r.hit, r.t.to_bits(), r.prim, r.list_pos, r.pe),
                (u.hit, u.t.to_bits(), u.prim, u.list_pos, u.pe)
            );
            match scene.brute_force(kernel, &ray, t_max) {
                None => assert!(!r.hit, "{kernel:?} ray {i}: spurious hit {r:?}"),
                Some((t, prim)) => {
                    hits += 1;
                    assert!(r.hit, "{kernel:?} ray {i}: missed t={t} prim={prim} ({ray:?}, list {list:?})");
                    assert!(r.t >= t, "{kernel:?} ray {i}: nearer than brute force");
                    if r.prim != prim && r.t != t {
                        assert!(r.t <= t * (1.0 + 2.0 * T_EXIT_REL_TOL), "{kernel:?} ray {i}: t {} vs {t}", r.t);
                        near_ties += 1;
                    }
                    let g = &scene.tris[(r.prim - 1000) as usize];
                    assert_eq!(r.material as u32, g.material);
                    let n = isect::geometric_normal(&g.vertices.map(Vec3::from_array));
                    assert_eq!(r.normal, n.to_array());
                    assert_eq!(r.pe, map(list[r.list_pos as usize].voxel));
                }
            }
        }
        assert!(hits > 3000, "{kernel:?}: too few hits ({hits}) to mean anything");
        assert!(near_ties * 1000 < hits, "{kernel:?}: {near_ties} near-ties in {hits} hits");
    }
}

/// The same voxels mapped to 1, 4 or 8 PEs give the same answers (only `pe` and the
/// timeline differ); the functional test count is the same too.
#[test]
fn answers_are_independent_of_the_pe_count() {
    let scene = GridScene::random(0x4E5, 40);
    type Map = fn(u32) -> u8;
    let maps: [(u8, Map); 3] = [(1, |_| 0), (4, |id| (id % 4) as u8), (8, |id| id as u8)];
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let rays: Vec<_> = (0..2000).map(|_| random_ray(&mut rng)).collect();
    let mut answers: Vec<Vec<_>> = Vec::new();
    for (pes, map) in maps {
        let mut backing = Vec::new();
        let mut cp = loaded(config(pes as u16, 4096), &mut backing, &scene.images(pes, map));
        let a = rays
            .iter()
            .map(|(ray, t_max)| {
                let list = scene.list(ray, map);
                let r = cp.trace(RayKind::Closest, ray, *t_max, &list).unwrap();
                let u = cp.trace_untimed(RayKind::Closest, ray, *t_max, &list).unwrap();
                let any = cp.trace(RayKind::Any, ray, *t_max, &list).unwrap();
                (
                    r.hit,
                    r.t.to_bits(),
                    r.prim,
                    r.material,
                    r.normal.map(f32::to_bits),
                    r.list_pos,
                    u.tests,
                    any.hit,
                    any.prim,
                )
            })
            .collect();
        answers.push(a);
    }
    assert_eq!(answers[0], answers[1]);
    assert_eq!(answers[0], answers[2]);
}

/// The same equivalence for every kernel in every fixed-point format, with the frame of the
/// grid box [0, 2]³; no test of this scene may overflow (the frame keeps it in range).
#[test]
fn trace_equals_brute_force_in_every_fixed_point_format() {
    let scene = GridScene::random(0x2223, 40);
    let map = |id: u32| (id % 4) as u8;
    let images = scene.images(4, map);
    for format in [NumberFormat::Fixed64Q23, NumberFormat::Fixed32Q16] {
        let frame = FixedFrame::for_box([0.0; 3], [2.0; 3], format).unwrap();
        for kernel in KernelKind::ALL {
            let cfg = CoprocConfig { kernel, ..config(4, 4096) };
            let mut backing = vec![0; cfg.required_backing_words()];
            let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
            cp.set_number_format(format, frame);
            for (pe, img) in images.iter().enumerate() {
                cp.load_pe(pe as u8, img).unwrap();
            }
            let is = Intersector::new(kernel, format, frame);
            let mut rng = ChaCha8Rng::seed_from_u64(0xF1C5 + kernel as u64);
            let (mut hits, mut near_ties) = (0, 0);
            for i in 0..3_000 {
                let (ray, t_max) = random_ray(&mut rng);
                let list = scene.list(&ray, map);
                let r = cp.trace(RayKind::Closest, &ray, t_max, &list).unwrap();
                let (u, info) = cp.trace_untimed_with_info(RayKind::Closest, &ray, t_max, &list).unwrap();
                assert_eq!((r.hit, r.t.to_bits(), r.prim), (u.hit, u.t.to_bits(), u.prim));
                assert_eq!(info.overflows, 0);
                match scene.brute_force_with(&is, &ray, t_max) {
                    None => assert!(!r.hit, "{kernel:?} {format:?} ray {i}: spurious hit {r:?}"),
                    Some((t, prim)) => {
                        hits += 1;
                        assert!(r.hit, "{kernel:?} {format:?} ray {i}: missed t={t} prim={prim}");
                        assert!(r.t >= t, "{kernel:?} {format:?} ray {i}: nearer than brute force");
                        if r.prim != prim && r.t != t {
                            assert!(r.t <= t * (1.0 + 2.0 * T_EXIT_REL_TOL), "{kernel:?} {format:?} ray {i}");
                            near_ties += 1;
                        }
                    }
                }
            }
            assert_eq!(cp.stats().overflows, 0, "{kernel:?} {format:?}");
            assert!(hits > 800, "{kernel:?} {format:?}: {hits}");
            assert!(near_ties * 100 < hits, "{kernel:?} {format:?}: {near_ties} near-ties in {hits}");
        }
    }
}

/// The record table is charged against PE memory: an image that fits for the f32
/// watertight kernel (which reads the image itself) fails to load for a kernel that needs a
/// table unless the table fits too, and `pe_words_needed` says exactly how much is needed.
#[test]
fn record_tables_are_charged_against_pe_memory() {
    let scene = GridScene::random(0x7AB, 30);
    let images = scene.images(1, |_| 0);
    let img = &images[0];
    let tris = img[1] as usize; // word 0 is the tag, word 1 the triangle count
    for kernel in KernelKind::ALL {
        for format in NumberFormat::ALL {
            let need = kernel.pe_words_needed(format, img.len(), tris);
            let frame = FixedFrame::for_box([0.0; 3], [2.0; 3], format).unwrap();
            for (words, ok) in [(need, true), (need - 1, false)] {
                if words < img.len() {
                    continue;
                }
                let cfg = CoprocConfig { kernel, ..config(1, words as u32) };
                let mut backing = vec![0; cfg.required_backing_words()];
                let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
                cp.set_number_format(format, frame);
                let r = cp.load_pe(0, img);
                assert_eq!(r.is_ok(), ok, "{kernel:?} {format:?} with {words} words: {r:?}");
                if !ok {
                    assert_eq!(r, Err(FslError::PeMemoryOverflow));
                    assert!(!cp.is_pe_loaded(0));
                }
            }
        }
    }
}

/// A list sent in two parts answers as the whole list (what the firmware relies on when it
/// sends a camera ray's first entries, then the rest after a miss, SPEC.md §4.3): for every
/// split point, a first part that hits gives the whole list's hit (same t, prim, normal,
/// material and entry), and one that misses leaves the same answer to the rest (its entry
/// shifted by the split). RAY_ANY: a hit in either part exactly when the whole list has one.
#[test]
fn a_list_split_in_two_answers_as_the_whole_list() {
    let scene = GridScene::random(0x5B11, 40);
    let map = |id: u32| (id % 4) as u8;
    let images = scene.images(4, map);
    for kernel in KernelKind::ALL {
        let mut backing = Vec::new();
        let mut cp = loaded(CoprocConfig { kernel, ..config(4, 4096) }, &mut backing, &images);
        let mut rng = ChaCha8Rng::seed_from_u64(0x5B12 + kernel as u64);
        let (mut first_hits, mut rest_hits) = (0, 0);
        for _ in 0..4000 {
            let (ray, t_max) = random_ray(&mut rng);
            let list = scene.list(&ray, map);
            let key = |r: &RayResult| (r.hit, r.t.to_bits(), r.prim, r.material, r.normal.map(f32::to_bits));
            let whole = cp.trace(RayKind::Closest, &ray, t_max, &list).unwrap();
            let any = cp.trace(RayKind::Any, &ray, t_max, &list).unwrap().hit;
            for k in 0..=list.len() {
                let (head, tail) = list.split_at(k);
                let first = cp.trace(RayKind::Closest, &ray, t_max, head).unwrap();
                let (r, pos) = if first.hit {
                    first_hits += 1;
                    (first, first.list_pos)
                } else {
                    let rest = cp.trace(RayKind::Closest, &ray, t_max, tail).unwrap();
                    rest_hits += usize::from(rest.hit);
                    (rest, rest.list_pos + k as u16 * u16::from(rest.hit))
                };
                assert_eq!(key(&r), key(&whole), "{kernel:?}: split at {k} of {list:?}, {ray:?}");
                assert_eq!(pos, whole.list_pos, "{kernel:?}: entry, split at {k}");
                let any_parts = cp.trace(RayKind::Any, &ray, t_max, head).unwrap().hit
                    || cp.trace(RayKind::Any, &ray, t_max, tail).unwrap().hit;
                assert_eq!(any_parts, any, "{kernel:?}: RAY_ANY, split at {k}");
            }
        }
        assert!(first_hits > 1000 && rest_hits > 1000, "{kernel:?}: {first_hits} {rest_hits}");
    }
}

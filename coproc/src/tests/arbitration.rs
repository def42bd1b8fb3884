//! List-order arbitration: GridRT's flaw fixed, RAY_ANY, ties.

use super::*;

/// Two unit voxels along x: voxel 0 = [0,1]×[0,1]², voxel 1 = [1,2]×[0,1]², on PEs 0 and 1.
/// A big slanted triangle spans both (bbox x ∈ [0.9, 1.9]) but the ray meets it at x = 1.7,
/// inside voxel 1; a small triangle only in voxel 1 is met at x = 1.2, nearer.
fn flaw_scene() -> (Vec<Vec<u32>>, Ray, Vec<ListEntry>) {
    let big = tri(v(0.9, 0.9, 0.0), v(0.9, 0.9, 1.0), v(1.9, 0.4, 0.5), 7, 1);
    let small = tri(v(1.2, 0.3, 0.3), v(1.2, 0.7, 0.3), v(1.2, 0.5, 0.8), 8, 2);
    // PE 0 holds voxel 0 = {big}; PE 1 holds voxel 1 = {big, small}.
    let img0 = image(&[(0, vec![0])], &[big]);
    let img1 = image(&[(1, vec![0, 1])], &[big, small]);
    let ray = Ray { origin: v(-0.5, 0.5, 0.5), dir: v(1.0, 0.0, 0.0) };
    let list = vec![entry(0, 0, 1.5), entry(1, 1, 2.5)];
    (vec![img0, img1], ray, list)
}

/// GridRT's flaw is fixed: the big triangle's hit (t = 2.2) lies beyond voxel
/// 0's exit (t = 1.5), so voxel 0 does not accept it and the nearer small triangle in voxel 1
/// (t = 1.7) wins. Under GridRT's original rule ("first PE with any hit") voxel 0 would win
/// with the far hit — the wrong answer.
#[test]
fn closer_hit_in_later_voxel_beats_spanning_triangle_hit_beyond_voxel_exit() {
    let (images, ray, list) = flaw_scene();
    for kernel in KernelKind::ALL {
        let mut backing = Vec::new();
        let mut cp = loaded(CoprocConfig { kernel, ..config(2, 256) }, &mut backing, &images);
        let fixed = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &list).unwrap();
        assert!(fixed.hit);
        assert_eq!((fixed.prim, fixed.pe, fixed.list_pos, fixed.material), (8, 1, 1, 2), "{kernel:?}");
        assert!((fixed.t - 1.7).abs() < 1e-5);

        cp.set_arbitration(ArbitrationRule::GridRtOriginal);
        let naive = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &list).unwrap();
        assert_eq!(
            (naive.prim, naive.pe, naive.list_pos),
            (7, 0, 0),
            "{kernel:?}: GridRT's rule picks the far triangle"
        );
        assert!((naive.t - 2.2).abs() < 1e-5);
    }
}

/// A hit exactly on the exit face (t = t_exit) and one rounded just past it (within 2⁻¹²
/// relative) are still accepted by the earlier voxel; one clearly past it is not.
#[test]
fn hit_on_voxel_exit_face_is_accepted_within_relative_tolerance() {
    let img = image(&[(0, vec![0])], &[hit_tri(1.0, 3)]); // hit at t = 2
    let mut backing = Vec::new();
    let mut cp = loaded(config(1, 256), &mut backing, &[img]);
    let ray = probe_ray();
    for (t_exit, accepted) in [(2.0, true), (2.0 * (1.0 - 1.0 / 8192.0), true), (2.0 * (1.0 - 1.0 / 1024.0), false)] {
        let r = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &[entry(0, 0, t_exit)]).unwrap();
        assert_eq!(r.hit, accepted, "t_exit {t_exit}");
    }
    // t_max is exclusive: a hit at exactly t_max is not reported (shadow rays to a light).
    let r = cp.trace(RayKind::Any, &ray, 2.0, &[entry(0, 0, 10.0)]).unwrap();
    assert!(!r.hit);
}

/// RAY_ANY returns the first accepted hit in reference order and stops testing; RAY_CLOSEST
/// tests every triangle of the entry and returns the nearest.
#[test]
fn ray_any_stops_at_first_accepted_hit() {
    // refs in order: a miss, a far hit (t = 4), a near hit (t = 2), another miss.
    let tris = [miss_tri(0.5, 1), hit_tri(3.0, 2), hit_tri(1.0, 3), miss_tri(0.2, 4)];
    let img0 = image(&[(0, vec![0, 1, 2, 3])], &tris);
    let img1 = image(&[(5, vec![0])], &[hit_tri(0.5, 9)]);
    let mut backing = Vec::new();
    let mut cp = loaded(config(2, 256), &mut backing, &[img0, img1]);
    let ray = probe_ray();
    let list = [entry(0, 0, 100.0)];
    let any = cp.trace(RayKind::Any, &ray, f32::INFINITY, &list).unwrap();
    assert_eq!((any.hit, any.prim, any.t, any.tests), (true, 2, 4.0, 2));
    let closest = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &list).unwrap();
    assert_eq!((closest.hit, closest.prim, closest.t, closest.tests), (true, 3, 2.0, 4));
    let untimed = cp.trace_untimed(RayKind::Any, &ray, f32::INFINITY, &list).unwrap();
    assert_eq!((untimed.prim, untimed.tests), (2, 2));

    // Across entries, list order decides for RAY_ANY too: entry 0 (PE 1) hits first in the
    // list although entry 1's PE would find its hit at the same time.
    let two = [entry(5, 1, 100.0), entry(0, 0, 100.0)];
    let any = cp.trace(RayKind::Any, &ray, f32::INFINITY, &two).unwrap();
    assert_eq!((any.prim, any.pe, any.list_pos), (9, 1, 0));
    // A t_max below every hit: no hit, every test performed.
    let none = cp.trace(RayKind::Any, &ray, 1.5, &list).unwrap();
    assert_eq!((none.hit, none.tests), (false, 4));
    assert_eq!(RayResult { tests: 0, cycles: 0, ..none }, RayResult::MISS);
}

/// Equal t within an entry: the lowest prim id wins, whatever the reference order.
#[test]
fn equal_t_within_entry_resolves_to_lowest_prim_id() {
    let tris = [hit_tri(1.0, 30), hit_tri(1.0, 10), hit_tri(1.0, 20)];
    let img = image(&[(0, vec![0, 1, 2])], &tris);
    let mut backing = Vec::new();
    let mut cp = loaded(config(1, 256), &mut backing, &[img]);
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 10.0)]).unwrap();
    assert_eq!((r.prim, r.t), (10, 2.0));
    // Geometric normal (b − a) × (c − a) = (2,0,0) × (0,2,0) = (0,0,4), not normalised.
    assert_eq!(r.normal, [0.0, 0.0, 4.0]);
    assert_eq!(r.material, 10 % 7);
}

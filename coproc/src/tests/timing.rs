//! Cycle accounting of whole rays against the timing profiles.

use super::*;

/// One voxel per PE: PE p holds voxel p with `n[p]` triangles; the hit flags say whether
/// its last triangle is hit by `probe_ray` (at t = 2 + p) — the rest are misses.
fn per_pe_scene(n: &[usize], hit: &[bool]) -> Vec<Vec<u32>> {
    n.iter()
        .zip(hit)
        .enumerate()
        .map(|(p, (&n, &h))| {
            let tris: Vec<_> = (0..n)
                .map(|i| {
                    if h && i + 1 == n {
                        hit_tri(1.0 + p as f32, 100 + p as u32)
                    } else {
                        miss_tri(i as f32, i as u32)
                    }
                })
                .collect();
            image(&[(p as u32, (0..n as u32).collect())], &tris)
        })
        .collect()
}

fn cfg(pes: u16, timing: TimingProfile) -> CoprocConfig {
    CoprocConfig { timing, ..config(pes, 16_384) }
}

/// Thesis §6.3.2: 648 cycles per intersection; 50 MHz / 648 ≈ 77 k tests/s per PE and
/// ≈ 308.6 k for 4 PEs. N tests on one PE cost N·648 plus a fixed overhead (request and
/// result words, one voxel setup, arbitration) that we subtract; 4 PEs with N tests each take
/// the same time as one, i.e. 4× the throughput.
#[test]
fn gridrt_profile_reproduces_648_cycles_per_test_and_308k_tests_per_s_for_4_pes_at_50mhz() {
    let p = TimingProfile::GRIDRT;
    let ray = probe_ray();
    for n in [0usize, 1, 7, 100] {
        let mut backing = Vec::new();
        let mut cp = loaded(cfg(1, p), &mut backing, &per_pe_scene(&[n], &[false]));
        let r = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
        let fixed = p.ray_io_cycles(1) + p.voxel_setup_cycles as u64;
        assert_eq!(fixed, 10 + 8 + 4 + 70);
        assert_eq!((r.hit, r.tests as usize), (false, n));
        assert_eq!(r.cycles as u64 - fixed, 648 * n as u64, "n = {n}");
    }
    let n = 100;
    let mut backing = Vec::new();
    let mut cp = loaded(cfg(4, p), &mut backing, &per_pe_scene(&[n; 4], &[false; 4]));
    let list: Vec<_> = (0..4).map(|pe| entry(pe, pe as u8, 50.0)).collect();
    let r = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &list).unwrap();
    let fixed = p.ray_io_cycles(4) + p.voxel_setup_cycles as u64;
    assert_eq!(r.tests as usize, 4 * n);
    assert_eq!(r.cycles as u64 - fixed, 648 * n as u64);
    let rate = r.tests as f64 * p.clock_hz as f64 / (r.cycles as u64 - fixed) as f64;
    assert!((rate - 308_641.975).abs() < 0.01, "{rate}");
    assert!((p.tests_per_second(4) - rate).abs() < 0.01);
    assert!((p.tests_per_second(1) - 77_160.49).abs() < 0.01);
    assert_eq!(cp.stats().tests, 4 * n as u64);
}

/// The pipelined PE issues a test per cycle and pays its fill latency once per entry.
#[test]
fn pipelined_profile_costs_one_cycle_per_test_after_fill_latency() {
    let p = TimingProfile::PIPELINED;
    for n in [1usize, 10, 1000] {
        let mut backing = Vec::new();
        let mut cp = loaded(cfg(1, p), &mut backing, &per_pe_scene(&[n], &[false]));
        let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
        let fixed = p.ray_io_cycles(1) + p.voxel_setup_cycles as u64 + p.test_latency_cycles as u64;
        assert_eq!(r.cycles as u64 - fixed, n as u64);
    }
}

/// The winner suspends the PEs after it: they are charged only the tests they had started.
#[test]
fn winner_suspends_later_pes_which_are_charged_only_started_tests() {
    let p = TimingProfile::GRIDRT;
    let mut backing = Vec::new();
    // PE 0: 2 triangles, the 2nd hit; PE 1: 10 misses.
    let mut cp = loaded(cfg(2, p), &mut backing, &per_pe_scene(&[2, 10], &[true, false]));
    let list = [entry(0, 0, 50.0), entry(1, 1, 60.0)];
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((r.hit, r.pe, r.list_pos), (true, 0, 0));
    // T = 70 + 2·648; PE 1 had started tests at 70 and 718 by then.
    assert_eq!(r.cycles as u64, p.ray_io_cycles(2) + 70 + 2 * 648);
    assert_eq!(r.tests, 2 + 2);
    // The untimed path reports the tests it actually ran: the winner's entry only.
    assert_eq!(cp.trace_untimed(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap().tests, 2);
}

/// A hit in a later entry must wait for "done" from every PE before it.
#[test]
fn later_winner_waits_for_done_from_earlier_pes() {
    let p = TimingProfile::GRIDRT;
    let mut backing = Vec::new();
    let mut cp = loaded(cfg(2, p), &mut backing, &per_pe_scene(&[10, 2], &[false, true]));
    let list = [entry(0, 0, 50.0), entry(1, 1, 60.0)];
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((r.hit, r.pe, r.list_pos, r.t), (true, 1, 1, 3.0));
    assert_eq!(r.cycles as u64, p.ray_io_cycles(2) + 70 + 10 * 648);
    assert_eq!(r.tests, 12);
}

/// Entries of one PE run back to back; RAY_ANY stops its entry at the first accepted hit.
#[test]
fn entries_on_one_pe_run_sequentially_and_any_stops_early() {
    let p = TimingProfile::GRIDRT;
    let tris =
        [miss_tri(0.0, 0), miss_tri(1.0, 1), miss_tri(2.0, 2), hit_tri(1.0, 3), hit_tri(0.5, 4), miss_tri(3.0, 5)];
    let img = image(&[(0, vec![0, 1, 2]), (1, vec![3, 4, 5])], &tris);
    let mut backing = Vec::new();
    let mut cp = loaded(cfg(1, p), &mut backing, &[img]);
    let list = [entry(0, 0, 50.0), entry(1, 0, 60.0)];
    let c = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((c.prim, c.tests), (4, 6));
    assert_eq!(c.cycles as u64, p.ray_io_cycles(2) + 2 * 70 + 6 * 648);
    let a = cp.trace(RayKind::Any, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((a.prim, a.tests), (3, 4));
    assert_eq!(a.cycles as u64, p.ray_io_cycles(2) + 2 * 70 + 4 * 648);
}

/// Counters saturate in the result words instead of wrapping.
#[test]
fn result_tests_saturate_at_u16_max() {
    let n = 70_000;
    // One triangle referenced 70 000 times.
    let img = image(&[(0, vec![0; n as usize])], &[miss_tri(0.0, 0)]);
    let cfg = CoprocConfig { timing: TimingProfile::PIPELINED, ..config(1, 80_000) };
    let mut backing = Vec::new();
    let mut cp = loaded(cfg, &mut backing, &[img]);
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
    assert_eq!(r.tests, u16::MAX);
    assert_eq!(cp.stats().tests, n as u64);
}

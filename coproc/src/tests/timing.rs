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

/// A profile whose numbers are unlike GridRT's, so the timeline arithmetic is checked against
/// cycle counts worked out by hand rather than against the constants it is built from.
const ODD: TimingProfile = TimingProfile {
    name: "odd",
    clock_hz: 1_000_000,
    test_issue_cycles: 37,
    test_latency_cycles: 5,
    voxel_setup_cycles: 11,
    word_in_cycles: 2,
    word_out_cycles: 3,
    arbitration_cycles: 7,
    ray_setup_cycles: 13,
};

/// Ray I/O of ODD by hand: (8 header + 2 per entry) words in × 2, ray setup 13, arbitration 7,
/// 8 result words out × 3.
fn odd_io(entries: u64) -> u64 {
    (8 + 2 * entries) * 2 + 13 + 7 + 8 * 3
}

/// One PE, one entry of n misses: I/O + setup 11 + n × 37 + latency 5 (the latency only when
/// a test ran).
#[test]
fn timeline_charges_setup_issue_and_latency_per_entry_as_worked_out_by_hand() {
    assert_eq!(odd_io(1), 64);
    for (n, cycles) in [(0usize, 64u64 + 11), (1, 64 + 11 + 37 + 5), (3, 64 + 11 + 111 + 5), (40, 64 + 11 + 1480 + 5)] {
        let mut backing = Vec::new();
        let mut cp = loaded(cfg(1, ODD), &mut backing, &per_pe_scene(&[n], &[false]));
        let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
        assert_eq!((r.hit, r.tests as usize, r.cycles as u64), (false, n, cycles), "n = {n}");
    }
}

/// Two PEs under ODD: a winner in the first entry ends the ray when its entry is done
/// (11 + 2·37 + 5 = 90); PE 1 had issued its tests at 11, 48 and 85 by then. A winner in the
/// second entry waits for PE 0's ten misses (11 + 370 + 5 = 386).
#[test]
fn winner_timing_under_another_profile_matches_the_hand_count() {
    let list = [entry(0, 0, 50.0), entry(1, 1, 60.0)];
    let mut backing = Vec::new();
    let mut cp = loaded(cfg(2, ODD), &mut backing, &per_pe_scene(&[2, 10], &[true, false]));
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((r.hit, r.pe, r.tests, r.cycles as u64), (true, 0, 2 + 3, odd_io(2) + 90));
    assert_eq!(odd_io(2), 68);

    let mut backing = Vec::new();
    let mut cp = loaded(cfg(2, ODD), &mut backing, &per_pe_scene(&[10, 2], &[false, true]));
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((r.hit, r.pe, r.tests, r.cycles as u64), (true, 1, 12, 68 + 386));
}

/// Four PEs with n misses each take the time one PE takes for n: the tests run in parallel.
#[test]
fn four_pes_run_their_entries_in_parallel() {
    let n = 25;
    let mut backing = Vec::new();
    let mut cp = loaded(cfg(4, ODD), &mut backing, &per_pe_scene(&[n; 4], &[false; 4]));
    let list: Vec<_> = (0..4).map(|pe| entry(pe, pe as u8, 50.0)).collect();
    let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &list).unwrap();
    // I/O (8 + 8)·2 + 13 + 7 + 24 = 76; each PE: 11 + 25·37 + 5 = 941.
    assert_eq!((r.tests as usize, r.cycles as u64), (4 * n, 76 + 941));
    assert_eq!(cp.stats().tests, 4 * n as u64);
}

/// The GridRT profile charges the thesis's 648 cycles per test (the constant it is set to),
/// on top of request/result words, one voxel setup of 70 and the arbitration of 4.
#[test]
fn gridrt_profile_charges_648_cycles_per_test() {
    for n in [0usize, 1, 7] {
        let mut backing = Vec::new();
        let mut cp = loaded(cfg(1, TimingProfile::GRIDRT), &mut backing, &per_pe_scene(&[n], &[false]));
        let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
        assert_eq!(r.cycles as u64, 10 + 4 + 8 + 70 + 648 * n as u64, "n = {n}");
    }
}

/// docs/bench-accuracy.md, "model cycles/test": the per-kernel cost model's figures, by hand
/// from each kernel's op count. A change of an op count or an op cost shows up here first.
#[test]
fn kernel_cycle_model_gives_the_documented_cycles_per_test() {
    use NumberFormat::{Fixed32Q16, Fixed64Q23, F32};
    let documented = [
        (KernelKind::Watertight, [(F32, 1188), (Fixed64Q23, 618), (Fixed32Q16, 490)]),
        (KernelKind::MollerTrumbore, [(F32, 675), (Fixed64Q23, 697), (Fixed32Q16, 533)]),
        (KernelKind::Wald, [(F32, 399), (Fixed64Q23, 462), (Fixed32Q16, 366)]),
        (KernelKind::HanikaKeller, [(F32, 399), (Fixed64Q23, 462), (Fixed32Q16, 366)]),
        (KernelKind::Cramer, [(F32, 859), (Fixed64Q23, 690), (Fixed32Q16, 527)]),
    ];
    let mut wrong = Vec::new();
    for (kind, rows) in documented {
        for (format, cycles) in rows {
            let model = crate::timing::test_cycles(kind, format);
            let issue = TimingProfile::GRIDRT.for_kernel(kind, format).test_issue_cycles;
            if libm::round(model) as u32 != cycles || issue != cycles {
                wrong.push(format!("{kind:?} {format:?}: documented {cycles}, model {model:.2}, profile {issue}"));
            }
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
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

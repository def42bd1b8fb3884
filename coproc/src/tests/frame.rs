//! FRAME (SPEC §4.6), the fixed-point frame rule, and what the RTL's kernel/format pair
//! (watertight, fixed64-q23) changes in the model: the 10-word record, the refusal of analytic
//! primitives, the `rtl` timing profile and the RAY_ANY timeline of a pipelined PE.

use super::*;
use gridrt_shared::fsl::frame_packet;
use gridrt_shared::scene::{PrimKind, PrimRecord};

fn fixed(pes: u16, words: u32) -> CoprocConfig {
    CoprocConfig { kernel: KernelKind::Watertight, ..config(pes, words) }
}

fn with_format<'m>(cfg: CoprocConfig, backing: &'m mut Vec<u32>, format: NumberFormat) -> Coprocessor<'m> {
    backing.clear();
    backing.resize(cfg.required_backing_words(), 0);
    let mut cp = Coprocessor::new(cfg, backing).unwrap();
    cp.set_number_format(format, FixedFrame::IDENTITY);
    cp
}

fn one_triangle() -> Vec<u32> {
    image(&[(0, vec![0])], &[hit_tri(0.5, 9)])
}

/// §4.6 worked example: FRAME of (−1, 0, 0.5)..(1, 2, 4.5) → ACK `95000000`; the frame is
/// `for_box` of the box (extent 4 → scale 4 in Q23's 16-unit box); every PE is empty after.
#[test]
fn frame_packet_sets_the_frame_and_empties_every_pe() {
    let mut backing = Vec::new();
    let mut cp = with_format(fixed(2, 256), &mut backing, NumberFormat::Fixed64Q23);
    cp.load_pe(0, &one_triangle()).unwrap();
    push_all(&mut cp, &framed(&frame_packet([-1.0, 0.0, 0.5], [1.0, 2.0, 4.5])));
    assert_eq!(drain(&mut cp), vec![FslWord::last(FRAME_ACK)]);
    assert_eq!(FRAME_ACK, 0x9500_0000);
    assert_eq!(cp.fixed_frame(), FixedFrame { origin: [-1.0, 0.0, 0.5], scale: 4.0 });
    assert!(!cp.is_pe_loaded(0));
    // An f32 co-processor acknowledges FRAME too (its frame is unused) and empties its PEs.
    let mut backing = Vec::new();
    let mut cp = with_format(config(1, 256), &mut backing, NumberFormat::F32);
    cp.load_pe(0, &one_triangle()).unwrap();
    push_all(&mut cp, &framed(&frame_packet([0.0; 3], [1.0; 3])));
    assert_eq!(drain(&mut cp), vec![FslWord::last(FRAME_ACK)]);
    assert!(!cp.is_pe_loaded(0));
}

/// FRAME's checks: the first non-finite word (its index), an inverted axis (4 + axis), then
/// framing; a refused FRAME changes nothing.
#[test]
fn frame_packet_errors_name_the_word_and_change_nothing() {
    let good = framed(&frame_packet([0.0; 3], [1.0; 3]));
    let mut cases: Vec<(Vec<FslWord>, FslError, u16)> = Vec::new();
    for i in 1..7 {
        let mut p = good.clone();
        p[i].data = if i % 2 == 0 { f32::NAN.to_bits() } else { f32::NEG_INFINITY.to_bits() };
        cases.push((p, FslError::BadFrame, i as u16));
    }
    for a in 0..3 {
        let mut p = good.clone();
        p[4 + a].data = (-0.5f32).to_bits();
        cases.push((p, FslError::BadFrame, 4 + a as u16));
    }
    let mut p = good.clone();
    p[1].data = f32::NAN.to_bits();
    p[5].data = (-1.0f32).to_bits();
    cases.push((p, FslError::BadFrame, 1));
    for cut in 0..6 {
        let mut p = good[..=cut].to_vec();
        p[cut].control = true;
        cases.push((p, FslError::PacketTooShort, cut as u16));
    }
    let mut p = good.clone();
    p[6].control = false;
    p.push(FslWord::last(0));
    cases.push((p, FslError::MissingControl, 6));
    for (words, err, detail) in cases {
        let mut backing = Vec::new();
        let mut cp = with_format(fixed(1, 256), &mut backing, NumberFormat::Fixed64Q23);
        cp.load_pe(0, &one_triangle()).unwrap();
        push_all(&mut cp, &words);
        assert_eq!(drain(&mut cp), vec![FslWord::last(err.to_word(detail))], "{words:08x?}");
        assert!(!cp.in_packet());
        assert!(cp.is_pe_loaded(0), "a refused FRAME leaves the PEs alone");
        assert_eq!(cp.fixed_frame(), FixedFrame::IDENTITY);
    }
    // The direct API refuses the same boxes.
    let mut backing = Vec::new();
    let mut cp = with_format(fixed(1, 256), &mut backing, NumberFormat::Fixed64Q23);
    assert_eq!(cp.set_frame_box([0.0; 3], [1.0, -1.0, 1.0]), Err(FslError::BadFrame));
    assert_eq!(cp.set_frame_box([0.0; 3], [1.0, 1.0, f32::INFINITY]), Err(FslError::BadFrame));
}

/// The frame's extent is the largest fl32(max − min): s = log2(units) − ⌈log2 extent⌉, so an
/// extent that rounds to a power of two in f32 gets the larger scale; 0 for a zero extent and
/// 2^-124 for an infinite one (Q23's 16 units).
#[test]
fn frame_scale_follows_the_f32_extent() {
    let q23 = NumberFormat::Fixed64Q23;
    let scale = |min: [f32; 3], max: [f32; 3]| FixedFrame::for_box(min, max, q23).unwrap().scale;
    assert_eq!(scale([0.0; 3], [4.0, 1.0, 1.0]), 4.0);
    assert_eq!(scale([0.0; 3], [4.5, 1.0, 1.0]), 2.0);
    // 2^24 + 1 − 1: exact 2^24, stays a power of two.
    assert_eq!(scale([1.0, 0.0, 0.0], [16_777_216.0, 0.0, 0.0]), libm::ldexp(1.0, 4 - 24));
    // 1e-30 apart around 1: fl32(max − min) is the spacing of f32 at 1, 2^-23 (f64 would see 1e-30).
    let one_up = f32::from_bits(1.0f32.to_bits() + 1);
    assert_eq!(scale([1.0, 0.0, 0.0], [one_up, 0.0, 0.0]), libm::ldexp(1.0, 4 + 23));
    assert_eq!(scale([0.0; 3], [f32::from_bits(3), 0.0, 0.0]), libm::ldexp(1.0, 4 + 149 - 2));
    assert_eq!(scale([0.0; 3], [0.0; 3]), 1.0);
    assert_eq!(scale([-f32::MAX, 0.0, 0.0], [f32::MAX, 0.0, 0.0]), libm::ldexp(1.0, 4 - 128));
    assert_eq!(FixedFrame::for_box([0.0; 3], [8.0; 3], NumberFormat::Fixed32Q16).unwrap().scale, 0.5);
}

/// The RTL's kernel does not test analytic primitives: an image holding one is refused with
/// `Unsupported` (after the image checks, before the memory check), and the f32 kernel takes it.
#[test]
fn analytic_primitives_are_refused_by_the_rtl_kernel_only() {
    let sphere = PrimRecord { kind: PrimKind::Sphere, prim: 1, material: 0, world_to_object: [0.0; 12] };
    let mut img = image(&[(0, vec![0, 1])], &[hit_tri(0.5, 0)]);
    img[4] = 1; // P = 1
    img.extend(sphere.to_words());
    let mut backing = Vec::new();
    let mut cp = with_format(fixed(2, 256), &mut backing, NumberFormat::Fixed64Q23);
    push_all(&mut cp, &load_packet(1, &img));
    assert_eq!(drain(&mut cp), vec![FslWord::last(FslError::Unsupported.to_word(1))]);
    assert!(!cp.is_pe_loaded(1));
    let mut bad = img.clone();
    bad[0] = 0;
    push_all(&mut cp, &load_packet(1, &bad));
    assert_eq!(drain(&mut cp), vec![FslWord::last(FslError::PeImageMalformed.to_word(1))]);
    let mut backing = Vec::new();
    let mut cp = with_format(config(2, 256), &mut backing, NumberFormat::F32);
    push_all(&mut cp, &load_packet(1, &img));
    assert_eq!(drain(&mut cp), vec![FslWord::last(load_ack(1))]);
}

/// Its record is 10 words (the 9 coordinates and a copy of the prim id): an image fits when
/// image + 10·T ≤ pe_mem_words, exactly.
#[test]
fn rtl_kernel_records_take_ten_words_per_triangle() {
    let tris: Vec<_> = (0..3).map(|i| hit_tri(0.5 + i as f32, i)).collect();
    let img = image(&[(0, vec![0, 1, 2])], &tris);
    let need = img.len() + 30;
    assert_eq!(KernelKind::Watertight.pe_words_needed(NumberFormat::Fixed64Q23, img.len(), 3), need);
    for (words, ok) in [(need, true), (need - 1, false)] {
        let mut backing = Vec::new();
        let mut cp = with_format(fixed(1, words as u32), &mut backing, NumberFormat::Fixed64Q23);
        assert_eq!(cp.load_pe(0, &img).is_ok(), ok, "{words} words");
    }
}

/// The `rtl` profiles (rtl/README.md §4.5): one entry of n tests costs the request and result
/// words, 25 ray setup, max(2, s) voxel setup, n issues s cycles apart (s PEs share a
/// pipeline), the latency of 66 + s cycles and 8 arbitration.
#[test]
fn rtl_profile_costs_setup_issue_latency_and_arbitration() {
    for s in 1..=4u64 {
        let p = TimingProfile::rtl(s as u32);
        assert_eq!(p.ray_io_cycles(1), 10 + 25 + 8 + 8);
        for n in [1usize, 3, 100] {
            let tris: Vec<_> = (0..n).map(|i| miss_tri(i as f32, i as u32)).collect();
            let img = image(&[(0, (0..n as u32).collect())], &tris);
            let mut backing = Vec::new();
            let cfg = CoprocConfig { timing: p, ..config(1, 16_384) };
            let mut cp = loaded(cfg, &mut backing, &[img]);
            let r = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &[entry(0, 0, 50.0)]).unwrap();
            let cycles = 51 + s.max(2) + s * n as u64 + 66 + s;
            assert_eq!((r.tests as usize, r.cycles as u64), (n, cycles), "s = {s}, n = {n}");
        }
    }
}

/// RAY_ANY on a pipelined PE: the winner is done when its accepted test's result is known,
/// and the PE had kept issuing — the rest of the winning entry, then the next entry — until
/// then, so those tests count. PIPELINED: setup 8, latency 33; entry 0 (3 tests, the first
/// accepted) issues at 8, 9, 10 and is done at 8 + 1 + 33 = 42; entry 1 on the same PE
/// (2 tests) issues at 19, 20.
#[test]
fn ray_any_winner_is_done_when_its_first_accepted_test_is_known() {
    let p = TimingProfile::PIPELINED;
    let tris = [hit_tri(0.5, 0), miss_tri(0.0, 1), miss_tri(1.0, 2), miss_tri(2.0, 3), miss_tri(3.0, 4)];
    let img = image(&[(0, vec![0, 1, 2]), (1, vec![3, 4])], &tris);
    let mut backing = Vec::new();
    let cfg = CoprocConfig { timing: p, ..config(1, 4096) };
    let mut cp = loaded(cfg, &mut backing, &[img]);
    let list = [entry(0, 0, 50.0), entry(1, 0, 60.0)];
    let r = cp.trace(RayKind::Any, &probe_ray(), f32::INFINITY, &list).unwrap();
    assert_eq!((r.hit, r.prim, r.list_pos), (true, 0, 0));
    assert_eq!((r.tests, r.cycles as u64), (5, p.ray_io_cycles(2) + 42));
}

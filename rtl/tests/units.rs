//! The datapath blocks against their Rust twins, vector by vector (rtl/tb/gridrt_units_top.sv):
//! IEEE-754 add/sub and mul against Rust's `f32`, the f32 → fixed conversion and the
//! intersection pipeline against the model's kernel (`gridrt_coproc::isect::watertight_q23`),
//! the CPU's f32 CFU on its handshake bus against its twin (`gridrt_shared::cfu::execute`).

use gridrt_coproc::isect::watertight_q23::{self as twin, Frame, RaySetup, Test};
use gridrt_coproc::{FixedFrame, NumberFormat};
use gridrt_rtl::sim::{default_programs, require_verilator, unit, CfuStress, Units};
use gridrt_shared::cfu;
use gridrt_shared::math::{Ray, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn units(test: &str) -> Option<Units> {
    if !require_verilator(test) {
        return None;
    }
    let programs = default_programs().unwrap_or_else(|e| panic!("{test}: {e}"));
    Some(Units::spawn(&programs.units).unwrap())
}

/// f32 bit patterns that exercise every class: zeros, subnormals, normals near the
/// boundaries, infinities, NaNs, and random bits.
fn f32_sample(rng: &mut ChaCha8Rng) -> u32 {
    let sign = (rng.gen::<u32>() & 1) << 31;
    match rng.gen_range(0..10) {
        0 => sign,
        1 => sign | rng.gen_range(1..0x80_0000),
        2 => sign | (rng.gen_range(1..4u32) << 23) | rng.gen_range(0..0x80_0000),
        3 => sign | (rng.gen_range(250..255u32) << 23) | rng.gen_range(0..0x80_0000),
        4 => sign | 0x7F80_0000 | if rng.gen_bool(0.5) { 0 } else { rng.gen_range(1..0x80_0000) },
        5 => sign | (rng.gen_range(120..135u32) << 23) | rng.gen_range(0..0x80_0000),
        _ => rng.gen(),
    }
}

/// Nearby operands: cancellation in subtraction, carries in addition.
fn f32_near(rng: &mut ChaCha8Rng, a: u32) -> u32 {
    let delta = rng.gen_range(-40i32..40);
    let b = (a as i32).wrapping_add(delta) as u32;
    if rng.gen_bool(0.5) {
        b ^ 0x8000_0000
    } else {
        b
    }
}

fn canonical(y: f32) -> u32 {
    if y.is_nan() {
        0x7FC0_0000
    } else {
        y.to_bits()
    }
}

#[test]
fn f32_add_and_sub_round_like_rust_on_every_class() {
    let Some(mut u) = units("f32_add_and_sub_round_like_rust_on_every_class") else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(0xADD);
    let mut v = Vec::new();
    for _ in 0..400_000 {
        let a = f32_sample(&mut rng);
        let b = if rng.gen_bool(0.3) { f32_near(&mut rng, a) } else { f32_sample(&mut rng) };
        v.extend([a, b, rng.gen_range(0..2)]);
    }
    let out = u.run(unit::ADD, &[], &v, 3, 1).unwrap();
    for (i, y) in out.iter().enumerate() {
        let (a, b, sub) = (f32::from_bits(v[3 * i]), f32::from_bits(v[3 * i + 1]), v[3 * i + 2] == 1);
        let want = canonical(if sub { a - b } else { a + b });
        assert_eq!(*y, want, "{a:e} {} {b:e}: {y:08x} vs {want:08x}", if sub { "-" } else { "+" });
    }
}

#[test]
fn f32_mul_rounds_like_rust_on_every_class() {
    let Some(mut u) = units("f32_mul_rounds_like_rust_on_every_class") else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(0x3A1);
    let mut v = Vec::new();
    for _ in 0..400_000 {
        let (a, b) = (f32_sample(&mut rng), f32_sample(&mut rng));
        v.extend([a, b]);
    }
    // The t_exit slack constant of SPEC §4.3 on every class.
    for _ in 0..50_000 {
        v.extend([f32_sample(&mut rng), 0x3F80_0800]);
    }
    // Subnormal products of sparse mantissas (a few set bits anywhere), shifted right by 1 to
    // 30 bits: the shift drops few set bits, so the rounding turns on exactly which dropped
    // bits count for the sticky bit.
    for _ in 0..300_000 {
        let sparse = |rng: &mut ChaCha8Rng| (0..rng.gen_range(1..4)).fold(0u32, |m, _| m | 1 << rng.gen_range(0..23));
        let sum = rng.gen_range(98..128u32); // biased exponents: shifts of 1..30
        let ea = rng.gen_range(1..sum);
        let a = (rng.gen::<u32>() & 0x8000_0000) | ea << 23 | sparse(&mut rng);
        let b = (rng.gen::<u32>() & 0x8000_0000) | (sum - ea) << 23 | sparse(&mut rng);
        v.extend([a, b]);
    }
    // Regression: products whose only set bit below the rounding position is the last one a
    // subnormal shift by 2, 3 or 4 drops (a sticky mask one bit short rounds them to even).
    for (a, b) in [(0x1F80_0001, 0x1F80_0001), (0x1F00_0002, 0x1FC0_0001), (0x1F00_0004, 0x1F60_0001)] {
        v.extend([a, b, a | 0x8000_0000, b]);
    }
    let out = u.run(unit::MUL, &[], &v, 2, 1).unwrap();
    for (i, y) in out.iter().enumerate() {
        let (a, b) = (f32::from_bits(v[2 * i]), f32::from_bits(v[2 * i + 1]));
        let want = canonical(a * b);
        assert_eq!(*y, want, "{a:e} * {b:e}: {y:08x} vs {want:08x}");
    }
}

#[test]
fn f32_to_fixed_matches_the_twin() {
    let Some(mut u) = units("f32_to_fixed_matches_the_twin") else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(0xF1C5);
    let mut v = Vec::new();
    for _ in 0..300_000 {
        let mut x = f32_sample(&mut rng);
        if x & 0x7F80_0000 == 0x7F80_0000 {
            x &= 0xBFFF_FFFF; // finite inputs only
        }
        let k = rng.gen_range(-300i32..300);
        v.extend([x, k as u32]);
    }
    let out = u.run(unit::TO_FIXED, &[], &v, 2, 3).unwrap();
    for i in 0..v.len() / 2 {
        let (x, k) = (f32::from_bits(v[2 * i]), v[2 * i + 1] as i32);
        let got = (out[3 * i + 2] == 0).then(|| ((out[3 * i + 1] as u64) << 32 | out[3 * i] as u64) as i64);
        assert_eq!(got, twin::to_fixed(x, k), "Q({x:e}, {k})");
    }
}

/// The ray words of the ISECT unit; `None` is a ray whose origin overflowed.
fn ray_header(r: Option<&RaySetup>) -> [u32; 13] {
    let mut h = [0u32; 13];
    let Some(r) = r else {
        h[10] = 1 << 23;
        h[12] = 1;
        return h;
    };
    for a in 0..3 {
        h[2 * a] = r.o[a] as u32;
        h[2 * a + 1] = (r.o[a] >> 32) as u32;
    }
    h[6] = r.kz as u32;
    h[7] = r.sx as u32;
    h[8] = r.sy as u32;
    h[9] = (r.d[2] < 0) as u32;
    h[10] = r.d[2].unsigned_abs() as u32;
    h[11] = r.texp as u32;
    h
}

fn v3(rng: &mut ChaCha8Rng, lo: f32, hi: f32) -> Vec3 {
    Vec3::new(rng.gen_range(lo..hi), rng.gen_range(lo..hi), rng.gen_range(lo..hi))
}

/// One ray against many triangles of one scenario; returns how many tests hit.
fn check_isect(u: &mut Units, frame: &FixedFrame, ray: &Ray, tris: &[[Vec3; 3]]) -> usize {
    let f = Frame::of(frame);
    let setup = twin::setup(&f, ray);
    let header = ray_header(setup.as_ref());
    let recs: Vec<[u32; 10]> = tris.iter().map(|t| twin::record(&f, t, 0).0).collect();
    let words: Vec<u32> = recs.iter().flat_map(|r| r[..9].iter().copied()).collect();
    let out = u.run(unit::ISECT, &header, &words, 9, 2).unwrap();
    let mut hits = 0;
    for (i, rec) in recs.iter().enumerate() {
        let want = setup.map_or(Test::Overflow, |s| twin::intersect(&s, rec));
        let got = match out[2 * i] {
            0 => Test::Miss,
            1 => Test::Hit(out[2 * i + 1]),
            _ => Test::Overflow,
        };
        assert_eq!(got, want, "ray {ray:?} triangle {:?}", tris[i]);
        hits += matches!(got, Test::Hit(_)) as usize;
    }
    hits
}

#[test]
fn intersection_pipeline_matches_the_twin() {
    let Some(mut u) = units("intersection_pipeline_matches_the_twin") else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(0x15EC7);
    let (mut hits, mut tests) = (0, 0);
    for round in 0..400 {
        // Scene boxes from tiny to huge, offset from the origin or not.
        let scale = [1e-3f32, 0.1, 1.0, 37.0, 1e4][round % 5];
        let offset = if round % 3 == 0 { v3(&mut rng, -1e3, 1e3) } else { Vec3::ZERO };
        let lo = offset - Vec3::splat(scale);
        let hi = offset + Vec3::splat(scale);
        let frame = FixedFrame::for_box(lo.to_array(), hi.to_array(), NumberFormat::Fixed64Q23).unwrap();
        let mut tris = Vec::new();
        for _ in 0..250 {
            let mut p = || offset + v3(&mut rng, -scale, scale);
            let mut t = [p(), p(), p()];
            if rng.gen_bool(0.1) {
                t[2] = t[0] + (t[1] - t[0]) * 0.5; // collinear
            }
            if rng.gen_bool(0.05) {
                t[1] = offset + v3(&mut rng, -300.0 * scale, 300.0 * scale); // out of range
            }
            tris.push(t);
        }
        // Rays aimed at triangle points (many hits, edges included) and random rays.
        for k in 0..8 {
            let origin = offset + v3(&mut rng, -3.0 * scale, 3.0 * scale) * if k == 7 { 500.0 } else { 1.0 };
            let t = tris[rng.gen_range(0..tris.len())];
            let (b1, b2) = (rng.gen_range(-0.1f32..1.0), rng.gen_range(-0.1f32..1.0));
            let target = t[0] + (t[1] - t[0]) * b1 + (t[2] - t[0]) * b2;
            let mut dir = if k % 2 == 0 { target - origin } else { v3(&mut rng, -1.0, 1.0) };
            if k == 5 {
                dir *= 1e-30;
            }
            if dir == Vec3::ZERO {
                continue;
            }
            hits += check_isect(&mut u, &frame, &Ray { origin, dir }, &tris);
            tests += tris.len();
        }
    }
    assert!(hits > tests / 50, "only {hits} hits in {tests} tests");
}

/// A function id: mostly add, sub and mul, else an unknown one (funct3 3..7, another funct7,
/// any 10 bits).
fn cfu_function_id(rng: &mut ChaCha8Rng) -> u16 {
    match rng.gen_range(0..20) {
        0..=5 => cfu::ADD,
        6..=11 => cfu::SUB,
        12..=17 => cfu::MUL,
        18 => cfu::function_id(rng.gen_range(1..0x80), rng.gen_range(0..3)),
        _ => loop {
            let id = rng.gen_range(3..0x400u16);
            if ![cfu::ADD, cfu::SUB, cfu::MUL].contains(&id) {
                break id;
            }
        },
    }
}

#[test]
fn cfu_answers_what_its_rust_twin_answers_under_random_back_pressure() {
    let test = "cfu_answers_what_its_rust_twin_answers_under_random_back_pressure";
    let Some(mut u) = units(test) else { return };
    let mut rng = ChaCha8Rng::seed_from_u64(0xCF0);
    // (gap %, stall %): back to back, light, heavy on each side, heavy on both.
    let stresses = [(0, 0), (20, 20), (80, 10), (10, 80), (60, 60)];
    let mut total = 0;
    for (k, (gap_pct, stall_pct)) in stresses.into_iter().enumerate() {
        let mut ops = Vec::new();
        for _ in 0..80_000 {
            let id = cfu_function_id(&mut rng);
            let a = f32_sample(&mut rng);
            let b = if rng.gen_bool(0.3) { f32_near(&mut rng, a) } else { f32_sample(&mut rng) };
            ops.push([u32::from(id), a, b]);
        }
        let stress = CfuStress { seed: 0x5EED + k as u32, gap_pct, stall_pct };
        let run = u.cfu(stress, &ops).unwrap();
        let n = ops.len() as u32;
        assert_eq!((run.commands, run.responses), (n, n), "{stress:?}: commands and responses of {n}");
        assert_eq!((run.rd.len(), run.latency.len()), (ops.len(), ops.len()));
        for ((&[id, a, b], &rd), &latency) in ops.iter().zip(&run.rd).zip(&run.latency) {
            let want = cfu::execute(id as u16, a, b);
            assert_eq!(rd, want, "{stress:?}: function_id {id:#x}, rs1 {a:08x}, rs2 {b:08x}: {rd:08x} vs {want:08x}");
            // rtl/README.md §7: 7 cycles for add and sub, 8 for mul, 1 for an unknown id.
            let want_latency = match id as u16 {
                cfu::ADD | cfu::SUB => 7,
                cfu::MUL => 8,
                _ => 1,
            };
            assert_eq!(latency, want_latency, "{stress:?}: latency of function_id {id:#x}");
        }
        total += ops.len();
    }
    assert_eq!(total, 400_000);
}

//! The co-processor RTL against the reference, word for word, through the Verilator build.

mod support;

use gridrt_coproc::{FslWord, RayKind, RayResult};
use gridrt_rtl::sim::{default_programs, require_verilator, CoprocSim};
use gridrt_rtl::twin::Frame;
use gridrt_shared::math::{Ray, Vec3};
use rand::Rng;
use support::*;

fn sim(test: &str, stall: Option<(u32, u64)>) -> Option<CoprocSim> {
    if !require_verilator(test) {
        return None;
    }
    let programs = default_programs().unwrap_or_else(|e| panic!("{test}: {e}"));
    Some(CoprocSim::spawn(&programs.coproc, stall).unwrap())
}

/// Sends a packet and collects every reply word.
fn exchange(s: &mut CoprocSim, packet: &[FslWord]) -> Vec<FslWord> {
    for &w in packet {
        s.push(w).unwrap();
    }
    let mut out = Vec::new();
    while let Some(w) = s.pop().unwrap() {
        out.push(w);
    }
    out
}

fn result_words(r: &RayResult) -> Vec<FslWord> {
    framed(&r.to_words())
}

#[test]
fn random_rays_give_the_reference_result_words() {
    let Some(mut s) = sim("random_rays_give_the_reference_result_words", None) else { return };
    let mut rng = rng(0xC0510);
    let mut rays = 0;
    let mut hits = 0;
    for round in 0..20 {
        let scene = random_scene(&mut rng, 4, 4.0);
        for (pe, p) in scene.iter().enumerate() {
            let img = p.image();
            assert_valid(&img);
            let ack = exchange(&mut s, &load_packet(pe as u8, &img));
            assert_eq!(ack, framed(&[0x9100_0000 | pe as u32]), "round {round} load {pe}");
        }
        let frame = Frame::of(&gridrt_coproc::FixedFrame::IDENTITY);
        let loaded = Loaded { frame, pes: &scene };
        for _ in 0..250 {
            let origin = Vec3::new(rng.gen_range(-8.0..8.0), rng.gen_range(-8.0..8.0), rng.gen_range(-8.0..8.0));
            let pe = &scene[rng.gen_range(0..scene.len())];
            let t = pe.tris[rng.gen_range(0..pe.tris.len())];
            // Interior points, and points on the edge a-b (shared with a neighbour).
            let (b1, b2) = if rng.gen_bool(0.3) {
                (rng.gen_range(0.0f32..1.0), 0.0)
            } else {
                (rng.gen_range(-0.1f32..0.7), rng.gen_range(-0.1f32..0.7))
            };
            let target = t.v[0] + (t.v[1] - t.v[0]) * b1 + (t.v[2] - t.v[0]) * b2;
            let dir = if rng.gen_bool(0.8) {
                target - origin
            } else {
                Vec3::new(rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0))
            };
            if dir == Vec3::ZERO {
                continue;
            }
            let ray = Ray { origin, dir };
            let list = random_list(&mut rng, &scene, 12);
            let kind = if rng.gen_bool(0.3) { RayKind::Any } else { RayKind::Closest };
            let t_max = if rng.gen_bool(0.7) { f32::INFINITY } else { rng.gen_range(0.0f32..3.0) };
            let want = reference(&loaded, kind, &ray, t_max, &list);
            let got = exchange(&mut s, &ray_packet(kind, &ray, t_max, &list));
            assert_eq!(
                got,
                result_words(&want),
                "round {round}: {kind:?} {ray:?} t_max {t_max} list {list:?}\nwant {want:?}"
            );
            rays += 1;
            hits += want.hit as usize;
        }
    }
    assert!(hits > rays / 10, "{hits} hits of {rays}");
}

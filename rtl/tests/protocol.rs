//! Protocol behaviour of the RTL against the model (`gridrt_coproc::Coprocessor`), word for
//! word: every ERROR, ACK and RESULT, and the resynchronisation after an error. Scripted cases
//! for every error of SPEC §4.5, then random word streams built from mutated packets.

mod support;

use gridrt_coproc::{Coprocessor, FslWord, RayKind};
use gridrt_rtl::sim::{default_programs, require_verilator, CoprocSim, RtlParams};
use gridrt_shared::math::{Ray, Vec3};
use rand::Rng;
use support::*;

struct Pair {
    rtl: CoprocSim,
    model: Coprocessor<'static>,
}

impl Pair {
    fn new(test: &str) -> Option<Self> {
        if !require_verilator(test) {
            return None;
        }
        let programs = default_programs().unwrap_or_else(|e| panic!("{test}: {e}"));
        Some(Self { rtl: CoprocSim::spawn(&programs.coproc, None).unwrap(), model: model(RtlParams::default()) })
    }

    /// Sends `words` to both and checks that the replies are the same words; returns them.
    fn check(&mut self, what: &str, words: &[FslWord]) -> Vec<FslWord> {
        let r = run_rtl(&mut self.rtl, words);
        let m = run_model(&mut self.model, words);
        assert_eq!(r, m, "{what}:\n rtl   {r:08x?}\n model {m:08x?}");
        r
    }
}

fn d(x: u32) -> FslWord {
    FslWord::data(x)
}

fn l(x: u32) -> FslWord {
    FslWord::last(x)
}

fn err(e: gridrt_coproc::FslError, detail: u16) -> FslWord {
    l(e.to_word(detail))
}

/// A small valid scene on PEs 0 and 1.
fn small_scene() -> Vec<PeScene> {
    let mut rng = rng(0x5CE);
    random_scene(&mut rng, 2, 2.0)
}

fn ray_words(kind: RayKind, list: &[gridrt_coproc::ListEntry]) -> Vec<FslWord> {
    let ray = Ray { origin: Vec3::new(0.1, 0.2, -5.0), dir: Vec3::new(0.0, 0.0, 1.0) };
    ray_packet(kind, &ray, f32::INFINITY, list)
}

#[test]
fn every_protocol_error_matches_the_model_word_for_word() {
    use gridrt_coproc::FslError as E;
    let Some(mut p) = Pair::new("every_protocol_error_matches_the_model_word_for_word") else { return };
    // Before any load.
    assert_eq!(p.check("ray before load", &ray_words(RayKind::Closest, &[])), vec![err(E::SceneNotLoaded, 0)]);
    assert_eq!(p.check("clear", &[l(0x4000_0000)]), vec![l(0x9400_0000)]);
    assert_eq!(p.check("clear without control", &[d(0x4000_0000), d(7), l(8)]), vec![err(E::MissingControl, 0)]);
    for op in [0x0u32, 0x6, 0x7, 0x8, 0x9, 0xE, 0xF] {
        p.check(&format!("opcode {op:x}"), &[l(op << 28)]);
        p.check(&format!("opcode {op:x} discards"), &[d(op << 28), d(1), d(2), l(3)]);
    }
    // LOAD_PE framing and sizes.
    p.check("load pe out of range", &[d(0x1000_0004), d(3), l(0)]);
    p.check("load pe out of range, control", &[l(0x1000_00FF)]);
    p.check("load header with control", &[l(0x1000_0001)]);
    p.check("load too big", &[d(0x1000_0001), d(16385), d(0), l(0)]);
    p.check("load too big, control", &[d(0x1000_0002), l(u32::MAX)]);
    p.check("load empty without control", &[d(0x1000_0003), d(0), l(5)]);
    assert_eq!(p.check("load empty", &[d(0x1000_0003), l(0)]), vec![l(0x9100_0003)]);
    p.check("load count with control", &[d(0x1000_0000), l(20)]);
    let scene = small_scene();
    let img = scene[0].image();
    let mut pk = load_packet(0, &img);
    pk[5].control = true;
    p.check("load image ends early", &pk[..6]);
    let mut pk = load_packet(0, &img);
    let n = pk.len();
    pk[n - 1].control = false;
    pk.push(l(0xAAAA));
    p.check("load image misses control", &pk);
    // Malformed images.
    let mut bad = Vec::new();
    let mut x = img.clone();
    x[0] = 0xFFFF_0001;
    bad.push(("bad tag", x));
    let mut x = img.clone();
    x[1] += 1;
    bad.push(("triangle count", x));
    let mut x = img.clone();
    x.pop();
    bad.push(("short image", x));
    bad.push(("four words", img[..4].to_vec()));
    let (v, r, t) = (img[2] as usize, img[3] as usize, img[1] as usize);
    if v >= 2 {
        let mut x = img.clone();
        x[8] = x[5];
        bad.push(("voxel ids not increasing", x));
    }
    let mut x = img.clone();
    x[7] = r as u32 + 1;
    bad.push(("ref range past the table", x));
    let mut x = img.clone();
    x[5 + 3 * v] = t as u32;
    bad.push(("ref past the triangles", x));
    let tri0 = 5 + 3 * v + r;
    let mut x = img.clone();
    x[tri0 + 4] = 0x7F80_0000;
    bad.push(("infinite vertex", x));
    let mut x = img.clone();
    x[tri0 + 10] = 65536;
    bad.push(("material too large", x));
    for (what, x) in bad {
        let reply = p.check(what, &load_packet(0, &x));
        assert_eq!(reply, vec![err(E::PeImageMalformed, 0)], "{what}");
    }
    assert!(!p.model.is_pe_loaded(0));
    // Rays with no loaded PE still fail; then load and exercise the ray checks.
    for (pe, s) in scene.iter().enumerate() {
        assert_eq!(p.check("load", &load_packet(pe as u8, &s.image())), vec![l(0x9100_0000 | pe as u32)]);
    }
    let entry = gridrt_coproc::ListEntry { voxel: scene[0].voxels[0].0, pe: 0, t_exit: 3.0 };
    let good = ray_words(RayKind::Closest, &[entry, entry]);
    p.check("valid ray", &good);
    p.check("list too long", &[d(0x2000_0101), d(0), l(0)]);
    p.check("list too long, control", &[l(0x3000_0101)]);
    for cut in 0..good.len() - 1 {
        let mut w = good[..=cut].to_vec();
        w[cut].control = true;
        p.check(&format!("ray ends at word {cut}"), &w);
    }
    let mut w = good.clone();
    let n = w.len();
    w[n - 1].control = false;
    w.push(d(1));
    w.push(l(2));
    p.check("ray misses control", &w);
    for (i, bad) in
        [(1, f32::NAN), (2, f32::INFINITY), (3, -f32::INFINITY), (4, f32::NAN), (5, f32::INFINITY), (6, f32::NAN)]
    {
        let mut w = good.clone();
        w[i].data = bad.to_bits();
        p.check(&format!("non-finite word {i}"), &w);
    }
    let mut w = good.clone();
    w[4].data = 0x8000_0000;
    w[5].data = 0;
    w[6].data = 0x8000_0000;
    p.check("zero direction", &w);
    let mut w = good.clone();
    w[7].data = f32::NAN.to_bits();
    p.check("t_max NaN", &w);
    let mut w = good.clone();
    w[7].data = f32::NEG_INFINITY.to_bits();
    p.check("t_max -inf", &w);
    p.check("empty list", &ray_words(RayKind::Any, &[]));
    let mut w = ray_words(RayKind::Any, &[]);
    w[7].control = false;
    w.push(l(0));
    p.check("empty list misses control", &w);
    let other = |e: gridrt_coproc::ListEntry| ray_words(RayKind::Closest, &[entry, e]);
    p.check("entry pe out of range", &other(gridrt_coproc::ListEntry { pe: 4, ..entry }));
    p.check("entry pe 200", &other(gridrt_coproc::ListEntry { pe: 200, ..entry }));
    p.check("entry pe not loaded", &other(gridrt_coproc::ListEntry { pe: 3, ..entry }));
    p.check("entry pe empty image", &[d(0x1000_0002), l(0)]);
    p.check("entry on empty image", &other(gridrt_coproc::ListEntry { pe: 2, ..entry }));
    for voxel in [0u32, 1, 2, 3, 4, 100, 0xFF_FFFF] {
        p.check(&format!("voxel {voxel}"), &other(gridrt_coproc::ListEntry { voxel, ..entry }));
    }
    p.check("t_exit NaN", &other(gridrt_coproc::ListEntry { t_exit: f32::NAN, ..entry }));
    p.check("t_exit -inf", &other(gridrt_coproc::ListEntry { t_exit: f32::NEG_INFINITY, ..entry }));
    // CLEAR empties every PE.
    p.check("clear", &[l(0x4000_0000)]);
    assert_eq!(p.check("ray after clear", &good), vec![err(E::SceneNotLoaded, 0)]);
}

#[test]
fn random_word_streams_get_the_models_replies() {
    let Some(mut p) = Pair::new("random_word_streams_get_the_models_replies") else { return };
    let mut rng = rng(0xF022);
    let scene = small_scene();
    let mut packets: Vec<Vec<FslWord>> = Vec::new();
    for (pe, s) in scene.iter().enumerate() {
        packets.push(load_packet(pe as u8, &s.image()));
    }
    for _ in 0..40 {
        let list = random_list(&mut rng, &scene, 5);
        packets.push(ray_words(if rng.gen_bool(0.5) { RayKind::Any } else { RayKind::Closest }, &list));
    }
    packets.push(framed(&[0x4000_0000]));
    packets.push(framed(&[0x1000_0003, 0]));
    packets.push(frame_packet([-2.0; 3], [2.0; 3]));
    packets.push(frame_packet([-1.0, -2.0, -3.0], [3.0, 1.0, 2.5]));
    for round in 0..3000 {
        let mut words = packets[rng.gen_range(0..packets.len())].clone();
        match rng.gen_range(0..8) {
            0 => {
                let i = rng.gen_range(0..words.len());
                words[i].data ^= 1 << rng.gen_range(0..32);
            }
            1 => {
                let i = rng.gen_range(0..words.len());
                words[i].control = !words[i].control;
            }
            2 => {
                let i = rng.gen_range(0..words.len());
                words.truncate(i + 1);
            }
            3 => words.push(FslWord { data: rng.gen(), control: rng.gen_bool(0.3) }),
            _ => {}
        }
        p.check(&format!("round {round}"), &words);
    }
}

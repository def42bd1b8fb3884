//! The co-processor RTL against the model (watertight, fixed64-q23, `rtl` timing), word for
//! word through the Verilator build: random rays over random scenes (10⁵ in all), in several
//! fixed-point frames (FRAME packets), with the stream handshakes stalled at random, and over a
//! PE memory filled to its last word; with PE caches, the cycles the RTL stands still for
//! them against the model's timing of them.

mod support;

use gridrt_coproc::{Coprocessor, FixedFrame, FslWord, ListEntry, NumberFormat, PeCacheConfig, RayKind};
use gridrt_rtl::sim::{default_programs, require_verilator, CoprocSim, RtlParams};
use gridrt_shared::math::{Ray, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use support::*;

fn sim(stall: Option<(u32, u64)>) -> CoprocSim {
    let programs = default_programs().unwrap_or_else(|e| panic!("{e}"));
    CoprocSim::spawn(&programs.coproc, stall).unwrap()
}

/// Sends a packet to the RTL and to the model; their replies must be the same words.
fn exchange(s: &mut CoprocSim, m: &mut Coprocessor, packet: &[FslWord], what: &dyn Fn() -> String) -> Vec<FslWord> {
    let got = run_rtl(s, packet);
    let want = run_model(m, packet);
    assert_eq!(got, want, "{}", what());
    got
}

/// What a batch of rays saw.
#[derive(Debug, Default)]
struct Tally {
    rays: usize,
    hits: usize,
    any: usize,
}

/// Where the random scenes lie: the box `center ± ext`, announced by a FRAME packet or left
/// in the reset frame (the identity).
#[derive(Debug, Clone, Copy)]
struct Place {
    center: Vec3,
    ext: f32,
    frame_packet: bool,
}

/// After each packet of [`random_rays_then`]: the RTL, the model, what the packet was.
type AfterPacket<'a> = &'a mut dyn FnMut(&mut CoprocSim, &Coprocessor, &dyn Fn() -> String);

/// `rounds` random scenes over `pes` PEs at `place`, `rays` random rays each; every reply
/// of the RTL equals the model's.
fn random_rays(
    s: &mut CoprocSim,
    m: &mut Coprocessor,
    rng: &mut ChaCha8Rng,
    sizes: (usize, usize, usize),
    place: Place,
) -> Tally {
    random_rays_then(s, m, rng, sizes, place, &mut |_, _, _| {})
}

/// [`random_rays`], calling `after` after every packet.
fn random_rays_then(
    s: &mut CoprocSim,
    m: &mut Coprocessor,
    rng: &mut ChaCha8Rng,
    (pes, rounds, rays): (usize, usize, usize),
    place: Place,
    after: AfterPacket<'_>,
) -> Tally {
    let Place { center, ext, frame_packet } = place;
    let mut tally = Tally::default();
    if frame_packet {
        let (min, max) = ((center - Vec3::splat(ext)).to_array(), (center + Vec3::splat(ext)).to_array());
        let what = || format!("FRAME {min:?} {max:?}");
        let ack = exchange(s, m, &support::frame_packet(min, max), &what);
        assert_eq!(ack, framed(&[0x9500_0000]));
        after(s, m, &what);
    }
    for round in 0..rounds {
        let mut scene = random_scene(rng, pes, ext);
        for pe in &mut scene {
            for t in &mut pe.tris {
                t.v = t.v.map(|v| v + center);
            }
        }
        for (pe, p) in scene.iter().enumerate() {
            let img = p.image();
            assert_valid(&img);
            let what = || format!("round {round} load {pe}");
            let ack = exchange(s, m, &load_packet(pe as u8, &img), &what);
            assert_eq!(ack, framed(&[0x9100_0000 | pe as u32]), "round {round} load {pe}");
            after(s, m, &what);
        }
        for _ in 0..rays {
            let origin =
                center + Vec3::new(rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0)) * ext;
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
            let list = random_list(rng, &scene, 12);
            let kind = if rng.gen_bool(0.3) { RayKind::Any } else { RayKind::Closest };
            let t_max = if rng.gen_bool(0.7) { f32::INFINITY } else { rng.gen_range(0.0f32..3.0) * ext };
            let what = || format!("round {round}: {kind:?} {ray:?} t_max {t_max} list {list:?}");
            let got = exchange(s, m, &ray_packet(kind, &ray, t_max, &list), &what);
            assert_eq!(got.len(), 8, "{}", what());
            after(s, m, &what);
            tally.rays += 1;
            tally.hits += (got[0].data & 1) as usize;
            tally.any += (kind == RayKind::Any) as usize;
        }
    }
    tally
}

/// 10⁵ random rays (two simulator processes in parallel, 50 000 each): RESULT words equal
/// the model's, cycles and test counts included.
#[test]
fn hundred_thousand_random_rays_give_the_models_result_words() {
    if !require_verilator("hundred_thousand_random_rays_give_the_models_result_words") {
        return;
    }
    let _ = default_programs();
    let tallies: Vec<Tally> = std::thread::scope(|sc| {
        let jobs: Vec<_> = (0..2u64)
            .map(|j| {
                sc.spawn(move || {
                    let mut s = sim(None);
                    let mut m = model(RtlParams::default());
                    let mut rng = rng(0xC0510 + j);
                    random_rays(
                        &mut s,
                        &mut m,
                        &mut rng,
                        (4, 100, 500),
                        Place { center: Vec3::ZERO, ext: 4.0, frame_packet: false },
                    )
                })
            })
            .collect();
        jobs.into_iter().map(|j| j.join().unwrap()).collect()
    });
    let rays: usize = tallies.iter().map(|t| t.rays).sum();
    let hits: usize = tallies.iter().map(|t| t.hits).sum();
    assert!(rays >= 99_000, "{rays} rays");
    assert!(hits > rays / 5, "{hits} hits of {rays}");
}

/// FRAME packets set the fixed-point frame of the loads and rays after them: scenes far from
/// the origin, tiny and huge, each in its own frame.
#[test]
fn frames_from_frame_packets_give_the_models_result_words() {
    if !require_verilator("frames_from_frame_packets_give_the_models_result_words") {
        return;
    }
    let mut s = sim(None);
    let mut m = model(RtlParams::default());
    let mut rng = rng(0xF4A3E);
    for (center, ext) in [
        (Vec3::new(1000.0, -2000.0, 5.5), 3.0),
        (Vec3::new(0.001, 0.002, -0.003), 1e-4),
        (Vec3::new(-3e5, 1e5, 2e5), 4e4),
        (Vec3::new(0.3, 0.7, 0.1), 0.37),
        (Vec3::ZERO, 1e-30),
    ] {
        let t = random_rays(&mut s, &mut m, &mut rng, (4, 3, 300), Place { center, ext, frame_packet: true });
        assert!(t.hits > t.rays / 10, "{center:?} ± {ext}: {t:?}");
    }
}

/// The other ways of sharing pipelines, each against the model's `rtl` profile of its
/// sharing (`TimingProfile::rtl`): 3 PEs two to a pipeline (the second pipeline's other lane
/// unused), 3 PEs on one pipeline of four lanes (one unused), and 2 PEs with a pipeline each.
/// Words, cycles and test counts as the model's.
#[test]
fn every_pipeline_sharing_gives_the_models_result_words() {
    if !require_verilator("every_pipeline_sharing_gives_the_models_result_words") {
        return;
    }
    for (pes, pes_per_pipeline, seed) in [(3, 2, 0x3E5), (3, 4, 0x3E4), (2, 1, 0x2E1)] {
        let params = RtlParams { pes, pes_per_pipeline, ..RtlParams::default() };
        let programs = gridrt_rtl::sim::build(params).unwrap_or_else(|e| panic!("{e}"));
        let mut s = CoprocSim::spawn(&programs.coproc, None).unwrap();
        let mut m = model(params);
        let mut rng = rng(seed);
        let t = random_rays(
            &mut s,
            &mut m,
            &mut rng,
            (pes.into(), 10, 300),
            Place { center: Vec3::ZERO, ext: 4.0, frame_packet: false },
        );
        assert!(t.rays >= 2_900 && t.hits > t.rays / 5, "{params:?}: {t:?}");
    }
}

/// The FPGA build (`STOP_WHEN_EMPTY` = 0: the intersection pipe's data registers run
/// freely; every other test here runs the simulation build, whose pipe stops when empty):
/// words, cycles and test counts as the model's.
#[test]
fn the_fpga_build_whose_pipe_never_stops_gives_the_models_result_words() {
    if !require_verilator("the_fpga_build_whose_pipe_never_stops_gives_the_models_result_words") {
        return;
    }
    let params = RtlParams { stop_when_empty: false, ..RtlParams::default() };
    let programs = gridrt_rtl::sim::build(params).unwrap_or_else(|e| panic!("{e}"));
    let mut s = CoprocSim::spawn(&programs.coproc, None).unwrap();
    let mut m = model(params);
    let mut rng = rng(0xF4EE);
    let t = random_rays(
        &mut s,
        &mut m,
        &mut rng,
        (4, 10, 300),
        Place { center: Vec3::ZERO, ext: 4.0, frame_packet: false },
    );
    assert!(t.rays >= 2_900 && t.hits > t.rays / 5, "{params:?}: {t:?}");
}

/// The stream handshakes (s_axis_tvalid_i before a word is offered, m_axis_tready_i) dropped
/// in 40 % of the cycles at random change nothing in the replies.
#[test]
fn stalled_handshakes_do_not_change_the_replies() {
    if !require_verilator("stalled_handshakes_do_not_change_the_replies") {
        return;
    }
    let mut s = sim(Some((40, 7)));
    let mut m = model(RtlParams::default());
    let mut rng = rng(0x57A11);
    let t = random_rays(
        &mut s,
        &mut m,
        &mut rng,
        (4, 4, 250),
        Place { center: Vec3::new(2.0, 1.0, -1.0), ext: 2.0, frame_packet: true },
    );
    assert!(t.hits > 100 && t.any > 100, "{t:?}");
}

/// FRAME checks its box (SPEC §4.6): non-finite words and inverted axes are ERROR 12 with the
/// word's index, framing errors as for every packet, and a good FRAME empties the PEs — the
/// model's answers, word for word.
#[test]
fn frame_packet_errors_and_effects() {
    if !require_verilator("frame_packet_errors_and_effects") {
        return;
    }
    let mut s = sim(None);
    let mut m = model(RtlParams::default());
    let mut x = |p: &[FslWord], what: &str| exchange(&mut s, &mut m, p, &|| what.to_string());
    let bad = |code: u32, detail: u32| framed(&[0xE000_0000 | code << 16 | detail]);
    let ok = support::frame_packet([0.0; 3], [1.0; 3]);
    assert_eq!(x(&ok, "ok"), framed(&[0x9500_0000]));
    for i in 1..7 {
        let mut p = ok.clone();
        p[i].data = if i % 2 == 0 { f32::NAN.to_bits() } else { f32::INFINITY.to_bits() };
        assert_eq!(x(&p, &format!("non-finite word {i}")), bad(12, i as u32));
    }
    for a in 0..3 {
        let mut p = ok.clone();
        p[4 + a].data = (-1.0f32).to_bits();
        assert_eq!(x(&p, &format!("inverted axis {a}")), bad(12, 4 + a as u32));
    }
    let mut p = ok.clone();
    p[3].control = true;
    assert_eq!(x(&p[..4], "control at word 3"), bad(2, 3));
    let mut p = ok.clone();
    p[6].control = false;
    p.push(FslWord::last(0));
    assert_eq!(x(&p, "missing control"), bad(3, 6));
    // A load, then FRAME: the PE is empty again.
    let mut rng = rng(1);
    let scene = random_scene(&mut rng, 1, 0.5);
    assert_eq!(x(&load_packet(0, &scene[0].image()), "load"), framed(&[0x9100_0000]));
    assert_eq!(x(&ok, "frame"), framed(&[0x9500_0000]));
    let ray = Ray { origin: Vec3::splat(0.5), dir: Vec3::X };
    assert_eq!(x(&ray_packet(RayKind::Closest, &ray, 1.0, &[]), "ray"), bad(10, 0));
    // Analytic primitives: refused by the fixed-point kernel (ERROR 13).
    let mut img = scene[0].image();
    img[4] = 1;
    img.extend([1, 7, 0]);
    img.extend([0.5f32.to_bits(), 0, 0, 0, 0, 0.5f32.to_bits(), 0, 0, 0, 0, 0.5f32.to_bits(), 0, 0]);
    assert_eq!(x(&load_packet(0, &img), "analytic primitive"), bad(13, 0));
}

/// A PE image of `tris` triangles (voxel v holds triangles 100v..100v+100) whose ref table is
/// padded with `pad` unused refs, so that its size n, and so n + 10 T, can be set to the word.
fn padded_image(tris: &[support::Tri], pad: usize) -> Vec<u32> {
    let t = tris.len() as u32;
    let voxels = t.div_ceil(100);
    let refs = t as usize + pad;
    let mut w = vec![0xFFFF_0002, t, voxels, refs as u32, 0];
    for v in 0..voxels {
        w.extend([v, 100 * v, (t - 100 * v).min(100)]);
    }
    w.extend(0..t);
    w.extend(std::iter::repeat_n(0, pad));
    for tri in tris {
        for v in tri.v {
            w.extend(v.to_array().map(f32::to_bits));
        }
        w.extend([tri.prim, tri.material]);
    }
    w
}

/// `n` small random triangles (each within a 1-unit cube in ±4), prim ids 0..n.
fn small_triangles(rng: &mut ChaCha8Rng, n: u32) -> Vec<support::Tri> {
    (0..n)
        .map(|i| {
            let c = Vec3::new(rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0));
            let mut p = || c + Vec3::new(rng.gen_range(-0.5..0.5), rng.gen_range(-0.5..0.5), rng.gen_range(-0.5..0.5));
            support::Tri { v: [p(), p(), p()], prim: i, material: i % 65536 }
        })
        .collect()
}

/// A ray at the centre of each triangle `which` of a `padded_image` loaded into PE 0 (its
/// voxel: index / 100), Any for every third: the model's words; returns the hits.
fn rays_at_triangles(
    s: &mut CoprocSim,
    m: &mut Coprocessor,
    tris: &[support::Tri],
    which: impl Iterator<Item = usize>,
    what: &str,
) -> usize {
    let mut hits = 0;
    for i in which {
        let t = tris[i];
        let target = (t.v[0] + t.v[1] + t.v[2]) / 3.0;
        let ray = Ray { origin: target + Vec3::new(0.3, -7.0, 0.2), dir: Vec3::new(-0.3, 7.0, -0.2) };
        let list = [ListEntry { voxel: i as u32 / 100, pe: 0, t_exit: f32::INFINITY }];
        let kind = if i % 3 == 0 { RayKind::Any } else { RayKind::Closest };
        let got =
            exchange(s, m, &ray_packet(kind, &ray, f32::INFINITY, &list), &|| format!("{what}: ray at triangle {i}"));
        hits += (got[0].data & 1) as usize;
    }
    hits
}

/// The triangles' records fill the PE memory up to the last word (n + 10 T = PE_MEM_WORDS, n
/// even and odd): rays at the first and the last triangles give the model's words, so no
/// record overwrote the image or another record. One word more is MEM_OVERFLOW, as in the
/// model.
#[test]
fn a_full_pe_memory_keeps_every_record_and_one_word_more_overflows() {
    if !require_verilator("a_full_pe_memory_keeps_every_record_and_one_word_more_overflows") {
        return;
    }
    let params = RtlParams::default();
    let mut s = sim(None);
    let mut m = model(params);
    let mut rng = rng(0xF11);
    let tris = small_triangles(&mut rng, 700);
    let words = params.pe_mem_words as usize;
    let full_pad = words - 10 * tris.len() - padded_image(&tris, 0).len();
    for (pad, fits) in [(full_pad, true), (full_pad - 1, true), (full_pad + 1, false), (full_pad + 2, false)] {
        let img = padded_image(&tris, pad);
        assert_valid(&img);
        let what = format!("n {} + 10 T {} vs {words}", img.len(), 10 * tris.len());
        let ack = exchange(&mut s, &mut m, &load_packet(0, &img), &|| what.clone());
        if !fits {
            assert_eq!(ack.len(), 1, "{what}");
            assert_eq!(ack[0].data >> 28, 0xE, "{what}: {ack:?}");
            continue;
        }
        assert_eq!(ack, framed(&[0x9100_0000]), "{what}");
        let hits = rays_at_triangles(&mut s, &mut m, &tris, (0..60).chain(640..700), &what);
        assert!(hits >= 100, "{what}: {hits} of 120 rays hit");
    }
}

/// PE memories as caches of an external memory (`--pe-cache-lines`, rtl/README.md §4.6):
/// random rays over random scenes give the model's words, cycles and test counts included,
/// whatever the memory's latency and with the stream handshakes stalled, through caches of
/// 16 lines (most reads miss and lines evict each other) and of 512. The caches did stop
/// the co-processor and fetch lines (a build whose memories were block RAM would not).
#[test]
fn pe_caches_give_the_models_result_words() {
    if !require_verilator("pe_caches_give_the_models_result_words") {
        return;
    }
    for (lines, latency, stall, seed) in
        [(16u32, 8u32, None, 0xCAC1u64), (512, 1, Some((20, 7)), 0xCAC2), (16, 23, Some((10, 3)), 0xCAC3)]
    {
        let params = RtlParams { pe_cache_lines: lines, ..RtlParams::default() };
        let programs = gridrt_rtl::sim::build(params).unwrap_or_else(|e| panic!("{e}"));
        let mut args = vec!["--mem-latency".to_string(), latency.to_string()];
        if let Some((pct, seed)) = stall {
            args.extend(["--stall".to_string(), pct.to_string(), "--seed".to_string(), seed.to_string()]);
        }
        let mut s = CoprocSim::spawn_with(&programs.coproc, &args).unwrap();
        let mut m = model(params);
        let mut rng = rng(seed);
        let t = random_rays(
            &mut s,
            &mut m,
            &mut rng,
            (4, 8, 250),
            Place { center: Vec3::new(3.0, -1.0, 2.0), ext: 4.0, frame_packet: true },
        );
        assert!(t.rays >= 1_900 && t.hits > t.rays / 5, "{lines} lines: {t:?}");
        let mem = s.pe_memory().unwrap();
        assert!(mem.reads > 0 && mem.writes > 0 && mem.stall_cycles > 0, "{lines} lines: {mem:?}");
    }
}

/// A PE image far larger than block RAM holds (20 000 triangles: 200 000 words of records,
/// with PE_MEM_WORDS 2²⁰ in the external memory behind a 512-line cache) loads, and rays at
/// its first and last triangles give the model's words.
#[test]
fn a_pe_image_beyond_block_ram_loads_through_the_cache() {
    if !require_verilator("a_pe_image_beyond_block_ram_loads_through_the_cache") {
        return;
    }
    let params = RtlParams { pe_mem_words: 1 << 20, pe_cache_lines: 512, ..RtlParams::default() };
    let programs = gridrt_rtl::sim::build(params).unwrap_or_else(|e| panic!("{e}"));
    let mut s = CoprocSim::spawn(&programs.coproc, None).unwrap();
    let mut m = model(params);
    let mut rng = rng(0xB16);
    let n = 20_000u32;
    let tris = small_triangles(&mut rng, n);
    let img = padded_image(&tris, 0);
    assert!(img.len() + 10 * tris.len() > 16384 * 8, "{} words", img.len() + 10 * tris.len());
    assert_valid(&img);
    let ack = exchange(&mut s, &mut m, &load_packet(0, &img), &|| "load".into());
    assert_eq!(ack, framed(&[0x9100_0000]));
    let hits = rays_at_triangles(&mut s, &mut m, &tris, (0..40).chain(n as usize - 40..n as usize), "2^20 words");
    assert!(hits >= 70, "{hits} of 80 rays hit");
    let mem = s.pe_memory().unwrap();
    assert!(mem.writes as usize >= img.len() + 10 * tris.len(), "{mem:?}");
}

/// The model's PE-cache timing (`Coprocessor::with_pe_caches`) for a build with caches.
fn model_with_caches(params: RtlParams, mem_latency: u32) -> Coprocessor<'static> {
    let cfg = support::model_config(params);
    let caches = PeCacheConfig { lines: params.pe_cache_lines, mem_latency };
    let words = cfg.required_backing_words() + caches.state_words(cfg.pe_count);
    let backing: &'static mut [u32] = vec![0u32; words].leak();
    let mut m = Coprocessor::with_pe_caches(cfg, caches, backing).expect("valid configuration");
    m.set_number_format(NumberFormat::Fixed64Q23, FixedFrame::IDENTITY);
    m
}

/// The model's PE-cache timing (rtl/README.md §4.6) against the RTL's counters: after every
/// packet (FRAME, LOAD_PE, rays) of random scenes, the cycles the co-processor stood still
/// for its caches and the words it read and wrote in the external memory equal the
/// model's, through caches of 16 lines (most reads miss, lines evict each other) and of
/// 512, with memory latencies of 1, 8 and 23 cycles (request words offered every cycle).
#[test]
fn the_models_pe_cache_stalls_equal_the_rtls_cycle_for_cycle() {
    if !require_verilator("the_models_pe_cache_stalls_equal_the_rtls_cycle_for_cycle") {
        return;
    }
    let (rounds, rays) = (6, 200);
    for (lines, latency, seed) in [
        (16u32, 1u32, 0x57A1u64),
        (16, 8, 0x57A2),
        (16, 23, 0x57A3),
        (512, 1, 0x57A4),
        (512, 8, 0x57A5),
        (512, 23, 0x57A6),
    ] {
        let params = RtlParams { pe_cache_lines: lines, ..RtlParams::default() };
        let programs = gridrt_rtl::sim::build(params).unwrap_or_else(|e| panic!("{e}"));
        let args = ["--mem-latency".to_string(), latency.to_string()];
        let mut s = CoprocSim::spawn_with(&programs.coproc, &args).unwrap();
        let mut m = model_with_caches(params, latency);
        let mut rng = rng(seed);
        let mut packets = 0usize;
        let t = random_rays_then(
            &mut s,
            &mut m,
            &mut rng,
            (4, rounds, rays),
            Place { center: Vec3::new(3.0, -1.0, 2.0), ext: 4.0, frame_packet: true },
            &mut |s, m, what| {
                packets += 1;
                let rtl = s.pe_memory().unwrap();
                let st = m.stats();
                let model = (st.pe_stall_cycles, st.pe_mem_reads, st.pe_mem_writes);
                assert_eq!(
                    model,
                    (rtl.stall_cycles, rtl.reads as u64, rtl.writes as u64),
                    "{lines} lines, latency {latency}, packet {packets} ({}): model (stalls, reads, writes) against the RTL's",
                    what()
                );
            },
        );
        let mem = s.pe_memory().unwrap();
        assert!(
            t.rays >= rounds * rays * 9 / 10 && mem.stall_cycles > 0 && mem.reads > 0,
            "{lines} lines: {t:?} {mem:?}"
        );
    }
}

//! The FSL word interface: packets, replies, every protocol violation, resynchronisation.

use super::*;
use gridrt_shared::fsl::{ray_header, CLEAR_WORD};

/// PE 0 holds voxel 0 (hit at t = 2, prim 3) and voxel 4; PE 1 holds voxel 1.
fn images() -> Vec<Vec<u32>> {
    vec![
        image(&[(0, vec![0, 1]), (4, vec![1])], &[hit_tri(1.0, 3), miss_tri(1.0, 4)]),
        image(&[(1, vec![0])], &[hit_tri(2.0, 5)]),
    ]
}

fn good_list() -> Vec<ListEntry> {
    vec![entry(0, 0, 100.0)]
}

/// The reply a good request must produce, control bit on the last of 8 words.
fn expect_result(words: &[FslWord], expected: &RayResult) {
    assert_eq!(words.len(), 8, "{words:x?}");
    assert_eq!(words.iter().map(|w| w.data).collect::<Vec<_>>(), expected.to_words().to_vec());
    assert!(words[..7].iter().all(|w| !w.control) && words[7].control);
}

#[test]
fn ray_packet_reply_equals_direct_trace() {
    let mut backing = Vec::new();
    let mut cp = loaded(config(2, 256), &mut backing, &images());
    let direct = cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &good_list()).unwrap();
    assert_eq!((direct.hit, direct.prim, direct.t, direct.tests), (true, 3, 2.0, 2));
    push_all(&mut cp, &ray_packet(RayKind::Closest, &probe_ray(), f32::INFINITY, &good_list()));
    let out = drain(&mut cp);
    expect_result(&out, &direct);
    let s = cp.stats();
    assert_eq!((s.rays, s.hits, s.tests, s.words_in, s.words_out, s.errors), (2, 2, 4, 10, 8, 0));
    // Two rays plus the two loads: (header + count + image) words in, one ACK out.
    let loads: u64 = images().iter().map(|img| img.len() as u64 + 3).sum();
    assert_eq!(s.cycles, 2 * direct.cycles as u64 + loads);
}

/// Each bad packet is answered with exactly one ERROR word (control bit set) carrying the
/// right code and detail; a good request afterwards is answered normally.
#[test]
fn every_violation_is_answered_with_one_error_word_and_the_link_resynchronises() {
    let ray = probe_ray();
    let head = |count: u16| {
        ray_request_head(RayKind::Closest, ray.origin.to_array(), ray.dir.to_array(), f32::INFINITY, count)
    };
    let with_head = |count: u16, tail: &[u32]| {
        let mut w = head(count).to_vec();
        w.extend_from_slice(tail);
        w
    };
    let e0 = entry_words(entry(0, 0, 100.0));
    let nan = f32::NAN.to_bits();
    let junk_then_flush = |mut w: Vec<FslWord>| {
        // Words after an error without control bit are discarded up to the next control word,
        // even when they look like a valid packet.
        w.extend(
            ray_packet(RayKind::Closest, &ray, f32::INFINITY, &good_list())
                .into_iter()
                .map(|x| FslWord { control: false, ..x }),
        );
        w.push(FslWord::last(0xDEAD_BEEF));
        w
    };
    let unframed = |w: &[u32]| w.iter().map(|&d| FslWord::data(d)).collect::<Vec<_>>();
    let mut bad_origin = head(1);
    bad_origin[1] = nan;
    let mut inf_dir = head(1);
    inf_dir[5] = f32::INFINITY.to_bits();
    let mut zero_dir = head(1);
    zero_dir[4..7].copy_from_slice(&[0, 0x8000_0000, 0]);
    let mut nan_tmax = head(1);
    nan_tmax[7] = nan;

    let cases: Vec<(&str, Vec<FslWord>, FslError, u16)> = vec![
        ("unknown opcode, one word", vec![FslWord::last(0x6000_0000)], FslError::UnknownOpcode, 6),
        ("unknown opcode, longer packet", framed(&[0x7000_0001, 1, 2]), FslError::UnknownOpcode, 7),
        ("control bit in the ray head", framed(&head(1)[..4]), FslError::PacketTooShort, 3),
        (
            "control bit on ray header word",
            vec![FslWord::last(ray_header(RayKind::Any, 1))],
            FslError::PacketTooShort,
            0,
        ),
        ("control bit inside the list", framed(&with_head(2, &[e0[0], e0[1], e0[0]])), FslError::PacketTooShort, 10),
        ("ray without control bit", junk_then_flush(unframed(&with_head(1, &e0))), FslError::MissingControl, 9),
        ("CLEAR without control bit", junk_then_flush(vec![FslWord::data(CLEAR_WORD)]), FslError::MissingControl, 0),
        ("LOAD to PE 9 of 2", framed(&[load_header(9), 3, 0, 0, 0]), FslError::PeOutOfRange, 9),
        ("list entry on PE 9", framed(&with_head(1, &entry_words(entry(0, 9, 1.0)))), FslError::PeOutOfRange, 9),
        (
            "voxel absent from its PE",
            framed(&with_head(2, &[e0[0], e0[1], entry_words(entry(1, 0, 5.0))[0], 0])),
            FslError::VoxelNotLoaded,
            1,
        ),
        (
            "voxel owned by another PE",
            framed(&with_head(1, &entry_words(entry(4, 1, 5.0)))),
            FslError::VoxelNotLoaded,
            0,
        ),
        ("list longer than max_list", framed(&with_head(65, &[0; 130])), FslError::ListTooLong, 64),
        ("LOAD longer than PE memory", framed(&[load_header(1), 257, 1, 2, 3]), FslError::PeMemoryOverflow, 1),
        ("LOAD of inconsistent image", framed(&[load_header(1), 4, 1, 0, 0, 0]), FslError::PeImageMalformed, 1),
        (
            "LOAD with unsorted voxel table",
            load_packet(1, &image(&[(7, vec![0]), (3, vec![0])], &[hit_tri(1.0, 1)])),
            FslError::PeImageMalformed,
            1,
        ),
        (
            "LOAD with duplicate voxel id",
            load_packet(1, &image(&[(3, vec![0]), (3, vec![0])], &[hit_tri(1.0, 1)])),
            FslError::PeImageMalformed,
            1,
        ),
        (
            "LOAD with non-finite vertex",
            load_packet(1, &image(&[(3, vec![0])], &[tri(v(f32::NAN, 0.0, 0.0), Vec3::X, Vec3::Y, 1, 0)])),
            FslError::PeImageMalformed,
            1,
        ),
        (
            "LOAD with material above 16 bits",
            load_packet(1, &image(&[(3, vec![0])], &[tri(Vec3::ZERO, Vec3::X, Vec3::Y, 1, 70_000)])),
            FslError::PeImageMalformed,
            1,
        ),
        ("LOAD of 3 words, control on the 2nd", framed(&[load_header(1), 3, 0, 0]), FslError::PacketTooShort, 3),
        (
            "LOAD without control bit",
            junk_then_flush(unframed(&[load_header(1), 2, 0, 0])),
            FslError::MissingControl,
            3,
        ),
        ("NaN origin", framed(&[&bad_origin[..], &e0[..]].concat()), FslError::NonFiniteRay, 1),
        ("infinite direction", framed(&[&inf_dir[..], &e0[..]].concat()), FslError::NonFiniteRay, 5),
        ("zero direction", framed(&[&zero_dir[..], &e0[..]].concat()), FslError::NonFiniteRay, 4),
        ("NaN t_max", framed(&[&nan_tmax[..], &e0[..]].concat()), FslError::NonFiniteRay, 7),
        ("NaN t_exit", framed(&with_head(1, &[e0[0], nan])), FslError::NonFiniteRay, 9),
    ];
    for (name, words, err, detail) in cases {
        let mut backing = Vec::new();
        let mut cp = loaded(config(2, 256), &mut backing, &images());
        let good = cp.trace(RayKind::Closest, &ray, f32::INFINITY, &good_list()).unwrap();
        push_all(&mut cp, &words);
        assert!(!cp.in_packet(), "{name}: receiver not back at a packet boundary");
        let out = drain(&mut cp);
        assert_eq!(out, vec![FslWord::last(err.to_word(detail))], "{name}");
        assert_eq!(FslError::from_word(out[0].data), (err, detail), "{name}");
        assert_eq!(cp.stats().errors, 1, "{name}");
        push_all(&mut cp, &ray_packet(RayKind::Closest, &ray, f32::INFINITY, &good_list()));
        expect_result(&drain(&mut cp), &good);
    }
}

#[test]
fn ray_before_any_load_and_after_clear_is_scene_not_loaded() {
    let cfg = config(2, 256);
    let mut backing = vec![0; cfg.required_backing_words()];
    let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
    let req = ray_packet(RayKind::Closest, &probe_ray(), f32::INFINITY, &good_list());
    push_all(&mut cp, &req);
    assert_eq!(drain(&mut cp), vec![FslWord::last(FslError::SceneNotLoaded.to_word(0))]);
    assert_eq!(cp.trace(RayKind::Any, &probe_ray(), 1.0, &[]), Err(FslError::SceneNotLoaded));

    push_all(&mut cp, &load_packet(0, &images()[0]));
    assert_eq!(drain(&mut cp), vec![FslWord::last(load_ack(0))]);
    // SPEC §4.4 worked example: LOAD_PE ACK of PE 0 is 91000000, CLEAR's ACK 94000000.
    assert_eq!((load_ack(0), load_ack(3), CLEAR_ACK), (0x9100_0000, 0x9100_0003, 0x9400_0000));
    push_all(&mut cp, &req);
    assert_eq!(drain(&mut cp).len(), 8);

    cp.push(FslWord::last(CLEAR_WORD));
    assert_eq!(drain(&mut cp), vec![FslWord::last(CLEAR_ACK)]);
    assert!(!cp.is_pe_loaded(0));
    push_all(&mut cp, &req);
    assert_eq!(drain(&mut cp), vec![FslWord::last(FslError::SceneNotLoaded.to_word(0))]);
}

/// A LOAD that fails leaves its PE empty (not holding the previous image).
#[test]
fn failed_load_leaves_the_pe_empty() {
    for bad in [
        framed(&[load_header(0), 257]),        // overflow
        framed(&[load_header(0), 3, 1, 0, 0]), // malformed
        vec![FslWord::last(load_header(0))],   // too short
    ] {
        let mut backing = Vec::new();
        let mut cp = loaded(config(2, 256), &mut backing, &images());
        assert!(cp.is_pe_loaded(0));
        push_all(&mut cp, &bad);
        assert_eq!(drain(&mut cp).len(), 1);
        assert!(!cp.is_pe_loaded(0));
        assert_eq!(cp.loaded_pes(), 1);
        assert_eq!(
            cp.trace(RayKind::Closest, &probe_ray(), f32::INFINITY, &good_list()),
            Err(FslError::VoxelNotLoaded)
        );
    }
    let mut backing = Vec::new();
    let mut cp = loaded(config(2, 256), &mut backing, &images());
    assert_eq!(cp.load_pe(0, &[1, 0, 0]), Err(FslError::PeImageMalformed));
    assert!(!cp.is_pe_loaded(0));
    assert_eq!(cp.load_pe(2, &images()[0]), Err(FslError::PeOutOfRange));
    assert_eq!(cp.stats().errors, 2);
}

/// An image of exactly `pe_mem_words` words loads; one word more is refused before any word
/// is stored, by both interfaces.
#[test]
fn pe_memory_limit_is_exact_for_both_interfaces() {
    let mem = 5 + 3 + 11 * 5; // header, 1 voxel, 0 refs, 5 triangles (unreferenced)
    let tris: Vec<_> = (0..5).map(|i| miss_tri(i as f32, i)).collect();
    let fits = image(&[(0, vec![])], &tris);
    assert_eq!(fits.len(), mem);
    let too_big = image(&[(0, vec![0])], &tris);
    let mut backing = vec![0; 2 * mem];
    let mut cp = Coprocessor::new(config(2, mem as u32), &mut backing).unwrap();
    assert_eq!(cp.load_pe(0, &fits), Ok(()));
    assert_eq!(cp.load_pe(1, &too_big), Err(FslError::PeMemoryOverflow));
    push_all(&mut cp, &load_packet(1, &fits));
    assert_eq!(drain(&mut cp), vec![FslWord::last(load_ack(1))]);
    push_all(&mut cp, &load_packet(1, &too_big));
    assert_eq!(drain(&mut cp), vec![FslWord::last(FslError::PeMemoryOverflow.to_word(1))]);
    // PE 0's memory (just below PE 1's) was not touched by the refused load.
    assert_eq!(cp.pe_image(0), Some(&fits[..]));
}

/// Loading via LOAD_PE packets and via `load_pe` yields the same memories and answers.
#[test]
fn loading_via_words_equals_load_pe() {
    use rand::SeedableRng;
    let scene = GridScene::random(77, 30);
    let map = |id: u32| (id % 3) as u8;
    let images = scene.images(3, map);
    let mut b1 = Vec::new();
    let direct = loaded(config(3, 2048), &mut b1, &images);
    let cfg = config(3, 2048);
    let mut b2 = vec![0; cfg.required_backing_words()];
    let mut worded = Coprocessor::new(cfg, &mut b2).unwrap();
    for (pe, img) in images.iter().enumerate() {
        push_all(&mut worded, &load_packet(pe as u8, img));
        assert_eq!(drain(&mut worded), vec![FslWord::last(load_ack(pe as u8))]);
        assert_eq!(worded.pe_image(pe as u8), direct.pe_image(pe as u8));
    }
    let mut direct = direct;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for _ in 0..300 {
        let (ray, t_max) = random_ray(&mut rng);
        let list = scene.list(&ray, map);
        let a = direct.trace(RayKind::Closest, &ray, t_max, &list).unwrap();
        push_all(&mut worded, &ray_packet(RayKind::Closest, &ray, t_max, &list));
        expect_result(&drain(&mut worded), &a);
    }
}

/// The direct API reports the same violations as the word interface.
#[test]
fn direct_api_shares_the_word_validation() {
    let mut backing = Vec::new();
    let mut cp = loaded(config(2, 256), &mut backing, &images());
    let ray = probe_ray();
    let nan_ray = Ray { origin: v(f32::NAN, 0.0, 0.0), ..ray };
    let zero = Ray { dir: Vec3::ZERO, ..ray };
    let long: Vec<_> = (0..65).map(|_| entry(0, 0, 1.0)).collect();
    let cases: [(Ray, f32, Vec<ListEntry>, FslError); 7] = [
        (nan_ray, 1.0, good_list(), FslError::NonFiniteRay),
        (zero, 1.0, good_list(), FslError::NonFiniteRay),
        (ray, f32::NAN, good_list(), FslError::NonFiniteRay),
        (ray, 1.0, vec![entry(0, 0, f32::NAN)], FslError::NonFiniteRay),
        (ray, 1.0, vec![entry(0, 7, 1.0)], FslError::PeOutOfRange),
        (ray, 1.0, vec![entry(9, 0, 1.0)], FslError::VoxelNotLoaded),
        (ray, 1.0, long, FslError::ListTooLong),
    ];
    for (i, (r, t_max, list, err)) in cases.into_iter().enumerate() {
        assert_eq!(cp.trace(RayKind::Closest, &r, t_max, &list), Err(err), "case {i}");
        assert_eq!(cp.trace_untimed(RayKind::Closest, &r, t_max, &list), Err(err), "case {i}");
        push_all(&mut cp, &ray_packet(RayKind::Closest, &r, t_max, &list));
        let out = drain(&mut cp);
        assert_eq!(out.len(), 1, "case {i}");
        assert_eq!(FslError::from_word(out[0].data).0, err, "case {i}");
    }
    // Voxel ids beyond 24 bits cannot be sent; the direct API refuses them.
    assert_eq!(cp.trace(RayKind::Closest, &ray, 1.0, &[entry(1 << 24, 0, 1.0)]), Err(FslError::VoxelOutOfRange));
    assert_eq!(cp.stats().errors, 2 * 7 + 1);
}

/// Replies that do not fit the output queue are dropped and counted, never a panic.
#[test]
fn full_output_queue_drops_and_counts_instead_of_panicking() {
    let cfg = config(1, 16);
    let mut backing = vec![0; cfg.required_backing_words()];
    let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
    for _ in 0..OUT_QUEUE_WORDS + 5 {
        assert_eq!(cp.can_push(), cp.out_len() + 8 <= OUT_QUEUE_WORDS);
        cp.push(FslWord::last(CLEAR_WORD));
    }
    assert_eq!(cp.out_len(), OUT_QUEUE_WORDS);
    assert_eq!(cp.stats().out_dropped, 5);
    assert_eq!(drain(&mut cp).len(), OUT_QUEUE_WORDS);
}

/// Arbitrary word streams never panic and always leave a sane state (seeded fuzz).
#[test]
fn random_word_streams_never_panic() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0xF022);
    let mut backing = Vec::new();
    let mut cp = loaded(config(2, 256), &mut backing, &images());
    let valid = ray_packet(RayKind::Closest, &probe_ray(), f32::INFINITY, &good_list());
    for _ in 0..200_000 {
        let w = match rng.gen_range(0..4) {
            0 => FslWord { data: rng.gen(), control: rng.gen_bool(0.1) },
            1 => FslWord { data: (rng.gen_range(0..16u32) << 28) | rng.gen_range(0..4u32), control: rng.gen_bool(0.3) },
            2 => valid[rng.gen_range(0..valid.len())],
            _ => FslWord { data: rng.gen_range(0..300), control: rng.gen_bool(0.05) },
        };
        cp.push(w);
        while cp.pop().is_some() {}
    }
    assert!(cp.stats().errors > 0);
}

/// Configurations are validated and the backing size is checked.
#[test]
fn configuration_is_validated() {
    let mut small = vec![0u32; 10];
    assert_eq!(config(2, 8).required_backing_words(), 16);
    assert_eq!(
        Coprocessor::new(config(2, 8), &mut small).err(),
        Some(ConfigError::BackingTooSmall { need: 16, have: 10 })
    );
    assert_eq!(Coprocessor::new(config(0, 8), &mut small).err(), Some(ConfigError::PeCount));
    assert_eq!(Coprocessor::new(config(256, 8), &mut small).err(), Some(ConfigError::PeCount));
    assert_eq!(Coprocessor::new(config(1, 0), &mut small).err(), Some(ConfigError::PeMemWords));
    let long = CoprocConfig { max_list: LIST_CAPACITY as u16 + 1, ..config(1, 8) };
    assert_eq!(Coprocessor::new(long, &mut small).err(), Some(ConfigError::MaxList));
    assert!(Coprocessor::new(config(1, 8), &mut small).is_ok());
    assert_eq!(CoprocConfig::GRIDRT.required_backing_words(), 4 * 8192);
}

/// SPEC §4.4 / §5.7 worked example as literal words: the LOAD_PE packet of the tiny scene's
/// PE 0 is acknowledged with `91000000`; a ray down onto its triangle returns these 8 words.
#[test]
fn golden_spec_tiny_scene_load_and_ray() {
    let packet: [u32; 22] = [
        0x1000_0000,
        0x0000_0014,
        0xFFFF_0002,
        0x0000_0001,
        0x0000_0001,
        0x0000_0001,
        0x0000_0000,
        0x0000_0000,
        0x0000_0000,
        0x0000_0001,
        0x0000_0000,
        0x3E80_0000,
        0x3E80_0000,
        0x3F00_0000,
        0x3F40_0000,
        0x3E80_0000,
        0x3F00_0000,
        0x3E80_0000,
        0x3F40_0000,
        0x3F00_0000,
        0x0000_0000,
        0x0000_0000,
    ];
    let cfg = CoprocConfig { timing: TimingProfile::GRIDRT, ..config(1, 64) };
    let mut backing = vec![0; cfg.required_backing_words()];
    let mut cp = Coprocessor::new(cfg, &mut backing).unwrap();
    push_all(&mut cp, &framed(&packet));
    assert_eq!(drain(&mut cp), vec![FslWord::last(0x9100_0000)]);
    // Origin (0.375, 0.375, 2), direction (0, 0, −1), voxel 0 left at t = 2.
    let ray = Ray { origin: v(0.375, 0.375, 2.0), dir: v(0.0, 0.0, -1.0) };
    push_all(&mut cp, &ray_packet(RayKind::Closest, &ray, f32::INFINITY, &[entry(0, 0, 2.0)]));
    let out: Vec<u32> = drain(&mut cp).iter().map(|w| w.data).collect();
    // hit, t = 1.5, prim 0, 1 test, normal (0, 0, 0.25), 10 + 70 + 648 + 4 + 8 = 740 cycles.
    assert_eq!(out, [0x8000_0001, 0x3FC0_0000, 0, 0x0001_0000, 0, 0, 0x3E80_0000, 740]);
}

/// SPEC §4.3: the acceptance limit is fl32(t_exit × 0x3F800800), e.g. 1.5 → 0x3FC00C00.
#[test]
fn golden_spec_acceptance_limit_constant() {
    assert_eq!((1.0f32 + T_EXIT_REL_TOL).to_bits(), 0x3F80_0800);
    assert_eq!((1.5f32 * (1.0 + T_EXIT_REL_TOL)).to_bits(), 0x3FC0_0C00);
}

/// A ray port answers every ray packet, good or bad, with the words the co-processor
/// itself gives (cycles and test counts included), and cannot load a PE.
#[test]
fn ray_port_answers_word_for_word_like_its_coprocessor_and_refuses_loads() {
    use rand::SeedableRng;
    let scene = GridScene::random(7, 40);
    let map = |id: u32| (id % 3) as u8;
    let mut backing = Vec::new();
    let mut cp = loaded(config(3, 4096), &mut backing, &scene.images(3, map));
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(14);
    let mut packets = Vec::new();
    for i in 0..300 {
        let (ray, t_max) = random_ray(&mut rng);
        let kind = if i % 3 == 0 { RayKind::Any } else { RayKind::Closest };
        let mut list = scene.list(&ray, map);
        if i % 50 == 7 {
            list.push(entry(6, 2, 1.0)); // not loaded on PE 2 (or mapped elsewhere): an ERROR word
        }
        packets.push(ray_packet(kind, &ray, t_max, &list));
    }
    let mut from_cp = Vec::new();
    for p in &packets {
        push_all(&mut cp, p);
        from_cp.push(drain(&mut cp));
    }
    let mut port = cp.ray_port();
    let mut from_port = Vec::new();
    for p in &packets {
        p.iter().for_each(|&w| port.push(w));
        from_port.push(core::iter::from_fn(|| port.pop()).collect::<Vec<_>>());
    }
    assert_eq!(from_port, from_cp);
    assert!(from_cp.iter().any(|r| r.len() == 1), "some packets must be refused");
    assert_eq!(port.stats().rays, cp.stats().rays);
    let img = scene.images(3, map).remove(0);
    load_packet(0, &img).iter().for_each(|&w| port.push(w));
    assert_eq!(
        core::iter::from_fn(|| port.pop()).collect::<Vec<_>>(),
        [FslWord::last(FslError::Unsupported.to_word(0))]
    );
    assert!(cp.is_pe_loaded(0));
}

//! The loopback simulator on several threads sends, byte for byte, what it sends on one:
//! seeded cameras, sizes, encodings, plans and regions over four scenes, and a frame that
//! fails halfway.

use std::io::{Read, Write};
use std::path::Path;
use std::time::Duration;

use gridrt_host::grid::GridParams;
use gridrt_host::plan::Plan;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{Session, SessionConfig};
use gridrt_loopback::{SimConfig, SimPort};
use gridrt_shared::frame::{encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED};
use gridrt_shared::msg::{render_flags, Msg, MsgType, PixelEncoding, Region, RenderRequest};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn prepared(name: &str, m: f64) -> PreparedScene {
    let scene =
        gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)).unwrap();
    PreparedScene::new(scene, &GridParams { pe_count: 4, pe_mem_words: 1 << 18, m, ..Default::default() }).unwrap()
}

/// A simulated board with `prepared` loaded, its port handed back for raw frames.
fn board(config: SimConfig, prepared: &PreparedScene) -> SimPort {
    let mut port = gridrt_loopback::spawn(config);
    port.set_timeout(Duration::from_millis(500));
    // No retransmission (timers far above any answer time on a loaded machine) and one chunk
    // in flight: the device sends the same frames during hello and upload, and so reaches
    // the render with the same sequence number, however the threads were scheduled.
    let cfg = SessionConfig::new("sim")
        .hello_timeout(Duration::from_secs(60))
        .turnaround(Duration::from_secs(60))
        .render_timeout(Duration::from_secs(60))
        .window(1);
    let mut s = Session::new(port, cfg);
    s.hello(&mut |_| {}).unwrap();
    s.upload_scene(&prepared.image, &mut |_| {}).unwrap();
    let mut port = s.into_inner();
    port.set_timeout(Duration::from_secs(60));
    port
}

/// Sends `msg` and returns every byte the device sends until it ends the frame (`FrameEnd`,
/// `RegionEnd` or `Error`).
fn exchange(port: &mut SimPort, msg: &Msg<'_>, seq: u16) -> Vec<u8> {
    let mut p = [0u8; 256];
    let n = msg.encode(&mut p).unwrap();
    let mut w = [0u8; MAX_ENCODED];
    let len = encode_frame(msg.kind() as u8, seq, &p[..n], &mut w).unwrap();
    port.write_all(&w[..len]).unwrap();
    let mut acc = FrameAccumulator::<MAX_ENCODED>::new();
    let mut wire = Vec::new();
    let mut buf = [0u8; 4096];
    loop {
        let k = port.read(&mut buf).expect("the device ends every frame");
        wire.extend_from_slice(&buf[..k]);
        let mut input = &buf[..k];
        loop {
            match acc.feed(input) {
                FeedResult::Frame { frame, rest } => {
                    let end = [MsgType::FrameEnd, MsgType::RegionEnd, MsgType::Error];
                    if end.iter().any(|&t| t as u8 == frame.kind) {
                        assert!(rest.is_empty(), "nothing follows the end of a frame");
                        return wire;
                    }
                    input = rest;
                }
                FeedResult::Consumed => break,
                FeedResult::BadFrame { .. } | FeedResult::Overflow { .. } => panic!("bad frame from the device"),
            }
        }
    }
}

/// Seeded requests around `prepared`'s scene: sizes that leave partial bands, every
/// encoding, shadows and prim ids on and off, the scene's plan, a region, an interpolated
/// frame.
fn requests(prepared: &PreparedScene, seed: u64) -> Vec<Msg<'static>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let base = RenderSettings::default_for(&prepared.grid.mesh_bounds);
    let plan = Plan::derive(&prepared.scene).flags();
    let mut out = Vec::new();
    for i in 0..5u16 {
        let (w, h) = (rng.gen_range(90..200), rng.gen_range(60..150));
        let mut req: RenderRequest = base.with_size(w, h).to_request(i);
        // The default eye turned about the vertical through the target, raised or lowered
        // and moved nearer or farther.
        let (a, k, lift) = (rng.gen_range(-1.2f32..1.2), rng.gen_range(0.7f32..1.3), rng.gen_range(-0.4f32..0.4));
        let d = [0, 1, 2].map(|j| req.eye[j] - req.target[j]);
        let len = d.iter().map(|c| c * c).sum::<f32>().sqrt();
        let (s, c) = a.sin_cos();
        let turned = [c * d[0] + s * d[2], d[1] + lift * len, -s * d[0] + c * d[2]];
        req.eye = [0, 1, 2].map(|j| req.target[j] + k * turned[j]);
        req.flags = plan;
        if rng.gen_bool(0.3) {
            req.flags &= !render_flags::SHADOWS;
        }
        if rng.gen_bool(0.5) {
            req.flags |= render_flags::PRIM_IDS;
        }
        req.encoding = [PixelEncoding::Rgb888, PixelEncoding::Rgb565, PixelEncoding::Rle][i as usize % 3];
        out.push(Msg::RenderRequest(req));
        if i == 3 {
            let region = Region { x0: w / 5, y0: h / 7, cols: w / 2, rows: h - h / 7 - 1 };
            out.push(Msg::RenderRegion { region, max_span: 37, options: 0, request: req });
        }
        if i == 4 {
            req.flags |= 3 << render_flags::INTERP_STEP_SHIFT | 8 << render_flags::INTERP_EPS_SHIFT;
            out.push(Msg::RenderRequest(req));
        }
    }
    out
}

/// Every byte of the answers to `msgs` from a board with `threads`.
fn wire(config: SimConfig, prepared: &PreparedScene, msgs: &[Msg<'_>]) -> Vec<Vec<u8>> {
    let mut port = board(config, prepared);
    msgs.iter().zip(10u16..).map(|(m, seq)| exchange(&mut port, m, seq)).collect()
}

#[test]
fn uart_bytes_do_not_depend_on_the_thread_count() {
    for (i, (name, m)) in
        [("viray_demo.toml", 1.0), ("bun_zipper_res4.obj", 2.0), ("teapot.obj", 1.0), ("suzanne.obj", 1.0)]
            .into_iter()
            .enumerate()
    {
        let p = prepared(name, m);
        let msgs = requests(&p, 14 + i as u64);
        let one = wire(SimConfig { threads: 1, ..SimConfig::default() }, &p, &msgs);
        for threads in [0, 3] {
            let farmed = gridrt_loopback::farmed_frames();
            let many = wire(SimConfig { threads, ..SimConfig::default() }, &p, &msgs);
            // Every frame but the interpolated one went through the farm.
            assert!(gridrt_loopback::farmed_frames() - farmed >= msgs.len() as u64 - 1, "{name}: the farm did not run");
            for (k, (a, b)) in one.iter().zip(&many).enumerate() {
                let at = a.iter().zip(b.iter()).position(|(x, y)| x != y);
                assert!(
                    a == b,
                    "{name}, message {k}, {threads} threads: {} bytes against {}, first difference at {at:?}",
                    b.len(),
                    a.len()
                );
            }
        }
        // The frames are real: pixels went out (not just errors).
        assert!(one.iter().all(|w| w.len() > 1000), "{name}: {:?}", one.iter().map(Vec::len).collect::<Vec<_>>());
    }
}

/// A frame that fails halfway (lists longer than the co-processor takes): the spans before
/// the failing pixel, then the same `Error`, whatever thread traced which row.
#[test]
fn a_frame_that_fails_halfway_sends_the_same_bytes_on_every_thread_count() {
    let p = prepared("bun_zipper_res4.obj", 3.0);
    let req = RenderSettings::default_for(&p.grid.mesh_bounds).with_size(160, 120).to_request(1);
    let msgs = [Msg::RenderRequest(req)];
    let config = |threads| SimConfig { threads, max_list: 6, ..SimConfig::default() };
    let one = wire(config(1), &p, &msgs);
    let mut acc = FrameAccumulator::<MAX_ENCODED>::new();
    let (mut spans, mut errors, mut input) = (0, 0, &one[0][..]);
    while let FeedResult::Frame { frame, rest } = acc.feed(input) {
        spans += (frame.kind == MsgType::PixelSpan as u8) as u32;
        errors += (frame.kind == MsgType::Error as u8) as u32;
        input = rest;
    }
    assert!(spans > 20 && errors == 1, "the frame must fail after some rows: {spans} spans, {errors} errors");
    for threads in [0, 2, 3] {
        assert!(wire(config(threads), &p, &msgs) == one, "{threads} threads");
    }
}

//! Fault injection: a lossy relay between the host session and the simulated
//! board flips bits (BER 1e-5, 1e-4, 1e-3), drops bytes, inserts garbage bursts and resets the
//! board mid-frame. Under every mix the final PNG must be byte-identical to a fault-free run
//! (no corrupted pixel is ever accepted), and the stats must show the retransmissions.
//!
//! Small frames (64×48) keep the suite fast; one 320×240 bunny frame checks the full size.

#[path = "support/fault_relay.rs"]
mod fault_relay;

use std::path::Path;
use std::sync::OnceLock;
use std::time::Duration;

use fault_relay::{Faults, FaultyPort};
use gridrt_host::grid::GridParams;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{LinkStats, RenderedFrame, Session, SessionConfig};
use gridrt_shared::msg::{PixelEncoding, RenderRequest};

struct Scene {
    image: Vec<u8>,
    settings: RenderSettings,
}

fn prepare(name: &str, w: u16, h: u16) -> Scene {
    let mesh = gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(name)).unwrap();
    let prepared =
        PreparedScene::new(mesh, &GridParams { pe_count: 4, pe_mem_words: 1 << 20, ..Default::default() }).unwrap();
    Scene { image: prepared.image, settings: RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(w, h) }
}

fn cornell() -> &'static Scene {
    static S: OnceLock<Scene> = OnceLock::new();
    S.get_or_init(|| prepare("cornell_box.obj", 64, 48))
}

fn request(s: &Scene, enc: PixelEncoding, prim_ids: bool) -> RenderRequest {
    RenderRequest { encoding: enc, ..s.settings.with_prim_ids(prim_ids).to_request(1) }
}

fn config() -> SessionConfig {
    // The in-process simulator is not paced: time the waits as for a fast line.
    SessionConfig::new("sim+faults")
        .baud(3_000_000)
        .turnaround(Duration::from_millis(20))
        .hello_timeout(Duration::from_secs(3))
        .render_timeout(Duration::from_secs(20))
        .max_probes(50)
}

fn png(f: &RenderedFrame) -> Vec<u8> {
    let img = image::RgbImage::from_raw(f.width as u32, f.height as u32, f.rgb.clone()).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// Hello, upload and render through the relay; hello/upload see the faults too unless
/// `clean_setup`.
/// Returns the frame, what the relay injected, and the session's link counters (upload included).
fn run(
    scene: &Scene,
    req: &RenderRequest,
    up: Faults,
    down: Faults,
    seed: u64,
    resets: Vec<u64>,
    clean_setup: bool,
) -> (RenderedFrame, fault_relay::Injected, LinkStats) {
    let mut sim = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
    sim.set_timeout(Duration::from_millis(5));
    let mut port = FaultyPort::new(sim, up, down, seed).reset_at(resets);
    port.active = !clean_setup;
    let mut s = Session::new(port, config());
    let mut hello = None;
    for _ in 0..20 {
        match s.hello(&mut |_| {}) {
            Ok(i) => {
                hello = Some(i);
                break;
            }
            Err(e) => eprintln!("hello retry: {e}"),
        }
    }
    hello.expect("hello through the faulty link");
    s.upload_scene(&scene.image, &mut |_| {}).unwrap();
    s.port_mut().active = true;
    let f = s.render(req, &mut |_| {}).unwrap_or_else(|e| panic!("render failed: {e}"));
    let injected = s.port_mut().injected();
    let total = s.link_stats().clone();
    (f, injected, total)
}

fn clean(scene: &Scene, req: &RenderRequest) -> RenderedFrame {
    run(scene, req, Faults::default(), Faults::default(), 0, vec![], true).0
}

fn assert_identical(got: &RenderedFrame, want: &RenderedFrame, what: &str) {
    assert_eq!(got.rgb.len(), want.rgb.len());
    let bad = got.rgb.chunks(3).zip(want.rgb.chunks(3)).filter(|(a, b)| a != b).count();
    assert_eq!(bad, 0, "{what}: {bad} pixels differ");
    assert_eq!(got.prim_ids, want.prim_ids, "{what}: primitive ids");
    assert_eq!(png(got), png(want), "{what}: PNG bytes");
}

#[test]
fn fault_free_run_has_no_retransmissions() {
    let s = cornell();
    let f = clean(s, &request(s, PixelEncoding::Rle, true));
    let l = &f.link;
    assert_eq!(
        (l.regions_requested, l.regions_resent, l.crc_errors, l.resyncs, l.seq_gaps, l.timeouts),
        (1, 0, 0, 0, 0, 0),
        "{l:?}"
    );
}

#[test]
fn bit_errors_1e5_1e4_1e3_give_the_fault_free_png() {
    let s = cornell();
    for enc in [PixelEncoding::Rle, PixelEncoding::Rgb888] {
        let req = request(s, enc, false);
        let want = clean(s, &req);
        for (i, ber) in [1e-5, 1e-4, 1e-3].into_iter().enumerate() {
            let (got, inj, total) = run(s, &req, Faults::ber(ber), Faults::ber(ber), 100 + i as u64, vec![], false);
            assert_identical(&got, &want, &format!("{enc:?} BER {ber}"));
            let l = &got.link;
            eprintln!("{enc:?} BER {ber}: {inj:?}\n  render {l:?}\n  session {total:?}");
            if ber >= 1e-4 {
                // Some flips hit the upload or the render; each cost a dropped frame somewhere.
                assert!(inj.flips > 0);
                assert!(total.crc_errors + total.resyncs + total.device_bad_frames > 0, "{enc:?} BER {ber}: {total:?}");
            }
            if ber >= 1e-3 {
                assert!(l.crc_errors > 0 && l.regions_resent > 0 && l.spans_resent > 0, "{enc:?} BER {ber}: {l:?}");
            }
        }
    }
}

#[test]
fn dropped_bytes_and_garbage_bursts_give_the_fault_free_png() {
    let s = cornell();
    let req = request(s, PixelEncoding::Rle, true);
    let want = clean(s, &req);
    let mixes = [
        ("drops", Faults { drop: 2e-4, ..Faults::default() }),
        ("bursts", Faults { burst: 2e-4, burst_max: 64, ..Faults::default() }),
        ("all", Faults { ber: 1e-4, drop: 1e-4, burst: 1e-4, burst_max: 32 }),
    ];
    for (i, (name, f)) in mixes.into_iter().enumerate() {
        let (got, inj, total) = run(s, &req, f, f, 200 + i as u64, vec![], false);
        eprintln!("{name}: {inj:?}\n  render {:?}\n  session {total:?}", got.link);
        assert_identical(&got, &want, name);
        assert!(inj.drops + inj.bursts > 0, "{name}: {inj:?}");
        assert!(total.resyncs + total.device_bad_frames > 0, "{name}: {total:?}");
    }
}

#[test]
fn device_reset_mid_frame_is_survived() {
    let s = cornell();
    for (enc, seed) in [(PixelEncoding::Rle, 300), (PixelEncoding::Rgb888, 301)] {
        let req = request(s, enc, false);
        let want = clean(s, &req);
        // Reset after a third of the frame's bytes, and again later.
        let third = want.bytes_rx / 3;
        let (got, inj, _) = run(s, &req, Faults::default(), Faults::default(), seed, vec![third, 5 * third], true);
        eprintln!("{enc:?} reset: {inj:?}\n  {:?}", got.link);
        assert_identical(&got, &want, &format!("{enc:?} reset"));
        assert!(inj.resets >= 1);
        assert!(got.link.device_resets >= 1 && got.link.scene_reuploads >= 1, "{:?}", got.link);
    }
    // Reset plus noise.
    let req = request(s, PixelEncoding::Rle, true);
    let want = clean(s, &req);
    let f = Faults { ber: 1e-4, drop: 5e-5, burst: 5e-5, burst_max: 16 };
    let (got, inj, _) = run(s, &req, f, f, 302, vec![want.bytes_rx / 2], true);
    assert_identical(&got, &want, "reset + noise");
    assert_eq!(inj.resets, 1);
}

#[test]
fn full_size_bunny_frame_survives_every_fault_at_once() {
    static S: OnceLock<Scene> = OnceLock::new();
    let s = S.get_or_init(|| prepare("bun_zipper_res4.obj", 320, 240));
    let req = request(s, PixelEncoding::Rle, false);
    let want = clean(s, &req);
    let f = Faults { ber: 1e-4, drop: 2e-5, burst: 2e-5, burst_max: 32 };
    let (got, inj, _) = run(s, &req, f, f, 400, vec![want.bytes_rx / 2], true);
    eprintln!("320×240: {inj:?}\n  {:?}", got.link);
    assert_identical(&got, &want, "320×240 bunny");
    assert!(got.link.device_resets >= 1 && got.link.regions_resent > 0, "{:?}", got.link);
}

#[test]
fn a_dead_line_times_out_naming_port_stage_and_sequence_numbers() {
    let s = cornell();
    let mut sim = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
    sim.set_timeout(Duration::from_millis(5));
    // Everything from the device is lost once the faults are switched on.
    let mut port = FaultyPort::new(sim, Faults::default(), Faults { drop: 1.0, ..Faults::default() }, 7);
    port.active = false;
    let cfg = config().max_probes(5).render_timeout(Duration::from_millis(300));
    let mut session = Session::new(port, cfg);
    session.hello(&mut |_| {}).unwrap();
    session.upload_scene(&s.image, &mut |_| {}).unwrap();
    session.port_mut().active = true;
    let err = session.render(&request(s, PixelEncoding::Rle, false), &mut |_| {}).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, gridrt_host::session::SessionError::Timeout { .. }), "{text}");
    for part in ["sim+faults", "render", "frame 1", "last sequence number received", "sent:"] {
        assert!(text.contains(part), "`{part}` missing from: {text}");
    }
}

//! The library's session against the loopback simulator, through its byte stream only.

use std::path::Path;
use std::time::Duration;

use gridrt_host::compare::compare;
use gridrt_host::grid::GridParams;
use gridrt_host::reference::{render, Reference, Stages};
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{ProgressEvent, Session, SessionConfig, SessionError, Stage};
use gridrt_shared::msg::ErrorCode;

fn scene(name: &str) -> gridrt_host::scene::Scene {
    gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes").join(name)).unwrap()
}

fn sim(pe_count: u16, pe_mem_words: u32) -> Session<gridrt_loopback::SimPort> {
    let mut port = gridrt_loopback::spawn(gridrt_loopback::SimConfig { pe_count, pe_mem_words, ..Default::default() });
    port.set_timeout(Duration::from_millis(20));
    Session::new(port, SessionConfig::new("sim").render_timeout(Duration::from_secs(60)))
}

#[test]
fn sim_frame_is_identical_to_the_f64_reference() {
    let mut s = sim(3, 1 << 16);
    let info = s.hello(&mut |_| {}).unwrap();
    assert_eq!(info.pe_count, 3);
    let prepared = PreparedScene::new(
        scene("bun_zipper_res4.obj"),
        &GridParams { pe_count: 3, pe_mem_words: 1 << 16, m: 2.0, ..Default::default() },
    )
    .unwrap();
    let mut events = Vec::new();
    s.upload_scene(&prepared.image, &mut |e| events.push(e)).unwrap();
    assert!(matches!(events.last(), Some(ProgressEvent::UploadFinished { .. })));
    let settings = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(96, 72).with_prim_ids(true);
    let frame = s.render(&settings.to_request(9), &mut |_| {}).unwrap();
    assert!(frame.bytes_rx > 96 * 72 * 3);
    let reference = render(&Reference::new(&prepared.scene, &prepared.grid.bounds), &settings, Stages::ALL, 2);
    let c = compare(&frame.rgb, &reference.rgb, frame.prim_ids.as_deref(), Some(&reference.prim_ids)).unwrap();
    // The claim (docs/bench-accuracy.md): images identical to the f64 reference. Primitive ids
    // may differ only where a ray hits an edge two triangles share (f32 and f64 round the tie
    // apart): 1 of the 786 hit pixels here.
    assert!(c.identical, "{c:?}");
    let hits = reference.prim_ids.iter().filter(|&&p| p != u32::MAX).count() as u64;
    assert!(hits > 300, "the bunny must be in view");
    assert!(c.hit_mismatches.is_some_and(|m| m <= 1), "more than one hit on another primitive: {c:?}");
    // A second frame on the same session (the scene stays loaded).
    let again = s.render(&settings.with_prim_ids(false).to_request(10), &mut |_| {}).unwrap();
    assert_eq!(again.rgb, frame.rgb);
    // It sends nothing but its request: one RenderRequest frame (72 bytes of payload, framed)
    // or, with regions, one RenderRegion frame; no scene byte.
    assert!(again.bytes_tx < 120, "the second frame sent {} bytes", again.bytes_tx);
}

#[test]
fn device_rejection_is_a_typed_error() {
    // Built for PE memories larger than the device has: the device must refuse the image.
    let mut s = sim(2, 4096);
    s.hello(&mut |_| {}).unwrap();
    let prepared = PreparedScene::new(
        scene("bun_zipper_res4.obj"),
        &GridParams { pe_count: 2, pe_mem_words: 1 << 20, ..Default::default() },
    )
    .unwrap();
    let err = s.upload_scene(&prepared.image, &mut |_| {}).unwrap_err();
    assert!(matches!(err, SessionError::Device { stage: Stage::Upload, code: ErrorCode::SceneRejected, .. }), "{err}");
    // Rendering without a scene is refused too.
    let settings = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(8, 8);
    let err = s.render(&settings.to_request(1), &mut |_| {}).unwrap_err();
    assert!(matches!(err, SessionError::Device { stage: Stage::Render, code: ErrorCode::NoScene, .. }), "{err}");
}

/// Tier "pty pair": the session over a real pseudo-terminal (serialport's `TTYPort`), with the
/// simulator bridged onto the other end, exercises the serial transport's timeout behaviour.
#[cfg(unix)]
#[test]
fn session_over_a_pty_pair_renders() {
    use std::io::{Read, Write};
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    use serialport::{SerialPort, TTYPort};

    let (mut device_end, mut host_end) = TTYPort::pair().expect("pty pair");
    device_end.set_timeout(Duration::from_millis(2)).unwrap();
    host_end.set_timeout(Duration::from_millis(20)).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let bridge = {
        let stop = stop.clone();
        std::thread::spawn(move || {
            let mut sim = gridrt_loopback::spawn(gridrt_loopback::SimConfig { pe_count: 2, ..Default::default() });
            sim.set_timeout(Duration::from_millis(2));
            let mut buf = [0u8; 4096];
            while !stop.load(Ordering::Relaxed) {
                if let Ok(n) = device_end.read(&mut buf) {
                    sim.write_all(&buf[..n]).unwrap();
                }
                if let Ok(n) = sim.read(&mut buf) {
                    device_end.write_all(&buf[..n]).unwrap();
                }
            }
        })
    };
    let mut s = Session::new(host_end, SessionConfig::new("pty").render_timeout(Duration::from_secs(30)));
    let info = s.hello(&mut |_| {}).unwrap();
    let prepared = PreparedScene::new(
        scene("cornell_box.obj"),
        &GridParams { pe_count: info.pe_count, pe_mem_words: info.pe_mem_words, ..Default::default() },
    )
    .unwrap();
    s.upload_scene(&prepared.image, &mut |_| {}).unwrap();
    let settings = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(40, 30);
    let frame = s.render(&settings.to_request(1), &mut |_| {}).unwrap();
    assert_eq!(frame.rgb.len(), 40 * 30 * 3);
    stop.store(true, Ordering::Relaxed);
    bridge.join().unwrap();
}

#[test]
fn upload_ignores_a_late_no_scene_answer_to_an_earlier_render() {
    // After a device reset, the answers to render requests sent before it arrive during the
    // re-upload. Here: a render request goes out with no scene loaded and, without waiting
    // for its `NoScene`, the (windowed) upload starts; the answer is not the upload's failure.
    use gridrt_shared::frame::{encode_frame, MAX_ENCODED, MAX_PAYLOAD};
    use gridrt_shared::msg::Msg;
    use std::io::Write;

    let mut s = sim(2, 1 << 16);
    s.hello(&mut |_| {}).unwrap();
    let prepared = PreparedScene::new(
        scene("bun_zipper_res4.obj"),
        &GridParams { pe_count: 2, pe_mem_words: 1 << 16, m: 2.0, ..Default::default() },
    )
    .unwrap();
    let settings = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(16, 12);
    let msg = Msg::RenderRequest(settings.to_request(1));
    let mut payload = [0u8; MAX_PAYLOAD];
    let n = msg.encode(&mut payload).unwrap();
    let mut wire = [0u8; MAX_ENCODED];
    let len = encode_frame(msg.kind() as u8, 40_000, &payload[..n], &mut wire).unwrap();
    s.port_mut().write_all(&wire[..len]).unwrap();
    s.upload_scene(&prepared.image, &mut |_| {}).unwrap();
    let frame = s.render(&settings.to_request(2), &mut |_| {}).unwrap();
    assert_eq!(frame.rgb.len(), 16 * 12 * 3);
}

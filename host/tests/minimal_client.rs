//! SPEC.md §8 ("Minimal client") against the device: a client written from that section
//! alone — raw frames from `gridrt_shared::frame`, messages from `gridrt_shared::msg`, no
//! session code — says Hello, uploads with stop-and-wait `SceneChunk`s, renders whole frames
//! in Rgb888 and checks them by the `FrameEnd` CRC. Its frames must equal the reference host's
//! (`Session`, regions off) for the same requests, and a second frame needs no second upload.

use std::io::{Read, Write};
use std::ops::ControlFlow;
use std::path::Path;
use std::time::{Duration, Instant};

use gridrt_host::grid::GridParams;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{Session, SessionConfig};
use gridrt_loopback::{SimConfig, SimPort};
use gridrt_shared::frame::{crc32, encode_frame, FrameAccumulator, Received, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{render_flags, Msg, PixelEncoding, RenderRequest, SceneStatus};

/// One decoded message: its type byte and payload (owned).
type Owned = (u8, Vec<u8>);

struct MinimalClient {
    port: SimPort,
    seq: u16,
    acc: Box<FrameAccumulator<MAX_ENCODED>>,
    inbox: std::collections::VecDeque<Owned>,
}

impl MinimalClient {
    fn send(&mut self, msg: &Msg) {
        let mut payload = vec![0u8; MAX_PAYLOAD];
        let n = msg.encode(&mut payload).unwrap();
        let mut wire = vec![0u8; MAX_ENCODED];
        let m = encode_frame(msg.kind() as u8, self.seq, &payload[..n], &mut wire).unwrap();
        self.seq = self.seq.wrapping_add(1);
        self.port.write_all(&wire[..m]).unwrap();
    }

    /// The next message within `wait`, frames failing the CRC and stray text dropped (§8).
    fn next(&mut self, wait: Duration) -> Option<Owned> {
        let deadline = Instant::now() + wait;
        let mut buf = [0u8; 4096];
        while self.inbox.is_empty() && Instant::now() < deadline {
            let n = match self.port.read(&mut buf) {
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(e) => panic!("{e}"),
            };
            let inbox = &mut self.inbox;
            self.acc.feed_all(&buf[..n], |r| {
                if let Received::Frame(f) = r {
                    inbox.push_back((f.kind, f.payload.to_vec()));
                }
                ControlFlow::<()>::Continue(())
            });
        }
        self.inbox.pop_front()
    }

    /// §8 step 1: `0x00`, `Hello`, up to 3 s for a `Version`.
    fn hello(&mut self) -> gridrt_shared::msg::DeviceInfo {
        self.port.write_all(&[0]).unwrap();
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(3) {
            self.send(&Msg::Hello { protocol: 1 });
            while let Some((kind, payload)) = self.next(Duration::from_millis(100)) {
                if let Ok(Msg::Version(info)) = Msg::decode(kind, &payload) {
                    assert_eq!(info.protocol, 1);
                    return info;
                }
            }
        }
        panic!("no Version within 3 s");
    }

    /// §8 step 3, stop-and-wait: each chunk answered by `SceneAck`, the last by `Loaded`.
    fn upload(&mut self, image: &[u8], chunk: usize) {
        self.port.write_all(&[0]).unwrap();
        self.send(&Msg::SceneBegin { total_len: image.len() as u32, crc: crc32(image) });
        let mut offset = 0usize;
        while offset < image.len() {
            let end = (offset + chunk).min(image.len());
            self.send(&Msg::SceneChunk { offset: offset as u32, data: &image[offset..end] });
            let (kind, payload) = self.next(Duration::from_secs(5)).expect("an answer to each SceneChunk");
            match Msg::decode(kind, &payload).unwrap() {
                Msg::SceneAck { next_offset, status } => {
                    assert_eq!(next_offset as usize, end);
                    let last = end == image.len();
                    assert_eq!(status, if last { SceneStatus::Loaded } else { SceneStatus::Receiving });
                    offset = end;
                }
                m => panic!("unexpected answer to a SceneChunk: {m:?}"),
            }
        }
    }

    /// §8 step 4: one `RenderRequest`, spans until `FrameEnd`, the CRC of the whole image.
    fn render(&mut self, req: &RenderRequest) -> Vec<u8> {
        let (w, h) = (req.width as usize, req.height as usize);
        let mut rgb = vec![0u8; w * h * 3];
        let mut got = vec![false; w * h];
        self.send(&Msg::RenderRequest(*req));
        loop {
            let (kind, payload) = self.next(Duration::from_secs(30)).expect("a message within render_timeout");
            match Msg::decode(kind, &payload).unwrap() {
                Msg::PixelSpan { frame, y, x0, count, encoding, data } if frame == req.frame => {
                    assert_eq!(encoding, PixelEncoding::Rgb888);
                    let at = y as usize * w + x0 as usize;
                    rgb[at * 3..(at + count as usize) * 3].copy_from_slice(data);
                    got[at..at + count as usize].iter_mut().for_each(|g| *g = true);
                }
                Msg::Stats { .. } => {}
                Msg::FrameEnd { frame, image_crc, .. } if frame == req.frame => {
                    assert!(got.iter().all(|&g| g), "a pixel never arrived");
                    assert_eq!(crc32(&rgb), image_crc, "FrameEnd's CRC");
                    return rgb;
                }
                m => panic!("unexpected during a frame: {m:?}"),
            }
        }
    }
}

/// The simulated board the tests use (2 PEs of 2¹⁶ words).
fn board() -> SimConfig {
    SimConfig { pe_count: 2, pe_mem_words: 1 << 16, ..Default::default() }
}

/// §8 steps 1 and 2: a client on a fresh simulated board (its first sequence number `seq`),
/// after `Hello`, and bun_zipper_res4's image for the device's PEs.
fn connect(seq: u16) -> (MinimalClient, gridrt_shared::msg::DeviceInfo, PreparedScene) {
    let scene =
        gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj"))
            .unwrap();
    let mut port = gridrt_loopback::spawn(board());
    port.set_timeout(Duration::from_millis(20));
    let mut client = MinimalClient { port, seq, acc: Box::new(FrameAccumulator::new()), inbox: Default::default() };
    let info = client.hello();
    let params = GridParams { pe_count: info.pe_count, pe_mem_words: info.pe_mem_words, ..Default::default() };
    (client, info, PreparedScene::new(scene, &params).unwrap())
}

#[test]
fn a_client_written_from_spec_section_8_renders_the_reference_hosts_frames() {
    let (mut client, info, prepared) = connect(7);
    let chunk = 1024.min(info.max_payload as usize - 4);
    client.upload(&prepared.image, chunk);

    let settings = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(40, 30);
    let mut first = settings.to_request(1);
    first.flags |= render_flags::SHADOWS;
    first.encoding = PixelEncoding::Rgb888;
    let mut second = RenderSettings { width: 24, height: 16, ..settings }.to_request(2);
    second.encoding = PixelEncoding::Rgb888;
    // §8 step 5: the scene stays loaded; the second frame needs only its request.
    let frames = [client.render(&first), client.render(&second)];

    let mut port = gridrt_loopback::spawn(board());
    port.set_timeout(Duration::from_millis(20));
    let mut host = Session::new(port, SessionConfig::new("sim").regions(false));
    host.hello(&mut |_| {}).unwrap();
    host.upload_scene(&prepared.image, &mut |_| {}).unwrap();
    for (req, rgb) in [first, second].iter().zip(&frames) {
        let frame = host.render(req, &mut |_| {}).unwrap();
        assert_eq!(&frame.rgb, rgb, "frame {}: the minimal client's image differs from the host's", req.frame);
    }
    assert!(frames[0].chunks(3).any(|p| p != &frames[0][..3]), "the bunny must be in view");
}

/// The compact upload (SPEC.md §5.12) through the same raw client: a stream whose content was
/// corrupted after it was encoded (its transport CRC recomputed, so only the decoder can
/// tell), or cut short, is refused with `SceneRejected`, never loaded; the intact stream
/// then loads and renders the same frame as the plain image.
#[test]
fn a_corrupted_or_cut_compact_upload_is_refused_and_the_intact_one_renders() {
    use gridrt_shared::msg::{feature, ErrorCode};
    let (mut client, info, prepared) = connect(0);
    assert_ne!(info.features & feature::COMPACT_SCENE, 0, "the simulated board decodes compact streams");
    let stream = gridrt_host::compact::encode(&prepared.image, gridrt_host::compact::CACHE_LOG2).unwrap();
    assert!(stream.len() * 2 < prepared.image.len(), "{} of {} bytes", stream.len(), prepared.image.len());

    let mut flipped = stream.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x5A;
    let cut = &stream[..stream.len() - 7];
    for (what, bad) in [("flipped", &flipped[..]), ("cut", cut)] {
        client.port.write_all(&[0]).unwrap();
        client.send(&Msg::SceneBegin { total_len: bad.len() as u32, crc: crc32(bad) });
        let mut refused = None;
        'upload: for (k, c) in bad.chunks(512).enumerate() {
            client.send(&Msg::SceneChunk { offset: (k * 512) as u32, data: c });
            let (kind, payload) = client.next(Duration::from_secs(5)).expect("an answer to each SceneChunk");
            match Msg::decode(kind, &payload).unwrap() {
                Msg::SceneAck { status, .. } => assert_ne!(status, SceneStatus::Loaded, "{what}: loaded"),
                Msg::Error { code, detail, .. } => {
                    refused = Some((code, detail));
                    break 'upload;
                }
                m => panic!("{what}: {m:?}"),
            }
        }
        let (code, _) = refused.unwrap_or_else(|| panic!("{what}: the device never refused the stream"));
        assert_eq!(code, ErrorCode::SceneRejected, "{what}");
    }

    client.upload(&stream, 512);
    let mut req = RenderSettings::default_for(&prepared.grid.mesh_bounds).with_size(32, 24).to_request(3);
    req.encoding = PixelEncoding::Rgb888;
    let compact_frame = client.render(&req);
    client.upload(&prepared.image, 512);
    req.frame = 4;
    assert_eq!(client.render(&req), compact_frame, "the compact and the plain upload render the same frame");
}

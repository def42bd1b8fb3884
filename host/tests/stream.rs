//! Frames as a stream (`gridrt_host::stream`) on the loopback simulator: rows are reported
//! as they arrive, long before the frame's end; several boards share every frame of a stream
//! in row bands and give the single board's pixels; the statistics add up.

use std::io::{Read, Write};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use gridrt_host::camera_path::CameraPath;
use gridrt_host::grid::GridParams;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{ProgressEvent, Session, SessionConfig};
use gridrt_host::stream::{self, StreamEvent, StreamPlan};
use gridrt_shared::msg::PixelEncoding;

fn prepared() -> PreparedScene {
    let mesh =
        gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj"))
            .unwrap();
    PreparedScene::new(mesh, &GridParams { pe_count: 4, pe_mem_words: 1 << 20, ..Default::default() }).unwrap()
}

/// A simulated board's port that counts the bytes the host has read.
struct Counting {
    sim: gridrt_loopback::SimPort,
    read: Arc<AtomicU64>,
    written: Arc<AtomicU64>,
}

impl Read for Counting {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.sim.read(buf)?;
        self.read.fetch_add(n as u64, Ordering::SeqCst);
        Ok(n)
    }
}

impl Write for Counting {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.sim.write(buf)?;
        self.written.fetch_add(n as u64, Ordering::SeqCst);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.sim.flush()
    }
}

fn board(p: &PreparedScene, name: &str, read: Arc<AtomicU64>) -> Session<Counting> {
    board_w(p, name, read, Arc::default())
}

fn board_w(p: &PreparedScene, name: &str, read: Arc<AtomicU64>, written: Arc<AtomicU64>) -> Session<Counting> {
    let mut sim = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
    sim.set_timeout(Duration::from_millis(10));
    let cfg = SessionConfig::new(name).baud(3_000_000).render_timeout(Duration::from_secs(60));
    let mut s = Session::new(Counting { sim, read, written }, cfg);
    s.hello(&mut |_| {}).unwrap();
    s.upload_scene(&p.image, &mut |_| {}).unwrap();
    s
}

fn plan(p: &PreparedScene, w: u16, h: u16, frames: u32) -> StreamPlan {
    let settings = p.scene.settings.with_size(w, h);
    let centre = p.scene.bounds().unwrap().center();
    StreamPlan {
        request: gridrt_shared::msg::RenderRequest { encoding: PixelEncoding::Rle, ..settings.to_request(1) },
        base: settings.camera,
        path: CameraPath::Orbit { degrees: 360.0, centre },
        frames,
        band_rows: 0,
        baud: 3_000_000,
    }
}

#[test]
fn rows_are_reported_as_they_arrive_not_at_the_frames_end() {
    let p = prepared();
    let (read, written) = (Arc::new(AtomicU64::new(0)), Arc::new(AtomicU64::new(0)));
    let mut sessions = vec![board_w(&p, "sim", read.clone(), written.clone())];
    let written0 = written.load(Ordering::SeqCst);
    let mut written_at_first_end = 0;
    let (w, h) = (64u16, 48u16);
    // Per frame: the bytes read when each row was reported, and at the frame's end.
    let mut at_rows: Vec<Vec<u64>> = Vec::new();
    let mut at_end: Vec<u64> = Vec::new();
    let mut rows_seen: Vec<Vec<u16>> = Vec::new();
    let r = stream::run(&mut sessions, &plan(&p, w, h, 2), &mut |e| {
        match e {
            StreamEvent::FrameStarted { .. } => {
                at_rows.push(Vec::new());
                rows_seen.push(Vec::new());
            }
            StreamEvent::Progress(ProgressEvent::RowArrived { y, x0, rgb }) => {
                assert_eq!((x0, rgb.len()), (0, 3 * w as usize));
                at_rows.last_mut().unwrap().push(read.load(Ordering::SeqCst));
                rows_seen.last_mut().unwrap().push(y);
            }
            StreamEvent::FrameDone { report, .. } => {
                at_end.push(read.load(Ordering::SeqCst));
                if report.index == 0 {
                    written_at_first_end = written.load(Ordering::SeqCst) - written0;
                }
            }
            StreamEvent::Progress(_) => {}
        }
        Ok(())
    })
    .unwrap();
    assert_eq!(r.frames.len(), 2);
    // The simulator queues requests: frame 1 was asked for before frame 0 was in (two
    // `RenderRegion`s of 97 wire bytes each, delimiter included).
    assert!(r.requested_ahead);
    assert!(written_at_first_end >= 2 * 97, "{written_at_first_end} B sent when frame 0 was complete");
    for (i, rows) in rows_seen.iter().enumerate() {
        let mut sorted = rows.clone();
        sorted.sort();
        assert_eq!(sorted, (0..h).collect::<Vec<_>>(), "frame {i}: every row reported once");
    }
    let start = at_end[0] - r.frames[0].wire_rx; // bytes read before frame 0's request
    for (i, (rows, end)) in at_rows.iter().zip(&at_end).enumerate() {
        let begin = if i == 0 { start } else { at_end[i - 1] };
        let frame = end - begin;
        // Row k is reported while the frame's bytes are still coming: the first row before a
        // quarter of them, the middle row before three quarters.
        assert!(rows[0] - begin < frame / 4, "frame {i}: the first row only after {} of {frame} B", rows[0] - begin);
        let mid = rows[h as usize / 2] - begin;
        assert!(mid < 3 * frame / 4, "frame {i}: the middle row only after {mid} of {frame} B");
        assert!(rows.windows(2).all(|w| w[0] <= w[1]));
    }
}

#[test]
fn several_boards_share_every_frame_of_a_stream() {
    let p = prepared();
    let frames = |n: usize| {
        let mut sessions: Vec<_> = (0..n).map(|i| board(&p, &format!("sim{i}"), Arc::default())).collect();
        let mut pngs = Vec::new();
        let mut boards = Vec::new();
        let r = stream::run(&mut sessions, &plan(&p, 48, 36, 3), &mut |e| {
            if let StreamEvent::FrameDone { frame, devices, .. } = e {
                pngs.push(frame.rgb.clone());
                boards.push(devices.len());
            }
            Ok(())
        })
        .unwrap();
        assert_eq!(sessions.len(), n, "the sessions come back for the next frame");
        (r, pngs, boards)
    };
    let (one, single, _) = frames(1);
    let (two, split, boards) = frames(2);
    assert_eq!(split, single, "2 boards: the same pixels as 1");
    assert_eq!(boards, [2, 2, 2]);
    assert_ne!(single[0], single[1], "the orbit moves the camera");
    for r in [&one, &two] {
        assert_eq!(r.frames.len(), 3);
        assert_eq!(r.wire_rx, r.frames.iter().map(|f| f.wire_rx).sum::<u64>());
        assert!((r.fps - 3.0 / r.elapsed_s).abs() < 1e-9 * r.fps);
        let expected = stream::line_utilisation(r.wire_rx, r.boards, r.baud, r.elapsed_s);
        assert!((r.line_utilisation - expected).abs() < 1e-12);
    }
    assert_eq!((one.boards, two.boards), (1, 2));
    assert!(one.requested_ahead && !two.requested_ahead, "requests ahead on one board only");
}

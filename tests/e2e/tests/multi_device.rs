//! Several simulated boards render one frame: the frame is split into row bands
//! taken from a shared queue, merged, and identical to a single board's frame; two boards
//! need clearly less modelled link time than one; a board that holds the scene and dies
//! mid-frame costs its band, not the frame.

use std::io::{ErrorKind, Read, Write};
use std::path::Path;
use std::time::Duration;

use gridrt_host::grid::GridParams;
use gridrt_host::multi::render_multi;
use gridrt_host::render_settings::RenderSettings;
use gridrt_host::scene_image::PreparedScene;
use gridrt_host::session::{Session, SessionConfig};
use gridrt_loopback::SimPort;
use gridrt_shared::msg::{PixelEncoding, RenderRequest};

fn prepared(name: &str) -> PreparedScene {
    let mesh = gridrt_host::scene::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes").join(name)).unwrap();
    PreparedScene::new(mesh, &GridParams { pe_count: 4, pe_mem_words: 1 << 20, ..Default::default() }).unwrap()
}

/// `n` loaded boards; with `baud`, their output is paced at that line rate.
fn boards(n: usize, p: &PreparedScene, baud: Option<u32>) -> Vec<Session<SimPort>> {
    (0..n)
        .map(|i| {
            let mut port = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
            port.set_timeout(Duration::from_millis(5));
            port.set_line_rate(baud);
            let cfg = SessionConfig::new(format!("sim{i}"))
                .baud(baud.unwrap_or(3_000_000))
                .turnaround(Duration::from_millis(20))
                .render_timeout(Duration::from_secs(5));
            let mut s = Session::new(port, cfg);
            s.hello(&mut |_| {}).unwrap();
            s.upload_scene(&p.image, &mut |_| {}).unwrap();
            s
        })
        .collect()
}

fn request(p: &PreparedScene, w: u16, h: u16, enc: PixelEncoding) -> RenderRequest {
    RenderRequest {
        encoding: enc,
        ..RenderSettings::default_for(&p.grid.mesh_bounds).with_size(w, h).with_prim_ids(true).to_request(4)
    }
}

#[test]
fn split_frames_equal_the_single_board_frame() {
    let p = prepared("bun_zipper_res4.obj");
    let req = request(&p, 80, 60, PixelEncoding::Rle);
    let single = boards(1, &p, None).remove(0).render(&req, &mut |_| {}).unwrap();
    for n in [2, 3] {
        let (m, _) = render_multi(boards(n, &p, None), &req, 0, &|_, _| {}).unwrap();
        assert_eq!(m.frame.rgb, single.rgb, "{n} boards");
        assert_eq!(m.frame.prim_ids, single.prim_ids, "{n} boards");
        assert_eq!(m.devices.iter().map(|d| d.rows).sum::<u32>(), 60);
        assert!(m.devices.iter().all(|d| d.error.is_none()));
        // Every ray was traced exactly once over all boards.
        assert_eq!(m.frame.stats, single.stats, "{n} boards: counters add up to the single frame's");
    }
}

#[test]
fn two_boards_need_clearly_less_modelled_link_time() {
    // Paced at 921 600 baud: the boards that finish first take the next band, so the split
    // follows the line rate as it would with real UARTs.
    let baud = 921_600;
    let p = prepared("bun_zipper_res4.obj");
    let req = request(&p, 96, 72, PixelEncoding::Rgb888);
    let (one, _) = render_multi(boards(1, &p, Some(baud)), &req, 9, &|_, _| {}).unwrap();
    let (two, _) = render_multi(boards(2, &p, Some(baud)), &req, 9, &|_, _| {}).unwrap();
    assert_eq!(one.frame.rgb, two.frame.rgb);
    let (t1, t2) = (one.link_seconds(baud), two.link_seconds(baud));
    eprintln!("modelled link time: 1 board {t1:.3} s, 2 boards {t2:.3} s ({:.2}×)", t1 / t2);
    assert!(t2 < 0.7 * t1, "1 board {t1:.3} s, 2 boards {t2:.3} s");
    let cycles = |m: &gridrt_host::multi::MultiFrame| m.devices.iter().map(|d| d.coproc_cycles).max().unwrap();
    assert!(cycles(&two) < cycles(&one), "the busiest board's co-processor works less");
}

/// A simulated board whose line can go dead: after `die_after` more device → host bytes it
/// sends nothing and hears nothing, as a board that loses power or hangs mid-frame.
struct DyingPort {
    sim: SimPort,
    /// Device → host bytes still to pass before the line dies (`None`: never).
    left: Option<u64>,
}

impl DyingPort {
    fn dead(&self) -> bool {
        self.left == Some(0)
    }
}

impl Read for DyingPort {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.dead() {
            std::thread::sleep(self.sim.timeout());
            return Err(ErrorKind::TimedOut.into());
        }
        let cap = self.left.map_or(buf.len(), |l| buf.len().min(l as usize));
        let n = self.sim.read(&mut buf[..cap])?;
        if let Some(l) = self.left.as_mut() {
            *l -= n as u64;
        }
        Ok(n)
    }
}

impl Write for DyingPort {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.dead() {
            return Ok(buf.len());
        }
        self.sim.write(buf)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.sim.flush()
    }
}

#[test]
fn a_board_that_dies_mid_frame_costs_its_band_not_the_frame() {
    let p = prepared("cornell_box.obj");
    let req = request(&p, 64, 48, PixelEncoding::Rgb888);
    let single = boards(1, &p, None).remove(0).render(&req, &mut |_| {}).unwrap();
    // Both boards hold the scene. Board 0 is paced at a real line rate, so board 1 (unpaced)
    // takes bands from the start; its line dies after 5 000 bytes, a little more than two
    // 4-row bands (64 × 4 pixels × 3 bytes, their framing, Stats and RegionEnd: about 2 kB
    // each), in the middle of its third.
    let board = |baud: Option<u32>, session: SessionConfig| {
        let mut sim = gridrt_loopback::spawn(gridrt_loopback::SimConfig::default());
        sim.set_timeout(Duration::from_millis(5));
        sim.set_line_rate(baud);
        let mut s = Session::new(DyingPort { sim, left: None }, session);
        s.hello(&mut |_| {}).unwrap();
        s.upload_scene(&p.image, &mut |_| {}).unwrap();
        s
    };
    let healthy = board(Some(460_800), SessionConfig::new("healthy").render_timeout(Duration::from_secs(5)));
    let mut dying = board(
        None,
        SessionConfig::new("dying")
            .baud(3_000_000)
            .turnaround(Duration::from_millis(10))
            .max_probes(4)
            .render_timeout(Duration::from_millis(300)),
    );
    dying.port_mut().left = Some(5_000);
    let (m, mut sessions) = render_multi(vec![healthy, dying], &req, 4, &|_, _| {}).unwrap();
    assert!(sessions[1].port_mut().dead(), "the line of board 1 died during the frame");
    assert_eq!(m.frame.rgb, single.rgb, "the frame is the single board's, byte for byte");
    assert_eq!(m.frame.prim_ids, single.prim_ids);
    let (ok, dead) = (&m.devices[0], &m.devices[1]);
    eprintln!("healthy: {} rows; dying: {} rows, then {:?}", ok.rows, dead.rows, dead.error);
    assert!(dead.error.is_some(), "{dead:?}");
    assert!(dead.rows > 0 && dead.rows < 48, "board 1 verified some rows before it died: {dead:?}");
    assert!(ok.error.is_none() && ok.rows + dead.rows == 48, "{ok:?} {dead:?}");
}

//! One whole session over a [`PtyRelay`](super::relay::PtyRelay): the simulated board
//! ([`gridrt_loopback::run_on_port`], what `gridrt device --port` runs) on the device slave,
//! a [`Session`] on the host slave, through real serial-port handles; hello, scene upload and
//! one frame, each timed. `gridrt bench link --faults` and the end-to-end tests run this.

use std::time::{Duration, Instant};

use gridrt_shared::msg::RenderRequest;
use serde::Serialize;

use super::relay::{PtyRelay, RelayConfig};
use super::Injected;
use crate::serial;
use crate::session::{LinkStats, ProgressEvent, RenderedFrame, Session, SessionConfig, SessionError};

/// What one run measured.
#[derive(Debug, Clone, Serialize)]
pub struct LineRun {
    /// Seconds to `Version`.
    pub hello_s: f64,
    /// Seconds of the scene upload.
    pub upload_s: f64,
    /// Seconds of the frame.
    pub frame_s: f64,
    /// Seconds from the start of hello to the frame (what a user waits for).
    pub total_s: f64,
    /// Wire bytes of the upload as the host's session counted them: (sent, received).
    pub upload_wire: (u64, u64),
    /// Wire bytes of the frame as the host's session counted them: (sent, received).
    pub frame_wire: (u64, u64),
    /// Bytes the relay paced onto the line during the upload: (host → device, device → host).
    pub upload_line: (u64, u64),
    /// Bytes the relay paced onto the line during the frame: (host → device, device → host).
    pub frame_line: (u64, u64),
    /// Link counters of the whole session.
    pub link: LinkStats,
    /// What the relay did host → device.
    pub up: Injected,
    /// What the relay did device → host.
    pub down: Injected,
    /// The frame.
    #[serde(skip)]
    pub frame: RenderedFrame,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The relay or a port could not be set up.
    #[error("setting up the relay: {0}")]
    Setup(String),
    /// The session failed.
    #[error(transparent)]
    Session(#[from] SessionError),
}

/// Runs hello, the upload of `image` and the frame `req` over a relay configured by `relay`
/// to a simulated board configured by `sim`; `session` configures the host (its `baud`
/// should be the relay's). `progress` sees every session event.
pub fn run_session(
    image: &[u8],
    req: &RenderRequest,
    relay: RelayConfig,
    sim: gridrt_loopback::SimConfig,
    session: SessionConfig,
    progress: &mut dyn FnMut(ProgressEvent),
) -> Result<LineRun, RunError> {
    let relay = PtyRelay::start(relay).map_err(|e| RunError::Setup(e.to_string()))?;
    let baud = session.baud;
    let dev_path = relay.device_path().to_string_lossy().into_owned();
    let dev_port =
        serial::open(&dev_path, baud, Duration::from_millis(100)).map_err(|e| RunError::Setup(e.to_string()))?;
    let device = std::thread::Builder::new()
        .name("gridrt-sim-on-pty".into())
        .spawn(move || gridrt_loopback::run_on_port(dev_port, sim))
        .map_err(|e| RunError::Setup(e.to_string()))?;
    let host_path = relay.host_path().to_string_lossy().into_owned();
    let port = serial::open(&host_path, baud, Duration::from_millis(5)).map_err(|e| RunError::Setup(e.to_string()))?;
    // Bytes the relay has paced so far, both directions; a phase's are the difference. A
    // phase ends on the last byte it waits for, so its bytes have all crossed by then.
    let line = || {
        let (up, down) = relay.injected();
        (up.bytes, down.bytes)
    };
    let since = |a: (u64, u64), b: (u64, u64)| (b.0 - a.0, b.1 - a.1);
    let result = (|| {
        let mut s = Session::new(port, session);
        let t0 = Instant::now();
        s.hello(progress)?;
        let hello_s = t0.elapsed().as_secs_f64();
        let (tx, rx) = (s.bytes_tx(), s.bytes_rx());
        let l1 = line();
        let t1 = Instant::now();
        s.upload_scene(image, progress)?;
        let upload_s = t1.elapsed().as_secs_f64();
        let l2 = line();
        let upload_wire = (s.bytes_tx() - tx, s.bytes_rx() - rx);
        let t2 = Instant::now();
        let frame = s.render(req, progress)?;
        let frame_s = t2.elapsed().as_secs_f64();
        let l3 = line();
        Ok::<_, SessionError>(LineRun {
            hello_s,
            upload_s,
            frame_s,
            total_s: t0.elapsed().as_secs_f64(),
            upload_wire,
            frame_wire: (frame.bytes_tx, frame.bytes_rx),
            upload_line: since(l1, l2),
            frame_line: since(l2, l3),
            link: s.link_stats().clone(),
            up: Injected::default(),
            down: Injected::default(),
            frame,
        })
    })();
    let (up, down) = relay.injected();
    // Closing the relay hangs up the device's port; its loop ends.
    drop(relay);
    let end = Instant::now() + Duration::from_secs(3);
    while !device.is_finished() && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(10));
    }
    if device.is_finished() {
        let _ = device.join();
    }
    let mut run = result?;
    run.up = up;
    run.down = down;
    Ok(run)
}

//! Loopback simulator: the firmware's device loop and the co-processor in one process.
//!
//! This is a library the product links, not only a test crate: `gridrt-host` depends on it
//! for `gridrt render --sim` (and `--sim` on the other subcommands, `sim_board::SimBoard`,
//! `gridrt bench skip`); the host's and the end-to-end tests use it as well. It lives under
//! `tests/` for history only.
//!
//! The host reaches the simulated board only through [`SimPort`], an in-memory byte stream
//! with the same blocking/timeout behaviour as a serial port: the device thread sees UART
//! bytes, the co-processor sees FSL words, and nothing else crosses. The co-processor is the
//! Rust model ([`Backend::Model`]) or the RTL in Verilator ([`Backend::Rtl`], a child process
//! built by `cargo xtask rtl sim`).
//!
//! ```text
//! host ──bytes──► SimPort ══channel══► device thread: Device<SimLink> ──FSL──► Coprocessor model
//!      ◄─bytes──         ◄═channel══                 (firmware logic)       or RTL (Verilator)
//! ```

use std::io;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use gridrt_firmware::device::{Device, NoClock};
use gridrt_firmware::embedded_io::{self, ErrorType};

mod config;
mod farm;
mod link;

pub use config::{Backend, SimConfig, BOARD_LOOPBACK, SIM_MAX_VOXELS};
use farm::SimFarm;
use link::SimLink;
pub use link::{PeCacheCounts, RtlLinkError, LOCKSTEP_VAR};

/// Points the simulated device keeps for splat frames (SPEC.md §6): 64 B each.
pub const SIM_MAX_POINTS: usize = 1 << 17;

/// Words of the simulated device's splat shape table (`TableConfig::DEVICE`).
pub const SIM_TABLE_WORDS: usize = 81_920;

/// The simulated device: the firmware's device loop on the simulator's link, its frames'
/// rows traced by the row farm.
type SimDevice<'a> = Device<SimLink<'a>, NoClock, SIM_MAX_VOXELS, SIM_MAX_POINTS, SIM_TABLE_WORDS, SimFarm>;

/// What the host end sends to the device thread.
enum Input {
    /// UART bytes.
    Bytes(Vec<u8>),
    /// Wakes the device thread so it notices a reset request.
    Reset,
    /// Asks for the PE caches' counters (answered after every byte sent before it).
    PeCacheCounts(Sender<Option<PeCacheCounts>>),
    /// The port was dropped: the device thread ends (reset handles may still hold senders).
    Shutdown,
}

/// Output of the device thread; drops everything while a reset is pending (the board is
/// going down: whatever it was still rendering never reaches the wire).
struct ChannelSink<'a> {
    out: &'a Sender<(u32, Vec<u8>)>,
    muted: &'a AtomicBool,
    /// Boot epoch (resets so far) the output belongs to.
    epoch: u32,
}

impl ErrorType for ChannelSink<'_> {
    type Error = core::convert::Infallible;
}

/// Never blocks and never fails: every byte is taken at once.
impl embedded_io::Write for ChannelSink<'_> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        if !self.muted.load(Ordering::Acquire) {
            // A closed channel means the host went away; the device keeps running until its
            // input closes too, like a board whose UART cable was pulled.
            let _ = self.out.send((self.epoch, bytes.to_vec()));
        }
        Ok(bytes.len())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// Runs the device loop on the current thread until `input` closes. A reset request (see
/// [`SimReset`]) drops the device (scene, last request, sequence numbers, co-processor
/// memories), boots a fresh one and sends its banner (`Device::announce`).
fn run_device(config: SimConfig, input: Receiver<Input>, output: Sender<(u32, Vec<u8>)>, reset: Arc<ResetState>) {
    let mut backing = vec![0u32; if link::needs_model(&config) { config.model_backing_words() } else { 0 }];
    // The board cannot start without its co-processor: say so on the line, like firmware
    // would, then stop.
    let fail = |what: String| {
        let _ = output.send((0, format!("loopback: {what}\n").into_bytes()));
    };
    let program = match link::rtl_program(&config) {
        Ok(p) => p,
        Err(e) => return fail(e),
    };
    let mut booted_before = false;
    loop {
        backing.fill(0);
        let link = match link::open(&config, &mut backing, program.as_deref()) {
            Ok(l) => l,
            Err(e) => return fail(e),
        };
        let mut device: Box<SimDevice<'_>> =
            Box::new(Device::with_farm(link, config.device_info(), SimFarm::new(config.farm_threads())));
        reset.muted.store(false, Ordering::Release);
        let epoch = reset.count.load(Ordering::Acquire);
        let mut sink = ChannelSink { out: &output, muted: &reset.muted, epoch };
        if booted_before {
            device.announce(&mut sink);
        }
        booted_before = true;
        loop {
            if reset.pending.swap(false, Ordering::AcqRel) {
                break;
            }
            match input.recv() {
                Ok(Input::Bytes(bytes)) => device.feed(&bytes, &mut sink),
                Ok(Input::Reset) => {}
                Ok(Input::PeCacheCounts(reply)) => {
                    let _ = reply.send(device.link_mut().pe_cache_counts(&config));
                }
                Ok(Input::Shutdown) | Err(_) => return,
            }
        }
    }
}

/// Shared between a [`SimPort`], its [`SimReset`] handles and the device thread.
#[derive(Debug, Default)]
struct ResetState {
    /// A reset was requested and the device thread has not acted on it yet.
    pending: AtomicBool,
    /// Output is dropped (set with `pending`, cleared when the new device boots).
    muted: AtomicBool,
    /// Resets requested so far.
    count: AtomicU32,
}

/// Resets a simulated board from any thread, like pressing its reset button: the device
/// stops talking at once (output it produced but the host has not read yet is dropped, as
/// the unsent part of a UART transmit buffer would be), forgets its scene and last request,
/// restarts with sequence number 0 and sends its banner (a `0x00` and an unsolicited
/// `Version`, SPEC.md §3.12). Bytes the host sends while it restarts are processed by the
/// old device with its output dropped, i.e. lost.
#[derive(Debug, Clone)]
pub struct SimReset {
    state: Arc<ResetState>,
    wake: Sender<Input>,
}

impl SimReset {
    /// Requests a reset (returns at once; the board reboots after its current step).
    pub fn reset(&self) {
        self.state.muted.store(true, Ordering::Release);
        self.state.pending.store(true, Ordering::Release);
        self.state.count.fetch_add(1, Ordering::AcqRel);
        let _ = self.wake.send(Input::Reset);
    }

    /// Resets requested so far.
    pub fn count(&self) -> u32 {
        self.state.count.load(Ordering::Acquire)
    }
}

/// Reads a simulated board's PE-cache counters from any thread ([`SimPort::pe_cache_probe`]).
#[derive(Debug, Clone)]
pub struct PeCacheProbe {
    wake: Sender<Input>,
}

impl PeCacheProbe {
    /// The counters once the device has handled every byte sent to it before this call:
    /// `None` for a board without PE caches ([`SimConfig::pe_cache_lines`] 0) or one that
    /// stopped or did not answer within 120 s (an RTL board can be busy that long).
    pub fn counts(&self) -> Option<PeCacheCounts> {
        let (tx, rx) = mpsc::channel();
        self.wake.send(Input::PeCacheCounts(tx)).ok()?;
        rx.recv_timeout(Duration::from_secs(120)).ok().flatten()
    }
}

/// Writes the device's output to a byte transport (the serial port of [`run_on_port`]).
struct PortSink<'a, T: io::Write> {
    port: &'a mut T,
    error: Option<io::Error>,
}

impl<T: io::Write> ErrorType for PortSink<'_, T> {
    type Error = embedded_io::ErrorKind;
}

/// Blocks as the transport's `write_all` + `flush` do (every byte handed on at once). The
/// first transport error is kept for [`run_on_port`] to return, and this and every later
/// write fail (`ErrorKind::Other`), so the device stops the frame it was sending.
impl<T: io::Write> embedded_io::Write for PortSink<'_, T> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        if self.error.is_some() {
            return Err(embedded_io::ErrorKind::Other);
        }
        match self.port.write_all(bytes).and_then(|()| self.port.flush()) {
            Ok(()) => Ok(bytes.len()),
            Err(e) => {
                self.error = Some(e);
                Err(embedded_io::ErrorKind::Other)
            }
        }
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A read that found nothing in time (retried).
fn is_timeout(e: &io::Error) -> bool {
    matches!(e.kind(), io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted)
}

/// Runs the simulated board (firmware device loop + co-processor model) on a real byte
/// transport, e.g. a serial port or one end of a `socat` pty pair (`gridrt device`), until
/// the transport fails or reaches end of file; returns that error (`UnexpectedEof` for end
/// of file). Reads that time out (`TimedOut`/`WouldBlock`) are retried.
///
/// The device runs on a thread of its own with a large stack (its voxel map is inline, as
/// in firmware RAM); this call blocks until it ends.
pub fn run_on_port<T: io::Read + io::Write + Send>(mut port: T, config: SimConfig) -> io::Result<()> {
    let run = move || -> io::Result<()> {
        let words = if link::needs_model(&config) { config.model_backing_words() } else { 0 };
        let mut backing = vec![0u32; words];
        let invalid = |e: String| io::Error::new(io::ErrorKind::InvalidInput, e);
        let program = link::rtl_program(&config).map_err(invalid)?;
        let link = link::open(&config, &mut backing, program.as_deref()).map_err(invalid)?;
        let mut device: Box<SimDevice<'_>> =
            Box::new(Device::with_farm(link, config.device_info(), SimFarm::new(config.farm_threads())));
        let mut buf = [0u8; 4096];
        loop {
            let n = match port.read(&mut buf) {
                Ok(0) => return Err(io::Error::new(io::ErrorKind::UnexpectedEof, "port closed")),
                Ok(n) => n,
                Err(e) if is_timeout(&e) => continue,
                Err(e) => return Err(e),
            };
            let mut sink = PortSink { port: &mut port, error: None };
            device.feed(&buf[..n], &mut sink);
            if let Some(e) = sink.error {
                return Err(e);
            }
        }
    };
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("gridrt-sim-device".into())
            .stack_size(64 << 20)
            .spawn_scoped(s, run)?
            .join()
            .unwrap_or_else(|_| Err(io::Error::other("simulated device thread panicked")))
    })
}

/// Frames whose rows were traced on the row farm's threads (`SimConfig::threads` ≠ 1) so
/// far in this process, by every board: lets a test or bench see that the farm ran.
pub fn farmed_frames() -> u64 {
    farm::FARMED_FRAMES.load(std::sync::atomic::Ordering::Relaxed)
}

/// Makes what `config` needs before a board starts: for [`Backend::Rtl`], the Verilator build
/// (`cargo xtask rtl sim`, tens of seconds the first time, then cached). [`spawn`] does it
/// too, but on the device thread, where a long build looks like a silent board to the host.
pub fn prepare(config: &SimConfig) -> Result<(), String> {
    link::rtl_program(config).map(|_| ())
}

/// Starts a simulated board in its own thread and returns the host's end of its UART.
pub fn spawn(config: SimConfig) -> SimPort {
    let (to_device, device_rx) = mpsc::channel::<Input>();
    let (device_tx, from_device) = mpsc::channel::<(u32, Vec<u8>)>();
    let reset = Arc::new(ResetState::default());
    let thread = {
        let reset = reset.clone();
        std::thread::Builder::new()
            .name("gridrt-sim-device".into())
            // The device keeps its voxel map inline, as firmware does in static RAM.
            .stack_size(64 << 20)
            .spawn(move || run_device(config, device_rx, device_tx, reset))
            .ok()
    };
    SimPort {
        to_device: Some(to_device),
        from_device,
        pending: Vec::new(),
        pending_pos: 0,
        timeout: Duration::from_secs(10),
        thread,
        reset,
        pace: None,
        pending_epoch: 0,
    }
}

/// Line-rate model of the device → host direction (see [`SimPort::set_line_rate`]).
#[derive(Debug, Clone, Copy)]
struct Pace {
    /// Seconds per byte on the wire (8N1: 10 bit times).
    byte_time: f64,
    /// When the line is next free.
    free_at: Instant,
}

/// Host end of the simulated UART: `Read + Write`, reads time out like a serial port.
#[derive(Debug)]
pub struct SimPort {
    to_device: Option<Sender<Input>>,
    from_device: Receiver<(u32, Vec<u8>)>,
    pending: Vec<u8>,
    pending_pos: usize,
    timeout: Duration,
    thread: Option<JoinHandle<()>>,
    reset: Arc<ResetState>,
    pace: Option<Pace>,
    pending_epoch: u32,
}

impl SimPort {
    /// How long a read waits for the first byte before failing with `TimedOut`.
    pub fn set_timeout(&mut self, timeout: Duration) {
        self.timeout = timeout;
    }

    /// The current read timeout.
    pub fn timeout(&self) -> Duration {
        self.timeout
    }

    /// A handle that resets the simulated board (usable from another thread, e.g. a
    /// fault-injecting relay).
    pub fn reset_handle(&self) -> SimReset {
        // A port without a device thread has no input channel; a dead handle is harmless.
        let wake = self.to_device.clone().unwrap_or_else(|| mpsc::channel().0);
        SimReset { state: self.reset.clone(), wake }
    }

    /// Resets the simulated board now (see [`SimReset`]).
    pub fn reset(&self) {
        self.reset_handle().reset();
    }

    /// A handle that reads the board's PE-cache counters (usable after the port moved into
    /// a session).
    pub fn pe_cache_probe(&self) -> PeCacheProbe {
        PeCacheProbe { wake: self.to_device.clone().unwrap_or_else(|| mpsc::channel().0) }
    }

    /// The board's PE-cache counters since it booted ([`PeCacheProbe::counts`]).
    pub fn pe_cache_counts(&self) -> Option<PeCacheCounts> {
        self.pe_cache_probe().counts()
    }

    /// Delivers device → host bytes no faster than an 8N1 UART at `baud` (`baud / 10`
    /// bytes per second), so wall time follows the modelled line rate; `None` = as fast as
    /// the device produces them (the default). The host → device direction is not paced.
    pub fn set_line_rate(&mut self, baud: Option<u32>) {
        self.pace = baud.filter(|&b| b > 0).map(|b| Pace { byte_time: 10.0 / b as f64, free_at: Instant::now() });
    }
}

impl io::Read for SimPort {
    /// Returns buffered bytes at once; otherwise waits up to the timeout for the device.
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() {
            return Ok(0);
        }
        if self.pending_epoch < self.reset.count.load(Ordering::Acquire) {
            self.pending.clear();
            self.pending_pos = 0;
        }
        if self.pending_pos >= self.pending.len() {
            match self.from_device.recv_timeout(self.timeout) {
                // Output of a board that has been reset since: never transmitted.
                Ok((epoch, _)) if epoch < self.reset.count.load(Ordering::Acquire) => {
                    return Err(io::Error::new(io::ErrorKind::TimedOut, "simulated device is restarting"))
                }
                Ok((epoch, bytes)) => {
                    self.pending = bytes;
                    self.pending_pos = 0;
                    self.pending_epoch = epoch;
                }
                Err(RecvTimeoutError::Timeout) => {
                    return Err(io::Error::new(
                        io::ErrorKind::TimedOut,
                        "simulated device sent nothing before the timeout",
                    ))
                }
                Err(RecvTimeoutError::Disconnected) => {
                    return Err(io::Error::new(io::ErrorKind::ConnectionAborted, "simulated device stopped"))
                }
            }
        }
        let avail = &self.pending[self.pending_pos..];
        let mut n = avail.len().min(buf.len());
        if let Some(p) = self.pace.as_mut() {
            // Bytes leave the line one byte time apart; an idle line starts at once.
            let now = Instant::now();
            if p.free_at < now {
                p.free_at = now;
            }
            let ahead = p.free_at.saturating_duration_since(now);
            if ahead > Duration::from_millis(2) {
                std::thread::sleep(ahead.min(self.timeout));
            }
            // Hand out at most ~2 ms of line time per read so pacing stays smooth.
            let burst = ((0.002 / p.byte_time) as usize).max(1);
            n = n.min(burst);
            p.free_at += Duration::from_secs_f64(p.byte_time * n as f64);
        }
        buf[..n].copy_from_slice(&avail[..n]);
        self.pending_pos += n;
        Ok(n)
    }
}

impl io::Write for SimPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let tx = self.to_device.as_ref().ok_or_else(|| io::Error::new(io::ErrorKind::BrokenPipe, "port closed"))?;
        tx.send(Input::Bytes(buf.to_vec()))
            .map_err(|_| io::Error::new(io::ErrorKind::BrokenPipe, "simulated device stopped"))?;
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

impl Drop for SimPort {
    fn drop(&mut self) {
        // Ending the input ends the device loop; wait so no thread outlives the port.
        if let Some(tx) = self.to_device.take() {
            let _ = tx.send(Input::Shutdown);
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

#[cfg(test)]
mod port_tests {
    use super::*;
    use gridrt_shared::frame::{encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED};
    use gridrt_shared::msg::Msg;
    use std::io::{Read, Write};
    use std::os::unix::net::UnixStream;

    #[test]
    fn run_on_port_answers_hello_and_ends_at_eof() {
        let (mut host, device) = UnixStream::pair().unwrap();
        let t = std::thread::spawn(move || run_on_port(device, SimConfig::default()));
        let mut p = [0u8; 16];
        let n = Msg::Hello { protocol: 1 }.encode(&mut p).unwrap();
        let mut w = [0u8; MAX_ENCODED];
        let len = encode_frame(0x01, 0, &p[..n], &mut w).unwrap();
        host.write_all(&w[..len]).unwrap();
        let mut acc = FrameAccumulator::<MAX_ENCODED>::new();
        let mut buf = [0u8; 256];
        let info = loop {
            let n = host.read(&mut buf).unwrap();
            if let FeedResult::Frame { frame, .. } = acc.feed(&buf[..n]) {
                break Msg::decode(frame.kind, frame.payload).unwrap();
            }
        };
        assert!(matches!(info, Msg::Version(d) if d.pe_count == 4), "{info:?}");
        drop(host);
        let e = t.join().unwrap().unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::UnexpectedEof);
    }
}

#[cfg(test)]
mod reset_tests {
    use super::*;
    use gridrt_shared::frame::{encode_frame, FeedResult, FrameAccumulator, MAX_ENCODED};
    use gridrt_shared::msg::{ErrorCode, Msg, PixelEncoding, RenderRequest};
    use std::io::{Read, Write};

    fn send(port: &mut SimPort, m: &Msg<'_>, seq: u16) {
        let mut p = [0u8; 256];
        let n = m.encode(&mut p).unwrap();
        let mut w = [0u8; MAX_ENCODED];
        let len = encode_frame(m.kind() as u8, seq, &p[..n], &mut w).unwrap();
        port.write_all(&w[..len]).unwrap();
    }

    /// Reads frames until `n` have arrived or the port times out: (seq, kind, payload).
    fn frames(port: &mut SimPort, n: usize) -> Vec<(u16, u8, Vec<u8>)> {
        let mut acc = FrameAccumulator::<MAX_ENCODED>::new();
        let mut out = Vec::new();
        let mut buf = [0u8; 4096];
        while out.len() < n {
            let Ok(k) = port.read(&mut buf) else { break };
            let mut input = &buf[..k];
            loop {
                match acc.feed(input) {
                    FeedResult::Frame { frame, rest } => {
                        out.push((frame.seq, frame.kind, frame.payload.to_vec()));
                        input = rest;
                    }
                    FeedResult::Consumed => break,
                    FeedResult::BadFrame { rest, .. } | FeedResult::Overflow { rest } => input = rest,
                }
            }
        }
        out
    }

    #[test]
    fn reset_forgets_everything_and_announces_with_sequence_zero() {
        let mut port = spawn(SimConfig::default());
        port.set_timeout(Duration::from_millis(200));
        send(&mut port, &Msg::Hello { protocol: 1 }, 0);
        send(&mut port, &Msg::Hello { protocol: 1 }, 1);
        let f = frames(&mut port, 2);
        assert_eq!(f.iter().map(|x| x.0).collect::<Vec<_>>(), [0, 1]);
        let h = port.reset_handle();
        h.reset();
        assert_eq!(h.count(), 1);
        let f = frames(&mut port, 1);
        assert_eq!((f[0].0, f[0].1), (0, 0x02), "banner: Version with seq 0");
        // The new device has no scene.
        let req = RenderRequest {
            frame: 1,
            width: 4,
            height: 4,
            flags: 0,
            eye: [0.0, 0.0, 5.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_y_deg: 45.0,
            light_pos: [1.0; 3],
            light_intensity: 1.0,
            ambient: 0.1,
            encoding: PixelEncoding::Rgb888,
        };
        send(&mut port, &Msg::RenderRequest(req), 2);
        let f = frames(&mut port, 1);
        assert!(matches!(Msg::decode(f[0].1, &f[0].2), Ok(Msg::Error { code: ErrorCode::NoScene, .. })), "{f:?}");
        assert_eq!(f[0].0, 1);
    }

    /// Kernel-true cycle counts: the simulated PEs charge the kernel that runs, not GridRT's 648 cycles
    /// for every kernel (docs/bench-accuracy.md, model cycles per test); a pipelined PE
    /// issues a test per cycle whatever the kernel.
    #[test]
    fn simulated_pes_charge_the_running_kernels_cycles_per_test() {
        use gridrt_coproc::{KernelKind, TimingProfile};
        let issue =
            |timing, kernel| SimConfig { timing, kernel, ..SimConfig::default() }.coproc().timing.test_issue_cycles;
        assert_eq!(issue(TimingProfile::GRIDRT, KernelKind::Watertight), 1188);
        assert_eq!(issue(TimingProfile::GRIDRT, KernelKind::Wald), 399);
        assert_eq!(issue(TimingProfile::GRIDRT, KernelKind::MollerTrumbore), 675);
        assert_eq!(issue(TimingProfile::PIPELINED, KernelKind::Watertight), 1);
        assert_eq!(SimConfig::default().kernel, KernelKind::Watertight);
    }

    #[test]
    fn line_rate_paces_device_output() {
        let mut port = spawn(SimConfig::default());
        port.set_timeout(Duration::from_millis(500));
        port.set_line_rate(Some(115_200));
        // 40 Hellos → 40 Versions of 34 wire bytes = 1360 bytes ≈ 118 ms at 11 520 B/s.
        for i in 0..40 {
            send(&mut port, &Msg::Hello { protocol: 1 }, i);
        }
        let start = Instant::now();
        let f = frames(&mut port, 40);
        let t = start.elapsed();
        assert_eq!(f.len(), 40);
        // Paced: not faster than the line rate (how much slower is the machine's load, not
        // the simulator's behaviour).
        assert!(t >= Duration::from_millis(100), "{t:?}");
    }
}

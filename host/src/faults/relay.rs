//! A paced, faulty relay between two kernel pseudo-terminals (no external tool).
//!
//! ```text
//! device ⇄ slave A ═ master A ─┬─ down: paced, FaultChannel ─►─┬─ master B ═ slave B ⇄ host
//!                              └─◄─ up: paced, FaultChannel ───┘
//! ```
//!
//! Each direction is a thread that reads what one side wrote, lets every byte take one byte
//! time of the line (8N1: 10 bit times at `baud`) in order, and hands it through its own
//! [`FaultChannel`] to the other side when its stop bit would have ended. The relay keeps both
//! slaves open itself (in raw mode from the start: no echo, no line discipline), so either
//! end may open, close and reopen its slave at any time.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, Read, Write};
use std::os::unix::io::{AsRawFd, FromRawFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::poll::{poll, PollFd, PollFlags};
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};

use super::{FaultChannel, Faults, Injected};

/// Bytes a direction holds before it stops reading (the writer then waits on the kernel's
/// pty buffer, as on a UART whose FIFO is full).
const QUEUE_CAP: usize = 1 << 16;

/// How the relay behaves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RelayConfig {
    /// Line rate of both directions (8N1); `None` relays bytes as fast as they come.
    pub baud: Option<u32>,
    /// Faults host → device (slave B → slave A).
    pub up: Faults,
    /// Faults device → host (slave A → slave B).
    pub down: Faults,
    /// Seed of both channels (each direction draws its own stream from it).
    pub seed: u64,
}

impl RelayConfig {
    /// A clean relay at `baud`.
    pub fn clean(baud: Option<u32>) -> Self {
        Self { baud, up: Faults::default(), down: Faults::default(), seed: 0 }
    }
}

/// State shared with the two pump threads.
#[derive(Debug, Default)]
struct Shared {
    stop: AtomicBool,
    /// Faults are applied only while this is set.
    active: AtomicBool,
    /// What each direction did: [up, down].
    injected: Mutex<[Injected; 2]>,
}

/// The running relay; dropping it stops the threads and closes both pseudo-terminals (the
/// ends that have them open see a hangup).
#[derive(Debug)]
pub struct PtyRelay {
    device_path: PathBuf,
    host_path: PathBuf,
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    /// The relay's own slave handles (kept open so an end may reopen its slave).
    _slaves: [File; 2],
}

/// Opens a pseudo-terminal pair in raw mode: (master, slave, slave path).
fn raw_pty() -> io::Result<(File, File, PathBuf)> {
    let pty = nix::pty::openpty(None, None).map_err(io::Error::from)?;
    // SAFETY: `openpty` returned two fresh descriptors that nothing else owns.
    let (master, slave) = unsafe { (File::from_raw_fd(pty.master), File::from_raw_fd(pty.slave)) };
    let mut t = tcgetattr(slave.as_raw_fd()).map_err(io::Error::from)?;
    cfmakeraw(&mut t);
    tcsetattr(slave.as_raw_fd(), SetArg::TCSANOW, &t).map_err(io::Error::from)?;
    let path = nix::unistd::ttyname(slave.as_raw_fd()).map_err(io::Error::from)?;
    let flags = OFlag::from_bits_truncate(fcntl(master.as_raw_fd(), FcntlArg::F_GETFL).map_err(io::Error::from)?);
    fcntl(master.as_raw_fd(), FcntlArg::F_SETFL(flags | OFlag::O_NONBLOCK)).map_err(io::Error::from)?;
    Ok((master, slave, path))
}

impl PtyRelay {
    /// Creates both pseudo-terminal pairs and starts relaying (faults active).
    pub fn start(cfg: RelayConfig) -> io::Result<Self> {
        let (master_a, slave_a, device_path) = raw_pty()?;
        let (master_b, slave_b, host_path) = raw_pty()?;
        let shared = Arc::new(Shared { active: AtomicBool::new(true), ..Shared::default() });
        let byte_time = cfg.baud.map(|b| Duration::from_secs_f64(10.0 / b.max(1) as f64));
        let up = FaultChannel::new(cfg.up, cfg.seed.wrapping_mul(2).wrapping_add(1));
        let down = FaultChannel::new(cfg.down, cfg.seed.wrapping_mul(2).wrapping_add(2));
        let mut threads = Vec::new();
        for (name, src, dst, ch, k) in [
            ("gridrt-relay-up", master_b.try_clone()?, master_a.try_clone()?, up, 0),
            ("gridrt-relay-down", master_a, master_b, down, 1),
        ] {
            let shared = shared.clone();
            threads.push(
                std::thread::Builder::new()
                    .name(name.into())
                    .spawn(move || pump(src, dst, byte_time, ch, k, &shared))?,
            );
        }
        Ok(Self { device_path, host_path, shared, threads, _slaves: [slave_a, slave_b] })
    }

    /// The slave the device opens.
    pub fn device_path(&self) -> &Path {
        &self.device_path
    }

    /// The slave the host opens.
    pub fn host_path(&self) -> &Path {
        &self.host_path
    }

    /// Applies the faults (`true`, the default) or relays clean bytes (pacing stays).
    pub fn set_faults_active(&self, on: bool) {
        self.shared.active.store(on, Ordering::Release);
    }

    /// What each direction did so far: (host → device, device → host).
    pub fn injected(&self) -> (Injected, Injected) {
        let g = self.shared.injected.lock().unwrap_or_else(|p| p.into_inner());
        (g[0], g[1])
    }
}

impl Drop for PtyRelay {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// Waits until `fd` is ready for `events` or `ms` milliseconds passed; true when ready.
fn ready(fd: &File, events: PollFlags, ms: i32) -> bool {
    let mut fds = [PollFd::new(fd.as_raw_fd(), events)];
    matches!(poll(&mut fds, ms), Ok(n) if n > 0)
}

/// Writes all of `bytes` to the non-blocking `dst`, waiting for room; gives up on `stop`.
fn write_all(dst: &mut File, mut bytes: &[u8], shared: &Shared) {
    while !bytes.is_empty() && !shared.stop.load(Ordering::Acquire) {
        match dst.write(bytes) {
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == io::ErrorKind::WouldBlock || e.kind() == io::ErrorKind::Interrupted => {
                ready(dst, PollFlags::POLLOUT, 20);
            }
            // Nobody can read this side (it was closed under us): the bytes are lost.
            Err(_) => return,
        }
    }
}

/// One direction (module docs); `k` indexes its counters.
fn pump(mut src: File, mut dst: File, byte_time: Option<Duration>, mut ch: FaultChannel, k: usize, shared: &Shared) {
    let mut queue: VecDeque<u8> = VecDeque::new();
    let mut line_free = Instant::now();
    let mut buf = vec![0u8; 4096];
    let (mut leaving, mut out) = (Vec::new(), Vec::new());
    let mut counted = Injected::default();
    while !shared.stop.load(Ordering::Acquire) {
        // Sleep until input arrives or the next byte's stop bit ends.
        let wait_ms = match (queue.front(), byte_time) {
            (Some(_), Some(bt)) => {
                let due = line_free + bt;
                due.saturating_duration_since(Instant::now()).as_millis().clamp(1, 20) as i32
            }
            (Some(_), None) => 0,
            (None, _) => 20,
        };
        if queue.len() < QUEUE_CAP && ready(&src, PollFlags::POLLIN, wait_ms) {
            match src.read(&mut buf[..(QUEUE_CAP - queue.len()).min(4096)]) {
                Ok(n) if n > 0 => {
                    if queue.is_empty() {
                        line_free = line_free.max(Instant::now());
                    }
                    queue.extend(&buf[..n]);
                }
                // No writer on the other slave right now (EIO), or nothing after all.
                _ => std::thread::sleep(Duration::from_millis(2)),
            }
        } else if queue.len() >= QUEUE_CAP {
            std::thread::sleep(Duration::from_millis(1));
        }
        // Every byte whose time on the line is over leaves now.
        leaving.clear();
        match byte_time {
            Some(bt) => {
                let now = Instant::now();
                while !queue.is_empty() && line_free + bt <= now {
                    line_free += bt;
                    leaving.extend(queue.pop_front());
                }
            }
            None => leaving.extend(queue.drain(..)),
        }
        if leaving.is_empty() {
            continue;
        }
        out.clear();
        if shared.active.load(Ordering::Acquire) {
            ch.apply(&leaving, &mut out);
        } else {
            out.extend_from_slice(&leaving);
            ch.injected.bytes += leaving.len() as u64;
        }
        // Counted before the bytes leave: whoever reads them also sees them counted.
        if ch.injected != counted {
            counted = ch.injected;
            if let Ok(mut g) = shared.injected.lock() {
                g[k] = counted;
            }
        }
        write_all(&mut dst, &out, shared);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn open(path: &Path) -> File {
        let f = std::fs::OpenOptions::new().read(true).write(true).open(path).unwrap();
        let mut t = tcgetattr(f.as_raw_fd()).unwrap();
        cfmakeraw(&mut t);
        tcsetattr(f.as_raw_fd(), SetArg::TCSANOW, &t).unwrap();
        f
    }

    /// Reads until `n` bytes arrived or `limit` passed.
    fn read_n(f: &mut File, n: usize, limit: Duration) -> Vec<u8> {
        let end = Instant::now() + limit;
        let mut got = Vec::new();
        let mut buf = [0u8; 4096];
        while got.len() < n && Instant::now() < end {
            if ready(f, PollFlags::POLLIN, 10) {
                if let Ok(k) = f.read(&mut buf) {
                    got.extend_from_slice(&buf[..k]);
                }
            }
        }
        got
    }

    #[test]
    fn bytes_cross_both_ways_unchanged_on_a_clean_line() {
        let relay = PtyRelay::start(RelayConfig::clean(None)).unwrap();
        let (mut dev, mut host) = (open(relay.device_path()), open(relay.host_path()));
        let data: Vec<u8> = (0..20_000u32).map(|i| (i * 7 + i / 256) as u8).collect();
        host.write_all(&data).unwrap();
        assert_eq!(read_n(&mut dev, data.len(), Duration::from_secs(5)), data);
        dev.write_all(&data[..5000]).unwrap();
        assert_eq!(read_n(&mut host, 5000, Duration::from_secs(5)), data[..5000]);
        let (up, down) = relay.injected();
        assert_eq!((up.bytes, down.bytes, up.flips + down.flips), (20_000, 5000, 0));
    }

    #[test]
    fn pacing_takes_ten_bit_times_per_byte() {
        // 4000 bytes at 100 000 baud: 0.4 s.
        let relay = PtyRelay::start(RelayConfig::clean(Some(100_000))).unwrap();
        let (mut dev, mut host) = (open(relay.device_path()), open(relay.host_path()));
        let t = Instant::now();
        host.write_all(&[0x55; 4000]).unwrap();
        let got = read_n(&mut dev, 4000, Duration::from_secs(5));
        let secs = t.elapsed().as_secs_f64();
        assert_eq!(got.len(), 4000);
        // Not faster than ten bit times a byte (how much slower is the machine's load).
        assert!(secs >= 0.38, "{secs} s for 4000 bytes at 100 000 baud");
    }

    #[test]
    fn each_direction_has_its_own_faults() {
        let cfg = RelayConfig { baud: None, up: Faults::ber(1e-2), down: Faults::default(), seed: 3 };
        let relay = PtyRelay::start(cfg).unwrap();
        let (mut dev, mut host) = (open(relay.device_path()), open(relay.host_path()));
        let data = vec![0u8; 10_000];
        host.write_all(&data).unwrap();
        let up = read_n(&mut dev, data.len(), Duration::from_secs(5));
        dev.write_all(&data).unwrap();
        let down = read_n(&mut host, data.len(), Duration::from_secs(5));
        assert!(up.iter().filter(|&&b| b != 0).count() > 300, "flips host → device");
        assert_eq!(down, data, "device → host clean");
        let (u, d) = relay.injected();
        assert!(u.flips > 500 && d.flips == 0, "{u:?} {d:?}");
    }
}

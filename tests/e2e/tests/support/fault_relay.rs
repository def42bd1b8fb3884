//! A lossy relay between the host session and a simulated board (in process): the library's
//! [`FaultChannel`] on each direction (bit flips, dropped bytes, garbage bursts), plus device
//! resets after a given number of device → host bytes. Seeded, so every run of a test sees the
//! same faults.
//!
//! ```text
//! Session ──write──► FaultyPort ──(faults)──► SimPort ──► device thread
//!         ◄──read───            ◄─(faults)──
//! ```
#![allow(dead_code)]

use std::io::{self, Read, Write};

use gridrt_host::faults::FaultChannel;
pub use gridrt_host::faults::Faults;
use gridrt_loopback::{SimPort, SimReset};

/// What the relay did, both directions together.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Injected {
    /// Bits flipped.
    pub flips: u64,
    /// Bytes dropped.
    pub drops: u64,
    /// Garbage bursts inserted.
    pub bursts: u64,
    /// Device resets triggered.
    pub resets: u64,
    /// Bytes that passed device → host.
    pub down_bytes: u64,
    /// Bytes that passed host → device.
    pub up_bytes: u64,
}

/// The relay: `Read + Write` for the session, a [`SimPort`] behind it.
pub struct FaultyPort {
    inner: SimPort,
    up: FaultChannel,
    down: FaultChannel,
    reset: SimReset,
    /// Device → host byte counts at which to reset the board (ascending).
    reset_at: Vec<u64>,
    resets: u64,
    down_bytes: u64,
    up_bytes: u64,
    pending: Vec<u8>,
    pos: usize,
    /// Faults are applied only while this is true (e.g. switch on after the upload).
    pub active: bool,
}

impl FaultyPort {
    /// A relay in front of `inner` with `up` (host → device) and `down` faults, seeded.
    pub fn new(inner: SimPort, up: Faults, down: Faults, seed: u64) -> Self {
        let reset = inner.reset_handle();
        Self {
            inner,
            up: FaultChannel::new(up, seed.wrapping_mul(2)),
            down: FaultChannel::new(down, seed.wrapping_mul(2).wrapping_add(1)),
            reset,
            reset_at: Vec::new(),
            resets: 0,
            down_bytes: 0,
            up_bytes: 0,
            pending: Vec::new(),
            pos: 0,
            active: true,
        }
    }

    /// Resets the board when the device → host byte count reaches each of `at`.
    pub fn reset_at(mut self, mut at: Vec<u64>) -> Self {
        at.sort_unstable();
        self.reset_at = at;
        self
    }

    /// What was injected so far.
    pub fn injected(&self) -> Injected {
        let mut both = self.up.injected;
        both.add(&self.down.injected);
        Injected {
            flips: both.flips,
            drops: both.drops,
            bursts: both.bursts,
            resets: self.resets,
            down_bytes: self.down_bytes,
            up_bytes: self.up_bytes,
        }
    }
}

impl Read for FaultyPort {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if self.pos >= self.pending.len() {
            let mut raw = [0u8; 4096];
            let n = self.inner.read(&mut raw)?;
            let mut raw = &raw[..n];
            // A reset point inside this chunk: deliver up to it, then press the button.
            if let Some(&at) = self.reset_at.first() {
                if at < self.down_bytes + raw.len() as u64 {
                    raw = &raw[..(at.saturating_sub(self.down_bytes)) as usize];
                    self.reset_at.remove(0);
                    self.reset.reset();
                    self.resets += 1;
                }
            }
            self.down_bytes += raw.len() as u64;
            self.pending.clear();
            self.pos = 0;
            if self.active {
                self.down.apply(raw, &mut self.pending);
            } else {
                self.pending.extend_from_slice(raw);
            }
            if self.pending.is_empty() {
                return Err(io::ErrorKind::TimedOut.into());
            }
        }
        let n = buf.len().min(self.pending.len() - self.pos);
        buf[..n].copy_from_slice(&self.pending[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl Write for FaultyPort {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.up_bytes += buf.len() as u64;
        if !self.active {
            return self.inner.write(buf);
        }
        let mut out = Vec::with_capacity(buf.len() + 8);
        self.up.apply(buf, &mut out);
        if !out.is_empty() {
            self.inner.write_all(&out)?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

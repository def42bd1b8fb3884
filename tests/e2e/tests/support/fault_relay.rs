//! A lossy relay between the host session and a simulated board (in process): bit flips at a
//! given bit error rate, dropped bytes, inserted garbage bursts, and device resets after a
//! given number of device → host bytes. Seeded, so every run of a test sees the same faults.
//!
//! ```text
//! Session ──write──► FaultyPort ──(faults)──► SimPort ──► device thread
//!         ◄──read───            ◄─(faults)──
//! ```
#![allow(dead_code)]

use std::io::{self, Read, Write};

use gridrt_loopback::{SimPort, SimReset};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Faults of one direction.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Faults {
    /// Probability that a bit is flipped.
    pub ber: f64,
    /// Probability that a byte is dropped.
    pub drop: f64,
    /// Probability that a garbage burst (1..=`burst_max` random bytes, zeros included) is
    /// inserted before a byte.
    pub burst: f64,
    /// Longest garbage burst.
    pub burst_max: usize,
}

impl Faults {
    /// Bit flips only.
    pub fn ber(ber: f64) -> Self {
        Self { ber, ..Self::default() }
    }
}

/// What the relay did.
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

/// Draws the gap to the next event of probability `p` per trial (geometric distribution).
fn gap(rng: &mut ChaCha8Rng, p: f64) -> u64 {
    if p <= 0.0 {
        return u64::MAX;
    }
    if p >= 1.0 {
        return 0;
    }
    let u: f64 = rng.gen_range(f64::MIN_POSITIVE..1.0);
    (u.ln() / (1.0 - p).ln()).floor().min(u64::MAX as f64 / 2.0) as u64
}

/// Per-direction fault state: countdowns to the next flip, drop and burst.
#[derive(Debug)]
struct Channel {
    f: Faults,
    next_flip: u64,
    next_drop: u64,
    next_burst: u64,
}

impl Channel {
    fn new(f: Faults, rng: &mut ChaCha8Rng) -> Self {
        Self { f, next_flip: gap(rng, f.ber), next_drop: gap(rng, f.drop), next_burst: gap(rng, f.burst) }
    }

    /// Passes `input` through the faults into `out`.
    fn apply(&mut self, input: &[u8], out: &mut Vec<u8>, rng: &mut ChaCha8Rng, n: &mut Injected) {
        for &b in input {
            if self.next_burst == 0 {
                let len = rng.gen_range(1..=self.f.burst_max.max(1));
                out.extend((0..len).map(|_| rng.gen::<u8>()));
                n.bursts += 1;
                self.next_burst = gap(rng, self.f.burst);
            } else {
                self.next_burst -= 1;
            }
            let mut byte = b;
            let mut bits = 8u64;
            while self.next_flip < bits {
                byte ^= 1 << (8 - bits + self.next_flip);
                n.flips += 1;
                bits -= self.next_flip + 1;
                self.next_flip = gap(rng, self.f.ber);
            }
            self.next_flip -= bits;
            if self.next_drop == 0 {
                n.drops += 1;
                self.next_drop = gap(rng, self.f.drop);
                continue;
            }
            self.next_drop -= 1;
            out.push(byte);
        }
    }
}

/// The relay: `Read + Write` for the session, a [`SimPort`] behind it.
pub struct FaultyPort {
    inner: SimPort,
    rng: ChaCha8Rng,
    up: Channel,
    down: Channel,
    reset: SimReset,
    /// Device → host byte counts at which to reset the board (ascending).
    reset_at: Vec<u64>,
    pending: Vec<u8>,
    pos: usize,
    /// Faults are applied only while this is true (e.g. switch on after the upload).
    pub active: bool,
    /// What was injected so far.
    pub injected: Injected,
}

impl FaultyPort {
    /// A relay in front of `inner` with `up` (host → device) and `down` faults, seeded.
    pub fn new(inner: SimPort, up: Faults, down: Faults, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let up = Channel::new(up, &mut rng);
        let down = Channel::new(down, &mut rng);
        let reset = inner.reset_handle();
        Self {
            inner,
            rng,
            up,
            down,
            reset,
            reset_at: Vec::new(),
            pending: Vec::new(),
            pos: 0,
            active: true,
            injected: Injected::default(),
        }
    }

    /// Resets the board when the device → host byte count reaches each of `at`.
    pub fn reset_at(mut self, mut at: Vec<u64>) -> Self {
        at.sort_unstable();
        self.reset_at = at;
        self
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
                let here = self.injected.down_bytes;
                if at < here + raw.len() as u64 {
                    raw = &raw[..(at.saturating_sub(here)) as usize];
                    self.reset_at.remove(0);
                    self.reset.reset();
                    self.injected.resets += 1;
                }
            }
            self.injected.down_bytes += raw.len() as u64;
            self.pending.clear();
            self.pos = 0;
            if self.active {
                self.down.apply(raw, &mut self.pending, &mut self.rng, &mut self.injected);
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
        self.injected.up_bytes += buf.len() as u64;
        if !self.active {
            return self.inner.write(buf);
        }
        let mut out = Vec::with_capacity(buf.len() + 8);
        self.up.apply(buf, &mut out, &mut self.rng, &mut self.injected);
        if !out.is_empty() {
            self.inner.write_all(&out)?;
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

#[test]
fn relay_injects_at_the_requested_rates() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut ch = Channel::new(Faults { ber: 1e-3, drop: 1e-3, burst: 1e-3, burst_max: 8 }, &mut rng);
    let mut n = Injected::default();
    let mut out = Vec::new();
    ch.apply(&vec![0u8; 1_000_000], &mut out, &mut rng, &mut n);
    // 8e6 bits at 1e-3 → 8000 flips; 1e6 bytes → 1000 drops and 1000 bursts (±10 %).
    assert!((7200..8800).contains(&n.flips), "{n:?}");
    assert!((900..1100).contains(&n.drops), "{n:?}");
    assert!((900..1100).contains(&n.bursts), "{n:?}");
    let ones: u64 = out.iter().map(|b| b.count_ones() as u64).sum();
    assert!(ones > 7000, "flipped bits reach the output");
}

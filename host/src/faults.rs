//! A faulty serial line for tests and benches: what a noisy UART does to a byte stream, and
//! a relay that puts it between two programs on real kernel pseudo-terminals.
//!
//! - [`FaultChannel`]: one direction's faults, seeded — bit flips at a bit error rate on the
//!   8 data bits of every byte, bytes dropped, garbage bursts inserted (random bytes, `0x00`
//!   included, so they also cut frames).
//! - [`relay::PtyRelay`] (Unix): two pseudo-terminal pairs and two threads copying between
//!   their masters, each direction paced to a baud rate (8N1: `baud / 10` bytes per second)
//!   and passed through its own channel. A device (`gridrt device --port A`, or
//!   [`gridrt_loopback::run_on_port`]) opens one slave, a host (`gridrt render --port B`)
//!   the other; neither knows the relay is there.
//! - [`run`]: a whole session (hello, upload, render) over a relay with the simulated board
//!   at the far end, timed; what `gridrt bench link --faults` ([`crate::bench::link_faults`])
//!   and the end-to-end tests run.

#[cfg(unix)]
pub mod relay;
#[cfg(unix)]
pub mod run;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Faults of one direction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Faults {
    /// Probability that a data bit is flipped.
    pub ber: f64,
    /// Probability that a byte is dropped.
    pub drop: f64,
    /// Probability that a garbage burst is inserted before a byte.
    pub burst: f64,
    /// Longest garbage burst in bytes (1..=this, uniform).
    pub burst_max: usize,
}

impl Faults {
    /// Bit flips only.
    pub fn ber(ber: f64) -> Self {
        Self { ber, ..Self::default() }
    }

    /// The mix `gridrt bench link --faults` measures at bit error rate `ber`: flips at `ber`,
    /// drops at `ber / 10` per byte, bursts of 1..=16 bytes at `ber / 100` per byte.
    pub fn line(ber: f64) -> Self {
        Self { ber, drop: ber / 10.0, burst: ber / 100.0, burst_max: 16 }
    }

    /// True when nothing is ever changed.
    pub fn is_clean(&self) -> bool {
        self.ber <= 0.0 && self.drop <= 0.0 && self.burst <= 0.0
    }
}

/// What a channel did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Injected {
    /// Bytes that went in.
    pub bytes: u64,
    /// Bits flipped.
    pub flips: u64,
    /// Bytes dropped.
    pub drops: u64,
    /// Garbage bursts inserted.
    pub bursts: u64,
    /// Garbage bytes inserted.
    pub burst_bytes: u64,
}

impl Injected {
    /// Adds another count.
    pub fn add(&mut self, o: &Injected) {
        self.bytes += o.bytes;
        self.flips += o.flips;
        self.drops += o.drops;
        self.bursts += o.bursts;
        self.burst_bytes += o.burst_bytes;
    }
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

/// One direction of a faulty line: countdowns to the next flip, drop and burst, drawn from a
/// seeded generator, so a run with the same seed and the same bytes sees the same faults.
#[derive(Debug, Clone)]
pub struct FaultChannel {
    f: Faults,
    rng: ChaCha8Rng,
    next_flip: u64,
    next_drop: u64,
    next_burst: u64,
    /// What was done so far.
    pub injected: Injected,
}

impl FaultChannel {
    /// A channel with faults `f`, seeded with `seed`.
    pub fn new(f: Faults, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (next_flip, next_drop, next_burst) = (gap(&mut rng, f.ber), gap(&mut rng, f.drop), gap(&mut rng, f.burst));
        Self { f, rng, next_flip, next_drop, next_burst, injected: Injected::default() }
    }

    /// The faults.
    pub fn faults(&self) -> Faults {
        self.f
    }

    /// Passes `input` through the faults, appending what comes out to `out`.
    pub fn apply(&mut self, input: &[u8], out: &mut Vec<u8>) {
        let n = &mut self.injected;
        for &b in input {
            n.bytes += 1;
            if self.next_burst == 0 {
                let len = self.rng.gen_range(1..=self.f.burst_max.max(1));
                out.extend((0..len).map(|_| self.rng.gen::<u8>()));
                n.bursts += 1;
                n.burst_bytes += len as u64;
                self.next_burst = gap(&mut self.rng, self.f.burst);
            } else {
                self.next_burst -= 1;
            }
            let mut byte = b;
            let mut bits = 8u64;
            while self.next_flip < bits {
                byte ^= 1 << (8 - bits + self.next_flip);
                n.flips += 1;
                bits -= self.next_flip + 1;
                self.next_flip = gap(&mut self.rng, self.f.ber);
            }
            self.next_flip -= bits;
            if self.next_drop == 0 {
                n.drops += 1;
                self.next_drop = gap(&mut self.rng, self.f.drop);
                continue;
            }
            self.next_drop -= 1;
            out.push(byte);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_injects_at_the_requested_rates() {
        let mut ch = FaultChannel::new(Faults { ber: 1e-3, drop: 1e-3, burst: 1e-3, burst_max: 8 }, 1);
        let mut out = Vec::new();
        ch.apply(&vec![0u8; 1_000_000], &mut out);
        let n = ch.injected;
        // 8e6 bits at 1e-3 → 8000 flips; 1e6 bytes → 1000 drops and 1000 bursts (±10 %).
        assert!((7200..8800).contains(&n.flips), "{n:?}");
        assert!((900..1100).contains(&n.drops), "{n:?}");
        assert!((900..1100).contains(&n.bursts), "{n:?}");
        assert_eq!(out.len() as u64, n.bytes - n.drops + n.burst_bytes);
        let ones: u64 = out.iter().map(|b| b.count_ones() as u64).sum();
        assert!(ones > 7000, "flipped bits reach the output");
    }

    #[test]
    fn the_same_seed_gives_the_same_faults_and_a_clean_channel_changes_nothing() {
        let input: Vec<u8> = (0..100_000u32).map(|i| (i * 31) as u8).collect();
        let run = |seed| {
            let mut ch = FaultChannel::new(Faults::line(1e-3), seed);
            let mut out = Vec::new();
            ch.apply(&input, &mut out);
            out
        };
        assert_eq!(run(5), run(5));
        assert_ne!(run(5), run(6));
        let mut clean = FaultChannel::new(Faults::default(), 5);
        let mut out = Vec::new();
        clean.apply(&input, &mut out);
        assert_eq!(out, input);
    }
}

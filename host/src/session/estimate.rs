//! What the line costs: the frame overhead of a payload, the efficiency of selective repeat
//! at a byte error rate (SPEC.md §3.14), and the byte error rate of one direction estimated
//! from the frames that got through and those that did not.
//!
//! # Model
//! A frame of `w` wire bytes arrives intact with probability `(1 − q)^w`, `q` the byte error
//! rate (a flipped bit, a dropped byte or noise inside the frame; for independent bit errors
//! at rate `b` on the 8 data bits, `q = 1 − (1 − b)^8 ≈ 8b`). Selective repeat sends each
//! payload byte until it arrives and nothing else, so its efficiency — payload bytes per wire
//! byte — with payloads of `n` bytes and `o` bytes of overhead per frame is
//! `η(n) = n / (n + o) · (1 − q)^(n + o)`. The best payload solves `dη/dn = 0`:
//! `n* = (−o + √(o² + 4o/λ)) / 2` with `λ = −ln(1 − q)`.

use std::collections::VecDeque;

use gridrt_shared::frame::{CRC_LEN, HEADER_LEN};

/// Wire bytes of a frame with a `payload`-byte payload: header, CRC, COBS code bytes (one per
/// 254 bytes, rounded up) and the delimiter.
pub fn wire_len(payload: usize) -> usize {
    let raw = HEADER_LEN + payload + CRC_LEN;
    raw + raw.div_ceil(254) + 1
}

/// Byte error rate `q` of a line with independent bit errors at `ber` on the 8 data bits.
pub fn byte_error_rate(ber: f64) -> f64 {
    1.0 - (1.0 - ber.clamp(0.0, 1.0)).powi(8)
}

/// Efficiency of selective repeat (payload bytes per wire byte) with `payload` bytes per frame
/// behind `head` bytes of message header, at byte error rate `q`.
pub fn efficiency(payload: usize, head: usize, q: f64) -> f64 {
    let w = wire_len(head + payload) as f64;
    payload as f64 / w * (1.0 - q.clamp(0.0, 1.0)).powf(w)
}

/// The payload in `min..=max` with the best [`efficiency`] at byte error rate `q`.
pub fn best_payload(head: usize, q: f64, min: usize, max: usize) -> usize {
    let (min, max) = (min.max(1), max.max(min.max(1)));
    if q <= 0.0 {
        return max;
    }
    let lambda = -(1.0 - q.min(0.999_999)).ln();
    let continuous = |o: f64| (-o + (o * o + 4.0 * o / lambda).sqrt()) / 2.0;
    // The overhead grows by a COBS byte per 254 raw bytes: solve with the overhead at the
    // first guess, then compare with the payloads just below the nearest COBS steps.
    let mut guess = continuous(wire_len(head) as f64).round().clamp(min as f64, max as f64) as usize;
    guess = continuous((wire_len(head + guess) - guess) as f64).round().clamp(min as f64, max as f64) as usize;
    let raw = |p: usize| p + head + gridrt_shared::frame::HEADER_LEN + gridrt_shared::frame::CRC_LEN;
    let step_below = |k: usize| (254 * k).saturating_sub(raw(0));
    let k = raw(guess) / 254;
    [guess.saturating_sub(1), guess, guess + 1, step_below(k), step_below(k + 1)]
        .into_iter()
        .map(|p| p.clamp(min, max))
        .max_by(|&a, &b| efficiency(a, head, q).total_cmp(&efficiency(b, head, q)))
        .unwrap_or(guess)
}

/// Byte error rate of one direction, estimated (maximum likelihood) from the outcomes of the
/// last frames sent over it: `(wire bytes, arrived)`.
#[derive(Debug, Clone)]
pub struct LossEstimator {
    samples: VecDeque<(u32, bool)>,
    capacity: usize,
    /// Cached estimate, `None` when samples changed since.
    cached: Option<f64>,
    lost: usize,
}

impl Default for LossEstimator {
    fn default() -> Self {
        Self::new(256)
    }
}

impl LossEstimator {
    /// Remembers the last `capacity` frames.
    pub fn new(capacity: usize) -> Self {
        Self { samples: VecDeque::with_capacity(capacity), capacity: capacity.max(1), cached: Some(0.0), lost: 0 }
    }

    /// Records one frame of `wire` bytes that arrived intact or did not.
    pub fn record(&mut self, wire: usize, arrived: bool) {
        if self.samples.len() == self.capacity {
            if let Some((_, ok)) = self.samples.pop_front() {
                self.lost -= usize::from(!ok);
            }
        }
        self.samples.push_back((wire.clamp(1, u32::MAX as usize) as u32, arrived));
        self.lost += usize::from(!arrived);
        self.cached = None;
    }

    /// Frames remembered.
    pub fn samples(&self) -> usize {
        self.samples.len()
    }

    /// Of those, frames lost.
    pub fn lost(&self) -> usize {
        self.lost
    }

    /// The estimated byte error rate (0 while no frame was lost).
    pub fn byte_error_rate(&mut self) -> f64 {
        if let Some(q) = self.cached {
            return q;
        }
        let q = self.solve();
        self.cached = Some(q);
        q
    }

    /// Root of the log-likelihood's derivative
    /// `−Σ_ok w/(1−q) + Σ_lost w(1−q)^(w−1)/(1 − (1−q)^w)`, which falls with `q`.
    fn solve(&self) -> f64 {
        const Q_MAX: f64 = 0.2;
        if self.lost == 0 {
            return 0.0;
        }
        let slope = |q: f64| {
            let mut d = 0.0;
            for &(w, ok) in &self.samples {
                let w = w as f64;
                if ok {
                    d -= w / (1.0 - q);
                } else {
                    let s = (1.0 - q).powf(w);
                    d += w * s / ((1.0 - q) * (1.0 - s).max(1e-300));
                }
            }
            d
        };
        if slope(Q_MAX) >= 0.0 {
            return Q_MAX; // nothing got through: as bad as this model goes
        }
        let (mut lo, mut hi) = (1e-9f64.ln(), Q_MAX.ln());
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if slope(mid.exp()) > 0.0 {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (0.5 * (lo + hi)).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn wire_length_counts_header_crc_cobs_and_delimiter() {
        assert_eq!(wire_len(4), 16); // the §2.3 Hello frame
        assert_eq!(wire_len(2048), 2068); // MAX_ENCODED
        assert_eq!(wire_len(244), 254 + 1 + 1); // raw 254: one code byte
        assert_eq!(wire_len(245), 255 + 2 + 1);
    }

    #[test]
    fn best_payload_matches_the_closed_form_and_maximises_efficiency() {
        for ber in [1e-6, 1e-5, 1e-4, 1e-3] {
            let q = byte_error_rate(ber);
            let n = best_payload(4, q, 1, 2044);
            for m in [n / 2, n * 2, n.saturating_sub(5).max(1), (n + 5).min(2044)] {
                assert!(efficiency(n, 4, q) >= efficiency(m, 4, q), "BER {ber}: {n} vs {m}");
            }
        }
        // SPEC.md §3.14 table: BER 1e-4 → about 134 bytes, 1e-3 → about 37, clean → all.
        assert!((125..=140).contains(&best_payload(4, byte_error_rate(1e-4), 1, 2044)));
        assert!((33..=40).contains(&best_payload(4, byte_error_rate(1e-3), 1, 2044)));
        assert_eq!(best_payload(4, 0.0, 16, 2044), 2044);
    }

    #[test]
    fn estimator_recovers_the_byte_error_rate_of_a_simulated_line() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        for q in [1e-5f64, 1e-4, 1e-3, 1e-2] {
            let mut e = LossEstimator::new(4000);
            for _ in 0..4000 {
                let w = rng.gen_range(20..400usize);
                let ok = rng.gen::<f64>() < (1.0 - q).powf(w as f64);
                e.record(w, ok);
            }
            let got = e.byte_error_rate();
            let tol = if q < 1e-4 { 0.5 } else { 0.15 };
            assert!((got / q - 1.0).abs() < tol, "q {q}: estimated {got} from {} lost", e.lost());
        }
        let mut e = LossEstimator::new(8);
        assert_eq!(e.byte_error_rate(), 0.0);
        for _ in 0..8 {
            e.record(100, false);
        }
        assert_eq!(e.byte_error_rate(), 0.2, "nothing through: the model's ceiling");
        for _ in 0..8 {
            e.record(100, true);
        }
        assert_eq!((e.samples(), e.lost(), e.byte_error_rate()), (8, 0, 0.0), "old samples forgotten");
    }
}

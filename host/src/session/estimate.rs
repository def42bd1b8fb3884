//! What the line costs: the frame overhead of a payload, the efficiency of selective repeat
//! at a byte error rate (SPEC.md §3.14), and the byte error rate of one direction estimated
//! from the frames that got through and those that did not.
//!
//! # Model
//! A frame of `w` wire bytes arrives intact with probability `(1 − q)^w`, `q` the byte error
//! rate (a flipped bit, a dropped byte or noise inside the frame; for independent bit errors
//! at rate `b` on the 8 data bits, `q = 1 − (1 − b)^8 ≈ 8b`). A frame of at most
//! [`CORRECTABLE_RAW`] raw bytes also arrives with one damaged byte: the receiver corrects a
//! single flipped bit (SPEC.md §2.5; a byte error is almost always one flipped bit at these
//! rates), so it arrives with probability `(1 − q)^w + w·q·(1 − q)^(w−1)` ([`arrival`]).
//! Selective repeat sends each payload byte until it arrives and nothing else, so its
//! efficiency — payload bytes per wire byte — with payloads of `n` bytes is
//! `η(n) = n / w(n) · arrival(w(n))`; the best payload is found by trying them all.

use std::collections::VecDeque;

use gridrt_shared::frame::{CORRECTABLE_RAW, CRC_LEN, HEADER_LEN};

/// Wire bytes of a frame with a `payload`-byte payload: header, CRC, COBS code bytes (one per
/// 254 bytes, rounded up) and the delimiter.
pub fn wire_len(payload: usize) -> usize {
    let raw = HEADER_LEN + payload + CRC_LEN;
    raw + raw.div_ceil(254) + 1
}

/// Wire bytes of the longest frame a receiver corrects ([`CORRECTABLE_RAW`] raw bytes).
pub fn correctable_wire() -> usize {
    CORRECTABLE_RAW + CORRECTABLE_RAW.div_ceil(254) + 1
}

/// Probability that a frame of `wire` bytes arrives (intact or corrected) at byte error rate
/// `q` (module docs).
pub fn arrival(wire: usize, q: f64) -> f64 {
    let q = q.clamp(0.0, 1.0);
    let w = wire as f64;
    let intact = (1.0 - q).powf(w);
    if wire <= correctable_wire() && q < 1.0 {
        intact + w * q * intact / (1.0 - q)
    } else {
        intact
    }
}

/// Byte error rate `q` of a line with independent bit errors at `ber` on the 8 data bits.
pub fn byte_error_rate(ber: f64) -> f64 {
    1.0 - (1.0 - ber.clamp(0.0, 1.0)).powi(8)
}

/// Efficiency of selective repeat (payload bytes per wire byte) with `payload` bytes per frame
/// behind `head` bytes of message header, at byte error rate `q`.
pub fn efficiency(payload: usize, head: usize, q: f64) -> f64 {
    let w = wire_len(head + payload);
    payload as f64 / w as f64 * arrival(w, q)
}

/// The payload in `min..=max` with the best [`efficiency`] at byte error rate `q` (the
/// smallest of equals).
pub fn best_payload(head: usize, q: f64, min: usize, max: usize) -> usize {
    let (min, max) = (min.max(1), max.max(min.max(1)));
    if q <= 0.0 {
        return max;
    }
    (min..=max)
        .fold((min, f64::MIN), |best, p| {
            let e = efficiency(p, head, q);
            if e > best.1 {
                (p, e)
            } else {
                best
            }
        })
        .0
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

    /// The `q` of the largest likelihood `Π_ok arrival(w) · Π_lost (1 − arrival(w))`, by
    /// golden-section search on `ln q` (the log-likelihood has one maximum).
    fn solve(&self) -> f64 {
        const Q_MIN: f64 = 1e-9;
        const Q_MAX: f64 = 0.2;
        if self.lost == 0 {
            return 0.0;
        }
        let log_likelihood = |ln_q: f64| {
            let q = ln_q.exp();
            self.samples
                .iter()
                .map(|&(w, ok)| {
                    let a = arrival(w as usize, q);
                    if ok {
                        a.max(1e-300).ln()
                    } else {
                        (1.0 - a).max(1e-300).ln()
                    }
                })
                .sum::<f64>()
        };
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        let (mut lo, mut hi) = (Q_MIN.ln(), Q_MAX.ln());
        let mut a = hi - ratio * (hi - lo);
        let mut b = lo + ratio * (hi - lo);
        let (mut fa, mut fb) = (log_likelihood(a), log_likelihood(b));
        for _ in 0..48 {
            if fa < fb {
                lo = a;
                (a, fa) = (b, fb);
                b = lo + ratio * (hi - lo);
                fb = log_likelihood(b);
            } else {
                hi = b;
                (b, fb) = (a, fa);
                a = hi - ratio * (hi - lo);
                fa = log_likelihood(a);
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
        // SPEC.md §3.14 table: BER 1e-4 → about 310 bytes (correctable), 1e-3 → about 70,
        // clean → all.
        assert!((280..=CORRECTABLE_RAW - 14).contains(&best_payload(4, byte_error_rate(1e-4), 1, 2044)));
        assert!((60..=80).contains(&best_payload(4, byte_error_rate(1e-3), 1, 2044)));
        assert_eq!(best_payload(4, 0.0, 16, 2044), 2044);
    }

    #[test]
    fn estimator_recovers_the_byte_error_rate_of_a_simulated_line() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(13);
        for q in [1e-5f64, 1e-4, 1e-3, 1e-2] {
            let mut e = LossEstimator::new(4000);
            for _ in 0..4000 {
                // Frames on both sides of the correctable length.
                let w = rng.gen_range(20..1200usize);
                let ok = rng.gen::<f64>() < arrival(w, q);
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
        assert!((e.byte_error_rate() / 0.2 - 1.0).abs() < 1e-6, "nothing through: the model's ceiling");
        for _ in 0..8 {
            e.record(100, true);
        }
        assert_eq!((e.samples(), e.lost(), e.byte_error_rate()), (8, 0, 0.0), "old samples forgotten");
    }
}

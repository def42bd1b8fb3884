//! The receive side of a windowed transfer (SPEC.md §3.14): which bytes of an image have
//! arrived — everything below `next`, plus at most [`MAX_SACK_RANGES`] ranges above it — and
//! the [`Sack`] that tells the sender.
//!
//! The tracker holds no data. A device copies accepted bytes into a buffer of `window` bytes
//! and processes `from..to` whenever [`ReceiveWindow::arrive`] reports that `next` moved; a
//! bootloader writes them straight to their address.

// Link-facing: offsets and lengths come from the sender.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use crate::msg::{Sack, SackRanges, MAX_SACK_RANGES};

/// What one data frame did to the window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arrival {
    /// Nothing new: the frame was empty or every byte was already held.
    Nothing,
    /// New bytes above a gap; `next` did not move.
    Held,
    /// `next` moved from `from` to `to`: bytes `from..to` are now contiguous and accepted.
    Advanced {
        /// The old `next`.
        from: u32,
        /// The new `next`.
        to: u32,
    },
    /// The frame reaches past `next + window`: dropped.
    OutOfWindow,
    /// Holding the frame would need more than [`MAX_SACK_RANGES`] ranges: dropped.
    TableFull,
    /// The frame reaches past the end of the image: dropped (the transfer is broken).
    PastEnd,
}

impl Arrival {
    /// True when the frame's bytes were taken (the caller keeps them).
    pub fn accepted(self) -> bool {
        matches!(self, Self::Held | Self::Advanced { .. })
    }
}

/// What has arrived of a `total`-byte transfer with a receive window of `window` bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReceiveWindow {
    total: u32,
    window: u16,
    next: u32,
    /// Absolute ranges above `next`: ascending, non-empty, separated by gaps.
    held: [(u32, u32); MAX_SACK_RANGES],
    len: usize,
}

impl ReceiveWindow {
    /// Nothing received yet of `total` bytes; frames may reach `window` bytes past `next`
    /// (at least 1).
    pub const fn new(total: u32, window: u16) -> Self {
        let window = if window == 0 { 1 } else { window };
        Self { total, window, next: 0, held: [(0, 0); MAX_SACK_RANGES], len: 0 }
    }

    /// Every byte below this offset has arrived.
    pub fn next(&self) -> u32 {
        self.next
    }

    /// The transfer's length.
    pub fn total(&self) -> u32 {
        self.total
    }

    /// The receive window in bytes.
    pub fn window(&self) -> u16 {
        self.window
    }

    /// True when every byte has arrived.
    pub fn complete(&self) -> bool {
        self.next >= self.total
    }

    /// The ranges held above `next` (absolute offsets).
    pub fn held(&self) -> &[(u32, u32)] {
        self.held.get(..self.len).unwrap_or(&[])
    }

    /// Records the data frame `offset .. offset + len`.
    pub fn arrive(&mut self, offset: u32, len: u32) -> Arrival {
        let Some(end) = offset.checked_add(len).filter(|&e| e <= self.total) else {
            return Arrival::PastEnd;
        };
        if len == 0 || end <= self.next {
            return Arrival::Nothing;
        }
        if end as u64 > (self.next as u64).saturating_add(self.window as u64) {
            return Arrival::OutOfWindow;
        }
        let start = offset.max(self.next);
        if self.held().iter().any(|&(s, e)| s <= start && end <= e) {
            return Arrival::Nothing;
        }
        // Merge [start, end) into the held ranges (one more slot than the table has).
        let mut merged = [(0u32, 0u32); MAX_SACK_RANGES + 1];
        let mut n = 0usize;
        let mut new = Some((start, end));
        for &(s, e) in self.held() {
            match new {
                // Touching or overlapping: absorb the held range into the new one.
                Some((ns, ne)) if s <= ne && ns <= e => {
                    new = Some((ns.min(s), ne.max(e)));
                    continue;
                }
                // The new range lies wholly below this one: it goes first.
                Some(r) if r.1 < s => {
                    if !put(&mut merged, &mut n, r) {
                        return Arrival::TableFull;
                    }
                    new = None;
                }
                _ => {}
            }
            if !put(&mut merged, &mut n, (s, e)) {
                return Arrival::TableFull;
            }
        }
        if let Some(r) = new {
            if !put(&mut merged, &mut n, r) {
                return Arrival::TableFull;
            }
        }
        // The first range may now start at `next`: it becomes contiguous.
        let (first_start, first_end) = merged.first().copied().unwrap_or((0, 0));
        let advanced = n > 0 && first_start == self.next;
        let skip = usize::from(advanced);
        if n.saturating_sub(skip) > MAX_SACK_RANGES {
            return Arrival::TableFull;
        }
        self.len = 0;
        for &r in merged.get(skip..n).unwrap_or(&[]) {
            if let Some(slot) = self.held.get_mut(self.len) {
                *slot = r;
                self.len = self.len.saturating_add(1);
            }
        }
        if advanced {
            let from = core::mem::replace(&mut self.next, first_end);
            Arrival::Advanced { from, to: first_end }
        } else {
            Arrival::Held
        }
    }

    /// The acknowledgement of the data frame with sequence number `heard`, for the transfer
    /// named by `crc`.
    pub fn sack(&self, heard: u16, crc: u32) -> Sack {
        let mut ranges = SackRanges::new();
        for &(s, e) in self.held() {
            // Held ranges end at most `window` (≤ u16::MAX) bytes past `next`.
            let rel = |v: u32| u16::try_from(v.saturating_sub(self.next)).unwrap_or(u16::MAX);
            ranges.push(rel(s), rel(e));
        }
        Sack { next_offset: self.next, heard, window: self.window, crc, ranges }
    }
}

/// Appends `r` to `out[..n]`; false when `out` is full.
fn put(out: &mut [(u32, u32); MAX_SACK_RANGES + 1], n: &mut usize, r: (u32, u32)) -> bool {
    match out.get_mut(*n) {
        Some(slot) => {
            *slot = r;
            *n = n.saturating_add(1);
            true
        }
        None => false,
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    #[test]
    fn in_order_frames_advance_next() {
        let mut w = ReceiveWindow::new(100, 40);
        assert_eq!(w.arrive(0, 10), Arrival::Advanced { from: 0, to: 10 });
        assert_eq!(w.arrive(10, 30), Arrival::Advanced { from: 10, to: 40 });
        assert_eq!(w.arrive(0, 40), Arrival::Nothing);
        assert_eq!(w.arrive(40, 0), Arrival::Nothing);
        assert_eq!(w.arrive(40, 60), Arrival::OutOfWindow);
        assert_eq!(w.arrive(90, 20), Arrival::PastEnd);
        assert_eq!(w.arrive(u32::MAX, 2), Arrival::PastEnd);
        assert_eq!(w.arrive(40, 40), Arrival::Advanced { from: 40, to: 80 });
        assert_eq!(w.arrive(80, 20), Arrival::Advanced { from: 80, to: 100 });
        assert!(w.complete());
    }

    #[test]
    fn gaps_are_held_and_filled_out_of_order() {
        let mut w = ReceiveWindow::new(1000, 1000);
        assert_eq!(w.arrive(100, 10), Arrival::Held);
        assert_eq!(w.arrive(300, 10), Arrival::Held);
        assert_eq!(w.arrive(110, 10), Arrival::Held); // touches: merges
        assert_eq!(w.held(), [(100, 120), (300, 310)]);
        assert_eq!(w.arrive(105, 10), Arrival::Nothing); // inside
        let s = w.sack(7, 0xABCD);
        assert_eq!((s.next_offset, s.heard, s.window, s.crc), (0, 7, 1000, 0xABCD));
        assert_eq!(s.ranges.as_slice(), [(100, 120), (300, 310)]);
        assert_eq!(w.arrive(0, 100), Arrival::Advanced { from: 0, to: 120 });
        assert_eq!(w.sack(8, 0).ranges.as_slice(), [(180, 190)]);
        // A frame overlapping [..next) and bridging to the held range.
        assert_eq!(w.arrive(50, 250), Arrival::Advanced { from: 120, to: 310 });
        assert!(w.held().is_empty());
    }

    #[test]
    fn a_fifth_range_is_refused_and_changes_nothing() {
        let mut w = ReceiveWindow::new(1000, 1000);
        for k in 1..=4 {
            assert_eq!(w.arrive(100 * k, 10), Arrival::Held);
        }
        let before = w;
        assert_eq!(w.arrive(500, 10), Arrival::TableFull);
        assert_eq!(w.arrive(50, 10), Arrival::TableFull);
        assert_eq!(w, before);
        // Bridging two ranges frees a slot.
        assert_eq!(w.arrive(110, 90), Arrival::Held);
        assert_eq!(w.held(), [(100, 210), (300, 310), (400, 410)]);
        assert_eq!(w.arrive(500, 10), Arrival::Held);
        // Filling the front advances past the first range only.
        assert_eq!(w.arrive(0, 100), Arrival::Advanced { from: 0, to: 210 });
        assert_eq!(w.held(), [(300, 310), (400, 410), (500, 510)]);
    }

    #[test]
    fn every_order_of_every_split_reassembles_the_whole() {
        use rand::{seq::SliceRandom, Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..2000 {
            let total = rng.gen_range(1..400u32);
            let mut cuts: Vec<u32> = (0..rng.gen_range(0..12)).map(|_| rng.gen_range(0..total)).collect();
            cuts.extend([0, total]);
            cuts.sort_unstable();
            cuts.dedup();
            let mut frames: Vec<(u32, u32)> = cuts.windows(2).map(|c| (c[0], c[1] - c[0])).collect();
            frames.shuffle(&mut rng);
            let longest = frames.iter().map(|f| f.1).max().unwrap_or(1).max(1);
            let mut w = ReceiveWindow::new(total, rng.gen_range(longest..=500) as u16);
            let mut have = vec![false; total as usize];
            // Resend what was refused until everything is in, as a sender would.
            for _ in 0..1000 {
                let mut left = Vec::new();
                for &(o, n) in &frames {
                    match w.arrive(o, n) {
                        a if a.accepted() => have[o as usize..(o + n) as usize].iter_mut().for_each(|h| *h = true),
                        Arrival::Nothing => {}
                        _ => left.push((o, n)),
                    }
                    // The tracker agrees with a plain bitmap.
                    let next = have.iter().position(|h| !h).unwrap_or(have.len()) as u32;
                    assert_eq!(w.next(), next);
                    for &(s, e) in w.held() {
                        assert!(s > next && s < e && have[s as usize..e as usize].iter().all(|h| *h));
                        assert!(!have[s as usize - 1]);
                    }
                }
                frames = left;
                if frames.is_empty() {
                    break;
                }
            }
            assert!(w.complete(), "{total} bytes: {w:?}");
        }
    }
}

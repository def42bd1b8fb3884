//! Fields of the windowed transfers (SPEC.md §3.14): the selective acknowledgement
//! [`Sack`] that `SceneSack` and `FlashSack` carry, and its list of received ranges.

/// Most ranges a [`Sack`] lists.
pub const MAX_SACK_RANGES: usize = 4;

/// Bytes of a `SceneSack` / `FlashSack` payload before its ranges.
pub const SACK_HEAD_LEN: usize = 16;

/// Bytes per listed range.
pub const SACK_RANGE_LEN: usize = 4;

/// Ranges received above `next_offset`, relative to it: `(start, end)` stands for the bytes
/// `next_offset + start .. next_offset + end`. Ascending, each non-empty, separated by a gap
/// of at least one missing byte, and `start ≥ 1` (byte `next_offset` is missing by
/// definition).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SackRanges {
    len: u8,
    ranges: [(u16, u16); MAX_SACK_RANGES],
}

impl SackRanges {
    /// No ranges.
    pub const fn new() -> Self {
        Self { len: 0, ranges: [(0, 0); MAX_SACK_RANGES] }
    }

    /// Appends `(start, end)`; `false` (and nothing added) when the list is full or the range
    /// breaks the ordering rules of the type.
    pub fn push(&mut self, start: u16, end: u16) -> bool {
        let after = match self.as_slice().last() {
            Some(&(_, prev_end)) => start > prev_end,
            None => start >= 1,
        };
        match self.ranges.get_mut(self.len as usize) {
            Some(slot) if after && end > start => {
                *slot = (start, end);
                self.len = self.len.saturating_add(1);
                true
            }
            _ => false,
        }
    }

    /// The ranges.
    pub fn as_slice(&self) -> &[(u16, u16)] {
        self.ranges.get(..self.len as usize).unwrap_or(&[])
    }

    /// Number of ranges.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// True when no range is listed.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// A selective acknowledgement: what a receiver holds of a windowed transfer.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Sack {
    /// Every byte below this offset was received and accepted.
    pub next_offset: u32,
    /// Sequence number (frame header) of the data frame this answers.
    pub heard: u16,
    /// Bytes from `next_offset` on that the receiver accepts; a data frame reaching past
    /// `next_offset + window` is dropped.
    pub window: u16,
    /// CRC-32 of the whole image as announced by the transfer's `SceneBegin` / `FlashBegin`
    /// (it names the transfer).
    pub crc: u32,
    /// Bytes held above `next_offset`.
    pub ranges: SackRanges,
}

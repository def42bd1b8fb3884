//! The worker harts of the LiteX SoC (`soc/gridrt_soc/harts.py`): starting them, and the
//! three mailbox words the first hart and a worker coordinate a frame through.
//!
//! The words are uncached registers, each written by one side only, so neither atomics nor
//! cache maintenance are needed for them; the memory they point at (the frame's state, the
//! worker's rows) is another matter: the reader invalidates its data cache first
//! (the image's `harts` module).
//!
//! The protocol, one frame (`seq` counts frames, never 0):
//! 1. The first hart writes the frame's state to memory, sets `TAKEN` to 0 and posts
//!    [`Job`] `{seq, cancel: false}`.
//! 2. The worker traces its rows, each into one of two slots, and after each publishes
//!    [`Done::Rows`] `{seq, rows, finished: false}`; it waits while both slots hold rows
//!    the first hart has not taken (`rows − TAKEN = 2`).
//! 3. The first hart takes the worker's rows in order and counts them in `TAKEN`.
//! 4. At the frame's end, or when it stops early, the first hart posts `{seq, cancel: true}`;
//!    the worker, between rows, sees it (or runs out of rows) and publishes `finished: true`.
//!    Only then may the frame's state change.
//!
//! A worker that traps publishes [`Done::Trapped`] and stops; the first hart then holds it
//! in reset and renders alone.

pub mod regs;

use super::Mmio;

/// The first hart's job word (`JOB`): bits 31..16 `seq`, bit 0 `cancel`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Job {
    /// The frame; 0 = no job yet.
    pub seq: u16,
    /// The frame is over: stop after the current row.
    pub cancel: bool,
}

impl Job {
    /// The register word.
    pub const fn to_word(self) -> u32 {
        (self.seq as u32) << 16 | self.cancel as u32
    }

    /// From the register word.
    pub const fn from_word(w: u32) -> Self {
        Self { seq: (w >> 16) as u16, cancel: w & 1 != 0 }
    }
}

/// The worker's progress word (`DONE`).
///
/// | bits | field |
/// |---|---|
/// | 31..16 | `seq`: the frame |
/// | 15 | `finished`: the worker has stopped work on that frame |
/// | 14..0 | `rows`: its rows traced and published so far |
///
/// [`Done::TRAPPED`] (`0xFFFF_FFFF`) says the worker trapped; 0 is a worker that has started
/// and had no job yet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Done {
    /// Progress on frame `seq`.
    Rows {
        /// The frame.
        seq: u16,
        /// Rows published.
        rows: u16,
        /// Stopped: no more rows come for this frame.
        finished: bool,
    },
    /// The worker trapped and stopped.
    Trapped,
}

impl Done {
    /// The word a trapped worker writes (its trap handler, in assembly).
    pub const TRAPPED: u32 = u32::MAX;
    /// The most rows a frame can publish (15 bits).
    pub const MAX_ROWS: u16 = 0x7FFF;

    /// The register word.
    pub const fn to_word(self) -> u32 {
        match self {
            Done::Rows { seq, rows, finished } => {
                (seq as u32) << 16 | (finished as u32) << 15 | (rows & Self::MAX_ROWS) as u32
            }
            Done::Trapped => Self::TRAPPED,
        }
    }

    /// From the register word.
    pub const fn from_word(w: u32) -> Self {
        if w == Self::TRAPPED {
            return Done::Trapped;
        }
        Done::Rows { seq: (w >> 16) as u16, rows: (w as u16) & Self::MAX_ROWS, finished: w & 1 << 15 != 0 }
    }
}

/// The worker harts' registers.
pub struct HartCsr<M: Mmio> {
    mmio: M,
}

impl<M: Mmio> HartCsr<M> {
    /// Wraps the register block.
    pub const fn new(mmio: M) -> Self {
        Self { mmio }
    }

    /// Harts of this build, the first included (1: no worker).
    pub fn count(&self) -> u32 {
        self.mmio.read32(regs::COUNT) & 0xFF
    }

    /// Holds the workers in reset, clears the mailboxes, sets their entry point and lets
    /// them run: they start at `entry`.
    pub fn start(&self, entry: u32) {
        self.stop();
        self.mmio.write32(regs::JOB, 0);
        self.mmio.write32(regs::TAKEN, 0);
        self.mmio.write32(regs::DONE, 0);
        self.mmio.write32(regs::ENTRY, entry);
        self.mmio.write32(regs::RUN, 1);
    }

    /// Holds the workers in reset.
    pub fn stop(&self) {
        self.mmio.write32(regs::RUN, 0);
    }

    /// Whether the workers run.
    pub fn running(&self) -> bool {
        self.mmio.read32(regs::RUN) & 1 != 0
    }

    /// Posts the worker's job (first hart).
    pub fn post(&self, job: Job) {
        self.mmio.write32(regs::JOB, job.to_word());
    }

    /// The posted job (worker).
    pub fn job(&self) -> Job {
        Job::from_word(self.mmio.read32(regs::JOB))
    }

    /// Counts the worker's rows the first hart has taken (first hart).
    pub fn set_taken(&self, rows: u16) {
        self.mmio.write32(regs::TAKEN, u32::from(rows));
    }

    /// The worker's rows the first hart has taken (worker).
    pub fn taken(&self) -> u16 {
        self.mmio.read32(regs::TAKEN) as u16
    }

    /// Publishes the worker's progress (worker).
    pub fn report(&self, done: Done) {
        self.mmio.write32(regs::DONE, done.to_word());
    }

    /// The worker's progress (first hart).
    pub fn done(&self) -> Done {
        Done::from_word(self.mmio.read32(regs::DONE))
    }
}

#[cfg(test)]
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::MockMmio;

    #[test]
    fn words_round_trip_and_trapped_is_not_a_progress_word() {
        for seq in [1u16, 2, 0x7FFF, 0xFFFF] {
            for cancel in [false, true] {
                let j = Job { seq, cancel };
                assert_eq!(Job::from_word(j.to_word()), j);
            }
            for rows in [0u16, 1, 2047, Done::MAX_ROWS] {
                for finished in [false, true] {
                    let d = Done::Rows { seq, rows, finished };
                    if d.to_word() == Done::TRAPPED {
                        // The only progress word that collides: seq 0xFFFF, finished,
                        // 0x7FFF rows; the first hart never numbers a frame 0xFFFF.
                        assert_eq!((seq, rows, finished), (0xFFFF, Done::MAX_ROWS, true));
                        continue;
                    }
                    assert_eq!(Done::from_word(d.to_word()), d);
                }
            }
        }
        assert_eq!(Done::from_word(Done::TRAPPED), Done::Trapped);
        assert_eq!(Done::from_word(0), Done::Rows { seq: 0, rows: 0, finished: false });
    }

    #[test]
    fn start_holds_the_workers_in_reset_until_the_mailboxes_and_entry_are_set() {
        let mock = MockMmio::new();
        HartCsr::new(&mock).start(0x4000_1234);
        assert_eq!(
            mock.writes(),
            vec![(RUN, 0), (JOB, 0), (TAKEN, 0), (DONE, 0), (ENTRY, 0x4000_1234), (RUN, 1)]
        );
    }

    #[test]
    fn count_reads_the_low_byte() {
        let mock = MockMmio::new();
        mock.set(COUNT, 0xFFFF_FF02);
        assert_eq!(HartCsr::new(&mock).count(), 2);
    }
}

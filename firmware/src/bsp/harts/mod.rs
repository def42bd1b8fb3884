//! The worker harts of the LiteX SoC (`soc/gridrt_soc/harts.py`): starting them, and the
//! registers the first hart and the workers coordinate a frame through.
//!
//! The registers are uncached, and each is written by one side only, except `TICKET` and the
//! `READY` bitmap, whose updates the gateware makes indivisible (one bus access each); so
//! neither atomics nor cache maintenance are needed for them. The memory they refer to (the
//! frame's state, the traced rows) is another matter: the reader invalidates its data cache
//! first (the image's `harts` module).
//!
//! The protocol, one frame of n rows (`seq` counts frames, never 0); rows are handed over in
//! [`regs::SLOTS`] slots, row k in slot k mod SLOTS:
//! 1. The first hart writes the frame's state to memory, sets `TICKET` and `SENT` to 0 and
//!    clears `READY`, then posts [`Job`] `{seq, cancel: false}`.
//! 2. Every hart claims rows by reading `TICKET` (k ≥ n: none left). A worker waits until
//!    slot k mod SLOTS is free (k < `SENT` + SLOTS), traces row k into it and sets its
//!    `READY` bit. The first hart traces the rows it claims into a buffer of its own.
//! 3. The first hart sends the rows in order: row `SENT` as soon as it is ready, clearing its
//!    bit and counting it in `SENT`; it claims a row of its own only while the next row is
//!    not ready.
//! 4. At the frame's end, or when it stops early, the first hart posts `{seq, cancel: true}`;
//!    each worker, between rows, sees it (or runs out of rows) and reports
//!    [`Done::Rows`] `{seq, finished: true}`. Only then may the frame's state change.
//!
//! No hart waits for a row that waits for it: the row `SENT` is ready or being traced by
//! the hart that claimed it, whose slot is free (`SENT` < `SENT` + SLOTS).
//!
//! A worker that traps reports [`Done::Trapped`] and stops; the first hart then holds every
//! worker in reset and renders alone.

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
/// | 14..0 | `rows`: the rows it traced of that frame |
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

    /// Harts of this build, the first included (1: no worker), at most
    /// [`regs::MAX_HARTS`].
    pub fn count(&self) -> u32 {
        (self.mmio.read32(regs::COUNT) & 0xFF).min(regs::MAX_HARTS)
    }

    /// Holds the workers in reset, clears their state words, sets their entry point and
    /// lets them run: worker k starts at `entry` + [`regs::ENTRY_STRIDE`]·(k − 1).
    pub fn start(&self, entry: u32) {
        self.stop();
        self.mmio.write32(regs::JOB, 0);
        for k in 1..regs::MAX_HARTS {
            self.report(k, Done::Rows { seq: 0, rows: 0, finished: false });
        }
        self.mmio.write32(regs::ENTRY, entry);
        self.mmio.write32(regs::RUN, 1);
    }

    /// Holds the workers in reset.
    pub fn stop(&self) {
        self.mmio.write32(regs::RUN, 0);
    }

    /// Opens frame `seq`: no row claimed, sent or ready, then the job posted (first hart).
    pub fn open(&self, seq: u16) {
        self.mmio.write32(regs::TICKET, 0);
        self.mmio.write32(regs::SENT, 0);
        self.mmio.write32(regs::READY_CLR, u32::MAX);
        self.post(Job { seq, cancel: false });
    }

    /// Posts the workers' job (first hart).
    pub fn post(&self, job: Job) {
        self.mmio.write32(regs::JOB, job.to_word());
    }

    /// The posted job (workers).
    pub fn job(&self) -> Job {
        Job::from_word(self.mmio.read32(regs::JOB))
    }

    /// Claims the next row: each read returns another number.
    pub fn claim(&self) -> u16 {
        self.mmio.read32(regs::TICKET) as u16
    }

    /// Counts the rows the first hart has sent (first hart).
    pub fn set_sent(&self, rows: u16) {
        self.mmio.write32(regs::SENT, u32::from(rows));
    }

    /// Rows the first hart has sent (workers).
    pub fn sent(&self) -> u16 {
        self.mmio.read32(regs::SENT) as u16
    }

    /// Whether slot `slot` holds a row not yet sent.
    pub fn is_ready(&self, slot: u16) -> bool {
        self.mmio.read32(regs::READY) >> (slot % regs::SLOTS) & 1 != 0
    }

    /// Marks slot `slot` ready (the worker that traced its row).
    pub fn set_ready(&self, slot: u16) {
        self.mmio.write32(regs::READY_SET, 1 << (slot % regs::SLOTS));
    }

    /// Marks slot `slot` free (the first hart, once it sent the row).
    pub fn clear_ready(&self, slot: u16) {
        self.mmio.write32(regs::READY_CLR, 1 << (slot % regs::SLOTS));
    }

    fn done_reg(worker: u32) -> usize {
        let k = worker.clamp(1, regs::MAX_HARTS - 1) as usize;
        regs::DONE1.wrapping_add(4usize.wrapping_mul(k.wrapping_sub(1)))
    }

    /// Reports worker `worker`'s state (that worker, 1..=3).
    pub fn report(&self, worker: u32, done: Done) {
        self.mmio.write32(Self::done_reg(worker), done.to_word());
    }

    /// Worker `worker`'s state (first hart).
    pub fn done(&self, worker: u32) -> Done {
        Done::from_word(self.mmio.read32(Self::done_reg(worker)))
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
    fn start_holds_the_workers_in_reset_until_their_state_and_entry_are_set() {
        let mock = MockMmio::new();
        HartCsr::new(&mock).start(0x4000_1234);
        assert_eq!(
            mock.writes(),
            vec![(RUN, 0), (JOB, 0), (DONE1, 0), (DONE1 + 4, 0), (DONE1 + 8, 0), (ENTRY, 0x4000_1234), (RUN, 1)]
        );
    }

    #[test]
    fn open_resets_the_frame_registers_before_posting_the_job() {
        let mock = MockMmio::new();
        HartCsr::new(&mock).open(7);
        assert_eq!(mock.writes(), vec![(TICKET, 0), (SENT, 0), (READY_CLR, u32::MAX), (JOB, 7 << 16)]);
    }

    #[test]
    fn slots_wrap_at_the_bitmap_and_worker_states_have_their_own_words() {
        let mock = MockMmio::new();
        let h = HartCsr::new(&mock);
        h.set_ready(SLOTS + 3);
        h.clear_ready(3);
        h.report(3, Done::Trapped);
        assert_eq!(mock.writes(), vec![(READY_SET, 1 << 3), (READY_CLR, 1 << 3), (DONE1 + 8, Done::TRAPPED)]);
        mock.set(READY, 1 << 5);
        assert!(h.is_ready(5) && h.is_ready(SLOTS + 5) && !h.is_ready(4));
    }

    #[test]
    fn count_reads_the_low_byte() {
        let mock = MockMmio::new();
        mock.set(COUNT, 0xFFFF_FF02);
        assert_eq!(HartCsr::new(&mock).count(), 2);
        mock.set(COUNT, 9);
        assert_eq!(HartCsr::new(&mock).count(), MAX_HARTS, "never more harts than the block serves");
    }
}

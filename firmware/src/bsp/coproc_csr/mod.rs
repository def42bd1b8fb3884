//! The co-processor's CSR FIFOs in the LiteX SoC (`soc/gridrt_soc/coproc.py`,
//! `GridrtCoprocCSR`): the FSL-style word link to the RTL co-processor.
//!
//! # FSL ↔ CSR FIFOs
//!
//! | FSL | CSR FIFOs |
//! | --- | --- |
//! | `nput(data, control = false)` | write `data` to `REQ` |
//! | `nput(data, control = true)`  | write `data` to `REQ_LAST` (tlast on this word) |
//! | `nget() -> (data, control)`   | read `STATUS` (a word waiting? its control bit), then read `RSP` (pops it) |
//!
//! Unlike the AXI4-Stream FIFO (`super::axis_fifo`) this is cut-through: words reach the
//! co-processor as they are written, so a request of any length can be sent. The free
//! request slots (`STATUS.req_space`) are cached, so a request word costs one CSR write
//! and `STATUS` is only read when the cached count runs out; a reply word costs two reads.
//!
//! Only non-blocking operations are offered: bounded blocking comes with the `FslLink`
//! trait.

pub mod regs;

use super::mmio::Mmio;

/// Errors of the link: the FIFOs' sticky error flags, which the driver's own accounting
/// never raises (a dropped request word or a read of an empty reply FIFO).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CoprocCsrError {
    /// A request word was written into a full FIFO and dropped (`STATUS.req_overflow`).
    RequestOverflow,
    /// `RSP` was read with no reply word waiting (`STATUS.rsp_underflow`).
    ReplyUnderflow,
}

impl core::fmt::Display for CoprocCsrError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::RequestOverflow => "co-processor request FIFO overflow: a word was dropped",
            Self::ReplyUnderflow => "co-processor reply FIFO read while empty",
        })
    }
}

/// The co-processor's CSR FIFOs as a word link with packet boundaries.
pub struct CoprocCsr<M: Mmio> {
    mmio: M,
    /// Free request slots known without reading `STATUS`.
    req_space: u32,
}

impl<M: Mmio> CoprocCsr<M> {
    /// Wraps the register block; call [`CoprocCsr::init`] before use.
    pub const fn new(mmio: M) -> Self {
        Self { mmio, req_space: 0 }
    }

    /// Resets the co-processor and empties both FIFOs (dropping any half-sent request or
    /// unread reply): the co-processor forgets its scene, as after power-up.
    pub fn init(&mut self) {
        self.mmio.write32(regs::CTRL, regs::CTRL_RESET);
        self.req_space = 0;
    }

    /// The co-processor's configuration, `(PEs, words per PE memory)`: the SoC reports what
    /// it was built with.
    pub fn config(&self) -> (u16, u32) {
        (u16::from(self.mmio.read32(regs::PES) as u8), self.mmio.read32(regs::PE_MEM_WORDS))
    }

    /// True when the co-processor waits for input with nothing to send (`STATUS.idle`).
    pub fn idle(&self) -> bool {
        self.mmio.read32(regs::STATUS) & regs::STATUS_IDLE != 0
    }

    fn check(status: u32) -> Result<(), CoprocCsrError> {
        if status & regs::STATUS_REQ_OVERFLOW != 0 {
            return Err(CoprocCsrError::RequestOverflow);
        }
        if status & regs::STATUS_RSP_UNDERFLOW != 0 {
            return Err(CoprocCsrError::ReplyUnderflow);
        }
        Ok(())
    }

    /// Non-blocking put of one word (MicroBlaze `nput`); `last` is the FSL control bit.
    /// `Err(WouldBlock)`: the request FIFO is full, nothing was written.
    pub fn nput_word(&mut self, data: u32, last: bool) -> nb::Result<(), CoprocCsrError> {
        if self.req_space == 0 {
            let status = self.mmio.read32(regs::STATUS);
            Self::check(status)?;
            self.req_space = (status >> regs::STATUS_REQ_SPACE_OFFSET) & regs::STATUS_LEVEL_MASK;
            if self.req_space == 0 {
                return Err(nb::Error::WouldBlock);
            }
        }
        self.mmio.write32(if last { regs::REQ_LAST } else { regs::REQ }, data);
        // Non-zero (checked above); the hardware only frees slots, never takes them.
        self.req_space = self.req_space.saturating_sub(1);
        Ok(())
    }

    /// Non-blocking get of one word (MicroBlaze `nget`): `(data, last)`, where `last` (the
    /// FSL control bit) marks a reply's final word. `Err(WouldBlock)`: no word is waiting,
    /// nothing was consumed.
    pub fn nget_word(&mut self) -> nb::Result<(u32, bool), CoprocCsrError> {
        let status = self.mmio.read32(regs::STATUS);
        Self::check(status)?;
        if (status >> regs::STATUS_RSP_LEVEL_OFFSET) & regs::STATUS_LEVEL_MASK == 0 {
            return Err(nb::Error::WouldBlock);
        }
        let data = self.mmio.read32(regs::RSP);
        Ok((data, status & regs::STATUS_RSP_LAST != 0))
    }

    /// Gives back the register block.
    pub fn free(self) -> M {
        self.mmio
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::MockMmio;

    fn status(req_space: u32, rsp_level: u32, flags: u32) -> u32 {
        req_space << STATUS_REQ_SPACE_OFFSET | rsp_level << STATUS_RSP_LEVEL_OFFSET | flags
    }

    #[test]
    fn init_resets_the_coprocessor_and_fifos() {
        let mock = MockMmio::new();
        CoprocCsr::new(&mock).init();
        assert_eq!(mock.writes(), vec![(CTRL, CTRL_RESET)]);
    }

    #[test]
    fn control_bit_selects_the_register_and_space_is_cached() {
        let mock = MockMmio::new();
        mock.queue(STATUS, &[status(16, 0, 0)]);
        let mut link = CoprocCsr::new(&mock);
        for (i, w) in [10, 20, 30].into_iter().enumerate() {
            assert_eq!(link.nput_word(w, i == 2), Ok(()));
        }
        assert_eq!(mock.writes(), vec![(REQ, 10), (REQ, 20), (REQ_LAST, 30)]);
        assert_eq!(mock.reads_at(STATUS), 1, "one status read for up to req_space words");
    }

    #[test]
    fn nput_would_block_when_the_fifo_is_full_then_resumes() {
        let mock = MockMmio::new();
        mock.queue(STATUS, &[status(1, 0, 0), status(0, 0, 0), status(2, 0, 0)]);
        let mut link = CoprocCsr::new(&mock);
        assert_eq!(link.nput_word(1, false), Ok(()));
        assert_eq!(link.nput_word(2, true), Err(nb::Error::WouldBlock));
        assert_eq!(mock.writes_at(REQ_LAST), Vec::<u32>::new());
        assert_eq!(link.nput_word(2, true), Ok(()));
        assert_eq!(mock.writes(), vec![(REQ, 1), (REQ_LAST, 2)]);
    }

    #[test]
    fn nget_pops_only_waiting_words_and_reports_the_control_bit() {
        let mock = MockMmio::new();
        mock.queue(STATUS, &[status(16, 0, STATUS_IDLE), status(16, 2, 0), status(16, 1, STATUS_RSP_LAST)]);
        mock.queue(RSP, &[0xA, 0xB]);
        let mut link = CoprocCsr::new(&mock);
        assert_eq!(link.nget_word(), Err(nb::Error::WouldBlock));
        assert_eq!(mock.reads_at(RSP), 0, "a read of RSP pops: never with the FIFO empty");
        assert_eq!(link.nget_word(), Ok((0xA, false)));
        assert_eq!(link.nget_word(), Ok((0xB, true)));
        assert_eq!(mock.reads_at(RSP), 2);
    }

    #[test]
    fn config_reads_the_built_pes_and_memory() {
        let mock = MockMmio::new();
        mock.set(PES, 0xFFFF_FF02);
        mock.set(PE_MEM_WORDS, 16384);
        assert_eq!(CoprocCsr::new(&mock).config(), (2, 16384));
        assert!(mock.writes().is_empty());
    }

    #[test]
    fn sticky_fifo_errors_are_reported() {
        let mock = MockMmio::new();
        mock.queue(STATUS, &[status(0, 1, STATUS_RSP_UNDERFLOW), status(0, 0, STATUS_REQ_OVERFLOW)]);
        let mut link = CoprocCsr::new(&mock);
        assert_eq!(link.nget_word(), Err(nb::Error::Other(CoprocCsrError::ReplyUnderflow)));
        assert_eq!(link.nput_word(1, true), Err(nb::Error::Other(CoprocCsrError::RequestOverflow)));
        assert_eq!(mock.reads_at(RSP), 0);
        assert!(mock.writes().is_empty());
    }
}

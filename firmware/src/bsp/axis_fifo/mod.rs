//! Xilinx AXI4-Stream FIFO (PG080) as the FSL-style stream link to the co-processor.
//!
//! # FSL ↔ AXI4-Stream mapping
//!
//! MicroBlaze FSL words carry 32 data bits plus one control bit; the co-processor
//! protocol sets the control bit on the **last word of a request/response**. On
//! AXI4-Stream that is exactly TLAST, so:
//!
//! | FSL | AXI4-Stream FIFO |
//! | --- | --- |
//! | `nput(data, control = false)` | push `data` to TDFD; the packet stays open |
//! | `nput(data, control = true)`  | push `data` to TDFD, then write the packet's byte length to TLR: the core sends the packet, TLAST on this word |
//! | `nget() -> (data, control)`   | at a packet start read RLR (byte length); pop RDFD; `control` is true on the packet's last word |
//!
//! Consequences of the store-and-forward design of the IP (the mode this driver needs;
//! cut-through receive is reported as [`AxisFifoError::RxCutThrough`]):
//! - nothing leaves the FPGA fabric until the control word is put, so a packet must fit
//!   in the TX FIFO ([`AxisFifoError::TxPacketTooLong`] otherwise; GridRT requests are
//!   8 words, the smallest FIFO depth is 512);
//! - a packet is only visible to `nget` once it has arrived completely.
//!
//! TDEST (TDR/RDR) is left at 0: there is one co-processor.
//!
//! Only non-blocking operations are offered: bounded blocking (a poll budget, so that
//! firmware loops over link data always end) comes with the `FslLink` trait.
//!
//! Vacancy and occupancy are cached, so a word costs one MMIO access in the common
//! case and TDFV/RDFO are only re-read when the cached count runs out.

pub mod regs;

use super::mmio::Mmio;

/// Errors of the stream link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum AxisFifoError {
    /// The open packet fills the whole TX FIFO without a control word: it can never be
    /// sent. Call [`AxisFifo::init`] to drop it.
    TxPacketTooLong {
        /// TX FIFO depth in words, as measured after reset.
        capacity_words: u32,
    },
    /// RLR announced a packet of 0 bytes.
    RxEmptyPacket,
    /// RLR flagged a partial packet: the IP is configured for cut-through receive,
    /// which this driver does not support.
    RxCutThrough,
    /// The core raised error bits in ISR (the `regs::ISR_*` error bits; now cleared).
    Core {
        /// The ISR error bits that were set.
        isr: u32,
    },
}

impl core::fmt::Display for AxisFifoError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TxPacketTooLong { capacity_words } => {
                write!(f, "stream packet longer than the TX FIFO ({capacity_words} words)")
            }
            Self::RxEmptyPacket => f.write_str("stream packet of length 0 received"),
            Self::RxCutThrough => f.write_str("stream FIFO in cut-through receive mode"),
            Self::Core { isr } => write!(f, "stream FIFO error bits {isr:#010x}"),
        }
    }
}

/// An AXI4-Stream FIFO used as a word link with packet boundaries.
pub struct AxisFifo<M: Mmio> {
    mmio: M,
    /// Words pushed to the open (not yet committed) TX packet.
    tx_pending: u32,
    /// Free TX words known without reading TDFV.
    tx_vacancy: u32,
    /// Largest vacancy seen with no open packet: the FIFO depth.
    tx_capacity: u32,
    /// Words of the current RX packet not yet popped; 0 between packets.
    rx_remaining: u32,
    /// RX words known to be in the FIFO without reading RDFO.
    rx_occupancy: u32,
}

impl<M: Mmio> AxisFifo<M> {
    /// Wraps the register block; call [`AxisFifo::init`] before use.
    pub const fn new(mmio: M) -> Self {
        Self { mmio, tx_pending: 0, tx_vacancy: 0, tx_capacity: 0, rx_remaining: 0, rx_occupancy: 0 }
    }

    /// Empties both FIFOs (dropping any half-sent or half-read packet), turns interrupts
    /// off, clears ISR and measures the TX FIFO depth.
    ///
    /// This does not reset the stream interfaces (SRR), so the co-processor is not reset.
    pub fn init(&mut self) {
        self.mmio.write32(regs::IER, 0);
        self.mmio.write32(regs::TDFR, regs::RESET_KEY);
        self.mmio.write32(regs::RDFR, regs::RESET_KEY);
        self.mmio.write32(regs::ISR, regs::ISR_CLEAR_ALL);
        self.tx_pending = 0;
        self.rx_remaining = 0;
        self.rx_occupancy = 0;
        self.tx_vacancy = self.mmio.read32(regs::TDFV);
        self.tx_capacity = self.tx_vacancy;
    }

    /// TX FIFO depth in words (0 until measured): the longest packet that can be sent.
    pub fn tx_capacity_words(&self) -> u32 {
        self.tx_capacity
    }

    /// True while a received packet has been started but not read to its last word.
    pub fn rx_in_packet(&self) -> bool {
        self.rx_remaining != 0
    }

    /// Reads ISR; if error bits are set, clears them and reports them.
    fn take_errors(&mut self) -> Result<(), AxisFifoError> {
        let isr = self.mmio.read32(regs::ISR) & regs::ISR_ERRORS;
        if isr == 0 {
            return Ok(());
        }
        self.mmio.write32(regs::ISR, isr);
        Err(AxisFifoError::Core { isr })
    }

    /// Non-blocking put of one word (MicroBlaze `nput`); `last` is the FSL control bit
    /// and ends the packet (TLAST). `Err(WouldBlock)`: the TX FIFO is full, nothing was
    /// written.
    pub fn nput_word(&mut self, data: u32, last: bool) -> nb::Result<(), AxisFifoError> {
        if self.tx_vacancy == 0 {
            self.tx_vacancy = self.mmio.read32(regs::TDFV);
            if self.tx_pending == 0 {
                self.tx_capacity = self.tx_capacity.max(self.tx_vacancy);
            }
            if self.tx_vacancy == 0 {
                // Our own open packet filling the FIFO can never drain: fail, don't spin.
                if self.tx_capacity != 0 && self.tx_pending >= self.tx_capacity {
                    return Err(nb::Error::Other(AxisFifoError::TxPacketTooLong { capacity_words: self.tx_capacity }));
                }
                return Err(nb::Error::WouldBlock);
            }
        }
        self.mmio.write32(regs::TDFD, data);
        // Vacancy was non-zero; pending stays below the FIFO's capacity (checked above).
        self.tx_vacancy = self.tx_vacancy.saturating_sub(1);
        self.tx_pending = self.tx_pending.saturating_add(1);
        if last {
            let bytes = self.tx_pending.saturating_mul(regs::WORD_BYTES);
            self.tx_pending = 0;
            self.mmio.write32(regs::TLR, bytes & regs::LEN_MASK);
            // TSE/TPOE would mean the core disagrees with the length just committed.
            self.take_errors()?;
        }
        Ok(())
    }

    /// Non-blocking get of one word (MicroBlaze `nget`): `(data, last)`, where `last`
    /// (the FSL control bit) marks the packet's final word. `Err(WouldBlock)`: no
    /// complete packet (or no further word) is waiting, nothing was consumed.
    pub fn nget_word(&mut self) -> nb::Result<(u32, bool), AxisFifoError> {
        if self.rx_occupancy == 0 {
            self.rx_occupancy = self.mmio.read32(regs::RDFO);
            if self.rx_occupancy == 0 {
                return Err(nb::Error::WouldBlock);
            }
        }
        if self.rx_remaining == 0 {
            self.take_errors()?;
            let rlr = self.mmio.read32(regs::RLR);
            if rlr & regs::RLR_PARTIAL != 0 {
                return Err(nb::Error::Other(AxisFifoError::RxCutThrough));
            }
            let bytes = rlr & regs::LEN_MASK;
            if bytes == 0 {
                return Err(nb::Error::Other(AxisFifoError::RxEmptyPacket));
            }
            // A trailing partial word (length not a multiple of 4) is still one FIFO
            // word; the co-processor only sends whole words.
            self.rx_remaining = bytes.div_ceil(regs::WORD_BYTES);
        }
        let data = self.mmio.read32(regs::RDFD);
        // Both were non-zero (read from the core, or counted down from its RLR).
        self.rx_occupancy = self.rx_occupancy.saturating_sub(1);
        self.rx_remaining = self.rx_remaining.saturating_sub(1);
        Ok((data, self.rx_remaining == 0))
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

    fn fifo_with_depth(mock: &MockMmio, depth: u32) -> AxisFifo<&MockMmio> {
        mock.queue(TDFV, &[depth]);
        let mut fifo = AxisFifo::new(mock);
        fifo.init();
        fifo
    }

    #[test]
    fn init_resets_fifos_clears_isr_and_measures_depth() {
        let mock = MockMmio::new();
        let fifo = fifo_with_depth(&mock, 512);
        assert_eq!(mock.writes(), vec![(IER, 0), (TDFR, RESET_KEY), (RDFR, RESET_KEY), (ISR, ISR_CLEAR_ALL)]);
        assert_eq!(fifo.tx_capacity_words(), 512);
        assert!(mock.writes_at(SRR).is_empty(), "init must not reset the co-processor");
    }

    #[test]
    fn control_word_commits_packet_length_in_bytes() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 512);
        let before = mock.writes().len();
        for (i, w) in [10, 20, 30].into_iter().enumerate() {
            assert_eq!(fifo.nput_word(w, i == 2), Ok(()));
        }
        assert_eq!(mock.writes()[before..], [(TDFD, 10), (TDFD, 20), (TDFD, 30), (TLR, 12)]);
        // Vacancy was cached from init: no TDFV re-read per word.
        assert_eq!(mock.reads_at(TDFV), 1);
    }

    #[test]
    fn nput_would_block_when_fifo_full_then_resumes() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 1);
        assert_eq!(fifo.nput_word(1, true), Ok(()));
        mock.queue(TDFV, &[0, 4]);
        assert_eq!(fifo.nput_word(2, true), Err(nb::Error::WouldBlock));
        assert_eq!(mock.writes_at(TDFD), vec![1]);
        assert_eq!(fifo.nput_word(2, true), Ok(()));
        assert_eq!(mock.writes_at(TDFD), vec![1, 2]);
        assert_eq!(mock.writes_at(TLR), vec![4, 4]);
        assert_eq!(fifo.tx_capacity_words(), 4, "vacancy with no open packet refines the depth");
    }

    #[test]
    fn packet_longer_than_fifo_is_an_error_not_a_hang() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 2);
        assert_eq!(fifo.nput_word(1, false), Ok(()));
        assert_eq!(fifo.nput_word(2, false), Ok(()));
        assert_eq!(
            fifo.nput_word(3, false),
            Err(nb::Error::Other(AxisFifoError::TxPacketTooLong { capacity_words: 2 }))
        );
        assert!(mock.writes_at(TLR).is_empty());
    }

    #[test]
    fn tx_size_error_is_reported_and_cleared() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 8);
        mock.queue(ISR, &[ISR_TSE | ISR_TC]);
        assert_eq!(fifo.nput_word(5, true), Err(nb::Error::Other(AxisFifoError::Core { isr: ISR_TSE })));
        assert_eq!(mock.writes().last(), Some(&(ISR, ISR_TSE)));
    }

    #[test]
    fn nget_reads_length_once_and_flags_last_word() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 8);
        assert_eq!(fifo.nget_word(), Err(nb::Error::WouldBlock));
        assert_eq!(mock.reads_at(RLR), 0, "RLR must not be read with an empty FIFO");
        mock.queue(RDFO, &[3]);
        mock.queue(RLR, &[12]);
        mock.queue(RDFD, &[0xA, 0xB, 0xC]);
        assert_eq!(fifo.nget_word(), Ok((0xA, false)));
        assert!(fifo.rx_in_packet());
        assert_eq!(fifo.nget_word(), Ok((0xB, false)));
        assert_eq!(fifo.nget_word(), Ok((0xC, true)));
        assert!(!fifo.rx_in_packet());
        assert_eq!(mock.reads_at(RLR), 1);
        assert_eq!(mock.reads_at(RDFO), 2, "occupancy is cached within the packet");
    }

    #[test]
    fn nget_waits_for_occupancy_inside_a_packet() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 8);
        mock.queue(RDFO, &[1, 0, 1]);
        mock.queue(RLR, &[8]);
        mock.queue(RDFD, &[1, 2]);
        assert_eq!(fifo.nget_word(), Ok((1, false)));
        assert_eq!(fifo.nget_word(), Err(nb::Error::WouldBlock));
        assert_eq!(fifo.nget_word(), Ok((2, true)));
        assert_eq!(mock.reads_at(RDFD), 2, "RDFD is never read while empty (RPUE)");
    }

    #[test]
    fn nget_rejects_empty_and_cut_through_packets() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 8);
        mock.set(RDFO, 1);
        mock.queue(RLR, &[0, RLR_PARTIAL | 4]);
        assert_eq!(fifo.nget_word(), Err(nb::Error::Other(AxisFifoError::RxEmptyPacket)));
        assert_eq!(fifo.nget_word(), Err(nb::Error::Other(AxisFifoError::RxCutThrough)));
        assert_eq!(mock.reads_at(RDFD), 0);
    }

    #[test]
    fn rx_error_bits_are_reported_at_packet_start() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 8);
        mock.set(RDFO, 1);
        mock.queue(ISR, &[ISR_RPUE | ISR_RC]);
        mock.set(RLR, 4);
        mock.set(RDFD, 9);
        assert_eq!(fifo.nget_word(), Err(nb::Error::Other(AxisFifoError::Core { isr: ISR_RPUE })));
        assert_eq!(fifo.nget_word(), Ok((9, true)));
    }

    #[test]
    fn words_round_trip_after_would_block() {
        let mock = MockMmio::new();
        let mut fifo = fifo_with_depth(&mock, 16);
        assert_eq!(fifo.nput_word(0xDEAD_BEEF, true), Ok(()));
        mock.queue(RDFO, &[0, 0, 1]);
        mock.queue(RLR, &[4]);
        mock.queue(RDFD, &[0xDEAD_BEEF]);
        assert_eq!(fifo.nget_word(), Err(nb::Error::WouldBlock));
        assert_eq!(fifo.nget_word(), Err(nb::Error::WouldBlock));
        assert_eq!(fifo.nget_word(), Ok((0xDEAD_BEEF, true)));
        assert_eq!(mock.writes_at(TDFD), vec![0xDEAD_BEEF]);
    }
}

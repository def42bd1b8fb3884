//! Xilinx AXI4-Stream FIFO register map (PG080, "Register Space", AXI4-Lite data
//! interface). All registers are 32 bits wide. Lengths are in **bytes**, vacancy and
//! occupancy in 32-bit **words**.

/// 0x00, read / write-1-to-clear: Interrupt Status Register (bits below).
pub const ISR: usize = 0x00;
/// 0x04: Interrupt Enable Register (same bits as ISR). We run polled: 0.
pub const IER: usize = 0x04;
/// 0x08, write: Transmit Data FIFO Reset; write [`RESET_KEY`].
pub const TDFR: usize = 0x08;
/// 0x0C, read: Transmit Data FIFO Vacancy, free words in the TX FIFO.
pub const TDFV: usize = 0x0C;
/// 0x10, write: Transmit Data FIFO Data, pushes one word of the current packet.
pub const TDFD: usize = 0x10;
/// 0x14, write: Transmit Length, byte length of the packet just pushed; writing it
/// starts the transmission, with TLAST on its last word.
pub const TLR: usize = 0x14;
/// 0x18, write: Receive Data FIFO Reset; write [`RESET_KEY`].
pub const RDFR: usize = 0x18;
/// 0x1C, read: Receive Data FIFO Occupancy, words waiting in the RX FIFO.
pub const RDFO: usize = 0x1C;
/// 0x20, read: Receive Data FIFO Data, pops one word of the current packet.
pub const RDFD: usize = 0x20;
/// 0x24, read: Receive Length, byte length of the next packet (read once per packet,
/// before its data words).
pub const RLR: usize = 0x24;
/// 0x28, write: AXI4-Stream Reset, resets the whole core and the stream interfaces;
/// write [`RESET_KEY`].
pub const SRR: usize = 0x28;
/// 0x2C: Transmit Destination (TDEST of the next packet). Unused: one co-processor.
pub const TDR: usize = 0x2C;
/// 0x30, read: Receive Destination (TDEST of the packet being read). Unused.
pub const RDR: usize = 0x30;

/// Value that triggers a reset when written to TDFR, RDFR or SRR.
pub const RESET_KEY: u32 = 0xA5;

/// TLR/RLR bits 22:0: the packet length in bytes.
pub const LEN_MASK: u32 = 0x007F_FFFF;
/// RLR bit 31 (cut-through mode only): the length is of a partial packet.
pub const RLR_PARTIAL: u32 = 1 << 31;

/// ISR bit 31, RPURE: Receive Packet Underrun Read Error (RLR read with no packet).
pub const ISR_RPURE: u32 = 1 << 31;
/// ISR bit 30, RPORE: Receive Packet Overrun Read Error (more words read than RLR gave).
pub const ISR_RPORE: u32 = 1 << 30;
/// ISR bit 29, RPUE: Receive Packet Underrun Error (RDFD read while the FIFO was empty).
pub const ISR_RPUE: u32 = 1 << 29;
/// ISR bit 28, TPOE: Transmit Packet Overrun Error (TDFD written while the FIFO was full).
pub const ISR_TPOE: u32 = 1 << 28;
/// ISR bit 27, TC: Transmit Complete, a packet left on the stream.
pub const ISR_TC: u32 = 1 << 27;
/// ISR bit 26, RC: Receive Complete, a whole packet arrived.
pub const ISR_RC: u32 = 1 << 26;
/// ISR bit 25, TSE: Transmit Size Error (TLR disagrees with the words pushed).
pub const ISR_TSE: u32 = 1 << 25;
/// ISR bit 24, TRC: Transmit Reset Complete.
pub const ISR_TRC: u32 = 1 << 24;
/// ISR bit 23, RRC: Receive Reset Complete.
pub const ISR_RRC: u32 = 1 << 23;

/// Every ISR error bit, receive and transmit.
pub const ISR_ERRORS: u32 = ISR_RPURE | ISR_RPORE | ISR_RPUE | ISR_TPOE | ISR_TSE;
/// Value that clears every ISR bit (write-1-to-clear).
pub const ISR_CLEAR_ALL: u32 = 0xFFFF_FFFF;

/// Bytes per FIFO word (the AXI4-Lite data interface is 32 bits wide).
pub const WORD_BYTES: u32 = 4;

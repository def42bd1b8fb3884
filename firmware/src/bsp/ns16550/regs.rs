//! NS16550A register map (8-bit registers, byte stride as on QEMU `virt`).
//!
//! Offsets are in register units; the driver multiplies them by its stride
//! (`1 << reg_shift`), since SoC integrations often space them 4 bytes apart.

/// Offset 0, read: Receiver Buffer Register (next received byte). DLAB must be 0.
pub const RBR: usize = 0;
/// Offset 0, write: Transmitter Holding Register (byte to send). DLAB must be 0.
pub const THR: usize = 0;
/// Offset 0 with DLAB = 1: Divisor Latch, low byte.
pub const DLL: usize = 0;
/// Offset 1: Interrupt Enable Register. We run polled, so it stays 0.
pub const IER: usize = 1;
/// Offset 1 with DLAB = 1: Divisor Latch, high byte.
pub const DLM: usize = 1;
/// Offset 2, write: FIFO Control Register.
pub const FCR: usize = 2;
/// Offset 3: Line Control Register (frame format, DLAB).
pub const LCR: usize = 3;
/// Offset 5: Line Status Register.
pub const LSR: usize = 5;

/// IER value: all interrupts off.
pub const IER_NONE: u8 = 0x00;
/// FCR bit 0: enable the 16-byte FIFOs.
pub const FCR_ENABLE: u8 = 1 << 0;
/// FCR bit 1: clear the receive FIFO (self-clearing).
pub const FCR_CLEAR_RX: u8 = 1 << 1;
/// FCR bit 2: clear the transmit FIFO (self-clearing).
pub const FCR_CLEAR_TX: u8 = 1 << 2;
/// FCR bits 7:6 = 11: receive trigger level 14 bytes. Interrupts stay off, so on hardware
/// this changes nothing for a polled driver; QEMU's 16550 however hands the guest at most
/// "trigger level" bytes per main-loop turn, so level 1 (the reset value) caps host → device
/// throughput at about 20 KB/s on a `-serial pty`, and level 14 lifts it ~10x.
pub const FCR_RX_TRIGGER_14: u8 = 0b11 << 6;
/// LCR bits 1:0 = 0b11: 8 data bits; bit 2 = 0: 1 stop bit; bit 3 = 0: no parity (8N1).
pub const LCR_8N1: u8 = 0x03;
/// LCR bit 7: Divisor Latch Access Bit; offsets 0/1 address DLL/DLM while set.
pub const LCR_DLAB: u8 = 1 << 7;

/// LSR bit 0: Data Ready, a byte waits in RBR.
pub const LSR_DR: u8 = 1 << 0;
/// LSR bit 1: Overrun Error, a byte was lost because RBR/FIFO was full.
pub const LSR_OE: u8 = 1 << 1;
/// LSR bit 2: Parity Error on the byte at the head of the FIFO.
pub const LSR_PE: u8 = 1 << 2;
/// LSR bit 3: Framing Error (bad stop bit) on the byte at the head of the FIFO.
pub const LSR_FE: u8 = 1 << 3;
/// LSR bit 4: Break Interrupt, the line was held low for a whole frame.
pub const LSR_BI: u8 = 1 << 4;
/// LSR bit 5: Transmitter Holding Register Empty (the TX FIFO is empty in FIFO mode).
pub const LSR_THRE: u8 = 1 << 5;
/// LSR bit 6: Transmitter Empty, THR and the shift register are both empty.
pub const LSR_TEMT: u8 = 1 << 6;

//! LiteX UART register map (`litex/soc/cores/uart.py`, class `UART`) with 32-bit CSRs: one
//! register per 4-byte word, in the order the core declares them. The image crate checks
//! these offsets at compile time against the addresses LiteX exported for the SoC
//! (`litex_map.rs`, generated from csr.json).

/// 0x00, read: the receive FIFO's head byte (bits 7:0); with `rx_fifo_rx_we` (our SoC) the
/// read pops it. Write: push a byte into the transmit FIFO.
pub const RXTX: usize = 0x00;
/// 0x04, read: bit 0 set while the transmit FIFO is full.
pub const TXFULL: usize = 0x04;
/// 0x08, read: bit 0 set while the receive FIFO is empty.
pub const RXEMPTY: usize = 0x08;
/// 0x0C, read: event status (`EV_TX`, `EV_RX`).
pub const EV_STATUS: usize = 0x0C;
/// 0x10, read/write: pending events; writing a 1 clears one.
pub const EV_PENDING: usize = 0x10;
/// 0x14, read/write: events that raise the interrupt.
pub const EV_ENABLE: usize = 0x14;
/// 0x18, read: bit 0 set while the transmit FIFO is empty.
pub const TXEMPTY: usize = 0x18;
/// 0x1C, read: bit 0 set while the receive FIFO is full.
pub const RXFULL: usize = 0x1C;

/// Event bit 0: the transmit FIFO has room.
pub const EV_TX: u32 = 1 << 0;
/// Event bit 1: the receive FIFO holds a byte.
pub const EV_RX: u32 = 1 << 1;
/// Bit 0 of the flag registers (`TXFULL`, `RXEMPTY`, `TXEMPTY`, `RXFULL`).
pub const FLAG: u32 = 1 << 0;

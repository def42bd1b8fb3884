//! Xilinx AXI UART Lite register map (PG142, "Register Space"). All registers are 32
//! bits wide; only the low byte of the FIFOs carries data.

/// 0x0, read: Receive Data FIFO; a read pops one byte (bits 7:0).
pub const RX_FIFO: usize = 0x0;
/// 0x4, write: Transmit Data FIFO; a write pushes one byte (bits 7:0).
pub const TX_FIFO: usize = 0x4;
/// 0x8, read: Status Register. Reading it clears the error bits 5..7.
pub const STAT: usize = 0x8;
/// 0xC, write: Control Register.
pub const CTRL: usize = 0xC;

/// STAT bit 0: the receive FIFO holds at least one byte.
pub const STAT_RX_VALID: u32 = 1 << 0;
/// STAT bit 1: the receive FIFO is full (16 bytes).
pub const STAT_RX_FULL: u32 = 1 << 1;
/// STAT bit 2: the transmit FIFO is empty (the shift register may still be sending).
pub const STAT_TX_EMPTY: u32 = 1 << 2;
/// STAT bit 3: the transmit FIFO is full.
pub const STAT_TX_FULL: u32 = 1 << 3;
/// STAT bit 4: interrupts are enabled.
pub const STAT_INTR_ENABLED: u32 = 1 << 4;
/// STAT bit 5: overrun error, a byte arrived while the receive FIFO was full.
pub const STAT_OVERRUN: u32 = 1 << 5;
/// STAT bit 6: frame error (bad stop bit) on some received byte.
pub const STAT_FRAME: u32 = 1 << 6;
/// STAT bit 7: parity error on some received byte (only with parity configured).
pub const STAT_PARITY: u32 = 1 << 7;

/// CTRL bit 0: reset (empty) the transmit FIFO.
pub const CTRL_RST_TX: u32 = 1 << 0;
/// CTRL bit 1: reset (empty) the receive FIFO.
pub const CTRL_RST_RX: u32 = 1 << 1;
/// CTRL bit 4: enable the interrupt output (we run polled: never set).
pub const CTRL_ENABLE_INTR: u32 = 1 << 4;

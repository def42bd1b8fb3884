//! NS16550A UART driver (polled), as emulated by QEMU `virt` at 0x1000_0000.
//!
//! All registers are accessed 8 bits wide: QEMU's 16550 splits wider accesses into
//! byte accesses of the neighbouring registers, which would clobber IER/FCR/LCR.

pub mod regs;

use super::mmio::Mmio;
use super::uart_io::impl_uart_io;
use super::ByteUart;

/// A receive-side line error, as flagged in LSR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Ns16550Error {
    /// A received byte was lost (FIFO full); the bytes still queued are good.
    RxOverrun,
    /// Parity error; the bad byte was dropped.
    RxParity,
    /// Framing error (bad stop bit); the bad byte was dropped.
    RxFraming,
    /// Break condition on the line; its zero byte was dropped.
    RxBreak,
}

impl core::fmt::Display for Ns16550Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::RxOverrun => "uart receive overrun",
            Self::RxParity => "uart receive parity error",
            Self::RxFraming => "uart receive framing error",
            Self::RxBreak => "uart break on receive line",
        })
    }
}

impl embedded_io::Error for Ns16550Error {
    fn kind(&self) -> embedded_io::ErrorKind {
        match self {
            Self::RxParity | Self::RxFraming => embedded_io::ErrorKind::InvalidData,
            Self::RxOverrun | Self::RxBreak => embedded_io::ErrorKind::Other,
        }
    }
}

/// An NS16550A-compatible UART: [`ByteUart`] primitives, and the blocking
/// [`embedded_io`] `Read`/`ReadReady`/`Write` with the blocking rules of
/// [`super::uart_io`].
pub struct Ns16550<M: Mmio> {
    mmio: M,
    /// log2 of the byte distance between consecutive registers.
    reg_shift: u32,
    /// A byte or line error taken from the hardware but not handed out yet
    /// ([`super::uart_io`]).
    rx_held: Option<Result<u8, Ns16550Error>>,
}

impl<M: Mmio> Ns16550<M> {
    /// A UART with byte-spaced registers (QEMU `virt`).
    pub const fn new(mmio: M) -> Self {
        Self::with_reg_shift(mmio, 0)
    }

    /// A UART whose registers are `1 << reg_shift` bytes apart (device tree `reg-shift`;
    /// 2 for Xilinx AXI UART16550 and most SoC integrations).
    pub const fn with_reg_shift(mmio: M, reg_shift: u32) -> Self {
        Self { mmio, reg_shift, rx_held: None }
    }

    fn reg_read(&self, reg: usize) -> u8 {
        self.mmio.read8(reg << self.reg_shift)
    }

    fn reg_write(&self, reg: usize, value: u8) {
        self.mmio.write8(reg << self.reg_shift, value)
    }

    /// Puts the UART in polled 8N1 mode with FIFOs on and cleared (receive trigger level 14,
    /// see [`regs::FCR_RX_TRIGGER_14`]).
    ///
    /// `divisor` is `input clock / (16 × baud)`; `None` keeps the current one (what the
    /// boot ROM or QEMU set, which ignores it anyway).
    pub fn init(&mut self, divisor: Option<u16>) {
        self.reg_write(regs::IER, regs::IER_NONE);
        if let Some(div) = divisor {
            let [lo, hi] = div.to_le_bytes();
            self.reg_write(regs::LCR, regs::LCR_DLAB);
            self.reg_write(regs::DLL, lo);
            self.reg_write(regs::DLM, hi);
        }
        // Writing LCR also clears DLAB, which RBR/THR access needs.
        self.reg_write(regs::LCR, regs::LCR_8N1);
        self.reg_write(regs::FCR, regs::FCR_ENABLE | regs::FCR_CLEAR_RX | regs::FCR_CLEAR_TX | regs::FCR_RX_TRIGGER_14);
    }

    /// Gives back the register block.
    pub fn free(self) -> M {
        self.mmio
    }
}

impl<M: Mmio> ByteUart for Ns16550<M> {
    type Error = Ns16550Error;

    fn write_byte(&mut self, byte: u8) -> nb::Result<(), Self::Error> {
        // THRE means the whole TX FIFO is empty; one byte per check keeps it simple
        // and never overfills, at a small cost in LSR reads.
        if self.reg_read(regs::LSR) & regs::LSR_THRE == 0 {
            return Err(nb::Error::WouldBlock);
        }
        self.reg_write(regs::THR, byte);
        Ok(())
    }

    fn read_byte(&mut self) -> nb::Result<u8, Self::Error> {
        if let Some(held) = self.rx_held.take() {
            return held.map_err(nb::Error::Other);
        }
        // One LSR read: it clears the error bits, so they are reported exactly once.
        let lsr = self.reg_read(regs::LSR);
        if lsr & regs::LSR_OE != 0 {
            // The lost byte is gone; the queued ones are fine and stay for the next call.
            return Err(nb::Error::Other(Ns16550Error::RxOverrun));
        }
        if lsr & regs::LSR_DR == 0 {
            return Err(nb::Error::WouldBlock);
        }
        let byte = self.reg_read(regs::RBR);
        // PE/FE/BI describe the byte at the head of the FIFO, i.e. the one just popped.
        if lsr & regs::LSR_BI != 0 {
            Err(nb::Error::Other(Ns16550Error::RxBreak))
        } else if lsr & regs::LSR_FE != 0 {
            Err(nb::Error::Other(Ns16550Error::RxFraming))
        } else if lsr & regs::LSR_PE != 0 {
            Err(nb::Error::Other(Ns16550Error::RxParity))
        } else {
            Ok(byte)
        }
    }

    fn nflush(&mut self) -> nb::Result<(), Self::Error> {
        if self.reg_read(regs::LSR) & regs::LSR_TEMT == 0 {
            return Err(nb::Error::WouldBlock);
        }
        Ok(())
    }
}

impl_uart_io!(Ns16550, Ns16550Error);

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::MockMmio;
    use embedded_io::{Read, ReadReady, Write};

    #[test]
    fn init_sets_divisor_then_8n1_and_fifos() {
        let mock = MockMmio::new();
        let mut uart = Ns16550::new(&mock);
        uart.init(Some(0x0102));
        assert_eq!(
            mock.writes(),
            vec![
                (IER, 0),
                (LCR, u32::from(LCR_DLAB)),
                (DLL, 0x02),
                (DLM, 0x01),
                (LCR, u32::from(LCR_8N1)),
                (FCR, u32::from(FCR_ENABLE | FCR_CLEAR_RX | FCR_CLEAR_TX | FCR_RX_TRIGGER_14)),
            ]
        );
    }

    #[test]
    fn init_without_divisor_leaves_dlab_alone() {
        let mock = MockMmio::new();
        Ns16550::new(&mock).init(None);
        assert!(!mock.writes().iter().any(|&(o, v)| o == LCR && v & u32::from(LCR_DLAB) != 0));
    }

    #[test]
    fn reg_shift_spaces_registers() {
        let mock = MockMmio::new();
        mock.set8(LSR << 2, LSR_THRE);
        let mut uart = Ns16550::with_reg_shift(&mock, 2);
        assert_eq!(uart.write_byte(b'x'), Ok(()));
        assert_eq!(mock.reads_at(LSR << 2), 1);
        assert_eq!(mock.writes(), vec![(THR << 2, u32::from(b'x'))]);
    }

    #[test]
    fn write_byte_waits_for_thre() {
        let mock = MockMmio::new();
        mock.queue(LSR, &[0, u32::from(LSR_THRE)]);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.write_byte(b'a'), Err(nb::Error::WouldBlock));
        assert!(mock.writes().is_empty());
        assert_eq!(uart.write_byte(b'a'), Ok(()));
        assert_eq!(mock.writes8_at(THR), b"a".to_vec());
    }

    #[test]
    fn write_all_blocks_until_every_byte_is_queued() {
        let mock = MockMmio::new();
        mock.queue(LSR, &[0, 0, u32::from(LSR_THRE), 0, u32::from(LSR_THRE)]);
        mock.set8(LSR, LSR_THRE);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.write_all(b"hi!"), Ok(()));
        assert_eq!(mock.writes8_at(THR), b"hi!".to_vec());
        assert_eq!(mock.reads_at(LSR), 6);
    }

    #[test]
    fn read_byte_is_nonblocking() {
        let mock = MockMmio::new();
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::WouldBlock));
        assert_eq!(mock.reads_at(RBR), 0, "RBR must not be popped when DR is clear");
        mock.queue(LSR, &[u32::from(LSR_DR)]);
        mock.queue(RBR, &[0x5A]);
        assert_eq!(uart.read_byte(), Ok(0x5A));
    }

    #[test]
    fn read_byte_checks_lsr_before_popping_rbr() {
        use crate::bsp::mock::{Access, Width};
        let mock = MockMmio::new();
        mock.set8(LSR, LSR_DR);
        mock.set8(RBR, b'r');
        assert_eq!(Ns16550::new(&mock).read_byte(), Ok(b'r'));
        assert_eq!(
            mock.log(),
            vec![
                Access::Read { off: LSR, width: Width::W8, value: u32::from(LSR_DR) },
                Access::Read { off: RBR, width: Width::W8, value: u32::from(b'r') },
            ]
        );
    }

    #[test]
    fn read_byte_reports_overrun_and_keeps_queued_byte() {
        let mock = MockMmio::new();
        mock.queue(LSR, &[u32::from(LSR_OE | LSR_DR), u32::from(LSR_DR)]);
        mock.queue(RBR, &[7]);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::Other(Ns16550Error::RxOverrun)));
        assert_eq!(uart.read_byte(), Ok(7));
    }

    #[test]
    fn read_byte_drops_byte_with_framing_error() {
        let mock = MockMmio::new();
        mock.queue(LSR, &[u32::from(LSR_FE | LSR_DR), u32::from(LSR_DR)]);
        mock.queue(RBR, &[0xFF, b'k'.into()]);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::Other(Ns16550Error::RxFraming)));
        assert_eq!(uart.read_byte(), Ok(b'k'));
    }

    #[test]
    fn flush_waits_for_transmitter_empty() {
        let mock = MockMmio::new();
        mock.queue(LSR, &[u32::from(LSR_THRE)]);
        mock.set8(LSR, LSR_THRE | LSR_TEMT);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.nflush(), Err(nb::Error::WouldBlock));
        assert_eq!(uart.nflush(), Ok(()));
        mock.queue(LSR, &[u32::from(LSR_THRE), u32::from(LSR_THRE)]);
        assert_eq!(Write::flush(&mut uart), Ok(()));
        assert_eq!(mock.reads_at(LSR), 5);
    }

    #[test]
    fn write_waits_for_the_first_byte_only() {
        let mock = MockMmio::new();
        // Busy, then room for one byte, then busy again: `write` takes one byte and returns.
        mock.queue(LSR, &[0, u32::from(LSR_THRE), 0]);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.write(b"xyz"), Ok(1));
        assert_eq!(uart.write(b""), Ok(0));
        assert_eq!(mock.writes8_at(THR), b"x".to_vec());
    }

    #[test]
    fn read_returns_what_is_waiting_and_holds_a_later_line_error() {
        let mock = MockMmio::new();
        let dr = u32::from(LSR_DR);
        // Nothing, then two bytes, then a framing error on the third, then nothing.
        mock.queue(LSR, &[0, dr, dr, u32::from(LSR_FE | LSR_DR)]);
        mock.queue(RBR, &[b'a'.into(), b'b'.into(), 0xFF]);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(uart.read_ready(), Ok(false));
        let mut buf = [0u8; 8];
        assert_eq!(uart.read(&mut buf), Ok(2));
        assert_eq!(&buf[..2], b"ab");
        // The error met after "ab" is reported once, by the next call, without waiting.
        assert_eq!(uart.read_ready(), Ok(true));
        assert_eq!(uart.read(&mut buf), Err(Ns16550Error::RxFraming));
        assert_eq!(uart.read(&mut []), Ok(0));
        mock.queue(LSR, &[dr]);
        mock.queue(RBR, &[b'c'.into()]);
        assert_eq!(uart.read_ready(), Ok(true));
        assert_eq!(uart.read(&mut buf[..1]), Ok(1));
        assert_eq!(buf[0], b'c');
    }
    #[test]
    fn uart_writer_formats_through_the_uart() {
        use crate::bsp::UartWriter;
        use core::fmt::Write as _;
        let mock = MockMmio::new();
        mock.set8(LSR, LSR_THRE);
        let mut uart = Ns16550::new(&mock);
        assert_eq!(write!(UartWriter(&mut uart), "n={}", 42), Ok(()));
        assert_eq!(mock.writes8_at(THR), b"n=42".to_vec());
    }
}

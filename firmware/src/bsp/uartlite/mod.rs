//! Xilinx AXI UART Lite driver (PG142), polled.
//!
//! The baud rate and frame format are fixed when the IP is generated, so there is
//! nothing to configure beyond emptying the FIFOs and keeping interrupts off.

pub mod regs;

use super::mmio::Mmio;
use super::uart_io::impl_uart_io;
use super::ByteUart;

/// A receive-side line error, as flagged in STAT. The IP does not say which byte was
/// bad, so no byte is dropped: the next read returns the next byte in the FIFO.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum UartLiteError {
    /// A received byte was lost because the 16-byte receive FIFO was full.
    RxOverrun,
    /// A byte was received with a bad stop bit.
    RxFraming,
    /// A byte was received with a parity error.
    RxParity,
}

impl core::fmt::Display for UartLiteError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::RxOverrun => "uart lite receive overrun",
            Self::RxFraming => "uart lite receive framing error",
            Self::RxParity => "uart lite receive parity error",
        })
    }
}

impl embedded_io::Error for UartLiteError {
    fn kind(&self) -> embedded_io::ErrorKind {
        match self {
            Self::RxParity | Self::RxFraming => embedded_io::ErrorKind::InvalidData,
            Self::RxOverrun => embedded_io::ErrorKind::Other,
        }
    }
}

/// An AXI UART Lite instance: [`ByteUart`] primitives, and the blocking [`embedded_io`]
/// `Read`/`ReadReady`/`Write` with the blocking rules of [`super::uart_io`].
pub struct UartLite<M: Mmio> {
    mmio: M,
    /// A byte or line error taken from the hardware but not handed out yet
    /// ([`super::uart_io`]).
    rx_held: Option<Result<u8, UartLiteError>>,
}

impl<M: Mmio> UartLite<M> {
    /// Wraps the register block; call [`UartLite::init`] before use.
    pub const fn new(mmio: M) -> Self {
        Self { mmio, rx_held: None }
    }

    /// Empties both FIFOs and disables the interrupt output.
    pub fn init(&mut self) {
        self.mmio.write32(regs::CTRL, regs::CTRL_RST_TX | regs::CTRL_RST_RX);
        // Clear stale error bits (a STAT read clears them).
        let _ = self.mmio.read32(regs::STAT);
    }

    /// Gives back the register block.
    pub fn free(self) -> M {
        self.mmio
    }
}

impl<M: Mmio> ByteUart for UartLite<M> {
    type Error = UartLiteError;

    fn write_byte(&mut self, byte: u8) -> nb::Result<(), Self::Error> {
        // This STAT read also clears receive error bits; those are only meaningful to
        // `read_byte`, and losing one report there is the IP's documented behaviour.
        if self.mmio.read32(regs::STAT) & regs::STAT_TX_FULL != 0 {
            return Err(nb::Error::WouldBlock);
        }
        self.mmio.write32(regs::TX_FIFO, u32::from(byte));
        Ok(())
    }

    fn read_byte(&mut self) -> nb::Result<u8, Self::Error> {
        if let Some(held) = self.rx_held.take() {
            return held.map_err(nb::Error::Other);
        }
        let stat = self.mmio.read32(regs::STAT);
        if stat & regs::STAT_OVERRUN != 0 {
            return Err(nb::Error::Other(UartLiteError::RxOverrun));
        }
        if stat & regs::STAT_FRAME != 0 {
            return Err(nb::Error::Other(UartLiteError::RxFraming));
        }
        if stat & regs::STAT_PARITY != 0 {
            return Err(nb::Error::Other(UartLiteError::RxParity));
        }
        if stat & regs::STAT_RX_VALID == 0 {
            return Err(nb::Error::WouldBlock);
        }
        Ok(self.mmio.read32(regs::RX_FIFO) as u8)
    }

    fn nflush(&mut self) -> nb::Result<(), Self::Error> {
        // The IP has no "shift register empty" flag; TX FIFO empty is as close as it gets,
        // so the last byte may still be on the wire for one frame time.
        if self.mmio.read32(regs::STAT) & regs::STAT_TX_EMPTY == 0 {
            return Err(nb::Error::WouldBlock);
        }
        Ok(())
    }
}

impl_uart_io!(UartLite, UartLiteError);

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::MockMmio;
    use embedded_io::{Read, ReadReady, Write};

    #[test]
    fn init_resets_fifos_with_interrupts_off() {
        let mock = MockMmio::new();
        UartLite::new(&mock).init();
        assert_eq!(mock.writes(), vec![(CTRL, CTRL_RST_TX | CTRL_RST_RX)]);
        assert_eq!(mock.writes_at(CTRL)[0] & CTRL_ENABLE_INTR, 0);
        assert_eq!(mock.reads_at(STAT), 1);
    }

    #[test]
    fn write_byte_waits_while_tx_fifo_full() {
        let mock = MockMmio::new();
        mock.queue(STAT, &[STAT_TX_FULL]);
        let mut uart = UartLite::new(&mock);
        assert_eq!(uart.write_byte(b'z'), Err(nb::Error::WouldBlock));
        assert_eq!(uart.write_byte(b'z'), Ok(()));
        assert_eq!(mock.writes(), vec![(TX_FIFO, u32::from(b'z'))]);
    }

    #[test]
    fn write_all_sends_every_byte_in_order() {
        let mock = MockMmio::new();
        mock.queue(STAT, &[0, STAT_TX_FULL, STAT_TX_FULL, 0]);
        let mut uart = UartLite::new(&mock);
        assert_eq!(uart.write_all(b"abc"), Ok(()));
        assert_eq!(mock.writes8_at(TX_FIFO), b"abc".to_vec());
    }

    #[test]
    fn read_byte_pops_only_when_valid() {
        let mock = MockMmio::new();
        let mut uart = UartLite::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::WouldBlock));
        assert_eq!(mock.reads_at(RX_FIFO), 0);
        mock.queue(STAT, &[STAT_RX_VALID | STAT_TX_EMPTY]);
        // Upper bits of the FIFO register are not data.
        mock.queue(RX_FIFO, &[0xFFFF_FF41]);
        assert_eq!(uart.read_byte(), Ok(b'A'));
    }

    #[test]
    fn read_byte_reports_errors_once_then_continues() {
        let mock = MockMmio::new();
        mock.queue(STAT, &[STAT_RX_VALID | STAT_OVERRUN, STAT_FRAME, STAT_PARITY | STAT_RX_FULL]);
        mock.set(STAT, STAT_RX_VALID);
        mock.set(RX_FIFO, u32::from(b'q'));
        let mut uart = UartLite::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::Other(UartLiteError::RxOverrun)));
        assert_eq!(uart.read_byte(), Err(nb::Error::Other(UartLiteError::RxFraming)));
        assert_eq!(uart.read_byte(), Err(nb::Error::Other(UartLiteError::RxParity)));
        assert_eq!(uart.read_byte(), Ok(b'q'));
    }

    #[test]
    fn flush_waits_for_tx_fifo_empty() {
        let mock = MockMmio::new();
        mock.queue(STAT, &[0]);
        mock.set(STAT, STAT_TX_EMPTY);
        let mut uart = UartLite::new(&mock);
        assert_eq!(uart.nflush(), Err(nb::Error::WouldBlock));
        assert_eq!(uart.nflush(), Ok(()));
        assert_eq!(Write::flush(&mut uart), Ok(()));
    }

    #[test]
    fn read_ready_holds_what_it_saw_for_the_next_read() {
        let mock = MockMmio::new();
        mock.queue(STAT, &[STAT_PARITY, STAT_RX_VALID, STAT_RX_VALID]);
        mock.queue(RX_FIFO, &[u32::from(b'p'), u32::from(b'q')]);
        let mut uart = UartLite::new(&mock);
        // The STAT read that saw the parity error cleared it: the error is held, not lost.
        assert_eq!(uart.read_ready(), Ok(true));
        let mut buf = [0u8; 4];
        assert_eq!(uart.read(&mut buf), Err(UartLiteError::RxParity));
        assert_eq!(uart.read(&mut buf), Ok(2));
        assert_eq!(&buf[..2], b"pq");
        assert_eq!(uart.read_ready(), Ok(false));
        assert_eq!(uart.write(b"ok"), Ok(2));
    }
}

//! LiteX UART driver (`litex/soc/cores/uart.py`), polled: the console and host link of the
//! LiteX SoC (`soc/`).
//!
//! The SoC builds the core with `rx_fifo_rx_we`, so a read of `RXTX` pops the receive FIFO
//! (one status read and one data read per byte; without it a pop is an extra write to
//! `EV_PENDING`). The baud rate is fixed in the gateware. The core reports no line errors
//! (its PHY drops a byte with a bad stop bit), so reads never fail.

pub mod regs;

use super::mmio::Mmio;
use super::uart_io::impl_uart_io;
use super::ByteUart;

/// The LiteX UART's receive error: there is none (the core reports no line errors).
pub type LitexUartError = core::convert::Infallible;

/// A LiteX UART instance: [`ByteUart`] primitives, and the blocking [`embedded_io`]
/// `Read`/`ReadReady`/`Write` with the blocking rules of [`super::uart_io`].
pub struct LitexUart<M: Mmio> {
    mmio: M,
    /// A byte taken from the hardware but not handed out yet ([`super::uart_io`]).
    rx_held: Option<Result<u8, LitexUartError>>,
}

impl<M: Mmio> LitexUart<M> {
    /// Wraps the register block; call [`LitexUart::init`] before use.
    pub const fn new(mmio: M) -> Self {
        Self { mmio, rx_held: None }
    }

    /// Turns the UART's interrupts off and clears its pending events. Bytes already in the
    /// receive FIFO stay there: after the bootloader starts an application, they are the
    /// host's first request to it.
    pub fn init(&mut self) {
        self.mmio.write32(regs::EV_ENABLE, 0);
        self.mmio.write32(regs::EV_PENDING, regs::EV_TX | regs::EV_RX);
    }

    /// Gives back the register block.
    pub fn free(self) -> M {
        self.mmio
    }
}

impl<M: Mmio> ByteUart for LitexUart<M> {
    type Error = LitexUartError;

    fn write_byte(&mut self, byte: u8) -> nb::Result<(), Self::Error> {
        if self.mmio.read32(regs::TXFULL) & regs::FLAG != 0 {
            return Err(nb::Error::WouldBlock);
        }
        self.mmio.write32(regs::RXTX, u32::from(byte));
        Ok(())
    }

    fn read_byte(&mut self) -> nb::Result<u8, Self::Error> {
        if let Some(held) = self.rx_held.take() {
            return held.map_err(nb::Error::Other);
        }
        if self.mmio.read32(regs::RXEMPTY) & regs::FLAG != 0 {
            return Err(nb::Error::WouldBlock);
        }
        // Only the low byte is data; the read popped it.
        Ok(self.mmio.read32(regs::RXTX) as u8)
    }

    fn nflush(&mut self) -> nb::Result<(), Self::Error> {
        // The core has no "shift register empty" flag; an empty TX FIFO is as close as it
        // gets, so the last byte may still be on the wire for one frame time.
        if self.mmio.read32(regs::TXEMPTY) & regs::FLAG == 0 {
            return Err(nb::Error::WouldBlock);
        }
        Ok(())
    }
}

impl_uart_io!(LitexUart, LitexUartError);

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::regs::*;
    use super::*;
    use crate::bsp::mock::MockMmio;
    use embedded_io::{Read, ReadReady, Write};

    #[test]
    fn init_disables_interrupts_and_clears_events_without_touching_the_fifos() {
        let mock = MockMmio::new();
        LitexUart::new(&mock).init();
        assert_eq!(mock.writes(), vec![(EV_ENABLE, 0), (EV_PENDING, EV_TX | EV_RX)]);
        assert_eq!(mock.reads_at(RXTX), 0, "init must not drain bytes meant for the application");
    }

    #[test]
    fn write_byte_waits_while_tx_fifo_full() {
        let mock = MockMmio::new();
        mock.queue(TXFULL, &[FLAG, 0]);
        let mut uart = LitexUart::new(&mock);
        assert_eq!(uart.write_byte(b'z'), Err(nb::Error::WouldBlock));
        assert!(mock.writes_at(RXTX).is_empty());
        assert_eq!(uart.write_byte(b'z'), Ok(()));
        assert_eq!(mock.writes_at(RXTX), vec![u32::from(b'z')]);
    }

    #[test]
    fn write_all_sends_every_byte_in_order() {
        let mock = MockMmio::new();
        mock.queue(TXFULL, &[0, FLAG, FLAG, 0, 0]);
        let mut uart = LitexUart::new(&mock);
        assert_eq!(uart.write_all(b"abc"), Ok(()));
        assert_eq!(mock.writes_at(RXTX), b"abc".iter().map(|&b| u32::from(b)).collect::<Vec<_>>());
    }

    #[test]
    fn read_byte_reads_data_only_when_the_fifo_holds_some() {
        let mock = MockMmio::new();
        mock.set(RXEMPTY, FLAG);
        let mut uart = LitexUart::new(&mock);
        assert_eq!(uart.read_byte(), Err(nb::Error::WouldBlock));
        assert_eq!(mock.reads_at(RXTX), 0, "a read of RXTX pops: never with the FIFO empty");
        mock.queue(RXEMPTY, &[0]);
        // Upper bits of the data register are not data.
        mock.queue(RXTX, &[0xFFFF_FF41]);
        assert_eq!(uart.read_byte(), Ok(b'A'));
        assert_eq!(mock.reads_at(RXTX), 1);
        assert!(mock.writes().is_empty(), "a pop needs no write (rx_fifo_rx_we)");
    }

    #[test]
    fn read_takes_what_is_waiting_and_stops_at_an_empty_fifo() {
        let mock = MockMmio::new();
        mock.queue(RXEMPTY, &[0, 0, 0, FLAG]);
        mock.set(RXEMPTY, FLAG);
        mock.queue(RXTX, &[u32::from(b'p'), u32::from(b'q'), u32::from(b'r')]);
        let mut uart = LitexUart::new(&mock);
        let mut buf = [0u8; 8];
        assert_eq!(uart.read(&mut buf), Ok(3));
        assert_eq!(&buf[..3], b"pqr");
        assert_eq!(uart.read_ready(), Ok(false));
    }

    #[test]
    fn flush_waits_for_tx_fifo_empty() {
        let mock = MockMmio::new();
        mock.queue(TXEMPTY, &[0]);
        mock.set(TXEMPTY, FLAG);
        let mut uart = LitexUart::new(&mock);
        assert_eq!(uart.nflush(), Err(nb::Error::WouldBlock));
        assert_eq!(uart.nflush(), Ok(()));
        assert_eq!(Write::flush(&mut uart), Ok(()));
    }
}

//! The blocking byte-stream API of the UART drivers: [`embedded_io`]'s `ErrorType`, `Read`,
//! `ReadReady` and `Write`, built once on the [`ByteUart`](super::ByteUart) primitives and
//! implemented on each driver by `impl_uart_io!`.
//!
//! # When each call blocks (polled: every wait is a spin on a status register)
//!
//! | call | returns |
//! | --- | --- |
//! | `Write::write(buf)` | at once with `Ok(0)` for an empty `buf`; else after at least one byte is queued in the transmitter, with as many more as it takes without waiting |
//! | `Write::write_all(buf)` | once every byte of `buf` is queued in the transmitter (not yet on the wire) |
//! | `Write::flush()` | once the transmitter has sent everything queued ([`ByteUart::nflush`](super::ByteUart::nflush)) |
//! | `ReadReady::read_ready()` | at once: `true` when the next `read` returns without waiting (a byte or a line error is waiting) |
//! | `Read::read(buf)` | at once with `Ok(0)` for an empty `buf`; else after at least one byte arrived (or a line error), with the bytes that are already waiting, up to `buf.len()` |
//!
//! Transmit never fails on our UARTs, so `write`/`write_all`/`flush` always return `Ok`; the
//! error type is the receive side's. A line error is reported by exactly one `read` (or
//! `read_byte`): when it is met after some bytes of a `read`, that call returns those bytes
//! and the error is held for the next call, so nothing is lost and nothing is reported twice.
//! `read_ready` has to take the byte (or error) from the hardware to see it (reading the
//! status register clears the error flags), so it holds it for the next read too.
//!
//! A driver plugs in by having a field `rx_held: Option<Result<u8, Error>>` that its
//! `ByteUart::read_byte` hands out first, and invoking `impl_uart_io!(Driver, Error)`.

/// Implements [`embedded_io::ErrorType`], [`embedded_io::Read`], [`embedded_io::ReadReady`]
/// and [`embedded_io::Write`] for a UART driver `$ty` (generic over `M: Mmio`) with error
/// type `$err`, from its [`ByteUart`](crate::bsp::ByteUart) impl and its `rx_held` field
/// (module docs of [`crate::bsp::uart_io`]).
macro_rules! impl_uart_io {
    ($ty:ident, $err:ty) => {
        impl<M: $crate::bsp::mmio::Mmio> embedded_io::ErrorType for $ty<M> {
            type Error = $err;
        }

        /// Blocks until the transmitter took at least one byte (module `bsp::uart_io`).
        impl<M: $crate::bsp::mmio::Mmio> embedded_io::Write for $ty<M> {
            /// Spins until the first byte of `buf` is queued, then queues what else fits
            /// without waiting; `Ok(0)` at once for an empty `buf`.
            fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
                let Some((&first, rest)) = buf.split_first() else {
                    return Ok(0);
                };
                nb::block!($crate::bsp::ByteUart::write_byte(self, first))?;
                let mut n = 1;
                for (queued, &b) in (2..).zip(rest) {
                    if $crate::bsp::ByteUart::write_byte(self, b).is_err() {
                        break;
                    }
                    n = queued;
                }
                Ok(n)
            }

            /// Spins until every byte of `buf` is queued in the transmitter (not until it has
            /// left the wire: that is `flush`). Overrides the default, which
            /// would add a panic path for `write` returning 0.
            fn write_all(&mut self, buf: &[u8]) -> Result<(), Self::Error> {
                for &b in buf {
                    nb::block!($crate::bsp::ByteUart::write_byte(self, b))?;
                }
                Ok(())
            }

            /// Spins until the transmitter has sent everything queued.
            fn flush(&mut self) -> Result<(), Self::Error> {
                nb::block!($crate::bsp::ByteUart::nflush(self))
            }
        }

        /// Blocks until one byte (or a line error) arrived (module `bsp::uart_io`).
        impl<M: $crate::bsp::mmio::Mmio> embedded_io::Read for $ty<M> {
            /// Spins until the first byte arrives (or a line error, returned as `Err`), then
            /// takes the bytes already waiting, up to `buf.len()`, without waiting further. A
            /// line error after the first byte ends the call and is returned by the next one.
            /// `Ok(0)` at once for an empty `buf`.
            fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
                let Some((first, rest)) = buf.split_first_mut() else {
                    return Ok(0);
                };
                *first = nb::block!($crate::bsp::ByteUart::read_byte(self))?;
                let mut n = 1;
                for (taken, slot) in (2..).zip(rest) {
                    match $crate::bsp::ByteUart::read_byte(self) {
                        Ok(b) => *slot = b,
                        Err(nb::Error::WouldBlock) => break,
                        Err(nb::Error::Other(e)) => {
                            self.rx_held = Some(Err(e));
                            break;
                        }
                    }
                    n = taken;
                }
                Ok(n)
            }
        }

        /// Never blocks (module `bsp::uart_io`).
        impl<M: $crate::bsp::mmio::Mmio> embedded_io::ReadReady for $ty<M> {
            /// `true` when a byte or a line error is waiting (then held for the next `read`,
            /// which returns at once); never `Err`.
            fn read_ready(&mut self) -> Result<bool, Self::Error> {
                if self.rx_held.is_none() {
                    self.rx_held = match $crate::bsp::ByteUart::read_byte(self) {
                        Ok(b) => Some(Ok(b)),
                        Err(nb::Error::Other(e)) => Some(Err(e)),
                        Err(nb::Error::WouldBlock) => return Ok(false),
                    };
                }
                Ok(true)
            }
        }
    };
}

pub(crate) use impl_uart_io;

//! The UART side of the images: the console as a [`ByteSink`], polled reads, and the
//! application's device loop.

use gridrt_firmware::bsp::ByteUart;
use gridrt_firmware::device::{ByteSink, Device, StageClock};
use gridrt_firmware::fsl::FslLink;

use crate::board::Console;

/// Bytes taken from the UART per `feed` call at most.
pub const RX_BATCH: usize = 256;

/// Blocking writes to the console.
pub struct ConsoleSink<'a>(pub &'a mut Console);

impl ByteSink for ConsoleSink<'_> {
    fn write_bytes(&mut self, bytes: &[u8]) {
        // Transmit cannot fail on these UARTs; a lost byte shows up as a bad frame at the host.
        let _ = self.0.write_all(bytes);
    }
}

/// Takes the bytes waiting in the receiver (non-blocking) into `buf`; returns how many.
///
/// A line error (overrun, framing) drops the byte; the frame it belonged to then fails its
/// CRC and the peer is told with `Error{BadFrame}` by the frame layer.
pub fn read_available(console: &mut Console, buf: &mut [u8]) -> usize {
    let mut n = 0;
    while let Some(slot) = buf.get_mut(n) {
        match console.read_byte() {
            Ok(b) => {
                *slot = b;
                n += 1;
            }
            Err(nb::Error::WouldBlock) => break,
            Err(nb::Error::Other(_)) => continue,
        }
    }
    n
}

/// Firmware version as `[major, minor, patch]` for `Msg::Version`.
pub fn firmware_version() -> [u8; 3] {
    let v = |s: &str| s.parse::<u8>().unwrap_or(0);
    [v(env!("CARGO_PKG_VERSION_MAJOR")), v(env!("CARGO_PKG_VERSION_MINOR")), v(env!("CARGO_PKG_VERSION_PATCH"))]
}

/// The device loop: poll the UART, feed what arrived to the device, which answers through
/// blocking console writes (a render runs to completion inside one `feed`). Never returns.
pub fn serve<L: FslLink, C: StageClock, const N: usize>(device: &mut Device<L, C, N>, console: &mut Console) -> ! {
    let mut buf = [0u8; RX_BATCH];
    loop {
        let n = read_available(console, &mut buf);
        if let Some(bytes) = buf.get(..n).filter(|b| !b.is_empty()) {
            device.feed(bytes, &mut ConsoleSink(console));
        }
    }
}

//! The UART side of the images: reads from any [`embedded_io`] UART, and the application's
//! device loop. The board's console driver (`crate::board::Console`) is used
//! as it is: it implements `embedded_io::{Read, ReadReady, Write}` itself.

use embedded_io::{Read, Write};
use gridrt_firmware::device::{Device, RowFarm, StageClock};
use gridrt_firmware::fsl::FslLink;

/// Bytes taken from the UART per `feed` call at most.
pub const RX_BATCH: usize = 256;

/// Blocks until at least one byte arrived, then takes the bytes already waiting into `buf`
/// (embedded-io `Read::read`); returns how many.
///
/// A line error (overrun, framing) ends the wait with 0; the frame its byte belonged to then
/// fails its CRC and the peer is told with `Error{BadFrame}` by the frame layer.
pub fn read_some<U: Read>(uart: &mut U, buf: &mut [u8]) -> usize {
    uart.read(buf).unwrap_or(0)
}

/// Firmware version as `[major, minor, patch]` for `Msg::Version`.
pub fn firmware_version() -> [u8; 3] {
    let v = |s: &str| s.parse::<u8>().unwrap_or(0);
    [v(env!("CARGO_PKG_VERSION_MAJOR")), v(env!("CARGO_PKG_VERSION_MINOR")), v(env!("CARGO_PKG_VERSION_PATCH"))]
}

/// The device loop: wait for UART bytes, feed what arrived to the device, which answers
/// through blocking `write_all`s to the same UART (a render runs to completion inside one `feed`; a
/// failed write stops the frame and is counted, `Device::write_errors`). Never returns.
pub fn serve<
    L: FslLink,
    C: StageClock,
    const N: usize,
    const P: usize,
    const T: usize,
    F: RowFarm<L>,
    U: Read + Write,
>(
    device: &mut Device<L, C, N, P, T, F>,
    uart: &mut U,
) -> ! {
    let mut buf = [0u8; RX_BATCH];
    loop {
        let n = read_some(uart, &mut buf);
        if let Some(bytes) = buf.get(..n).filter(|b| !b.is_empty()) {
            device.feed(bytes, uart);
        }
    }
}

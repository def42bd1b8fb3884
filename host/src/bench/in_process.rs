//! The byte plumbing of benches that run the simulated device in this process, without a
//! line: the device writes into a queue ([`VecSink`]), and the session reads from it
//! ([`read_queued`]), which times out at once when the device has nothing to say.

use std::collections::VecDeque;

use gridrt_firmware::embedded_io::{self, ErrorType};

/// The device's output, gathered in memory.
pub(crate) struct VecSink<'a>(pub(crate) &'a mut VecDeque<u8>);

impl ErrorType for VecSink<'_> {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for VecSink<'_> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        self.0.extend(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// `std::io::Read` of the queued device output: what is there, else `TimedOut`.
pub(crate) fn read_queued(out: &mut VecDeque<u8>, buf: &mut [u8]) -> std::io::Result<usize> {
    if out.is_empty() {
        return Err(std::io::ErrorKind::TimedOut.into());
    }
    let n = buf.len().min(out.len());
    for (dst, src) in buf.iter_mut().zip(out.drain(..n)) {
        *dst = src;
    }
    Ok(n)
}

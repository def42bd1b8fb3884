//! Frame sending: [`FrameTx`], the UART frame encoder (`shared::frame`: COBS + CRC-32) with
//! the device's sequence number, and [`TxError`]. A write error has no one to be reported to:
//! [`FrameTx`] counts it ([`FrameTx::write_errors`]) and returns [`TxError::Write`].

use embedded_io::{Error as _, ErrorKind, Write};
use gridrt_shared::frame::{encode_frame, FrameError, MAX_ENCODED, MAX_PAYLOAD};
use gridrt_shared::msg::{Msg, MsgError};

/// Why a message could not be sent: a firmware bug (never outside data), or the output.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TxError {
    /// The payload did not fit.
    Msg(MsgError),
    /// The frame did not fit.
    Frame(FrameError),
    /// The output failed (counted in [`FrameTx::write_errors`]); part of the frame may
    /// have gone out.
    Write(ErrorKind),
}

/// Frame encoder: owns the outbound sequence number and the payload/wire buffers.
pub struct FrameTx {
    pub(super) seq: u16,
    write_errors: u32,
    payload: [u8; MAX_PAYLOAD],
    wire: [u8; MAX_ENCODED],
}

impl Default for FrameTx {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameTx {
    /// Encoder whose first frame has sequence number 0.
    pub const fn new() -> Self {
        Self { seq: 0, write_errors: 0, payload: [0; MAX_PAYLOAD], wire: [0; MAX_ENCODED] }
    }

    /// Sequence number of the next frame.
    pub fn next_seq(&self) -> u16 {
        self.seq
    }

    /// Writes that failed so far (saturating): each failed [`send`](Self::send) or
    /// [`delimiter`](Self::delimiter) counts once.
    pub fn write_errors(&self) -> u32 {
        self.write_errors
    }

    /// Encodes `msg` as one frame and writes it with `write_all` (blocking until the output
    /// took every byte); the sequence number advances (wrapping) only when the frame was
    /// written.
    pub fn send<W: Write + ?Sized>(&mut self, msg: &Msg<'_>, out: &mut W) -> Result<(), TxError> {
        let n = msg.encode(&mut self.payload).map_err(TxError::Msg)?;
        let payload = self.payload.get(..n).ok_or(TxError::Msg(MsgError::EncodeBufferTooSmall))?;
        let len = encode_frame(msg.kind() as u8, self.seq, payload, &mut self.wire).map_err(TxError::Frame)?;
        let wire = self.wire.get(..len).ok_or(TxError::Frame(FrameError::EncodeBufferTooSmall))?;
        Self::write(&mut self.write_errors, wire, out)?;
        self.seq = self.seq.wrapping_add(1);
        Ok(())
    }

    /// Writes a lone frame delimiter (`0x00`: the receiver drops whatever partial frame it
    /// holds), blocking like [`send`](Self::send).
    pub fn delimiter<W: Write + ?Sized>(&mut self, out: &mut W) -> Result<(), TxError> {
        Self::write(&mut self.write_errors, &[0], out)
    }

    fn write<W: Write + ?Sized>(errors: &mut u32, bytes: &[u8], out: &mut W) -> Result<(), TxError> {
        out.write_all(bytes).map_err(|e| {
            *errors = errors.saturating_add(1);
            TxError::Write(e.kind())
        })
    }
}

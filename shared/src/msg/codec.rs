//! Payload encoding and decoding of every [`Msg`] (SPEC.md §3), and why it can fail
//! ([`MsgError`]).

use super::device::DeviceInfo;
use super::flash::FlashStatus;
use super::message::{ErrorCode, Msg, MsgType, SceneStatus, MAX_ERROR_TEXT};
use super::render::{PixelEncoding, Region, RenderRequest};
use super::sack::{Sack, SackRanges, MAX_SACK_RANGES};
use super::stats::STAT_ENTRY_LEN;
use crate::bytes::{Overflow, Reader, Truncated, Writer};

/// Why a payload could not be encoded or decoded.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MsgError {
    /// Unknown message type byte.
    DecodeUnknownType,
    /// Payload shorter than the message requires.
    DecodeTruncated,
    /// Payload longer than the message allows.
    DecodeTrailingBytes,
    /// A field holds a value outside its range.
    DecodeBadField,
    /// Error text is not UTF-8.
    DecodeBadText,
    /// Output buffer too small.
    EncodeBufferTooSmall,
    /// A field cannot be encoded as given (data length disagrees with a count, too many entries).
    EncodeBadField,
}

impl MsgError {
    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::DecodeUnknownType => "unknown message type",
            Self::DecodeTruncated => "payload truncated",
            Self::DecodeTrailingBytes => "payload has trailing bytes",
            Self::DecodeBadField => "field out of range",
            Self::DecodeBadText => "error text is not UTF-8",
            Self::EncodeBufferTooSmall => "output buffer too small",
            Self::EncodeBadField => "field cannot be encoded as given",
        }
    }
}

impl core::fmt::Display for MsgError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for MsgError {}

impl MsgError {
    /// Error number used in `Error.detail` (SPEC.md §3.9): declaration order, from 1.
    pub const fn code(self) -> u32 {
        match self {
            Self::DecodeUnknownType => 1,
            Self::DecodeTruncated => 2,
            Self::DecodeTrailingBytes => 3,
            Self::DecodeBadField => 4,
            Self::DecodeBadText => 5,
            Self::EncodeBufferTooSmall => 6,
            Self::EncodeBadField => 7,
        }
    }
}

impl From<Truncated> for MsgError {
    fn from(_: Truncated) -> Self {
        Self::DecodeTruncated
    }
}
impl From<Overflow> for MsgError {
    fn from(_: Overflow) -> Self {
        Self::EncodeBufferTooSmall
    }
}

impl<'a> Msg<'a> {
    /// Writes the payload into `out` and returns its length.
    ///
    /// # Example
    ///
    /// A message's payload, its type byte, and back; a payload of the wrong length is an error.
    ///
    /// ```
    /// use gridrt_shared::msg::{Msg, MsgError};
    ///
    /// let msg = Msg::Hello { protocol: 1 };
    /// let mut buf = [0u8; 16];
    /// let n = msg.encode(&mut buf)?;
    /// assert_eq!(buf[..n], [0x01, 0x00, 0x00, 0x00]); // protocol (u16 LE), reserved (u16)
    /// assert_eq!(msg.kind() as u8, 0x01);
    /// assert_eq!(Msg::decode(0x01, &buf[..n]), Ok(msg));
    /// assert_eq!(Msg::decode(0x01, &buf[..n - 1]), Err(MsgError::DecodeTruncated));
    /// assert_eq!(Msg::decode(0xEE, &buf[..n]), Err(MsgError::DecodeUnknownType));
    /// # Ok::<(), MsgError>(())
    /// ```
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, MsgError> {
        let mut w = Writer::new(out);
        match *self {
            Self::Hello { protocol } => {
                w.u16(protocol)?;
                w.u16(0)?;
            }
            Self::Version(d) => {
                w.u16(d.protocol)?;
                w.bytes(&d.firmware)?;
                w.u8(d.board)?;
                w.u16(d.max_payload)?;
                w.u16(d.pe_count)?;
                w.u32(d.voxel_capacity)?;
                w.u32(d.pe_mem_words)?;
                w.u32(d.features)?;
            }
            Self::SceneBegin { total_len, crc } => {
                w.u32(total_len)?;
                w.u32(crc)?;
            }
            Self::SceneChunk { offset, data } => {
                w.u32(offset)?;
                w.bytes(data)?;
            }
            Self::SceneAck { next_offset, status } => {
                w.u32(next_offset)?;
                w.u8(status as u8)?;
                w.bytes(&[0; 3])?;
            }
            Self::SceneData { offset, data } | Self::FlashData { offset, data } => {
                w.u32(offset)?;
                w.bytes(data)?;
            }
            Self::SceneSack { status, sack } => write_sack(&mut w, status as u8, &sack)?,
            Self::FlashSack { status, sack } => write_sack(&mut w, status as u8, &sack)?,
            Self::RenderRequest(r) => write_request(&mut w, &r)?,
            Self::RenderRegion { region, max_span, options, request } => {
                write_region(&mut w, region)?;
                w.u16(max_span)?;
                w.u16(options)?;
                write_request(&mut w, &request)?;
            }
            Self::RegionEnd { frame, region, spans, crc } => {
                w.u16(frame)?;
                w.u16(0)?;
                write_region(&mut w, region)?;
                w.u32(spans)?;
                w.u32(crc)?;
            }
            Self::PixelSpan { frame, y, x0, count, encoding, data } => {
                if !span_data_valid(encoding, count, data) {
                    return Err(MsgError::EncodeBadField);
                }
                w.u16(frame)?;
                w.u16(y)?;
                w.u16(x0)?;
                w.u16(count)?;
                w.u8(encoding as u8)?;
                w.u8(0)?;
                w.bytes(data)?;
            }
            Self::FrameEnd { frame, spans, image_crc } => {
                w.u16(frame)?;
                w.u16(0)?;
                w.u32(spans)?;
                w.u32(image_crc)?;
            }
            Self::Stats { frame, entries } => {
                if entries.len() % STAT_ENTRY_LEN != 0 || entries.len() / STAT_ENTRY_LEN > u16::MAX as usize {
                    return Err(MsgError::EncodeBadField);
                }
                w.u16(frame)?;
                w.u16((entries.len() / STAT_ENTRY_LEN) as u16)?;
                w.bytes(entries)?;
            }
            Self::FlashBegin { version, total_len, crc, load_addr, entry } => {
                w.u16(version)?;
                w.u16(0)?;
                w.u32(total_len)?;
                w.u32(crc)?;
                w.u32(load_addr)?;
                w.u32(entry)?;
            }
            Self::FlashChunk { offset, data } => {
                w.u32(offset)?;
                w.bytes(data)?;
            }
            Self::FlashAck { next_offset, status, crc } => {
                w.u32(next_offset)?;
                w.u8(status as u8)?;
                w.bytes(&[0; 3])?;
                w.u32(crc)?;
            }
            Self::FlashBoot { crc } => {
                w.u32(crc)?;
            }
            Self::Error { code, detail, text } => {
                // Cut at a character boundary so the decoder's UTF-8 check accepts it.
                let mut cut = MAX_ERROR_TEXT.min(text.len());
                while !text.is_char_boundary(cut) {
                    // 0 is a boundary, so this stops before it would underflow.
                    cut = cut.saturating_sub(1);
                }
                let text = text.as_bytes().get(..cut).unwrap_or(&[]);
                w.u16(code.code())?;
                w.u16(text.len() as u16)?;
                w.u32(detail)?;
                w.bytes(text)?;
            }
        }
        Ok(w.len())
    }

    /// Decodes a payload of message type `kind`.
    pub fn decode(kind: u8, payload: &'a [u8]) -> Result<Self, MsgError> {
        let ty = MsgType::from_u8(kind).ok_or(MsgError::DecodeUnknownType)?;
        let mut r = Reader::new(payload);
        let msg = match ty {
            MsgType::Hello => {
                let protocol = r.u16()?;
                let _ = r.u16()?;
                Self::Hello { protocol }
            }
            MsgType::Version => Self::Version(DeviceInfo {
                protocol: r.u16()?,
                firmware: [r.u8()?, r.u8()?, r.u8()?],
                board: r.u8()?,
                max_payload: r.u16()?,
                pe_count: r.u16()?,
                voxel_capacity: r.u32()?,
                pe_mem_words: r.u32()?,
                features: r.u32()?,
            }),
            MsgType::SceneBegin => Self::SceneBegin { total_len: r.u32()?, crc: r.u32()? },
            MsgType::SceneChunk => Self::SceneChunk { offset: r.u32()?, data: r.rest() },
            MsgType::SceneAck => {
                let next_offset = r.u32()?;
                let status = match r.u8()? {
                    0 => SceneStatus::Receiving,
                    1 => SceneStatus::Loaded,
                    _ => return Err(MsgError::DecodeBadField),
                };
                let _ = r.take(3)?;
                Self::SceneAck { next_offset, status }
            }
            MsgType::SceneData => Self::SceneData { offset: r.u32()?, data: r.rest() },
            MsgType::SceneSack => {
                let (status, sack) = read_sack(&mut r)?;
                let status = match status {
                    0 => SceneStatus::Receiving,
                    1 => SceneStatus::Loaded,
                    _ => return Err(MsgError::DecodeBadField),
                };
                Self::SceneSack { status, sack }
            }
            MsgType::RenderRequest => Self::RenderRequest(read_request(&mut r)?),
            MsgType::RenderRegion => {
                let region = read_region(&mut r)?;
                let max_span = r.u16()?;
                let options = r.u16()?;
                Self::RenderRegion { region, max_span, options, request: read_request(&mut r)? }
            }
            MsgType::RegionEnd => {
                let frame = r.u16()?;
                let _ = r.u16()?;
                Self::RegionEnd { frame, region: read_region(&mut r)?, spans: r.u32()?, crc: r.u32()? }
            }
            MsgType::PixelSpan => {
                let frame = r.u16()?;
                let y = r.u16()?;
                let x0 = r.u16()?;
                let count = r.u16()?;
                let encoding = PixelEncoding::from_u8(r.u8()?).ok_or(MsgError::DecodeBadField)?;
                let _ = r.u8()?;
                let data = r.rest();
                if !span_data_valid(encoding, count, data) {
                    return Err(MsgError::DecodeBadField);
                }
                Self::PixelSpan { frame, y, x0, count, encoding, data }
            }
            MsgType::FrameEnd => {
                let frame = r.u16()?;
                let _ = r.u16()?;
                Self::FrameEnd { frame, spans: r.u32()?, image_crc: r.u32()? }
            }
            MsgType::Stats => {
                let frame = r.u16()?;
                let n = r.u16()? as usize;
                let entries = r.take(n.saturating_mul(STAT_ENTRY_LEN))?;
                Self::Stats { frame, entries }
            }
            MsgType::FlashBegin => {
                let version = r.u16()?;
                let _ = r.u16()?;
                Self::FlashBegin { version, total_len: r.u32()?, crc: r.u32()?, load_addr: r.u32()?, entry: r.u32()? }
            }
            MsgType::FlashChunk => Self::FlashChunk { offset: r.u32()?, data: r.rest() },
            MsgType::FlashAck => {
                let next_offset = r.u32()?;
                let status = match r.u8()? {
                    0 => FlashStatus::Receiving,
                    1 => FlashStatus::Verified,
                    2 => FlashStatus::Booting,
                    _ => return Err(MsgError::DecodeBadField),
                };
                let _ = r.take(3)?;
                Self::FlashAck { next_offset, status, crc: r.u32()? }
            }
            MsgType::FlashBoot => Self::FlashBoot { crc: r.u32()? },
            MsgType::FlashData => Self::FlashData { offset: r.u32()?, data: r.rest() },
            MsgType::FlashSack => {
                let (status, sack) = read_sack(&mut r)?;
                let status = match status {
                    0 => FlashStatus::Receiving,
                    1 => FlashStatus::Verified,
                    _ => return Err(MsgError::DecodeBadField),
                };
                Self::FlashSack { status, sack }
            }
            MsgType::Error => {
                let code = ErrorCode::from_code(r.u16()?);
                let len = r.u16()? as usize;
                if len > MAX_ERROR_TEXT {
                    return Err(MsgError::DecodeBadField);
                }
                let detail = r.u32()?;
                let text = core::str::from_utf8(r.take(len)?).map_err(|_| MsgError::DecodeBadText)?;
                Self::Error { code, detail, text }
            }
        };
        if r.remaining() != 0 {
            return Err(MsgError::DecodeTrailingBytes);
        }
        Ok(msg)
    }
}

fn write_request(w: &mut Writer<'_>, r: &RenderRequest) -> Result<(), MsgError> {
    w.u16(r.frame)?;
    w.u16(r.width)?;
    w.u16(r.height)?;
    w.u16(r.flags)?;
    w.vec3(r.eye)?;
    w.vec3(r.target)?;
    w.vec3(r.up)?;
    w.f32(r.fov_y_deg)?;
    w.vec3(r.light_pos)?;
    w.f32(r.light_intensity)?;
    w.f32(r.ambient)?;
    w.u8(r.encoding as u8)?;
    w.bytes(&[0; 3])?;
    Ok(())
}

fn read_request(r: &mut Reader<'_>) -> Result<RenderRequest, MsgError> {
    let req = RenderRequest {
        frame: r.u16()?,
        width: r.u16()?,
        height: r.u16()?,
        flags: r.u16()?,
        eye: r.vec3()?,
        target: r.vec3()?,
        up: r.vec3()?,
        fov_y_deg: r.f32()?,
        light_pos: r.vec3()?,
        light_intensity: r.f32()?,
        ambient: r.f32()?,
        encoding: PixelEncoding::from_u8(r.u8()?).ok_or(MsgError::DecodeBadField)?,
    };
    let _ = r.take(3)?;
    Ok(req)
}

fn write_sack(w: &mut Writer<'_>, status: u8, s: &Sack) -> Result<(), MsgError> {
    w.u32(s.next_offset)?;
    w.u8(status)?;
    w.u8(s.ranges.len() as u8)?;
    w.u16(s.heard)?;
    w.u16(s.window)?;
    w.u16(0)?;
    w.u32(s.crc)?;
    for &(start, end) in s.ranges.as_slice() {
        w.u16(start)?;
        w.u16(end)?;
    }
    Ok(())
}

/// The status byte (checked by the caller, it differs per message) and the rest.
fn read_sack(r: &mut Reader<'_>) -> Result<(u8, Sack), MsgError> {
    let next_offset = r.u32()?;
    let status = r.u8()?;
    let count = r.u8()? as usize;
    let heard = r.u16()?;
    let window = r.u16()?;
    let _ = r.u16()?;
    let crc = r.u32()?;
    if count > MAX_SACK_RANGES {
        return Err(MsgError::DecodeBadField);
    }
    let mut ranges = SackRanges::new();
    for _ in 0..count {
        let (start, end) = (r.u16()?, r.u16()?);
        if !ranges.push(start, end) {
            return Err(MsgError::DecodeBadField);
        }
    }
    Ok((status, Sack { next_offset, heard, window, crc, ranges }))
}

fn write_region(w: &mut Writer<'_>, g: Region) -> Result<(), MsgError> {
    w.u16(g.x0)?;
    w.u16(g.y0)?;
    w.u16(g.cols)?;
    w.u16(g.rows)?;
    Ok(())
}

fn read_region(r: &mut Reader<'_>) -> Result<Region, MsgError> {
    Ok(Region { x0: r.u16()?, y0: r.u16()?, cols: r.u16()?, rows: r.u16()? })
}

/// `data` holds exactly `count` pixels of `encoding` (for `Rle`: decodes to exactly `count`).
fn span_data_valid(encoding: PixelEncoding, count: u16, data: &[u8]) -> bool {
    match encoding.fixed_bytes_per_pixel() {
        Some(bpp) => Some(data.len()) == (count as usize).checked_mul(bpp),
        None => crate::pixel::rle_validate(count as usize, data).is_ok(),
    }
}

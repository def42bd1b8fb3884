//! Bounds-checked little-endian cursors used by every decoder in this crate.
//!
//! Reads past the end return [`Truncated`] instead of panicking, so a short or corrupt
//! payload can never index out of bounds.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// A read ran past the end of the input.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncated;

/// A write ran past the end of the output buffer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Overflow;

/// Little-endian reader over a byte slice.
#[derive(Debug, Clone)]
pub struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    /// Starts reading at the beginning of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Self { buf, pos: 0 }
    }
    /// Bytes not yet consumed.
    pub fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }
    /// Current offset from the start.
    pub fn position(&self) -> usize {
        self.pos
    }
    /// Takes the next `n` bytes.
    pub fn take(&mut self, n: usize) -> Result<&'a [u8], Truncated> {
        let end = self.pos.checked_add(n).ok_or(Truncated)?;
        let s = self.buf.get(self.pos..end).ok_or(Truncated)?;
        self.pos = end;
        Ok(s)
    }
    /// Takes everything that is left.
    pub fn rest(&mut self) -> &'a [u8] {
        let s = self.buf.get(self.pos..).unwrap_or(&[]);
        self.pos = self.buf.len();
        s
    }
    /// Reads the next `N` bytes.
    pub fn array<const N: usize>(&mut self) -> Result<[u8; N], Truncated> {
        self.take(N)?.try_into().map_err(|_| Truncated)
    }
    /// Reads a `u8`.
    pub fn u8(&mut self) -> Result<u8, Truncated> {
        let [b] = self.array::<1>()?;
        Ok(b)
    }
    /// Reads a little-endian `u16`.
    pub fn u16(&mut self) -> Result<u16, Truncated> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    /// Reads a little-endian `u32`.
    pub fn u32(&mut self) -> Result<u32, Truncated> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    /// Reads a little-endian `u64`.
    pub fn u64(&mut self) -> Result<u64, Truncated> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    /// Reads a little-endian IEEE-754 `f32`.
    pub fn f32(&mut self) -> Result<f32, Truncated> {
        Ok(f32::from_bits(self.u32()?))
    }
    /// Reads three `f32` as `[x, y, z]`.
    pub fn vec3(&mut self) -> Result<[f32; 3], Truncated> {
        Ok([self.f32()?, self.f32()?, self.f32()?])
    }
    /// Reads `N` little-endian `f32`.
    pub fn f32s<const N: usize>(&mut self) -> Result<[f32; N], Truncated> {
        let mut out = [0f32; N];
        for v in out.iter_mut() {
            *v = self.f32()?;
        }
        Ok(out)
    }
}

/// Little-endian writer into a caller-provided buffer.
#[derive(Debug)]
pub struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl<'a> Writer<'a> {
    /// Starts writing at the beginning of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self { buf, pos: 0 }
    }
    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.pos
    }
    /// True when nothing has been written.
    pub fn is_empty(&self) -> bool {
        self.pos == 0
    }
    /// Appends raw bytes.
    pub fn bytes(&mut self, b: &[u8]) -> Result<(), Overflow> {
        let end = self.pos.checked_add(b.len()).ok_or(Overflow)?;
        self.buf.get_mut(self.pos..end).ok_or(Overflow)?.copy_from_slice(b);
        self.pos = end;
        Ok(())
    }
    /// Appends a `u8`.
    pub fn u8(&mut self, v: u8) -> Result<(), Overflow> {
        self.bytes(&[v])
    }
    /// Appends a little-endian `u16`.
    pub fn u16(&mut self, v: u16) -> Result<(), Overflow> {
        self.bytes(&v.to_le_bytes())
    }
    /// Appends a little-endian `u32`.
    pub fn u32(&mut self, v: u32) -> Result<(), Overflow> {
        self.bytes(&v.to_le_bytes())
    }
    /// Appends a little-endian `u64`.
    pub fn u64(&mut self, v: u64) -> Result<(), Overflow> {
        self.bytes(&v.to_le_bytes())
    }
    /// Appends a little-endian `f32`.
    pub fn f32(&mut self, v: f32) -> Result<(), Overflow> {
        self.u32(v.to_bits())
    }
    /// Appends three `f32`.
    pub fn vec3(&mut self, v: [f32; 3]) -> Result<(), Overflow> {
        let [x, y, z] = v;
        self.f32(x)?;
        self.f32(y)?;
        self.f32(z)
    }
    /// Appends `f32`s.
    pub fn f32s(&mut self, v: &[f32]) -> Result<(), Overflow> {
        v.iter().try_for_each(|&f| self.f32(f))
    }
}

/// A fixed-size record written front to back by `write`, zero-filled after what it wrote.
/// The record types' round-trip tests pin that `write` fits `N` bytes; a longer `write` is
/// cut at `N` (debug builds assert).
pub fn record<const N: usize>(write: impl FnOnce(&mut Writer<'_>) -> Result<(), Overflow>) -> [u8; N] {
    let mut b = [0u8; N];
    let fits = write(&mut Writer::new(&mut b));
    debug_assert!(fits.is_ok(), "record longer than {N} bytes");
    b
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    #[test]
    fn reader_reports_truncation_instead_of_panicking() {
        let mut r = Reader::new(&[1, 2, 3]);
        assert_eq!(r.u16(), Ok(0x0201));
        assert_eq!(r.u16(), Err(Truncated));
        assert_eq!(r.u8(), Ok(3));
        assert_eq!(r.u8(), Err(Truncated));
    }

    #[test]
    fn writer_reports_overflow_and_keeps_written_prefix() {
        let mut buf = [0u8; 5];
        let mut w = Writer::new(&mut buf);
        assert_eq!(w.u32(0xDEADBEEF), Ok(()));
        assert_eq!(w.u16(1), Err(Overflow));
        assert_eq!(w.len(), 4);
        assert_eq!(buf[..4], [0xEF, 0xBE, 0xAD, 0xDE]);
    }
}

//! The PE image as a PE holds it: where its tables start, what LOAD checks beyond
//! `PeImage::parse`, its triangle records as vertices, and checked access to PE memory by
//! offsets that come from images and requests.

use gridrt_shared::math::Vec3;
use gridrt_shared::scene::{PeImage, TRIANGLE_WORDS, VOXEL_ENTRY_WORDS};

use crate::isect::Triangle;

/// Layout of one loaded PE image (offsets relative to the PE's memory base).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct PeSlot {
    pub(super) loaded: bool,
    pub(super) len: u32,
    pub(super) voxels: u32,
    pub(super) ref_off: u32,
    pub(super) tri_off: u32,
    /// Words before the voxel table (`PE_HEADER_WORDS`, or 0 for an empty image).
    pub(super) hdr: u32,
    /// Triangles T (refs ≥ T name analytic primitives).
    pub(super) tris: u32,
    /// Offset of the primitive records.
    pub(super) prim_off: u32,
    /// Analytic primitives P.
    pub(super) prims: u32,
}

/// Checks a PE image beyond `PeImage::parse`: voxel ids strictly increasing (so lookups can
/// binary-search) and materials that fit the 16-bit result field.
pub(super) fn validate_image(words: &[u32]) -> Option<PeSlot> {
    let img = PeImage::parse(words).ok()?;
    let voxels = img.voxel_count();
    let mut prev: Option<u32> = None;
    for i in 0..voxels {
        let (id, _, _) = img.voxel_entry(i)?;
        if prev.is_some_and(|p| id <= p) {
            return None;
        }
        prev = Some(id);
    }
    for i in 0..img.triangle_count() {
        if img.triangle(i)?.material > u16::MAX as u32 {
            return None;
        }
    }
    for i in 0..img.primitive_count() {
        if img.primitive(i)?.material > u16::MAX as u32 {
            return None;
        }
    }
    let ref_off = voxels.checked_mul(VOXEL_ENTRY_WORDS)?.checked_add(img.header_words())?;
    let tri_off = ref_off.checked_add(img.ref_table().len())?;
    Some(PeSlot {
        loaded: true,
        len: u32::try_from(words.len()).ok()?,
        voxels: u32::try_from(voxels).ok()?,
        ref_off: u32::try_from(ref_off).ok()?,
        tri_off: u32::try_from(tri_off).ok()?,
        hdr: u32::try_from(img.header_words()).ok()?,
        tris: u32::try_from(img.triangle_count()).ok()?,
        prim_off: u32::try_from(img.primitive_offset()).ok()?,
        prims: u32::try_from(img.primitive_count()).ok()?,
    })
}

/// The 9 vertex floats at the start of an image's triangle record.
#[inline(always)]
pub(super) fn record(rec: &[u32; TRIANGLE_WORDS]) -> Triangle {
    let f = f32::from_bits;
    [
        Vec3::new(f(rec[0]), f(rec[1]), f(rec[2])),
        Vec3::new(f(rec[3]), f(rec[4]), f(rec[5])),
        Vec3::new(f(rec[6]), f(rec[7]), f(rec[8])),
    ]
}

/// The `n` words of `mem` at `at`; `None` when they reach past its end (or `at + n`
/// overflows).
#[inline(always)]
pub(super) fn span(mem: &[u32], at: usize, n: usize) -> Option<&[u32]> {
    mem.get(at..at.checked_add(n)?)
}

/// [`span`], writable.
#[inline(always)]
pub(super) fn span_mut(mem: &mut [u32], at: usize, n: usize) -> Option<&mut [u32]> {
    mem.get_mut(at..at.checked_add(n)?)
}

/// The `N`-word record of `mem` at `at`.
#[inline(always)]
pub(super) fn record_at<const N: usize>(mem: &[u32], at: usize) -> Option<&[u32; N]> {
    span(mem, at, N)?.try_into().ok()
}

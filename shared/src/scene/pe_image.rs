//! The PE memory image (SPEC.md §5.4): what one PE's block RAM holds, loaded verbatim over FSL
//! with a LOAD_PE packet, and the read-only view every side parses it with.

use super::geometry::{PrimRecord, TriangleRecord};
use super::layout::{SceneError, PE_HEADER_WORDS, PE_IMAGE_TAG, PRIM_WORDS, TRIANGLE_WORDS, VOXEL_ENTRY_WORDS};

/// Read-only view of one PE memory image (SPEC.md §5.4), validated on construction.
///
/// ```text
/// word 0: PE_IMAGE_TAG   word 1: T triangles   word 2: V voxels   word 3: R refs   word 4: P primitives
/// V × (voxel id, first ref, ref count)
/// R × ref: < T a local triangle index, T..T+P local primitive T + i
/// T × triangle record (11 words: ax ay az bx by bz cx cy cz, prim id, material)
/// P × primitive record (16 words, PrimRecord)
/// ```
/// An empty image (0 words) is an empty PE.
#[derive(Debug, Clone, Copy)]
pub struct PeImage<'a> {
    // Invariant (checked by `parse`): header + 3V + R + 11T + 16P = words.len() without
    // overflow, so every offset below the counts is a sum of terms of that total.
    words: &'a [u32],
    header: usize,
    triangles: usize,
    voxels: usize,
    refs: usize,
    prims: usize,
}

// Offsets are sums and products of counts whose total `parse` checked against the slice
// length (`checked_*`), so they cannot overflow; the slices are taken with `get`.
#[allow(clippy::arithmetic_side_effects)]
impl<'a> PeImage<'a> {
    /// Checks the counts, that every voxel's ref range lies inside the ref table and every ref
    /// names a triangle or a primitive, that vertex coordinates and primitive
    /// transforms are finite and primitive kinds known.
    pub fn parse(words: &'a [u32]) -> Result<Self, SceneError> {
        let empty = Self { words, header: PE_HEADER_WORDS, triangles: 0, voxels: 0, refs: 0, prims: 0 };
        let (header, t, v, r, p) = match words {
            [] => return Ok(empty),
            &[PE_IMAGE_TAG, t, v, r, p, ..] => (PE_HEADER_WORDS, t, v, r, p),
            _ => return Err(SceneError::BadPeBlock),
        };
        let (t, v, r, p) = (t as usize, v as usize, r as usize, p as usize);
        let need = v
            .checked_mul(VOXEL_ENTRY_WORDS)
            .and_then(|x| x.checked_add(r))
            .and_then(|x| t.checked_mul(TRIANGLE_WORDS).and_then(|y| x.checked_add(y)))
            .and_then(|x| p.checked_mul(PRIM_WORDS).and_then(|y| x.checked_add(y)))
            .and_then(|x| x.checked_add(header))
            .ok_or(SceneError::BadPeBlock)?;
        if need != words.len() {
            return Err(SceneError::BadPeBlock);
        }
        let img = Self { words, header, triangles: t, voxels: v, refs: r, prims: p };
        let mut previous: Option<u32> = None;
        for i in 0..v {
            let (voxel, first, count) = img.voxel_entry(i).ok_or(SceneError::BadPeBlock)?;
            // Strictly increasing ids let the co-processor binary-search the table.
            if previous.is_some_and(|p| voxel <= p) {
                return Err(SceneError::BadPeBlock);
            }
            previous = Some(voxel);
            let end = (first as usize).checked_add(count as usize).ok_or(SceneError::BadPeBlock)?;
            if end > r {
                return Err(SceneError::BadPeBlock);
            }
        }
        // t + p < need ≤ words.len(): no overflow.
        if img.ref_table().iter().any(|&x| (x as usize) >= t.saturating_add(p)) {
            return Err(SceneError::BadPeBlock);
        }
        for i in 0..t {
            let tri = img.triangle(i).ok_or(SceneError::BadPeBlock)?;
            if tri.vertices.iter().flatten().any(|c| !c.is_finite()) {
                return Err(SceneError::NonFinite);
            }
        }
        for i in 0..p {
            let prim = img.primitive(i).ok_or(SceneError::BadPeBlock)?;
            if prim.world_to_object.iter().any(|c| !c.is_finite()) {
                return Err(SceneError::NonFinite);
            }
        }
        Ok(img)
    }

    /// Words before the voxel table ([`PE_HEADER_WORDS`], or 0 for an empty image).
    pub fn header_words(&self) -> usize {
        self.header
    }
    /// Number of analytic primitives.
    pub fn primitive_count(&self) -> usize {
        self.prims
    }
    /// Word offset of the triangle records.
    pub fn triangle_offset(&self) -> usize {
        self.header + self.voxels * VOXEL_ENTRY_WORDS + self.refs
    }
    /// Word offset of the primitive records.
    pub fn primitive_offset(&self) -> usize {
        self.triangle_offset() + self.triangles * TRIANGLE_WORDS
    }
    /// Local primitive `i`.
    pub fn primitive(&self, i: usize) -> Option<PrimRecord> {
        if i >= self.prims {
            return None;
        }
        let base = self.primitive_offset() + i * PRIM_WORDS;
        PrimRecord::from_words(self.words.get(base..base + PRIM_WORDS)?)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }
    /// Number of voxels this PE owns that hold primitives.
    pub fn voxel_count(&self) -> usize {
        self.voxels
    }
    /// `(voxel id, first ref, ref count)` of voxel-table entry `i`.
    pub fn voxel_entry(&self, i: usize) -> Option<(u32, u32, u32)> {
        if i >= self.voxels {
            return None;
        }
        let base = self.header + i * VOXEL_ENTRY_WORDS;
        match self.words.get(base..base + VOXEL_ENTRY_WORDS)? {
            &[a, b, c] => Some((a, b, c)),
            _ => None,
        }
    }
    /// The reference table (local triangle indices, then local primitive indices from T).
    pub fn ref_table(&self) -> &'a [u32] {
        let base = self.header + self.voxels * VOXEL_ENTRY_WORDS;
        self.words.get(base..base + self.refs).unwrap_or(&[])
    }
    /// Local triangle `i`.
    pub fn triangle(&self, i: usize) -> Option<TriangleRecord> {
        if i >= self.triangles {
            return None;
        }
        let base = self.triangle_offset() + i * TRIANGLE_WORDS;
        let w = self.words.get(base..base + TRIANGLE_WORDS)?;
        let f = |k: usize| f32::from_bits(w.get(k).copied().unwrap_or(0));
        Some(TriangleRecord {
            vertices: [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]],
            prim: w.get(9).copied().unwrap_or(0),
            material: w.get(10).copied().unwrap_or(0),
        })
    }
}

//! The fixed 64-byte header of the scene image (SPEC.md §5.1).

use super::layout::{SceneError, HEADER_LEN, MAGIC, MAX_PES, MAX_VOXELS, VERSION};
use crate::bytes::Reader;

/// The fixed 64-byte header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHeader {
    /// Grid resolution along x, y, z.
    pub dims: [u16; 3],
    /// Number of PEs (and PE blocks).
    pub pe_count: u16,
    /// Grid box minimum corner.
    pub bounds_min: [f32; 3],
    /// Grid box maximum corner.
    pub bounds_max: [f32; 3],
    /// Number of materials (each a colour record and a model record).
    pub material_count: u16,
    /// Flags ([`scene_flags`](super::scene_flags)): bit 0 `POINTS` (a point section follows the PE
    /// blocks); other bits written 0, ignored by readers.
    pub flags: u16,
    /// Primitives in the scene (triangles + analytic); global prim ids are below it.
    pub triangle_count: u32,
    /// PE memory size (32-bit words) the image was built for.
    pub pe_mem_words: u32,
    /// Total image length in bytes, header included.
    pub total_len: u32,
    /// CRC-32 of bytes `64..total_len`.
    pub body_crc: u32,
    /// Number of object records.
    pub object_count: u16,
}

impl SceneHeader {
    /// Number of voxels `nx·ny·nz`.
    pub fn voxel_count(&self) -> u32 {
        // parse() guarantees the product fits 24 bits; saturate for unvalidated headers.
        u32::try_from(self.dims.iter().map(|&d| d as u64).product::<u64>()).unwrap_or(u32::MAX)
    }

    /// Bytes of the voxel map including padding to a multiple of 4.
    pub fn voxel_map_len(&self) -> usize {
        // voxel_count() ≤ u32::MAX, so rounding up to a multiple of 4 fits a usize ≥ 64 bits or
        // saturates on a 32-bit target (and then never matches a real stream's length).
        (self.voxel_count() as usize).div_ceil(4).saturating_mul(4)
    }

    /// Serialises the header.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        let mut w = crate::bytes::Writer::new(&mut b);
        // The buffer is exactly HEADER_LEN bytes, so none of these writes can overflow.
        let _ = (|| -> Result<(), crate::bytes::Overflow> {
            w.bytes(&MAGIC)?;
            w.u16(VERSION)?;
            w.u16(HEADER_LEN as u16)?;
            for d in self.dims {
                w.u16(d)?;
            }
            w.u16(self.pe_count)?;
            w.vec3(self.bounds_min)?;
            w.vec3(self.bounds_max)?;
            w.u16(self.material_count)?;
            w.u16(self.flags)?;
            w.u32(self.triangle_count)?;
            w.u32(self.pe_mem_words)?;
            w.u32(self.total_len)?;
            w.u32(self.body_crc)?;
            w.u16(self.object_count)?;
            w.u16(0)
        })();
        b
    }

    /// Parses and range-checks the header.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        if r.take(4).map_err(t)? != MAGIC {
            return Err(SceneError::BadMagic);
        }
        if r.u16().map_err(t)? != VERSION {
            return Err(SceneError::BadVersion);
        }
        if r.u16().map_err(t)? as usize != HEADER_LEN {
            return Err(SceneError::BadHeader);
        }
        let dims = [r.u16().map_err(t)?, r.u16().map_err(t)?, r.u16().map_err(t)?];
        let pe_count = r.u16().map_err(t)?;
        let bounds_min = r.vec3().map_err(t)?;
        let bounds_max = r.vec3().map_err(t)?;
        let h = Self {
            dims,
            pe_count,
            bounds_min,
            bounds_max,
            material_count: r.u16().map_err(t)?,
            flags: r.u16().map_err(t)?,
            triangle_count: r.u32().map_err(t)?,
            pe_mem_words: r.u32().map_err(t)?,
            total_len: r.u32().map_err(t)?,
            body_crc: r.u32().map_err(t)?,
            object_count: r.u16().map_err(t)?,
        };
        if bounds_min.iter().chain(bounds_max.iter()).any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        let box_ok = bounds_min.iter().zip(bounds_max.iter()).all(|(lo, hi)| lo < hi);
        let voxels: u64 = dims.iter().map(|&d| d as u64).product();
        if voxels > MAX_VOXELS as u64
            || dims.contains(&0)
            || pe_count == 0
            || pe_count as usize > MAX_PES
            || !box_ok
            || (h.total_len as usize) < HEADER_LEN
        {
            return Err(SceneError::BadHeader);
        }
        Ok(h)
    }
}

//! The point section of a scene image (SPEC.md §5.10): an oriented point cloud for the splat
//! renderer (point splatting), after the PE blocks, present when the header's
//! [`scene_flags::POINTS`] bit is set. The same points are in the PE blocks as disks, so the
//! ray tracer renders them too.

use super::layout::SceneError;
use crate::bytes::{record, Reader};

/// Header `flags` bits.
pub mod scene_flags {
    /// The image ends with a point section (SPEC.md §5.10).
    pub const POINTS: u16 = 1 << 0;
}

/// Bytes of the point section's head.
pub const POINTS_HEAD_LEN: usize = 32;
/// Bytes per point record.
pub const POINT_LEN: usize = 32;

/// The point section's head.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointsHead {
    /// Point records that follow.
    pub count: u32,
    /// Box of the whole cloud (every board of a sort-last split gets the same box, so all
    /// quantise depth alike): finite, min ≤ max per axis.
    pub bounds_min: [f32; 3],
    /// Maximum corner.
    pub bounds_max: [f32; 3],
}

impl PointsHead {
    /// Serialises the head: count u32, reserved u32 (0), bounds min, bounds max.
    pub fn to_bytes(&self) -> [u8; POINTS_HEAD_LEN] {
        record(|w| {
            w.u32(self.count)?;
            w.u32(0)?;
            w.vec3(self.bounds_min)?;
            w.vec3(self.bounds_max)
        })
    }

    /// Parses and checks the head.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let count = r.u32().map_err(t)?;
        let _reserved = r.u32().map_err(t)?;
        let bounds_min = r.vec3().map_err(t)?;
        let bounds_max = r.vec3().map_err(t)?;
        if bounds_min.iter().chain(bounds_max.iter()).any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        if bounds_min.iter().zip(bounds_max.iter()).any(|(lo, hi)| lo > hi) {
            return Err(SceneError::BadRecord);
        }
        Ok(Self { count, bounds_min, bounds_max })
    }
}

/// One oriented point: a disk of `radius` around `pos`, facing `normal`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointRecord {
    /// Centre.
    pub pos: [f32; 3],
    /// Normal: finite, not zero (need not be unit; readers normalise).
    pub normal: [f32; 3],
    /// Disk radius, > 0.
    pub radius: f32,
    /// Material index, < the header's `material_count`.
    pub material: u16,
}

impl PointRecord {
    /// Serialises the record: pos f32×3, normal f32×3, radius f32, material u16, reserved u16.
    pub fn to_bytes(&self) -> [u8; POINT_LEN] {
        record(|w| {
            w.vec3(self.pos)?;
            w.vec3(self.normal)?;
            w.f32(self.radius)?;
            w.u16(self.material)?;
            w.u16(0)
        })
    }

    /// Parses and checks a record of a scene with `material_count` materials.
    pub fn parse(bytes: &[u8], material_count: u16) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        let [px, py, pz, nx, ny, nz, radius] = r.f32s::<7>().map_err(t)?;
        let material = r.u16().map_err(t)?;
        let _reserved = r.u16().map_err(t)?;
        if [px, py, pz, nx, ny, nz, radius].iter().any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        if radius <= 0.0 || (nx == 0.0 && ny == 0.0 && nz == 0.0) || material >= material_count {
            return Err(SceneError::BadRecord);
        }
        Ok(Self { pos: [px, py, pz], normal: [nx, ny, nz], radius, material })
    }
}

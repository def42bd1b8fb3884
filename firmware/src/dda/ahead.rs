//! Occupancy ahead: per voxel and per direction octant, whether a non-empty voxel lies in the
//! box from that voxel toward the octant's corner of the grid (the voxel included).
//!
//! Why a walk may stop where the bit is clear: the 3D-DDA moves monotonically on each axis
//! (Amanatides and Woo 1987; `dda` module doc), up where the direction component's sign bit
//! is 0 and down where it is 1, and not at all on a zero component; so every voxel it has
//! still to visit lies in that box, none of them is non-empty, and no entry can follow. The
//! walk then writes the same entries with fewer steps: on bun_zipper_res4 28 % of the camera
//! rays' steps came after their last entry, 18 % with the table (counted on the host's walk,
//! docs/bench-firmware.md).
//!
//! The table is a byte per voxel, built once per scene by six sweeps (a prefix and a suffix
//! OR along each axis, each on the four octants that look that way): the box OR is
//! separable.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

use gridrt_shared::scene::EMPTY_VOXEL;

/// The octant bits of rays going down on an axis (octant `i` has bit `a` of `i` set when
/// it goes down on axis `a`).
const DOWN: [u8; 3] = [0xAA, 0xCC, 0xF0];

/// The voxel → PE map a walk reads, with its occupancy-ahead table.
#[derive(Debug, Clone, Copy)]
pub struct VoxelMap<'a> {
    /// Owning PE per voxel, [`EMPTY_VOXEL`] = empty; ids past its end count as empty.
    pub pe: &'a [u8],
    /// [`fill_ahead`]'s table for `pe`; ids past its end (an empty table) never stop a walk.
    pub ahead: &'a [u8],
}

impl<'a> VoxelMap<'a> {
    /// A map whose walks stop only where the ray leaves the grid or its range.
    pub const fn plain(pe: &'a [u8]) -> Self {
        Self { pe, ahead: &[] }
    }

    /// The bit of `ahead` for a ray along `d` (the sign bits of its components).
    #[inline(always)]
    pub(super) fn octant_bit(d: [f32; 3]) -> u8 {
        let down = |c: f32, a: u32| (c.to_bits() >> 31) << a;
        1u8 << (down(d[0], 0) | down(d[1], 1) | down(d[2], 2))
    }

    /// False when no non-empty voxel lies ahead of `voxel` for octant bit `bit` (then a
    /// walk can stop).
    #[inline(always)]
    pub(super) fn any_ahead(&self, voxel: u32, bit: u8) -> bool {
        self.ahead.get(voxel as usize).is_none_or(|&b| b & bit != 0)
    }
}

/// Fills `ahead[..nx·ny·nz]` with the occupancy-ahead bits of the grid `dims` whose voxel map
/// is `pe` (ids past its end are empty). Returns false, with `ahead` left as "never stop"
/// (every byte 0xFF), when `ahead` is shorter than the grid.
///
/// ```
/// use gridrt_firmware::dda::fill_ahead;
/// // 3×1×1: only the middle voxel is non-empty.
/// let mut ahead = [0u8; 3];
/// assert!(fill_ahead([3, 1, 1], &[0xFF, 0, 0xFF], &mut ahead));
/// // From voxel 0, rays going up in x (even octants) have it ahead, rays going down do not.
/// assert_eq!(ahead, [0x55, 0xFF, 0xAA]);
/// ```
pub fn fill_ahead(dims: [u32; 3], pe: &[u8], ahead: &mut [u8]) -> bool {
    let [nx, ny, nz] = dims.map(|n| n as usize);
    let voxels = nx.checked_mul(ny).and_then(|v| v.checked_mul(nz));
    let Some(table) = voxels.and_then(|v| ahead.get_mut(..v)) else {
        ahead.fill(0xFF);
        return false;
    };
    for (v, b) in table.iter_mut().enumerate() {
        *b = if pe.get(v).is_some_and(|&p| p != EMPTY_VOXEL) { 0xFF } else { 0 };
    }
    // Strides of x, y, z and the voxels per axis; every index below is < nx·ny·nz.
    let strides = [1, nx, nx.wrapping_mul(ny)];
    for ((stride, n), down) in strides.into_iter().zip(dims.map(|n| n as usize)).zip(DOWN) {
        let up = !down;
        // Up the axis: a voxel sees what the one below it sees going down.
        for v in 0..table.len() {
            if coord(v, stride, n) != Some(0) {
                let below = table.get(v.wrapping_sub(stride)).copied().unwrap_or(0xFF);
                if let Some(b) = table.get_mut(v) {
                    *b |= below & down;
                }
            }
        }
        // Down the axis: a voxel sees what the one above it sees going up.
        for v in (0..table.len()).rev() {
            if coord(v, stride, n) != Some(n.wrapping_sub(1)) {
                let above = table.get(v.wrapping_add(stride)).copied().unwrap_or(0xFF);
                if let Some(b) = table.get_mut(v) {
                    *b |= above & up;
                }
            }
        }
    }
    true
}

/// The coordinate of voxel `v` on the axis of `stride` with `n` voxels.
fn coord(v: usize, stride: usize, n: usize) -> Option<usize> {
    v.checked_div(stride).and_then(|q| q.checked_rem(n))
}

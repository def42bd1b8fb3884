//! The voxel step both DDAs share (Amanatides & Woo 1987): emit the current voxel, find the
//! axis whose next boundary is nearest (the lowest axis on ties), step into the neighbour on
//! it. A number format ([`Stepper`]) only decides how a ray parameter is held, where the next
//! boundary on the stepped axis lies and how a parameter reads back as an f32.

use super::grid::VoxelStep;
use core::cmp::Ordering;

/// What the shared step loop asks of a DDA's number format.
pub(super) trait Stepper {
    /// A ray parameter: world `t` in f32, or the fixed-point `t'`.
    type T: Copy + PartialOrd;
    /// The smaller parameter (f32: the other one when one is NaN).
    fn min(a: Self::T, b: Self::T) -> Self::T;
    /// The larger parameter (f32: the other one when one is NaN).
    fn max(a: Self::T, b: Self::T) -> Self::T;
    /// The parameter of the next boundary on `axis`, the walk having just entered
    /// `walk.cell[axis]` on it (`walk.t_next[axis]` still holds the boundary it crossed).
    fn next_crossing(&self, walk: &Walk<Self::T>, axis: usize) -> Self::T;
    /// The parameter as the f32 of a [`VoxelStep`].
    fn world(&self, t: Self::T) -> f32;
}

/// The state of a walk through the grid, in a format's ray parameter `T`.
#[derive(Debug, Clone)]
pub(super) struct Walk<T> {
    /// Voxels per axis (0 for an empty walk).
    pub(super) dims: [i32; 3],
    /// The current voxel.
    pub(super) cell: [i32; 3],
    /// −1, 0 or +1 per axis; 0: never stepped.
    pub(super) step: [i32; 3],
    /// Parameter of the next boundary per axis.
    pub(super) t_next: [T; 3],
    /// Where the ray entered the current voxel.
    pub(super) t: T,
    /// Where the walk ends (the clip exit).
    pub(super) t_end: T,
    /// Voxels still allowed: the hard bound `nx + ny + nz`, 0 once the walk is over.
    pub(super) steps_left: u32,
    nx: u32,
    ny: u32,
}

impl<T: Copy + PartialOrd> Walk<T> {
    /// A walk that yields nothing, with every boundary at `never`.
    pub(super) const fn empty(zero: T, never: T) -> Self {
        Self {
            dims: [0; 3],
            cell: [0; 3],
            step: [0; 3],
            t_next: [never; 3],
            t: zero,
            t_end: zero,
            steps_left: 0,
            nx: 0,
            ny: 0,
        }
    }

    /// An empty walk on a grid of `dims` voxels, to be set up by the format: per axis `dims`,
    /// `cell`, `step`, `t_next`, then `start`.
    pub(super) const fn on_grid(dims: [u32; 3], zero: T, never: T) -> Self {
        Self { nx: dims[0], ny: dims[1], ..Self::empty(zero, never) }
    }

    /// Starts the walk on `[t0, t1]`, bounded to `nx + ny + nz` voxels.
    pub(super) fn start(&mut self, t0: T, t1: T, dims: [u32; 3]) {
        self.t = t0;
        self.t_end = t1;
        self.steps_left = dims.iter().sum();
    }

    /// The current voxel, then one step; `None` once the walk is over.
    #[inline(always)]
    pub(super) fn next<S: Stepper<T = T>>(&mut self, format: &S) -> Option<VoxelStep> {
        if self.steps_left == 0 {
            return None;
        }
        self.steps_left -= 1;
        let [tx, ty, tz] = self.t_next;
        // Lowest axis wins ties (documented in the module header of `dda`).
        let axis = if tx <= ty && tx <= tz {
            0
        } else if ty <= tz {
            1
        } else {
            2
        };
        let t_cross = self.t_next[axis];
        // f32: min/max ignore NaN, so a NaN boundary ends the voxel at t_end.
        let t_exit = S::max(S::min(t_cross, self.t_end), self.t);
        let cell = [self.cell[0] as u32, self.cell[1] as u32, self.cell[2] as u32];
        let item = VoxelStep {
            voxel: cell[0] + self.nx * (cell[1] + self.ny * cell[2]),
            cell,
            t_enter: format.world(self.t),
            t_exit: format.world(t_exit),
        };
        // The walk ends at t_end, and at a NaN boundary (which compares neither way).
        if t_cross.partial_cmp(&self.t_end) != Some(Ordering::Less) {
            self.steps_left = 0;
            return Some(item);
        }
        let c = self.cell[axis] + self.step[axis];
        if c < 0 || c >= self.dims[axis] {
            self.steps_left = 0;
            return Some(item);
        }
        self.cell[axis] = c;
        self.t_next[axis] = format.next_crossing(self, axis);
        self.t = t_exit;
        Some(item)
    }
}

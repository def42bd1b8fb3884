//! Axis-aligned bounds: what the scene model ([`crate::scene`]) measures and the default
//! camera ([`crate::render_settings`]) frames, below both.

/// Axis-aligned bounds in f32 (the precision of the scene).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

impl Bounds {
    /// Extent along each axis, in f64.
    pub fn extent(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| self.max[i] as f64 - self.min[i] as f64)
    }
    /// Centre point, in f64.
    pub fn center(&self) -> [f64; 3] {
        [0, 1, 2].map(|i| 0.5 * (self.min[i] as f64 + self.max[i] as f64))
    }
    /// Length of the diagonal, in f64.
    pub fn diagonal_len(&self) -> f64 {
        let e = self.extent();
        (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt()
    }
}

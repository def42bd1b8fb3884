//! Affine maps in f64 (row-major 3×4) for placing analytic primitives: composition, inverse,
//! translate-rotate-scale, and the f32 wire form the device receives.

use gridrt_shared::scene::Affine;

/// Row-major 3×4 affine map in f64.
pub type Affine64 = [[f64; 4]; 3];

/// The identity map.
pub const IDENTITY: Affine64 = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// `a ∘ b` (apply b first).
pub fn compose(a: &Affine64, b: &Affine64) -> Affine64 {
    let mut r = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..4 {
            let mut v = if j == 3 { a[i][3] } else { 0.0 };
            for k in 0..3 {
                v += a[i][k] * b[k][j];
            }
            r[i][j] = v;
        }
    }
    r
}

/// Inverse of an affine map; `None` when singular.
pub fn invert(m: &Affine64) -> Option<Affine64> {
    let a = |i: usize, j: usize| m[i][j];
    let det = a(0, 0) * (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) - a(0, 1) * (a(1, 0) * a(2, 2) - a(1, 2) * a(2, 0))
        + a(0, 2) * (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0));
    if det.is_nan() || det.abs() <= 1e-300 || !det.is_finite() {
        return None;
    }
    let inv = [
        [
            (a(1, 1) * a(2, 2) - a(1, 2) * a(2, 1)) / det,
            (a(0, 2) * a(2, 1) - a(0, 1) * a(2, 2)) / det,
            (a(0, 1) * a(1, 2) - a(0, 2) * a(1, 1)) / det,
        ],
        [
            (a(1, 2) * a(2, 0) - a(1, 0) * a(2, 2)) / det,
            (a(0, 0) * a(2, 2) - a(0, 2) * a(2, 0)) / det,
            (a(0, 2) * a(1, 0) - a(0, 0) * a(1, 2)) / det,
        ],
        [
            (a(1, 0) * a(2, 1) - a(1, 1) * a(2, 0)) / det,
            (a(0, 1) * a(2, 0) - a(0, 0) * a(2, 1)) / det,
            (a(0, 0) * a(1, 1) - a(0, 1) * a(1, 0)) / det,
        ],
    ];
    let mut r = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] = inv[i][j];
        }
        r[i][3] = -(inv[i][0] * m[0][3] + inv[i][1] * m[1][3] + inv[i][2] * m[2][3]);
    }
    Some(r)
}

/// Applies `m` to a point.
pub fn apply_point(m: &Affine64, p: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
}

/// Applies the linear part of `m` to a vector.
pub fn apply_vector(m: &Affine64, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// Applies the transposed linear part (object normal → world normal for a world→object map).
pub fn apply_transpose(m: &Affine64, v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|j| m[0][j] * v[0] + m[1][j] * v[1] + m[2][j] * v[2])
}

/// Translate · Rz · Ry · Rx · Scale (angles in degrees).
pub fn trs(translate: [f64; 3], rotate_deg: [f64; 3], scale: [f64; 3]) -> Affine64 {
    let s = [[scale[0], 0.0, 0.0, 0.0], [0.0, scale[1], 0.0, 0.0], [0.0, 0.0, scale[2], 0.0]];
    let (sx, cx) = rotate_deg[0].to_radians().sin_cos();
    let (sy, cy) = rotate_deg[1].to_radians().sin_cos();
    let (sz, cz) = rotate_deg[2].to_radians().sin_cos();
    let rx = [[1.0, 0.0, 0.0, 0.0], [0.0, cx, -sx, 0.0], [0.0, sx, cx, 0.0]];
    let ry = [[cy, 0.0, sy, 0.0], [0.0, 1.0, 0.0, 0.0], [-sy, 0.0, cy, 0.0]];
    let rz = [[cz, -sz, 0.0, 0.0], [sz, cz, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let mut m = compose(&rz, &compose(&ry, &compose(&rx, &s)));
    for (i, t) in translate.iter().enumerate() {
        m[i][3] = *t;
    }
    m
}

/// The f32 wire form of a world→object map (row-major 3×4).
pub fn to_wire(m: &Affine64) -> Affine {
    let mut a = [0f32; 12];
    for i in 0..3 {
        for j in 0..4 {
            a[4 * i + j] = m[i][j] as f32;
        }
    }
    a
}

/// The f64 map of the f32 wire form (the reference uses exactly what the device gets).
pub fn from_wire(a: &Affine) -> Affine64 {
    let mut m = [[0.0; 4]; 3];
    for i in 0..3 {
        for j in 0..4 {
            m[i][j] = a[4 * i + j] as f64;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trs_inverse_round_trips() {
        let m = trs([1.0, 2.0, 3.0], [10.0, 20.0, 30.0], [2.0, 0.5, 3.0]);
        let inv = invert(&m).unwrap();
        let p = [0.3, -0.7, 1.1];
        let q = apply_point(&inv, apply_point(&m, p));
        for i in 0..3 {
            assert!((p[i] - q[i]).abs() < 1e-12);
        }
        assert!(invert(&trs([0.0; 3], [0.0; 3], [1.0, 0.0, 1.0])).is_none());
    }
}

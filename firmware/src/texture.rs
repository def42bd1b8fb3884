//! Procedural textures (ViRAY: checkerboard, XOR, marble, wood, RGB dots),
//! texture-coordinate mappings (planar, cylindrical, spherical) and bilinear filtering.
//!
//! ViRAY generated its textures on the MicroBlaze into a 256×256 BRAM page; here the texel
//! (i, j) of an N×N texture (N = 2^`tex_log2`) is *computed* when it is fetched, from integer
//! texel coordinates, so no texture memory travels to the device and the f64 reference
//! (`host/src/reference/texture.rs`) evaluates the same texels. Checker, XOR and dots are integer
//! exact; marble and wood use a value noise whose lattice values come from an integer hash.
//! Addressing wraps (tiling); filtering is bilinear between texel centres or nearest.
//! `sin`/`cos`/`atan2`/`acos` are `crate::fmath`'s f32 polynomials (errors ≤ 3e-7 rad, no
//! `f64`), not ViRAY's polynomial/LUT approximations (their 0.005 and 0.06 rad errors would
//! cost PSNR).

use crate::fmath;
use gridrt_shared::scene::{Mapping, MaterialModel, TextureKind};

const TAU: f32 = core::f32::consts::TAU;
const PI: f32 = core::f32::consts::PI;

/// The integer hash of the value noise (shared with the host reference).
#[inline]
pub fn hash(x: u32, y: u32, seed: u32) -> u32 {
    let mut h = x.wrapping_mul(0x8DA6_B343) ^ y.wrapping_mul(0xD816_3841) ^ seed.wrapping_mul(0xCB1A_B31F);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5BD1_E995);
    h ^ (h >> 15)
}

/// Lattice value in [0, 1).
#[inline]
fn lattice(x: u32, y: u32, seed: u32) -> f32 {
    (hash(x, y, seed) >> 8) as f32 / 16_777_216.0
}

/// Tileable value noise at texel (i, j) of an N×N texture, lattice spacing N/8 texels.
pub fn noise(i: u32, j: u32, n: u32, seed: u32) -> f32 {
    let cell = (n / 8).max(1);
    let cells = (n / cell).max(1);
    let (ix, iy) = (i / cell, j / cell);
    let fx = (i % cell) as f32 / cell as f32;
    let fy = (j % cell) as f32 / cell as f32;
    let s = |t: f32| t * t * (3.0 - 2.0 * t);
    let (sx, sy) = (s(fx), s(fy));
    let (x1, y1) = ((ix + 1) % cells, (iy + 1) % cells);
    let a = lattice(ix, iy, seed);
    let b = lattice(x1, iy, seed);
    let c = lattice(ix, y1, seed);
    let d = lattice(x1, y1, seed);
    let top = a + (b - a) * sx;
    let bot = c + (d - c) * sx;
    top + (bot - top) * sy
}

#[inline]
fn mix(c1: [f32; 3], c2: [f32; 3], m: f32) -> [f32; 3] {
    [0, 1, 2].map(|k| c1[k] * m + c2[k] * (1.0 - m))
}

/// Texel (i, j), both in `0..N`, of the material's texture; `c1` is the material colour.
pub fn texel(ext: &MaterialModel, c1: [f32; 3], i: u32, j: u32) -> [f32; 3] {
    let n = 1u32 << ext.tex_log2.clamp(1, 12);
    let c2 = ext.colour2;
    match ext.texture {
        TextureKind::None => c1,
        TextureKind::Checker => {
            let cells = (ext.tex_param as u32).clamp(1, n);
            let cs = (n / cells).max(1);
            if ((i / cs) + (j / cs)) & 1 == 0 {
                c1
            } else {
                c2
            }
        }
        TextureKind::Xor => {
            let v = ((i * 256 / n) ^ (j * 256 / n)) & 255;
            mix(c1, c2, v as f32 / 255.0)
        }
        TextureKind::Marble => {
            let x = i as f32 / n as f32;
            let m = 0.5 + 0.5 * fmath::sin_turns(4.0 * x + ext.tex_param * noise(i, j, n, ext.tex_seed));
            mix(c1, c2, m)
        }
        TextureKind::Wood => {
            let x = i as f32 / n as f32 - 0.5;
            let y = j as f32 / n as f32 - 0.5;
            let r = libm::sqrtf(x * x + y * y);
            let m = 0.5 + 0.5 * fmath::cos_turns(ext.tex_param * r + 0.5 * noise(i, j, n, ext.tex_seed));
            mix(c1, c2, m * m)
        }
        TextureKind::RgbDots => {
            let cells = (ext.tex_param as u32).clamp(1, n);
            let cs = (n / cells).max(1);
            let (ci, cj) = (i / cs, j / cs);
            // Offsets from the cell centre in half texels.
            let di = (2 * (i - ci * cs) + 1) as i64 - cs as i64;
            let dj = (2 * (j - cj * cs) + 1) as i64 - cs as i64;
            if 100 * (di * di + dj * dj) <= 49 * (cs as i64) * (cs as i64) {
                match (ci + cj) % 3 {
                    0 => [1.0, 0.0, 0.0],
                    1 => [0.0, 1.0, 0.0],
                    _ => [0.0, 0.0, 1.0],
                }
            } else {
                c2
            }
        }
    }
}

/// Texture coordinates (u, v) of the object-space point `p` (before scale and offset).
pub fn map_uv(mapping: Mapping, p: [f32; 3]) -> (f32, f32) {
    let around = || {
        let u = fmath::atan2(p[0], p[2]) / TAU;
        if u < 0.0 {
            u + 1.0
        } else {
            u
        }
    };
    match mapping {
        Mapping::Planar => ((p[0] + 1.0) * 0.5, (p[2] + 1.0) * 0.5),
        Mapping::Cylindrical => (around(), (p[1] + 1.0) * 0.5),
        Mapping::Spherical => {
            let len = libm::sqrtf(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
            let c = if len > 0.0 { (p[1] / len).clamp(-1.0, 1.0) } else { 0.0 };
            (around(), 1.0 - fmath::acos(c) / PI)
        }
    }
}

/// `i mod n` for the power of two `n` (two's complement keeps the low bits: no 64-bit
/// division on the soft-core).
#[inline]
fn wrap(i: i32, n: u32) -> u32 {
    i as u32 & (n - 1)
}

/// The filtered texture colour at object-space point `p`.
pub fn sample(ext: &MaterialModel, c1: [f32; 3], p: [f32; 3]) -> [f32; 3] {
    let (u, v) = map_uv(ext.mapping, p);
    let u = u * ext.uv_scale[0] + ext.uv_offset[0];
    let v = v * ext.uv_scale[1] + ext.uv_offset[1];
    let n = 1u32 << ext.tex_log2.clamp(1, 12);
    let nf = n as f32;
    if !(u.is_finite() && v.is_finite()) {
        return c1;
    }
    // Reduce to [0, 1) first so large coordinates keep their texel precision.
    let (u, v) = (u - libm::floorf(u), v - libm::floorf(v));
    if !ext.bilinear {
        // u, v ∈ [0, 1]: the texel indices are in 0..=n, well inside i32.
        let i = wrap(libm::floorf(u * nf) as i32, n);
        let j = wrap(libm::floorf(v * nf) as i32, n);
        return texel(ext, c1, i, j);
    }
    let x = u * nf - 0.5;
    let y = v * nf - 0.5;
    let (x0, y0) = (libm::floorf(x), libm::floorf(y));
    let (fx, fy) = (x - x0, y - y0);
    let (i0, j0) = (x0 as i32, y0 as i32);
    let t00 = texel(ext, c1, wrap(i0, n), wrap(j0, n));
    let t10 = texel(ext, c1, wrap(i0 + 1, n), wrap(j0, n));
    let t01 = texel(ext, c1, wrap(i0, n), wrap(j0 + 1, n));
    let t11 = texel(ext, c1, wrap(i0 + 1, n), wrap(j0 + 1, n));
    [0, 1, 2].map(|k| {
        let top = t00[k] + (t10[k] - t00[k]) * fx;
        let bot = t01[k] + (t11[k] - t01[k]) * fx;
        top + (bot - top) * fy
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ext(kind: TextureKind) -> MaterialModel {
        MaterialModel { texture: kind, tex_log2: 4, tex_param: 4.0, colour2: [0.0; 3], ..MaterialModel::default() }
    }

    #[test]
    fn checker_alternates_by_cell() {
        let e = ext(TextureKind::Checker);
        // 16 texels, 4 cells → 4 texels per cell.
        assert_eq!(texel(&e, [1.0; 3], 0, 0), [1.0; 3]);
        assert_eq!(texel(&e, [1.0; 3], 4, 0), [0.0; 3]);
        assert_eq!(texel(&e, [1.0; 3], 4, 4), [1.0; 3]);
    }

    #[test]
    fn every_kind_stays_in_range_and_bilinear_is_continuous() {
        for kind in
            [TextureKind::Checker, TextureKind::Xor, TextureKind::Marble, TextureKind::Wood, TextureKind::RgbDots]
        {
            let e = ext(kind);
            for i in 0..16 {
                for j in 0..16 {
                    let c = texel(&e, [1.0; 3], i, j);
                    assert!(c.iter().all(|v| (0.0..=1.0 + 1e-6).contains(v)), "{kind:?} {c:?}");
                }
            }
            // Bilinear: a tiny step in p gives a tiny change in colour.
            let a = sample(&e, [1.0; 3], [0.1234, 0.0, -0.4321]);
            let b = sample(&e, [1.0; 3], [0.1234 + 1e-5, 0.0, -0.4321]);
            assert!((0..3).all(|k| (a[k] - b[k]).abs() < 1e-2), "{kind:?}");
        }
    }

    #[test]
    fn mappings_cover_the_unit_square() {
        assert_eq!(map_uv(Mapping::Planar, [-1.0, 0.0, 1.0]), (0.0, 1.0));
        let (u, v) = map_uv(Mapping::Cylindrical, [1.0, 0.0, 0.0]);
        assert!((u - 0.25).abs() < 1e-6 && (v - 0.5).abs() < 1e-6);
        let (u, v) = map_uv(Mapping::Spherical, [0.0, -1.0, 0.0]);
        assert!(u.abs() < 1e-6 && v.abs() < 1e-6);
        let (u, _) = map_uv(Mapping::Spherical, [-1.0, 0.0, 0.0]);
        assert!((u - 0.75).abs() < 1e-6);
    }
}

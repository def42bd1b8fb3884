//! Procedural textures in f64 (docs/CONTRACTS.md; firmware `texture.rs`): texel (i, j)
//! computed from integers, wrap addressing, bilinear between texel centres, the three
//! mappings, then uv·scale + offset.

use gridrt_shared::scene::{Mapping, MaterialModel, TextureKind};

use super::vec3::dot;

fn hash(x: u32, y: u32, seed: u32) -> u32 {
    let mut h = x.wrapping_mul(0x8DA6_B343) ^ y.wrapping_mul(0xD816_3841) ^ seed.wrapping_mul(0xCB1A_B31F);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5BD1_E995);
    h ^ (h >> 15)
}

fn noise(i: u32, j: u32, n: u32, seed: u32) -> f64 {
    let cell = (n / 8).max(1);
    let cells = (n / cell).max(1);
    let (ix, iy) = (i / cell, j / cell);
    let fx = (i % cell) as f64 / cell as f64;
    let fy = (j % cell) as f64 / cell as f64;
    let s = |t: f64| t * t * (3.0 - 2.0 * t);
    let v = |x: u32, y: u32| (hash(x, y, seed) >> 8) as f64 / 16_777_216.0;
    let (x1, y1) = ((ix + 1) % cells, (iy + 1) % cells);
    let top = v(ix, iy) + (v(x1, iy) - v(ix, iy)) * s(fx);
    let bot = v(ix, y1) + (v(x1, y1) - v(ix, y1)) * s(fx);
    top + (bot - top) * s(fy)
}

fn texel(e: &MaterialModel, c1: [f64; 3], i: u32, j: u32) -> [f64; 3] {
    let n = 1u32 << e.tex_log2.clamp(1, 12);
    let c2 = e.colour2.map(|c| c as f64);
    let mix = |m: f64| [0, 1, 2].map(|k| c1[k] * m + c2[k] * (1.0 - m));
    let tau = std::f64::consts::TAU;
    match e.texture {
        TextureKind::None => c1,
        TextureKind::Checker => {
            let cs = (n / (e.tex_param as u32).clamp(1, n)).max(1);
            if ((i / cs) + (j / cs)).is_multiple_of(2) {
                c1
            } else {
                c2
            }
        }
        TextureKind::Xor => mix((((i * 256 / n) ^ (j * 256 / n)) & 255) as f64 / 255.0),
        TextureKind::Marble => {
            let x = i as f64 / n as f64;
            mix(0.5 + 0.5 * (tau * (4.0 * x + e.tex_param as f64 * noise(i, j, n, e.tex_seed))).sin())
        }
        TextureKind::Wood => {
            let x = i as f64 / n as f64 - 0.5;
            let y = j as f64 / n as f64 - 0.5;
            let m = 0.5
                + 0.5 * (tau * (e.tex_param as f64 * (x * x + y * y).sqrt() + 0.5 * noise(i, j, n, e.tex_seed))).cos();
            mix(m * m)
        }
        TextureKind::RgbDots => {
            let cs = (n / (e.tex_param as u32).clamp(1, n)).max(1);
            let (ci, cj) = (i / cs, j / cs);
            let di = (2 * (i - ci * cs) + 1) as i64 - cs as i64;
            let dj = (2 * (j - cj * cs) + 1) as i64 - cs as i64;
            if 100 * (di * di + dj * dj) <= 49 * (cs as i64) * (cs as i64) {
                let mut c = [0.0; 3];
                c[((ci + cj) % 3) as usize] = 1.0;
                c
            } else {
                c2
            }
        }
    }
}

pub(super) fn texture(e: &MaterialModel, c1: [f64; 3], p: [f64; 3]) -> [f64; 3] {
    let tau = std::f64::consts::TAU;
    let around = || {
        let u = p[0].atan2(p[2]) / tau;
        if u < 0.0 {
            u + 1.0
        } else {
            u
        }
    };
    let (u, v) = match e.mapping {
        Mapping::Planar => ((p[0] + 1.0) * 0.5, (p[2] + 1.0) * 0.5),
        Mapping::Cylindrical => (around(), (p[1] + 1.0) * 0.5),
        Mapping::Spherical => {
            let len = dot(p, p).sqrt();
            let c = if len > 0.0 { (p[1] / len).clamp(-1.0, 1.0) } else { 0.0 };
            (around(), 1.0 - c.acos() / std::f64::consts::PI)
        }
    };
    let u = u * e.uv_scale[0] as f64 + e.uv_offset[0] as f64;
    let v = v * e.uv_scale[1] as f64 + e.uv_offset[1] as f64;
    let (u, v) = (u - u.floor(), v - v.floor());
    let n = 1u32 << e.tex_log2.clamp(1, 12);
    let nf = n as f64;
    let wrap = |i: i64| i.rem_euclid(n as i64) as u32;
    if !e.bilinear {
        return texel(e, c1, wrap((u * nf).floor() as i64), wrap((v * nf).floor() as i64));
    }
    let (x, y) = (u * nf - 0.5, v * nf - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (i0, j0) = (x0 as i64, y0 as i64);
    let t00 = texel(e, c1, wrap(i0), wrap(j0));
    let t10 = texel(e, c1, wrap(i0 + 1), wrap(j0));
    let t01 = texel(e, c1, wrap(i0), wrap(j0 + 1));
    let t11 = texel(e, c1, wrap(i0 + 1), wrap(j0 + 1));
    [0, 1, 2].map(|k| {
        let top = t00[k] + (t10[k] - t00[k]) * fx;
        let bot = t01[k] + (t11[k] - t01[k]) * fx;
        top + (bot - top) * fy
    })
}

// ---------------------------------------------------------------- shading (f64)

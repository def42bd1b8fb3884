//! Point clouds sampled from analytic surfaces with a seeded generator (tests and
//! `gridrt bench splat` make clouds the project has never seen), and a PLY writer for them.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::scene::PlyVertices;

/// `n` points with outward normals on a torus (major radius 1, minor 0.35, around y) and a
/// sphere (radius 0.5) resting in it, in proportion to their areas; uniform on each surface.
pub fn torus_and_sphere(n: usize, seed: u64) -> PlyVertices {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (big, small, ball) = (1.0f64, 0.35f64, 0.5f64);
    let torus_area = 4.0 * std::f64::consts::PI.powi(2) * big * small;
    let sphere_area = 4.0 * std::f64::consts::PI * ball * ball;
    let n_torus = (n as f64 * torus_area / (torus_area + sphere_area)).round() as usize;
    let mut v = PlyVertices { normal: Some(Vec::with_capacity(n)), ..PlyVertices::default() };
    let tau = std::f64::consts::TAU;
    let mut i = 0;
    while i < n {
        let (p, nrm) = if i < n_torus {
            // Rejection sampling makes the torus uniform in area (the outer side is larger).
            let (u, w) = (rng.gen::<f64>() * tau, rng.gen::<f64>() * tau);
            if rng.gen::<f64>() * (big + small) > big + small * w.cos() {
                continue;
            }
            let (c, s) = (w.cos(), w.sin());
            ([(big + small * c) * u.cos(), small * s, (big + small * c) * u.sin()], [c * u.cos(), s, c * u.sin()])
        } else {
            let (z, t) = (rng.gen_range(-1.0..1.0f64), rng.gen::<f64>() * tau);
            let r = (1.0 - z * z).sqrt();
            let nrm = [r * t.cos(), z, r * t.sin()];
            ([ball * nrm[0], ball * nrm[1] + 0.2, ball * nrm[2]], nrm)
        };
        v.pos.push(p.map(|c| c as f32));
        if let Some(ns) = v.normal.as_mut() {
            ns.push(nrm.map(|c| c as f32));
        }
        i += 1;
    }
    v
}

/// Writes vertices (positions, and normals, radii and colours where present) as a PLY file
/// with no faces: ASCII, or binary little endian with float properties (uchar colours).
pub fn write_ply(v: &PlyVertices, binary: bool) -> Vec<u8> {
    let mut head = format!(
        "ply\nformat {} 1.0\ncomment gridrt synthetic cloud\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        if binary { "binary_little_endian" } else { "ascii" },
        v.pos.len()
    );
    if v.normal.is_some() {
        head += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    if v.radius.is_some() {
        head += "property float radius\n";
    }
    if v.colour.is_some() {
        head += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    }
    head += "end_header\n";
    let mut out = head.into_bytes();
    for i in 0..v.pos.len() {
        let mut floats: Vec<f32> = v.pos[i].to_vec();
        if let Some(n) = &v.normal {
            floats.extend_from_slice(&n[i]);
        }
        if let Some(r) = &v.radius {
            floats.push(r[i]);
        }
        let rgb = v.colour.as_ref().map(|c| c[i].map(|x| (x.clamp(0.0, 1.0) * 255.0).round() as u8));
        if binary {
            for f in floats {
                out.extend_from_slice(&f.to_le_bytes());
            }
            if let Some(c) = rgb {
                out.extend_from_slice(&c);
            }
        } else {
            let mut line: Vec<String> = floats.iter().map(|f| format!("{f:?}")).collect();
            if let Some(c) = rgb {
                line.extend(c.iter().map(|b| b.to_string()));
            }
            out.extend_from_slice(line.join(" ").as_bytes());
            out.push(b'\n');
        }
    }
    out
}

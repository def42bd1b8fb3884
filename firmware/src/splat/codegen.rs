//! The code generator: the DSP's role in the point-splatting design. Per frame it transforms every point
//! into the camera's frame, looks up the shape table with its quantised screen radius and
//! view-space normal, composes the 64-bit codeword of each 8×8 tile (template | diffuse |
//! specular | material | X | Z), and files it in a bucket keyed by the tile's top row. Then it
//! streams the material table, the ambient term and the buckets top to bottom with `shift`
//! commands between them (SPEC.md §6.3).
//!
//! Depth is `D = (1/z − 1/z_near) / (1/z_far − 1/z_near) · 65534`, with z the view depth and
//! [z_near, z_far] the view depths of the cloud's box: linear in screen space for a plane, so
//! the per-pixel mode's depth word is exact across a splat. The seed's 9-bit Z is `D >> 7`.

// `!(x > y)` is how this file rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::table::{template_bits, ShapeTable, TILE_EMPTY};
use gridrt_shared::math::Vec3;
use gridrt_shared::splat::{Command, DepthWord, MaterialTerm, MAX_PIXEL_DEPTH, MAX_TERM};

/// One point as the device keeps it.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SplatPoint {
    /// Centre.
    pub pos: Vec3,
    /// Unit normal.
    pub normal: Vec3,
    /// Disk radius.
    pub radius: f32,
    /// Material index (< 128).
    pub material: u8,
}

/// The light as the code generator needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SplatLight {
    /// Position.
    pub pos: Vec3,
    /// False: D = S = 0 (no light, or a black one).
    pub on: bool,
    /// Inverse-square falloff.
    pub inverse_square: bool,
    /// Spotlight axis (unit) and cosines, `None` for an omnidirectional light.
    pub spot: Option<(Vec3, f32, f32)>,
}

/// Per-frame view: camera basis, pixel mapping, depth range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct View {
    /// Eye.
    pub eye: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit right vector.
    pub right: Vec3,
    /// Unit vector down the image (−camera up).
    pub down: Vec3,
    /// Focal length in pixels, `H / (2·tan(fov/2))`.
    pub focal: f32,
    /// Pixel coordinates of the optical axis (W/2, H/2): pixel i's centre is i + 0.5.
    pub centre: (f32, f32),
    /// 1/z_near and 1/z_far.
    pub inv_near: f32,
    /// 1/z_far.
    pub inv_far: f32,
    /// Points nearer than this view depth are culled.
    pub clip: f32,
    /// Emit a depth word after every codeword.
    pub pixel_depth: bool,
    /// Key the table as the seed does: the view-space normal in the camera's frame and the
    /// radius scaled by 1/z (orthographic at every splat). Off (the device's default): the
    /// ellipse of the disk under the perspective projection's local affine map (its Jacobian
    /// at the centre), re-expressed as the (radius, normal) of the table's family.
    pub seed_affine: bool,
}

impl View {
    /// The view of a camera (eye, unit forward/right/up, focal length, image size) over a
    /// cloud whose box is `bounds`; `None` when the box lies wholly behind the eye.
    pub fn new(eye: Vec3, basis: [Vec3; 3], focal: f32, size: (u16, u16), bounds: [Vec3; 2]) -> Option<Self> {
        let [forward, right, up] = basis;
        let (mut near, mut far) = (f32::INFINITY, 0.0f32);
        for i in 0..8u32 {
            let c = Vec3::new(
                if i & 1 == 0 { bounds[0].x } else { bounds[1].x },
                if i & 2 == 0 { bounds[0].y } else { bounds[1].y },
                if i & 4 == 0 { bounds[0].z } else { bounds[1].z },
            );
            let z = (c - eye).dot(forward);
            near = near.min(z);
            far = far.max(z);
        }
        if !(far > 0.0) || !far.is_finite() {
            return None;
        }
        // A camera inside the box: depth resolution from a thousandth of the far depth on.
        let clip = far * 1e-3;
        let near = near.max(clip);
        let far = if far > near { far } else { near * 2.0 };
        Some(Self {
            eye,
            forward,
            right,
            down: -up,
            focal,
            centre: (size.0 as f32 * 0.5, size.1 as f32 * 0.5),
            inv_near: 1.0 / near,
            inv_far: 1.0 / far,
            clip,
            pixel_depth: false,
            seed_affine: false,
        })
    }
}

/// The rectangle a pass renders: `columns` ≤ 504 columns from `x0`, `rows` rows from `y0`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pass {
    /// First column.
    pub x0: u16,
    /// First row.
    pub y0: u16,
    /// Columns, 1..=504.
    pub columns: u16,
    /// Rows.
    pub rows: u16,
}

impl Pass {
    /// Buckets (stripe lines) of the pass: 7 lines above the first row, then the rows.
    pub fn lines(&self) -> u32 {
        self.rows as u32 + 7
    }
}

/// Counters of one pass.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CodegenStats {
    /// Points transformed.
    pub points: u64,
    /// Points culled.
    pub culled: u64,
    /// Points whose radius was clamped to the table's largest.
    pub clamped: u64,
    /// Splat codewords emitted.
    pub codewords: u64,
    /// Command and load words emitted.
    pub commands: u64,
}

/// A point filed in a bucket: the codeword fields but the template and X, and the tile row
/// it is at.
#[derive(Debug, Clone, Copy, Default)]
struct Node {
    /// Diffuse, specular, material, Z bits.
    fields: u64,
    /// Template index of tile (0, tj).
    first: u32,
    /// X of tile column 0 (may be off the tile for a cascade's first column).
    x0: i32,
    /// Depth at tile (0, tj)'s centre in 1/16 units, and per-pixel slopes in 1/16 units.
    z16: i32,
    dzdx: i16,
    dzdy: i16,
    next: u32,
    k: u8,
    tj: u8,
}

const NONE: u32 = u32::MAX;

/// Largest pass height + 7 the buckets hold.
pub const MAX_LINES: usize = 4096 + 8;

/// Bucket storage for up to `P` points.
pub struct Buckets<const P: usize> {
    nodes: heapless::Vec<Node, P>,
    heads: [u32; MAX_LINES],
}

impl<const P: usize> Buckets<P> {
    /// Empty buckets.
    pub const fn new() -> Self {
        Self { nodes: heapless::Vec::new(), heads: [NONE; MAX_LINES] }
    }
}

impl<const P: usize> Default for Buckets<P> {
    fn default() -> Self {
        Self::new()
    }
}

/// The 7-bit term of a value in [0, 1].
#[inline]
fn term(v: f32) -> u8 {
    let t = v * MAX_TERM as f32 + 0.5;
    if t >= MAX_TERM as f32 {
        MAX_TERM
    } else if t > 0.0 {
        t as u8
    } else {
        0
    }
}

/// Diffuse and specular terms of a splat at `p` with facing unit normal `n` (point splatting:
/// n_s = 1), the light's falloff and spot factor included.
#[inline]
fn light_terms(light: &SplatLight, eye: Vec3, p: Vec3, n: Vec3) -> (u8, u8) {
    if !light.on {
        return (0, 0);
    }
    let d = light.pos - p;
    let r2 = d.length_squared();
    let Some(l) = d.try_normalize() else { return (0, 0) };
    let cos = n.dot(l);
    if !(cos > 0.0) {
        return (0, 0);
    }
    let mut f = if light.inverse_square { 1.0 / r2 } else { 1.0 };
    if let Some((axis, co, ci)) = light.spot {
        let c = axis.dot(-l);
        f *= if ci > co {
            ((c - co) / (ci - co)).clamp(0.0, 1.0)
        } else if c >= co {
            1.0
        } else {
            0.0
        };
    }
    let v = (eye - p).try_normalize().unwrap_or(n);
    let r = n * (2.0 * cos) - l;
    (term(cos * f), term(r.dot(v).max(0.0) * f))
}

/// The table key (radius in pixels, nx, ny) of the ellipse that a disk with view-space unit
/// normal `n` at view position `v` (x right, y down, z depth) and radius `r` pixels-at-depth
/// projects to under the local affine map of the perspective projection, `J = [I | −v.xy/z]`
/// (times f/z, already in `r`). The table's ellipses have semi-axes r and r·|nz| with the
/// minor axis along (nx, ny); any centred ellipse is one of them.
#[inline]
fn local_affine_key(n: Vec3, v: Vec3, r: f32) -> (f32, f32, f32) {
    let a = if n.x.abs() < 0.6 { Vec3::X } else { Vec3::Y };
    let Some(t1) = n.cross(a).try_normalize() else { return (r, 0.0, 0.0) };
    let t2 = n.cross(t1);
    let (wx, wy) = (v.x / v.z, v.y / v.z);
    let j = |t: Vec3| (r * (t.x - wx * t.z), r * (t.y - wy * t.z));
    let (e1, e2) = (j(t1), j(t2));
    let (m00, m01, m11) = (e1.0 * e1.0 + e2.0 * e2.0, e1.0 * e1.1 + e2.0 * e2.1, e1.1 * e1.1 + e2.1 * e2.1);
    let half = 0.5 * (m00 + m11);
    let disc = libm::sqrtf(0.25 * (m00 - m11) * (m00 - m11) + m01 * m01);
    let (l1, l2) = (half + disc, (half - disc).max(0.0));
    let major = libm::sqrtf(l1);
    if !(major > 0.0) {
        return (0.0, 0.0, 0.0);
    }
    // Major axis direction; the normal's screen part lies along the minor axis.
    let (ux, uy) = if m01.abs() > 1e-12 * l1 {
        let (x, y) = (l1 - m11, m01);
        let l = libm::sqrtf(x * x + y * y);
        (x / l, y / l)
    } else if m00 >= m11 {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let ratio = (libm::sqrtf(l2) / major).min(1.0);
    let s = libm::sqrtf(1.0 - ratio * ratio);
    (major, -uy * s, ux * s)
}

/// Files every point of `points` that can touch `pass` in its bucket. `materials` maps a
/// point's material to the 7-bit index the stage's table uses (identity when shorter).
pub fn file_points<const P: usize, const T: usize>(
    points: &[SplatPoint],
    table: &ShapeTable<T>,
    view: &View,
    light: &SplatLight,
    pass: &Pass,
    buckets: &mut Buckets<P>,
    stats: &mut CodegenStats,
) {
    let lines = (pass.lines() as usize).min(MAX_LINES);
    buckets.heads.iter_mut().take(lines).for_each(|h| *h = NONE);
    buckets.nodes.clear();
    let scale = MAX_PIXEL_DEPTH as f32 / (view.inv_far - view.inv_near);
    let (tx, ty) = (pass.x0 as i32, pass.y0 as i32 - 7);
    let (cols, rows) = (pass.columns as i32, pass.rows as i32);
    for p in points {
        stats.points += 1;
        let d = p.pos - view.eye;
        let z = d.dot(view.forward);
        if !(z > view.clip) {
            stats.culled += 1;
            continue;
        }
        let inv = 1.0 / z;
        let px = view.centre.0 + view.focal * d.dot(view.right) * inv;
        let py = view.centre.1 + view.focal * d.dot(view.down) * inv;
        let (nx, ny) = (p.normal.dot(view.right), p.normal.dot(view.down));
        let (r_px, kx_n, ky_n) = if view.seed_affine {
            (p.radius * view.focal * inv, nx, ny)
        } else {
            let v = Vec3::new(d.dot(view.right), d.dot(view.down), z);
            local_affine_key(Vec3::new(nx, ny, p.normal.dot(view.forward)), v, p.radius * view.focal * inv)
        };
        let (s, clamped) = table.size_bin(r_px);
        if s == 0 || !(px.abs() < 1e6 && py.abs() < 1e6) {
            stats.culled += 1;
            continue;
        }
        let e = table.entry(s, table.normal_bin(kx_n), table.normal_bin(ky_n));
        let k = e.k as i32;
        // Box centre on the pixel corner nearest the projected centre.
        let (kx, ky) = (libm::floorf(px + 0.5) as i32, libm::floorf(py + 0.5) as i32);
        let (left, top) = (kx - 4 * k, ky - 4 * k);
        let (x_rel, b0) = (left - tx, top - ty);
        // Tile rows whose bucket is ≥ 0 and < lines; boxes off the pass are culled.
        let tj0 = if b0 < 0 { (-b0 + 7) / 8 } else { 0 };
        if x_rel + 8 * k <= 0 || x_rel >= cols || tj0 >= k || b0 + 8 * tj0 >= rows + 7 {
            stats.culled += 1;
            continue;
        }
        if clamped {
            stats.clamped += 1;
        }
        let n = if p.normal.dot(d) > 0.0 { -p.normal } else { p.normal };
        let (diffuse, specular) = light_terms(light, view.eye, p.pos, n);
        // Depth at the box centre (the corner), and its screen slopes (1/z is linear there).
        let nd = p.normal.dot(d);
        let (gx, gy) = if nd.abs() > 1e-20 { (nx / (view.focal * nd), ny / (view.focal * nd)) } else { (0.0, 0.0) };
        let inv_k = inv + gx * (kx as f32 - px) + gy * (ky as f32 - py);
        let dval = ((inv_k - view.inv_near) * scale).clamp(0.0, MAX_PIXEL_DEPTH as f32);
        let z16 =
            if view.pixel_depth { dval } else { ((inv - view.inv_near) * scale).clamp(0.0, MAX_PIXEL_DEPTH as f32) };
        let z9 = (z16 as u32 >> 7) as u64;
        let slope = |g: f32| (g * scale * 16.0).clamp(i16::MIN as f32, i16::MAX as f32) as i16;
        let (dzdx, dzdy) = (slope(gx), slope(gy));
        // Tile (0, tj0)'s centre: 4 − 4k + 8·tj0 rows below the corner, 4 − 4k columns right.
        let off = |g: i16, o: i32| (g as i32) * o;
        let z16_tile = (dval * 16.0) as i32 + off(dzdx, 4 - 4 * k) + off(dzdy, 4 - 4 * k + 8 * tj0);
        let fields = (diffuse as u64) << 32 | (specular as u64) << 25 | ((p.material & 0x7F) as u64) << 18 | z9;
        let bucket = (b0 + 8 * tj0) as usize;
        let node = Node {
            fields,
            first: e.first + (tj0 as u32) * e.k,
            x0: x_rel + 8,
            z16: z16_tile,
            dzdx,
            dzdy,
            next: buckets.heads.get(bucket).copied().unwrap_or(NONE),
            k: k as u8,
            tj: tj0 as u8,
        };
        let idx = buckets.nodes.len() as u32;
        if buckets.nodes.push(node).is_ok() {
            if let Some(h) = buckets.heads.get_mut(bucket) {
                *h = idx;
            }
        }
    }
}

/// Streams the pass: material table, ambient, then the buckets top to bottom, and a final
/// shift that finishes the last line. `emit` is the stage's input (the design's DMA).
#[allow(clippy::too_many_arguments)]
pub fn stream<const P: usize, const T: usize, E>(
    table: &ShapeTable<T>,
    materials: &[[MaterialTerm; 3]],
    ambient: u8,
    pass: &Pass,
    pixel_depth: bool,
    buckets: &mut Buckets<P>,
    stats: &mut CodegenStats,
    emit: &mut impl FnMut(u64) -> Result<(), E>,
) -> Result<(), E> {
    let cmd = |w: u64, stats: &mut CodegenStats, emit: &mut dyn FnMut(u64) -> Result<(), E>| {
        stats.commands += 1;
        emit(w)
    };
    cmd(Command::StartLoad.pack(), stats, emit)?;
    for m in materials.iter().take(128) {
        for t in m {
            cmd(t.pack(), stats, emit)?;
        }
    }
    cmd(Command::EndLoad.pack(), stats, emit)?;
    cmd(Command::Ambient(ambient).pack(), stats, emit)?;
    let lines = (pass.lines() as usize).min(MAX_LINES);
    let max_x = pass.columns as i32 + 7;
    let mut top = 0usize;
    for b in 0..lines {
        let mut i = buckets.heads.get(b).copied().unwrap_or(NONE);
        if i == NONE {
            continue;
        }
        if b > top {
            cmd(Command::Shift((b - top) as u16).pack(), stats, emit)?;
            top = b;
        }
        while let Some(node) = buckets.nodes.get(i as usize).copied() {
            let next = node.next;
            let k = node.k as u32;
            for ti in 0..k {
                let tpl = table.template(node.first + ti);
                let x = node.x0 + 8 * ti as i32;
                if tpl & TILE_EMPTY != 0 || x < 1 || x > max_x {
                    continue;
                }
                stats.codewords += 1;
                emit(template_bits(tpl) | node.fields | (x as u64) << 9)?;
                if pixel_depth {
                    let z = (node.z16 + node.dzdx as i32 * 8 * ti as i32) >> 4;
                    let d =
                        DepthWord { z: z.clamp(0, MAX_PIXEL_DEPTH as i32) as u16, dzdx: node.dzdx, dzdy: node.dzdy };
                    emit(d.pack())?;
                }
            }
            // The cascade's next tile row goes to the bucket 8 lines down.
            let nb = b + 8;
            if (node.tj as u32) + 1 < k && nb < lines {
                if let Some(n) = buckets.nodes.get_mut(i as usize) {
                    n.tj += 1;
                    n.first += k;
                    n.z16 += n.dzdy as i32 * 8;
                    if let Some(h) = buckets.heads.get_mut(nb) {
                        n.next = *h;
                        *h = i;
                    }
                }
            }
            i = next;
        }
    }
    if lines > top {
        cmd(Command::Shift((lines - top) as u16).pack(), stats, emit)?;
    }
    Ok(())
}

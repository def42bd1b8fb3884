//! Screen-space culling of primary rays: per image row, the columns whose camera rays can
//! enter the grid box ([`BoxSpans`]). Every other pixel's ray misses the box, so its list is
//! empty and its colour is the background: the device sends those pixels as background runs
//! without generating or walking their rays (the image is the same).
//!
//! The bound is conservative. Per frame the 8 corners of the box, grown by 2⁻¹⁶ of its size
//! plus the eye's distance, are projected into pixel coordinates (`Camera`'s own basis, one
//! projection each); a ray from the eye enters the box only through the convex hull of the
//! projected corners, and that hull's extent on a row is the extent of the 28 corner-to-corner
//! segments on it. Rows are taken as bands ±1/8 pixel around the pixel centre, and the
//! columns are widened by [`MARGIN_PX`] pixels each way, which covers the f32
//! rounding of the projection, the fixed-point evaluation below and the slab test's own
//! widening by orders of magnitude (pinned by `pixels_outside_the_spans_miss_the_box`).
//! When a corner lies behind or near the eye plane, or projects more than 2²⁰ pixels away, the
//! spans are the whole rows (no culling).
//!
//! Per frame: 8 projections and 28 slopes in f32. Per row: integer arithmetic only
//! (Q8 pixel coordinates, Q16 slopes, 64-bit products), so a soft-float core pays a few
//! hundred instructions per row, not per pixel.

use crate::camera::Camera;
use gridrt_shared::math::{Aabb, Vec3};

/// Columns added on each side of a row's span.
pub const MARGIN_PX: i32 = 2;

/// Fractional bits of the projected coordinates.
const Q: u32 = 8;
/// Fractional bits of the segment slopes.
const QS: u32 = 16;
/// Largest projected coordinate accepted, in pixels.
const FAR_PX: f32 = (1u32 << 20) as f32;
/// Most consecutive non-empty cells of a grid row that [`OccupancyMask::new`] projects as one
/// box.
const MASK_RUN: usize = 16;
/// Corner pairs.
const SEGMENTS: usize = 28;
/// Half height of a row's band, Q8: 1/8 pixel, far above the projection's rounding
/// (≈ 10⁻² pixel) and the Q8 quantisation, so that a hull edge steeper than a row is met
/// wherever rounding puts it.
const BAND: i32 = 1 << (Q - 3);

/// One corner-to-corner segment in Q8 pixel coordinates, its lower end first.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
struct Segment {
    y0: i32,
    y1: i32,
    x0: i32,
    /// dx/dy in Q16 (0 for a horizontal segment, whose ends are both taken).
    slope: i64,
    x1: i32,
}

/// Per frame: which columns of each row can see the grid box (module doc).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BoxSpans {
    /// False: no culling, every span is the whole row.
    active: bool,
    /// Q8 row band of the projected box (rows outside it see nothing).
    y_min: i32,
    y_max: i32,
    segments: [Segment; SEGMENTS],
}

impl BoxSpans {
    /// Spans that cull nothing.
    pub fn whole_rows() -> Self {
        Self { active: false, y_min: 0, y_max: 0, segments: [Segment::default(); SEGMENTS] }
    }

    /// The spans of `cam` for the box `bounds`.
    pub fn new(cam: &Camera, bounds: &Aabb) -> Self {
        let mut s = Self::whole_rows();
        let (half_w, half_h, w, h) = cam.screen();
        let (eye, f, r, u) = (cam.eye(), cam.forward(), cam.right(), cam.up());
        // Grown by 2^-16 of the box size plus the eye's distance: far above the slab test's
        // relative widening of t (≈ 3.6·10⁻⁷) and the f32 rounding of ray points.
        let size = (bounds.max - bounds.min).max_element();
        let grow = (size + (bounds.center() - eye).length()) * (1.0 / 65536.0);
        let (lo, hi) = (bounds.min - Vec3::splat(grow), bounds.max + Vec3::splat(grow));
        let mut pts = [(0i32, 0i32); 8];
        for (i, p) in pts.iter_mut().enumerate() {
            let c = Vec3::new(
                if i & 1 == 0 { lo.x } else { hi.x },
                if i & 2 == 0 { lo.y } else { hi.y },
                if i & 4 == 0 { lo.z } else { hi.z },
            );
            let rel = c - eye;
            let zc = rel.dot(f);
            // In front of the eye by more than a relative 2^-10 of the distance: the
            // projection is well conditioned.
            let in_front = zc > rel.length() * (1.0 / 1024.0);
            if !in_front {
                return s;
            }
            let (sx, sy) = (rel.dot(r) / zc, rel.dot(u) / zc);
            // Pixel coordinates of the point: x + 0.5 = (sx/half_w + 1)·W/2, y + 0.5 =
            // (1 − sy/half_h)·H/2 (the inverse of the camera's pixel → screen map).
            let px = (sx / half_w + 1.0) * (w * 0.5) - 0.5;
            let py = (1.0 - sy / half_h) * (h * 0.5) - 0.5;
            let near = px.abs() < FAR_PX && py.abs() < FAR_PX;
            if !near {
                return s;
            }
            let q = (1u32 << Q) as f32;
            *p = ((px * q) as i32, (py * q) as i32);
        }
        let mut k = 0;
        for i in 0..8 {
            for j in i + 1..8 {
                let (a, b) = if pts[i].1 <= pts[j].1 { (pts[i], pts[j]) } else { (pts[j], pts[i]) };
                let dy = b.1 - a.1;
                let slope = if dy == 0 { 0 } else { (i64::from(b.0 - a.0) << QS) / i64::from(dy) };
                if let Some(seg) = s.segments.get_mut(k) {
                    *seg = Segment { y0: a.1, y1: b.1, x0: a.0, slope, x1: b.0 };
                }
                k += 1;
            }
        }
        s.y_min = pts.iter().map(|p| p.1).min().unwrap_or(0);
        s.y_max = pts.iter().map(|p| p.1).max().unwrap_or(0);
        s.active = true;
        s
    }

    /// Whether these spans cull anything.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// The columns `[lo, hi)` of row `y` whose rays may enter the box, within `[0, width)`;
    /// `lo == hi` when none can.
    pub fn row(&self, y: u16, width: u16) -> (u16, u16) {
        if !self.active {
            return (0, width);
        }
        let one = 1i32 << Q;
        let (band_lo, band_hi) = ((i32::from(y) << Q) - BAND, (i32::from(y) << Q) + BAND);
        if band_hi < self.y_min || band_lo > self.y_max {
            return (0, 0);
        }
        let (mut x_min, mut x_max) = (i32::MAX, i32::MIN);
        for s in &self.segments {
            let (ya, yb) = (band_lo.max(s.y0), band_hi.min(s.y1));
            if ya > yb {
                continue;
            }
            let (xa, xb) = if s.y0 == s.y1 {
                (s.x0, s.x1)
            } else {
                let at = |y: i32| s.x0 + ((i64::from(y - s.y0) * s.slope) >> QS) as i32;
                (at(ya), at(yb))
            };
            x_min = x_min.min(xa).min(xb);
            x_max = x_max.max(xa).max(xb);
        }
        if x_min > x_max {
            return (0, 0);
        }
        // Floor/ceiling to whole pixels, then the margin.
        let lo = (x_min >> Q) - MARGIN_PX;
        let hi = ((x_max + one - 1) >> Q) + MARGIN_PX + 1;
        let clamp = |v: i32| v.clamp(0, i32::from(width)) as u16;
        (clamp(lo), clamp(hi))
    }
}

/// Pixels added on each side of a cell's projection in an [`OccupancyMask`].
const MASK_MARGIN_PX: f32 = 0.25;

/// Tiles of an [`OccupancyMask`] per image axis: 128, so that a 320×240 frame has tiles
/// of 3×2 pixels (a tile's slack is paid as empty walks).
const TILES: u32 = 128;
/// Words of a mask row.
const ROW_WORDS: usize = TILES as usize / 32;

/// Per frame, a conservative screen mask of the grid cells that hold primitives: the image
/// cut into 128 × 128 tiles, a tile set when a camera ray through a pixel of it may pass within
/// 2⁻¹⁶·(box size + eye distance) of a non-empty cell. A camera ray of a pixel in a clear
/// tile meets only empty cells, so its walk lists nothing: its pixel is the background,
/// without a ray or a walk (the image and the counters are the walk's).
///
/// Per non-empty cell one projection of its centre and a bound on the projection of the
/// cell grown by the growth, half extents `h`: a point `c + δ`, `|δᵢ| ≤ hᵢ`, has
/// `|δ·r| ≤ Hr = Σ hᵢ|rᵢ|` (and `Hu`, `Hf` for the other camera axes), so in front of the eye
/// by `z > Hf` it projects within `(Hr + |sx|·Hf)/(z − Hf)` of the centre's screen coordinate
/// `sx` (the same with `Hu` and `sy`): `x − s = (δ·r − s·δ·f)/(z + δ·f)`. Widened by
/// [`MASK_MARGIN_PX`] and 2⁻¹⁶ of the coordinate: the f32 rounding of this projection and
/// of the camera's rays is a few 2⁻²⁴ of the coordinates plus the image size (below 0.02
/// pixel for 65 535 columns). The walk's own rounding (a few 2⁻²⁴ of
/// the eye's distance plus the box size) is far below the growth. A cell within `2·Hf` of the
/// eye plane, or projecting more than 2²⁰ pixels away, sets every tile (no culling).
/// Pinned by `pixels_in_clear_tiles_meet_only_empty_cells`.
#[derive(Debug, Clone)]
pub struct OccupancyMask {
    /// False: every tile may hit.
    active: bool,
    /// Pixels per tile on each axis.
    tile_w: u32,
    tile_h: u32,
    /// Row `ty`, bit `tx % 32` of word `tx / 32`.
    rows: [[u32; ROW_WORDS]; TILES as usize],
}

impl OccupancyMask {
    /// The mask that culls nothing.
    pub fn everything() -> Self {
        Self { active: false, tile_w: 1, tile_h: 1, rows: [[u32::MAX; ROW_WORDS]; TILES as usize] }
    }

    /// The mask of `cam`'s frame for the cells of `grid` whose entry in `voxel_pe` is not
    /// `EMPTY_VOXEL` (ids past the map's end are empty).
    // Once per frame: out of line.
    #[inline(never)]
    pub fn new(cam: &Camera, grid: &crate::dda::GridDesc, voxel_pe: &[u8]) -> Self {
        let every = Self::everything();
        if !grid.is_valid() {
            return every;
        }
        let (half_w, half_h, w, h) = cam.screen();
        let (eye, f, r, u) = (cam.eye(), cam.forward(), cam.right(), cam.up());
        let bounds = grid.aabb();
        let extent = bounds.max - bounds.min;
        let [nx, ny, nz] = grid.dims;
        let cell = extent / Vec3::new(nx as f32, ny as f32, nz as f32);
        let grow = (extent.max_element() + (bounds.center() - eye).length()) * (1.0 / 65536.0);
        // The grown box's half extents dotted with |r|, |u|, |f| (rounded up by far more than
        // their f32 rounding), per run length. Up to MASK_RUN consecutive non-empty cells of a row along x are one box: a box's
        // bound below holds for any half extents, so the mask stays safe; it is looser, and
        // it costs one projection per run instead of one per cell.
        let up = 1.0 + 1.0 / 4096.0;
        let halves: [(f32, f32, f32); MASK_RUN] = core::array::from_fn(|i| {
            let half = cell * Vec3::new((i + 1) as f32 * 0.5, 0.5, 0.5) + Vec3::splat(grow);
            (half.dot(r.abs()) * up, half.dot(u.abs()) * up, half.dot(f.abs()) * up)
        });
        let (tile_w, tile_h) = ((w as u32).div_ceil(TILES).max(1), (h as u32).div_ceil(TILES).max(1));
        let mut mask = Self { active: true, tile_w, tile_h, rows: [[0; ROW_WORDS]; TILES as usize] };
        let (sx_px, sy_px) = (w * 0.5 / half_w, h * 0.5 / half_h);
        let filled = |i: usize| voxel_pe.get(i).map(|&pe| pe != gridrt_shared::scene::EMPTY_VOXEL);
        // Voxel ids stay below 255³: the index arithmetic cannot overflow.
        let (nx, ny, nz) = (nx as usize, ny as usize, nz as usize);
        for z in 0..nz {
            for y in 0..ny {
                let base = (z * ny + y) * nx;
                let mut x = 0;
                while x < nx {
                    // Ids past the map's end are empty: no cell after them has primitives.
                    let Some(here) = filled(base + x) else { return mask };
                    if !here {
                        x += 1;
                        continue;
                    }
                    let mut k = 1;
                    while k < MASK_RUN && x + k < nx && filled(base + x + k) == Some(true) {
                        k += 1;
                    }
                    let (hr, hu, hf) = halves[k - 1];
                    let centre =
                        bounds.min + cell * Vec3::new(x as f32 + k as f32 * 0.5, y as f32 + 0.5, z as f32 + 0.5);
                    x += k;
                    let rel = centre - eye;
                    let zc = rel.dot(f);
                    let in_front = zc > 2.0 * hf;
                    if !in_front {
                        return every;
                    }
                    let (sx, sy) = (rel.dot(r) / zc, rel.dot(u) / zc);
                    let (rx, ry) = ((hr + sx.abs() * hf) / (zc - hf), (hu + sy.abs() * hf) / (zc - hf));
                    let (px, py) = ((sx / half_w + 1.0) * (w * 0.5) - 0.5, (1.0 - sy / half_h) * (h * 0.5) - 0.5);
                    let (dx, dy) = (rx * sx_px, ry * sy_px);
                    let near = px.abs() + dx < FAR_PX && py.abs() + dy < FAR_PX;
                    if !near {
                        return every;
                    }
                    let margin = |p: f32, d: f32| MASK_MARGIN_PX + (p.abs() + d) * (1.0 / 65536.0);
                    let (mx, my) = (dx + margin(px, dx), dy + margin(py, dy));
                    let tile = |v: f32, size: u32| ((v.max(0.0) as u32) / size).min(TILES - 1);
                    let (tx0, tx1) = (tile(px - mx, tile_w), tile(px + mx, tile_w));
                    let (ty0, ty1) = (tile(py - my, tile_h), tile(py + my, tile_h));
                    // Bits tx0 ..= tx1 (tx1 < TILES), word by word.
                    let mut bits = [0u32; ROW_WORDS];
                    for (i, word) in bits.iter_mut().enumerate() {
                        let (lo, hi) = (32 * i as u32, 32 * i as u32 + 31);
                        if tx0 <= hi && tx1 >= lo {
                            let (a, b) = (tx0.max(lo) - lo, tx1.min(hi) - lo);
                            *word = (u32::MAX >> (31 - b)) & (u32::MAX << a);
                        }
                    }
                    for row in mask.rows.iter_mut().take(ty1 as usize + 1).skip(ty0 as usize) {
                        for (r, b) in row.iter_mut().zip(bits) {
                            *r |= b;
                        }
                    }
                }
            }
        }
        mask
    }

    /// Whether these masks cull anything.
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// The camera ray of pixel (x, y) may meet a cell with primitives.
    #[inline]
    pub fn may_hit(&self, x: u16, y: u16) -> bool {
        let (tx, ty) = ((u32::from(x) / self.tile_w).min(TILES - 1), (u32::from(y) / self.tile_h).min(TILES - 1));
        let word = self.rows.get(ty as usize).and_then(|row| row.get(tx as usize / 32));
        word.is_none_or(|w| w >> (tx % 32) & 1 != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dda::{GridDesc, VoxelMap, WalkGrid};
    use gridrt_shared::math::Ray;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Every pixel in a clear tile of the occupancy mask has a camera ray whose walk lists
    /// nothing, over random grids with random empty cells and random cameras (eyes close to
    /// the box included); and the mask clears most of the pixels whose rays meet only empty
    /// cells.
    #[test]
    fn pixels_in_clear_tiles_meet_only_empty_cells() {
        use gridrt_shared::scene::EMPTY_VOXEL;
        let mut rng = ChaCha8Rng::seed_from_u64(0x00CC_0001);
        let (mut active, mut cleared, mut empty_walks) = (0, 0u64, 0u64);
        for round in 0..300 {
            let v = |rng: &mut ChaCha8Rng, s: f32| {
                Vec3::new(rng.gen_range(-s..s), rng.gen_range(-s..s), rng.gen_range(-s..s))
            };
            let min = v(&mut rng, 4.0);
            let dims = [rng.gen_range(1..12), rng.gen_range(1..12), rng.gen_range(1..12)];
            let grid = GridDesc { min, max: min + v(&mut rng, 3.0).abs() + Vec3::splat(0.05), dims };
            let cells = (dims[0] * dims[1] * dims[2]) as usize;
            let fill = rng.gen_range(0.0..0.5f64);
            let mut map: Vec<u8> = (0..cells).map(|_| if rng.gen_bool(fill) { 1 } else { EMPTY_VOXEL }).collect();
            if round % 9 == 0 {
                map.truncate(rng.gen_range(0..=cells));
            }
            let eye = grid.aabb().center() + v(&mut rng, 1.0).normalize() * rng.gen_range(0.5..20.0f32);
            let target = grid.aabb().center() + v(&mut rng, 2.0);
            let (w, h) = (rng.gen_range(1..=96u32), rng.gen_range(1..=72u32));
            let Ok(cam) = Camera::new(eye, target, v(&mut rng, 1.0), rng.gen_range(5.0..150.0f32), w, h) else {
                continue;
            };
            let mask = OccupancyMask::new(&cam, &grid, &map);
            active += u32::from(mask.is_active());
            let walk = WalkGrid::new(&grid);
            let mut words = [0u32; 128];
            for y in 0..h {
                for x in 0..w {
                    let listed =
                        walk.write_entries(VoxelMap::plain(&map), &cam.primary_ray(x, y), f32::INFINITY, &mut words)
                            > 0;
                    let may = mask.may_hit(x as u16, y as u16);
                    assert!(may || !listed, "pixel ({x}, {y}) lists cells in a clear tile: {cam:?} {grid:?}");
                    empty_walks += u64::from(!listed);
                    cleared += u64::from(!may);
                }
            }
        }
        assert!(active > 150, "{active} active masks");
        // Tight: the bound of runs of up to 16 cells clears 87.6 % of these empty walks (each
        // cell's own 88.5 %, the bounding sphere 82 %).
        assert!(cleared * 100 > empty_walks * 86, "{cleared} cleared of {empty_walks} empty walks");
        // An eye inside the box culls nothing.
        let g = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [2; 3] };
        let cam = Camera::new(Vec3::splat(0.5), Vec3::ONE, Vec3::Y, 60.0, 8, 8).unwrap();
        let m = OccupancyMask::new(&cam, &g, &[0; 8]);
        assert!(!m.is_active() && m.may_hit(3, 3));
    }

    /// Every pixel outside its row's span has a primary ray that misses the box (an empty
    /// walk over a grid whose every voxel is non-empty), for random boxes and cameras,
    /// including eyes close to the box; and the spans are tight (on average the margins and
    /// about a pixel more than the pixels that hit, per row).
    #[test]
    fn pixels_outside_the_spans_miss_the_box() {
        let mut rng = ChaCha8Rng::seed_from_u64(0xC011_0001);
        let (mut active, mut culled, mut hits, mut spanned) = (0, 0u64, 0u64, 0u64);
        let (mut span_rows, mut excess) = (0u64, 0u64);
        for _ in 0..400 {
            let v = |rng: &mut ChaCha8Rng, s: f32| {
                Vec3::new(rng.gen_range(-s..s), rng.gen_range(-s..s), rng.gen_range(-s..s))
            };
            let min = v(&mut rng, 4.0);
            let grid = GridDesc { min, max: min + v(&mut rng, 3.0).abs() + Vec3::splat(0.05), dims: [3, 2, 4] };
            let eye = grid.aabb().center() + v(&mut rng, 1.0).normalize() * rng.gen_range(0.5..20.0f32);
            let target = grid.aabb().center() + v(&mut rng, 2.0);
            let (w, h) = (rng.gen_range(1..=64u32), rng.gen_range(1..=48u32));
            let Ok(cam) = Camera::new(eye, target, v(&mut rng, 1.0), rng.gen_range(5.0..150.0f32), w, h) else {
                continue;
            };
            let spans = BoxSpans::new(&cam, &grid.aabb());
            active += spans.is_active() as u32;
            let walk = WalkGrid::new(&grid);
            let map = [0u8; 24];
            let mut words = [0u32; 64];
            let mut rows = Vec::new();
            for y in 0..h {
                let (lo, hi) = spans.row(y as u16, w as u16);
                assert!(lo <= hi && hi as u32 <= w);
                let (mut first, mut last) = (u32::MAX, 0);
                for x in 0..w {
                    let ray: Ray = cam.primary_ray(x, y);
                    let hit = walk.write_entries(VoxelMap::plain(&map), &ray, f32::INFINITY, &mut words) > 0;
                    if hit {
                        (first, last) = (first.min(x), x);
                        hits += 1;
                    }
                    let inside = (lo as u32..hi as u32).contains(&x);
                    assert!(inside || !hit, "pixel ({x}, {y}) hits the box outside [{lo}, {hi}): {cam:?} {grid:?}");
                    culled += !inside as u64;
                }
                spanned += (hi - lo) as u64;
                rows.push((lo, hi, first, last));
            }
            if spans.is_active() {
                for &(lo, hi, first, last) in &rows {
                    if lo < hi {
                        span_rows += 1;
                        let hit = if first <= last { last + 1 - first } else { 0 };
                        excess += u64::from(hi - lo) - u64::from(hit);
                    }
                }
            }
        }
        assert!(active > 250 && culled > 100_000, "{active} active, {culled} culled");
        assert!(spanned < 2 * hits, "{spanned} pixels in spans for {hits} hits");
        // Tight: on average the margins and about a pixel more per row.
        let per_row = excess as f64 / span_rows as f64;
        assert!(per_row < 2.0 * MARGIN_PX as f64 + 1.5, "{per_row} extra pixels per row");
        // An eye inside the box culls nothing.
        let g = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [1; 3] };
        let cam = Camera::new(Vec3::splat(0.5), Vec3::ONE, Vec3::Y, 60.0, 8, 8).unwrap();
        let s = BoxSpans::new(&cam, &g.aabb());
        assert!(!s.is_active());
        assert_eq!(s.row(3, 8), (0, 8));
    }
}

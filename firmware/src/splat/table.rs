//! The precomputed shape table of the point-splatting design (`LUT[size][nx][ny]`): for every quantised screen
//! radius and view-space normal, the codeword template (mode bit + the 24-bit scans) of each
//! 8×8 tile of the splat's ellipse.
//!
//! A splat of screen radius r (pixels) centred on a pixel corner, with unit view-space normal
//! (nx, ny, nz) (x right, y down), covers the pixel centres (dx, dy) from the centre with
//! `A·dx² + 2B·dx·dy + C·dy² ≤ F`, `A = 1 − ny²`, `B = nx·ny`, `C = 1 − nx²`, `F = r²·nz²`
//! (point splatting: the disk projected orthographically, the design's affine approximation; the
//! sign of nz does not matter, so splats are two-sided). Row dy is the run
//! `[(−B·dy − √disc)/A, (−B·dy + √disc)/A]`, `disc = B²dy² − A(C·dy² − F)`.
//!
//! Sizes up to 4 px are one symmetric 8×8 box (rows 0..=3 sent); larger ones a k×k cascade of
//! tiles in interpolated mode (rows 0, 2, 5, 7 sent), k = ⌈r/4⌉. Built in firmware (the
//! build is a few hundred thousand square roots, once per boot) rather than uploaded: it
//! depends on nothing the host knows better, and the same code serves the device, the
//! simulator and `gridrt bench splat`.

use gridrt_shared::splat::{Mode, RowCode, SplatWord};

/// Shape of a table: how finely it quantises normals and radii.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableConfig {
    /// Bins per normal component over [−1, 1] (nx and ny each), ≥ 2.
    pub normal_bins: u16,
    /// Radius bins per pixel, ≥ 1.
    pub steps_per_px: u16,
    /// Largest radius in pixels, 1..=16 (larger splats are clamped to it).
    pub max_radius_px: u16,
}

impl TableConfig {
    /// The device's table: 32 × 32 normals, quarter-pixel radii up to 8 px (81 920 words).
    pub const DEVICE: Self = Self { normal_bins: 32, steps_per_px: 4, max_radius_px: 8 };

    /// Radius bins (bin s ≥ 1 is radius s / steps_per_px).
    pub const fn sizes(&self) -> u32 {
        self.steps_per_px as u32 * self.max_radius_px as u32
    }

    /// Tiles per side of size bin `s`: ⌈r / 4⌉.
    pub const fn tiles(&self, s: u32) -> u32 {
        let steps4 = 4 * self.steps_per_px as u32;
        if s == 0 {
            1
        } else {
            s.div_ceil(steps4)
        }
    }

    /// Words the table needs.
    pub fn words(&self) -> usize {
        let n = self.normal_bins as usize * self.normal_bins as usize;
        (1..=self.sizes()).map(|s| n * (self.tiles(s) * self.tiles(s)) as usize).sum()
    }

    fn valid(&self) -> bool {
        self.normal_bins >= 2 && self.steps_per_px >= 1 && (1..=16).contains(&self.max_radius_px)
    }
}

/// Template flag: the tile covers no pixel (the code generator sends no codeword for it).
pub const TILE_EMPTY: u32 = 1 << 31;
/// Template bit of the mode (1 = interpolated), above the 24 scan bits.
const TILE_MODE: u32 = 1 << 24;

/// Why a table could not be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableError {
    /// The configuration is out of range.
    BadConfig,
    /// The storage is smaller than [`TableConfig::words`].
    TooSmall,
}

/// A built shape table over caller-provided storage.
pub struct ShapeTable<const CAP: usize> {
    config: TableConfig,
    /// First word of each size bin (index s − 1).
    base: heapless::Vec<u32, 256>,
    words: heapless::Vec<u32, CAP>,
}

/// What a lookup returns: where the tile templates are and how many per side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Index of tile (0, 0); tile (i, j) is at `first + j·k + i`.
    pub first: u32,
    /// Tiles per side.
    pub k: u32,
}

impl<const CAP: usize> ShapeTable<CAP> {
    /// An empty (unbuilt) table.
    pub const fn new() -> Self {
        Self {
            config: TableConfig { normal_bins: 0, steps_per_px: 0, max_radius_px: 0 },
            base: heapless::Vec::new(),
            words: heapless::Vec::new(),
        }
    }

    /// The configuration it was built with, `None` before [`build`](Self::build).
    pub fn config(&self) -> Option<TableConfig> {
        (!self.words.is_empty()).then_some(self.config)
    }

    /// Builds the table for `config` (a no-op if it is already built for it).
    pub fn build(&mut self, config: TableConfig) -> Result<(), TableError> {
        if !config.valid() {
            return Err(TableError::BadConfig);
        }
        if self.config() == Some(config) {
            return Ok(());
        }
        if config.words() > CAP || config.sizes() as usize > 256 {
            return Err(TableError::TooSmall);
        }
        self.words.clear();
        self.base.clear();
        self.config = config;
        let q = config.normal_bins as u32;
        for s in 1..=config.sizes() {
            let _ = self.base.push(self.words.len() as u32);
            let r = s as f32 / config.steps_per_px as f32;
            let k = config.tiles(s);
            for qx in 0..q {
                for qy in 0..q {
                    let (nx, ny) = (bin_value(qx, q), bin_value(qy, q));
                    for j in 0..k {
                        for i in 0..k {
                            let _ = self.words.push(tile_template(r, nx, ny, k, i, j));
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// The entry of size bin `s` (1..=sizes) and normal bins (qx, qy).
    #[inline]
    pub fn entry(&self, s: u32, qx: u32, qy: u32) -> Entry {
        let q = self.config.normal_bins as u32;
        let k = self.config.tiles(s);
        let base = self.base.get((s as usize).wrapping_sub(1)).copied().unwrap_or(0);
        Entry { first: base + (qx * q + qy) * k * k, k }
    }

    /// Template word `index`: [`TILE_EMPTY`], or the mode bit (bit 24) and the scans (23..0).
    #[inline]
    pub fn template(&self, index: u32) -> u32 {
        self.words.get(index as usize).copied().unwrap_or(TILE_EMPTY)
    }

    /// Normal bin of a component in [−1, 1] (clamped).
    #[inline]
    pub fn normal_bin(&self, n: f32) -> u32 {
        let q = self.config.normal_bins as f32;
        let b = ((n + 1.0) * 0.5 * (q - 1.0) + 0.5) as i32;
        b.clamp(0, self.config.normal_bins as i32 - 1) as u32
    }

    /// Size bin of a radius in pixels: 0 (covers nothing), or 1..=sizes (clamped; the bool
    /// says it was clamped).
    #[inline]
    pub fn size_bin(&self, r: f32) -> (u32, bool) {
        let s = (r * self.config.steps_per_px as f32 + 0.5) as i64;
        let max = self.config.sizes() as i64;
        if s > max {
            (max as u32, true)
        } else {
            (s.max(0) as u32, false)
        }
    }
}

impl<const CAP: usize> Default for ShapeTable<CAP> {
    fn default() -> Self {
        Self::new()
    }
}

/// The codeword upper bits of a template: mode and scans in place (`SplatWord::pack` layout).
#[inline]
pub fn template_bits(template: u32) -> u64 {
    let mode = ((template & TILE_MODE) != 0) as u64;
    (mode << 63) | (((template & 0x00FF_FFFF) as u64) << 39)
}

/// Centre value of bin `b` of `q` over [−1, 1].
fn bin_value(b: u32, q: u32) -> f32 {
    b as f32 * 2.0 / (q - 1) as f32 - 1.0
}

/// Pixel runs of the rows of a `8k`-pixel box centred on the ellipse: `(first, last)` box
/// columns of row `row`, `None` when no pixel centre of the row is inside.
fn row_run(r: f32, nx: f32, ny: f32, k: u32, row: u32) -> Option<(i32, i32)> {
    // Normals outside the unit disk (corner bins) are pulled onto it: nz² ≥ 1e-4.
    let len2 = nx * nx + ny * ny;
    let (nx, ny) = if len2 > 0.9999 {
        let s = libm::sqrtf(0.9999 / len2);
        (nx * s, ny * s)
    } else {
        (nx, ny)
    };
    let nz2 = 1.0 - nx * nx - ny * ny;
    let (a, b, c, f) = (1.0 - ny * ny, nx * ny, 1.0 - nx * nx, r * r * nz2);
    let half = 4.0 * k as f32;
    let dy = row as f32 + 0.5 - half;
    let disc = b * b * dy * dy - a * (c * dy * dy - f);
    if disc < 0.0 {
        return None;
    }
    let root = libm::sqrtf(disc);
    let (xl, xr) = ((-b * dy - root) / a, (-b * dy + root) / a);
    // Pixel i is covered iff i + 0.5 − half ∈ [xl, xr].
    let first = libm::ceilf(xl + half - 0.5) as i32;
    let last = libm::floorf(xr + half - 0.5) as i32;
    (first <= last).then_some((first, last))
}

/// Template of tile (i, j) of the k×k cascade.
fn tile_template(r: f32, nx: f32, ny: f32, k: u32, i: u32, j: u32) -> u32 {
    let (mode, rows): (Mode, [u32; 4]) =
        if k == 1 { (Mode::Symmetric, [0, 1, 2, 3]) } else { (Mode::Interpolated, [0, 2, 5, 7]) };
    let x0 = 8 * i as i32;
    let mut scans = [RowCode::EMPTY; 4];
    let mut any = false;
    for (code, &row) in scans.iter_mut().zip(rows.iter()) {
        if let Some((a, b)) = row_run(r, nx, ny, k, 8 * j + row) {
            *code = RowCode::span(a - x0, b - x0);
            any |= code.pixels().is_some();
        }
    }
    // Symmetric boxes are judged by their sent half; a cascade tile also by its rebuilt rows.
    let w = SplatWord { mode, scans, diffuse: 0, specular: 0, material: 0, x: 0, z: 0 };
    if !any && w.rows().iter().all(Option::is_none) {
        return TILE_EMPTY;
    }
    let bits = w.pack();
    (((bits >> 63) as u32) << 24) | ((bits >> 39) as u32 & 0x00FF_FFFF)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn covered(t: u32) -> Vec<(usize, usize)> {
        let w = SplatWord::unpack(template_bits(t));
        let mut v = Vec::new();
        for (r, row) in w.rows().iter().enumerate() {
            if let Some((a, b)) = row {
                for c in *a..=*b {
                    v.push((r, c as usize));
                }
            }
        }
        v
    }

    #[test]
    fn facing_disk_of_radius_three_is_the_pixel_disk() {
        let mut t: ShapeTable<20480> = ShapeTable::new();
        let cfg = TableConfig { normal_bins: 16, steps_per_px: 4, max_radius_px: 8 };
        t.build(cfg).unwrap();
        assert_eq!(cfg.words(), 20480);
        // A facing normal in a 16-bin table is bin 7 or 8 (±1/15): nearly round.
        let (s, clamped) = t.size_bin(3.0);
        assert_eq!((s, clamped), (12, false));
        let e = t.entry(s, t.normal_bin(0.0), t.normal_bin(0.0));
        assert_eq!(e.k, 1);
        let cov = covered(t.template(e.first));
        // Pixel centres within 3 px of the box centre (4, 4): exactly the disk's pixels.
        let want: Vec<(usize, usize)> = (0..8)
            .flat_map(|r| (0..8).map(move |c| (r, c)))
            .filter(|&(r, c)| {
                let (dx, dy) = (c as f32 + 0.5 - 4.0, r as f32 + 0.5 - 4.0);
                // nx = ny = −1/15: nearly a circle, the ±0.07 slant moves no pixel here.
                dx * dx + dy * dy <= 9.0
            })
            .collect();
        assert_eq!(cov, want);
    }

    #[test]
    fn edge_on_and_tiny_splats_cover_nothing_large_ones_tile() {
        let mut t: ShapeTable<20480> = ShapeTable::new();
        t.build(TableConfig { normal_bins: 16, steps_per_px: 4, max_radius_px: 8 }).unwrap();
        // Radius 0.5: no pixel centre (≥ 0.707 from the corner) is inside.
        let e = t.entry(2, 8, 8);
        assert_eq!(t.template(e.first), TILE_EMPTY);
        assert_eq!(t.size_bin(0.1), (0, false));
        assert_eq!(t.size_bin(100.0), (32, true));
        // Radius 6: a 2×2 cascade in interpolated mode, every tile covers something.
        let e = t.entry(24, 8, 8);
        assert_eq!(e.k, 2);
        for i in 0..4 {
            let tpl = t.template(e.first + i);
            assert_ne!(tpl, TILE_EMPTY);
            assert_eq!(SplatWord::unpack(template_bits(tpl)).mode, Mode::Interpolated);
        }
        // Tile (1, 1) of a near-circle of radius 6 around the corner (8, 8): its top-left
        // pixel (centre 0.5, 0.5 from the corner) is covered.
        assert!(covered(t.template(e.first + 3)).contains(&(0, 0)));
    }

    #[test]
    fn refuses_bad_configs_and_small_storage() {
        let mut t: ShapeTable<100> = ShapeTable::new();
        assert_eq!(t.build(TableConfig { normal_bins: 1, ..TableConfig::DEVICE }), Err(TableError::BadConfig));
        assert_eq!(t.build(TableConfig { max_radius_px: 17, ..TableConfig::DEVICE }), Err(TableError::BadConfig));
        assert_eq!(t.build(TableConfig::DEVICE), Err(TableError::TooSmall));
        assert_eq!(TableConfig::DEVICE.words(), 81920);
        assert!(t.config().is_none());
    }
}

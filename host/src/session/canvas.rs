//! A frame being assembled from spans: pixels, primitive ids, and per pixel what has arrived
//! and what a `RegionEnd` CRC has verified.

use std::collections::BTreeMap;

use gridrt_shared::msg::{PixelEncoding, Region};
use gridrt_shared::pixel;

/// Pixel has its colour.
const HAVE_RGB: u8 = 1;
/// Pixel has its primitive id.
const HAVE_ID: u8 = 2;
/// Pixel is covered by a `RegionEnd` whose CRC matched.
pub(super) const VERIFIED: u8 = 4;

/// A frame being assembled: pixels plus, per pixel, what has arrived and what is verified.
#[derive(Debug, Clone, PartialEq)]
pub struct Canvas {
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// RGB8 row-major.
    pub rgb: Vec<u8>,
    /// Primitive ids, when requested.
    pub prim_ids: Option<Vec<u32>>,
    state: Vec<u8>,
}

impl Canvas {
    /// An empty `width`×`height` canvas; `prim_ids` also collects primitive ids.
    pub fn new(width: u16, height: u16, prim_ids: bool) -> Self {
        let n = width as usize * height as usize;
        Self { width, height, rgb: vec![0; 3 * n], prim_ids: prim_ids.then(|| vec![u32::MAX; n]), state: vec![0; n] }
    }

    pub(super) fn need(&self) -> u8 {
        if self.prim_ids.is_some() {
            HAVE_RGB | HAVE_ID
        } else {
            HAVE_RGB
        }
    }

    pub(super) fn rows(&self, r: Region) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let w = self.width as usize;
        (r.y0 as usize..r.y0 as usize + r.rows as usize)
            .map(move |y| y * w + r.x0 as usize..y * w + (r.x0 + r.cols) as usize)
    }

    /// True when every pixel of `r` has arrived (colour, and id when collected).
    pub fn complete(&self, r: Region) -> bool {
        let need = self.need();
        self.rows(r).all(|row| self.state[row].iter().all(|&s| s & need == need))
    }

    /// True when every pixel of `r` is verified.
    pub fn verified(&self, r: Region) -> bool {
        self.rows(r).all(|row| self.state[row].iter().all(|&s| s & VERIFIED != 0))
    }

    /// CRC-32 of the RGB888 pixels of `r`, row-major.
    pub fn crc(&self, r: Region) -> u32 {
        let mut d = gridrt_shared::frame::Crc32Digest::default();
        for row in self.rows(r) {
            d.update(&self.rgb[3 * row.start..3 * row.end]);
        }
        d.finalize()
    }

    pub(super) fn mark(&mut self, r: Region, f: impl Fn(u8) -> u8) {
        let w = self.width as usize;
        for y in r.y0 as usize..r.y0 as usize + r.rows as usize {
            for s in &mut self.state[y * w + r.x0 as usize..y * w + (r.x0 + r.cols) as usize] {
                *s = f(*s);
            }
        }
    }

    /// Copies region `r` (pixels, ids, state) from `other`, a canvas of the same size.
    pub fn copy_region_from(&mut self, other: &Canvas, r: Region) {
        let rows: Vec<_> = self.rows(r).collect();
        for row in rows {
            self.rgb[3 * row.start..3 * row.end].copy_from_slice(&other.rgb[3 * row.start..3 * row.end]);
            if let (Some(dst), Some(src)) = (self.prim_ids.as_mut(), other.prim_ids.as_ref()) {
                dst[row.clone()].copy_from_slice(&src[row.clone()]);
            }
            self.state[row.clone()].copy_from_slice(&other.state[row]);
        }
    }

    /// Places a decoded span; returns how many of its pixels are new.
    pub(super) fn place(
        &mut self,
        y: u16,
        x0: u16,
        count: u16,
        encoding: PixelEncoding,
        data: &[u8],
    ) -> Result<usize, String> {
        let (w, h) = (self.width as usize, self.height as usize);
        let (y, x0, n) = (y as usize, x0 as usize, count as usize);
        if y >= h || x0 + n > w {
            return Err(format!("span y {y} x {x0}+{n} outside the {w}×{h} image"));
        }
        let base = y * w + x0;
        let flag = match encoding {
            PixelEncoding::PrimId32 => {
                let Some(ids) = self.prim_ids.as_mut() else { return Ok(0) };
                for (k, c) in data.chunks_exact(4).enumerate() {
                    ids[base + k] = u32::from_le_bytes([c[0], c[1], c[2], c[3]]);
                }
                HAVE_ID
            }
            enc => {
                let dst = &mut self.rgb[3 * base..3 * (base + n)];
                decode_colour(enc, n, data, dst)?;
                HAVE_RGB
            }
        };
        let mut newly = 0;
        for s in &mut self.state[base..base + n] {
            if *s & flag == 0 {
                newly += 1;
            }
            *s |= flag;
        }
        Ok(newly)
    }

    /// Runs of pixels of `band` that have not arrived (colour, or id when collected), row by
    /// row, left to right: `(row, first column, end column)`.
    pub(super) fn missing_runs(&self, band: Region) -> Vec<(u16, u16, u16)> {
        let (w, need) = (self.width as usize, self.need());
        let mut runs = Vec::new();
        for y in band.y0..band.y0 + band.rows {
            let base = y as usize * w;
            let mut x = band.x0;
            while x < band.x0 + band.cols {
                if self.state[base + x as usize] & need == need {
                    x += 1;
                    continue;
                }
                let start = x;
                while x < band.x0 + band.cols && self.state[base + x as usize] & need != need {
                    x += 1;
                }
                runs.push((y, start, x));
            }
        }
        runs
    }

    /// Pixels of `r` that have not arrived.
    pub(super) fn missing_in(&self, r: Region) -> u64 {
        let need = self.need();
        self.rows(r).map(|row| self.state[row].iter().filter(|&&s| s & need != need).count() as u64).sum()
    }

    /// The first group of consecutive rows of `band` with unverified pixels, as one region
    /// (the union of their column ranges); `None` when the band is verified.
    pub(super) fn next_unverified(&self, band: Region) -> Option<Region> {
        let w = self.width as usize;
        let mut group: Option<(u16, u16, usize, usize)> = None; // (y0, rows, xmin, xmax)
        for y in band.y0..band.y0 + band.rows {
            let row = &self.state[y as usize * w + band.x0 as usize..y as usize * w + (band.x0 + band.cols) as usize];
            let first = row.iter().position(|&s| s & VERIFIED == 0);
            match (first, group.as_mut()) {
                (Some(a), None) => {
                    let b = row.iter().rposition(|&s| s & VERIFIED == 0).unwrap_or(a);
                    group = Some((y, 1, a, b));
                }
                (Some(a), Some(g)) => {
                    let b = row.iter().rposition(|&s| s & VERIFIED == 0).unwrap_or(a);
                    g.1 += 1;
                    g.2 = g.2.min(a);
                    g.3 = g.3.max(b);
                }
                (None, Some(_)) => break,
                (None, None) => {}
            }
        }
        group.map(|(y0, rows, a, b)| Region { x0: band.x0 + a as u16, y0, cols: (b - a + 1) as u16, rows })
    }

    /// Pixels of `band` that are verified.
    pub(super) fn verified_pixels(&self, band: Region) -> u64 {
        self.rows(band).map(|row| self.state[row].iter().filter(|&&s| s & VERIFIED != 0).count() as u64).sum()
    }

    /// Rows of `band` that are fully verified.
    pub(super) fn verified_rows(&self, band: Region) -> Vec<u16> {
        (band.y0..band.y0 + band.rows)
            .filter(|&y| self.verified(Region { x0: band.x0, y0: y, cols: band.cols, rows: 1 }))
            .collect()
    }
}

/// Adds one device counter of a region to the counters of a frame: counts add up; the
/// `PLAN` bit set is OR-ed (every region of a frame follows the same plan).
pub fn merge_stat(into: &mut BTreeMap<u8, u64>, key: u8, value: u64) {
    let slot = into.entry(key).or_insert(0);
    if key == gridrt_shared::msg::stat::PLAN {
        *slot |= value;
    } else {
        *slot += value;
    }
}

/// Decodes `count` colour pixels into RGB888.
pub fn decode_colour(enc: PixelEncoding, count: usize, data: &[u8], dst: &mut [u8]) -> Result<(), String> {
    match enc {
        PixelEncoding::Rgb888 => dst.copy_from_slice(data),
        PixelEncoding::Rgb565 => {
            for (d, c) in dst.chunks_exact_mut(3).zip(data.chunks_exact(2)) {
                d.copy_from_slice(&pixel::rgb565_unpack(u16::from_le_bytes([c[0], c[1]])));
            }
        }
        PixelEncoding::Rle => pixel::rle_decode(count, data, dst).map_err(|e| format!("Rle span: {e}"))?,
        other => return Err(format!("unsupported pixel encoding {other:?}")),
    }
    Ok(())
}

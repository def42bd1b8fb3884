//! The reference's frame: RGB8 and primary primitive ids, rendered row by row on scoped
//! worker threads, and the 8-bit rule of docs/CONTRACTS.md.

use std::sync::atomic::{AtomicUsize, Ordering};

use crate::render_settings::RenderSettings;

/// Primitive id of a pixel whose primary ray missed.
pub const MISS_ID: u32 = u32::MAX;

/// A rendered reference frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ReferenceImage {
    /// Width in pixels.
    pub width: u16,
    /// Height in pixels.
    pub height: u16,
    /// RGB8, row-major.
    pub rgb: Vec<u8>,
    /// Primitive id of each pixel's primary hit, [`MISS_ID`] for a miss.
    pub prim_ids: Vec<u32>,
}

/// Linear `[0, 1]` colour to 8 bits: `(c·255 + 0.5) as u8`.
pub fn to_rgb8(c: [f64; 3]) -> [u8; 3] {
    c.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
}

/// Runs `shade(x, y) -> (linear colour, primary prim id)` over every pixel of `settings`' frame
/// on `threads` scoped worker threads that take rows from a shared counter.
pub fn render_pixels(
    settings: &RenderSettings,
    threads: usize,
    shade: impl Fn(u32, u32) -> ([f64; 3], u32) + Sync,
) -> ReferenceImage {
    let (w, h) = (settings.width as usize, settings.height as usize);
    let next = AtomicUsize::new(0);
    /// One rendered row: (y, RGB8, prim ids).
    type Row = (usize, Vec<u8>, Vec<u32>);
    let rows: Vec<Vec<Row>> = std::thread::scope(|sc| {
        let workers: Vec<_> = (0..threads.max(1))
            .map(|_| {
                sc.spawn(|| {
                    let mut out = Vec::new();
                    loop {
                        let y = next.fetch_add(1, Ordering::Relaxed);
                        if y >= h {
                            break;
                        }
                        let mut rgb = Vec::with_capacity(3 * w);
                        let mut ids = Vec::with_capacity(w);
                        for x in 0..w {
                            let (c, id) = shade(x as u32, y as u32);
                            rgb.extend_from_slice(&to_rgb8(c));
                            ids.push(id);
                        }
                        out.push((y, rgb, ids));
                    }
                    out
                })
            })
            .collect();
        workers.into_iter().map(|j| j.join().unwrap_or_default()).collect()
    });
    let mut rgb = vec![0u8; 3 * w * h];
    let mut prim_ids = vec![MISS_ID; w * h];
    for (y, row, ids) in rows.into_iter().flatten() {
        rgb[3 * w * y..3 * w * (y + 1)].copy_from_slice(&row);
        prim_ids[w * y..w * (y + 1)].copy_from_slice(&ids);
    }
    ReferenceImage { width: settings.width, height: settings.height, rgb, prim_ids }
}

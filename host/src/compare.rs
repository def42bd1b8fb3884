//! Image comparison of a device frame against the reference.
//!
//! PSNR is computed over all RGB8 channel values: `10·log10(255² / MSE)`. Identical images
//! have `MSE = 0` and an infinite PSNR, which JSON cannot carry: [`Comparison::psnr_db`] is then
//! `None` (JSON `null`) and [`Comparison::identical`] is true. Any finite PSNR is reported as is
//! (for RGB8 it is at most `10·log10(255²·3·W·H)`, about 102 dB at 320×240).

use serde::Serialize;

/// Result of comparing two RGB8 images of the same size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Peak signal-to-noise ratio in dB; `None` when the images are identical.
    pub psnr_db: Option<f64>,
    /// True when every byte matches.
    pub identical: bool,
    /// Largest absolute difference of one channel value.
    pub max_abs_diff: u8,
    /// Pixels with at least one differing channel.
    pub differing_pixels: u64,
    /// Pixels whose primary primitive id differs (None when no ids were compared).
    pub hit_mismatches: Option<u64>,
}

/// Why two images cannot be compared.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("cannot compare images: {what}")]
pub struct CompareError {
    /// What does not match.
    pub what: String,
}

/// PSNR in dB of two equally long RGB8 buffers; `None` for identical buffers.
pub fn psnr(a: &[u8], b: &[u8]) -> Option<f64> {
    if a.is_empty() || a.len() != b.len() {
        return None;
    }
    let se: u64 = a.iter().zip(b).map(|(&x, &y)| (x as i64 - y as i64).unsigned_abs().pow(2)).sum();
    if se == 0 {
        return None;
    }
    let mse = se as f64 / a.len() as f64;
    Some(10.0 * (255.0f64 * 255.0 / mse).log10())
}

/// Compares `rgb` with `reference_rgb` (both RGB8 row-major, same size), and the primitive
/// ids when both are given.
pub fn compare(
    rgb: &[u8],
    reference_rgb: &[u8],
    ids: Option<&[u32]>,
    reference_ids: Option<&[u32]>,
) -> Result<Comparison, CompareError> {
    if rgb.len() != reference_rgb.len() || !rgb.len().is_multiple_of(3) {
        return Err(CompareError {
            what: format!("image sizes differ ({} vs {} bytes)", rgb.len(), reference_rgb.len()),
        });
    }
    let mut max_abs_diff = 0u8;
    let mut differing_pixels = 0u64;
    for (p, q) in rgb.chunks_exact(3).zip(reference_rgb.chunks_exact(3)) {
        let d = (0..3).map(|i| p[i].abs_diff(q[i])).max().unwrap_or(0);
        max_abs_diff = max_abs_diff.max(d);
        differing_pixels += (d > 0) as u64;
    }
    let hit_mismatches = match (ids, reference_ids) {
        (Some(a), Some(b)) => {
            if a.len() != b.len() || a.len() * 3 != rgb.len() {
                return Err(CompareError {
                    what: format!("primitive-id buffers differ in size ({} vs {})", a.len(), b.len()),
                });
            }
            Some(a.iter().zip(b).filter(|(x, y)| x != y).count() as u64)
        }
        _ => None,
    };
    Ok(Comparison {
        psnr_db: psnr(rgb, reference_rgb),
        identical: differing_pixels == 0,
        max_abs_diff,
        differing_pixels,
        hit_mismatches,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn psnr_of_identical_images_is_none() {
        let a = vec![7u8; 30];
        let c = compare(&a, &a, None, None).unwrap();
        assert_eq!(c.psnr_db, None);
        assert!(c.identical);
        assert_eq!((c.max_abs_diff, c.differing_pixels, c.hit_mismatches), (0, 0, None));
        assert_eq!(serde_json::to_value(&c).unwrap()["psnr_db"], serde_json::Value::Null);
    }

    #[test]
    fn psnr_matches_the_formula() {
        // One channel of one pixel off by 255 out of 4 pixels (12 values): MSE = 255²/12.
        let a = vec![0u8; 12];
        let mut b = a.clone();
        b[4] = 255;
        let p = psnr(&a, &b).unwrap();
        assert!((p - 10.0 * 12f64.log10()).abs() < 1e-12, "{p}");
        // Uniform error of 1: MSE = 1 → 20·log10(255) = 48.1308…
        let c = vec![1u8; 12];
        assert!((psnr(&a, &c).unwrap() - 20.0 * 255f64.log10()).abs() < 1e-12);
        let cmp = compare(&a, &b, Some(&[1, 2, 3, 4]), Some(&[1, 9, 3, 4])).unwrap();
        assert_eq!((cmp.max_abs_diff, cmp.differing_pixels, cmp.hit_mismatches), (255, 1, Some(1)));
        assert!(!cmp.identical);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        assert!(compare(&[0; 6], &[0; 9], None, None).is_err());
        assert!(compare(&[0; 6], &[0; 6], Some(&[0]), Some(&[0, 1])).is_err());
    }
}

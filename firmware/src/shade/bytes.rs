//! The 8-bit colour of a matte hit in fixed point, with the f32 rule's bytes.
//!
//! For a matte material without the specular stage (docs/CONTRACTS.md § Shading), a camera
//! hit's channel is `to_u8(cd·(ka·la + D·kd) + D·(0·cs))` with `D = e·rad` (`e = spot·E`
//! the light's factor at the hit, 0 when the light is not seen), i.e. the byte
//! `⌊255·c + 0.5⌋` of a value affine in `e`:
//!
//! ```text
//! V = base + e·slope,   base = 255·cd·ka·la + 0.5,   slope = 255·cd·kd·rad
//! ```
//!
//! `base` and `slope` are per frame and material ([`MatteBytes::new`]); per hit `V` is one
//! 32×32-bit product and an addition in 16.16 fixed point, where the f32 rule
//! ([`outgoing`](super::outgoing) and [`to_rgb8`](super::to_rgb8)) is about 27 rounded
//! operations: on a soft-float core ~1 000 instructions.
//!
//! **Why the bytes are the f32 rule's.** Every input is a non-negative f32 and every operation
//! of either side adds or multiplies non-negative values, so each side's rounding errors
//! compound without cancellation: the f32 rule's `V` (at most seven roundings deep, the 8-bit rule's
//! `·255` and `+ 0.5` included) is within `γ₇·V` of the exact `V` (γₖ = k·u/(1 − k·u),
//! u = 2⁻²⁴); the fixed-point `V` is within `γ₄·V` (the f32 constants) plus four truncations
//! to 2⁻¹⁶. For `V < 257` both are within 2.2·10⁻⁴ of the exact value, so where the
//! fixed-point `V` is more than 2⁻¹⁰ from an integer both floor to the same byte (and at
//! `V ≥ 256` both give 255). Within 2⁻¹⁰ of an integer (about one channel in 500) the caller
//! runs the f32 rule. Pinned by `matte_bytes_equal_the_f32_rule` (random materials, lights
//! and factors, and factors placed at the byte boundaries).

use gridrt_shared::scene::{DiffuseModel, Material, MaterialModel, ReflectMode, TextureKind};

/// Materials (ids `0..FAST_MATERIALS`) with a fixed-point rule; others take the f32 rule. On
/// a bare-metal hard-float image none: there the f32 rule is cheap.
pub const FAST_MATERIALS: usize = if cfg!(any(soft_float, not(target_os = "none"))) { 8 } else { 0 };

/// Distance from an integer, in 16.16, below which the f32 rule decides (2⁻¹⁰; module doc).
const MARGIN: u32 = 1 << 6;

/// Constants are kept below 2¹⁴ (their sum with `e < 2` stays below 2¹⁶ in 16.16).
const LIMIT: f32 = 16384.0;

/// Per channel, `base` and `slope` in 16.16 fixed point (truncated), and the margin for a
/// factor known to within 2⁻²⁰ ([`super::FACTOR_ERROR`]): `MARGIN + slope·2⁻¹⁹`.
#[derive(Debug, Clone, Copy, Default)]
struct Rule {
    base: [u32; 3],
    slope: [u32; 3],
    loose: [u32; 3],
}

/// The fixed-point 8-bit rule of a frame's matte materials (module doc).
#[derive(Debug, Clone, Copy, Default)]
pub struct MatteBytes {
    rules: [Option<Rule>; FAST_MATERIALS],
}

/// `x` is a finite f32 ≥ +0 (sign bit clear).
fn non_negative(x: f32) -> bool {
    x.to_bits() < 0x7F80_0000
}

/// `v · 2¹⁶` truncated, for `0 ≤ v < LIMIT` (the multiplication by a power of two is exact).
fn q16(v: f32) -> u32 {
    (v * 65536.0) as u32
}

impl MatteBytes {
    /// The rules of a frame: `materials` and their `models` (a missing model is
    /// [`MaterialModel::MATTE`]), the ambient light `la` and the light's radiance `rad`
    /// (colour × intensity), and the plan: a material gets a rule when it is matte, its
    /// inputs are finite and non-negative, the specular stage is off, and it is neither
    /// textured (`textures`) nor reflective (`reflections`) in this frame.
    #[inline(never)]
    pub fn new(
        materials: &[Material],
        models: &[MaterialModel],
        la: [f32; 3],
        rad: [f32; 3],
        plan: (bool, bool, bool),
    ) -> Self {
        let (specular, textures, reflections) = plan;
        let mut out = Self::default();
        if specular {
            return out;
        }
        for (i, (slot, m)) in out.rules.iter_mut().zip(materials).enumerate() {
            let ext = models.get(i).unwrap_or(&MaterialModel::MATTE);
            let eligible = ext.diffuse_model == DiffuseModel::Matte
                && !(textures && ext.texture != TextureKind::None)
                && !(reflections && ext.reflect_mode != ReflectMode::None)
                // `D·(0·cs)` is 0 only for a finite cs.
                && ext.specular.iter().all(|c| c.is_finite());
            let inputs = m.diffuse.iter().chain(&la).chain(&rad).chain([&ext.ka, &ext.kd]);
            if !eligible || !inputs.copied().all(non_negative) {
                continue;
            }
            let mut rule = Rule::default();
            let mut fits = true;
            for k in 0..3 {
                let cd = m.diffuse[k];
                let base = cd * (ext.ka * la[k]) * 255.0 + 0.5;
                let slope = cd * (ext.kd * rad[k]) * 255.0;
                fits &= base < LIMIT && slope < LIMIT;
                rule.base[k] = q16(base.min(LIMIT));
                rule.slope[k] = q16(slope.min(LIMIT));
                rule.loose[k] = MARGIN + (rule.slope[k] >> (super::FACTOR_ERROR - 1)) + 1;
            }
            if fits {
                *slot = Some(rule);
            }
        }
        out
    }

    /// The bytes of a hit on `material` lit with factor `e` (`spot·E`; +0 when no direct light
    /// reaches it), or `None` where the f32 rule decides: no rule for the material, `e`
    /// outside `[0, 2)`, or a channel within the margin of a byte boundary.
    #[inline]
    pub fn rgb(&self, material: u16, e: f32) -> Option<[u8; 3]> {
        let bits = e.to_bits();
        // Negative, NaN and ≥ 2: the f32 rule.
        if bits >= 0x4000_0000 {
            return None;
        }
        // e · 2^30 (truncated): the significand shifted by the exponent; subnormals count as 0.
        let exp = bits >> 23;
        let sig = (bits & 0x007F_FFFF) | 0x0080_0000;
        let e30 = if exp >= 120 {
            sig << (exp - 120)
        } else if exp > 120 - 32 {
            sig >> (120 - exp)
        } else {
            0
        };
        self.rgb_q30(material, e30, false)
    }

    /// The material has a rule.
    #[inline]
    pub fn covers(&self, material: u16) -> bool {
        matches!(self.rules.get(material as usize), Some(Some(_)))
    }

    /// [`MatteBytes::rgb`] for a factor `e30·2⁻³⁰` (below 2), exact (`loose` false) or known to
    /// within 2⁻²⁰ of the f32 factor (`loose`: `shade::light_factor`'s estimate), which
    /// widens the margin by the slope's share.
    #[inline(never)]
    pub fn rgb_q30(&self, material: u16, e30: u32, loose: bool) -> Option<[u8; 3]> {
        let rule = self.rules.get(material as usize).copied().flatten()?;
        if e30 >= 1 << 31 {
            return None;
        }
        let mut rgb = [0u8; 3];
        for (k, byte) in rgb.iter_mut().enumerate() {
            // base + slope·e in 16.16: below 2^14 + 2·2^14, no overflow.
            let v = rule.base[k].wrapping_add(((u64::from(rule.slope[k]) * u64::from(e30)) >> 30) as u32);
            let whole = v >> 16;
            if whole >= 256 {
                *byte = 255;
                continue;
            }
            let frac = v & 0xFFFF;
            let margin = if loose { rule.loose[k] } else { MARGIN };
            if frac < margin || frac > 0xFFFF - margin {
                return None;
            }
            *byte = whole as u8;
        }
        Some(rgb)
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)]
mod tests {
    use super::super::brdf::{direct_toward, outgoing, DirectLight};
    use super::super::colour::to_rgb8;
    use super::*;
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The f32 rule of the pipeline for a camera hit: `outgoing` with the direct term of
    /// factor `e` (or none), then the 8-bit rule.
    fn f32_rule(m: &Material, ext: &MaterialModel, la: [f32; 3], rad: [f32; 3], e: Option<f32>) -> [u8; 3] {
        let light = DirectLight { pos: Vec3::ZERO, radiance: rad, specular: false };
        let d = e.map(|e| direct_toward(ext, Vec3::Z, Vec3::Z, Vec3::Z, &light, e));
        to_rgb8(outgoing(ext, m.diffuse, la, d.as_ref()))
    }

    /// Wherever the fixed-point rule answers, it gives the f32 rule's bytes: random matte
    /// materials, ambient and radiance (up to 20), factors uniform in [0, 1.2) and factors placed within
    /// a few 2⁻²⁰ of every byte boundary; and it answers for nearly every hit.
    #[test]
    fn matte_bytes_equal_the_f32_rule() {
        let mut rng = ChaCha8Rng::seed_from_u64(0x008B_17E5);
        let (mut answered, mut asked) = (0u64, 0u64);
        for round in 0..400 {
            let unit = |rng: &mut ChaCha8Rng| [0; 3].map(|_| rng.gen_range(0.0..1.0f32));
            let m = Material { diffuse: unit(&mut rng), reflect: 0.0 };
            let ext =
                MaterialModel { ka: rng.gen_range(0.0..1.0), kd: rng.gen_range(0.0..1.5), ..MaterialModel::MATTE };
            let la = unit(&mut rng);
            // Radiance up to 20: slopes up to ~7 700 of the 16 384 `LIMIT` allows, so the loose
            // margin's slope share (up to ~480 in 16.16) is well past the bare `MARGIN` (64).
            let rad = [0; 3].map(|_| rng.gen_range(0.0..20.0f32));
            let bytes = MatteBytes::new(&[m], &[ext], la, rad, (false, false, false));
            // Shadowed (no direct term): e = 0.
            if let Some(rgb) = bytes.rgb(0, 0.0) {
                assert_eq!(rgb, f32_rule(&m, &ext, la, rad, None), "round {round}");
            }
            // `off`: an estimate of e off by `off`·2⁻³⁰, |off| < 2¹⁰ (within 2⁻²⁰, the loose rule).
            let check = |e: f32, off: i64| {
                let want = f32_rule(&m, &ext, la, rad, Some(e));
                let fixed = bytes.rgb(0, e);
                if let Some(rgb) = fixed {
                    assert_eq!(rgb, want, "round {round}, e = {e:e}");
                }
                let estimate = ((e as f64 * 2f64.powi(30)) as i64 + off).max(0) as u32;
                if let Some(rgb) = bytes.rgb_q30(0, estimate, true) {
                    assert_eq!(rgb, want, "round {round}, e = {e:e}, estimate {estimate}");
                }
                fixed.is_some()
            };
            for _ in 0..500 {
                asked += 1;
                answered += u64::from(check(rng.gen_range(0.0..1.2f32), rng.gen_range(-1023..1024)));
            }
            // Factors at the byte boundaries of each channel: V = n exactly in real numbers.
            for k in 0..3 {
                let base = m.diffuse[k] as f64 * (ext.ka as f64 * la[k] as f64) * 255.0 + 0.5;
                let slope = m.diffuse[k] as f64 * (ext.kd as f64 * rad[k] as f64) * 255.0;
                if slope <= 0.0 {
                    continue;
                }
                for n in 1..=255 {
                    let e = (n as f64 - base) / slope;
                    if !(0.0..1.2).contains(&e) {
                        continue;
                    }
                    for j in -3..=3 {
                        let off = rng.gen_range(-1023..1024);
                        check((e * (1.0 + j as f64 * 2f64.powi(-20))) as f32, off);
                        check((e + j as f64 * 2f64.powi(-30)) as f32, off);
                    }
                }
            }
        }
        // About one channel in 500 is within the margin: the rule answers for nearly every hit.
        assert!(answered as f64 > 0.98 * asked as f64, "{answered} of {asked}");
    }

    /// Materials the rule does not cover get none: another model, the specular stage, a
    /// texture or a reflection in the frame's plan, a negative or infinite input, an id past
    /// the table; and factors outside [0, 2).
    #[test]
    fn matte_bytes_refuse_what_the_rule_does_not_cover() {
        let m = Material { diffuse: [0.8; 3], reflect: 0.0 };
        let la = [0.2; 3];
        let rad = [1.0; 3];
        let ok = MatteBytes::new(&[m], &[MaterialModel::MATTE], la, rad, (false, false, false));
        assert!(ok.rgb(0, 0.5).is_some());
        assert_eq!(ok.rgb(1, 0.5), None);
        for e in [-0.5, -0.0, 2.0, f32::INFINITY, f32::NAN] {
            assert_eq!(ok.rgb(0, e), None, "{e}");
        }
        let lambert = MaterialModel { diffuse_model: DiffuseModel::Lambert, ..MaterialModel::MATTE };
        assert_eq!(MatteBytes::new(&[m], &[lambert], la, rad, (false, false, false)).rgb(0, 0.5), None);
        assert_eq!(MatteBytes::new(&[m], &[MaterialModel::MATTE], la, rad, (true, false, false)).rgb(0, 0.5), None);
        let textured = MaterialModel { texture: TextureKind::Checker, ..MaterialModel::MATTE };
        assert!(MatteBytes::new(&[m], &[textured], la, rad, (false, false, false)).rgb(0, 0.5).is_some());
        assert_eq!(MatteBytes::new(&[m], &[textured], la, rad, (false, true, false)).rgb(0, 0.5), None);
        let mirror = MaterialModel { reflect_mode: ReflectMode::Constant, ..MaterialModel::MATTE };
        assert_eq!(MatteBytes::new(&[m], &[mirror], la, rad, (false, false, true)).rgb(0, 0.5), None);
        let dark = Material { diffuse: [0.8, -0.1, 0.8], reflect: 0.0 };
        assert_eq!(MatteBytes::new(&[dark], &[MaterialModel::MATTE], la, rad, (false, false, false)).rgb(0, 0.5), None);
        let hot = [1.0, f32::INFINITY, 1.0];
        assert_eq!(MatteBytes::new(&[m], &[MaterialModel::MATTE], la, hot, (false, false, false)).rgb(0, 0.5), None);
    }
}

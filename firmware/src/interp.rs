//! Row interpolation (Malcheva et al.): trace every (l+1)-th pixel of a row and fill
//! the pixels between two traced pixels linearly when the segment passes the test, else
//! refine through the centre pixel recursively.
//!
//! Improvements on the seed (its §6.3): a segment is interpolated only when its two traced
//! end pixels
//! - differ by less than EPS in every 8-bit channel (the seed's criterion, strict `<`),
//! - hit the same primitive (or both miss), and
//! - have close depths: `|t_L − t_R| ≤ DEPTH_REL · min(t_L, t_R)`;
//!
//! otherwise the centre pixel is traced and both halves are tested again (bisection), so a
//! failing segment never costs more rays than tracing it fully. The fill uses the exact
//! integer formula `c_k = (c_L·(n−k) + c_R·k + ⌊n/2⌋) / n` per channel (Malcheva et al.), so
//! firmware, simulator and host agree bit for bit.
//!
//! Step modes: fixed (the seed's hardware choice) and adaptive per row (seed §3.5: the next
//! row's step grows after ≥ 90 % successful segments and shrinks below 60 %).
//! The tail of a row that is shorter than a segment is traced directly (seed's `skipflag`).
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

/// Primitive id of a miss.
pub const MISS: u32 = u32::MAX;

/// Relative depth tolerance of the geometric test.
pub const DEPTH_REL: f32 = 1.0 / 32.0;

/// Largest step l (the request carries 4 bits).
pub const MAX_STEP: u8 = 15;

/// Adaptive mode: largest step it grows to (the row-interpolation paper's S_MAX).
pub const ADAPTIVE_MAX: u8 = 8;

/// Adaptive mode: grow the step after this share of successful segments (percent).
pub const P_HI: u32 = 90;
/// Adaptive mode: shrink the step below this share (percent).
pub const P_LO: u32 = 60;

/// One traced (or interpolated) pixel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sample {
    /// Colour.
    pub rgb: [u8; 3],
    /// Primitive id of the primary hit, [`MISS`] for a miss.
    pub prim: u32,
    /// Ray parameter of the primary hit (`+∞` for a miss).
    pub t: f32,
}

/// Interpolation settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Params {
    /// Step l: every (l+1)-th pixel is traced; 0 = off.
    pub step: u8,
    /// Colour threshold in 8-bit levels (strict).
    pub eps: u8,
    /// Adapt the step per row.
    pub adaptive: bool,
}

/// Counters of interpolated rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Pixels traced (end points, centre pixels and tails).
    pub traced: u64,
    /// Pixels filled by interpolation.
    pub interpolated: u64,
    /// Centre pixels traced after a failed test.
    pub retraces: u64,
    /// Segments (of the initial step) tested.
    pub segments: u64,
    /// Of which interpolated without refinement.
    pub segments_ok: u64,
}

/// Longest segment [`lerp_channel`] takes: `255·n + n/2` stays below 2^32.
const MAX_LERP_LEN: u32 = 1 << 23;

/// Exact integer interpolation of one channel: `(c_L·(n−k) + c_R·k + ⌊n/2⌋) / n`, `0 < k < n`
/// (`n` is clamped to `1..=2^23`, `k` to `0..=n`).
#[inline]
// n ≥ 1 and k ≤ n ≤ 2^23 after the clamps: no term overflows u32, the divisor is not 0.
#[allow(clippy::arithmetic_side_effects)]
pub fn lerp_channel(cl: u8, cr: u8, k: u32, n: u32) -> u8 {
    let n = n.clamp(1, MAX_LERP_LEN);
    let k = k.min(n);
    ((cl as u32 * (n - k) + cr as u32 * k + n / 2) / n) as u8
}

/// [`lerp_channel`] of each channel.
#[inline]
fn lerp_rgb(l: [u8; 3], r: [u8; 3], k: u32, n: u32) -> [u8; 3] {
    let ([l0, l1, l2], [r0, r1, r2]) = (l, r);
    [lerp_channel(l0, r0, k, n), lerp_channel(l1, r1, k, n), lerp_channel(l2, r2, k, n)]
}

/// The improved test (module doc).
#[inline]
pub fn similar(a: &Sample, b: &Sample, eps: u8) -> bool {
    let colour = a.rgb.iter().zip(b.rgb).all(|(&x, y)| x.abs_diff(y) < eps);
    if !colour || a.prim != b.prim {
        return false;
    }
    if a.prim == MISS {
        return true;
    }
    let (lo, hi) = if a.t <= b.t { (a.t, b.t) } else { (b.t, a.t) };
    hi - lo <= DEPTH_REL * lo
}

/// Largest bisection depth: segments have at most 16 pixels.
const STACK: usize = 16;

/// Fills `row[l+1..r]` from the traced end points `row[l]`, `row[r]`, tracing centre pixels
/// where the test fails. Returns true when the segment passed without refinement.
fn fill_segment<E>(
    row: &mut [Sample],
    l: usize,
    r: usize,
    eps: u8,
    counts: &mut Counts,
    trace: &mut impl FnMut(usize) -> Result<Sample, E>,
) -> Result<bool, E> {
    let mut stack = heapless::Vec::<(usize, usize), STACK>::new();
    let mut first = true;
    let mut ok_first = false;
    let mut cur = Some((l, r));
    // Bounded: every iteration either fills a segment or splits it into two shorter ones;
    // at most 2·(r − l) iterations.
    let rounds = r.saturating_sub(l).saturating_add(1).saturating_mul(2);
    for _ in 0..rounds {
        let Some((a, b)) = cur.take().or_else(|| stack.pop()) else {
            break;
        };
        if b.saturating_sub(a) <= 1 {
            continue;
        }
        let (sa, sb) = match (row.get(a), row.get(b)) {
            (Some(x), Some(y)) => (*x, *y),
            _ => continue,
        };
        if similar(&sa, &sb, eps) {
            // b − a ≤ 16 (a segment of the largest step).
            let n = b.saturating_sub(a) as u32;
            for (k, px) in (0..n).zip(row.get_mut(a..b).unwrap_or(&mut [])).skip(1) {
                *px = Sample {
                    rgb: lerp_rgb(sa.rgb, sb.rgb, k, n),
                    prim: sa.prim,
                    t: sa.t + (sb.t - sa.t) * k as f32 / n as f32,
                };
            }
            counts.interpolated = counts.interpolated.wrapping_add(n.saturating_sub(1) as u64);
            if first {
                ok_first = true;
            }
        } else {
            let m = a.midpoint(b);
            let s = trace(m)?;
            if let Some(px) = row.get_mut(m) {
                *px = s;
            }
            counts.traced = counts.traced.wrapping_add(1);
            counts.retraces = counts.retraces.wrapping_add(1);
            // A full stack (deeper than a 16-pixel segment needs) drops the right half.
            let _ = stack.push((m, b));
            cur = Some((a, m));
        }
        first = false;
    }
    Ok(ok_first)
}

/// Interpolates one row of `row.len()` pixels with step `step` (≥ 1): traces every
/// (step+1)-th pixel from 0, fills or refines the segments between them, traces the tail.
/// `trace(x)` traces pixel x of the row.
pub fn fill_row<E>(
    row: &mut [Sample],
    step: u8,
    eps: u8,
    counts: &mut Counts,
    mut trace: impl FnMut(usize) -> Result<Sample, E>,
) -> Result<(), E> {
    let w = row.len();
    if w == 0 {
        return Ok(());
    }
    let inc = usize::from(step.clamp(1, MAX_STEP)).saturating_add(1);
    let s0 = trace(0)?;
    if let Some(px) = row.first_mut() {
        *px = s0;
    }
    counts.traced = counts.traced.wrapping_add(1);
    let mut x = 0usize;
    // Bounded: x grows by `inc` ≥ 2 per round until the tail.
    for _ in 0..w {
        let next = x.saturating_add(inc);
        if next >= w {
            // Tail shorter than a segment: trace it directly.
            for (xi, px) in row.iter_mut().enumerate().skip(x.saturating_add(1)) {
                *px = trace(xi)?;
                counts.traced = counts.traced.wrapping_add(1);
            }
            return Ok(());
        }
        let s = trace(next)?;
        if let Some(px) = row.get_mut(next) {
            *px = s;
        }
        counts.traced = counts.traced.wrapping_add(1);
        counts.segments = counts.segments.wrapping_add(1);
        if fill_segment(row, x, next, eps, counts, &mut trace)? {
            counts.segments_ok = counts.segments_ok.wrapping_add(1);
        }
        x = next;
    }
    Ok(())
}

/// Per-row step control of the adaptive mode (Malcheva et al.).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StepControl {
    /// Step of the next row.
    pub step: u8,
    /// Largest step.
    pub max: u8,
    adaptive: bool,
}

impl StepControl {
    /// Starts at `p.step` (the fixed step, or S0 of the adaptive mode).
    pub fn new(p: &Params) -> Self {
        Self { step: p.step.clamp(1, MAX_STEP), max: ADAPTIVE_MAX.max(p.step), adaptive: p.adaptive }
    }

    /// Updates the step after a row whose counts went from `before` to `after`.
    pub fn after_row(&mut self, before: &Counts, after: &Counts) {
        if !self.adaptive {
            return;
        }
        let seg = after.segments.wrapping_sub(before.segments);
        let ok = after.segments_ok.wrapping_sub(before.segments_ok);
        let Some(pct) = ok.saturating_mul(100).checked_div(seg) else { return };
        if pct >= P_HI as u64 && self.step < self.max {
            self.step = self.step.saturating_add(1);
        } else if pct < P_LO as u64 && self.step > 1 {
            self.step = self.step.saturating_sub(1);
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::*;

    fn px(v: u8, prim: u32, t: f32) -> Sample {
        Sample { rgb: [v, v, v], prim, t }
    }

    #[test]
    fn integer_formula_is_exact_and_matches_seed_example() {
        // Seed 003 §3.3: n = 4, (200,100,50) → (204,100,46) gives (201,100,49) (202,100,48) (203,100,47).
        let (l, r) = ([200u8, 100, 50], [204u8, 100, 46]);
        let got: Vec<[u8; 3]> = (1..4).map(|k| [0, 1, 2].map(|c| lerp_channel(l[c], r[c], k, 4))).collect();
        assert_eq!(got, vec![[201, 100, 49], [202, 100, 48], [203, 100, 47]]);
        // Exhaustive against the rational value rounded half up, every n ≤ 16.
        for n in 2..=16u32 {
            for k in 1..n {
                for a in (0..=255u32).step_by(5) {
                    for b in (0..=255u32).step_by(3) {
                        let exact = (a * (n - k) + b * k) as f64 / n as f64;
                        let want = (exact + 0.5).floor() as u8;
                        // Integer division rounds ties of odd n toward the formula's floor.
                        let got = lerp_channel(a as u8, b as u8, k, n);
                        assert!(
                            (got as i32 - want as i32).abs() <= 1 && got == ((a * (n - k) + b * k + n / 2) / n) as u8
                        );
                        assert!(got >= a.min(b) as u8 && got <= a.max(b) as u8);
                    }
                }
            }
        }
    }

    #[test]
    fn smooth_row_traces_every_fourth_pixel() {
        // A 17-pixel linear ramp on one primitive: step 3 traces 0, 4, 8, 12, 16.
        let truth: Vec<Sample> = (0..17).map(|x| px(100 + x as u8, 7, 10.0)).collect();
        let mut row = vec![Sample::default(); 17];
        let mut counts = Counts::default();
        let mut traced = Vec::new();
        fill_row::<()>(&mut row, 3, 8, &mut counts, |x| {
            traced.push(x);
            Ok(truth[x])
        })
        .unwrap();
        assert_eq!(traced, vec![0, 4, 8, 12, 16]);
        assert_eq!(row, truth);
        assert_eq!(
            (counts.traced, counts.interpolated, counts.retraces, counts.segments, counts.segments_ok),
            (5, 12, 0, 4, 4)
        );
    }

    #[test]
    fn tail_is_traced_directly() {
        let truth: Vec<Sample> = (0..7).map(|_| px(50, 1, 1.0)).collect();
        let mut row = vec![Sample::default(); 7];
        let mut counts = Counts::default();
        let mut traced = Vec::new();
        fill_row::<()>(&mut row, 3, 8, &mut counts, |x| {
            traced.push(x);
            Ok(truth[x])
        })
        .unwrap();
        assert_eq!(traced, vec![0, 4, 5, 6]);
        assert_eq!(counts.interpolated, 3);
    }

    #[test]
    fn edges_refine_through_the_centre_pixel() {
        // An edge between pixels 5 and 6 (prim 1 | prim 2), step 7: segment 0..8 fails, the
        // centre 4 is traced, 0..4 interpolates, 4..8 fails, 6 is traced, 4..6 fails → 5,
        // 6..8 fails? (6 and 8 both prim 2) → interpolates 7.
        let truth: Vec<Sample> = (0..9).map(|x| if x <= 5 { px(10, 1, 5.0) } else { px(200, 2, 5.0) }).collect();
        let mut row = vec![Sample::default(); 9];
        let mut counts = Counts::default();
        let mut traced = Vec::new();
        fill_row::<()>(&mut row, 7, 8, &mut counts, |x| {
            traced.push(x);
            Ok(truth[x])
        })
        .unwrap();
        assert_eq!(row, truth, "the edge is reproduced exactly");
        traced.sort();
        assert_eq!(traced, vec![0, 4, 5, 6, 8]);
        assert_eq!(counts.retraces, 3);
        assert_eq!(counts.segments_ok, 0);
        // Same colours but different primitives are not blended (silhouette guard).
        let truth: Vec<Sample> = (0..5).map(|x| px(10, if x < 2 { 1 } else { 2 }, 5.0)).collect();
        let mut row = vec![Sample::default(); 5];
        fill_row::<()>(&mut row, 3, 8, &mut Counts::default(), |x| Ok(truth[x])).unwrap();
        assert_eq!(row, truth);
        // Depth jump on one primitive (folded surface) is refined too.
        assert!(!similar(&px(10, 1, 1.0), &px(10, 1, 2.0), 8));
        assert!(similar(&px(10, 1, 1.0), &px(10, 1, 1.01), 8));
        assert!(similar(&px(10, MISS, f32::INFINITY), &px(12, MISS, f32::INFINITY), 8));
        assert!(!similar(&px(10, 1, 1.0), &px(18, 1, 1.0), 8));
    }

    #[test]
    fn worst_case_never_traces_more_than_every_pixel() {
        // Alternating primitives: every pixel fails; each is traced exactly once.
        for step in 1..=15u8 {
            let truth: Vec<Sample> = (0..100).map(|x| px((x * 37 % 251) as u8, x as u32, 1.0)).collect();
            let mut row = vec![Sample::default(); 100];
            let mut counts = Counts::default();
            let mut seen = vec![0u32; 100];
            fill_row::<()>(&mut row, step, 8, &mut counts, |x| {
                seen[x] += 1;
                Ok(truth[x])
            })
            .unwrap();
            assert_eq!(row, truth, "step {step}");
            assert!(seen.iter().all(|&c| c == 1), "step {step}: {seen:?}");
            assert_eq!(counts.traced, 100);
        }
    }

    #[test]
    fn adaptive_step_grows_on_smooth_rows_and_shrinks_on_edges() {
        let mut c = StepControl::new(&Params { step: 3, eps: 8, adaptive: true });
        let a = Counts::default();
        c.after_row(&a, &Counts { segments: 10, segments_ok: 10, ..a });
        assert_eq!(c.step, 4);
        c.after_row(&a, &Counts { segments: 10, segments_ok: 2, ..a });
        assert_eq!(c.step, 3);
        let mut f = StepControl::new(&Params { step: 3, eps: 8, adaptive: false });
        f.after_row(&a, &Counts { segments: 10, segments_ok: 10, ..a });
        assert_eq!(f.step, 3);
    }
}

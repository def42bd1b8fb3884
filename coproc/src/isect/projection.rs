//! The projection record, which Wald's and Hanika–Keller's tests share: both intersect the
//! triangle's plane first and decide inside/outside in the 2-D projection that drops the
//! normal's dominant axis r. The record is that axis word followed by nine values computed in
//! f64 from the vertices and rounded once to the format; the axis word is
//! 3 (`AXIS_DEGENERATE`) for a degenerate triangle (N = 0, or a coefficient not finite in f32)
//! and 4 (`AXIS_OVERFLOW`) for a record whose values overflow the fixed-point storage.
//! A kernel gives its nine values and its test ([`ProjectionTest`]); [`F32Projection`] and
//! [`FxProjection`] make it a [`Kernel`].

use core::marker::PhantomData;

use super::kernel::{Kernel, KernelKind, RecordStatus, Triangle};
use crate::numeric::{beyond, FixedFormat, FixedFrame, Fx, FxRay, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::Ray;

/// Words of a projection record: the axis word and nine values.
pub(crate) const WORDS: usize = 10;
/// Axis word of a degenerate triangle (0..=2 are projection axes).
pub(crate) const AXIS_DEGENERATE: u32 = 3;
/// Axis word of a record whose precomputed values overflowed the format.
pub(crate) const AXIS_OVERFLOW: u32 = 4;

/// A triangle's plane seen along the dominant axis of its normal `N = e1 × e2`, in f64.
#[derive(Debug, Clone, Copy)]
pub struct Projection {
    /// The dominant axis `r = argmax |N_i|`.
    pub r: usize,
    /// `r + 1 (mod 3)`.
    pub s: usize,
    /// `r + 2 (mod 3)` (cyclic, so that the projected area Δ = N_r).
    pub q: usize,
    /// `v1 − v0`.
    pub e1: [f64; 3],
    /// `v2 − v0`.
    pub e2: [f64; 3],
    /// `N_r`, non-zero and finite.
    pub nr: f64,
    /// `N_s / N_r`.
    pub ns: f64,
    /// `N_q / N_r`.
    pub nq: f64,
}

impl Projection {
    /// The projection of the triangle `v`; `None` when it is degenerate (N_r zero or not
    /// finite).
    fn of(v: [[f64; 3]; 3]) -> Option<Self> {
        let e1 = [v[1][0] - v[0][0], v[1][1] - v[0][1], v[1][2] - v[0][2]];
        let e2 = [v[2][0] - v[0][0], v[2][1] - v[0][1], v[2][2] - v[0][2]];
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        let r = if n[0].abs() >= n[1].abs() && n[0].abs() >= n[2].abs() {
            0
        } else if n[1].abs() >= n[2].abs() {
            1
        } else {
            2
        };
        let (s, q) = ((r + 1) % 3, (r + 2) % 3);
        let nr = n[r];
        if !(nr != 0.0 && nr.is_finite()) {
            return None;
        }
        Some(Self { r, s, q, e1, e2, nr, ns: n[s] / nr, nq: n[q] / nr })
    }
}

/// The axes `(r, s, q)` of a record's axis word; `None` for a degenerate or overflowed one.
#[inline(always)]
fn axes(r: u32) -> Option<(usize, usize, usize)> {
    match r {
        0 => Some((0, 1, 2)),
        1 => Some((1, 2, 0)),
        2 => Some((2, 0, 1)),
        _ => None,
    }
}

/// Per-ray data of the f32 projection tests: origin and direction as arrays (indexed by the
/// record's axes).
#[derive(Debug, Clone, Copy)]
pub struct ProjectionRay {
    pub(crate) o: [f32; 3],
    pub(crate) d: [f32; 3],
}

/// A projection test: its nine record values, where its plane is among them, and its inside
/// test of the plane's hit point.
pub trait ProjectionTest {
    /// The selector of the kernel.
    const KIND: KernelKind;
    /// Operations of one full f32 test.
    const OPS_F32: OpCount;
    /// Operations of one full fixed-point test.
    const OPS_FIXED: OpCount;
    /// Record words holding the plane's `n_s`, `n_q` and `n_d` (the plane step, `plane_t`).
    const PLANE: [usize; 3];

    /// The nine values after the axis word, in f64, for the triangle `v` projected by `p`.
    fn coefficients(p: &Projection, v: [[f64; 3]; 3]) -> [f64; 9];

    /// True when the plane's hit point at `t` lies inside the triangle; the record's values
    /// are `f32::from_bits(w[1..])`, its axes `axes`.
    fn inside_f32(ray: &ProjectionRay, axes: (usize, usize, usize), w: &[u32; WORDS], t: f32) -> bool;

    /// [`ProjectionTest::inside_f32`] in fixed point (values `Fx::from_word(w[1..])`, frame `t`).
    fn inside_fx<Q: FixedFormat>(
        ray: &FxRay<Q>,
        axes: (usize, usize, usize),
        w: &[u32; WORDS],
        t: Fx<Q>,
    ) -> Result<bool, Overflow>;
}

/// The plane step both tests share (Wald eq. 35): the distance along the ray to the plane
/// `x_r + n_s·x_s + n_q·x_q = n_d`, if it is above 0, finite and within `t_bound`.
#[inline(always)]
fn plane_t(
    ray: &ProjectionRay,
    (r, s, q): (usize, usize, usize),
    ns: f32,
    nq: f32,
    nd: f32,
    t_bound: f32,
) -> Option<f32> {
    let (o, d) = (&ray.o, &ray.d);
    let den = d[r] + ns * d[s] + nq * d[q];
    if den == 0.0 {
        return None;
    }
    let t = (nd - o[r] - ns * o[s] - nq * o[q]) / den;
    // `!(t > 0)` also rejects NaN.
    if !(t > 0.0) || t > t_bound || t == f32::INFINITY {
        return None;
    }
    Some(t)
}

/// [`plane_t`] in fixed point: the range test is done on the sign-normalised numerator
/// before the one division; the result is the frame `t`.
#[inline(always)]
fn fx_plane_t<Q: FixedFormat>(
    ray: &FxRay<Q>,
    (r, s, q): (usize, usize, usize),
    ns: Fx<Q>,
    nq: Fx<Q>,
    nd: Fx<Q>,
    t_bound: f32,
) -> Result<Option<Fx<Q>>, Overflow> {
    let (o, d) = (&ray.o, &ray.d);
    let den = (d[r] + ns * d[s] + nq * d[q]).ok()?;
    if den.is_zero() {
        return Ok(None);
    }
    let num = (nd - o[r] - ns * o[s] - nq * o[q]).ok()?;
    // Sign-normalise (den > 0) and cull the range before dividing.
    let (num, den) = if den.is_neg() { (-num, -den) } else { (num, den) };
    if !num.is_pos() || beyond(num, den, ray.bound(t_bound)) {
        return Ok(None);
    }
    let t = (num / den).ok()?;
    if !t.is_pos() {
        return Ok(None);
    }
    Ok(Some(t))
}

/// The record words of `rec`, `None` when it is too short.
#[inline(always)]
fn record(rec: &[u32]) -> Option<&[u32; WORDS]> {
    rec.get(..WORDS).and_then(|w| <&[u32; WORDS]>::try_from(w).ok())
}

/// A [`ProjectionTest`] in f32.
#[derive(Debug, Clone, Copy)]
pub struct F32Projection<T>(PhantomData<T>);

impl<T: ProjectionTest> Kernel for F32Projection<T> {
    const KIND: KernelKind = T::KIND;
    const FORMAT: NumberFormat = NumberFormat::F32;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = false;
    const OPS: OpCount = T::OPS_F32;
    type RayData = ProjectionRay;

    #[inline]
    fn prepare(ray: &Ray, _frame: &FixedFrame) -> Result<ProjectionRay, Overflow> {
        Ok(ProjectionRay { o: ray.origin.to_array(), d: ray.dir.to_array() })
    }

    fn precompute(tri: &Triangle, _frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        let v = tri.map(|p| p.to_array().map(|c| c as f64));
        let mut words = [0u32; WORDS];
        let coefficients = Projection::of(v).map(|p| (p.r, T::coefficients(&p, v)));
        let status = match coefficients {
            Some((r, vals)) if vals.iter().all(|x| (*x as f32).is_finite()) => {
                words[0] = r as u32;
                for (w, x) in words[1..].iter_mut().zip(vals) {
                    *w = (x as f32).to_bits();
                }
                RecordStatus::Ok
            }
            _ => {
                words[0] = AXIS_DEGENERATE;
                RecordStatus::Degenerate
            }
        };
        for (o, w) in out.iter_mut().zip(words) {
            *o = w;
        }
        status
    }

    #[inline]
    fn intersect(ray: &ProjectionRay, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(w) = record(rec) else { return Ok(None) };
        let Some(axes) = axes(w[0]) else { return Ok(None) };
        let f = |i: usize| f32::from_bits(w[i]);
        let [ns, nq, nd] = T::PLANE;
        let Some(t) = plane_t(ray, axes, f(ns), f(nq), f(nd), t_bound) else { return Ok(None) };
        Ok(T::inside_f32(ray, axes, w, t).then_some(t))
    }
}

/// A [`ProjectionTest`] in fixed-point format `Q` (frame coordinates, checked arithmetic).
#[derive(Debug, Clone, Copy)]
pub struct FxProjection<T, Q>(PhantomData<(T, Q)>);

impl<T: ProjectionTest, Q: FixedFormat> Kernel for FxProjection<T, Q> {
    const KIND: KernelKind = T::KIND;
    const FORMAT: NumberFormat = Q::FORMAT;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = false;
    const OPS: OpCount = T::OPS_FIXED;
    type RayData = FxRay<Q>;

    #[inline]
    fn prepare(ray: &Ray, frame: &FixedFrame) -> Result<FxRay<Q>, Overflow> {
        FxRay::new(frame, ray.origin.to_array(), ray.dir.to_array())
    }

    fn precompute(tri: &Triangle, frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        let v = tri.map(|p| frame.point(p.to_array()));
        let mut words = [0u32; WORDS];
        let status = match Projection::of(v) {
            None => {
                words[0] = AXIS_DEGENERATE;
                RecordStatus::Degenerate
            }
            Some(p) => {
                words[0] = p.r as u32;
                let mut status = RecordStatus::Ok;
                for (w, x) in words[1..].iter_mut().zip(T::coefficients(&p, v)) {
                    match Fx::<Q>::from_f64(x).to_word() {
                        Ok(x) => *w = x,
                        Err(Overflow) => status = RecordStatus::Overflow,
                    }
                }
                if status == RecordStatus::Overflow {
                    words[0] = AXIS_OVERFLOW;
                }
                status
            }
        };
        for (o, w) in out.iter_mut().zip(words) {
            *o = w;
        }
        status
    }

    #[inline]
    fn intersect(ray: &FxRay<Q>, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(w) = record(rec) else { return Ok(None) };
        let Some(axes) = axes(w[0]) else {
            return if w[0] == AXIS_OVERFLOW { Err(Overflow) } else { Ok(None) };
        };
        let f = |i: usize| Fx::<Q>::from_word(w[i]);
        let [ns, nq, nd] = T::PLANE;
        let Some(t) = fx_plane_t(ray, axes, f(ns), f(nq), f(nd), t_bound)? else { return Ok(None) };
        Ok(if T::inside_fx(ray, axes, w, t)? { ray.world_t(t) } else { None })
    }
}

//! The vertex record: the triangle's 9 vertex words, which the watertight, Möller–Trumbore
//! and Cramer kernels read (in f32 straight from the scene image, in fixed point from the
//! load-time table), and the one pair of [`Kernel`] impls for a test that needs no per-ray
//! setup beyond the ray itself ([`VertexTest`]: Möller–Trumbore, Cramer).

use core::marker::PhantomData;

use super::kernel::{Kernel, KernelKind, RecordStatus, Triangle};
use crate::numeric::{fx_point, FixedFormat, FixedFrame, Fx, Fx3, FxRay, NumberFormat, OpCount, Overflow};
use gridrt_shared::math::{Ray, Vec3};

/// Words of a vertex record.
pub(crate) const WORDS: usize = 9;

/// The 9 vertex floats of an f32 vertex record.
#[inline(always)]
pub(crate) fn f32_vertices(rec: &[u32]) -> Option<Triangle> {
    let w: &[u32; WORDS] = rec.get(..WORDS)?.try_into().ok()?;
    let f = f32::from_bits;
    Some([
        Vec3::new(f(w[0]), f(w[1]), f(w[2])),
        Vec3::new(f(w[3]), f(w[4]), f(w[5])),
        Vec3::new(f(w[6]), f(w[7]), f(w[8])),
    ])
}

/// Writes the 9 vertex floats (the f32 vertex record, identical to the image's words).
pub(crate) fn f32_vertices_precompute(tri: &Triangle, out: &mut [u32]) -> RecordStatus {
    let words = tri.iter().flat_map(|v| v.to_array()).map(f32::to_bits);
    for (o, w) in out.iter_mut().zip(words) {
        *o = w;
    }
    RecordStatus::Ok
}

/// Writes the 9 frame coordinates of the vertices as fixed-point words (fixed vertex
/// record); coordinates that do not fit are stored as poison and reported. A triangle whose
/// *quantised* vertices are collinear (checked exactly on the integers) is stored as a point
/// at the frame origin and reported degenerate: with per-product rounding, the sheared or
/// projected copies of collinear points need not stay collinear, but every kernel rejects a
/// point triangle exactly (all its edges are zero).
pub(crate) fn fx_vertices_precompute<Q: FixedFormat>(
    tri: &Triangle,
    frame: &FixedFrame,
    out: &mut [u32],
) -> RecordStatus {
    let p = tri.map(|v| fx_point::<Q>(frame, v.to_array()));
    let mut words = [0u32; WORDS];
    let mut status = RecordStatus::Ok;
    for (w, c) in words.iter_mut().zip(p.iter().flatten()) {
        *w = c.to_word().unwrap_or_else(|_| {
            status = RecordStatus::Overflow;
            i32::MIN as u32
        });
    }
    if status == RecordStatus::Ok {
        // Exact cross product of the integer edges (|raw| < 2^31: products fit i128).
        let r = p.map(|v| v.map(|c| c.raw() as i128));
        let e1 = [r[1][0] - r[0][0], r[1][1] - r[0][1], r[1][2] - r[0][2]];
        let e2 = [r[2][0] - r[0][0], r[2][1] - r[0][1], r[2][2] - r[0][2]];
        let n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]];
        if n == [0, 0, 0] {
            words = [0; WORDS];
            status = RecordStatus::Degenerate;
        }
    }
    for (o, w) in out.iter_mut().zip(words) {
        *o = w;
    }
    status
}

/// The vertices of a fixed vertex record (poison components for overflowed words).
#[inline(always)]
pub(crate) fn fx_vertices<Q: FixedFormat>(rec: &[u32]) -> Option<[Fx3<Q>; 3]> {
    let w: &[u32; WORDS] = rec.get(..WORDS)?.try_into().ok()?;
    let f = Fx::<Q>::from_word;
    Some([[f(w[0]), f(w[1]), f(w[2])], [f(w[3]), f(w[4]), f(w[5])], [f(w[6]), f(w[7]), f(w[8])]])
}

/// A ray–triangle test on the vertex record that takes the ray as it is (f32) or in frame
/// coordinates ([`FxRay`]): [`F32Vertices`] and [`FxVertices`] make it a [`Kernel`].
pub trait VertexTest {
    /// The selector of the kernel.
    const KIND: KernelKind;
    /// Operations of one full f32 test.
    const OPS_F32: OpCount;
    /// Operations of one full fixed-point test.
    const OPS_FIXED: OpCount;

    /// The f32 test (contract in the module doc of [`crate::isect`]).
    fn test_f32(ray: &Ray, tri: &Triangle, t_bound: f32) -> Option<f32>;

    /// The fixed-point test on the quantised vertices.
    fn test_fx<Q: FixedFormat>(ray: &FxRay<Q>, tri: [Fx3<Q>; 3], t_bound: f32) -> Result<Option<f32>, Overflow>;
}

/// A [`VertexTest`] in f32, reading the scene image's vertex words.
#[derive(Debug, Clone, Copy)]
pub struct F32Vertices<T>(PhantomData<T>);

impl<T: VertexTest> Kernel for F32Vertices<T> {
    const KIND: KernelKind = T::KIND;
    const FORMAT: NumberFormat = NumberFormat::F32;
    const RECORD_WORDS: usize = WORDS;
    const USES_IMAGE: bool = true;
    const OPS: OpCount = T::OPS_F32;
    type RayData = Ray;

    #[inline]
    fn prepare(ray: &Ray, _frame: &FixedFrame) -> Result<Ray, Overflow> {
        Ok(*ray)
    }

    fn precompute(tri: &Triangle, _frame: &FixedFrame, out: &mut [u32]) -> RecordStatus {
        f32_vertices_precompute(tri, out)
    }

    #[inline]
    fn intersect(ray: &Ray, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        Ok(f32_vertices(rec).and_then(|tri| T::test_f32(ray, &tri, t_bound)))
    }
}

/// A [`VertexTest`] in fixed-point format `Q`, reading the load-time table.
#[derive(Debug, Clone, Copy)]
pub struct FxVertices<T, Q>(PhantomData<(T, Q)>);

impl<T: VertexTest, Q: FixedFormat> Kernel for FxVertices<T, Q> {
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
        fx_vertices_precompute::<Q>(tri, frame, out)
    }

    #[inline]
    fn intersect(ray: &FxRay<Q>, rec: &[u32], t_bound: f32) -> Result<Option<f32>, Overflow> {
        let Some(tri) = fx_vertices::<Q>(rec) else { return Ok(None) };
        T::test_fx(ray, tri, t_bound)
    }
}

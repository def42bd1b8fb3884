//! The edge-sign filter: the first half of the watertight test (translate, permute, shear,
//! the three edge functions and their sign test) on eight triangles at once.
//!
//! It only *rejects*: a lane is dropped when all three edge functions are non-zero and do not
//! share a sign, which is exactly when the co-processor's kernel
//! (`gridrt_coproc::isect::watertight`) returns "no hit" at its sign test — the values are
//! computed with the same operations in the same order (no fused multiply-add except the two
//! of Kahan's `difference_of_products`, which are fused there too), so they are the same bits.
//! Every other lane (NaN, a zero edge function that the kernel would redo in f64, a real
//! candidate) is a survivor, and the kernel itself decides it. The filter therefore never
//! changes an answer; it saves the kernel call for the ~all triangles a ray does not pierce.

use gridrt_shared::math::{max_dimension, Ray};

/// Triangles per group.
pub(crate) const LANES: usize = 8;

/// Eight triangles, structure of arrays: `c[3·v + axis][lane]` is coordinate `axis` of vertex
/// `v` (the order of the scene image's 9 vertex words), with what a hit on each lane reports
/// beside them, so that testing a survivor and answering with it read only this group.
#[derive(Debug, Clone, Copy, Default)]
#[repr(C, align(32))]
pub(crate) struct Group {
    pub(crate) c: [[f32; LANES]; 9],
    pub(crate) prim: [u32; LANES],
    pub(crate) material: [u32; LANES],
    /// `geometric_normal` of each lane's record, per axis.
    pub(crate) normal: [[f32; LANES]; 3],
}

impl Group {
    /// The 9 vertex words of `lane` (the kernel's record).
    #[inline(always)]
    pub(crate) fn words(&self, lane: usize) -> [u32; 9] {
        core::array::from_fn(|k| self.c[k][lane].to_bits())
    }
}

/// What the filter needs of a ray: the kernel's axis permutation, the origin in permuted
/// order and the shear constants (`Watertight::prepare`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneRay {
    /// Source axes of the permuted x, y, z (cyclic, dominant direction axis last).
    perm: [usize; 3],
    o: [f32; 3],
    sx: f32,
    sy: f32,
}

impl LaneRay {
    /// The kernel's setup for `ray`: `kz` = the dominant axis of the direction (first of
    /// equals), `kx = kz + 1`, `ky = kx + 1` (mod 3), `sx = −d.x / d.z`, `sy = −d.y / d.z`.
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> Self {
        let perm = match max_dimension(ray.dir) {
            0 => [1, 2, 0],
            1 => [2, 0, 1],
            _ => [0, 1, 2],
        };
        let d = ray.dir.to_array();
        let o = ray.origin.to_array();
        let (dx, dy, dz) = (d[perm[0]], d[perm[1]], d[perm[2]]);
        Self { perm, o: [o[perm[0]], o[perm[1]], o[perm[2]]], sx: -dx / dz, sy: -dy / dz }
    }
}

/// Which lanes of a group survive the filter (bit i = lane i); all lanes are computed, the
/// caller masks off the unused ones.
pub(crate) trait LaneFilter {
    fn survivors(g: &Group, r: &LaneRay) -> u32;
}

/// `a·b − c·d` as `gridrt_shared::math::difference_of_products` computes it.
#[inline(always)]
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let dop = a.mul_add(b, -cd);
    let err = (-c).mul_add(d, cd);
    dop + err
}

/// One lane at a time, in plain Rust (any target; `mul_add` is the correctly rounded fused
/// multiply-add, as `libm::fmaf` is).
pub(crate) struct Portable;

impl LaneFilter for Portable {
    #[inline(always)]
    fn survivors(g: &Group, r: &LaneRay) -> u32 {
        let [kx, ky, kz] = r.perm;
        let mut keep = 0u32;
        for lane in 0..LANES {
            let v = |k: usize| g.c[k][lane];
            let mut p = [[0.0f32; 3]; 3];
            for (j, pj) in p.iter_mut().enumerate() {
                let x = v(3 * j + kx) - r.o[0];
                let y = v(3 * j + ky) - r.o[1];
                let z = v(3 * j + kz) - r.o[2];
                *pj = [x + r.sx * z, y + r.sy * z, z];
            }
            let e0 = difference_of_products(p[1][0], p[2][1], p[1][1], p[2][0]);
            let e1 = difference_of_products(p[2][0], p[0][1], p[2][1], p[0][0]);
            let e2 = difference_of_products(p[0][0], p[1][1], p[0][1], p[1][0]);
            let zero = e0 == 0.0 || e1 == 0.0 || e2 == 0.0;
            let mixed = (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0);
            if zero || !mixed {
                keep |= 1 << lane;
            }
        }
        keep
    }
}

/// AVX2 + FMA, eight lanes per instruction. Only called after runtime detection.
#[cfg(target_arch = "x86_64")]
pub(crate) struct Avx2;

#[cfg(target_arch = "x86_64")]
impl LaneFilter for Avx2 {
    #[inline(always)]
    fn survivors(g: &Group, r: &LaneRay) -> u32 {
        // SAFETY: `Avx2` is only used inside functions compiled with (and reached after
        // runtime detection of) the `avx2` and `fma` target features (`trace::Tracer`);
        // the loads read the 32-byte aligned rows of `g`.
        unsafe { avx2_survivors(g, r) }
    }
}

// Everything below is `#[target_feature]` + `#[inline]` (no closures), so it inlines into
// the AVX2 trace functions and the intrinsics compile to single instructions.

/// `difference_of_products(a, b, c, d)`: `cd = c·d; fma(a, b, −cd) + fma(−c, d, cd)`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn dop_avx2(
    a: core::arch::x86_64::__m256,
    b: core::arch::x86_64::__m256,
    c: core::arch::x86_64::__m256,
    d: core::arch::x86_64::__m256,
) -> core::arch::x86_64::__m256 {
    use core::arch::x86_64::*;
    let cd = _mm256_mul_ps(c, d);
    _mm256_add_ps(_mm256_fmsub_ps(a, b, cd), _mm256_fnmadd_ps(c, d, cd))
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
unsafe fn avx2_survivors(g: &Group, r: &LaneRay) -> u32 {
    use core::arch::x86_64::*;
    let [kx, ky, kz] = r.perm;
    let (ox, oy, oz) = (_mm256_set1_ps(r.o[0]), _mm256_set1_ps(r.o[1]), _mm256_set1_ps(r.o[2]));
    let (sx, sy) = (_mm256_set1_ps(r.sx), _mm256_set1_ps(r.sy));
    // Translate, permute, shear: x + sx·z and y + sy·z, each rounded twice like the kernel.
    let mut x = [_mm256_setzero_ps(); 3];
    let mut y = [_mm256_setzero_ps(); 3];
    for j in 0..3 {
        let px = _mm256_sub_ps(_mm256_load_ps(g.c[3 * j + kx].as_ptr()), ox);
        let py = _mm256_sub_ps(_mm256_load_ps(g.c[3 * j + ky].as_ptr()), oy);
        let pz = _mm256_sub_ps(_mm256_load_ps(g.c[3 * j + kz].as_ptr()), oz);
        x[j] = _mm256_add_ps(px, _mm256_mul_ps(sx, pz));
        y[j] = _mm256_add_ps(py, _mm256_mul_ps(sy, pz));
    }
    let e0 = dop_avx2(x[1], y[2], y[1], x[2]);
    let e1 = dop_avx2(x[2], y[0], y[2], x[0]);
    let e2 = dop_avx2(x[0], y[1], y[0], x[1]);
    let z = _mm256_setzero_ps();
    let zero = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(e0, z), _mm256_cmp_ps::<_CMP_EQ_OQ>(e1, z)),
        _mm256_cmp_ps::<_CMP_EQ_OQ>(e2, z),
    );
    let neg = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(e0, z), _mm256_cmp_ps::<_CMP_LT_OQ>(e1, z)),
        _mm256_cmp_ps::<_CMP_LT_OQ>(e2, z),
    );
    let pos = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(e0, z), _mm256_cmp_ps::<_CMP_GT_OQ>(e1, z)),
        _mm256_cmp_ps::<_CMP_GT_OQ>(e2, z),
    );
    // Rejected: mixed signs and no zero.
    let reject = _mm256_andnot_ps(zero, _mm256_and_ps(neg, pos));
    !(_mm256_movemask_ps(reject) as u32) & ((1 << LANES) - 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gridrt_shared::math::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Both filters give the same mask on random groups, including vertices shared between
    /// lanes and rays through them (edge functions exactly zero).
    /// The filter's defining property: a lane it rejects is one the co-processor's kernel
    /// misses. Rays aimed at points of edges shared by two triangles (where the edge functions
    /// are near zero and a rounding difference would flip a sign), at vertices, and inside.
    #[test]
    fn filter_rejects_only_what_the_kernel_misses() {
        use gridrt_coproc::isect::watertight::Watertight;
        use gridrt_coproc::{FixedFrame, Kernel};
        let mut rng = ChaCha8Rng::seed_from_u64(0xED6E);
        let (mut hits, mut near_edge) = (0, 0);
        for _ in 0..40_000 {
            let mut g = Group::default();
            let p = |rng: &mut ChaCha8Rng| {
                Vec3::new(rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0), rng.gen_range(-3.0..3.0))
            };
            // Lanes 0/1 share the edge a–b; the others are random.
            let (a, b, c, d) = (p(&mut rng), p(&mut rng), p(&mut rng), p(&mut rng));
            let mut tris = vec![[a, b, c], [b, a, d]];
            while tris.len() < LANES {
                tris.push([p(&mut rng), p(&mut rng), p(&mut rng)]);
            }
            for (lane, t) in tris.iter().enumerate() {
                for (v, pt) in t.iter().enumerate() {
                    for axis in 0..3 {
                        g.c[3 * v + axis][lane] = pt[axis];
                    }
                }
            }
            let s: f32 = rng.gen_range(0.0..1.0);
            let target = match rng.gen_range(0..3) {
                0 => a + (b - a) * s,
                1 => a,
                _ => (a + b + c) * (1.0 / 3.0),
            };
            let origin = p(&mut rng) * 3.0;
            let ray = Ray { origin, dir: target - origin };
            if !ray.is_valid() {
                continue;
            }
            let r = LaneRay::new(&ray);
            let pre = Watertight::prepare(&ray, &FixedFrame::IDENTITY).unwrap();
            let mut masks = vec![Portable::survivors(&g, &r)];
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                #[target_feature(enable = "avx2,fma")]
                unsafe fn avx2(g: &Group, r: &LaneRay) -> u32 {
                    Avx2::survivors(g, r)
                }
                // SAFETY: the features were detected just above.
                masks.push(unsafe { avx2(&g, &r) });
            }
            for (lane, t) in tris.iter().enumerate() {
                let words: Vec<u32> = t.iter().flat_map(|v| v.to_array()).map(f32::to_bits).collect();
                let hit = Watertight::intersect(&pre, &words, f32::INFINITY).unwrap();
                hits += hit.is_some() as u32;
                near_edge += (lane < 2 && hit.is_some()) as u32;
                for m in &masks {
                    assert!(
                        hit.is_none() || m & (1 << lane) != 0,
                        "lane {lane} rejected but hit at {hit:?}: {ray:?} {t:?}"
                    );
                }
            }
        }
        assert!(hits > 10_000 && near_edge > 10_000, "{hits} hits, {near_edge} at the shared edge");
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_filter_equals_portable_filter() {
        if !(std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")) {
            eprintln!("avx2_filter_equals_portable_filter: no AVX2+FMA on this CPU, only the portable filter runs");
            return;
        }
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2(g: &Group, r: &LaneRay) -> u32 {
            Avx2::survivors(g, r)
        }
        let mut rng = ChaCha8Rng::seed_from_u64(0xF117);
        let mut kept = 0;
        for _ in 0..20_000 {
            let mut g = Group::default();
            let shared = [rng.gen_range(-2.0f32..2.0), rng.gen_range(-2.0..2.0), rng.gen_range(-2.0..2.0)];
            for lane in 0..LANES {
                for k in 0..9 {
                    g.c[k][lane] = if rng.gen_bool(0.2) { shared[k % 3] } else { rng.gen_range(-2.0..2.0) };
                }
            }
            let origin = Vec3::new(rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0), rng.gen_range(-4.0..4.0));
            let target = if rng.gen_bool(0.5) { Vec3::from_array(shared) } else { Vec3::ZERO };
            let ray = Ray { origin, dir: target - origin };
            let r = LaneRay::new(&ray);
            // SAFETY: the features were detected above.
            let a = unsafe { avx2(&g, &r) };
            assert_eq!(a, Portable::survivors(&g, &r));
            kept += a.count_ones();
        }
        assert!(kept > 10_000, "{kept}");
    }
}

//! The reference's triangle BVH (median split) and the watertight ray–triangle test of Woop,
//! Benthin and Wald ("Watertight Ray/Triangle Intersection", JCGT 2013) in f64. It shares no
//! intersection or traversal code with the device path (uniform grid, co-processor kernels).
//!
//! Hit rule: the nearest hit with `t > 0` wins; equal `t` → lowest primitive id.

use super::vec3::sub;
use crate::scene::Mesh;

/// Largest triangle count of a BVH leaf.
const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f64; 3],
    max: [f64; 3],
    /// Leaf: first primitive slot; inner: index of the right child (left child = self + 1).
    index: u32,
    /// Leaf: primitive count (> 0); inner: 0.
    count: u32,
    /// Inner: split axis.
    axis: u8,
}

/// The triangles of a mesh in a BVH.
#[derive(Debug, Clone)]
pub struct TriangleBvh {
    tris: Vec<[[f64; 3]; 3]>,
    nodes: Vec<Node>,
    /// Primitive ids in BVH leaf order.
    order: Vec<u32>,
}

/// A closest hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter.
    pub t: f64,
    /// Primitive id.
    pub prim: u32,
}

fn bbox_of(tris: &[[[f64; 3]; 3]], ids: &[u32]) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for &i in ids {
        for p in &tris[i as usize] {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    (lo, hi)
}

impl TriangleBvh {
    /// Builds the BVH of `mesh`'s triangles (widened to f64).
    pub fn new(mesh: &Mesh) -> Self {
        let tris: Vec<[[f64; 3]; 3]> = mesh.triangles.iter().map(|t| t.v.map(|p| p.map(|c| c as f64))).collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * tris.len() / LEAF_SIZE + 1);
        let centroid = |i: u32, a: usize| {
            let t = &tris[i as usize];
            t[0][a] + t[1][a] + t[2][a]
        };
        // Iterative build: (node slot, range) work list.
        let mut work = vec![(usize::MAX, 0usize, order.len())];
        while let Some((parent, lo, hi)) = work.pop() {
            let me = nodes.len();
            if parent != usize::MAX {
                let p: &mut Node = &mut nodes[parent];
                p.index = me as u32;
            }
            let (bmin, bmax) = bbox_of(&tris, &order[lo..hi]);
            if hi - lo <= LEAF_SIZE {
                nodes.push(Node { min: bmin, max: bmax, index: lo as u32, count: (hi - lo) as u32, axis: 0 });
                continue;
            }
            let ext = [0, 1, 2].map(|a| bmax[a] - bmin[a]);
            let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
                0
            } else if ext[1] >= ext[2] {
                1
            } else {
                2
            };
            let mid = (lo + hi) / 2;
            order[lo..hi].select_nth_unstable_by(mid - lo, |&x, &y| centroid(x, axis).total_cmp(&centroid(y, axis)));
            nodes.push(Node { min: bmin, max: bmax, index: 0, count: 0, axis: axis as u8 });
            // Right child is patched when it is built; left child is built next (me + 1).
            work.push((me, mid, hi));
            work.push((usize::MAX, lo, mid));
        }
        Self { tris, nodes, order }
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Nearest hit with `0 < t < t_max` (ties → lowest prim id), or, with `any`, the first
    /// hit found.
    fn trace(&self, o: [f64; 3], d: [f64; 3], t_max: f64, any: bool) -> Option<Hit> {
        let inv = d.map(|c| 1.0 / c);
        let neg = [inv[0] < 0.0, inv[1] < 0.0, inv[2] < 0.0];
        let pre = WatertightRay::new(o, d);
        let mut best: Option<Hit> = None;
        let mut stack = [0u32; 128];
        let mut sp = 1usize;
        while sp > 0 {
            sp -= 1;
            let ni = stack[sp] as usize;
            let node = &self.nodes[ni];
            let limit = best.map_or(t_max, |h| h.t);
            if !slab_hit(node, o, inv, limit) {
                continue;
            }
            if node.count > 0 {
                for &prim in &self.order[node.index as usize..(node.index + node.count) as usize] {
                    if let Some(t) = pre.intersect(&self.tris[prim as usize], 0.0, t_max) {
                        let better = match best {
                            None => true,
                            Some(b) => t < b.t || (t == b.t && prim < b.prim),
                        };
                        if better {
                            best = Some(Hit { t, prim });
                            if any {
                                return best;
                            }
                        }
                    }
                }
            } else if sp + 2 <= stack.len() {
                // Visit the near child first.
                let (first, second) =
                    if neg[node.axis as usize] { (node.index, ni as u32 + 1) } else { (ni as u32 + 1, node.index) };
                stack[sp] = second;
                stack[sp + 1] = first;
                sp += 2;
            }
        }
        best
    }

    /// Nearest hit of the ray `o + t·d` with `0 < t < t_max`.
    pub fn closest_hit(&self, o: [f64; 3], d: [f64; 3], t_max: f64) -> Option<Hit> {
        self.trace(o, d, t_max, false)
    }

    /// True if anything is hit with `0 < t < t_max`.
    pub fn any_hit(&self, o: [f64; 3], d: [f64; 3], t_max: f64) -> bool {
        self.trace(o, d, t_max, true).is_some()
    }
}

/// Robust slab test (the far distance widened by `1 + 2γ(3)` in f64, pbrt-v4 style); NaN
/// from `0·∞` is discarded by the comparison order.
fn slab_hit(node: &Node, o: [f64; 3], inv: [f64; 3], t_max: f64) -> bool {
    const WIDEN: f64 = 1.0 + 2.0 * (3.0 * f64::EPSILON * 0.5) / (1.0 - 3.0 * f64::EPSILON * 0.5);
    let mut t0 = 0.0f64;
    let mut t1 = t_max;
    for a in 0..3 {
        let mut tn = (node.min[a] - o[a]) * inv[a];
        let mut tf = (node.max[a] - o[a]) * inv[a];
        if tn > tf {
            std::mem::swap(&mut tn, &mut tf);
        }
        tf *= WIDEN;
        if tn > t0 {
            t0 = tn;
        }
        if tf < t1 {
            t1 = tf;
        }
        if t0 > t1 {
            return false;
        }
    }
    true
}

/// Per-ray precomputation of the watertight test: axis permutation and shear.
pub(super) struct WatertightRay {
    o: [f64; 3],
    k: [usize; 3],
    s: [f64; 3],
}

impl WatertightRay {
    pub(super) fn new(o: [f64; 3], d: [f64; 3]) -> Self {
        // Permute so that z is the largest direction component; swap x/y to keep winding.
        let kz = if d[0].abs() >= d[1].abs() && d[0].abs() >= d[2].abs() {
            0
        } else if d[1].abs() >= d[2].abs() {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let s = [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]];
        Self { o, k: [kx, ky, kz], s }
    }

    /// `t` of the hit with `t_min < t < t_max`, both sides counted.
    pub(super) fn intersect(&self, tri: &[[f64; 3]; 3], t_min: f64, t_max: f64) -> Option<f64> {
        let [kx, ky, kz] = self.k;
        // Translate to the ray origin and shear so the ray is the +z axis.
        let rel = tri.map(|p| sub(p, self.o));
        let sh = rel.map(|p| [p[kx] - self.s[0] * p[kz], p[ky] - self.s[1] * p[kz]]);
        let (a, b, c) = (sh[0], sh[1], sh[2]);
        // Edge functions.
        let u = c[0] * b[1] - c[1] * b[0];
        let v = a[0] * c[1] - a[1] * c[0];
        let w = b[0] * a[1] - b[1] * a[0];
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 {
            return None;
        }
        // Scaled hit distance, then the division.
        let z = rel.map(|p| self.s[2] * p[kz]);
        let t_scaled = u * z[0] + v * z[1] + w * z[2];
        let t = t_scaled / det;
        (t > t_min && t < t_max).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use std::path::Path;

    fn brute_force(tris: &[[[f64; 3]; 3]], o: [f64; 3], d: [f64; 3]) -> Option<Hit> {
        let pre = WatertightRay::new(o, d);
        let mut best: Option<Hit> = None;
        for (i, t) in tris.iter().enumerate() {
            if let Some(t) = pre.intersect(t, 0.0, f64::INFINITY) {
                if best.is_none_or(|b| t < b.t) {
                    best = Some(Hit { t, prim: i as u32 });
                }
            }
        }
        best
    }

    #[test]
    fn bvh_matches_brute_force_on_the_bunny() {
        let mesh =
            crate::scene::load_mesh(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes/bun_zipper_res4.obj"))
                .unwrap();
        let b = mesh.bounds().unwrap();
        let scene = TriangleBvh::new(&mesh);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
        let c = b.center();
        let mut hits = 0;
        for _ in 0..2000 {
            let o = [0, 1, 2].map(|a| c[a] + rng.gen_range(-0.02..0.02));
            let d = [rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)];
            let got = scene.closest_hit(o, d, f64::INFINITY);
            let want = brute_force(&scene.tris, o, d);
            assert_eq!(got.map(|h| h.t), want.map(|h| h.t));
            hits += got.is_some() as u32;
        }
        assert!(hits > 500, "{hits}");
    }

    #[test]
    fn watertight_on_a_shared_edge() {
        // Two triangles sharing the diagonal of a unit square; rays through the diagonal
        // must hit exactly one of them or both, never neither.
        let tris =
            [[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]], [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]];
        for k in 0..=1000 {
            let s = k as f64 / 1000.0;
            let o = [s, s, 1.0];
            assert!(brute_force(&tris, o, [0.0, 0.0, -1.0]).is_some(), "lost hit at {s}");
            assert!(brute_force(&tris, o, [1e-3, -2e-3, -1.0]).is_some() || !(0.01..0.99).contains(&s));
        }
    }
}

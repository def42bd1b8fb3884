//! Normals of a cloud that has none (an `x y z`-only PLY file): each point's normal is the
//! direction its neighbourhood is thinnest in (principal component analysis of its
//! [`NORMAL_KNN`] nearest neighbours and itself: the eigenvector of the smallest eigenvalue of
//! their covariance), then the signs are made consistent (Hoppe et al. 1992): a minimum
//! spanning tree over the k-NN graph weighted by `1 − |nᵢ·nⱼ|`, grown from a seed on each
//! connected part — its point farthest from the part's centroid, turned away from it — and
//! every point turned to agree with its parent in the tree.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::knn;

/// Neighbours the normal is fitted to.
pub const NORMAL_KNN: usize = 12;

/// One unit normal per point of `pos`, consistently oriented (outward on a closed surface).
pub fn estimate(pos: &[[f32; 3]]) -> Result<Vec<[f32; 3]>, String> {
    let n = pos.len();
    if n < 3 {
        return Err(format!(
            "a point cloud without per-vertex normals (nx ny nz) needs at least 3 points to estimate them, it has {n}"
        ));
    }
    let nb = knn::nearest(pos, NORMAL_KNN)?;
    let p64 = |i: usize| pos[i].map(f64::from);
    let mut normals: Vec<[f64; 3]> = (0..n)
        .map(|i| {
            let pts: Vec<[f64; 3]> = std::iter::once(p64(i)).chain(nb.of(i).map(|(j, _)| p64(j))).collect();
            smallest_axis(&covariance(&pts))
        })
        .collect();
    if flat_as_a_line(pos) {
        return Err("the points lie on a line: no normals (nx ny nz) to estimate".into());
    }
    orient(pos, &nb, &mut normals);
    Ok(normals.iter().map(|v| v.map(|c| c as f32)).collect())
}

/// Covariance of `pts` about their mean.
fn covariance(pts: &[[f64; 3]]) -> [[f64; 3]; 3] {
    let m = pts.len() as f64;
    let mut mean = [0.0; 3];
    for p in pts {
        for a in 0..3 {
            mean[a] += p[a] / m;
        }
    }
    let mut c = [[0.0; 3]; 3];
    for p in pts {
        let d = [p[0] - mean[0], p[1] - mean[1], p[2] - mean[2]];
        for a in 0..3 {
            for b in 0..3 {
                c[a][b] += d[a] * d[b] / m;
            }
        }
    }
    c
}

/// Eigenvalues and eigenvectors (columns of the second) of a symmetric 3×3 matrix, by
/// cyclic Jacobi rotations.
fn eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..32 {
        let off = a[0][1].abs() + a[0][2].abs() + a[1][2].abs();
        let scale = a[0][0].abs() + a[1][1].abs() + a[2][2].abs();
        if off <= 1e-15 * scale || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with J the rotation in the (p, q) plane.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * row_p[k] - s * row_q[k]);
            a[q] = std::array::from_fn(|k| s * row_p[k] + c * row_q[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

/// Unit eigenvector of the smallest eigenvalue.
fn smallest_axis(c: &[[f64; 3]; 3]) -> [f64; 3] {
    let (w, v) = eigen(*c);
    let i = (0..3).min_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0);
    let e = [v[0][i], v[1][i], v[2][i]];
    let l = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        e.map(|x| x / l)
    } else {
        [0.0, 1.0, 0.0]
    }
}

/// Whether the whole cloud spreads along one direction only (no plane to fit anywhere).
fn flat_as_a_line(pos: &[[f32; 3]]) -> bool {
    let pts: Vec<[f64; 3]> = pos.iter().map(|p| p.map(f64::from)).collect();
    let (mut w, _) = eigen(covariance(&pts));
    w.sort_by(f64::total_cmp);
    w[1] <= 1e-12 * w[2]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Makes the signs of `normals` consistent (see the module docs).
fn orient(pos: &[[f32; 3]], nb: &knn::Neighbours, normals: &mut [[f64; 3]]) {
    let n = pos.len();
    // The symmetric k-NN graph.
    let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
    for i in 0..n {
        for (j, _) in nb.of(i) {
            adj[i].push(j as u32);
            adj[j].push(i as u32);
        }
    }
    for a in &mut adj {
        a.sort_unstable();
        a.dedup();
    }
    // Connected parts, each with its centroid and its seed.
    let mut part = vec![u32::MAX; n];
    let mut seeds = Vec::new();
    for start in 0..n {
        if part[start] != u32::MAX {
            continue;
        }
        let id = seeds.len() as u32;
        let mut members = vec![start];
        part[start] = id;
        let mut at = 0;
        while at < members.len() {
            let i = members[at];
            at += 1;
            for &j in &adj[i] {
                if part[j as usize] == u32::MAX {
                    part[j as usize] = id;
                    members.push(j as usize);
                }
            }
        }
        let mut c = [0.0; 3];
        for &i in &members {
            for a in 0..3 {
                c[a] += pos[i][a] as f64 / members.len() as f64;
            }
        }
        let d2 = |i: usize| (0..3).map(|a| (pos[i][a] as f64 - c[a]).powi(2)).sum::<f64>();
        let seed = members.iter().copied().max_by(|&a, &b| d2(a).total_cmp(&d2(b))).unwrap_or(start);
        let out = [0, 1, 2].map(|a| pos[seed][a] as f64 - c[a]);
        if dot(normals[seed], out) < 0.0 {
            normals[seed] = normals[seed].map(|x| -x);
        }
        seeds.push(seed);
    }
    // Prim's algorithm from every seed; weights in [0, 1] order like their bit patterns.
    let mut done = vec![false; n];
    let mut heap: BinaryHeap<Reverse<(u64, u32, u32)>> = BinaryHeap::new();
    for seed in seeds {
        done[seed] = true;
        let push = |heap: &mut BinaryHeap<Reverse<(u64, u32, u32)>>, normals: &[[f64; 3]], done: &[bool], i: usize| {
            for &j in &adj[i] {
                if !done[j as usize] {
                    let w = (1.0 - dot(normals[i], normals[j as usize]).abs()).max(0.0);
                    heap.push(Reverse((w.to_bits(), j, i as u32)));
                }
            }
        };
        push(&mut heap, normals, &done, seed);
        while let Some(Reverse((_, j, parent))) = heap.pop() {
            let j = j as usize;
            if done[j] {
                continue;
            }
            done[j] = true;
            if dot(normals[j], normals[parent as usize]) < 0.0 {
                normals[j] = normals[j].map(|x| -x);
            }
            push(&mut heap, normals, &done, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_finds_the_thin_axis() {
        // A plane z = 0.3x tilted, slightly thick.
        let pts: Vec<[f64; 3]> = (0..50)
            .map(|i| {
                let (x, y) = ((i % 7) as f64, (i / 7) as f64);
                [x, y, 0.3 * x + 1e-3 * ((i * 37) % 5) as f64]
            })
            .collect();
        let n = smallest_axis(&covariance(&pts));
        let want = [-0.3, 0.0, 1.0].map(|c: f64| c / 1.09f64.sqrt());
        assert!(dot(n, want).abs() > 0.999, "{n:?}");
    }

    #[test]
    fn a_sphere_gets_outward_normals() {
        let mut pos = Vec::new();
        for i in 0..2000 {
            // Fibonacci sphere, off centre.
            let z = 1.0 - 2.0 * (i as f64 + 0.5) / 2000.0;
            let t = i as f64 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            pos.push([(r * t.cos() + 3.0) as f32, (r * t.sin()) as f32, z as f32]);
        }
        let n = estimate(&pos).unwrap();
        for (p, n) in pos.iter().zip(&n) {
            let out = [p[0] as f64 - 3.0, p[1] as f64, p[2] as f64];
            assert!(dot(n.map(f64::from), out) > 0.95, "{p:?} {n:?}");
        }
    }

    #[test]
    fn too_few_or_collinear_points_are_errors() {
        assert!(estimate(&[[0.0; 3], [1.0, 0.0, 0.0]]).unwrap_err().contains("at least 3"));
        let line: Vec<[f32; 3]> = (0..10).map(|i| [i as f32, 2.0 * i as f32, 0.0]).collect();
        assert!(estimate(&line).unwrap_err().contains("line"));
    }
}

//! k nearest neighbours of every point of a cloud, found with a uniform grid: the density
//! radii and the normal estimate both use it.

use std::collections::HashMap;

/// Every point's `k` nearest other points, nearest first.
#[derive(Debug, Clone)]
pub struct Neighbours {
    /// Neighbours per point (`min(k, n − 1)`).
    pub k: usize,
    /// `k` indices per point.
    pub index: Vec<u32>,
    /// `k` squared distances per point, ascending.
    pub dist2: Vec<f64>,
    /// The grid's cell size (a length on the cloud's scale).
    pub cell: f64,
}

impl Neighbours {
    /// Point `i`'s neighbours: (index, squared distance), nearest first.
    pub fn of(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = i * self.k..(i + 1) * self.k;
        self.index[r.clone()].iter().map(|&j| j as usize).zip(self.dist2[r].iter().copied())
    }
}

/// The `k` nearest neighbours of every point (`k` is lowered to `n − 1`).
pub fn nearest(pos: &[[f32; 3]], k: usize) -> Result<Neighbours, String> {
    let n = pos.len();
    if n < 2 {
        return Err(format!("a radius from density needs at least 2 points, the cloud has {n}"));
    }
    let k = k.min(n - 1).max(1);
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in pos {
        for i in 0..3 {
            lo[i] = lo[i].min(p[i] as f64);
            hi[i] = hi[i].max(p[i] as f64);
        }
    }
    let diag = (0..3).map(|i| (hi[i] - lo[i]).powi(2)).sum::<f64>().sqrt();
    if diag.is_nan() || diag <= 0.0 {
        return Err("all points coincide: no density to derive radii from".into());
    }
    // About 4 points per cell on a surface spanning the box.
    let h = (diag * 2.0 / (n as f64).sqrt()).max(diag * 1e-6);
    let cell = |p: [f32; 3]| -> [i64; 3] { [0, 1, 2].map(|i| ((p[i] as f64 - lo[i]) / h).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    for (i, p) in pos.iter().enumerate() {
        grid.entry(cell(*p)).or_default().push(i as u32);
    }
    // Rings of cells around the point's cell; an isolated point (nothing within 16 cells)
    // falls back to a scan of the whole cloud, so outliers cost O(n), not O(rings³).
    let max_ring = ((diag / h).ceil() as i64 + 1).min(16);
    let consider = |best: &mut Vec<(f64, u32)>, p: [f32; 3], j: usize| {
        let q = pos[j];
        let d2: f64 = (0..3).map(|a| (q[a] as f64 - p[a] as f64).powi(2)).sum();
        if best.len() < k || d2 < best[k - 1].0 {
            let at = best.partition_point(|&(b, _)| b <= d2);
            best.insert(at, (d2, j as u32));
            best.truncate(k);
        }
    };
    let mut index = Vec::with_capacity(n * k);
    let mut dist2 = Vec::with_capacity(n * k);
    let mut best: Vec<(f64, u32)> = Vec::with_capacity(k + 1);
    for (i, &p) in pos.iter().enumerate() {
        let c = cell(p);
        best.clear();
        let mut done = false;
        for r in 0..=max_ring {
            for dx in -r..=r {
                for dy in -r..=r {
                    for dz in -r..=r {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != r {
                            continue;
                        }
                        let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) else { continue };
                        for &j in list.iter().filter(|&&j| j as usize != i) {
                            consider(&mut best, p, j as usize);
                        }
                    }
                }
            }
            // Every point of ring r + 1 is at least r·h away.
            if best.len() == k && best[k - 1].0 <= (r as f64 * h).powi(2) {
                done = true;
                break;
            }
        }
        if !done {
            best.clear();
            for j in (0..n).filter(|&j| j != i) {
                consider(&mut best, p, j);
            }
        }
        index.extend(best.iter().map(|b| b.1));
        dist2.extend(best.iter().map(|b| b.0));
    }
    Ok(Neighbours { k, index, dist2, cell: h })
}

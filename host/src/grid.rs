//! Uniform grid build: resolution (GridRT Eq. 6.1), triangle binning (exact SAT overlap on
//! padded voxel boxes), voxel→PE mapping, and the per-PE memory images.
//!
//! # Resolution (GridRT, Nery 2010: Eq. 6.1, after Suffern)
//! `s = cbrt(wx·wy·wz / n)`, `n_i = floor(m·w_i / s) + 1`, clamped to `1..=255` per axis
//! (255 keeps voxel ids below 2^24 and fits the header's u16 fields). `w` is the extent of the
//! mesh bounding box (before padding), `n` the triangle count and `m` the multiplier.
//! An axis whose extent is at most 2^-20 of the largest one is *flat*: it gets one voxel and is
//! left out of the product (the root becomes a square root for a planar scene), so a flat
//! scene does not divide by zero.
//!
//! # Grid box
//! The box sent to the device is the mesh bounding box grown on every side by
//! [`BOX_PAD_REL`] × the largest extent, rounded outward to f32. Geometry lying on the mesh
//! bounding box (the walls of a Cornell box) is then strictly inside the grid, and a flat axis
//! still has `min < max`.
//!
//! # Binning and padding
//! A triangle is listed in every voxel whose *padded* box it overlaps, by the separating-axis
//! test of Akenine-Möller ("Fast 3D Triangle-Box Overlap Testing", JGT 2001) evaluated in f64.
//! Each voxel box is grown by [`VOXEL_PAD_REL`] of its size plus 2^-20 of the coordinate
//! magnitude on every side. The firmware computes voxel boundaries and DDA distances in f32,
//! so a hit point on (or a few ulps from) a voxel face may be attributed to either neighbour;
//! the padding (≫ f32 rounding) makes every triangle that touches a face belong to both
//! neighbours, so such hits are never lost. The price is a few duplicate references for
//! triangles within 2^-10 of a cell from a face.
//!
//! # Voxel→PE mapping
//! Default [`PeMapping::Interleaved`]: `pe = (ix + iy + iz) mod N`. One DDA step changes
//! exactly one index by ±1, so consecutive voxels of a ray always belong to different PEs
//! (N ≥ 2) and, for a ray moving monotonically, any N consecutive voxels are on N distinct
//! PEs: the PEs named in a traversal list test in parallel instead of queueing on one PE.
//! [`PeMapping::Slabs`] (contiguous x-slabs, GridRT's spatial split) is available for
//! comparison. Empty voxels map to [`EMPTY_VOXEL`].
//!
//! # PE memory image
//! Exactly [`gridrt_shared::scene::PeImage`]: tag and counts, voxel table sorted by voxel id,
//! ref table, then each of the PE's triangles once (sorted by primitive id) and each of its
//! analytic primitives once, referenced by local index from every voxel that holds it.
//!
//! # Analytic primitives
//! [`build_with_prims`] also bins ViRAY's analytic primitives (global ids `T + i` after the
//! `T` triangles) by conservative bounds: a primitive is listed in every voxel whose padded
//! box overlaps its world AABB ([`AnalyticPrim::bounds`]: the image of the canonical box, for
//! a sphere the ellipsoid's exact box); disks and squares must in addition meet the padded
//! box with their plane (`|n·(c − p)| ≤ Σ|n_a|·h_a`). A scene-file *plane* is a square of
//! finite extent (docs/SCENE-FILE.md), so the grid box always contains every primitive and a
//! ray that misses the grid box misses the scene. Refs ≥ T name primitives.

use gridrt_shared::scene::{
    PrimRecord, TriangleRecord, EMPTY_VOXEL, MAX_PES, PE_HEADER_WORDS, PE_IMAGE_TAG, PRIM_WORDS, TRIANGLE_WORDS,
    VOXEL_ENTRY_WORDS,
};

use crate::scene::{AnalyticPrim, Bounds, Mesh};

/// Largest resolution per axis.
pub const MAX_DIM: u16 = 255;
/// Grid box padding per side, relative to the largest mesh extent.
pub const BOX_PAD_REL: f64 = 1e-4;
/// Voxel box padding per side, relative to the voxel size (2^-10).
pub const VOXEL_PAD_REL: f64 = 1.0 / 1024.0;
/// Absolute voxel padding per side, relative to the coordinate magnitude (2^-20).
pub const VOXEL_PAD_ABS_REL: f64 = 1.0 / 1_048_576.0;
/// An axis with extent ≤ this fraction of the largest extent counts as flat.
pub const FLAT_AXIS_REL: f64 = 1.0 / 1_048_576.0;
/// Voxels of the largest grid (255 per axis): as [`GridParams::max_voxels`], no cap, the
/// default. A smaller budget trades the soft-core's 3D-DDA steps for the co-processor's tests:
/// it pays where PE memory is fast (block RAM, the models' PEs), and costs a board whose PE
/// images sit in SDRAM behind caches (every test reads its record through them;
/// docs/bench-firmware.md, "Cost independent of mesh size").
pub const MAX_VOXELS: u32 = 255 * 255 * 255;

/// How voxels are assigned to PEs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PeMapping {
    /// `(ix + iy + iz) mod N`: consecutive voxels of a ray go to different PEs.
    #[default]
    Interleaved,
    /// `ix · N / nx`: N contiguous slabs along x.
    Slabs,
}

impl PeMapping {
    /// PE of voxel `(ix, iy, iz)` in a grid of `dims` with `pe_count` PEs.
    pub fn pe_of(self, ix: u32, iy: u32, iz: u32, dims: [u16; 3], pe_count: u16) -> u8 {
        let n = pe_count.max(1) as u32;
        let pe = match self {
            Self::Interleaved => (ix + iy + iz) % n,
            Self::Slabs => (ix * n / dims[0].max(1) as u32).min(n - 1),
        };
        pe as u8
    }
}

/// Parameters of a grid build.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridParams {
    /// Eq. 6.1 multiplier `m` (> 0).
    pub m: f64,
    /// Number of PEs (1..=255).
    pub pe_count: u16,
    /// Words of memory per PE.
    pub pe_mem_words: u32,
    /// Voxel→PE mapping.
    pub mapping: PeMapping,
    /// Fixed resolution instead of Eq. 6.1 (still clamped to 1..=255).
    pub dims_override: Option<[u16; 3]>,
    /// Most voxels of an Eq. 6.1 grid: a mesh whose grid would hold more gets a smaller `m`
    /// ([`resolution_within`]); `dims_override` is not capped. [`MAX_VOXELS`]: no cap.
    pub max_voxels: u32,
}

impl Default for GridParams {
    fn default() -> Self {
        Self {
            m: 1.0,
            pe_count: 4,
            pe_mem_words: 1 << 20,
            mapping: PeMapping::Interleaved,
            dims_override: None,
            max_voxels: MAX_VOXELS,
        }
    }
}

/// Why a grid could not be built.
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GridError {
    /// A PE's memory image does not fit its memory.
    #[error("scene too large: PE {pe} needs {needed_words} words but has {limit_words}; {hint}")]
    SceneTooLarge {
        /// The first PE that overflows.
        pe: u8,
        /// Words its image needs.
        needed_words: u64,
        /// Words it has.
        limit_words: u32,
        /// What to change.
        hint: String,
    },
    /// The PE count is 0 or above 255.
    #[error("PE count {0} out of range (1..=255)")]
    BadPeCount(u32),
    /// The multiplier is not a positive finite number.
    #[error("grid multiplier m = {0} must be positive and finite")]
    BadMultiplier(f64),
    /// The mesh has no triangles.
    #[error("cannot build a grid for an empty mesh")]
    EmptyMesh,
}

/// Eq. 6.1 resolution for `n` objects in a box of extents `w` with multiplier `m`.
pub fn resolution(w: [f64; 3], n: usize, m: f64) -> [u16; 3] {
    let wmax = w.iter().cloned().fold(0.0f64, f64::max);
    let usable = wmax > 0.0 && n > 0 && m > 0.0 && m.is_finite();
    if !usable {
        return [1, 1, 1];
    }
    let solid: Vec<usize> = (0..3).filter(|&i| w[i] > wmax * FLAT_AXIS_REL).collect();
    let volume: f64 = solid.iter().map(|&i| w[i]).product();
    let s = (volume / n as f64).powf(1.0 / solid.len() as f64);
    let mut dims = [1u16; 3];
    for &i in &solid {
        let v = (m * w[i] / s).floor() + 1.0;
        dims[i] = v.clamp(1.0, MAX_DIM as f64) as u16;
    }
    dims
}

/// A built grid with its PE memory images.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Resolution.
    pub dims: [u16; 3],
    /// Padded grid box (what the scene header carries).
    pub bounds: Bounds,
    /// Unpadded mesh bounds.
    pub mesh_bounds: Bounds,
    /// Number of PEs.
    pub pe_count: u16,
    /// Words per PE memory the images were checked against.
    pub pe_mem_words: u32,
    /// Voxel→PE map, `nx·ny·nz` bytes, [`EMPTY_VOXEL`] for empty voxels.
    pub owners: Vec<u8>,
    /// Non-empty voxel ids, ascending.
    pub voxels: Vec<u32>,
    /// `voxel_tris[voxel_offsets[k]..voxel_offsets[k+1]]` are the primitive ids of `voxels[k]`.
    pub voxel_offsets: Vec<u32>,
    /// Primitive ids per non-empty voxel, ascending within a voxel.
    pub voxel_tris: Vec<u32>,
    /// PE memory images (one per PE, in PE order).
    pub pe_images: Vec<Vec<u32>>,
    /// Triangles stored per PE.
    pub pe_triangles: Vec<u32>,
    /// Total triangles of the mesh.
    pub triangle_count: u32,
    /// Analytic primitives (global ids `triangle_count..triangle_count + prim_count`).
    pub prim_count: u32,
}

impl Grid {
    /// Number of voxels.
    pub fn voxel_count(&self) -> u32 {
        self.dims.iter().map(|&d| d as u32).product()
    }
    /// Linear voxel id `ix + nx·(iy + ny·iz)`.
    pub fn voxel_id(&self, ix: u32, iy: u32, iz: u32) -> u32 {
        ix + self.dims[0] as u32 * (iy + self.dims[1] as u32 * iz)
    }
    /// Primitive ids listed in `voxel` (empty for an empty voxel).
    pub fn triangles_in(&self, voxel: u32) -> &[u32] {
        match self.voxels.binary_search(&voxel) {
            Ok(k) => &self.voxel_tris[self.voxel_offsets[k] as usize..self.voxel_offsets[k + 1] as usize],
            Err(_) => &[],
        }
    }
    /// Size of one voxel along each axis, in f64.
    pub fn cell_size(&self) -> [f64; 3] {
        let e = self.bounds.extent();
        [0, 1, 2].map(|i| e[i] / self.dims[i] as f64)
    }
    /// Total ray–voxel references (sum of list lengths).
    pub fn ref_count(&self) -> usize {
        self.voxel_tris.len()
    }
    /// Largest PE image in words.
    pub fn max_pe_words(&self) -> usize {
        self.pe_images.iter().map(Vec::len).max().unwrap_or(0)
    }
}

fn pad_bounds(b: &Bounds) -> Bounds {
    let wmax = b.extent().iter().cloned().fold(0.0f64, f64::max);
    let pad = BOX_PAD_REL * wmax;
    let mut out = *b;
    for i in 0..3 {
        let lo = b.min[i] as f64 - pad;
        let hi = b.max[i] as f64 + pad;
        // Round outward to f32.
        let mut flo = lo as f32;
        if flo as f64 > lo {
            flo = gridrt_shared::math::next_float_down(flo);
        }
        let mut fhi = hi as f32;
        if (fhi as f64) < hi {
            fhi = gridrt_shared::math::next_float_up(fhi);
        }
        if fhi <= flo {
            fhi = gridrt_shared::math::next_float_up(flo);
        }
        out.min[i] = flo;
        out.max[i] = fhi;
    }
    out
}

/// [`resolution`] with at most `max_voxels` voxels (at least 1): Eq. 6.1 at the largest
/// multiplier `m' ≤ m` whose grid fits. Eq. 6.1's dimensions never shrink as `m` grows, so a
/// bisection on `m'` finds it; a grid that fits at `m` is returned unchanged.
///
/// ```
/// use gridrt_host::grid::{resolution, resolution_within};
/// // The full Stanford bunny: Eq. 6.1 gives 45×45×35 = 70 875 voxels.
/// let w = [77.849503, 77.166809, 60.336647];
/// assert_eq!(resolution(w, 69_451, 1.0), [45, 45, 35]);
/// let capped = resolution_within(w, 69_451, 1.0, 2048);
/// assert!(capped.iter().map(|&d| d as u32).product::<u32>() <= 2048);
/// ```
pub fn resolution_within(w: [f64; 3], n: usize, m: f64, max_voxels: u32) -> [u16; 3] {
    let voxels = |d: [u16; 3]| d.iter().map(|&v| u64::from(v)).product::<u64>();
    let budget = u64::from(max_voxels.max(1));
    let full = resolution(w, n, m);
    if voxels(full) <= budget || !(m > 0.0 && m.is_finite()) {
        return full;
    }
    // resolution(w, n, lo) fits (m' = 0 is the 1×1×1 grid), resolution(w, n, hi) does not.
    let (mut lo, mut hi) = (0.0f64, m);
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if voxels(resolution(w, n, mid)) <= budget {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    resolution(w, n, lo)
}

/// Builds the grid, bins the triangles, maps voxels to PEs and lays out the PE images.
pub fn build(mesh: &Mesh, params: &GridParams) -> Result<Grid, GridError> {
    build_with_prims(mesh, &[], params)
}

/// [`build`] for triangles plus analytic primitives (module doc).
pub fn build_with_prims(mesh: &Mesh, prims: &[AnalyticPrim], params: &GridParams) -> Result<Grid, GridError> {
    if params.pe_count == 0 || params.pe_count as usize > MAX_PES {
        return Err(GridError::BadPeCount(params.pe_count as u32));
    }
    if !(params.m > 0.0 && params.m.is_finite()) {
        return Err(GridError::BadMultiplier(params.m));
    }
    let mesh_bounds = Bounds::of_geometry(mesh, prims).ok_or(GridError::EmptyMesh)?;
    let n_prims = mesh.triangles.len() + prims.len();
    let dims = match params.dims_override {
        Some(d) => d.map(|v| v.clamp(1, MAX_DIM)),
        None => resolution_within(mesh_bounds.extent(), n_prims, params.m, params.max_voxels),
    };
    let bounds = pad_bounds(&mesh_bounds);
    let gmin = bounds.min.map(|v| v as f64);
    let ext = bounds.extent();
    let cell = [0, 1, 2].map(|i| ext[i] / dims[i] as f64);
    let nx = dims[0] as u32;
    let ny = dims[1] as u32;

    // Bin: (voxel, prim) pairs, then sort into CSR.
    let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles.len() * 4);
    for (prim, tri) in mesh.triangles.iter().enumerate() {
        let v = tri.v.map(|p| p.map(|c| c as f64));
        let mut range = [(0u32, 0u32); 3];
        for a in 0..3 {
            let lo = v[0][a].min(v[1][a]).min(v[2][a]);
            let hi = v[0][a].max(v[1][a]).max(v[2][a]);
            let pad = cell[a] * VOXEL_PAD_REL + VOXEL_PAD_ABS_REL * (lo.abs().max(hi.abs()));
            let to_idx = |x: f64| (((x - gmin[a]) / cell[a]).floor().max(0.0) as u32).min(dims[a] as u32 - 1);
            range[a] = (to_idx(lo - pad), to_idx(hi + pad));
        }
        for iz in range[2].0..=range[2].1 {
            for iy in range[1].0..=range[1].1 {
                for ix in range[0].0..=range[0].1 {
                    let idx = [ix, iy, iz];
                    let mut center = [0.0; 3];
                    let mut half = [0.0; 3];
                    for a in 0..3 {
                        let lo = gmin[a] + idx[a] as f64 * cell[a];
                        let hi = gmin[a] + (idx[a] + 1) as f64 * cell[a];
                        let pad = cell[a] * VOXEL_PAD_REL + VOXEL_PAD_ABS_REL * lo.abs().max(hi.abs());
                        center[a] = 0.5 * (lo + hi);
                        half[a] = 0.5 * (hi - lo) + pad;
                    }
                    if tri_box_overlap(center, half, &v) {
                        pairs.push((ix + nx * (iy + ny * iz), prim as u32));
                    }
                }
            }
        }
    }
    let t_total = mesh.triangles.len() as u32;
    for (i, p) in prims.iter().enumerate() {
        let b = p.bounds();
        let plane = p.plane();
        let mut range = [(0u32, 0u32); 3];
        for a in 0..3 {
            let (lo, hi) = (b.min[a] as f64, b.max[a] as f64);
            let pad = cell[a] * VOXEL_PAD_REL + VOXEL_PAD_ABS_REL * (lo.abs().max(hi.abs()));
            let to_idx = |x: f64| (((x - gmin[a]) / cell[a]).floor().max(0.0) as u32).min(dims[a] as u32 - 1);
            range[a] = (to_idx(lo - pad), to_idx(hi + pad));
        }
        for iz in range[2].0..=range[2].1 {
            for iy in range[1].0..=range[1].1 {
                for ix in range[0].0..=range[0].1 {
                    if let Some((q, n)) = plane {
                        let idx = [ix, iy, iz];
                        let mut dist = 0.0;
                        let mut reach = 0.0;
                        for a in 0..3 {
                            let lo = gmin[a] + idx[a] as f64 * cell[a];
                            let hi = gmin[a] + (idx[a] + 1) as f64 * cell[a];
                            let pad = cell[a] * VOXEL_PAD_REL + VOXEL_PAD_ABS_REL * lo.abs().max(hi.abs());
                            dist += n[a] * (0.5 * (lo + hi) - q[a]);
                            reach += n[a].abs() * (0.5 * (hi - lo) + pad);
                        }
                        if dist.abs() > reach {
                            continue;
                        }
                    }
                    pairs.push((ix + nx * (iy + ny * iz), t_total + i as u32));
                }
            }
        }
    }
    pairs.sort_unstable();
    let mut voxels = Vec::new();
    let mut voxel_offsets = Vec::new();
    let mut voxel_tris = Vec::with_capacity(pairs.len());
    for &(vox, prim) in &pairs {
        if voxels.last() != Some(&vox) {
            voxels.push(vox);
            voxel_offsets.push(voxel_tris.len() as u32);
        }
        voxel_tris.push(prim);
    }
    voxel_offsets.push(voxel_tris.len() as u32);

    // Map voxels to PEs.
    let voxel_count = dims.iter().map(|&d| d as usize).product::<usize>();
    let mut owners = vec![EMPTY_VOXEL; voxel_count];
    let mut per_pe: Vec<Vec<usize>> = vec![Vec::new(); params.pe_count as usize];
    for (k, &vox) in voxels.iter().enumerate() {
        let ix = vox % nx;
        let iy = (vox / nx) % ny;
        let iz = vox / (nx * ny);
        let pe = params.mapping.pe_of(ix, iy, iz, dims, params.pe_count);
        owners[vox as usize] = pe;
        per_pe[pe as usize].push(k);
    }

    // Lay out PE images.
    let mut pe_images = Vec::with_capacity(per_pe.len());
    let mut pe_triangles = Vec::with_capacity(per_pe.len());
    let mut local = vec![u32::MAX; mesh.triangles.len() + prims.len()];
    let analytic = prims;
    for cells in &per_pe {
        let mut prims: Vec<u32> = cells
            .iter()
            .flat_map(|&k| voxel_tris[voxel_offsets[k] as usize..voxel_offsets[k + 1] as usize].iter().copied())
            .collect();
        prims.sort_unstable();
        prims.dedup();
        // Sorted ids put the triangles (< T) first, so local index i < T_local is a triangle
        // and T_local + j the j-th analytic primitive, as the ref table requires.
        for (i, &p) in prims.iter().enumerate() {
            local[p as usize] = i as u32;
        }
        let n_tris = prims.iter().filter(|&&p| p < t_total).count();
        let n_analytic = prims.len() - n_tris;
        let refs: usize = cells.iter().map(|&k| (voxel_offsets[k + 1] - voxel_offsets[k]) as usize).sum();
        let needed = PE_HEADER_WORDS
            + cells.len() * VOXEL_ENTRY_WORDS
            + refs
            + n_tris * TRIANGLE_WORDS
            + n_analytic * PRIM_WORDS;
        let mut words = Vec::with_capacity(needed);
        words.extend_from_slice(&[PE_IMAGE_TAG, n_tris as u32, cells.len() as u32, refs as u32, n_analytic as u32]);
        let mut first = 0u32;
        for &k in cells {
            let count = voxel_offsets[k + 1] - voxel_offsets[k];
            words.extend_from_slice(&[voxels[k], first, count]);
            first += count;
        }
        for &k in cells {
            for &p in &voxel_tris[voxel_offsets[k] as usize..voxel_offsets[k + 1] as usize] {
                words.push(local[p as usize]);
            }
        }
        for &p in &prims {
            if p < t_total {
                let t = &mesh.triangles[p as usize];
                words.extend_from_slice(&TriangleRecord { vertices: t.v, prim: p, material: t.material }.to_words());
            } else {
                let a = &analytic[(p - t_total) as usize];
                let rec = PrimRecord { kind: a.kind, prim: p, material: a.material, world_to_object: a.to_object };
                words.extend_from_slice(&rec.to_words());
            }
        }
        debug_assert_eq!(words.len(), needed);
        pe_triangles.push(prims.len() as u32);
        pe_images.push(words);
    }

    // Enforce the PE memory limit.
    if let Some((pe, img)) = pe_images.iter().enumerate().find(|(_, w)| w.len() as u64 > params.pe_mem_words as u64) {
        let total: u64 = pe_images.iter().map(|w| w.len() as u64).sum();
        let max = pe_images.iter().map(|w| w.len() as u64).max().unwrap_or(0);
        let hint = format!(
            "the largest PE image is {max} words and all {} PEs together need {total} words for {} triangles \
             (grid {}×{}×{}); use more PEs (--pes), larger PE memories (--pe-mem-words ≥ {max}), \
             or a coarser grid (smaller --grid-m) to store fewer duplicated triangles",
            params.pe_count,
            mesh.triangles.len(),
            dims[0],
            dims[1],
            dims[2]
        );
        return Err(GridError::SceneTooLarge {
            pe: pe as u8,
            needed_words: img.len() as u64,
            limit_words: params.pe_mem_words,
            hint,
        });
    }

    Ok(Grid {
        dims,
        bounds,
        mesh_bounds,
        pe_count: params.pe_count,
        pe_mem_words: params.pe_mem_words,
        owners,
        voxels,
        voxel_offsets,
        voxel_tris,
        pe_images,
        pe_triangles,
        triangle_count: mesh.triangles.len() as u32,
        prim_count: analytic.len() as u32,
    })
}

/// Triangle–box overlap by the separating-axis theorem (Akenine-Möller 2001): the box
/// `center ± half` and triangle `v` overlap unless one of 13 axes separates them (3 box
/// normals, the triangle normal, 9 edge × box-axis cross products). Touching counts as
/// overlap. Axes that degenerate to zero never separate, so the test errs on "overlap".
pub fn tri_box_overlap(center: [f64; 3], half: [f64; 3], v: &[[f64; 3]; 3]) -> bool {
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross =
        |a: [f64; 3], b: [f64; 3]| [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    // Move the box to the origin.
    let p = [sub(v[0], center), sub(v[1], center), sub(v[2], center)];
    let separates = |axis: [f64; 3]| {
        let (a, b, c) = (dot(p[0], axis), dot(p[1], axis), dot(p[2], axis));
        let r = half[0] * axis[0].abs() + half[1] * axis[1].abs() + half[2] * axis[2].abs();
        a.min(b).min(c) > r || a.max(b).max(c) < -r
    };
    // Box face normals (the triangle's AABB against the box).
    for a in 0..3 {
        let mut axis = [0.0; 3];
        axis[a] = 1.0;
        if separates(axis) {
            return false;
        }
    }
    // Triangle normal.
    let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
    if separates(cross(e[0], e[1])) {
        return false;
    }
    // Edge × box axis.
    for edge in e {
        for a in 0..3 {
            let mut unit = [0.0; 3];
            unit[a] = 1.0;
            if separates(cross(edge, unit)) {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Triangle, DEFAULT_MATERIAL};
    use gridrt_shared::scene::PeImage;
    use rand::{Rng, SeedableRng};
    use std::path::Path;

    fn scenes() -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/scenes")
    }

    fn mesh_of(tris: Vec<[[f32; 3]; 3]>) -> Mesh {
        Mesh::from_triangles(
            Path::new("t"),
            tris.into_iter().map(|v| Triangle { v, material: 0 }),
            vec![DEFAULT_MATERIAL],
        )
        .unwrap()
    }

    #[test]
    fn eq61_gives_45x45x35_for_the_full_bunny() {
        let mesh = crate::scene::load_mesh(&scenes().join("stanford-bunny.obj")).unwrap();
        assert_eq!(mesh.triangles.len(), 69_451);
        let dims = resolution(mesh.bounds().unwrap().extent(), mesh.triangles.len(), 1.0);
        assert_eq!(dims, [45, 45, 35]);
    }

    #[test]
    fn eq61_matches_the_thesis_extents() {
        // Seed 004 §2.2: (wx, wy, wz) = (77.849503, 77.166809, 60.336647), n = 69 451.
        assert_eq!(resolution([77.849503, 77.166809, 60.336647], 69_451, 1.0), [45, 45, 35]);
        // Clamping and flat axes.
        assert_eq!(resolution([1.0, 1.0, 1.0], 1 << 30, 1.0), [255, 255, 255]);
        assert_eq!(resolution([1.0, 1.0, 0.0], 100, 1.0), [11, 11, 1]);
        assert_eq!(resolution([0.0, 0.0, 0.0], 100, 1.0), [1, 1, 1]);
        assert_eq!(resolution([1.0, 1.0, 1.0], 1, 1.0), [2, 2, 2]);
    }

    fn voxels(d: [u16; 3]) -> u64 {
        d.iter().map(|&v| u64::from(v)).product()
    }

    /// The capped grid fits the budget, is nowhere finer than Eq. 6.1's at m, and no Eq. 6.1
    /// grid at a multiplier in (0, m] that fits holds more voxels; a grid that fits is left as
    /// Eq. 6.1 gives it.
    #[test]
    fn the_voxel_budget_keeps_the_largest_eq61_grid_that_fits() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x6121_D0C5);
        for _ in 0..400 {
            let w = [0, 1, 2].map(|_| if rng.gen_bool(0.1) { 0.0 } else { rng.gen_range(0.01..100.0) });
            let n = rng.gen_range(1..200_000usize);
            let m = rng.gen_range(0.1..3.0);
            let budget = rng.gen_range(1..20_000u32);
            let capped = resolution_within(w, n, m, budget);
            let full = resolution(w, n, m);
            if voxels(full) <= u64::from(budget) {
                assert_eq!(capped, full, "{w:?} {n} {m} {budget}");
                continue;
            }
            assert!(voxels(capped) <= u64::from(budget), "{w:?} {n} {m} {budget}: {capped:?}");
            assert!((0..3).all(|i| capped[i] <= full[i]));
            for k in 1..=200 {
                let d = resolution(w, n, m * k as f64 / 200.0);
                if voxels(d) <= u64::from(budget) {
                    assert!(voxels(d) <= voxels(capped), "{w:?} {n} {m} {budget}: {d:?} fits, {capped:?} kept");
                }
            }
        }
    }

    #[test]
    fn a_budget_caps_larger_bunnies_and_leaves_res4_alone() {
        let load = |f: &str| crate::scene::load_mesh(&scenes().join(f)).unwrap();
        let capped = GridParams { max_voxels: 2048, ..GridParams::default() };
        let full = build(&load("stanford-bunny.obj"), &capped).unwrap();
        assert_eq!(full.dims, [14, 13, 11]);
        assert!(voxels(full.dims) <= 2048);
        assert_eq!(build(&load("bun_zipper_res4.obj"), &capped).unwrap().dims, [11, 11, 9]);
        // bun_zipper_res3: Eq. 6.1 gives 18×17×14 = 4 284 voxels; by default nothing is capped.
        assert_eq!(build(&load("bun_zipper_res3.obj"), &capped).unwrap().dims, [14, 13, 11]);
        assert_eq!(build(&load("bun_zipper_res3.obj"), &GridParams::default()).unwrap().dims, [18, 17, 14]);
    }

    /// Independent exact overlap: clip the triangle polygon against the six slabs of the box
    /// (Sutherland–Hodgman); overlap iff something remains.
    fn clip_overlap(lo: [f64; 3], hi: [f64; 3], v: &[[f64; 3]; 3]) -> bool {
        let mut poly: Vec<[f64; 3]> = v.to_vec();
        for a in 0..3 {
            for (bound, keep_above) in [(lo[a], true), (hi[a], false)] {
                let inside = |p: &[f64; 3]| if keep_above { p[a] >= bound } else { p[a] <= bound };
                let mut out = Vec::new();
                for i in 0..poly.len() {
                    let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
                    if inside(&p) {
                        out.push(p);
                    }
                    if inside(&p) != inside(&q) {
                        let t = (bound - p[a]) / (q[a] - p[a]);
                        let mut r = [0.0; 3];
                        for k in 0..3 {
                            r[k] = p[k] + t * (q[k] - p[k]);
                        }
                        r[a] = bound;
                        out.push(r);
                    }
                }
                poly = out;
                if poly.is_empty() {
                    return false;
                }
            }
        }
        true
    }

    #[test]
    fn sat_binning_matches_brute_force_clipping() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5A7);
        let mut tris = Vec::new();
        for _ in 0..300 {
            let c: [f32; 3] = [rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0), rng.gen_range(-1.0..1.0)];
            let s: f32 = rng.gen_range(0.01..0.6);
            let t = [0, 1, 2].map(|_| [0, 1, 2].map(|a| c[a] + s * rng.gen_range(-1.0f32..1.0)));
            tris.push(t);
        }
        // Axis-aligned triangles lying exactly on voxel faces are the hard case.
        tris.push([[-1.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 0.0, 1.0]]);
        tris.push([[0.25, -1.0, -1.0], [0.25, 1.0, 0.0], [0.25, 0.0, 1.0]]);
        let mesh = mesh_of(tris);
        let grid = build(&mesh, &GridParams { dims_override: Some([8, 8, 8]), ..Default::default() }).unwrap();
        let cell = grid.cell_size();
        let gmin = grid.bounds.min.map(|v| v as f64);
        for iz in 0..8u32 {
            for iy in 0..8u32 {
                for ix in 0..8u32 {
                    let idx = [ix, iy, iz];
                    let lo = [0, 1, 2].map(|a| gmin[a] + idx[a] as f64 * cell[a]);
                    let hi = [0, 1, 2].map(|a| gmin[a] + (idx[a] + 1) as f64 * cell[a]);
                    let listed = grid.triangles_in(grid.voxel_id(ix, iy, iz));
                    for (p, t) in mesh.triangles.iter().enumerate() {
                        let v = t.v.map(|q| q.map(|c| c as f64));
                        let exact = clip_overlap(lo, hi, &v);
                        // Grow the box by more than the padding: anything listed must overlap it.
                        let g = 4.0 * VOXEL_PAD_REL;
                        let lo2 = [0, 1, 2].map(|a| lo[a] - g * cell[a] - 1e-9);
                        let hi2 = [0, 1, 2].map(|a| hi[a] + g * cell[a] + 1e-9);
                        let loose = clip_overlap(lo2, hi2, &v);
                        let is_listed = listed.contains(&(p as u32));
                        assert!(!exact || is_listed, "triangle {p} overlaps voxel {idx:?} but is not listed");
                        assert!(!is_listed || loose, "triangle {p} listed in voxel {idx:?} it does not touch");
                    }
                }
            }
        }
    }

    #[test]
    fn voxel_face_triangle_is_in_both_neighbours() {
        // A triangle in the plane x = 0.5 of a 2×1×1 grid over [0,1]: after box padding the
        // plane is close to, but not exactly on, the face; it must be listed where it lies and
        // every point of it must be in a listing voxel.
        let mesh = mesh_of(vec![
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
            [[0.5, 0.0, 0.0], [0.5, 1.0, 0.0], [0.5, 0.0, 1.0]],
        ]);
        let grid = build(&mesh, &GridParams { dims_override: Some([2, 1, 1]), ..Default::default() }).unwrap();
        assert!(grid.triangles_in(0).contains(&1) && grid.triangles_in(1).contains(&1));
    }

    #[test]
    fn pe_images_parse_and_store_each_triangle_once() {
        let mesh = crate::scene::load_mesh(&scenes().join("bun_zipper_res4.obj")).unwrap();
        let grid = build(&mesh, &GridParams { m: 2.0, ..Default::default() }).unwrap();
        assert_eq!(grid.pe_images.len(), 4);
        let mut seen_refs = 0;
        for (pe, words) in grid.pe_images.iter().enumerate() {
            let img = PeImage::parse(words).unwrap();
            let mut last = None;
            let prims: Vec<u32> = (0..img.triangle_count()).map(|i| img.triangle(i).unwrap().prim).collect();
            let mut dedup = prims.clone();
            dedup.dedup();
            assert_eq!(prims, dedup, "PE {pe} stores a triangle twice");
            for i in 0..img.voxel_count() {
                let (vox, first, count) = img.voxel_entry(i).unwrap();
                assert!(last < Some(vox), "voxel table not sorted");
                last = Some(vox);
                assert_eq!(grid.owners[vox as usize], pe as u8);
                let listed: Vec<u32> = img.ref_table()[first as usize..(first + count) as usize]
                    .iter()
                    .map(|&l| img.triangle(l as usize).unwrap().prim)
                    .collect();
                assert_eq!(listed, grid.triangles_in(vox));
                seen_refs += count as usize;
            }
        }
        assert_eq!(seen_refs, grid.ref_count());
        // Empty voxels are marked empty, non-empty ones are owned.
        for (v, &o) in grid.owners.iter().enumerate() {
            assert_eq!(o == EMPTY_VOXEL, grid.triangles_in(v as u32).is_empty());
        }
    }

    #[test]
    fn interleaved_mapping_alternates_along_every_axis() {
        let dims = [10, 10, 10];
        for n in [2u16, 3, 4, 7] {
            for (a, b) in [((3, 4, 5), (4, 4, 5)), ((3, 4, 5), (3, 5, 5)), ((3, 4, 5), (3, 4, 4))] {
                assert_ne!(
                    PeMapping::Interleaved.pe_of(a.0, a.1, a.2, dims, n),
                    PeMapping::Interleaved.pe_of(b.0, b.1, b.2, dims, n)
                );
            }
        }
    }

    #[test]
    fn pe_memory_overflow_is_a_clear_error() {
        let mesh = crate::scene::load_mesh(&scenes().join("bun_zipper_res4.obj")).unwrap();
        let err = build(&mesh, &GridParams { pe_count: 2, pe_mem_words: 1000, ..Default::default() }).unwrap_err();
        match &err {
            GridError::SceneTooLarge { pe, needed_words, limit_words, hint } => {
                assert_eq!(*pe, 0);
                assert!(*needed_words > 1000);
                assert_eq!(*limit_words, 1000);
                assert!(hint.contains("--pes"), "{hint}");
            }
            other => panic!("{other:?}"),
        }
        assert!(err.to_string().starts_with("scene too large: PE 0 needs"));
        assert!(matches!(
            build(&mesh, &GridParams { pe_count: 0, ..Default::default() }),
            Err(GridError::BadPeCount(0))
        ));
        assert!(matches!(
            build(&mesh, &GridParams { pe_count: 256, ..Default::default() }),
            Err(GridError::BadPeCount(256))
        ));
        assert!(matches!(
            build(&mesh, &GridParams { m: f64::NAN, ..Default::default() }),
            Err(GridError::BadMultiplier(_))
        ));
    }

    #[test]
    fn flat_scene_gets_a_valid_box() {
        let mesh = mesh_of(vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
        let grid = build(&mesh, &GridParams::default()).unwrap();
        assert!((0..3).all(|i| grid.bounds.min[i] < grid.bounds.max[i]));
        assert_eq!(grid.dims[2], 1);
    }
}

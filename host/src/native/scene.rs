//! The scene in the fast path's layout: built from the PE images and the voxel→PE map the
//! firmware uploads (see the module doc of `native`).

use gridrt_coproc::isect::geometric_normal;
use gridrt_firmware::dda::GridDesc;
use gridrt_shared::math::Vec3;
use gridrt_shared::scene::{PeImage, EMPTY_VOXEL, PRIM_WORDS, TRIANGLE_WORDS};

use super::dda::{GridWalk, NO_SPAN};
use super::filter::{Group, LANES};

/// Why a [`NativeScene`] could not be built: the inputs are not what a co-processor would
/// accept for the given map (the model would answer the same rays with an error word).
#[derive(Debug, Clone, thiserror::Error, PartialEq, Eq)]
pub enum NativeError {
    /// A PE image does not parse (`PeImage::parse`).
    #[error("PE {pe}: malformed image")]
    BadImage {
        /// The PE.
        pe: usize,
    },
    /// The voxel→PE map has a different length than the grid has voxels.
    #[error("voxel map has {have} entries, the grid has {want} voxels")]
    MapSize {
        /// Entries of the map.
        have: usize,
        /// Voxels of the grid.
        want: usize,
    },
    /// The map names a PE that has no image, or whose image lacks the voxel.
    #[error("voxel {voxel} is mapped to PE {pe}, which does not hold it")]
    NotHeld {
        /// The voxel.
        voxel: u32,
        /// The PE named by the map.
        pe: u8,
    },
}

/// One triangle: its record words and what a hit on it reports.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Slot {
    /// The 9 vertex words of the scene image (the watertight f32 kernel's record).
    pub(crate) words: [u32; 9],
    pub(crate) prim: u32,
    pub(crate) material: u16,
    /// `geometric_normal` of the record.
    pub(crate) normal: [f32; 3],
}

/// A reference of a voxel that holds analytic primitives (kept in the image's order).
#[derive(Debug, Clone, Copy)]
pub(crate) enum OrderedRef {
    /// Index into `slots`.
    Tri(u32),
    /// Index into `prims`.
    Prim(u32),
}

/// One non-empty voxel.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Span {
    /// Owning PE (the result's `pe`).
    pub(crate) pe: u8,
    /// References of the voxel (the PE's test count for it).
    pub(crate) refs: u32,
    /// First group and number of triangle lanes (`refs` when `ordered` is empty).
    pub(crate) group: u32,
    pub(crate) lanes: u32,
    /// Range in `ordered` when the voxel holds analytic primitives (then no groups).
    pub(crate) ordered: u32,
    pub(crate) ordered_len: u32,
}

/// The scene in the fast path's layout (module doc).
#[derive(Debug, Clone)]
pub struct NativeScene {
    pub(crate) walk: GridWalk,
    /// Per voxel: index into `spans`, or [`NO_SPAN`].
    pub(crate) cell_span: Vec<u32>,
    pub(crate) spans: Vec<Span>,
    pub(crate) groups: Vec<Group>,
    pub(crate) slots: Vec<Slot>,
    pub(crate) ordered: Vec<OrderedRef>,
    pub(crate) prims: Vec<[u32; PRIM_WORDS]>,
    /// AVX2 and FMA were detected at build time.
    pub(crate) avx2: bool,
}

impl NativeScene {
    /// Lays out the scene the firmware would walk (`grid`, voxel→PE map `owners`, as in
    /// `dda::build_list`) over the co-processor loaded with `pe_images` (PE p = image p).
    pub fn new(grid: &GridDesc, owners: &[u8], pe_images: &[impl AsRef<[u32]>]) -> Result<Self, NativeError> {
        let walk = GridWalk::new(grid);
        let voxel_count = walk.voxel_count();
        if owners.len() != voxel_count && walk.voxel_count() > 0 {
            return Err(NativeError::MapSize { have: owners.len(), want: voxel_count });
        }
        let images: Vec<PeImage<'_>> = pe_images
            .iter()
            .enumerate()
            .map(|(pe, w)| PeImage::parse(w.as_ref()).map_err(|_| NativeError::BadImage { pe }))
            .collect::<Result<_, _>>()?;

        // Triangles of every PE, slot = PE base + local index.
        let mut slots = Vec::new();
        let mut slot_base = Vec::with_capacity(images.len());
        let mut prims = Vec::new();
        let mut prim_base = Vec::with_capacity(images.len());
        for (pe, img) in images.iter().enumerate() {
            slot_base.push(slots.len() as u32);
            prim_base.push(prims.len() as u32);
            let words = pe_images[pe].as_ref();
            for i in 0..img.triangle_count() {
                let at = img.triangle_offset() + i * TRIANGLE_WORDS;
                let w = words.get(at..at + TRIANGLE_WORDS).ok_or(NativeError::BadImage { pe })?;
                let mut vw = [0u32; 9];
                vw.copy_from_slice(&w[..9]);
                let f = |k: usize| f32::from_bits(vw[k]);
                let tri = [Vec3::new(f(0), f(1), f(2)), Vec3::new(f(3), f(4), f(5)), Vec3::new(f(6), f(7), f(8))];
                let n = geometric_normal(&tri);
                slots.push(Slot { words: vw, prim: w[9], material: w[10] as u16, normal: [n.x, n.y, n.z] });
            }
            for i in 0..img.primitive_count() {
                let at = img.primitive_offset() + i * PRIM_WORDS;
                let w = words.get(at..at + PRIM_WORDS).ok_or(NativeError::BadImage { pe })?;
                let mut pw = [0u32; PRIM_WORDS];
                pw.copy_from_slice(w);
                prims.push(pw);
            }
        }

        // Each PE's voxel table, (voxel id, first ref, ref count), ids ascending (parse checked).
        let tables: Vec<Vec<(u32, u32, u32)>> = images
            .iter()
            .enumerate()
            .map(|(pe, img)| {
                (0..img.voxel_count())
                    .map(|i| img.voxel_entry(i))
                    .collect::<Option<Vec<_>>>()
                    .ok_or(NativeError::BadImage { pe })
            })
            .collect::<Result<_, _>>()?;

        let mut cell_span = vec![NO_SPAN; voxel_count];
        let mut spans = Vec::new();
        let mut groups = Vec::new();
        let mut ordered = Vec::new();
        for (voxel, &pe) in owners.iter().enumerate() {
            if pe == EMPTY_VOXEL {
                continue;
            }
            let voxel = voxel as u32;
            let not_held = NativeError::NotHeld { voxel, pe };
            let (Some(img), Some(entry)) = (images.get(pe as usize), tables.get(pe as usize)) else {
                return Err(not_held);
            };
            let (first, count) = match entry.binary_search_by_key(&voxel, |e| e.0) {
                Ok(i) => (entry[i].1 as usize, entry[i].2 as usize),
                Err(_) => return Err(not_held),
            };
            let refs = img.ref_table().get(first..first + count).ok_or(NativeError::BadImage { pe: pe as usize })?;
            let tris = img.triangle_count() as u32;
            let (sb, pb) = (slot_base[pe as usize], prim_base[pe as usize]);
            let mut span =
                Span { pe, refs: count as u32, group: groups.len() as u32, lanes: 0, ordered: 0, ordered_len: 0 };
            if refs.iter().any(|&r| r >= tris) {
                span.ordered = ordered.len() as u32;
                span.ordered_len = count as u32;
                ordered.extend(refs.iter().map(|&r| {
                    if r < tris {
                        OrderedRef::Tri(sb + r)
                    } else {
                        OrderedRef::Prim(pb + (r - tris))
                    }
                }));
            } else {
                span.lanes = count as u32;
                for chunk in refs.chunks(LANES) {
                    let mut g = Group::default();
                    for (lane, &r) in chunk.iter().enumerate() {
                        let slot = sb + r;
                        let s: &Slot = &slots[slot as usize];
                        g.prim[lane] = s.prim;
                        g.material[lane] = s.material as u32;
                        for (a, n) in s.normal.iter().enumerate() {
                            g.normal[a][lane] = *n;
                        }
                        for k in 0..9 {
                            g.c[k][lane] = f32::from_bits(s.words[k]);
                        }
                    }
                    groups.push(g);
                }
            }
            cell_span[voxel as usize] = spans.len() as u32;
            spans.push(span);
        }
        Ok(Self { walk, cell_span, spans, groups, slots, ordered, prims, avx2: simd_available() })
    }

    /// Builds the scene of a host grid (its box, resolution, voxel map and PE images).
    pub fn from_grid(grid: &crate::grid::Grid) -> Result<Self, NativeError> {
        Self::new(&grid_desc(grid), &grid.owners, &grid.pe_images)
    }

    /// Forces the portable filter even where AVX2 is available (tests, comparisons).
    pub fn set_portable(&mut self, portable: bool) {
        self.avx2 = !portable && simd_available();
    }

    /// True when traces use the AVX2 filter.
    pub fn uses_avx2(&self) -> bool {
        self.avx2
    }

    /// Bytes of the fast path's tables (voxel table, groups, triangle slots).
    pub fn table_bytes(&self) -> usize {
        use core::mem::size_of;
        self.cell_span.len() * 4
            + self.spans.len() * size_of::<Span>()
            + self.groups.len() * size_of::<Group>()
            + self.slots.len() * size_of::<Slot>()
            + self.ordered.len() * size_of::<OrderedRef>()
            + self.prims.len() * size_of::<[u32; PRIM_WORDS]>()
    }
}

/// The firmware's grid description of a host grid (what the scene header carries).
pub fn grid_desc(grid: &crate::grid::Grid) -> GridDesc {
    GridDesc {
        min: Vec3::from_array(grid.bounds.min),
        max: Vec3::from_array(grid.bounds.max),
        dims: grid.dims.map(|d| d as u32),
    }
}

/// AVX2 and FMA on this CPU.
fn simd_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

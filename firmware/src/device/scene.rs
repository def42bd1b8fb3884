//! The scene store and its loader: a `SceneBegin`/`SceneChunk` upload ([`Upload`]) streams
//! the scene image (SPEC.md §5) through `shared::scene`'s parser into a [`SceneSink`] that
//! keeps what rendering needs (grid, voxel → PE map, materials, objects, lighting:
//! [`SceneStore`]) and forwards each PE block to the co-processor as a LOAD_PE packet after
//! one CLEAR, checking every ACK.

use super::fail::Fail;
use crate::dda::{GridDesc, LightCells, VoxelMap, WalkGrid, MAX_GRID_DIM};
use crate::fsl::{FslLink, FslWord};
use crate::splat::PointSink;
use gridrt_shared::frame::Crc32Digest;
use gridrt_shared::fsl::{self as wire, op, FslError};
use gridrt_shared::math::Vec3;
use gridrt_shared::msg::DeviceInfo;
use gridrt_shared::scene::{
    LightingRecord, Material, MaterialModel, ObjectRecord, PointRecord, PointsHead, SceneError, SceneHeader, SceneSink,
    SceneStream, Unpacker, EMPTY_VOXEL,
};
use gridrt_shared::window::{Arrival, ReceiveWindow};

/// Receive window of a windowed upload (SPEC.md §3.14): how far past the next expected byte
/// a `SceneData` may reach. Bytes that arrive ahead of a gap wait in a buffer this large.
pub const UPLOAD_WINDOW: usize = 4096;

const _: () = assert!(UPLOAD_WINDOW.is_power_of_two() && UPLOAD_WINDOW <= u16::MAX as usize);

/// Image bytes that arrived ahead of a gap, at their offset modulo [`UPLOAD_WINDOW`].
pub(super) type Reorder = [u8; UPLOAD_WINDOW];

/// Vertex-cache entries of the compact upload decoder (SPEC.md §5.12): 4096 (48 KiB) with
/// the `compact-scene` feature, else none (compact streams are refused with `BadCompact`, and
/// `feature::COMPACT_SCENE` is not advertised).
pub const VERTEX_CACHE: usize = if cfg!(feature = "compact-scene") { 4096 } else { 0 };

/// Cells per cube-face edge of the shadow rays' light cells (`dda::LightCells`): 48 with the
/// `light-cells` feature (6·48² cells of [`LIGHT_CELL_VOXELS`] voxels, 1.4 MiB), else 0:
/// every shadow ray walks.
pub const LIGHT_CELLS: usize = if cfg!(feature = "light-cells") { 48 } else { 0 };

/// Voxels a light cell holds (a shadow ray whose list would need more walks).
pub const LIGHT_CELL_VOXELS: usize = 12;

/// Largest grid whose shadow rays use light cells: the build visits every voxel on three
/// faces and projects every column of every slab, about 150 instructions per voxel on
/// riscv32imac; on stanford-bunny's 45×45×35 grid that cost more than the walks it saved
/// (docs/bench-firmware.md, "Shadow rays from light cells").
pub const LIGHT_CELLS_MAX_VOXELS: usize = 8192;

/// Largest material table the device holds.
pub const MAX_MATERIALS: usize = 64;

/// The loaded scene as the device needs it for rendering.
pub(super) struct SceneStore<const N: usize> {
    /// A complete, verified scene is loaded (renders are accepted).
    pub(super) loaded: bool,
    /// Grid bounds and dimensions.
    pub(super) grid: GridDesc,
    /// The grid's walk constants (computed once per scene).
    pub(super) walk: WalkGrid,
    /// Voxels of the grid (the used prefix of `voxel_pe`).
    pub(super) voxels: usize,
    /// Owning PE of each voxel, or `EMPTY_VOXEL`.
    pub(super) voxel_pe: [u8; N],
    /// Occupancy ahead of each voxel (`dda::fill_ahead`), filled once the scene is complete;
    /// 0xFF (a walk never stops early) before.
    pub(super) ahead: [u8; N],
    /// Material table.
    pub(super) materials: heapless::Vec<Material, MAX_MATERIALS>,
    /// Shading models, parallel to `materials`.
    pub(super) material_model: heapless::Vec<MaterialModel, MAX_MATERIALS>,
    /// Object table (prim id ranges, texture spaces).
    pub(super) objects: heapless::Vec<ObjectRecord, MAX_OBJECTS>,
    /// Lighting record.
    pub(super) lighting: LightingRecord,
    /// The shadow rays' lists by direction from the frame's light, built at the first frame
    /// with shadows for that light (`Renderer::pixels`), cleared with each scene.
    pub(super) light_cells: LightCells<LIGHT_CELLS, LIGHT_CELL_VOXELS>,
}

impl<const N: usize> SceneStore<N> {
    /// The voxel map walks read: the grid's prefix of `voxel_pe`, with `ahead`.
    #[inline(always)]
    pub(super) fn map(&self) -> VoxelMap<'_> {
        VoxelMap {
            pe: self.voxel_pe.get(..self.voxels).unwrap_or(&[]),
            ahead: self.ahead.get(..self.voxels).unwrap_or(&[]),
        }
    }

    /// Builds `ahead` from the complete voxel map (scene load) and forgets the last scene's
    /// light cells.
    pub(super) fn fill_ahead(&mut self) {
        let pe = self.voxel_pe.get(..self.voxels).unwrap_or(&[]);
        crate::dda::fill_ahead(self.grid.dims, pe, &mut self.ahead);
        self.light_cells.clear();
    }

    /// No scene.
    #[inline(always)]
    pub(super) fn new() -> Self {
        let grid = GridDesc { min: Vec3::ZERO, max: Vec3::ONE, dims: [1; 3] };
        Self {
            loaded: false,
            grid,
            walk: WalkGrid::new(&grid),
            voxels: 0,
            voxel_pe: [EMPTY_VOXEL; N],
            ahead: [0xFF; N],
            materials: heapless::Vec::new(),
            material_model: heapless::Vec::new(),
            objects: heapless::Vec::new(),
            lighting: LightingRecord::default(),
            light_cells: LightCells::new(),
        }
    }
}

/// Largest object table the device holds.
pub const MAX_OBJECTS: usize = 64;

/// An upload in progress.
pub(super) struct Upload {
    /// Raw images pass through, compact streams are decoded (SPEC.md §5.12).
    unpack: Unpacker<VERTEX_CACHE>,
    stream: SceneStream,
    total_len: u32,
    /// CRC-32 of the whole image, from `SceneBegin` (it also names the upload in `SceneSack`).
    pub(super) crc: u32,
    digest: Crc32Digest,
    /// Offset of the next byte the parser expects.
    pub(super) next: u32,
    /// What has arrived, in order or ahead of a gap.
    pub(super) window: ReceiveWindow,
    /// Words of the current PE block still to forward (a block spans chunks).
    pe_words_left: u32,
}

impl Upload {
    /// The upload `SceneBegin` announced: `total_len` bytes whose CRC-32 is `crc`.
    pub(super) fn new(total_len: u32, crc: u32, window: u16) -> Self {
        Self {
            unpack: Unpacker::new(),
            stream: SceneStream::new(),
            total_len,
            crc,
            digest: Crc32Digest::default(),
            next: 0,
            window: ReceiveWindow::new(total_len, window),
            pe_words_left: 0,
        }
    }

    /// The image's length.
    pub(super) fn total_len(&self) -> u32 {
        self.total_len
    }

    /// True once every announced byte has been fed.
    pub(super) fn complete(&self) -> bool {
        self.next >= self.total_len
    }

    /// Takes the data frame `offset .. offset + data.len()` (any order inside the window):
    /// keeps its new bytes in `ahead` and feeds every byte that became contiguous through
    /// the parser. Returns what the frame did; `PastEnd` is refused as `TrailingBytes`.
    // The frame, the reorder buffer, and what `feed` needs to load PE blocks.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn receive<L: FslLink, const N: usize>(
        &mut self,
        offset: u32,
        data: &[u8],
        ahead: &mut Reorder,
        link: &mut L,
        polls: u32,
        store: &mut SceneStore<N>,
        points: &mut dyn crate::splat::PointSink,
        info: &DeviceInfo,
    ) -> Result<Arrival, (SceneError, Option<Fail>)> {
        let old_next = self.window.next();
        let len = u32::try_from(data.len()).unwrap_or(u32::MAX);
        let arrival = self.window.arrive(offset, len);
        match arrival {
            Arrival::PastEnd => return Err((SceneError::TrailingBytes, None)),
            a if !a.accepted() => return Ok(a),
            _ => {}
        }
        let skip = old_next.saturating_sub(offset) as usize;
        // In order with nothing waiting beyond it (the usual case): fed straight from the
        // frame, without a pass through `ahead`.
        if let Arrival::Advanced { from, to } = arrival {
            if offset <= from && u64::from(to) == u64::from(offset).saturating_add(data.len() as u64) {
                return self.feed(data.get(skip..).unwrap_or(&[]), link, polls, store, points, info).map(|()| arrival);
            }
        }
        // New bytes start at or after `old_next` and end within the window: each lands in its
        // own slot of `ahead` (offset modulo the window), never on a byte still waiting.
        let mut pos = offset.max(old_next) as usize;
        for &b in data.get(skip..).unwrap_or(&[]) {
            if let Some(slot) = ahead.get_mut(pos % UPLOAD_WINDOW) {
                *slot = b;
            }
            pos = pos.saturating_add(1);
        }
        if let Arrival::Advanced { from, to } = arrival {
            let (a, b) = ring_slices(ahead, from, to);
            self.feed(a, link, polls, store, points, info)?;
            self.feed(b, link, polls, store, points, info)?;
        }
        Ok(arrival)
    }

    /// Feeds the chunk at [`next`](Self::next) through the scene parser into `store` (the
    /// point section into `points`), forwarding PE blocks to the co-processor over `link`. On
    /// failure returns the scene error and, when the link or the co-processor caused it, that
    /// failure.
    pub(super) fn feed<L: FslLink, const N: usize>(
        &mut self,
        data: &[u8],
        link: &mut L,
        polls: u32,
        store: &mut SceneStore<N>,
        points: &mut dyn PointSink,
        info: &DeviceInfo,
    ) -> Result<(), (SceneError, Option<Fail>)> {
        let end = (self.next as u64).saturating_add(data.len() as u64);
        if end > self.total_len as u64 {
            return Err((SceneError::TrailingBytes, None));
        }
        self.digest.update(data);
        let total_len = self.total_len;
        let mut loader =
            Loader { link, store, points, info, polls, total_len, words_left: &mut self.pe_words_left, failure: None };
        let stream = &mut self.stream;
        let fed = self.unpack.feed(data, &mut |bytes, compact| {
            // A compact stream's image is as long as its compact header says (checked there).
            loader.total_len = if compact { 0 } else { total_len };
            stream.feed(bytes, &mut loader)
        });
        match fed {
            Ok(()) => {
                self.next = end as u32;
                Ok(())
            }
            Err(e) => Err((e, loader.failure.take())),
        }
    }

    /// Ends an upload that stopped inside a PE block: the co-processor still waits for the
    /// rest of that LOAD_PE packet and would take the next packet's words as its own (SPEC.md
    /// §4.5). One word with the control bit ends the packet; its one answer (the co-processor's
    /// ERROR for the short packet, or the answer it already had queued) is read and dropped.
    /// Link failures are ignored: the next upload's CLEAR reports a dead link.
    pub(super) fn close<L: FslLink>(&mut self, link: &mut L, polls: u32) {
        if core::mem::take(&mut self.pe_words_left) == 0 {
            return;
        }
        if link.put(FslWord::last(0), polls).is_ok() {
            let _ = link.get(polls);
        }
    }

    /// After the last byte: the stream has checked the body CRC and every ACK; this checks
    /// that the image ended where its header said and the whole-image CRC of `SceneBegin`.
    /// A compact stream must also have decoded to exactly its image (length and CRC-32).
    pub(super) fn finish(&mut self) -> Result<(), (SceneError, &'static str)> {
        let done = self.stream.is_done();
        let crc_ok = core::mem::take(&mut self.digest).finalize() == self.crc;
        if !done {
            Err((SceneError::Truncated, "scene image ended early"))
        } else if !crc_ok {
            Err((SceneError::BadCrc, "scene CRC differs from SceneBegin"))
        } else if let Err(e) = self.unpack.finish() {
            Err((e, "compact scene stream did not decode to its image"))
        } else {
            Ok(())
        }
    }
}

/// Bytes `from..to` (at most [`UPLOAD_WINDOW`] of them) of `ring`, in order: two slices when
/// they wrap around its end.
fn ring_slices(ring: &Reorder, from: u32, to: u32) -> (&[u8], &[u8]) {
    let n = (to.saturating_sub(from) as usize).min(UPLOAD_WINDOW);
    let start = from as usize % UPLOAD_WINDOW;
    let first = n.min(UPLOAD_WINDOW.saturating_sub(start));
    let a = ring.get(start..start.saturating_add(first)).unwrap_or(&[]);
    let b = ring.get(..n.saturating_sub(first)).unwrap_or(&[]);
    (a, b)
}

/// [`SceneSink`] that stores the header, voxel map and materials and forwards PE blocks to
/// the co-processor as LOAD_PE packets.
struct Loader<'a, L: FslLink, const N: usize> {
    link: &'a mut L,
    store: &'a mut SceneStore<N>,
    points: &'a mut dyn PointSink,
    info: &'a DeviceInfo,
    polls: u32,
    total_len: u32,
    words_left: &'a mut u32,
    /// Set when the co-processor or the link failed (the stream only sees `Rejected`).
    failure: Option<Fail>,
}

impl<L: FslLink, const N: usize> Loader<'_, L, N> {
    fn put(&mut self, word: FslWord, what: &'static str) -> Result<(), SceneError> {
        self.link.put(word, self.polls).map_err(|e| {
            self.failure = Some(Fail::link(e, what));
            SceneError::Rejected
        })
    }

    /// Reads the one-word answer to CLEAR / LOAD_PE: ACK, else the load fails.
    fn expect_ack(&mut self, what: &'static str) -> Result<(), SceneError> {
        match self.link.get(self.polls) {
            Ok(w) if wire::opcode(w.data) == op::ACK => Ok(()),
            Ok(w) => {
                self.failure = Some(Fail::Word(w.data, what));
                Err(SceneError::Rejected)
            }
            Err(e) => {
                self.failure = Some(Fail::link(e, what));
                Err(SceneError::Rejected)
            }
        }
    }
}

impl<L: FslLink, const N: usize> Loader<'_, L, N> {
    /// The answer to FRAME: ACK, or `UnknownOpcode` from a co-processor without a fixed-point
    /// frame (SPEC §4.6: both work); anything else fails the load.
    fn expect_frame_ack(&mut self) -> Result<(), SceneError> {
        match self.link.get(self.polls) {
            Ok(w) if wire::opcode(w.data) == op::ACK => Ok(()),
            Ok(w) if FslError::from_word(w.data).0 == FslError::UnknownOpcode && wire::opcode(w.data) == op::ERROR => {
                Ok(())
            }
            Ok(w) => {
                self.failure = Some(Fail::Word(w.data, "FRAME"));
                Err(SceneError::Rejected)
            }
            Err(e) => {
                self.failure = Some(Fail::link(e, "FRAME"));
                Err(SceneError::Rejected)
            }
        }
    }
}

impl<L: FslLink, const N: usize> SceneSink for Loader<'_, L, N> {
    fn header(&mut self, h: &SceneHeader) -> Result<(), SceneError> {
        let dims = h.dims.map(u32::from);
        if dims.iter().any(|&d| d > MAX_GRID_DIM) || h.voxel_count() as usize > N {
            return Err(SceneError::GridTooLarge);
        }
        if h.material_count as usize > MAX_MATERIALS {
            return Err(SceneError::TooManyMaterials);
        }
        let len_differs = self.total_len != 0 && h.total_len != self.total_len;
        if len_differs || (self.info.pe_count != 0 && h.pe_count > self.info.pe_count) {
            return Err(SceneError::BadHeader);
        }
        if self.info.pe_mem_words != 0 && h.pe_mem_words > self.info.pe_mem_words {
            return Err(SceneError::PeMemoryOverflow);
        }
        if h.object_count as usize > MAX_OBJECTS {
            return Err(SceneError::BadHeader);
        }
        self.store.grid = GridDesc { min: Vec3::from_array(h.bounds_min), max: Vec3::from_array(h.bounds_max), dims };
        self.store.walk = WalkGrid::new(&self.store.grid);
        self.store.voxels = h.voxel_count() as usize;
        // Only the grid's prefix is ever read (`SceneStore::map`); filling all N bytes of both
        // tables wrote 512 KiB per upload on the LiteX board (N = 2^18), whatever the grid.
        if let Some(pe) = self.store.voxel_pe.get_mut(..self.store.voxels) {
            pe.fill(EMPTY_VOXEL);
        }
        if let Some(ahead) = self.store.ahead.get_mut(..self.store.voxels) {
            ahead.fill(0xFF);
        }
        self.store.materials.clear();
        self.store.material_model.clear();
        self.store.objects.clear();
        self.store.lighting = LightingRecord::default();
        self.points.clear();
        // The co-processor's old scene goes now: CLEAR, FRAME (the grid box, from which a
        // fixed-point co-processor takes its frame), then one LOAD_PE per block.
        self.put(FslWord::last(wire::CLEAR_WORD), "CLEAR")?;
        self.expect_ack("CLEAR")?;
        let frame = wire::frame_packet(h.bounds_min, h.bounds_max);
        let last = frame.len().saturating_sub(1);
        for (i, &w) in frame.iter().enumerate() {
            self.put(FslWord { data: w, control: i == last }, "FRAME")?;
        }
        self.expect_frame_ack()
    }

    fn voxel_map(&mut self, first: u32, owners: &[u8]) -> Result<(), SceneError> {
        let start = first as usize;
        let end = start.checked_add(owners.len()).ok_or(SceneError::GridTooLarge)?;
        let dst = self.store.voxel_pe.get_mut(start..end).ok_or(SceneError::GridTooLarge)?;
        dst.copy_from_slice(owners);
        Ok(())
    }

    fn material(&mut self, _index: u16, m: Material) -> Result<(), SceneError> {
        self.store.materials.push(m).map_err(|_| SceneError::TooManyMaterials)
    }

    fn material_model(&mut self, _index: u16, m: MaterialModel) -> Result<(), SceneError> {
        self.store.material_model.push(m).map_err(|_| SceneError::TooManyMaterials)
    }

    fn object(&mut self, _index: u16, o: ObjectRecord) -> Result<(), SceneError> {
        self.store.objects.push(o).map_err(|_| SceneError::BadHeader)
    }

    fn lighting(&mut self, l: LightingRecord) -> Result<(), SceneError> {
        self.store.lighting = l;
        Ok(())
    }

    fn pe_begin(&mut self, pe: u8, words: u32) -> Result<(), SceneError> {
        *self.words_left = words;
        self.put(FslWord::data(wire::load_header(pe)), "LOAD_PE")?;
        let count = if words == 0 { FslWord::last(words) } else { FslWord::data(words) };
        self.put(count, "LOAD_PE")
    }

    fn pe_word(&mut self, word: u32) -> Result<(), SceneError> {
        *self.words_left = self.words_left.checked_sub(1).ok_or(SceneError::BadPeBlock)?;
        let w = if *self.words_left == 0 { FslWord::last(word) } else { FslWord::data(word) };
        self.put(w, "LOAD_PE")
    }

    fn pe_end(&mut self) -> Result<(), SceneError> {
        if *self.words_left != 0 {
            return Err(SceneError::BadPeBlock);
        }
        self.expect_ack("LOAD_PE")
    }

    fn points_begin(&mut self, head: &PointsHead) -> Result<(), SceneError> {
        self.points.begin(head)
    }

    fn point(&mut self, _index: u32, p: PointRecord) -> Result<(), SceneError> {
        self.points.push(&p)
    }
}

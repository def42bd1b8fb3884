//! Streaming parser of the scene image (SPEC.md §5): the device never holds the whole image;
//! [`SceneStream`] parses it byte by byte as chunks arrive and hands each piece to a
//! [`SceneSink`].

use super::geometry::ObjectRecord;
use super::header::SceneHeader;
use super::layout::{SceneError, EMPTY_VOXEL, HEADER_LEN, LIGHTING_LEN, MATERIAL_LEN, MATERIAL_MODEL_LEN, OBJECT_LEN};
use super::lights::LightingRecord;
use super::materials::{Material, MaterialModel};
use super::points::{scene_flags, PointRecord, PointsHead, POINTS_HEAD_LEN, POINT_LEN};
use crate::bytes::Reader;
use crate::frame::Crc32Digest;

/// Receiver of a streamed scene image. Every call may refuse with an error, which aborts
/// the stream. Calls arrive in this order: `header`, `voxel_map` (possibly in several pieces,
/// padding excluded), `material` × count, `material_model` × count, `object` × count,
/// `lighting`, then per PE `pe_begin`, `pe_word` × words, `pe_end`, and, when the header has
/// [`scene_flags::POINTS`], `points_begin` and `point` × count.
pub trait SceneSink {
    /// The validated header.
    fn header(&mut self, header: &SceneHeader) -> Result<(), SceneError>;
    /// Voxel-map bytes starting at voxel `first`.
    fn voxel_map(&mut self, first: u32, owners: &[u8]) -> Result<(), SceneError>;
    /// Material record `index`.
    fn material(&mut self, index: u16, material: Material) -> Result<(), SceneError>;
    /// Start of PE `pe`'s memory image of `words` words.
    fn pe_begin(&mut self, pe: u8, words: u32) -> Result<(), SceneError>;
    /// Next word of the current PE's memory image.
    fn pe_word(&mut self, word: u32) -> Result<(), SceneError>;
    /// End of the current PE's memory image.
    fn pe_end(&mut self) -> Result<(), SceneError>;
    /// Material model record `index` (after all colour records).
    fn material_model(&mut self, _index: u16, _model: MaterialModel) -> Result<(), SceneError> {
        Ok(())
    }
    /// Object record `index` (after the material models).
    fn object(&mut self, _index: u16, _object: ObjectRecord) -> Result<(), SceneError> {
        Ok(())
    }
    /// The lighting record (after the objects, before the PE blocks).
    fn lighting(&mut self, _lighting: LightingRecord) -> Result<(), SceneError> {
        Ok(())
    }
    /// The point section's head (after the last PE block; SPEC.md §5.10).
    fn points_begin(&mut self, _head: &PointsHead) -> Result<(), SceneError> {
        Ok(())
    }
    /// Point record `index`.
    fn point(&mut self, _index: u32, _point: PointRecord) -> Result<(), SceneError> {
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Header,
    VoxelMap,
    Materials,
    MaterialModels,
    Objects,
    Lighting,
    PeBlockHead,
    PeWords,
    PointsHead,
    Points,
    Done,
    Failed,
}

/// Largest record the stream stages (the material model record).
const STAGING_LEN: usize = if MATERIAL_MODEL_LEN > HEADER_LEN { MATERIAL_MODEL_LEN } else { HEADER_LEN };

/// Streaming parser of a scene image with O(1) memory (plus one 96-byte staging buffer).
#[derive(Debug)]
pub struct SceneStream {
    stage: Stage,
    staging: [u8; STAGING_LEN],
    staged: usize,
    header: Option<SceneHeader>,
    offset: u32,
    index: u32,
    next_pe: u16,
    words_left: u32,
    points_left: u32,
    crc: Crc32Digest,
}

impl Default for SceneStream {
    fn default() -> Self {
        Self::new()
    }
}

impl SceneStream {
    /// A parser waiting for the first header byte.
    pub fn new() -> Self {
        Self {
            stage: Stage::Header,
            staging: [0; STAGING_LEN],
            staged: 0,
            header: None,
            offset: 0,
            index: 0,
            next_pe: 0,
            words_left: 0,
            points_left: 0,
            crc: Crc32Digest::default(),
        }
    }

    /// Bytes consumed so far.
    pub fn offset(&self) -> u32 {
        self.offset
    }

    /// The header, once parsed.
    pub fn header(&self) -> Option<&SceneHeader> {
        self.header.as_ref()
    }

    /// True when the whole image was parsed and its CRC checked.
    pub fn is_done(&self) -> bool {
        self.stage == Stage::Done
    }

    /// Declares the input complete: `Ok` only if the whole image was parsed and checked,
    /// otherwise [`SceneError::Truncated`] (or the stream's earlier failure).
    pub fn finish(&self) -> Result<(), SceneError> {
        match self.stage {
            Stage::Done => Ok(()),
            Stage::Failed => Err(SceneError::Rejected),
            _ => Err(SceneError::Truncated),
        }
    }

    /// Feeds the next bytes of the image. After an error the stream stays failed.
    pub fn feed<S: SceneSink>(&mut self, mut bytes: &[u8], sink: &mut S) -> Result<(), SceneError> {
        if self.stage == Stage::Failed {
            return Err(SceneError::Rejected);
        }
        while !bytes.is_empty() {
            match self.step(&mut bytes, sink) {
                Ok(()) => {}
                Err(e) => {
                    self.stage = Stage::Failed;
                    return Err(e);
                }
            }
        }
        Ok(())
    }

    /// Stages up to `want` bytes; returns true when `want` bytes are staged.
    fn stage_bytes(&mut self, bytes: &mut &[u8], want: usize) -> bool {
        let need = want.saturating_sub(self.staged);
        let n = need.min(bytes.len());
        let (head, tail) = bytes.split_at(n);
        // staged + n ≤ want ≤ STAGING_LEN: the sums cannot overflow; `get_mut` checks the range.
        if let Some(dst) = self.staging.get_mut(self.staged..self.staged.saturating_add(n)) {
            dst.copy_from_slice(head);
        }
        if self.stage != Stage::Header {
            self.crc.update(head);
        }
        // A stream longer than 4 GiB saturates and then fails the total-length check.
        self.offset = self.offset.saturating_add(n as u32);
        self.staged = self.staged.saturating_add(n);
        *bytes = tail;
        self.staged >= want
    }

    fn step<S: SceneSink>(&mut self, bytes: &mut &[u8], sink: &mut S) -> Result<(), SceneError> {
        match self.stage {
            Stage::Header => {
                if self.stage_bytes(bytes, HEADER_LEN) {
                    let h = SceneHeader::parse(self.staging.get(..HEADER_LEN).unwrap_or(&[]))?;
                    sink.header(&h)?;
                    self.header = Some(h);
                    self.staged = 0;
                    self.stage = Stage::VoxelMap;
                    self.index = 0;
                }
            }
            Stage::VoxelMap => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                let total = h.voxel_map_len() as u32;
                let n = total.saturating_sub(self.index).min(bytes.len() as u32) as usize;
                let (head, tail) = bytes.split_at(n);
                let real = h.voxel_count();
                let useful = (real.saturating_sub(self.index) as usize).min(n);
                let owners = head.get(..useful).unwrap_or(&[]);
                if owners.iter().any(|&o| o != EMPTY_VOXEL && o as u16 >= h.pe_count) {
                    return Err(SceneError::BadVoxelMap);
                }
                if !owners.is_empty() {
                    sink.voxel_map(self.index, owners)?;
                }
                self.crc.update(head);
                self.offset = self.offset.saturating_add(n as u32);
                self.index = self.index.saturating_add(n as u32);
                *bytes = tail;
                if self.index == total {
                    self.index = 0;
                    self.stage = if h.material_count == 0 { Self::after_material_models(&h) } else { Stage::Materials };
                }
            }
            Stage::Materials => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, MATERIAL_LEN) {
                    let m = Material::parse(self.staging.get(..MATERIAL_LEN).unwrap_or(&[]))?;
                    sink.material(self.index as u16, m)?;
                    self.staged = 0;
                    self.index = self.index.saturating_add(1);
                    if self.index == h.material_count as u32 {
                        self.index = 0;
                        self.stage = Stage::MaterialModels;
                    }
                }
            }
            Stage::MaterialModels => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, MATERIAL_MODEL_LEN) {
                    let m = MaterialModel::parse(self.staging.get(..MATERIAL_MODEL_LEN).unwrap_or(&[]))?;
                    sink.material_model(self.index as u16, m)?;
                    self.staged = 0;
                    self.index = self.index.saturating_add(1);
                    if self.index == h.material_count as u32 {
                        self.index = 0;
                        self.stage = Self::after_material_models(&h);
                    }
                }
            }
            Stage::Objects => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, OBJECT_LEN) {
                    let o = ObjectRecord::parse(self.staging.get(..OBJECT_LEN).unwrap_or(&[]))?;
                    sink.object(self.index as u16, o)?;
                    self.staged = 0;
                    self.index = self.index.saturating_add(1);
                    if self.index == h.object_count as u32 {
                        self.index = 0;
                        self.stage = Stage::Lighting;
                    }
                }
            }
            Stage::Lighting => {
                if self.stage_bytes(bytes, LIGHTING_LEN) {
                    let l = LightingRecord::parse(self.staging.get(..LIGHTING_LEN).unwrap_or(&[]))?;
                    sink.lighting(l)?;
                    self.staged = 0;
                    self.stage = Stage::PeBlockHead;
                }
            }
            Stage::PeBlockHead => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, 8) {
                    let mut r = Reader::new(&self.staging);
                    let pe = r.u16().map_err(|_| SceneError::Truncated)?;
                    let _reserved = r.u16().map_err(|_| SceneError::Truncated)?;
                    let words = r.u32().map_err(|_| SceneError::Truncated)?;
                    if pe != self.next_pe || pe >= h.pe_count {
                        return Err(SceneError::BadPeBlock);
                    }
                    if words > h.pe_mem_words {
                        return Err(SceneError::PeMemoryOverflow);
                    }
                    sink.pe_begin(pe as u8, words)?;
                    self.staged = 0;
                    self.words_left = words;
                    self.stage = Stage::PeWords;
                    if words == 0 {
                        self.finish_pe(sink, &h)?;
                    }
                }
            }
            Stage::PeWords => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                // Whole words at hand go to the sink straight from `bytes`: one CRC update
                // for the run, no staging (the upload's hot loop on a soft-core).
                let whole = (bytes.len() / 4).min(self.words_left.saturating_sub(1) as usize);
                if self.staged == 0 && whole > 0 {
                    let (run, tail) = bytes.split_at(whole.saturating_mul(4));
                    self.crc.update(run);
                    for w in run.chunks_exact(4) {
                        if let [b0, b1, b2, b3] = *w {
                            sink.pe_word(u32::from_le_bytes([b0, b1, b2, b3]))?;
                        }
                    }
                    self.offset = self.offset.saturating_add(run.len() as u32);
                    self.words_left = self.words_left.saturating_sub(whole as u32);
                    *bytes = tail;
                    return Ok(());
                }
                if self.stage_bytes(bytes, 4) {
                    let [b0, b1, b2, b3, ..] = self.staging;
                    sink.pe_word(u32::from_le_bytes([b0, b1, b2, b3]))?;
                    self.staged = 0;
                    self.words_left = self.words_left.saturating_sub(1);
                    if self.words_left == 0 {
                        self.finish_pe(sink, &h)?;
                    }
                }
            }
            Stage::PointsHead => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, POINTS_HEAD_LEN) {
                    let head = PointsHead::parse(self.staging.get(..POINTS_HEAD_LEN).unwrap_or(&[]))?;
                    sink.points_begin(&head)?;
                    self.staged = 0;
                    self.index = 0;
                    self.points_left = head.count;
                    self.stage = Stage::Points;
                    if head.count == 0 {
                        self.finish_image(&h)?;
                    }
                }
            }
            Stage::Points => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, POINT_LEN) {
                    let p = PointRecord::parse(self.staging.get(..POINT_LEN).unwrap_or(&[]), h.material_count)?;
                    sink.point(self.index, p)?;
                    self.staged = 0;
                    self.index = self.index.saturating_add(1);
                    self.points_left = self.points_left.saturating_sub(1);
                    if self.points_left == 0 {
                        self.finish_image(&h)?;
                    }
                }
            }
            Stage::Done => return Err(SceneError::TrailingBytes),
            Stage::Failed => return Err(SceneError::Rejected),
        }
        Ok(())
    }

    /// Stage after the material sections: the objects, or straight to the lighting record.
    fn after_material_models(h: &SceneHeader) -> Stage {
        if h.object_count == 0 {
            Stage::Lighting
        } else {
            Stage::Objects
        }
    }

    fn finish_pe<S: SceneSink>(&mut self, sink: &mut S, h: &SceneHeader) -> Result<(), SceneError> {
        sink.pe_end()?;
        self.next_pe = self.next_pe.saturating_add(1);
        if self.next_pe < h.pe_count {
            self.stage = Stage::PeBlockHead;
            return Ok(());
        }
        if h.flags & scene_flags::POINTS != 0 {
            self.stage = Stage::PointsHead;
            return Ok(());
        }
        self.finish_image(h)
    }

    /// After the last section: the image must end here and its body CRC match.
    fn finish_image(&mut self, h: &SceneHeader) -> Result<(), SceneError> {
        if self.offset != h.total_len {
            return Err(SceneError::BadHeader);
        }
        let crc = core::mem::take(&mut self.crc).finalize();
        if crc != h.body_crc {
            return Err(SceneError::BadCrc);
        }
        self.stage = Stage::Done;
        Ok(())
    }
}

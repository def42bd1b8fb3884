//! The versioned scene image the host builds and the device loads (SPEC.md §5).
//!
//! ```text
//! header (64 B) ‖ voxel→PE map (nx·ny·nz B, padded to 4) ‖ materials (16 B each) ‖ PE blocks
//! ```
//! A PE block is `pe u16 ‖ reserved u16 ‖ words u32 ‖ words × u32` where the words are the PE's
//! memory image ([`PeImage`]), loaded verbatim over FSL with a LOAD_PE packet.
//!
//! The device never holds the whole image: [`SceneStream`] parses it byte by byte as chunks
//! arrive and hands each piece to a [`SceneSink`].

use crate::bytes::Reader;
use crate::frame::Crc32Digest;
pub use crate::scene_v2::{
    HeaderExt, LightingRecord, MaterialExt, ObjectRecord, PrimRecord, LIGHTING_LEN, MATERIAL_EXT_LEN, OBJECT_LEN,
    PE_V2_HEADER_WORDS, PE_V2_TAG, PRIM_WORDS, VERSION_2,
};

/// Magic bytes at offset 0.
pub const MAGIC: [u8; 4] = *b"GRTS";
/// Scene image format version.
pub const VERSION: u16 = 1;
/// Header size in bytes.
pub const HEADER_LEN: usize = 64;
/// Bytes per material record.
pub const MATERIAL_LEN: usize = 16;
/// Voxel-map value of an empty voxel.
pub const EMPTY_VOXEL: u8 = 0xFF;
/// Largest PE count (ids 0..=254; 255 marks empty voxels).
pub const MAX_PES: usize = 255;
/// Largest grid: voxel ids are 24-bit on the FSL link.
pub const MAX_VOXELS: u32 = 1 << 24;
/// Words per triangle record in a PE image: 9 vertex coordinates, prim id, material.
pub const TRIANGLE_WORDS: usize = 11;
/// Words per voxel-table entry in a PE image: voxel id, first ref, ref count.
pub const VOXEL_ENTRY_WORDS: usize = 3;
/// Words before the voxel table in a PE image: triangle, voxel and ref counts.
pub const PE_HEADER_WORDS: usize = 3;

/// Why a scene image was rejected.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SceneError {
    /// The image does not start with `GRTS`.
    BadMagic,
    /// The image has a version this build cannot read.
    BadVersion,
    /// The image ends before a section it declares.
    Truncated,
    /// The image has bytes past its declared end.
    TrailingBytes,
    /// A header field is out of range (zero grid size, bad bounds, too many PEs, …).
    BadHeader,
    /// The voxel map names a PE that the image does not have.
    BadVoxelMap,
    /// A PE block is out of order or malformed.
    BadPeBlock,
    /// A PE block is larger than the PE memory the image was built for.
    PeMemoryOverflow,
    /// The body CRC does not match.
    BadCrc,
    /// The grid has more voxels than this device can hold.
    GridTooLarge,
    /// More materials than this device can hold.
    TooManyMaterials,
    /// A coordinate or material value is NaN or infinite.
    NonFinite,
    /// The consumer of the stream refused a piece (e.g. the co-processor reported an error).
    Rejected,
    /// A version-2 record (material ext, object, lighting, primitive) has an out-of-range
    /// enum or value.
    BadRecord,
}

impl SceneError {
    /// Error number used in `Error.detail` (SPEC.md §3.9): declaration order, from 1.
    pub const fn code(self) -> u32 {
        match self {
            Self::BadMagic => 1,
            Self::BadVersion => 2,
            Self::Truncated => 3,
            Self::TrailingBytes => 4,
            Self::BadHeader => 5,
            Self::BadVoxelMap => 6,
            Self::BadPeBlock => 7,
            Self::PeMemoryOverflow => 8,
            Self::BadCrc => 9,
            Self::GridTooLarge => 10,
            Self::TooManyMaterials => 11,
            Self::NonFinite => 12,
            Self::Rejected => 13,
            Self::BadRecord => 14,
        }
    }
}

impl SceneError {
    /// The error's text (what `Display` prints), for output without `core::fmt`.
    pub const fn as_str(&self) -> &'static str {
        match self {
            Self::BadMagic => "not a scene image (bad magic)",
            Self::BadVersion => "unsupported scene image version",
            Self::Truncated => "scene image truncated",
            Self::TrailingBytes => "bytes after the end of the scene image",
            Self::BadHeader => "scene header field out of range",
            Self::BadVoxelMap => "voxel map names a PE that does not exist",
            Self::BadPeBlock => "malformed PE block",
            Self::PeMemoryOverflow => "PE block exceeds PE memory",
            Self::BadCrc => "scene image CRC mismatch",
            Self::GridTooLarge => "grid has more voxels than the device can hold",
            Self::TooManyMaterials => "more materials than the device can hold",
            Self::NonFinite => "NaN or infinite value in scene image",
            Self::Rejected => "scene piece rejected by the loader",
            Self::BadRecord => "scene record field out of range",
        }
    }
}

impl core::fmt::Display for SceneError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(any(test, feature = "std"))]
impl std::error::Error for SceneError {}

/// The fixed 64-byte header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHeader {
    /// Grid resolution along x, y, z.
    pub dims: [u16; 3],
    /// Number of PEs (and PE blocks).
    pub pe_count: u16,
    /// Grid box minimum corner.
    pub bounds_min: [f32; 3],
    /// Grid box maximum corner.
    pub bounds_max: [f32; 3],
    /// Number of material records.
    pub material_count: u16,
    /// Reserved flags, 0 in version 1.
    pub flags: u16,
    /// Distinct triangles in the scene.
    pub triangle_count: u32,
    /// PE memory size (32-bit words) the image was built for.
    pub pe_mem_words: u32,
    /// Total image length in bytes, header included.
    pub total_len: u32,
    /// CRC-32 of bytes `64..total_len`.
    pub body_crc: u32,
}

impl SceneHeader {
    /// Number of voxels `nx·ny·nz`.
    pub fn voxel_count(&self) -> u32 {
        // parse() guarantees the product fits 24 bits; saturate for unvalidated headers.
        u32::try_from(self.dims.iter().map(|&d| d as u64).product::<u64>()).unwrap_or(u32::MAX)
    }

    /// Bytes of the voxel map including padding to a multiple of 4.
    pub fn voxel_map_len(&self) -> usize {
        (self.voxel_count() as usize).div_ceil(4) * 4
    }

    /// Serialises the header.
    pub fn to_bytes(&self) -> [u8; HEADER_LEN] {
        self.to_bytes_ext(&HeaderExt::V1)
    }

    /// Serialises the header with the version-specific fields of `ext` (version at offset 4,
    /// v2 object count at offset 60).
    pub fn to_bytes_ext(&self, ext: &HeaderExt) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        let mut w = crate::bytes::Writer::new(&mut b);
        // The buffer is exactly HEADER_LEN bytes, so none of these writes can overflow.
        let _ = (|| -> Result<(), crate::bytes::Overflow> {
            w.bytes(&MAGIC)?;
            w.u16(ext.version)?;
            w.u16(HEADER_LEN as u16)?;
            for d in self.dims {
                w.u16(d)?;
            }
            w.u16(self.pe_count)?;
            w.vec3(self.bounds_min)?;
            w.vec3(self.bounds_max)?;
            w.u16(self.material_count)?;
            w.u16(self.flags)?;
            w.u32(self.triangle_count)?;
            w.u32(self.pe_mem_words)?;
            w.u32(self.total_len)?;
            w.u32(self.body_crc)?;
            w.u16(ext.object_count)?;
            w.u16(0)
        })();
        b
    }

    /// Parses and range-checks the header (version 1 or 2).
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        Self::parse_ext(bytes).map(|(h, _)| h)
    }

    /// Parses the header and its version-specific fields.
    pub fn parse_ext(bytes: &[u8]) -> Result<(Self, HeaderExt), SceneError> {
        let mut r = Reader::new(bytes);
        let t = |_| SceneError::Truncated;
        if r.take(4).map_err(t)? != MAGIC {
            return Err(SceneError::BadMagic);
        }
        let version = r.u16().map_err(t)?;
        if version != VERSION && version != VERSION_2 {
            return Err(SceneError::BadVersion);
        }
        if r.u16().map_err(t)? as usize != HEADER_LEN {
            return Err(SceneError::BadHeader);
        }
        let dims = [r.u16().map_err(t)?, r.u16().map_err(t)?, r.u16().map_err(t)?];
        let pe_count = r.u16().map_err(t)?;
        let bounds_min = r.vec3().map_err(t)?;
        let bounds_max = r.vec3().map_err(t)?;
        let h = Self {
            dims,
            pe_count,
            bounds_min,
            bounds_max,
            material_count: r.u16().map_err(t)?,
            flags: r.u16().map_err(t)?,
            triangle_count: r.u32().map_err(t)?,
            pe_mem_words: r.u32().map_err(t)?,
            total_len: r.u32().map_err(t)?,
            body_crc: r.u32().map_err(t)?,
        };
        let object_count = r.u16().map_err(t)?;
        let ext = HeaderExt { version, object_count: if version == VERSION_2 { object_count } else { 0 } };
        if bounds_min.iter().chain(bounds_max.iter()).any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        let box_ok = (0..3).all(|i| bounds_min[i] < bounds_max[i]);
        let voxels: u64 = dims.iter().map(|&d| d as u64).product();
        if voxels > MAX_VOXELS as u64
            || dims.contains(&0)
            || pe_count == 0
            || pe_count as usize > MAX_PES
            || !box_ok
            || (h.total_len as usize) < HEADER_LEN
        {
            return Err(SceneError::BadHeader);
        }
        Ok((h, ext))
    }
}

/// Surface description referenced by primitives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Diffuse reflectance, linear RGB in `[0, 1]`.
    pub diffuse: [f32; 3],
    /// Mirror reflectance in `[0, 1]` (0 = not reflective).
    pub reflect: f32,
}

impl Material {
    /// Serialises the 16-byte record.
    pub fn to_bytes(&self) -> [u8; MATERIAL_LEN] {
        let mut b = [0u8; MATERIAL_LEN];
        for (i, v) in self.diffuse.iter().chain(core::iter::once(&self.reflect)).enumerate() {
            b[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
        }
        b
    }

    /// Parses a 16-byte record.
    pub fn parse(bytes: &[u8]) -> Result<Self, SceneError> {
        let mut r = Reader::new(bytes);
        let diffuse = r.vec3().map_err(|_| SceneError::Truncated)?;
        let reflect = r.f32().map_err(|_| SceneError::Truncated)?;
        if diffuse.iter().chain(core::iter::once(&reflect)).any(|v| !v.is_finite()) {
            return Err(SceneError::NonFinite);
        }
        Ok(Self { diffuse, reflect })
    }
}

/// Receiver of a streamed scene image. Every call may refuse with an error, which aborts
/// the stream. Calls arrive in this order: `header`, `voxel_map` (possibly in several pieces,
/// padding excluded), `material` × count, then per PE `pe_begin`, `pe_word` × words, `pe_end`.
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
    /// Version-specific header fields; called right after `header` for every image
    /// (version 1: `HeaderExt::V1`).
    fn header_ext(&mut self, _ext: &HeaderExt) -> Result<(), SceneError> {
        Ok(())
    }
    /// v2: extended material record `index` (after all v1 material records).
    fn material_ext(&mut self, _index: u16, _ext: MaterialExt) -> Result<(), SceneError> {
        Ok(())
    }
    /// v2: object record `index` (after the material ext records).
    fn object(&mut self, _index: u16, _object: ObjectRecord) -> Result<(), SceneError> {
        Ok(())
    }
    /// v2: the lighting record (after the objects, before the PE blocks).
    fn lighting(&mut self, _lighting: LightingRecord) -> Result<(), SceneError> {
        Ok(())
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    Header,
    VoxelMap,
    Materials,
    MaterialsExt,
    Objects,
    Lighting,
    PeBlockHead,
    PeWords,
    Done,
    Failed,
}

/// Largest record the stream stages (the v2 material ext record).
const STAGING_LEN: usize = if MATERIAL_EXT_LEN > HEADER_LEN { MATERIAL_EXT_LEN } else { HEADER_LEN };

/// Streaming parser of a scene image with O(1) memory (plus one 96-byte staging buffer).
#[derive(Debug)]
pub struct SceneStream {
    stage: Stage,
    staging: [u8; STAGING_LEN],
    staged: usize,
    header: Option<SceneHeader>,
    ext: HeaderExt,
    offset: u32,
    index: u32,
    next_pe: u16,
    words_left: u32,
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
            ext: HeaderExt::V1,
            offset: 0,
            index: 0,
            next_pe: 0,
            words_left: 0,
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
        if let Some(dst) = self.staging.get_mut(self.staged..self.staged + n) {
            dst.copy_from_slice(head);
        }
        if self.stage != Stage::Header {
            self.crc.update(head);
        }
        self.offset += n as u32;
        self.staged += n;
        *bytes = tail;
        self.staged >= want
    }

    fn step<S: SceneSink>(&mut self, bytes: &mut &[u8], sink: &mut S) -> Result<(), SceneError> {
        match self.stage {
            Stage::Header => {
                if self.stage_bytes(bytes, HEADER_LEN) {
                    let (h, ext) = SceneHeader::parse_ext(self.staging.get(..HEADER_LEN).unwrap_or(&[]))?;
                    sink.header(&h)?;
                    sink.header_ext(&ext)?;
                    self.header = Some(h);
                    self.ext = ext;
                    self.staged = 0;
                    self.stage = Stage::VoxelMap;
                    self.index = 0;
                }
            }
            Stage::VoxelMap => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                let total = h.voxel_map_len() as u32;
                let n = (total - self.index).min(bytes.len() as u32) as usize;
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
                self.offset += n as u32;
                self.index += n as u32;
                *bytes = tail;
                if self.index == total {
                    self.index = 0;
                    self.stage = if h.material_count == 0 { self.after_materials() } else { Stage::Materials };
                }
            }
            Stage::Materials => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, MATERIAL_LEN) {
                    let m = Material::parse(self.staging.get(..MATERIAL_LEN).unwrap_or(&[]))?;
                    sink.material(self.index as u16, m)?;
                    self.staged = 0;
                    self.index += 1;
                    if self.index == h.material_count as u32 {
                        self.index = 0;
                        self.stage = self.after_materials();
                    }
                }
            }
            Stage::MaterialsExt => {
                let h = self.header.ok_or(SceneError::BadHeader)?;
                if self.stage_bytes(bytes, MATERIAL_EXT_LEN) {
                    let m = MaterialExt::parse(self.staging.get(..MATERIAL_EXT_LEN).unwrap_or(&[]))?;
                    sink.material_ext(self.index as u16, m)?;
                    self.staged = 0;
                    self.index += 1;
                    if self.index == h.material_count as u32 {
                        self.index = 0;
                        self.stage = if self.ext.object_count == 0 { Stage::Lighting } else { Stage::Objects };
                    }
                }
            }
            Stage::Objects => {
                if self.stage_bytes(bytes, OBJECT_LEN) {
                    let o = ObjectRecord::parse(self.staging.get(..OBJECT_LEN).unwrap_or(&[]))?;
                    sink.object(self.index as u16, o)?;
                    self.staged = 0;
                    self.index += 1;
                    if self.index == self.ext.object_count as u32 {
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
                if self.stage_bytes(bytes, 4) {
                    let w = u32::from_le_bytes([self.staging[0], self.staging[1], self.staging[2], self.staging[3]]);
                    sink.pe_word(w)?;
                    self.staged = 0;
                    self.words_left -= 1;
                    if self.words_left == 0 {
                        self.finish_pe(sink, &h)?;
                    }
                }
            }
            Stage::Done => return Err(SceneError::TrailingBytes),
            Stage::Failed => return Err(SceneError::Rejected),
        }
        Ok(())
    }

    /// Stage after the v1 material records: the v2 sections, or the PE blocks.
    fn after_materials(&self) -> Stage {
        match (self.ext.version, self.header.map_or(0, |h| h.material_count)) {
            (VERSION_2, 0) if self.ext.object_count == 0 => Stage::Lighting,
            (VERSION_2, 0) => Stage::Objects,
            (VERSION_2, _) => Stage::MaterialsExt,
            _ => Stage::PeBlockHead,
        }
    }

    fn finish_pe<S: SceneSink>(&mut self, sink: &mut S, h: &SceneHeader) -> Result<(), SceneError> {
        sink.pe_end()?;
        self.next_pe += 1;
        if self.next_pe < h.pe_count {
            self.stage = Stage::PeBlockHead;
            return Ok(());
        }
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

/// Read-only view of one PE memory image (SPEC.md §5.4), validated on construction.
///
/// ```text
/// word 0: T triangles   word 1: V voxels   word 2: R refs
/// V × (voxel id, first ref, ref count)
/// R × local triangle index
/// T × (ax ay az bx by bz cx cy cz, prim id, material)
/// ```
///
/// Version 2 (SPEC.md §5.8.2) starts with [`PE_V2_TAG`] and adds analytic primitives:
///
/// ```text
/// word 0: PE_V2_TAG   word 1: T   word 2: V   word 3: R   word 4: P primitives
/// V × (voxel id, first ref, ref count)
/// R × ref: < T a local triangle index, T..T+P local primitive T + i
/// T × triangle record (11 words)
/// P × primitive record (16 words, PrimRecord)
/// ```
#[derive(Debug, Clone, Copy)]
pub struct PeImage<'a> {
    words: &'a [u32],
    header: usize,
    triangles: usize,
    voxels: usize,
    refs: usize,
    prims: usize,
}

impl<'a> PeImage<'a> {
    /// Checks the counts, that every voxel's ref range lies inside the ref table and every ref
    /// names a triangle (or, v2, a primitive), that vertex coordinates and primitive
    /// transforms are finite and primitive kinds known.
    pub fn parse(words: &'a [u32]) -> Result<Self, SceneError> {
        let empty = Self { words, header: PE_HEADER_WORDS, triangles: 0, voxels: 0, refs: 0, prims: 0 };
        let (header, t, v, r, p) = match words {
            [] => return Ok(empty),
            &[PE_V2_TAG, t, v, r, p, ..] => (PE_V2_HEADER_WORDS, t, v, r, p),
            &[PE_V2_TAG, ..] => return Err(SceneError::BadPeBlock),
            &[t, v, r, ..] => (PE_HEADER_WORDS, t, v, r, 0),
            _ => return Err(SceneError::BadPeBlock),
        };
        let (t, v, r, p) = (t as usize, v as usize, r as usize, p as usize);
        let need = v
            .checked_mul(VOXEL_ENTRY_WORDS)
            .and_then(|x| x.checked_add(r))
            .and_then(|x| t.checked_mul(TRIANGLE_WORDS).and_then(|y| x.checked_add(y)))
            .and_then(|x| p.checked_mul(PRIM_WORDS).and_then(|y| x.checked_add(y)))
            .and_then(|x| x.checked_add(header))
            .ok_or(SceneError::BadPeBlock)?;
        if need != words.len() {
            return Err(SceneError::BadPeBlock);
        }
        let img = Self { words, header, triangles: t, voxels: v, refs: r, prims: p };
        let mut previous: Option<u32> = None;
        for i in 0..v {
            let (voxel, first, count) = img.voxel_entry(i).ok_or(SceneError::BadPeBlock)?;
            // Strictly increasing ids let the co-processor binary-search the table.
            if previous.is_some_and(|p| voxel <= p) {
                return Err(SceneError::BadPeBlock);
            }
            previous = Some(voxel);
            let end = (first as usize).checked_add(count as usize).ok_or(SceneError::BadPeBlock)?;
            if end > r {
                return Err(SceneError::BadPeBlock);
            }
        }
        if img.ref_table().iter().any(|&x| x as usize >= t + p) {
            return Err(SceneError::BadPeBlock);
        }
        for i in 0..t {
            let tri = img.triangle(i).ok_or(SceneError::BadPeBlock)?;
            if tri.vertices.iter().flatten().any(|c| !c.is_finite()) {
                return Err(SceneError::NonFinite);
            }
        }
        for i in 0..p {
            let prim = img.primitive(i).ok_or(SceneError::BadPeBlock)?;
            if prim.world_to_object.iter().any(|c| !c.is_finite()) {
                return Err(SceneError::NonFinite);
            }
        }
        Ok(img)
    }

    /// True for a version-2 image (starts with [`PE_V2_TAG`]).
    pub fn is_v2(&self) -> bool {
        self.header == PE_V2_HEADER_WORDS
    }
    /// Words before the voxel table (3 in v1, 5 in v2).
    pub fn header_words(&self) -> usize {
        self.header
    }
    /// Number of analytic primitives (0 in v1).
    pub fn primitive_count(&self) -> usize {
        self.prims
    }
    /// Word offset of the triangle records.
    pub fn triangle_offset(&self) -> usize {
        self.header + self.voxels * VOXEL_ENTRY_WORDS + self.refs
    }
    /// Word offset of the primitive records.
    pub fn primitive_offset(&self) -> usize {
        self.triangle_offset() + self.triangles * TRIANGLE_WORDS
    }
    /// Local primitive `i` (v2).
    pub fn primitive(&self, i: usize) -> Option<PrimRecord> {
        if i >= self.prims {
            return None;
        }
        let base = self.primitive_offset() + i * PRIM_WORDS;
        PrimRecord::from_words(self.words.get(base..base + PRIM_WORDS)?)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles
    }
    /// Number of voxels this PE owns that hold primitives.
    pub fn voxel_count(&self) -> usize {
        self.voxels
    }
    /// `(voxel id, first ref, ref count)` of voxel-table entry `i`.
    pub fn voxel_entry(&self, i: usize) -> Option<(u32, u32, u32)> {
        if i >= self.voxels {
            return None;
        }
        let base = self.header + i * VOXEL_ENTRY_WORDS;
        match self.words.get(base..base + VOXEL_ENTRY_WORDS)? {
            &[a, b, c] => Some((a, b, c)),
            _ => None,
        }
    }
    /// The reference table (local triangle indices).
    pub fn ref_table(&self) -> &'a [u32] {
        let base = self.header + self.voxels * VOXEL_ENTRY_WORDS;
        self.words.get(base..base + self.refs).unwrap_or(&[])
    }
    /// Local triangle `i`.
    pub fn triangle(&self, i: usize) -> Option<TriangleRecord> {
        if i >= self.triangles {
            return None;
        }
        let base = self.triangle_offset() + i * TRIANGLE_WORDS;
        let w = self.words.get(base..base + TRIANGLE_WORDS)?;
        let f = |k: usize| f32::from_bits(w.get(k).copied().unwrap_or(0));
        Some(TriangleRecord {
            vertices: [[f(0), f(1), f(2)], [f(3), f(4), f(5)], [f(6), f(7), f(8)]],
            prim: w.get(9).copied().unwrap_or(0),
            material: w.get(10).copied().unwrap_or(0),
        })
    }
}

/// One triangle as stored in PE memory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TriangleRecord {
    /// Vertices a, b, c.
    pub vertices: [[f32; 3]; 3],
    /// Global primitive id.
    pub prim: u32,
    /// Material index.
    pub material: u32,
}

impl TriangleRecord {
    /// The 11 words of the record.
    pub fn to_words(&self) -> [u32; TRIANGLE_WORDS] {
        let v = &self.vertices;
        [
            v[0][0].to_bits(),
            v[0][1].to_bits(),
            v[0][2].to_bits(),
            v[1][0].to_bits(),
            v[1][1].to_bits(),
            v[1][2].to_bits(),
            v[2][0].to_bits(),
            v[2][1].to_bits(),
            v[2][2].to_bits(),
            self.prim,
            self.material,
        ]
    }
}

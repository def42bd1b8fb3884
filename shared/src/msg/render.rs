//! What a render asks for: the frame's [`RenderRequest`] with its option bits, the
//! rectangle of a `RenderRegion`, and the [`PixelEncoding`] of the spans that answer it.

use super::device::feature;

/// Pixel encodings of a [`Msg::PixelSpan`](crate::msg::Msg::PixelSpan).
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum PixelEncoding {
    /// 3 bytes per pixel: R, G, B.
    Rgb888 = 0,
    /// 2 bytes per pixel, LE `r5 << 11 | g6 << 5 | b5` (lossy; see [`crate::pixel`]).
    Rgb565 = 1,
    /// Lossless run-length + delta byte code, variable length ([`crate::pixel`]).
    Rle = 2,
    /// Auxiliary: 4 bytes per pixel, the primitive id of the primary hit (LE), `u32::MAX` for
    /// a miss. Sent after the colour span of the same pixels when
    /// [`render_flags::PRIM_IDS`] is set; lets the host compare hits with a reference.
    PrimId32 = 0x80,
}

impl PixelEncoding {
    /// Bytes per pixel on the wire of a fixed-size encoding; 0 for the variable-size
    /// [`Self::Rle`] (use [`Self::fixed_bytes_per_pixel`] to tell them apart).
    pub const fn bytes_per_pixel(self) -> usize {
        match self.fixed_bytes_per_pixel() {
            Some(n) => n,
            None => 0,
        }
    }
    /// Bytes per pixel, `None` for a variable-size encoding.
    pub const fn fixed_bytes_per_pixel(self) -> Option<usize> {
        match self {
            Self::Rgb888 => Some(3),
            Self::Rgb565 => Some(2),
            Self::Rle => None,
            Self::PrimId32 => Some(4),
        }
    }
    /// True for the colour encodings a render request may ask for.
    pub const fn is_colour(self) -> bool {
        !matches!(self, Self::PrimId32)
    }
    /// Encoding for a wire byte.
    pub fn from_u8(b: u8) -> Option<Self> {
        match b {
            0 => Some(Self::Rgb888),
            1 => Some(Self::Rgb565),
            2 => Some(Self::Rle),
            0x80 => Some(Self::PrimId32),
            _ => None,
        }
    }
    /// The `Version.features` bit a device sets when it can send this encoding (0 for
    /// encodings every device sends).
    pub const fn feature_bit(self) -> u32 {
        match self {
            Self::Rgb565 => feature::RGB565,
            Self::Rle => feature::RLE,
            Self::Rgb888 | Self::PrimId32 => 0,
        }
    }
}

/// Render request options (bit flags in [`RenderRequest::flags`]).
pub mod render_flags {
    /// Trace shadow rays toward the light.
    pub const SHADOWS: u16 = 1 << 0;
    /// Also send the primitive id of every primary hit ([`super::PixelEncoding::PrimId32`]).
    pub const PRIM_IDS: u16 = 1 << 1;
    /// Pipeline plan (SPEC.md §3.13): trace mirror-reflection rays.
    pub const REFLECTIONS: u16 = 1 << 2;
    /// Pipeline plan: run the texture stage.
    pub const TEXTURES: u16 = 1 << 3;
    /// Pipeline plan: evaluate specular BRDFs.
    pub const SPECULAR: u16 = 1 << 4;
    /// Row interpolation: adapt the step per row (Malcheva et al.); else a fixed step.
    pub const INTERP_ADAPTIVE: u16 = 1 << 5;
    /// Row interpolation step l (trace every (l+1)-th pixel), bits 9..6; 0 = off.
    pub const INTERP_STEP_SHIFT: u32 = 6;
    /// Mask of the step field.
    pub const INTERP_STEP_MASK: u16 = 0xF << INTERP_STEP_SHIFT;
    /// Row interpolation colour threshold EPS (8-bit levels, 0..=31), bits 14..10.
    pub const INTERP_EPS_SHIFT: u32 = 10;
    /// Mask of the EPS field.
    pub const INTERP_EPS_MASK: u16 = 0x1F << INTERP_EPS_SHIFT;
    /// Render the scene's point section as splats (point splatting, SPEC.md §6) instead of tracing
    /// rays. With it, [`PRIM_IDS`] asks for each pixel's depth instead of a primitive id, the
    /// ray-stage bits (shadows, reflections, textures, specular) are ignored and the
    /// interpolation step must be 0.
    pub const SPLATS: u16 = 1 << 15;
    /// With [`SPLATS`]: depth-test per pixel (each splat's plane) instead of one Z per splat
    /// as in the seed. The bit is [`INTERP_ADAPTIVE`]'s, which means nothing for splats.
    pub const SPLAT_PIXEL_DEPTH: u16 = 1 << 5;

    /// The interpolation bits for step `l` (0..=15) and threshold `eps` (0..=31).
    pub const fn interp(step: u8, eps: u8, adaptive: bool) -> u16 {
        (((step as u16) & 0xF) << INTERP_STEP_SHIFT)
            | (((eps as u16) & 0x1F) << INTERP_EPS_SHIFT)
            | if adaptive { INTERP_ADAPTIVE } else { 0 }
    }
    /// Interpolation step l of `flags` (0 = off).
    pub const fn interp_step(flags: u16) -> u8 {
        ((flags & INTERP_STEP_MASK) >> INTERP_STEP_SHIFT) as u8
    }
    /// Interpolation threshold EPS of `flags`.
    pub const fn interp_eps(flags: u16) -> u8 {
        ((flags & INTERP_EPS_MASK) >> INTERP_EPS_SHIFT) as u8
    }
}

/// Camera, light and output settings of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderRequest {
    /// Frame id echoed in every pixel span and the frame end.
    pub frame: u16,
    /// Image width in pixels.
    pub width: u16,
    /// Image height in pixels.
    pub height: u16,
    /// Option bits, see [`render_flags`].
    pub flags: u16,
    /// Camera position.
    pub eye: [f32; 3],
    /// Point the camera looks at.
    pub target: [f32; 3],
    /// Up vector.
    pub up: [f32; 3],
    /// Vertical field of view in degrees.
    pub fov_y_deg: f32,
    /// Point light position.
    pub light_pos: [f32; 3],
    /// Point light intensity (scales the diffuse term).
    pub light_intensity: f32,
    /// Ambient term.
    pub ambient: f32,
    /// Pixel encoding of the spans.
    pub encoding: PixelEncoding,
}

/// Payload size of a render request.
pub const RENDER_REQUEST_LEN: usize = 72;

/// A rectangle of a frame: columns `x0..x0+cols` of rows `y0..y0+rows` (SPEC.md §3.12).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Region {
    /// First column.
    pub x0: u16,
    /// First row.
    pub y0: u16,
    /// Columns.
    pub cols: u16,
    /// Rows.
    pub rows: u16,
}

impl Region {
    /// The whole `width`×`height` frame.
    pub const fn full(width: u16, height: u16) -> Self {
        Self { x0: 0, y0: 0, cols: width, rows: height }
    }
    /// Pixels in the region.
    pub const fn pixels(&self) -> u64 {
        // u16 · u16 < 2^32: never saturates.
        (self.cols as u64).saturating_mul(self.rows as u64)
    }
    /// True when the region is non-empty and lies inside a `width`×`height` frame.
    pub const fn fits(&self, width: u16, height: u16) -> bool {
        self.cols > 0
            && self.rows > 0
            && (self.x0 as u32).saturating_add(self.cols as u32) <= width as u32
            && (self.y0 as u32).saturating_add(self.rows as u32) <= height as u32
    }
}

/// Option bits of a `RenderRegion` (SPEC.md §3.12).
pub mod region_options {
    /// Render the region but send no spans: only `Stats` and `RegionEnd` (its CRC lets the
    /// host verify pixels it already holds when an earlier `RegionEnd` was lost).
    pub const CRC_ONLY: u16 = 1 << 0;
    /// Send no `Stats` for this region (re-requests of a few pixels, whose counters the host
    /// does not need). A device that does not know the bit sends them anyway.
    pub const NO_STATS: u16 = 1 << 1;
    /// `max_span` counts bytes of span data, not pixels: each span ends before its data would
    /// pass `max_span` bytes (a span holds at least one pixel). Spans of run-length data then
    /// stay as long in pixels as their content allows. A device that does not know the bit
    /// takes `max_span` as pixels.
    pub const SPAN_BYTES: u16 = 1 << 2;
}

/// Payload size of a `RenderRegion`.
pub const RENDER_REGION_LEN: usize = 12 + RENDER_REQUEST_LEN;
/// Payload size of a `RegionEnd`.
pub const REGION_END_LEN: usize = 20;

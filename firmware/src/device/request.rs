//! Render requests (SPEC.md §3.6, §3.12): the checks a `RenderRequest` or `RenderRegion`
//! passes before anything is traced, the field offsets a refusal names, and the validated
//! [`Job`] the pixel pipeline works from.

use super::fail::Fail;
use crate::camera::{Camera, CameraError};
use crate::shade::Light;
use gridrt_shared::math::Vec3;
use gridrt_shared::msg::{region_options, ErrorCode, Region, RenderRequest};

/// Largest accepted render width and height.
pub const MAX_IMAGE_DIM: u16 = 4096;

/// Offsets of the RenderRequest fields (`Msg::Error{BadRequest}` detail).
pub(super) mod field {
    pub const WIDTH: u32 = 2;
    pub const HEIGHT: u32 = 4;
    pub const EYE: u32 = 8;
    pub const TARGET: u32 = 20;
    pub const UP: u32 = 32;
    pub const FOV: u32 = 44;
    pub const LIGHT_POS: u32 = 48;
    pub const LIGHT_INTENSITY: u32 = 60;
    pub const AMBIENT: u32 = 64;
    pub const ENCODING: u32 = 68;
    /// `RenderRequest.flags` (a pipeline plan this build refuses).
    pub const FLAGS: u32 = 6;
    /// `RenderRegion`: region fields, then the embedded request at [`REGION_REQUEST`].
    pub const REGION_X0: u32 = 0;
    pub const REGION_Y0: u32 = 2;
    pub const REGION_REQUEST: u32 = 12;
}

/// What a render message asks for.
#[derive(Debug, Clone, Copy)]
pub(super) enum Target {
    /// `RenderRequest`: the whole frame, ended by `FrameEnd`.
    Frame,
    /// `RenderRegion` (SPEC.md §3.12): the pixels of `region` exactly as a full render would
    /// produce them, at most `max_span` pixels per span (0 = default), ended by `RegionEnd`.
    Region {
        /// The rectangle.
        region: Region,
        /// Span length limit.
        max_span: u16,
        /// `region_options` bits.
        options: u16,
    },
}

/// A validated render request: what the pixel pipeline renders and how it sends it.
pub(super) struct Job<'r> {
    /// The request.
    pub(super) req: &'r RenderRequest,
    /// The pixels to render (the whole image for a frame).
    pub(super) region: Region,
    /// Span length limit (0 = default).
    pub(super) max_span: u16,
    /// Keep the CRC but send no spans (`region_options::CRC_ONLY`).
    pub(super) crc_only: bool,
    /// Send no `Stats` (`region_options::NO_STATS`).
    pub(super) no_stats: bool,
    /// `max_span` counts data bytes (`region_options::SPAN_BYTES`).
    pub(super) span_bytes: bool,
    /// The request's camera.
    pub(super) cam: Camera,
    /// The request's light.
    pub(super) light: Light,
}

/// Checks `req` for `target` (request fields first, then the region) and returns the job,
/// or the failure that refuses it (`NoScene`, or `BadRequest` naming the offending field's
/// offset in its message).
pub(super) fn job(scene_loaded: bool, req: &RenderRequest, target: Target) -> Result<Job<'_>, Fail> {
    let base = match target {
        Target::Frame => 0,
        Target::Region { .. } => field::REGION_REQUEST,
    };
    let (cam, light) = validate(scene_loaded, req, base)?;
    let (region, max_span, options) = match target {
        Target::Frame => (Region::full(req.width, req.height), 0, 0),
        Target::Region { region, max_span, options } => {
            if !region.fits(req.width, req.height) {
                let (f, t) =
                    if region.cols == 0 || (region.x0 as u32).saturating_add(region.cols as u32) > req.width as u32 {
                        (field::REGION_X0, "region columns outside the image")
                    } else {
                        (field::REGION_Y0, "region rows outside the image")
                    };
                return Err(Fail::Plain(ErrorCode::BadRequest, f, t));
            }
            (region, max_span, options)
        }
    };
    let crc_only = options & region_options::CRC_ONLY != 0;
    let no_stats = options & region_options::NO_STATS != 0;
    let span_bytes = options & region_options::SPAN_BYTES != 0;
    Ok(Job { req, region, max_span, crc_only, no_stats, span_bytes, cam, light })
}

/// Validates a request whose fields start at offset `base` of its message; returns the
/// camera and light.
fn validate(scene_loaded: bool, r: &RenderRequest, base: u32) -> Result<(Camera, Light), Fail> {
    // Offsets of a 72-byte request inside its message: no overflow.
    let bad = |f: u32, t: &'static str| Fail::Plain(ErrorCode::BadRequest, base.saturating_add(f), t);
    if !scene_loaded {
        return Err(Fail::Plain(ErrorCode::NoScene, 0, "no scene loaded"));
    }
    if !(1..=MAX_IMAGE_DIM).contains(&r.width) {
        return Err(bad(field::WIDTH, "width not in 1..=4096"));
    }
    if !(1..=MAX_IMAGE_DIM).contains(&r.height) {
        return Err(bad(field::HEIGHT, "height not in 1..=4096"));
    }
    let finite = |v: [f32; 3]| v.iter().all(|c| c.is_finite());
    let vectors = [
        (r.eye, field::EYE, "eye not finite"),
        (r.target, field::TARGET, "target not finite"),
        (r.up, field::UP, "up not finite"),
        (r.light_pos, field::LIGHT_POS, "light position not finite"),
    ];
    for (v, f, t) in vectors {
        if !finite(v) {
            return Err(bad(f, t));
        }
    }
    if !r.light_intensity.is_finite() {
        return Err(bad(field::LIGHT_INTENSITY, "light intensity not finite"));
    }
    if !r.ambient.is_finite() {
        return Err(bad(field::AMBIENT, "ambient not finite"));
    }
    if !r.encoding.is_colour() {
        return Err(bad(field::ENCODING, "encoding is not a colour encoding"));
    }
    let v = Vec3::from_array;
    let cam = Camera::new(v(r.eye), v(r.target), v(r.up), r.fov_y_deg, r.width as u32, r.height as u32).map_err(
        |e| match e {
            CameraError::EyeIsTarget => bad(field::TARGET, "eye equals target"),
            CameraError::DegenerateUp => bad(field::UP, "up is zero or parallel to the view direction"),
            CameraError::BadSize => bad(field::WIDTH, "empty image"),
            CameraError::BadFov | CameraError::NonFinite => bad(field::FOV, "fov not in (0, 180) degrees"),
        },
    )?;
    Ok((cam, Light { pos: v(r.light_pos), intensity: r.light_intensity, ambient: r.ambient }))
}

//! `[render]` (depth, background, ambient) and `[light]` (point or spot light).

use gridrt_shared::scene::{Falloff, LightingRecord, MAX_DEPTH};
use toml::Spanned;

use super::error::{Ctx, SceneFileError};
use super::schema::{f3, finite3, FalloffDef, LightDef, RenderDef};
use crate::render_settings::{Light, RenderSettings};

/// The lighting record the `[render]` table sets, and the ambient term.
pub(super) fn render(
    cx: &Ctx<'_>,
    render: Option<&Spanned<RenderDef>>,
) -> Result<(LightingRecord, f64), SceneFileError> {
    let mut lighting = LightingRecord::default();
    if let Some(r) = render {
        let span = r.span();
        let r = r.get_ref();
        if !(1..=MAX_DEPTH).contains(&r.max_depth) {
            return Err(cx.field(
                span,
                "render",
                "max_depth",
                format!("must be in 1..={MAX_DEPTH} (1 = primary rays only)"),
            ));
        }
        lighting.max_depth = r.max_depth;
        if let Some(b) = r.background {
            if !finite3(b) {
                return Err(cx.field(span, "render", "background", "must be finite"));
            }
            lighting.background = f3(b);
        }
        if let Some(a) = r.ambient_colour {
            if !finite3(a) {
                return Err(cx.field(span, "render", "ambient_colour", "must be finite"));
            }
            lighting.ambient_colour = f3(a);
        }
    }
    let ambient = render.and_then(|r| r.get_ref().ambient).unwrap_or(0.1);
    if !ambient.is_finite() {
        return Err(cx.field(render.map_or(0..0, |r| r.span()), "render", "ambient", "must be finite"));
    }
    Ok((lighting, ambient))
}

/// Applies `[light]`; without one the scene is unlit but for the ambient term.
pub(super) fn light(
    cx: &Ctx<'_>,
    light: Option<&Spanned<LightDef>>,
    lighting: &mut LightingRecord,
    settings: &mut RenderSettings,
) -> Result<(), SceneFileError> {
    match light {
        None => {
            lighting.light_count = 0;
            settings.light = Light { pos: settings.light.pos, intensity: 0.0 };
            settings.shadows = false;
        }
        Some(l) => {
            let span = l.span();
            let l = l.get_ref();
            if !finite3(l.position) {
                return Err(cx.field(span, "light", "position", "must be finite"));
            }
            if !(l.intensity.is_finite() && l.intensity >= 0.0) {
                return Err(cx.field(span, "light", "intensity", "must be ≥ 0"));
            }
            settings.light = Light { pos: f3(l.position), intensity: l.intensity as f32 };
            lighting.light_count = 1;
            lighting.falloff = match l.falloff {
                FalloffDef::InverseSquare => Falloff::InverseSquare,
                FalloffDef::None => Falloff::None,
            };
            if let Some(c) = l.colour {
                if !finite3(c) {
                    return Err(cx.field(span, "light", "colour", "must be finite"));
                }
                lighting.light_colour = f3(c);
            }
            match (l.spot_direction, l.spot_outer_deg) {
                (None, None) => {
                    if l.spot_inner_deg.is_some() {
                        return Err(cx.field(
                            span,
                            "light",
                            "spot_inner_deg",
                            "needs spot_direction and spot_outer_deg",
                        ));
                    }
                }
                (Some(d), Some(outer)) => {
                    if !finite3(d) || d == [0.0; 3] {
                        return Err(cx.field(span, "light", "spot_direction", "must be finite and non-zero"));
                    }
                    let inner = l.spot_inner_deg.unwrap_or(outer);
                    if !(0.0 < outer && outer <= 180.0 && (0.0..=outer).contains(&inner)) {
                        return Err(cx.field(
                            span,
                            "light",
                            "spot_inner_deg",
                            "need 0 ≤ spot_inner_deg ≤ spot_outer_deg ≤ 180",
                        ));
                    }
                    lighting.spot_dir = f3(d);
                    lighting.cos_outer = outer.to_radians().cos() as f32;
                    lighting.cos_inner = (inner.to_radians().cos() as f32).max(lighting.cos_outer);
                }
                _ => {
                    return Err(cx.field(
                        span,
                        "light",
                        "spot_direction",
                        "a spotlight needs both spot_direction and spot_outer_deg",
                    ))
                }
            }
        }
    }
    Ok(())
}

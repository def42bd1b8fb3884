//! The pipeline plan (SPEC.md §3.13): which firmware stages a scene needs, derived on the
//! host and sent as `RenderRequest.flags` bits, plus the row-interpolation setting.
//!
//! - shadows: only with a light of non-zero intensity and something that can occlude it
//!   (a lone sphere, disk or square cannot shadow itself);
//! - reflections: only when the depth is > 1 and some used material reflects;
//! - textures: only when some used material has a texture;
//! - specular: only when some used material has a specular model with `ks > 0`.

use gridrt_shared::msg::render_flags;
use gridrt_shared::scene::{PrimKind, ReflectMode, SpecularModel, TextureKind};
use serde::Serialize;

use crate::scene::Scene;

/// Stages a frame runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Plan {
    /// Shadow rays.
    pub shadows: bool,
    /// Mirror-reflection rays.
    pub reflections: bool,
    /// Texture stage.
    pub textures: bool,
    /// Specular terms.
    pub specular: bool,
}

impl Plan {
    /// Every stage (what a build without skipping would run).
    pub const ALL: Self = Self { shadows: true, reflections: true, textures: true, specular: true };

    /// The stages `scene` needs.
    pub fn derive(world: &Scene) -> Self {
        let used: Vec<u32> =
            world.mesh.triangles.iter().map(|t| t.material).chain(world.prims.iter().map(|p| p.material)).collect();
        let any = |f: &dyn Fn(u32) -> bool| used.iter().any(|&m| f(m));
        let lone_convex = world.mesh.triangles.is_empty()
            && world.prims.len() == 1
            && matches!(world.prims[0].kind, PrimKind::Sphere | PrimKind::Disk | PrimKind::Square);
        let light = world.lighting.light_count > 0
            && world.settings.light.intensity > 0.0
            && world.lighting.light_colour.iter().any(|&c| c > 0.0);
        Self {
            shadows: light && !lone_convex,
            reflections: world.lighting.max_depth > 1
                && any(&|m| {
                    let (mat, e) = world.material(m);
                    match e.reflect_mode {
                        ReflectMode::None => false,
                        ReflectMode::Constant => mat.reflect > 0.0,
                        _ => true,
                    }
                }),
            textures: any(&|m| world.material(m).1.texture != TextureKind::None),
            specular: light
                && any(&|m| {
                    let e = world.material(m).1;
                    e.specular_model != SpecularModel::None && e.ks > 0.0
                }),
        }
    }

    /// The `RenderRequest.flags` bits.
    pub fn flags(&self) -> u16 {
        let mut f = 0;
        for (on, bit) in [
            (self.shadows, render_flags::SHADOWS),
            (self.reflections, render_flags::REFLECTIONS),
            (self.textures, render_flags::TEXTURES),
            (self.specular, render_flags::SPECULAR),
        ] {
            if on {
                f |= bit;
            }
        }
        f
    }

    /// Names of the stages that run.
    pub fn names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        for (on, n) in [
            (self.shadows, "shadows"),
            (self.reflections, "reflections"),
            (self.textures, "textures"),
            (self.specular, "specular"),
        ] {
            if on {
                v.push(n);
            }
        }
        v
    }
}

/// Row interpolation request (`--interp l,EPS[,adaptive]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Interp {
    /// Step l: every (l+1)-th pixel is traced, 1..=15.
    pub step: u8,
    /// Colour threshold in 8-bit levels, 0..=31.
    pub eps: u8,
    /// Adaptive step per row.
    pub adaptive: bool,
}

impl Interp {
    /// Parses `l,EPS` or `l,EPS,adaptive`.
    pub fn parse(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(',').map(str::trim).collect();
        let bad = || format!("`{s}`: expected l,EPS or l,EPS,adaptive with l in 1..=15 and EPS in 0..=31");
        let (l, e, adaptive) = match parts.as_slice() {
            [l, e] => (l, e, false),
            [l, e, "adaptive"] => (l, e, true),
            [l, e, "fixed"] => (l, e, false),
            _ => return Err(bad()),
        };
        let step: u8 = l.parse().map_err(|_| bad())?;
        let eps: u8 = e.parse().map_err(|_| bad())?;
        if !(1..=15).contains(&step) || eps > 31 {
            return Err(bad());
        }
        Ok(Self { step, eps, adaptive })
    }

    /// The `RenderRequest.flags` bits.
    pub fn flags(&self) -> u16 {
        render_flags::interp(self.step, self.eps, self.adaptive)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    #[test]
    fn interp_parses_and_encodes() {
        let i = Interp::parse("3,8").unwrap();
        assert_eq!(render_flags::interp_step(i.flags()), 3);
        assert_eq!(render_flags::interp_eps(i.flags()), 8);
        assert!(Interp::parse("3,8,adaptive").unwrap().adaptive);
        assert!(Interp::parse("0,8").is_err() && Interp::parse("3,40").is_err() && Interp::parse("x").is_err());
    }

    #[test]
    fn plan_follows_the_scene() {
        let no = |_: &Path| Err(crate::scene::SceneLoadError::UnsupportedFormat { path: "x".into() });
        let scene = |extra: &str, mat: &str| {
            let text = format!("{extra}\n[materials.m]\n{mat}\n[[objects]]\ntype = \"sphere\"\nmaterial = \"m\"\n[[objects]]\ntype = \"plane\"\ntranslate = [0, -1, 0]\n");
            crate::scene::parse_scene_file(Path::new("t.toml"), &text, &no).unwrap()
        };
        let p = Plan::derive(&scene("", "colour = [0.5, 0.5, 0.5]"));
        assert_eq!(p, Plan { shadows: false, reflections: false, textures: false, specular: false });
        let p = Plan::derive(&scene(
            "[light]\nposition = [0, 5, 0]\n[render]\nmax_depth = 2",
            "reflection = \"constant\"\nreflectivity = 0.5",
        ));
        assert_eq!(p, Plan { shadows: true, reflections: true, textures: false, specular: false });
        let p = Plan::derive(&scene(
            "[light]\nposition = [0, 5, 0]",
            "reflection = \"dielectric\"\nspecular = \"blinn-phong\"\nks = 0.3",
        ));
        assert_eq!(p, Plan { shadows: true, reflections: false, textures: false, specular: true });
    }
}

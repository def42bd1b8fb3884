//! A `SPLATS` frame (SPEC.md §6.4): the scene's point section rendered by the point-splatting
//! path (`crate::splat`) instead of ray tracing, sent as the same pixel spans. With
//! `PRIM_IDS` each pixel's auxiliary word is its depth (`u32::MAX` where no splat landed), so
//! a host can composite several boards' images by depth.

use super::fail::Fail;
use super::request::{field, Job};
use super::scene::SceneStore;
use super::stats::{Stage, StageClock};
use crate::pixels::{FrameTx, SpanEncoder, TxError};
use crate::shade::to_rgb8;
use crate::splat::codegen::{Pass, SplatLight, View};
use crate::splat::stage::{BACKGROUND_DEPTH, TILE_COLUMNS};
use crate::splat::{PassError, SplatEngine, SplatStats};
use embedded_io::Write;
use gridrt_shared::math::Vec3;
use gridrt_shared::msg::{render_flags, stat, ErrorCode, Msg, STAT_ENTRY_LEN};
use gridrt_shared::scene::{DiffuseModel, Falloff, Material, MaterialModel, SpecularModel};
use gridrt_shared::splat::{MaterialTerm, MAX_TERM};

/// Stats entries of a splat frame.
const SPLAT_STATS: usize = 15;

/// The splat stage's material table for this frame: per material, the colour coefficients of
/// the ambient, diffuse and specular terms (point splatting; lights and ambient folded in), and
/// the ambient register.
// Indexes only the fixed `[f32; 3]` colour arrays with 0..3.
#[allow(clippy::indexing_slicing)]
fn material_terms<const N: usize>(scene: &SceneStore<N>, job: &Job<'_>, table: &mut [[MaterialTerm; 3]]) -> u8 {
    let l = &scene.lighting;
    let light = job.light;
    let ambient = light.ambient.clamp(0.0, 1.0);
    let a_reg = (ambient * MAX_TERM as f32 + 0.5) as u8;
    // k_a is scaled so that A = a_reg stands for the request's ambient exactly.
    let a_scale = if a_reg > 0 { light.ambient * MAX_TERM as f32 / a_reg as f32 } else { 0.0 };
    let lit = l.light_count > 0;
    for (i, slot) in table.iter_mut().enumerate() {
        let m = scene.materials.get(i).copied().unwrap_or(Material { diffuse: [0.0; 3], reflect: 0.0 });
        let model = scene.material_model.get(i).copied().unwrap_or(MaterialModel::MATTE);
        let diffuse_f = if model.diffuse_model == DiffuseModel::Matte { 1.0 } else { core::f32::consts::FRAC_1_PI };
        let mut ka = [0f32; 3];
        let mut kd = [0f32; 3];
        let mut ks = [0f32; 3];
        for c in 0..3 {
            let (cd, la) = (m.diffuse[c], l.ambient_colour[c]);
            let radiance = if lit { l.light_colour[c] * light.intensity } else { 0.0 };
            ka[c] = cd * model.ka * la * a_scale;
            kd[c] = cd * model.kd * radiance * diffuse_f;
            if model.specular_model != SpecularModel::None {
                ks[c] = model.ks * model.specular[c] * radiance;
            }
        }
        *slot = [ka, kd, ks].map(MaterialTerm::from_coefficient);
    }
    a_reg
}

/// The view and light of a job over the engine's cloud.
fn view_of<const N: usize, const P: usize, const T: usize>(
    engine: &SplatEngine<P, T>,
    scene: &SceneStore<N>,
    job: &Job<'_>,
) -> Option<(View, SplatLight)> {
    let req = job.req;
    let cam = &job.cam;
    let half_h = crate::fmath::tan_turns(req.fov_y_deg / 720.0);
    let focal = req.height as f32 / (2.0 * half_h);
    let eye = Vec3::from_array(req.eye);
    let mut view =
        View::new(eye, [cam.forward(), cam.right(), cam.up()], focal, (req.width, req.height), engine.bounds())?;
    view.pixel_depth = req.flags & render_flags::SPLAT_PIXEL_DEPTH != 0;
    let l = &scene.lighting;
    let on = l.light_count > 0 && l.light_colour.iter().any(|&c| c != 0.0) && job.light.intensity != 0.0;
    let spot = Vec3::from_array(l.spot_dir).try_normalize().map(|a| (a, l.cos_outer, l.cos_inner));
    let light = SplatLight { pos: job.light.pos, on, inverse_square: l.falloff == Falloff::InverseSquare, spot };
    Some((view, light))
}

/// Renders `job` as splats and sends its spans and `Stats`; returns (spans, CRC).
#[allow(clippy::too_many_arguments)]
pub(super) fn render<const N: usize, const P: usize, const T: usize, C: StageClock>(
    engine: &mut SplatEngine<P, T>,
    scene: &SceneStore<N>,
    clock: &C,
    spans: &mut SpanEncoder,
    tx: &mut FrameTx,
    job: &Job<'_>,
    out: &mut impl Write,
) -> Result<(u32, u32), Fail> {
    let req = job.req;
    let region = job.region;
    let bad = |f: u32, t: &'static str| Fail::Plain(ErrorCode::BadRequest, f, t);
    if P == 0 || T == 0 {
        return Err(bad(field::FLAGS, "this firmware was built without the splat path"));
    }
    if !engine.has_points() || engine.points().is_empty() {
        return Err(bad(field::FLAGS, "the scene has no point section to splat"));
    }
    if render_flags::interp_step(req.flags) != 0 {
        return Err(bad(field::FLAGS, "row interpolation does not apply to splat frames"));
    }
    if region.cols > TILE_COLUMNS {
        return Err(bad(field::WIDTH, "splat regions are at most 504 columns wide (9-bit X)"));
    }
    let prim_ids = req.flags & render_flags::PRIM_IDS != 0 && !job.crc_only;
    spans.begin_with(req.frame, prim_ids, req.encoding, job.max_span);
    spans.set_silent(job.crc_only);
    let mut table = [[MaterialTerm::default(); 3]; 128];
    let used = scene.materials.len().clamp(1, 128);
    let ambient = material_terms(scene, job, table.get_mut(..used).unwrap_or(&mut []));
    let bg = to_rgb8(scene.lighting.background);
    let background = (bg[0] as u32) << 16 | (bg[1] as u32) << 8 | bg[2] as u32;
    let mut st = SplatStats::default();
    let mut encode = [0u64; 2];
    let mut pixels = 0u64;
    // The stage clock gives the low words of the counters (32-bit stamps, wrapping): the
    // pass takes differences of 64-bit readings, extended here from the wrapping deltas.
    let last = core::cell::Cell::new(clock.now());
    let total = core::cell::Cell::new([0u64; 2]);
    let now = || {
        let c = clock.now();
        let l = last.replace(c);
        let [cy, ir] = total.get();
        let t = [
            cy.wrapping_add(u64::from(c.cycles.wrapping_sub(l.cycles))),
            ir.wrapping_add(u64::from(c.instret.wrapping_sub(l.instret))),
        ];
        total.set(t);
        t
    };
    if let Some((view, light)) = view_of(engine, scene, job) {
        let pass = Pass { x0: region.x0, y0: region.y0, columns: region.cols, rows: region.rows };
        let mut line = |y: u16, colours: &[u32], depths: &[u16]| -> Result<(), TxError> {
            let a = now();
            for (i, (&c, &d)) in colours.iter().zip(depths).enumerate() {
                let rgb = [(c >> 16) as u8, (c >> 8) as u8, c as u8];
                let aux = if d == BACKGROUND_DEPTH { u32::MAX } else { d as u32 };
                spans.push(region.x0.wrapping_add(i as u16), y, rgb, aux, tx, out)?;
            }
            pixels = pixels.wrapping_add(colours.len() as u64);
            let r = spans.flush(tx, out);
            let b = now();
            encode = [encode[0].wrapping_add(b[0].wrapping_sub(a[0])), encode[1].wrapping_add(b[1].wrapping_sub(a[1]))];
            r
        };
        st = engine
            .render_pass(&view, &light, &pass, table.get(..used).unwrap_or(&[]), ambient, background, &now, &mut line)
            .map_err(|e| match e {
                PassError::Line(t) => Fail::tx(t),
                PassError::Table(_) => Fail::Plain(ErrorCode::BadRequest, field::FLAGS, "shape table does not fit"),
                PassError::Stage(_) => Fail::Plain(ErrorCode::BadRequest, field::FLAGS, "splat stage refused a word"),
            })?;
        st.stage_clock = [st.stage_clock[0].wrapping_sub(encode[0]), st.stage_clock[1].wrapping_sub(encode[1])];
    } else {
        // The cloud is behind the camera: every pixel is background.
        for y in region.y0..region.y0.saturating_add(region.rows) {
            for x in region.x0..region.x0.saturating_add(region.cols) {
                spans.push(x, y, bg, u32::MAX, tx, out).map_err(Fail::tx)?;
                pixels = pixels.wrapping_add(1);
            }
            spans.flush(tx, out).map_err(Fail::tx)?;
        }
    }
    let (n, crc) = spans.finish();
    let c = &st.codegen;
    let plan = req.flags & (render_flags::SPLATS | render_flags::SPLAT_PIXEL_DEPTH);
    let entries: [(u8, u64); SPLAT_STATS] = [
        (stat::PIXELS, pixels),
        (stat::PLAN, plan as u64),
        (stat::SPLAT_POINTS, c.points),
        (stat::SPLAT_CODEWORDS, c.codewords),
        (stat::SPLAT_CULLED, c.culled),
        (stat::SPLAT_CLAMPED, c.clamped),
        (stat::SPLAT_COMMANDS, c.commands),
        (stat::SPLAT_FRAGMENTS, st.fragments),
        (stat::STAGE_SPLAT_CODEGEN, st.codegen_clock[1]),
        (stat::STAGE_SPLAT_CODEGEN.wrapping_add(1), st.codegen_clock[0]),
        (stat::STAGE_SPLAT_STAGE, st.stage_clock[1]),
        (stat::STAGE_SPLAT_STAGE.wrapping_add(1), st.stage_clock[0]),
        (Stage::Encode.instret_key(), encode[1]),
        (Stage::Encode.cycles_key(), encode[0]),
        (stat::COPROC_CYCLES, 0),
    ];
    let mut bytes = [0u8; SPLAT_STATS * STAT_ENTRY_LEN];
    for ((k, v), dst) in entries.iter().zip(bytes.chunks_exact_mut(STAT_ENTRY_LEN)) {
        if let Some((key, val)) = dst.split_first_mut() {
            *key = *k;
            val.copy_from_slice(&v.to_le_bytes());
        }
    }
    if let Err(TxError::Write(_)) = tx.send(&Msg::Stats { frame: req.frame, entries: &bytes }, out) {
        return Err(Fail::Output);
    }
    Ok((n, crc))
}

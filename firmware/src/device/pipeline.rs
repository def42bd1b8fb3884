//! The per-pixel pipeline of a frame: primary ray, shading (`crate::shade`: matte, ViRAY's
//! models, textures), shadow and reflection rays, and row interpolation (`crate::interp`),
//! following the pipeline plan of the request (SPEC.md §3.13).
//!
//! The plan decides what runs: no shadow rays without a light (or with `SHADOWS` clear), no
//! reflection rays without `REFLECTIONS` (the host clears it when no material reflects), no
//! texture stage without `TEXTURES`, no specular term without `SPECULAR`. Shadow rays are
//! any-hit queries; a ray whose list is empty (it misses the grid box or meets only empty
//! voxels) costs no FSL words. A plan bit whose stage is compiled out (cargo features
//! `reflections`, `textures`, `specular`) is refused with `Error{BadRequest}`.

use super::fail::Fail;
use super::farm::{RowDone, RowFarm, Rows};
use super::pixel::{pixel, FrameCtx};
use super::raypath::RayPath;
use super::request::{field, Job};
use super::scene::SceneStore;
use super::stats::{count, FrameStats, Stage, StageClock, Stopwatch};
use crate::fsl::FslLink;
use crate::interp::{self, Counts, Sample, StepControl};
use crate::pixels::{FrameTx, SpanEncoder, TxError};
use core::ops::ControlFlow;
use embedded_io::Write;
use gridrt_shared::msg::{feature, render_flags, ErrorCode, Msg};

/// Widest row the interpolation buffer holds.
pub const MAX_INTERP_WIDTH: usize = 2048;

/// The plan bits this build honours.
const fn compiled_plan() -> u16 {
    let r = if cfg!(feature = "reflections") { render_flags::REFLECTIONS } else { 0 };
    let t = if cfg!(feature = "textures") { render_flags::TEXTURES } else { 0 };
    let s = if cfg!(feature = "specular") { render_flags::SPECULAR } else { 0 };
    r | t | s
}

/// Feature bits of the stages in this module.
pub const fn pipeline_features() -> u32 {
    let r = if cfg!(feature = "reflections") { feature::REFLECTIONS } else { 0 };
    let t = if cfg!(feature = "textures") { feature::TEXTURES } else { 0 };
    let s = if cfg!(feature = "specular") { feature::SPECULAR } else { 0 };
    r | t | s | feature::INTERP | feature::ANALYTIC_PRIMITIVES
}

/// Refuses a plan that names a stage missing from `compiled` (the build's plan bits).
pub(super) fn check_plan(flags: u16, compiled: u16) -> Result<(), &'static str> {
    let missing = flags & (render_flags::REFLECTIONS | render_flags::TEXTURES | render_flags::SPECULAR) & !compiled;
    if missing & render_flags::TEXTURES != 0 {
        return Err(
            "the scene needs textures but this firmware was built without the texture stage (feature `textures`)",
        );
    }
    if missing & render_flags::REFLECTIONS != 0 {
        return Err("the scene needs reflections but this firmware was built without the reflection stage (feature `reflections`)");
    }
    if missing & render_flags::SPECULAR != 0 {
        return Err("the scene needs specular highlights but this firmware was built without the specular stage (feature `specular`)");
    }
    Ok(())
}

/// The frame-rendering half of the device: the ray path, the stage clock, the span encoder,
/// the row buffer of the interpolation and the row farm (`farm`).
pub(super) struct Renderer<L, C, F> {
    /// The co-processor link, traversal list and frame counters.
    pub(super) path: RayPath<L>,
    clock: C,
    spans: SpanEncoder,
    /// Row buffer of the row interpolation.
    row: [Sample; MAX_INTERP_WIDTH],
    farm: F,
}

impl<L: FslLink, C: StageClock, F: RowFarm<L>> Renderer<L, C, F> {
    /// The stage clock (the splat path times its stages with it too).
    #[cfg(feature = "splats")]
    pub(super) fn clock(&self) -> &C {
        &self.clock
    }

    /// A renderer over `link`, timed by `clock`, with rows traced by `farm` when it takes
    /// them.
    pub(super) fn new(link: L, clock: C, farm: F) -> Self {
        Self {
            path: RayPath::new(link),
            clock,
            spans: SpanEncoder::new(),
            row: [Sample::default(); MAX_INTERP_WIDTH],
            farm,
        }
    }

    /// Renders `job` and sends its spans and `Stats` through `tx`; returns (spans, CRC of the
    /// decoded pixels). On `Err` the frame stopped: nothing more is to be sent for it but the
    /// report of the failure.
    pub(super) fn frame<const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(u32, u32), Fail> {
        let req = job.req;
        self.path.stats = FrameStats::default();
        let prim_ids = req.flags & render_flags::PRIM_IDS != 0 && !job.crc_only;
        if job.span_bytes {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, 0);
            self.spans.set_data_limit(job.max_span);
        } else {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, job.max_span);
        }
        self.spans.set_silent(job.crc_only);
        self.pixels(scene, tx, job, out)?;
        let (spans, crc) = self.spans.finish();
        if job.no_stats {
            return Ok((spans, crc));
        }
        let entries = self.path.stats.to_bytes();
        // Only a write error stops the frame here (a `Stats` that does not fit a frame would be
        // a firmware bug, and the frame's pixels are all out).
        if let Err(TxError::Write(_)) = tx.send(&Msg::Stats { frame: req.frame, entries: &entries }, out) {
            return Err(Fail::Output);
        }
        Ok((spans, crc))
    }

    /// The frame context and the plan the device follows, or the refusal of a plan bit whose
    /// stage this build does not have.
    fn frame_ctx<const N: usize>(scene: &SceneStore<N>, job: &Job<'_>) -> Result<FrameCtx, Fail> {
        let req = job.req;
        check_plan(req.flags, compiled_plan()).map_err(|t| Fail::Plain(ErrorCode::BadRequest, field::FLAGS, t))?;
        let shadows =
            cfg!(feature = "shadows") && req.flags & render_flags::SHADOWS != 0 && scene.lighting.light_count > 0;
        Ok(FrameCtx {
            cam: job.cam,
            light: job.light,
            shadows,
            reflections: req.flags & render_flags::REFLECTIONS != 0 && scene.lighting.max_depth > 1,
            textures: req.flags & render_flags::TEXTURES != 0,
            specular: req.flags & render_flags::SPECULAR != 0,
            diag: scene.grid.aabb().diagonal().length(),
        })
    }

    /// Row-major render loop of `region`; returns early (frame aborted) on any co-processor
    /// failure.
    fn pixels<const N: usize>(
        &mut self,
        scene: &SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        let (req, region) = (job.req, job.region);
        let ctx = Self::frame_ctx(scene, job)?;
        let step = render_flags::interp_step(req.flags);
        let params = interp::Params {
            step,
            eps: render_flags::interp_eps(req.flags),
            adaptive: req.flags & render_flags::INTERP_ADAPTIVE != 0,
        };
        let interpolate = step > 0;
        if interpolate && region.cols as usize > MAX_INTERP_WIDTH {
            return Err(Fail::Plain(
                ErrorCode::BadRequest,
                field::FLAGS,
                "row interpolation supports rows of at most 2048 pixels",
            ));
        }
        let mut plan = 0u16;
        for (on, bit) in [
            (ctx.shadows, render_flags::SHADOWS),
            (ctx.reflections, render_flags::REFLECTIONS),
            (ctx.textures, render_flags::TEXTURES),
            (ctx.specular, render_flags::SPECULAR),
        ] {
            if on {
                plan |= bit;
            }
        }
        if interpolate {
            plan |= req.flags
                & (render_flags::INTERP_STEP_MASK | render_flags::INTERP_EPS_MASK | render_flags::INTERP_ADAPTIVE);
        }
        self.path.stats.plan = plan as u64;
        let mut sw = Stopwatch::start(&self.clock);
        let (x1, y1) = (region.x0.saturating_add(region.cols), region.y0.saturating_add(region.rows));
        if !interpolate {
            let rows =
                Rows { scene, ctx: &ctx, x0: region.x0, cols: region.cols, ys: region.y0..y1, polls: self.path.polls };
            if let Some(r) = self.farmed(&rows, tx, out) {
                return r;
            }
        }
        let mut counts = Counts::default();
        let mut ctl = StepControl::new(&params);
        for y in region.y0..y1 {
            if interpolate {
                let w = region.cols as usize;
                let before = counts;
                let (path, clock) = (&mut self.path, &self.clock);
                let row = self.row.get_mut(..w).unwrap_or(&mut []);
                // `region` lies inside the image (≤ 4096 wide): x0 + xi does not wrap.
                interp::fill_row(row, ctl.step, params.eps, &mut counts, |xi| {
                    pixel(path, scene, clock, &mut sw, &ctx, region.x0.wrapping_add(xi as u16), y)
                })?;
                ctl.after_row(&before, &counts);
                for (x, s) in (region.x0..x1).zip(self.row.iter()) {
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    count(&mut self.path.stats.pixels, 1);
                }
                sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
            } else {
                for x in region.x0..x1 {
                    let s = pixel(&mut self.path, scene, &self.clock, &mut sw, &ctx, x, y)?;
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    count(&mut self.path.stats.pixels, 1);
                    sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
                }
            }
            // Flush per row so the host sees progress while the next row renders.
            self.spans.flush(tx, out).map_err(Fail::tx)?;
            sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
        }
        self.path.stats.interpolated_pixels = counts.interpolated;
        self.path.stats.interp_retraces = counts.retraces;
        Ok(())
    }

    /// The rows of a frame without interpolation through the farm, sent as the loop of
    /// [`pixels`](Self::pixels) sends them (the farm only exists with a clock that reads 0,
    /// so the stage laps that loop takes add nothing); `None` when the farm does not take
    /// the frame.
    fn farmed<const N: usize>(
        &mut self,
        rows: &Rows<'_, N>,
        tx: &mut FrameTx,
        out: &mut impl Write,
    ) -> Option<Result<(), Fail>> {
        let (spans, stats) = (&mut self.spans, &mut self.path.stats);
        let mut result = Ok(());
        let x0 = rows.x0;
        let mut sink = |row: RowDone<'_>| {
            stats.accumulate(&row.stats);
            let n = row.fault.map_or(row.samples.len(), |f| f.done);
            for (x, s) in (x0..).zip(row.samples.iter().take(n)) {
                if let Err(e) = spans.push(x, row.y, s.rgb, s.prim, tx, out) {
                    result = Err(Fail::tx(e));
                    return ControlFlow::Break(());
                }
                count(&mut stats.pixels, 1);
            }
            if let Some(f) = row.fault {
                result = Err(f.fail);
                return ControlFlow::Break(());
            }
            match spans.flush(tx, out) {
                Ok(()) => ControlFlow::Continue(()),
                Err(e) => {
                    result = Err(Fail::tx(e));
                    ControlFlow::Break(())
                }
            }
        };
        self.farm.render(&self.path.link, rows, &mut sink).then_some(result)
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests {
    use super::{check_plan, compiled_plan, pipeline_features};
    use gridrt_shared::msg::{feature, render_flags};

    #[test]
    fn a_build_without_a_stage_refuses_plans_that_need_it() {
        let all = render_flags::REFLECTIONS | render_flags::TEXTURES | render_flags::SPECULAR;
        let no_textures = all & !render_flags::TEXTURES;
        let e = check_plan(render_flags::TEXTURES | render_flags::SHADOWS, no_textures).unwrap_err();
        assert!(e.contains("without the texture stage"), "{e}");
        assert!(check_plan(render_flags::REFLECTIONS | render_flags::SHADOWS, no_textures).is_ok());
        assert!(check_plan(render_flags::REFLECTIONS, 0).unwrap_err().contains("reflection"));
        assert!(check_plan(render_flags::SPECULAR, 0).unwrap_err().contains("specular"));
        // This build: whatever its features, it refuses exactly what it lacks.
        assert_eq!(check_plan(render_flags::TEXTURES, compiled_plan()).is_ok(), cfg!(feature = "textures"));
        assert_eq!(pipeline_features() & feature::TEXTURES != 0, cfg!(feature = "textures"));
    }
}

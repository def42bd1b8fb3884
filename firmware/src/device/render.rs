//! The frame loop of the device: renders a job row by row through the per-pixel pipeline
//! (`pipeline::pixel`), with row interpolation (`crate::interp`) and background runs for the
//! columns the camera rays cannot reach (`crate::cull`), or hands a frame without
//! interpolation to a [`RowFarm`] and sends its rows as its own loop does; then the frame's
//! `Stats`.

use core::ops::ControlFlow;

use embedded_io::Write;
use gridrt_shared::msg::{render_flags, ErrorCode, Msg};
use gridrt_shared::scene::Falloff;

use super::fail::Fail;
use super::farm::{RowDone, RowFarm, Rows};
use super::pipeline::{check_plan, compiled_plan, open_pixel, pixel, FrameCtx};
use super::raypath::RayPath;
use super::request::{field, Job};
use super::scene::{SceneStore, LIGHT_CELLS_MAX_VOXELS};
use super::stats::{count, cycles_between, FrameStats, FrameWriter, Stage, StageClock, Stopwatch, UploadWork};
use crate::camera::ColumnTerms;
use crate::cull::{BoxSpans, OccupancyMask};
use crate::dda::VoxelMap;
use crate::fsl::FslLink;
use crate::interp::{self, Counts, Sample, StepControl};
use crate::pixels::{FrameTx, SpanEncoder, TxError};
use crate::shade;

/// Widest row the interpolation buffer holds.
pub const MAX_INTERP_WIDTH: usize = 2048;

/// The frame-rendering half of the device: the ray path, the stage clock, the span encoder,
/// the row buffer of the interpolation and the row farm.
pub(super) struct Renderer<L, C, F> {
    /// The co-processor link, traversal list and frame counters.
    pub(super) path: RayPath<L>,
    clock: C,
    spans: SpanEncoder,
    /// Row buffer of the row interpolation.
    row: [Sample; MAX_INTERP_WIDTH],
    farm: F,
    /// What loading the current scene cost: sent with every frame's `Stats`.
    pub(super) upload: UploadWork,
}

impl<L: FslLink, C: StageClock, F: RowFarm<L>> Renderer<L, C, F> {
    /// The stage clock (the splat path and the upload are timed with it too).
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
            upload: UploadWork::default(),
        }
    }

    /// Renders `job` and sends its spans and `Stats` through `tx`; returns (spans, CRC of the
    /// decoded pixels). On `Err` the frame stopped: nothing more is to be sent for it but the
    /// report of the failure.
    pub(super) fn frame<const N: usize>(
        &mut self,
        scene: &mut SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(u32, u32), Fail> {
        let req = job.req;
        self.path.stats = FrameStats { upload: self.upload, ..FrameStats::default() };
        let prim_ids = req.flags & render_flags::PRIM_IDS != 0 && !job.crc_only;
        if job.span_bytes {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, 0);
            self.spans.set_data_limit(job.max_span);
        } else {
            self.spans.begin_with(req.frame, prim_ids, req.encoding, job.max_span);
        }
        self.spans.set_silent(job.crc_only);
        let excluded = self.clock.excluded();
        let arrival = self.clock.now();
        let mut wire = FrameWriter::new(out, self.clock.clone());
        let drawn = self.pixels(scene, tx, job, &mut wire);
        self.path.settle();
        drawn?;
        // The frame ends when its last byte has left the transmit FIFO (SPEC.md §3.8).
        wire.flush().map_err(|_| Fail::Output)?;
        let drained = self.clock.now();
        self.path.stats.frame_cycles = cycles_between(arrival, drained);
        self.path.stats.link_cycles = wire.first.map_or(0, |first| cycles_between(first, drained));
        self.path.stats.frame_tx_bytes = wire.bytes;
        let now = self.clock.excluded();
        self.path.stats.model_instructions = now.model.wrapping_sub(excluded.model);
        self.path.stats.link_wrapper_instructions = now.link_wrapper.wrapping_sub(excluded.link_wrapper);
        let (spans, crc) = self.spans.finish();
        if job.no_stats {
            return Ok((spans, crc));
        }
        let (bytes, len) = self.path.stats.to_bytes();
        let entries = bytes.get(..len).unwrap_or(&bytes);
        // Only a write error stops the frame here (a `Stats` that does not fit a frame would be
        // a firmware bug, and the frame's pixels are all out).
        if let Err(TxError::Write(_)) = tx.send(&Msg::Stats { frame: req.frame, entries }, out) {
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
        // A camera ray that sends nothing ends at bounce 0 with `acc = 0 + 1·background`.
        let background = scene.lighting.background.map(|b| 0.0 + 1.0 * b);
        let lighting = &scene.lighting;
        let light = job.light;
        let direct = shade::DirectLight {
            pos: light.pos,
            radiance: lighting.light_colour.map(|c| c * light.intensity),
            specular: req.flags & render_flags::SPECULAR != 0,
        };
        let diag = scene.grid.aabb().diagonal().length();
        Ok(FrameCtx {
            cam: job.cam,
            columns: ColumnTerms::default(),
            ambient: lighting.ambient_colour.map(|c| c * light.ambient),
            lit: lighting.light_count > 0 && direct.radiance.iter().any(|&c| c != 0.0),
            direct,
            spot: shade::SpotCone::of(lighting),
            eps_diag: shade::SHADOW_EPS_DIAG * diag,
            spans: BoxSpans::new(&job.cam, &scene.grid.aabb()),
            occupancy: OccupancyMask::new(&job.cam, &scene.grid, scene.map().pe),
            background: Sample { rgb: shade::to_rgb8(background), prim: interp::MISS, t: f32::INFINITY },
            shadows,
            reflections: req.flags & render_flags::REFLECTIONS != 0 && scene.lighting.max_depth > 1,
            textures: req.flags & render_flags::TEXTURES != 0,
            specular: req.flags & render_flags::SPECULAR != 0,
            bytes: shade::MatteBytes::default(),
            estimate_light: false,
        })
    }

    /// Pixels `from..to` of row `y`, whose camera rays cannot enter the grid box
    /// ([`background_run`]).
    fn background(
        &mut self,
        bg: &Sample,
        from: u16,
        to: u16,
        y: u16,
        tx: &mut FrameTx,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        background_run(&mut self.spans, &mut self.path.stats, bg, from, to, y, tx, out)
    }

    /// Row-major render loop of `region`; returns early (frame aborted) on any co-processor
    /// failure.
    fn pixels<const N: usize>(
        &mut self,
        scene: &mut SceneStore<N>,
        tx: &mut FrameTx,
        job: &Job<'_>,
        out: &mut impl Write,
    ) -> Result<(), Fail> {
        let (req, region) = (job.req, job.region);
        // The frame's setup (camera, spans, the occupancy mask: work per non-empty cell, per
        // column) is ray generation's, and counted as such.
        let mut sw = Stopwatch::start(&self.clock);
        let mut ctx = Self::frame_ctx(scene, job)?;
        // Shadow rays take their lists from the light's cells (built once per light) on grids
        // where the build pays.
        let cells = ctx.shadows && scene.voxels <= LIGHT_CELLS_MAX_VOXELS;
        if cells && !scene.light_cells.is_built_for(ctx.direct.pos) {
            let map = VoxelMap { pe: scene.voxel_pe.get(..scene.voxels).unwrap_or(&[]), ahead: &[] };
            scene.light_cells.build(&scene.walk, map, ctx.direct.pos);
        }
        let scene = &*scene;
        ctx.columns.fill(&ctx.cam, req.width, cfg!(soft_float));
        if cfg!(soft_float) {
            let plan = (ctx.direct.specular, ctx.textures, ctx.reflections);
            let radiance = if ctx.lit { ctx.direct.radiance } else { [0.0; 3] };
            ctx.bytes = shade::MatteBytes::new(&scene.materials, &scene.material_model, ctx.ambient, radiance, plan);
            ctx.estimate_light = ctx.lit && scene.lighting.falloff == Falloff::None && ctx.spot.is_none();
        }
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
        let (x1, y1) = (region.x0.saturating_add(region.cols), region.y0.saturating_add(region.rows));
        if !interpolate {
            let rows = Rows {
                scene,
                ctx: &ctx,
                width: req.width,
                x0: region.x0,
                x1,
                ys: region.y0..y1,
                polls: self.path.polls,
            };
            if let Some(r) = self.farmed(&rows, tx, out) {
                return r;
            }
        }
        // Timed frames only (the farm's are not): the setup, charged to ray generation.
        sw.lap(&self.clock, &mut self.path.stats, Stage::RayGen);
        let mut counts = Counts::default();
        let mut ctl = StepControl::new(&params);
        for y in region.y0..y1 {
            // Columns outside the row's span see only the background (`crate::cull`).
            let (cols, rays) = ctx.row(y, req.width, region.x0, x1);
            let (lo, hi) = (cols.start, cols.end);
            if interpolate {
                let w = region.cols as usize;
                let before = counts;
                let (path, clock) = (&mut self.path, &self.clock);
                let row = self.row.get_mut(..w).unwrap_or(&mut []);
                // `region` lies inside the image (≤ 4096 wide): x0 + xi does not wrap.
                interp::fill_row(row, ctl.step, params.eps, &mut counts, |xi| {
                    let x = region.x0.wrapping_add(xi as u16);
                    if x < lo || x >= hi {
                        count(&mut path.stats.primary_rays, 1);
                        count(&mut path.stats.culled_rays, 1);
                        return Ok(ctx.background);
                    }
                    pixel(path, scene, clock, &mut sw, &ctx, &rays, x)
                })?;
                ctl.after_row(&before, &counts);
                for (x, s) in (region.x0..x1).zip(self.row.iter()) {
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    count(&mut self.path.stats.pixels, 1);
                }
                sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
            } else {
                self.background(&ctx.background, region.x0, lo, y, tx, out)?;
                // The run before the traced columns is encoding, not the first pixel's raygen.
                sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
                // Pixels in clear tiles of the occupancy mask are the background without a ray
                // (`pixel` would return it at once): each run of them goes out as one
                // background run, like the columns outside the span.
                let mut clear_from = None;
                // The row's traced pixels, each a primary ray: counted once per row.
                let mut traced = 0u32;
                for x in lo..hi {
                    if !ctx.occupancy.may_hit(x, y) {
                        clear_from = clear_from.or(Some(x));
                        continue;
                    }
                    if let Some(from) = clear_from.take() {
                        self.background(&ctx.background, from, x, y, tx, out)?;
                        sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
                    }
                    traced = traced.wrapping_add(1);
                    let s = open_pixel(&mut self.path, scene, &self.clock, &mut sw, &ctx, &rays, x)?;
                    self.spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
                    sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
                }
                count(&mut self.path.stats.primary_rays, u64::from(traced));
                count(&mut self.path.stats.pixels, u64::from(traced));
                self.background(&ctx.background, clear_from.unwrap_or(hi), x1, y, tx, out)?;
            }
            // Flush per row so the host sees progress while the next row renders.
            self.spans.flush(tx, out).map_err(Fail::tx)?;
            sw.lap(&self.clock, &mut self.path.stats, Stage::Encode);
            sw.flush(&mut self.path.stats);
            self.path.settle();
        }
        self.path.stats.interpolated_pixels = counts.interpolated;
        self.path.stats.interp_retraces = counts.retraces;
        Ok(())
    }

    /// The rows of a frame without interpolation through the farm, sent as the loop of
    /// [`pixels`](Self::pixels) sends them, without its stage laps (the farm's rows are not
    /// timed: with a clock only the whole frame is); `None` when the farm does not take the
    /// frame.
    fn farmed<const N: usize>(
        &mut self,
        rows: &Rows<'_, N>,
        tx: &mut FrameTx,
        out: &mut impl Write,
    ) -> Option<Result<(), Fail>> {
        let (spans, path) = (&mut self.spans, &mut self.path);
        let (link, stats) = (&path.link, &mut path.stats);
        let mut result = Ok(());
        let mut sink = |row: RowDone<'_>| {
            result = farmed_row(spans, stats, rows, &row, tx, out);
            if result.is_ok() {
                ControlFlow::Continue(())
            } else {
                ControlFlow::Break(())
            }
        };
        self.farm.render(link, rows, &mut sink).then_some(result)
    }
}

/// Sends a farmed row as the device loop sends a row: the background before its traced
/// columns, their samples, the background after, then the flush.
fn farmed_row<const N: usize>(
    spans: &mut SpanEncoder,
    stats: &mut FrameStats,
    rows: &Rows<'_, N>,
    row: &RowDone<'_>,
    tx: &mut FrameTx,
    out: &mut impl Write,
) -> Result<(), Fail> {
    stats.accumulate(&row.stats);
    let (bg, y) = (&rows.ctx.background, row.y);
    let cols = rows.columns(y);
    background_run(spans, stats, bg, rows.x0, cols.start, y, tx, out)?;
    let n = row.fault.map_or(cols.len(), |f| f.done);
    for (x, s) in cols.clone().zip(row.samples.iter().take(n)) {
        spans.push(x, y, s.rgb, s.prim, tx, out).map_err(Fail::tx)?;
        count(&mut stats.pixels, 1);
    }
    if let Some(f) = row.fault {
        return Err(f.fail);
    }
    background_run(spans, stats, bg, cols.end, rows.x1, y, tx, out)?;
    spans.flush(tx, out).map_err(Fail::tx)
}

/// Pixels `from..to` of row `y`, whose camera rays cannot enter the grid box: counted as
/// traced rays with empty lists (as tracing them would) and sent as one background run.
#[allow(clippy::too_many_arguments)]
fn background_run(
    spans: &mut SpanEncoder,
    stats: &mut FrameStats,
    bg: &Sample,
    from: u16,
    to: u16,
    y: u16,
    tx: &mut FrameTx,
    out: &mut impl Write,
) -> Result<(), Fail> {
    let n = to.saturating_sub(from);
    if n == 0 {
        return Ok(());
    }
    for c in [&mut stats.primary_rays, &mut stats.culled_rays, &mut stats.pixels] {
        count(c, u64::from(n));
    }
    spans.push_run(from, y, n, bg.rgb, bg.prim, tx, out).map_err(Fail::tx)
}

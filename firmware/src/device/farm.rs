//! Row farms: the rows of a frame traced away from the device loop. A simulator's worker
//! threads each trace rows on a link of their own to the same co-processor ([`RowTracer`],
//! through the device loop's own `pipeline::pixel`) and the farm hands the device every row
//! in order ([`RowFarm`]: the [`Rows`] asked for, each [`RowDone`], a [`RowFault`]); the
//! device encodes and sends them as its own loop does (`render`).
//! Every pixel is a pure function of the frame, the scene and the co-processor's loaded
//! memories, so the bytes on the UART are the same whichever thread traced which row.
//!
//! On one hart the firmware has no farm ([`NoFarm`]): it renders every row itself. On the
//! LiteX SoC with worker harts the image's `HartFarm` shares each frame's rows with them.

use core::ops::{ControlFlow, Range};

use super::fail::Fail;
use super::pipeline::{pixel, FrameCtx};
use super::raypath::RayPath;
use super::scene::SceneStore;
use super::stats::{FrameStats, NoClock, Stopwatch};
use crate::fsl::FslLink;
use crate::interp::Sample;

/// The rows of one frame a [`RowFarm`] is asked to trace: the region's rows, each over the
/// columns its camera rays can enter the grid box through ([`Rows::columns`]).
pub struct Rows<'a, const N: usize> {
    pub(super) scene: &'a SceneStore<N>,
    pub(super) ctx: &'a FrameCtx,
    /// Image width (the culling spans depend on it).
    pub(super) width: u16,
    pub(super) x0: u16,
    pub(super) x1: u16,
    pub(super) ys: Range<u16>,
    pub(super) polls: u32,
}

impl<const N: usize> Rows<'_, N> {
    /// The rows, top to bottom.
    pub fn ys(&self) -> Range<u16> {
        self.ys.clone()
    }

    /// Most samples a row has (the region's width).
    pub fn width(&self) -> usize {
        self.x1.wrapping_sub(self.x0) as usize
    }

    /// The columns of row `y` that are traced; the rest of the region's row is background.
    pub fn columns(&self, y: u16) -> Range<u16> {
        self.ctx.row(y, self.width, self.x0, self.x1).0
    }
}

/// A pixel of a row failed: the frame stops there, as it does in the device loop.
#[derive(Debug, Clone, Copy)]
pub struct RowFault {
    /// Samples of the row done before the failing pixel.
    pub(super) done: usize,
    pub(super) fail: Fail,
}

impl RowFault {
    /// Samples of the row done before the failing pixel.
    pub fn done(&self) -> usize {
        self.done
    }
}

/// One traced row, handed to the device.
pub struct RowDone<'s> {
    /// The row.
    pub y: u16,
    /// The samples of its [`Rows::columns`] (all of them unless `fault`).
    pub samples: &'s [Sample],
    /// The failure that stopped the row, if any.
    pub fault: Option<RowFault>,
    /// What tracing the row counted (`RowTracer::take_stats` after it).
    pub stats: FrameStats,
}

/// Traces the rows of a frame for the device, possibly on other threads.
pub trait RowFarm<L> {
    /// Traces every row of `rows` and hands each to `sink` in order, top to bottom; stops
    /// after a row with a fault or when `sink` breaks. Returns `false` without calling `sink`
    /// when it does not take this frame (e.g. `link` is not one it can share): the device
    /// then renders the frame on `link` itself.
    fn render<const N: usize>(
        &mut self,
        link: &L,
        rows: &Rows<'_, N>,
        sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool;
}

/// Traces rows of a frame on a link of its own, counting what it does in its own
/// [`FrameStats`] (the ray, FSL word and co-processor counters; stage clocks stay 0).
pub struct RowTracer<L> {
    path: RayPath<L>,
}

impl<L: FslLink> RowTracer<L> {
    /// A tracer over `link` with the device's poll budget.
    #[inline(always)]
    pub fn new<const N: usize>(rows: &Rows<'_, N>, link: L) -> Self {
        Self { path: RayPath::with_polls(link, rows.polls) }
    }

    /// Traces the [`Rows::columns`] of row `y` into `out`, left-aligned (`out` holds at
    /// least [`Rows::width`] samples). On a failure the samples before the failing pixel are
    /// in `out` and the rest of the row is not traced.
    pub fn row<const N: usize>(&mut self, rows: &Rows<'_, N>, y: u16, out: &mut [Sample]) -> Result<(), RowFault> {
        let mut sw = Stopwatch::start(&NoClock);
        let (cols, rays) = rows.ctx.row(y, rows.width, rows.x0, rows.x1);
        for (done, (x, slot)) in cols.zip(out.iter_mut()).enumerate() {
            match pixel(&mut self.path, rows.scene, &NoClock, &mut sw, rows.ctx, &rays, x) {
                Ok(s) => *slot = s,
                Err(fail) => return Err(RowFault { done, fail }),
            }
        }
        Ok(())
    }

    /// The counters since the last call; zeroes them.
    pub fn take_stats(&mut self) -> FrameStats {
        self.path.settle();
        core::mem::take(&mut self.path.stats)
    }
}

/// No farm: the device renders every row itself.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoFarm;

impl<L> RowFarm<L> for NoFarm {
    #[inline(always)]
    fn render<const N: usize>(
        &mut self,
        _link: &L,
        _rows: &Rows<'_, N>,
        _sink: &mut dyn FnMut(RowDone<'_>) -> ControlFlow<()>,
    ) -> bool {
        false
    }
}

//! Row farms: the rows of a frame traced away from the device loop. A simulator's worker
//! threads each trace rows on a link of their own to the same co-processor ([`RowTracer`],
//! through the device loop's own `pipeline::pixel`) and the farm hands the device every row
//! in order (`pipeline::RowFarm`); the device encodes and sends them as its own loop does.
//! Every pixel is a pure function of the frame, the scene and the co-processor's loaded
//! memories, so the bytes on the UART are the same whichever thread traced which row.
//!
//! The firmware has no farm ([`NoFarm`]): it renders every row itself.

use core::ops::ControlFlow;

use super::pipeline::{pixel, RowDone, RowFarm, RowFault, Rows};
use super::raypath::RayPath;
use super::stats::{FrameStats, NoClock, Stopwatch};
use crate::fsl::FslLink;
use crate::interp::Sample;

/// Traces rows of a frame on a link of its own, counting what it does in its own
/// [`FrameStats`] (the ray, FSL word and co-processor counters; stage clocks stay 0).
pub struct RowTracer<L> {
    path: RayPath<L>,
}

impl<L: FslLink> RowTracer<L> {
    /// A tracer over `link` with the device's poll budget.
    pub fn new<const N: usize>(rows: &Rows<'_, N>, link: L) -> Self {
        let mut path = RayPath::new(link);
        path.polls = rows.polls;
        Self { path }
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

//! The device state machine: UART frames in → scene load over FSL → render → frames out.
//!
//! I/O agnostic: bytes arrive through [`Device::feed`], leave through an
//! [`embedded_io::Write`] (blocking `write_all`, e.g. a `crate::bsp` UART), the
//! co-processor is any [`FslLink`](crate::fsl::FslLink), and stage timing comes from a [`StageClock`]. The same code
//! runs on the soft-core, in host tests and in the loopback simulator.
//!
//! Data path of one pixel (DESIGN.md §4, GridRT (Nery 2010) with the extended request of
//! `shared::fsl`): camera ray → 3D-DDA list of non-empty voxels (an empty list sends nothing)
//! → put 8 head words + 2 words per entry, control bit on the last → get the 8 result words →
//! Lambert shading (+ an any-hit shadow ray, feature `shadows`) → pixel span.
//!
//! Every wait on the link is a bounded poll ([`FslLink::get`](crate::fsl::FslLink::get)/[`FslLink::put`](crate::fsl::FslLink::put)); a timeout, a
//! link error, an ERROR word or a malformed answer aborts the frame with `Msg::Error` and the
//! device goes back to waiting for frames. Nothing allocates.
//!
//! | module | concern | uses |
//! | --- | --- | --- |
//! | `stats` | [`FrameStats`] (`Msg::Stats`), [`Stage`]s, [`StageClock`]s, the stage stopwatch | — |
//! | `fail` | why a frame or an upload stopped, and its `Msg::Error` code, detail and text | — |
//! | `scene` | the scene store and the upload that loads it ([`SceneSink`](gridrt_shared::scene::SceneSink), LOAD_PE over FSL) | `fail` |
//! | `raypath` | one ray's FSL request and response, drain after a failure | `stats`, `fail`, `scene` |
//! | `request` | render request checks, field offsets, the validated job | `fail` |
//! | `pipeline` | the per-pixel pipeline (primary, shadow and reflection rays, shading) and the plan checks; the per-frame constants | all of the above |
//! | `farm` | row farming: the [`RowFarm`] hook and what crosses it ([`Rows`], [`RowDone`], [`RowFault`]); [`RowTracer`]: a farm's rows traced through `pipeline`'s pixel on a link of their own; [`NoFarm`] | `fail`, `scene`, `stats`, `raypath`, `pipeline` |
//! | `render` | the frame loop: renders a job row by row (row interpolation, background runs), its rows on a [`RowFarm`] when one takes them, then `Stats` | all of the above |
//! | `splat` | a `SPLATS` job: the point-splatting path over the scene's points | `fail`, `request`, `scene`, `stats` |
//! | `machine` | the [`Device`] state machine: frames in, answers out | all of the above |
//!
//! Each module uses only those listed before it in its row, never the other way round.
#![deny(clippy::indexing_slicing, clippy::arithmetic_side_effects)]

mod fail;
mod farm;
mod machine;
mod pipeline;
mod raypath;
mod render;
mod request;
mod scene;
#[cfg(feature = "splats")]
mod splat;
mod stats;

pub use fail::{DETAIL_LINK_HARDWARE, DETAIL_LINK_OTHER, DETAIL_LINK_TIMEOUT, DETAIL_MSG_ERROR};
pub use farm::{NoFarm, RowDone, RowFarm, RowFault, RowTracer, Rows};
pub use machine::{compiled_features, Device};
pub use raypath::DEFAULT_POLLS;
pub use request::MAX_IMAGE_DIM;
pub use scene::{MAX_MATERIALS, MAX_OBJECTS};
pub use stats::{
    CounterClock, ExcludedWork, FrameStats, HartWork, NoClock, Stage, StageClock, StageCount, StageStamp, UploadWork,
    MAX_FRAME_HARTS, STAT_COUNT,
};

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::arithmetic_side_effects)] // tests index known-size buffers
mod tests;

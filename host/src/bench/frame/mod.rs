//! `gridrt bench frame`: the whole-frame time on the modelled board (soft-core,
//! co-processor and UART link, with what overlaps), per configuration and soft-core target,
//! with every image checked against the f64 reference.
//!
//! # What is measured, what is modelled
//! - **Instructions** (measured): each firmware image boots on QEMU `virt` with
//!   `-icount shift=0` and renders the frame over its UART; the device's per-stage
//!   `minstret` counters (raygen, traverse, FSL I/O, shade, encode) are the counts. On
//!   qemu-virt the co-processor model runs on the same hart behind a timed link that excludes
//!   its work; the link wrapper's own instructions (measured at boot, per FSL word, printed in
//!   the banner) are reported on a line of their own and not charged to the firmware.
//! - **Co-processor cycles** (modelled): the loopback simulator renders the same frame with
//!   the configuration's timing profile at the kernel and number format that ran
//!   ([`gridrt_coproc::TimingProfile::for_kernel`]). The bench refuses to report when a
//!   QEMU run and the loopback with its image's kernel did different work (rays, list
//!   entries, FSL words, tests), cycles or images.
//! - **Soft-core cycles**: instructions × the CPI of a named soft-core profile
//!   ([`CpuProfile`]; `cpu_source` = `"cpi-model"`, modelled), or, for the soft-float
//!   `riscv32imac` rows with `--cpu-measured`, each stage's instructions × that stage's CPI
//!   measured (`mcycle` / `minstret`) on the LiteX SoC's VexRiscv in Verilator
//!   ([`MeasuredCpi`]; `cpu_source` = `"rtl"`).
//! - **Link** (modelled): wire bytes of the render, both directions, at the baud rate (8N1),
//!   as the loopback sends them for the same frame (QEMU's slow UART makes the host
//!   re-request regions; those resent bytes are not the frame's).
//!   The scene upload is not part of the frame; its bytes and modelled time are reported
//!   apart.
//! - **Frame**: the [`timeline`] of those, with the overlaps written down there.
//! - **host-native** (measured): the same firmware code with the intersection called
//!   directly, compiled for this CPU, wall time of the best of several frames, single thread:
//!   the host-only comparison. No link.
//!
//! # Configurations
//! [`Configuration`]: `soft-core-only` (no co-processor: the firmware calls the kernel itself
//! and every instruction is counted), `gridrt` (GridRT's multi-cycle PEs), `pipelined`, `rtl`
//! (the RTL co-processor's kernel, format and cycles, on its own QEMU image), `host-native`,
//! and `soc`: the LiteX SoC simulated cycle by cycle, every figure measured by its own
//! counters (frame cycles from the render request's arrival to the last byte leaving the UART
//! at the baud rate in simulated time, per-stage `mcycle`/`minstret`). Every row runs at one
//! clock: `--clock-mhz`, or a SoC build report's routed clock (`--soc-build`), else the SoC's
//! 50 MHz target.
//!
//! | module | what | uses |
//! |---|---|---|
//! | `setup` | targets, configurations, the soft-core profile, options, events, errors | — |
//! | [`timeline`] | per-frame quantities → frame time, the overlaps, hand-checked tests | — |
//! | [`run`] | one frame on QEMU, on the loopback, natively; work-counter comparison | `setup` |
//! | [`soc`] | one frame on the LiteX SoC in Verilator (`cargo xtask soc sim`), measured by its own counters, and on `--sim --coproc rtl` | `setup`, `run` |
//! | `report` | the rows, JSON, CSV and the SVG of stacked bars | `setup`, `run`, `soc`, `timeline` |
//! | `bench` | the bench: reference, runs, cross-checks, rows | `setup`, `run`, `soc`, `report` |

mod bench;
mod report;
pub mod run;
mod setup;
pub mod soc;
#[cfg(test)]
mod tests;
pub mod timeline;

pub use bench::{prepare, rtl_skip_reason, run_bench};
pub use report::{critical_path, write_csv, write_svg, FrameReport, FrameRow};
pub use run::{run_native, run_on_loopback, run_on_qemu, work_differences, DeviceRun};
pub use setup::{
    kernel, BenchEvent, BenchOptions, Configuration, CoprocCycles, CpuProfile, FrameBenchError, Image, MeasuredCpi,
    SocClock, SocFloatHw, Target,
};
pub use timeline::{timeline, FrameWork, Timeline};

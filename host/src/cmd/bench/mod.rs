//! `gridrt bench`: one file per bench (the library's benches are `gridrt_host::bench`), and the
//! plotting helpers they share (`plot`).

pub mod accuracy;
pub mod frame;
pub mod link;
pub mod link_faults;
pub mod pe_cache;
pub mod plot;
pub mod rays;
pub mod skip;
pub mod splat;
pub mod stream;

/// Benchmarks.
#[derive(Debug, clap::Parser)]
pub struct Cmd {
    #[command(subcommand)]
    what: What,
}

#[derive(Debug, clap::Subcommand)]
enum What {
    /// Primary rays through the native path: firmware camera → 3D-DDA → co-processor search
    /// on the loaded PE images (no cycle model, no UART, no shading), by default the fast
    /// native path (same result words as the model's `trace_untimed`, checked on every
    /// pixel), optionally on several threads and beside Embree. Reports the best of --runs
    /// after --warmup runs.
    Rays(rays::Args),
    /// Accuracy against run time of every intersection kernel and number format.
    Accuracy(accuracy::Args),
    /// What the pipeline plan and row interpolation save: rays, FSL words and modeled time
    /// with and without each skip, traced pixels vs PSNR over (l, EPS), and the ViRAY-like
    /// demo at 1920×1080 (CSV, SVG plot and JSON in --out-dir).
    Skip(skip::Args),
    /// The serial link: wire bytes per frame, payload efficiency against the line
    /// rate and compression per pixel encoding on the bundled scenes, modelled frame time
    /// with transmission overlapped with ray work at 115 200 / 921 600 / 3 000 000 baud, on
    /// 1, 2 and 4 boards (CSV, SVG plot and JSON in --out-dir).
    Link(link::Args),
    /// The whole frame on the modelled board (soft-core instructions measured on QEMU,
    /// co-processor cycles from the timing model, UART link, and what overlaps), per
    /// configuration (soft-core-only, gridrt, pipelined, host-native) and soft-core target
    /// (riscv32imac, riscv32imafc); every image checked against the f64 reference (JSON,
    /// and CSV + SVG in --out-dir).
    Frame(frame::Args),
    /// Point splats: native splats/s and image error against the ray-traced disks for
    /// 10³…10⁶ points and several shape tables, optionally soft-core instructions per splat
    /// from QEMU (`--port`); CSV, SVG plot and JSON in --out-dir.
    Splat(splat::Args),
    /// Frames as a stream: fps and link goodput for a scene × baud × encoding, on the
    /// loopback simulator with its line paced at each baud rate and once unpaced (the
    /// device's own frame rate); every frame checked against the unpaced run's (CSV, SVG
    /// plot and JSON in --out-dir).
    Stream(stream::Args),
    /// A per-PE cache for PE images kept in SDRAM instead of block RAM: one frame per scene
    /// through the co-processor model (the RTL's kernel, format and timing), every PE's
    /// memory reads replayed through each cache size × line × ways (LRU); hit rates
    /// (measured), cycles per ray with a modelled LiteDRAM miss penalty, and DP16KD blocks
    /// per PE (CSV, SVG plot and JSON in --out-dir).
    PeCache(pe_cache::Args),
}

impl Cmd {
    /// Runs the command.
    pub fn run(self) -> anyhow::Result<()> {
        match self.what {
            What::Rays(a) => a.run(),
            What::Accuracy(a) => a.run(),
            What::Skip(a) => a.run(),
            What::Link(a) => a.run(),
            What::Frame(a) => a.run(),
            What::Splat(a) => a.run(),
            What::Stream(a) => a.run(),
            What::PeCache(a) => a.run(),
        }
    }
}

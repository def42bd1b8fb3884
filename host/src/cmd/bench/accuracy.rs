//! `gridrt bench accuracy --out-dir DIR`: every intersection kernel in every number format on the
//! bundled scenes, against the f64 reference; writes `DIR/accuracy.csv` and
//! `DIR/accuracy.svg` (library: [`gridrt_host::bench::accuracy`]).

use std::path::PathBuf;

use anyhow::{anyhow, Context};
use gridrt_coproc::{KernelKind, NumberFormat};
use gridrt_firmware::fixed::RayFormat;
use gridrt_host::bench::accuracy::{self as acc, AccuracyEvent, AccuracyOptions};

/// Accuracy against run time of the intersection kernels and number formats.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created if needed) for accuracy.csv and accuracy.svg.
    #[arg(long = "out-dir", alias = "out", value_name = "DIR")]
    out: PathBuf,
    /// Scene files (repeatable); default: the bundled bun_zipper_res4, suzanne, teapot and
    /// cornell_box.
    #[arg(long = "scene", value_name = "FILE")]
    scenes: Vec<PathBuf>,
    /// Kernels (repeatable): watertight, moller-trumbore, wald, hanika-keller, cramer;
    /// default: all.
    #[arg(long = "isect", value_name = "NAME", value_parser = parse_kernel)]
    kernels: Vec<KernelKind>,
    /// Number formats (repeatable): f32, fixed64-q23, fixed32-q16; default: all.
    #[arg(long = "format", value_name = "NAME", value_parser = parse_format)]
    formats: Vec<NumberFormat>,
    /// Number format of the firmware's ray generation and DDA: f32 or fixed.
    #[arg(long, value_name = "NAME", default_value = "f32", value_parser = parse_raygen)]
    raygen: RayFormat,
    /// Image width.
    #[arg(long, default_value_t = 160)]
    width: u16,
    /// Image height.
    #[arg(long, default_value_t = 120)]
    height: u16,
    /// Timed native frames per configuration (the best counts).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..))]
    runs: u32,
    /// Watertightness probes per configuration.
    #[arg(long, default_value_t = 20_000)]
    probes: u32,
    /// PEs of the modelled co-processor.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u16).range(1..=255))]
    pes: u16,
}

fn parse_kernel(s: &str) -> Result<KernelKind, String> {
    KernelKind::from_name(s).ok_or_else(|| {
        let names: Vec<_> = KernelKind::ALL.iter().map(|k| k.name()).collect();
        format!("unknown kernel {s:?} (one of {})", names.join(", "))
    })
}

fn parse_format(s: &str) -> Result<NumberFormat, String> {
    NumberFormat::from_name(s).ok_or_else(|| {
        let names: Vec<_> = NumberFormat::ALL.iter().map(|f| f.name()).collect();
        format!("unknown number format {s:?} (one of {})", names.join(", "))
    })
}

fn parse_raygen(s: &str) -> Result<RayFormat, String> {
    RayFormat::ALL.into_iter().find(|f| f.name() == s).ok_or_else(|| format!("unknown ray format {s:?} (f32 or fixed)"))
}

impl Args {
    /// Runs the bench and writes its outputs.
    pub fn run(self) -> anyhow::Result<()> {
        let mut opts = AccuracyOptions::new();
        // The bundled scenes travel inside the binary: the bench runs from any folder.
        let bundled = if self.scenes.is_empty() { Some(crate::cmd::scenes::Bundled::extract()?) } else { None };
        match &bundled {
            Some(b) => opts.scenes = acc::DEFAULT_SCENES.iter().map(|s| b.join(s)).collect(),
            None => opts.scenes = self.scenes,
        }
        if !self.kernels.is_empty() {
            opts.kernels = self.kernels;
        }
        if !self.formats.is_empty() {
            opts.formats = self.formats;
        }
        opts.raygen = self.raygen;
        opts.width = self.width;
        opts.height = self.height;
        opts.runs = self.runs;
        opts.probes = self.probes;
        opts.pes = self.pes;
        std::fs::create_dir_all(&self.out).with_context(|| format!("creating {}", self.out.display()))?;

        eprintln!(
            "{:<20} {:<16} {:<12} {:>9} {:>10} {:>8} {:>6} {:>9} {:>9} {:>5}",
            "scene", "kernel", "format", "ns/ray", "cyc/test", "PSNR dB", "max", "mismatch", "leaks", "B/tri"
        );
        let rows = acc::run(&opts, &mut |ev| match ev {
            AccuracyEvent::Scene { name, triangles, reference_ms } => {
                eprintln!("{name}: {triangles} triangles, reference {reference_ms:.0} ms");
            }
            AccuracyEvent::Row(r) => eprintln!(
                "{:<20} {:<16} {:<12} {:>9.0} {:>10.0} {:>8} {:>6} {:>8.3}% {:>9} {:>5}",
                r.scene,
                r.kernel,
                r.format,
                r.native_ns_per_ray,
                r.model_cycles_per_test,
                r.psnr_db.map_or("ident".into(), |p| format!("{p:.2}")),
                r.max_pixel_error,
                100.0 * r.hit_mismatch_rate,
                format!("{}/{}", r.leaks, r.probes),
                r.bytes_per_triangle
            ),
        })
        .map_err(|e| anyhow!(e))?;
        let csv = self.out.join("accuracy.csv");
        let svg = self.out.join("accuracy.svg");
        acc::write_csv(&rows, &csv)?;
        acc::write_plot(&rows, &svg)?;
        println!("wrote {} ({} rows) and {}", csv.display(), rows.len(), svg.display());
        Ok(())
    }
}

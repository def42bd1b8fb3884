//! The bench's outputs: CSV, per-configuration summary, Pareto fronts and the SVG plot.

use std::path::Path;

use gridrt_coproc::KernelKind;

use super::row::{AccuracyError, AccuracyRow};

/// CSV header of [`write_csv`].
pub const CSV_HEADER: &str = "scene,triangles,kernel,format,raygen,width,height,rays,native_ns_per_ray,\
model_cycles_per_test,model_cycles_per_ray,model_tests_per_ray,fw_instructions_per_ray,psnr_db,max_pixel_error,\
hit_mismatch_rate,t_rel_err_mean,t_rel_err_max,leak_rate,leaks,probes,overflows,bytes_per_triangle,ops_per_test";

/// The rows as CSV text (one header line, one line per row; empty fields for unknown values;
/// `psnr_db` is `inf` for an image identical to the reference).
pub fn to_csv(rows: &[AccuracyRow]) -> String {
    // Through the csv crate: a scene name with a comma or a quote stays one field.
    let mut w = csv::Writer::from_writer(Vec::new());
    let opt = |v: Option<f64>, prec: usize| v.map_or(String::new(), |v| format!("{v:.prec$}"));
    let _ = w.write_record(CSV_HEADER.split(','));
    for r in rows {
        let _ = w.write_record([
            r.scene.to_string(),
            r.triangles.to_string(),
            r.kernel.to_string(),
            r.format.to_string(),
            r.raygen.to_string(),
            r.width.to_string(),
            r.height.to_string(),
            r.rays.to_string(),
            format!("{:.1}", r.native_ns_per_ray),
            format!("{:.1}", r.model_cycles_per_test),
            format!("{:.1}", r.model_cycles_per_ray),
            format!("{:.2}", r.model_tests_per_ray),
            opt(r.fw_instructions_per_ray, 1),
            r.psnr_db.map_or("inf".into(), |p| format!("{p:.2}")),
            r.max_pixel_error.to_string(),
            format!("{:.6}", r.hit_mismatch_rate),
            format!("{:.3e}", r.t_rel_err_mean),
            format!("{:.3e}", r.t_rel_err_max),
            format!("{:.6}", r.leak_rate),
            r.leaks.to_string(),
            r.probes.to_string(),
            r.overflows.to_string(),
            r.bytes_per_triangle.to_string(),
            r.ops_per_test.to_string(),
        ]);
    }
    w.into_inner().ok().and_then(|b| String::from_utf8(b).ok()).unwrap_or_default()
}

/// Writes [`to_csv`] to `path`.
pub fn write_csv(rows: &[AccuracyRow], path: &Path) -> Result<(), AccuracyError> {
    std::fs::write(path, to_csv(rows)).map_err(|source| AccuracyError::Io { path: path.into(), source })
}

/// One (kernel, format) summarised over the scenes: mean native ns/ray, modelled cycles per
/// test, and the worst scene's error as an MSE (from its PSNR; identical images count as a
/// small floor so they stay on a log axis).
#[derive(Debug, Clone, PartialEq)]
pub struct Summary {
    /// Kernel name.
    pub kernel: &'static str,
    /// Format name.
    pub format: &'static str,
    /// Mean native ns per ray over the scenes.
    pub ns_per_ray: f64,
    /// Modelled cycles per test.
    pub cycles_per_test: f64,
    /// Worst (lowest) PSNR over the scenes, dB (`None` if every image was identical).
    pub worst_psnr_db: Option<f64>,
    /// Worst-scene MSE (255² · 10^(−PSNR/10)), floored at 10⁻⁴.
    pub worst_mse: f64,
    /// Total leaks over the scenes, per probe.
    pub leak_rate: f64,
    /// Worst scene's mean relative t error (floored at 10⁻¹⁰ for the log axis).
    pub worst_t_err: f64,
}

/// MSE floor for identical images on the plot's log axis.
const MSE_FLOOR: f64 = 1e-4;
/// Floor of the t error on the plot's log axis.
const T_ERR_FLOOR: f64 = 1e-10;

/// Summaries per (kernel, format), in first-seen order.
pub fn summarize(rows: &[AccuracyRow]) -> Vec<Summary> {
    let mut out: Vec<(Summary, u32, u64, u64)> = Vec::new();
    for r in rows {
        let mse = r.psnr_db.map_or(MSE_FLOOR, |p| (255.0f64 * 255.0 * 10f64.powf(-p / 10.0)).max(MSE_FLOOR));
        match out.iter_mut().find(|(s, ..)| s.kernel == r.kernel && s.format == r.format) {
            Some((s, n, leaks, probes)) => {
                s.ns_per_ray += r.native_ns_per_ray;
                s.worst_mse = s.worst_mse.max(mse);
                s.worst_t_err = s.worst_t_err.max(r.t_rel_err_mean.max(T_ERR_FLOOR));
                s.worst_psnr_db = match (s.worst_psnr_db, r.psnr_db) {
                    (Some(a), Some(b)) => Some(a.min(b)),
                    (a, b) => a.or(b),
                };
                *n += 1;
                *leaks += r.leaks;
                *probes += r.probes;
            }
            None => out.push((
                Summary {
                    kernel: r.kernel,
                    format: r.format,
                    ns_per_ray: r.native_ns_per_ray,
                    cycles_per_test: r.model_cycles_per_test,
                    worst_psnr_db: r.psnr_db,
                    worst_mse: mse,
                    leak_rate: 0.0,
                    worst_t_err: r.t_rel_err_mean.max(T_ERR_FLOOR),
                },
                1,
                r.leaks,
                r.probes,
            )),
        }
    }
    out.into_iter()
        .map(|(mut s, n, leaks, probes)| {
            s.ns_per_ray /= n as f64;
            s.leak_rate = leaks as f64 / probes.max(1) as f64;
            s
        })
        .collect()
}

/// Indices of the Pareto-optimal points when both coordinates are minimised (a point is on
/// the front unless another is at least as good in both and better in one), sorted by x.
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            let (xi, yi) = points[i];
            !points.iter().any(|&(x, y)| x <= xi && y <= yi && (x < xi || y < yi))
        })
        .collect();
    front.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0));
    front
}

/// Draws the run-time/error plot (SVG), one point per (kernel, format) (colour: kernel;
/// marker: ● f32, ▲ fixed64-q23, ✕ fixed32-q16), Pareto front drawn and its points ringed:
/// top row the worst scene's image MSE against the reference, bottom row the worst scene's
/// mean relative t error; left column against native ns per ray, right column against the
/// modelled GridRT PE cycles per test.
pub fn write_plot(rows: &[AccuracyRow], path: &Path) -> Result<(), AccuracyError> {
    use plotters::prelude::*;
    let perr = |e: &dyn std::fmt::Display| AccuracyError::Plot { path: path.into(), what: e.to_string() };
    let sums = summarize(rows);
    if sums.is_empty() {
        return Err(perr(&"no rows"));
    }
    let root = SVGBackend::new(path, (1400, 1200)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| perr(&e))?;
    let areas = root.split_evenly((2, 2));
    let palette = [
        RGBColor(31, 119, 180),
        RGBColor(214, 39, 40),
        RGBColor(44, 160, 44),
        RGBColor(148, 103, 189),
        RGBColor(255, 127, 14),
    ];
    let colour =
        |k: &str| KernelKind::ALL.iter().position(|x| x.name() == k).map_or(BLACK, |i| palette[i % palette.len()]);
    let short = |s: &Summary| {
        let k = match s.kernel {
            "watertight" => "WT",
            "moller-trumbore" => "MT",
            "wald" => "Wald",
            "hanika-keller" => "HK",
            "cramer" => "Cr",
            other => other,
        };
        let f = match s.format {
            "f32" => "f32",
            "fixed64-q23" => "q23",
            "fixed32-q16" => "q16",
            other => other,
        };
        format!("{k}/{f}")
    };
    type Axis = fn(&Summary) -> f64;
    let x_ns: Axis = |s| s.ns_per_ray;
    let x_cyc: Axis = |s| s.cycles_per_test;
    let y_mse: Axis = |s| s.worst_mse;
    let y_t: Axis = |s| s.worst_t_err;
    let panels: [(Axis, Axis, &str, &str, &str); 4] = [
        (
            x_ns,
            y_mse,
            "Image error vs native run time",
            "native ns per ray (single thread, log)",
            "worst-scene MSE vs f64 reference (log; 1e-4 = identical)",
        ),
        (
            x_cyc,
            y_mse,
            "Image error vs modelled co-processor cost",
            "modelled GridRT PE cycles per test (log)",
            "worst-scene MSE vs f64 reference (log; 1e-4 = identical)",
        ),
        (
            x_ns,
            y_t,
            "Hit-distance error vs native run time",
            "native ns per ray (single thread, log)",
            "worst-scene mean relative t error vs exact (log)",
        ),
        (
            x_cyc,
            y_t,
            "Hit-distance error vs modelled co-processor cost",
            "modelled GridRT PE cycles per test (log)",
            "worst-scene mean relative t error vs exact (log)",
        ),
    ];
    for (area, (x_of, y_of, title, xlabel, ylabel)) in areas.iter().zip(panels) {
        let pts: Vec<(f64, f64)> = sums.iter().map(|s| (x_of(s), y_of(s))).collect();
        let range = |v: &mut dyn Iterator<Item = f64>| {
            let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
            (lo / 1.5, (hi * 1.5).max(lo * 3.0))
        };
        let (x0, x1) = range(&mut pts.iter().map(|p| p.0));
        let (y0, y1) = range(&mut pts.iter().map(|p| p.1));
        // Head room above the highest point for the legend.
        let y1 = y1 * 4.0;
        let mut chart = ChartBuilder::on(area)
            .caption(title, ("sans-serif", 18))
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(75)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(|e| perr(&e))?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc(ylabel)
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()
            .map_err(|e| perr(&e))?;
        let front = pareto_front(&pts);
        chart
            .draw_series(LineSeries::new(front.iter().map(|&i| pts[i]), BLACK.stroke_width(2)))
            .map_err(|e| perr(&e))?
            .label("Pareto front (lower-left is better)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(2)));
        chart
            .draw_series(front.iter().map(|&i| Circle::new(pts[i], 11, BLACK.stroke_width(1))))
            .map_err(|e| perr(&e))?;
        // Labels of points that (nearly) coincide are stacked, not drawn over each other:
        // positions in axis fractions (log axes), one line further down per neighbour.
        let frac = |v: f64, lo: f64, hi: f64| (v.ln() - lo.ln()) / (hi.ln() - lo.ln()).max(1e-12);
        let mut placed: Vec<(f64, f64)> = Vec::new();
        for (s, &p) in sums.iter().zip(&pts) {
            let c = colour(s.kernel);
            let at = (frac(p.0, x0, x1), frac(p.1, y0, y1));
            let near = placed.iter().filter(|q| (q.0 - at.0).abs() < 0.08 && (q.1 - at.1).abs() < 0.03).count();
            placed.push(at);
            let dy = -4 + 12 * near as i32;
            let marker: DynElement<_, _> = match s.format {
                "f32" => Circle::new(p, 5, c.filled()).into_dyn(),
                "fixed64-q23" => TriangleMarker::new(p, 7, c.filled()).into_dyn(),
                _ => Cross::new(p, 6, c.stroke_width(3)).into_dyn(),
            };
            chart.draw_series(std::iter::once(marker)).map_err(|e| perr(&e))?;
            let label = EmptyElement::at(p) + Text::new(short(s), (8, dy), ("sans-serif", 11).into_font().color(&c));
            chart.draw_series(std::iter::once(label)).map_err(|e| perr(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE)
            .draw()
            .map_err(|e| perr(&e))?;
    }
    root.present().map_err(|e| perr(&e))?;
    Ok(())
}

//! What the bench plots share: tick labels a reader can read.

/// A tick label: 3 significant digits at most, with k / M for thousands and millions
/// (`115k`, `1M`, `0.25`).
pub fn short_number(v: f64) -> String {
    let trim = |s: String| {
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    let a = v.abs();
    if a >= 1e6 {
        trim(format!("{:.2}", v / 1e6)) + "M"
    } else if a >= 1e3 {
        trim(format!("{:.1}", v / 1e3)) + "k"
    } else if a >= 1.0 || a == 0.0 {
        trim(format!("{v:.2}"))
    } else {
        // Small values: a short exponent form (1e-5, 2.5e-4) or 3 decimals.
        if a >= 0.01 {
            trim(format!("{v:.3}"))
        } else {
            let e = a.log10().floor() as i32;
            let m = v / 10f64.powi(e);
            format!("{}e{e}", trim(format!("{m:.1}")))
        }
    }
}

/// The tail every bench plot shares: the series' legend in a framed box, then the file.
pub fn legend_and_present<'a, DB, CT>(
    chart: &mut plotters::chart::ChartContext<'a, DB, CT>,
    root: &plotters::drawing::DrawingArea<DB, plotters::coord::Shift>,
) -> anyhow::Result<()>
where
    DB: plotters::prelude::DrawingBackend + 'a,
    CT: plotters::coord::CoordTranslate,
{
    use plotters::prelude::*;
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    root.present().map_err(|e| anyhow::anyhow!("{e}"))
}

#[cfg(test)]
mod tests {
    use super::short_number;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(short_number(115_200.0), "115.2k");
        assert_eq!(short_number(1_000_000.0), "1M");
        assert_eq!(short_number(3_000_000.0), "3M");
        assert_eq!(short_number(9.999999999999999e-6), "1e-5");
        assert_eq!(short_number(2.5e-4), "2.5e-4");
        assert_eq!(short_number(0.25), "0.25");
        assert_eq!(short_number(12.0), "12");
    }
}

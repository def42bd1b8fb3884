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

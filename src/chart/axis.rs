//! The numbers around a log–log plot: axis ranges, tick labels (10⁴, 2×10⁴, …), the least-squares slope
//! of a series, and the legend's wording.

use super::{Level, Series};

/// Whether a log axis can show `v`.
pub fn drawable(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Least-squares slope of log y against log x over the drawable points; `None` below two distinct x.
/// On a log–log convergence chart this is the rate: error ∝ photons^slope.
pub fn slope(points: &[(f64, f64)]) -> Option<f64> {
    let logs: Vec<(f64, f64)> = points
        .iter()
        .filter(|&&(x, y)| drawable(x) && drawable(y))
        .map(|&(x, y)| (x.log10(), y.log10()))
        .collect();
    let n = logs.len() as f64;
    let mean_x = logs.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = logs.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = logs.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    let sxy: f64 = logs.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    (logs.len() >= 2 && sxx > 1e-12).then(|| sxy / sxx)
}

/// Log ranges of x and y covering every drawable point and level, padded a little and holding at least
/// one power of ten each, so that every axis has a labelled tick. Without any point: 1–10.
pub fn ranges(series: &[Series], levels: &[&Level]) -> ((f64, f64), (f64, f64)) {
    let points = || {
        series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&(x, y)| drawable(x) && drawable(y))
    };
    let xs = points().map(|p| p.0);
    let ys = points().map(|p| p.1).chain(levels.iter().map(|l| l.y));
    (padded(xs), padded(ys))
}

fn padded(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    if lo > hi {
        return (1.0, 10.0);
    }
    let (mut lo, mut hi) = (lo.log10() - 0.08, hi.log10() + 0.08);
    if lo.ceil() > hi.floor() {
        // No power of ten inside: reach a little past the nearer one (past, so that plotters, which
        // rounds, draws its grid line too).
        if lo - lo.floor() <= hi.ceil() - hi {
            lo = lo.floor() - 0.02;
        } else {
            hi = hi.ceil() + 0.02;
        }
    }
    (10f64.powf(lo), 10f64.powf(hi))
}

const SUPERSCRIPT: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];

fn superscript(e: i32) -> String {
    let digits: String = e
        .unsigned_abs()
        .to_string()
        .chars()
        .map(|d| SUPERSCRIPT[d.to_digit(10).unwrap_or(0) as usize])
        .collect();
    if e < 0 {
        format!("⁻{digits}")
    } else {
        digits
    }
}

/// `v` typeset with up to two decimals: `10⁴`, `3×10⁴`, `7.84×10⁻⁵`, `−2×10³`.
pub fn sci(v: f64) -> String {
    if !v.is_finite() || v == 0.0 {
        return format!("{v}");
    }
    let mut e = v.abs().log10().floor();
    let mut m = (v.abs() / 10f64.powf(e) * 100.0).round() / 100.0;
    if m >= 10.0 {
        (m, e) = (m / 10.0, e + 1.0);
    }
    let sign = if v < 0.0 { "−" } else { "" };
    let m = format!("{m:.2}");
    let m = m.trim_end_matches('0').trim_end_matches('.');
    let e = superscript(e as i32);
    if m == "1" {
        format!("{sign}10{e}")
    } else {
        format!("{sign}{m}×10{e}")
    }
}

/// The label of a tick at `v`: [`sci`] at 1, 2 and 5 times a power of ten, empty at the others
/// (their grid lines stay).
pub fn tick_label(v: f64) -> String {
    if !drawable(v) {
        return String::new();
    }
    let e = (v.log10() + 1e-9).floor();
    let m = v / 10f64.powf(e);
    let on = |k: f64| (m - k).abs() < 1e-6 * k;
    if on(1.0) || on(2.0) || on(5.0) {
        sci(m.round() * 10f64.powf(e))
    } else {
        String::new()
    }
}

/// The labelled ticks inside `(lo, hi)`: every power of ten, and 2× and 5× it when the range spans at
/// most two and a half decades.
pub fn ticks((lo, hi): (f64, f64)) -> Vec<f64> {
    if !(drawable(lo) && drawable(hi) && lo < hi) {
        return Vec::new();
    }
    let mantissas: &[f64] = if (hi / lo).log10() <= 2.5 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0]
    };
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let slack = 1e-9;
    (first..=last)
        .flat_map(|e| mantissas.iter().map(move |m| m * 10f64.powi(e)))
        .filter(|v| *v >= lo * (1.0 - slack) && *v <= hi * (1.0 + slack))
        .collect()
}

/// A number with a true minus sign, as typeset.
fn signed(v: f64, decimals: usize) -> String {
    format!("{v:.decimals$}").replace('-', "−")
}

/// `name   slope −0.52`, and the x of the points not drawn.
pub fn legend_text(s: &Series) -> String {
    let rate = match slope(&s.points) {
        Some(k) => format!("slope {}", signed(k, 2)),
        None => "no slope (fewer than two points)".to_string(),
    };
    let missing: Vec<String> = s
        .points
        .iter()
        .filter(|&&(x, y)| !(drawable(x) && drawable(y)))
        .map(|&(x, _)| sci(x))
        .collect();
    if missing.is_empty() {
        format!("{}   {rate}", s.name)
    } else {
        format!("{}   {rate};  not drawn at {}", s.name, missing.join(", "))
    }
}

pub fn level_text(l: &Level) -> String {
    if drawable(l.y) {
        format!("{} ({})", l.name, sci(l.y))
    } else {
        format!("{} (no value; not drawn)", l.name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slope_of_a_power_law_is_its_exponent() {
        let pts: Vec<(f64, f64)> = [1e3, 1e4, 1e5]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(-0.5)))
            .collect();
        assert!((slope(&pts).unwrap() + 0.5).abs() < 1e-12);
    }

    #[test]
    fn slope_skips_missing_points_and_needs_two() {
        let pts = [(1e3, 1e-2), (1e4, 1e-3), (1e5, f64::NAN), (1e6, 0.0)];
        assert!((slope(&pts).unwrap() + 1.0).abs() < 1e-12);
        assert_eq!(slope(&pts[..1]), None);
        assert_eq!(slope(&[(1e3, 1.0), (1e3, 2.0)]), None);
        assert_eq!(slope(&[]), None);
    }

    #[test]
    fn tick_labels() {
        assert_eq!(tick_label(1e4), "10⁴");
        assert_eq!(tick_label(2e4), "2×10⁴");
        assert_eq!(tick_label(5e-3), "5×10⁻³");
        assert_eq!(tick_label(1.0), "10⁰");
        assert_eq!(tick_label(3e4), "");
        assert_eq!(tick_label(f64::NAN), "");
    }

    #[test]
    fn sci_typesets() {
        assert_eq!(sci(1e5), "10⁵");
        assert_eq!(sci(3e4), "3×10⁴");
        assert_eq!(sci(7.838e-5), "7.84×10⁻⁵");
        assert_eq!(sci(9.999e2), "10³");
        assert_eq!(sci(-2e3), "−2×10³");
        assert_eq!(sci(0.0), "0");
        assert_eq!(sci(f64::NAN), "NaN");
    }

    #[test]
    fn ticks_by_span() {
        assert_eq!(ticks((8e3, 1.2e5)), vec![1e4, 2e4, 5e4, 1e5]);
        assert_eq!(ticks((0.5e-5, 2e-1)), vec![1e-5, 1e-4, 1e-3, 1e-2, 1e-1]);
        assert!(ticks((1.0, 1.0)).is_empty());
        assert!(ticks((0.0, 1.0)).is_empty());
    }

    #[test]
    fn ranges_hold_the_points_and_a_power_of_ten() {
        let s = |points| Series {
            name: String::new(),
            points,
        };
        let series = [s(vec![(2e4, 3e-3), (5e4, f64::NAN)]), s(vec![(3e4, 4e-3)])];
        let level = Level {
            name: String::new(),
            y: 1e-4,
        };
        let ((x0, x1), (y0, y1)) = ranges(&series, &[&level]);
        assert!(x0 < 2e4 && x1 > 3e4 && y0 < 1e-4 && y1 > 4e-3);
        assert!(x0 < 1e4 || x1 > 1e5);
        assert_eq!(ranges(&[], &[]), ((1.0, 10.0), (1.0, 10.0)));
    }

    #[test]
    fn legend_names_slope_and_missing_points() {
        let s = Series {
            name: "caustic term".into(),
            points: vec![(1e4, 1e-2), (1e5, 1e-3), (1e6, f64::NAN)],
        };
        assert_eq!(
            legend_text(&s),
            "caustic term   slope −1.00;  not drawn at 10⁶"
        );
    }
}

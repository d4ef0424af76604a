//! Statistics of sampled signals: time averages by the trapezoidal rule and the late-time mean
//! and standard deviation of a time series.

/// Time-weighted mean and standard deviation (trapezoidal rule) of `y(t)` for `t >= from`.
pub(crate) fn late_statistics(t: &[f64], y: &[f64], from: f64) -> Option<(f64, f64)> {
    let pairs: Vec<(f64, f64)> = t
        .iter()
        .zip(y)
        .filter(|(ti, _)| **ti >= from)
        .map(|(a, b)| (*a, *b))
        .collect();
    if pairs.len() < 2 {
        return None;
    }
    let span = pairs.last()?.0 - pairs[0].0;
    if span <= 0.0 {
        return None;
    }
    let mean = trapezoid_mean(&pairs, |v| v);
    let var = trapezoid_mean(&pairs, |v| (v - mean) * (v - mean)).max(0.0);
    Some((mean, var.sqrt()))
}

/// The time average of `f(y)` over the samples `(t, y)` (sorted in `t`, spanning a positive
/// time) by the trapezoidal rule.
pub(crate) fn trapezoid_mean(points: &[(f64, f64)], f: impl Fn(f64) -> f64) -> f64 {
    let span = points[points.len() - 1].0 - points[0].0;
    points
        .windows(2)
        .map(|w| 0.5 * (f(w[0].1) + f(w[1].1)) * (w[1].0 - w[0].0))
        .sum::<f64>()
        / span
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_statistics_of_a_sine_wave() {
        let t: Vec<f64> = (0..=4000).map(|i| i as f64 * 0.001).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|t| 2.0 + 0.5 * (2.0 * std::f64::consts::PI * t).sin())
            .collect();
        let (mean, std) = late_statistics(&t, &y, 1.0).unwrap();
        assert!(
            (mean - 2.0).abs() < 1e-6 && (std - 0.5 / 2f64.sqrt()).abs() < 1e-6,
            "{mean} {std}"
        );
    }
}

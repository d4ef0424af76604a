//! Scaling-law fits: power laws in logarithms with confidence intervals (one or shared by
//! groups), lines through the origin, and local exponents and log-slopes along sampled curves.

use serde::Serialize;
use statrs::distribution::{ContinuousCDF, StudentsT};

use crate::{Error, Result};

/// Two-sided 95% quantile of Student's t distribution with `dof` degrees of freedom.
fn t95(dof: usize) -> Result<f64> {
    let t = StudentsT::new(0.0, 1.0, dof as f64)
        .map_err(|e| Error::Numerical(format!("Student t: {e}")))?;
    Ok(t.inverse_cdf(0.975))
}

/// A power law `y = C x^p` fitted in logarithms, with 95% confidence intervals.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PowerLaw {
    #[serde(rename = "C")]
    pub c: f64,
    pub p: f64,
    #[serde(rename = "C_ci")]
    pub c_ci: [f64; 2],
    pub p_ci: [f64; 2],
    pub n: usize,
    /// Coefficient of determination in `ln y`.
    pub r2: f64,
    /// Residuals in logarithms, `ln y_i - ln C - p ln x_i` (relative errors, to first order).
    pub residuals: Vec<f64>,
}

/// The ordinary least-squares line `y = a + b x` through at least three points, with the
/// standard errors of `a` and `b`: with `xbar`, `ybar` the means, `Sxx = sum (x - xbar)^2`,
/// `b = sum (x - xbar)(y - ybar) / Sxx`, `a = ybar - b xbar`, `s^2 = SSE/(n - 2)`,
/// `se(b) = s / sqrt(Sxx)` and `se(a) = s sqrt(1/n + xbar^2/Sxx)` (centred sums, exact for data
/// far from the origin).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Line {
    a: f64,
    b: f64,
    se_a: f64,
    se_b: f64,
    sse: f64,
    sst: f64,
    n: usize,
}

impl Line {
    fn fit(x: &[f64], y: &[f64]) -> Self {
        let n = x.len();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
        let (mx, my) = (mean(x), mean(y));
        let sxx: f64 = x.iter().map(|v| (v - mx).powi(2)).sum();
        let sxy: f64 = x.iter().zip(y).map(|(u, v)| (u - mx) * (v - my)).sum();
        let b = sxy / sxx;
        let a = my - b * mx;
        let sse: f64 = x.iter().zip(y).map(|(u, v)| (v - a - b * u).powi(2)).sum();
        let sst: f64 = y.iter().map(|v| (v - my).powi(2)).sum();
        let s2 = if n > 2 {
            sse / (n - 2) as f64
        } else {
            f64::NAN
        };
        Line {
            a,
            b,
            se_a: (s2 * (1.0 / n as f64 + mx * mx / sxx)).sqrt(),
            se_b: (s2 / sxx).sqrt(),
            sse,
            sst,
            n,
        }
    }

    /// Half-widths of the 95% intervals of `a` and `b`: `t(0.975, n - 2)` standard errors.
    fn half_widths(&self) -> Result<(f64, f64)> {
        let t = t95(self.n - 2)?;
        Ok((t * self.se_a, t * self.se_b))
    }
}

/// Fits `y = C x^p` by ordinary least squares in logarithms, `ln y = ln C + p ln x`: the errors
/// of a scaling law are relative (multiplicative), so each point weighs by its relative
/// deviation, whatever its size (an unweighted fit of `y` lets the largest `y` decide, and its
/// intervals cover the true exponent far less often than they say). The 95% intervals are
/// `estimate +- t(0.975, n - 2) se` on the log-scale residuals; `C`'s comes from that of
/// `ln C`, `[C e^-w, C e^w]`.
pub fn power_law(x: &[f64], y: &[f64]) -> Result<PowerLaw> {
    if x.len() != y.len() {
        return Err(Error::input("fit", "x and y have different lengths"));
    }
    let n = x.len();
    if n < 3 {
        return Err(Error::input(
            "fit",
            format!("needs at least 3 points, got {n}"),
        ));
    }
    if x.iter().chain(y).any(|v| !v.is_finite() || *v <= 0.0) {
        return Err(Error::input(
            "fit",
            "a power law needs finite, positive x and y",
        ));
    }
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    if lx.iter().all(|v| *v == lx[0]) {
        return Err(Error::input(
            "fit",
            "a power law needs at least two distinct x",
        ));
    }
    let line = Line::fit(&lx, &ly);
    let (wa, wb) = line.half_widths()?;
    let c = line.a.exp();
    Ok(PowerLaw {
        c,
        p: line.b,
        c_ci: [c * (-wa).exp(), c * wa.exp()],
        p_ci: [line.b - wb, line.b + wb],
        n,
        r2: 1.0 - line.sse / line.sst,
        residuals: lx
            .iter()
            .zip(&ly)
            .map(|(u, v)| v - line.a - line.b * u)
            .collect(),
    })
}

/// A line through the origin `y = k x` with the 95% interval of `k`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Slope {
    pub slope: f64,
    pub slope_ci: [f64; 2],
    pub n: usize,
    pub r2: f64,
}

/// Least squares `y = k x`: `k = sum(x y)/sum(x^2)`, `sigma_k = s/sqrt(sum x^2)`,
/// `s^2 = SSE/(n-1)`.
pub(crate) fn through_origin(x: &[f64], y: &[f64]) -> Result<Slope> {
    let n = x.len();
    if n < 2 || y.len() != n {
        return Err(Error::input(
            "fit",
            "a line through the origin needs at least 2 points",
        ));
    }
    let sxx: f64 = x.iter().map(|v| v * v).sum();
    let k = x.iter().zip(y).map(|(a, b)| a * b).sum::<f64>() / sxx;
    let sse: f64 = x.iter().zip(y).map(|(a, b)| (b - k * a).powi(2)).sum();
    let syy: f64 = y.iter().map(|v| v * v).sum();
    let half = t95(n - 1)? * (sse / (n - 1) as f64 / sxx).sqrt();
    Ok(Slope {
        slope: k,
        slope_ci: [k - half, k + half],
        n,
        r2: 1.0 - sse / syy,
    })
}

/// The local exponent of `y(x)` over one interval between neighbouring samples:
/// `p_loc = ln(y_hi / y_lo) / ln(x_hi / x_lo)`, the slope of the chord in logarithms, which is
/// `d ln y / d ln x` at some point of the interval (mean value theorem) and, for a smooth
/// `y`, at its geometric midpoint `sqrt(x_lo x_hi)` to second order in `ln(x_hi / x_lo)`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LocalExponent {
    pub x_lo: f64,
    pub x_hi: f64,
    pub x_mid: f64,
    pub p: f64,
}

/// The local exponents of the samples `(x, y)` (positive), taken in increasing `x`.
pub(crate) fn local_exponents(x: &[f64], y: &[f64]) -> Vec<LocalExponent> {
    let mut points: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(x, y)| **x > 0.0 && **y > 0.0)
        .map(|(x, y)| (*x, *y))
        .collect();
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points.dedup_by(|a, b| a.0 == b.0);
    points
        .windows(2)
        .map(|w| LocalExponent {
            x_lo: w[0].0,
            x_hi: w[1].0,
            x_mid: (w[0].0 * w[1].0).sqrt(),
            p: (w[1].1 / w[0].1).ln() / (w[1].0 / w[0].0).ln(),
        })
        .collect()
}

/// `dy/dx` at every sample of `(x, y)` (in the order given): the three-point formula on an
/// uneven grid inside, two points at the ends; `None` for a lone sample or a non-finite value
/// (`x`, `y` logarithms of non-positive numbers). For densely sampled curves, where the
/// derivative at the samples is wanted; [`local_exponents`] gives chords between coarse samples.
pub(crate) fn log_slopes(x: &[f64], y: &[f64]) -> Vec<Option<f64>> {
    let n = x.len();
    let d = |a: usize, b: usize| (y[b] - y[a]) / (x[b] - x[a]);
    (0..n)
        .map(|i| {
            let slope = match (i, n) {
                (_, 0 | 1) => return None,
                (0, _) => d(0, 1),
                (i, n) if i == n - 1 => d(n - 2, n - 1),
                (i, _) => {
                    let (h0, h1) = (x[i] - x[i - 1], x[i + 1] - x[i]);
                    (h0 * d(i, i + 1) + h1 * d(i - 1, i)) / (h0 + h1)
                }
            };
            slope.is_finite().then_some(slope)
        })
        .collect()
}

/// The intercept `a` of the least-squares line `y = a + b x` through `points` and the
/// half-width of its 95% interval (`t(0.975, n - 2)` standard errors of `a`, from the scatter
/// about the line); `None` with fewer than three points.
pub(crate) fn line_intercept(points: &[(f64, f64)]) -> Option<[f64; 2]> {
    if points.len() < 3 {
        return None;
    }
    let (x, y): (Vec<f64>, Vec<f64>) = points.iter().copied().unzip();
    let line = Line::fit(&x, &y);
    let (half_width, _) = line.half_widths().ok()?;
    line.a.is_finite().then_some([line.a, half_width])
}

/// One exponent shared by several groups, each with its own prefactor:
/// `y = N_k x^p` for group `k` (the separable form `y = M(x) N(group)` with `M = x^p`).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CommonPowerLaw {
    pub p: f64,
    pub p_ci: [f64; 2],
    /// `(group, N_k)`.
    pub prefactors: Vec<(String, f64)>,
    /// Each group fitted alone by the same estimator (groups of at least three points):
    /// `(group, p, p_ci)`, for the check of the separable form (the exponents should agree with
    /// the common one within their intervals).
    pub per_group: Vec<(String, f64, [f64; 2])>,
    pub n: usize,
    /// Coefficient of determination in `ln y`.
    pub r2: f64,
}

/// Fits [`CommonPowerLaw`] by least squares in logarithms (multiplicative errors):
/// `ln y = ln N_k + p ln x`; `p` is the pooled within-group slope, its 95% interval uses
/// `t(0.975, n - K - 1)`.
pub(crate) fn common_power_law(groups: &[(String, Vec<f64>, Vec<f64>)]) -> Result<CommonPowerLaw> {
    let logs: Vec<(&String, Vec<f64>, Vec<f64>)> = groups
        .iter()
        .map(|(g, x, y)| {
            (
                g,
                x.iter().map(|v| v.ln()).collect(),
                y.iter().map(|v| v.ln()).collect(),
            )
        })
        .collect();
    let n: usize = logs.iter().map(|g| g.1.len()).sum();
    let k = logs.len();
    if n < k + 2
        || logs
            .iter()
            .flat_map(|g| g.1.iter().chain(&g.2))
            .any(|v| !v.is_finite())
    {
        return Err(Error::input(
            "fit",
            "a common power law needs positive data and n >= groups + 2",
        ));
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (_, lx, ly) in &logs {
        let (mx, my) = (mean(lx), mean(ly));
        sxy += lx
            .iter()
            .zip(ly)
            .map(|(a, b)| (a - mx) * (b - my))
            .sum::<f64>();
        sxx += lx.iter().map(|a| (a - mx).powi(2)).sum::<f64>();
    }
    let p = sxy / sxx;
    let mut sse = 0.0;
    let mut prefactors = Vec::new();
    for (g, lx, ly) in &logs {
        let a = mean(ly) - p * mean(lx);
        sse += lx
            .iter()
            .zip(ly)
            .map(|(u, v)| (v - a - p * u).powi(2))
            .sum::<f64>();
        prefactors.push(((*g).clone(), a.exp()));
    }
    let all: Vec<f64> = logs.iter().flat_map(|g| g.2.iter().copied()).collect();
    let m = mean(&all);
    let sst: f64 = all.iter().map(|v| (v - m).powi(2)).sum();
    let dof = n - k - 1;
    let half = if dof > 0 {
        t95(dof)? * (sse / dof as f64 / sxx).sqrt()
    } else {
        f64::INFINITY
    };
    let per_group = logs
        .iter()
        .filter(|g| g.1.len() >= 3)
        .map(|(g, lx, ly)| {
            let line = Line::fit(lx, ly);
            let (_, half) = line.half_widths()?;
            Ok(((*g).clone(), line.b, [line.b - half, line.b + half]))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(CommonPowerLaw {
        p,
        p_ci: [p - half, p + half],
        prefactors,
        per_group,
        n,
        r2: 1.0 - sse / sst,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_law_recovers_a_known_exponent_with_a_covering_interval() {
        // y = 2.5 x^-0.75 with 2% multiplicative noise from a fixed pseudo-random sequence.
        let x: Vec<f64> = (0..40).map(|i| 0.1 * 1.1f64.powi(i)).collect();
        let mut state = 12345u64;
        let y: Vec<f64> = x
            .iter()
            .map(|xi| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                2.5 * xi.powf(-0.75) * (1.0 + 0.04 * u)
            })
            .collect();
        let fit = power_law(&x, &y).unwrap();
        assert!(fit.p_ci[0] < -0.75 && -0.75 < fit.p_ci[1], "{fit:?}");
        assert!(fit.c_ci[0] < 2.5 && 2.5 < fit.c_ci[1], "{fit:?}");
        assert!((fit.p_ci[1] - fit.p_ci[0]) < 0.05 && fit.r2 > 0.99);
        // Exact data: the interval collapses onto the value.
        let exact: Vec<f64> = x.iter().map(|v| 3.0 * v.powf(1.5)).collect();
        let fit = power_law(&x, &exact).unwrap();
        assert!((fit.p - 1.5).abs() < 1e-10 && (fit.c - 3.0).abs() < 1e-9);
    }

    /// The 95% intervals are calibrated: on 100 seeded synthetic sets `y = 2 x^-3.2` with 5%
    /// multiplicative Gaussian noise at 8 points of `x` in `[0.05, 0.5]`, the interval of `p`
    /// contains -3.2 in 90 to 99 of them, and that of `C` contains 2 as often (an unweighted
    /// fit of `y` covered -3.2 in 16 of such sets). With three points `C`'s lower bound stays
    /// positive.
    #[test]
    fn power_law_intervals_cover_the_true_values_at_their_stated_rate() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand::rngs::StdRng::seed_from_u64(20261204);
        let noise = Normal::new(0.0, 0.05).unwrap();
        let x: Vec<f64> = (0..8).map(|i| 0.05 * 10f64.powf(i as f64 / 7.0)).collect();
        let (mut p_in, mut c_in) = (0, 0);
        for _ in 0..100 {
            let y: Vec<f64> = x
                .iter()
                .map(|v| 2.0 * v.powf(-3.2) * (1.0 + noise.sample(&mut rng)))
                .collect();
            let fit = power_law(&x, &y).unwrap();
            p_in += usize::from(fit.p_ci[0] < -3.2 && -3.2 < fit.p_ci[1]);
            c_in += usize::from(fit.c_ci[0] < 2.0 && 2.0 < fit.c_ci[1]);
        }
        assert!((90..=99).contains(&p_in), "p covered in {p_in} of 100");
        assert!((90..=99).contains(&c_in), "C covered in {c_in} of 100");
        let three = power_law(&x[..3], &[800.0, 100.0, 30.0]).unwrap();
        assert!(three.c_ci[0] > 0.0 && three.c_ci[0] < three.c && three.c < three.c_ci[1]);
    }

    #[test]
    fn common_power_law_recovers_a_separable_form() {
        // y = N_k x^-1.3 with N = 1, 2, 5 and 1% pseudo-random multiplicative noise.
        let mut state = 987654321u64;
        let mut noise = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let groups: Vec<(String, Vec<f64>, Vec<f64>)> = [1.0, 2.0, 5.0]
            .iter()
            .enumerate()
            .map(|(k, nk)| {
                let x: Vec<f64> = (0..6).map(|i| 0.2 + 0.15 * i as f64).collect();
                let y = x
                    .iter()
                    .map(|v| nk * v.powf(-1.3) * (1.0 + 0.02 * noise()))
                    .collect();
                (format!("g{k}"), x, y)
            })
            .collect();
        let fit = common_power_law(&groups).unwrap();
        assert!(fit.p_ci[0] < -1.3 && -1.3 < fit.p_ci[1], "{fit:?}");
        assert!((fit.prefactors[2].1 / fit.prefactors[0].1 - 5.0).abs() < 0.1);
        assert_eq!(fit.per_group.len(), 3);
    }

    #[test]
    fn slope_through_origin() {
        let x = [1.0, 2.0, 3.0, 4.0];
        let y = [2.1, 3.9, 6.0, 8.1];
        let s = through_origin(&x, &y).unwrap();
        assert!((s.slope - 60.3 / 30.0).abs() < 1e-12);
        assert!(s.slope_ci[0] < 2.0 && s.slope_ci[1] > 2.0);
    }

    #[test]
    fn local_exponents_follow_a_varying_slope() {
        // y = x^(-2 - ln x) has d ln y / d ln x = -2 - 2 ln x: at the geometric midpoint of
        // each interval the chord slope is exact (the log-log curve is a parabola).
        let x: Vec<f64> = [0.05, 0.1, 0.2, 0.3, 0.4].to_vec();
        let y: Vec<f64> = x.iter().map(|x: &f64| x.powf(-2.0 - x.ln())).collect();
        let local = local_exponents(&x, &y);
        assert_eq!(local.len(), 4);
        for l in &local {
            let exact = -2.0 - 2.0 * l.x_mid.ln();
            assert!((l.p - exact).abs() < 1e-12, "{l:?} vs {exact}");
        }
        // Unsorted input, and a non-positive sample left out.
        let local = local_exponents(&[0.2, 0.1, 0.3, -1.0], &[4.0, 16.0, 1.0, 1.0]);
        assert_eq!(local.len(), 2);
        assert!((local[0].p - (0.25f64).ln() / 2f64.ln()).abs() < 1e-14);
    }

    #[test]
    fn the_log_slope_is_second_order_on_an_uneven_grid() {
        // y = sin(x) on uneven points: the three-point derivative errs by O(h^2).
        let error = |h: f64| {
            let x: Vec<f64> = (0..12)
                .map(|i| 1.0 + h * (i as f64 + 0.3 * (i % 3) as f64))
                .collect();
            let y: Vec<f64> = x.iter().map(|x| x.sin()).collect();
            let slopes = log_slopes(&x, &y);
            (1..x.len() - 1)
                .map(|i| (slopes[i].unwrap() - x[i].cos()).abs())
                .fold(0.0, f64::max)
        };
        let (coarse, fine) = (error(0.02), error(0.01));
        let order = (coarse / fine).log2();
        assert!((order - 2.0).abs() < 0.2, "observed order {order}");
        assert!(log_slopes(&[1.0], &[2.0])[0].is_none());
    }

    /// The limit of a straight line is its intercept, with no width; with scatter, the width is
    /// the classic `t(0.975, n - 2) s sqrt(1/n + mean(x)^2 / Sxx)`: for `y = 2 + x` plus
    /// `0.1, -0.1, -0.1, 0.1` at `x = 1, 2, 3, 4` (residuals orthogonal to the line: `s^2 =
    /// 0.04/2`, `Sxx = 5`, `t(0.975, 2) = 4.302653`), `4.302653 sqrt(0.02 (1/4 + 6.25/5))
    /// = 0.745242`.
    #[test]
    fn the_limit_of_a_straight_line_is_its_intercept() {
        let points: Vec<(f64, f64)> = (0..5)
            .map(|i| (0.1 * i as f64, 2.1 + 3.0 * 0.1 * i as f64))
            .collect();
        let [a, width] = line_intercept(&points).unwrap();
        assert!((a - 2.1).abs() < 1e-14 && width < 1e-13);
        assert!(line_intercept(&points[..2]).is_none());
        let scattered = [(1.0, 3.1), (2.0, 3.9), (3.0, 4.9), (4.0, 6.1)];
        let [a, width] = line_intercept(&scattered).unwrap();
        let expected = 4.302653 * (0.02_f64 * (0.25 + 6.25 / 5.0)).sqrt();
        assert!((a - 2.0).abs() < 1e-12, "{a}");
        assert!((width - expected).abs() < 1e-5, "{width} vs {expected}");
    }
}

//! A simulation started on a periodic orbit (`helixbif simulate --from-orbit`) against the
//! orbit, one period `T` at a time: `cycles.csv`.
//!
//! For each complete window `[k T, (k + 1) T]` of the simulated time series: the time averages
//! of `hbar` and `Fpbar` over the window (trapezoids, the ends interpolated), to be set against
//! the orbit's period averages; the deviation
//!
//! ```text
//! d_k = max over the window of |hbar_sim(t) - hbar_orbit(t mod T)|
//! ```
//!
//! (`hbar_orbit` interpolated linearly, periodically, between the orbit's equally spaced
//! states), which a stable orbit keeps at the level of the two discretizations' difference and
//! an unstable one lets grow by the largest Floquet multiplier per period, `d_{k+1} / d_k -> |mu|`;
//! and the simulation's own period, the time between successive upward crossings of the orbit's
//! mean `hbar` (only where the orbit's `hbar` crosses its mean upward once a period, so that a
//! crossing marks a phase).

use serde::Serialize;

use crate::analysis::orbits::OrbitStart;
use crate::numerics::statistics::trapezoid_mean;

/// One row of `cycles.csv` (times in s).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct CycleRow {
    pub cycle: usize,
    pub t_start: f64,
    pub hbar_mean: f64,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: f64,
    /// `d_k` of the module docs.
    pub deviation: f64,
    /// Time from the previous upward crossing of the orbit's mean `hbar` to the first one in
    /// this window; empty where there is none, or where the orbit's `hbar` does not cross its
    /// mean exactly once a period.
    pub period: Option<f64>,
}

/// The value at `t` of the periodic function sampled at `t_k = k period / n`.
fn periodic_value(samples: &[f64], period: f64, t: f64) -> f64 {
    let n = samples.len();
    let x = (t / period).rem_euclid(1.0) * n as f64;
    let k = (x.floor() as usize).min(n - 1);
    let f = x - k as f64;
    samples[k] * (1.0 - f) + samples[(k + 1) % n] * f
}

/// `y` at `t` by linear interpolation in the sorted `ts` (clamped to its ends).
fn interpolate(ts: &[f64], y: &[f64], t: f64) -> f64 {
    let j = ts.partition_point(|&s| s < t);
    if j == 0 {
        return y[0];
    }
    if j == ts.len() {
        return y[ts.len() - 1];
    }
    let f = (t - ts[j - 1]) / (ts[j] - ts[j - 1]);
    y[j - 1] * (1.0 - f) + y[j] * f
}

/// The mean of `y` over `[a, b]` (trapezoids over the samples inside, the ends interpolated).
fn window_mean(ts: &[f64], y: &[f64], a: f64, b: f64) -> f64 {
    let mut points = vec![(a, interpolate(ts, y, a))];
    points.extend(
        ts.iter()
            .zip(y)
            .filter(|(t, _)| **t > a && **t < b)
            .map(|(t, v)| (*t, *v)),
    );
    points.push((b, interpolate(ts, y, b)));
    trapezoid_mean(&points, |v| v)
}

/// Times where `y` crosses `level` upward (linear interpolation between samples).
fn upward_crossings(ts: &[f64], y: &[f64], level: f64) -> Vec<f64> {
    ts.windows(2)
        .zip(y.windows(2))
        .filter(|(_, v)| v[0] < level && v[1] >= level)
        .map(|(t, v)| t[0] + (level - v[0]) / (v[1] - v[0]) * (t[1] - t[0]))
        .collect()
}

/// The rows of `cycles.csv` for a simulation sampled at `t` (s, from the orbit's start) with
/// `hbar`, `fpbar`, against `orbit`: one per complete period.
pub fn cycles(t: &[f64], hbar: &[f64], fpbar: &[f64], orbit: &OrbitStart) -> Vec<CycleRow> {
    let period = orbit.period;
    let Some(&t_last) = t.last() else {
        return Vec::new();
    };
    let level = orbit.hbar_mean();
    // Upward crossings of the orbit's own samples, closed periodically.
    let mut closed = orbit.hbar.clone();
    closed.push(orbit.hbar[0]);
    let steps: Vec<f64> = (0..closed.len()).map(|k| k as f64).collect();
    let phase_marked = upward_crossings(&steps, &closed, level).len() == 1;
    let crossings = if phase_marked {
        upward_crossings(t, hbar, level)
    } else {
        Vec::new()
    };
    let complete = (t_last / period + 1e-9).floor() as usize;
    (0..complete)
        .map(|k| {
            let (a, b) = (k as f64 * period, (k + 1) as f64 * period);
            let deviation = t
                .iter()
                .zip(hbar)
                .filter(|(s, _)| **s >= a && **s <= b)
                .map(|(s, h)| (h - periodic_value(&orbit.hbar, period, *s)).abs())
                .fold(0.0, f64::max);
            let first = crossings.iter().position(|&c| c >= a && c < b);
            CycleRow {
                cycle: k,
                t_start: a,
                hbar_mean: window_mean(t, hbar, a, b),
                fpbar_mean: window_mean(t, fpbar, a, b),
                deviation,
                period: first
                    .filter(|&j| j > 0)
                    .map(|j| crossings[j] - crossings[j - 1]),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// An orbit whose `hbar` is `1 + 0.1 sin(2 pi t / T)` and `Fpbar` `5 + cos(...)`.
    fn orbit(period: f64, n: usize) -> OrbitStart {
        let phase = |k: usize| 2.0 * PI * k as f64 / n as f64;
        OrbitStart {
            index: 0,
            omega: 0.5,
            period,
            max_multiplier: 1.0,
            hbar: (0..n).map(|k| 1.0 + 0.1 * phase(k).sin()).collect(),
            fpbar: (0..n).map(|k| 5.0 + phase(k).cos()).collect(),
            u: Vec::new(),
            physical: serde_json::Value::Null,
        }
    }

    #[test]
    fn a_simulation_with_another_period_and_a_growing_offset_is_read_cycle_by_cycle() {
        // The orbit: T = 10; the simulation: period 10.2, and an offset growing by 1.5 a period.
        let (period, sim_period, n) = (10.0, 10.2, 400);
        let o = orbit(period, n);
        let t: Vec<f64> = (0..=20_000).map(|i| i as f64 * 2e-3).collect();
        let offset = |t: f64| 1e-5 * 1.5f64.powf(t / period);
        let hbar: Vec<f64> = t
            .iter()
            .map(|&t| 1.0 + 0.1 * (2.0 * PI * t / sim_period).sin() + offset(t))
            .collect();
        let fpbar: Vec<f64> = t
            .iter()
            .map(|&t| 5.0 + (2.0 * PI * t / sim_period).cos())
            .collect();
        let rows = cycles(&t, &hbar, &fpbar, &o);
        assert_eq!(rows.len(), 4);
        for r in &rows {
            let (a, b) = (r.t_start, r.t_start + period);
            // Exact window means of the sine and cosine and of the exponential offset.
            let w = 2.0 * PI / sim_period;
            let sine = 0.1 * ((w * a).cos() - (w * b).cos()) / (w * period);
            let growth = 1.5f64.ln() / period;
            let drift = 1e-5 * ((growth * b).exp() - (growth * a).exp()) / (growth * period);
            assert!((r.hbar_mean - (1.0 + sine + drift)).abs() < 1e-8, "{r:?}");
            let cosine = ((w * b).sin() - (w * a).sin()) / (w * period);
            assert!((r.fpbar_mean - (5.0 + cosine)).abs() < 1e-7, "{r:?}");
            // The phase slip dominates the deviation: `0.1 |sin(w t) - sin(w_sim t)|` is
            // `slip(t) |cos|` with the cosine's phase running through a whole turn each period,
            // so the window's largest lies between the slip half a period before its end and
            // the slip at its end (give or take the offset).
            let slip = |t: f64| 0.2 * (PI * t * (1.0 / period - 1.0 / sim_period)).sin();
            assert!(r.deviation <= slip(b) + offset(b) + 1e-6, "{r:?}");
            assert!(r.deviation >= slip(a + 0.5 * period) - offset(b), "{r:?}");
        }
        // The crossings are one simulated period apart.
        assert_eq!(rows[0].period, None);
        for r in &rows[2..] {
            assert!((r.period.unwrap() - sim_period).abs() < 1e-3, "{r:?}");
        }
    }

    #[test]
    fn the_deviation_from_the_orbit_itself_is_the_interpolation_error() {
        let (period, n) = (7.0, 100);
        let o = orbit(period, n);
        let t: Vec<f64> = (0..=7000).map(|i| i as f64 * 3e-3).collect();
        let hbar: Vec<f64> = t
            .iter()
            .map(|&t| 1.0 + 0.1 * (2.0 * PI * t / period).sin())
            .collect();
        let rows = cycles(&t, &hbar, &hbar, &o);
        assert_eq!(rows.len(), 3);
        // Linear interpolation of a sine of amplitude 0.1 at 100 points a period: at most
        // 0.1 (2 pi / 100)^2 / 8.
        let bound = 0.1 * (2.0 * PI / n as f64).powi(2) / 8.0;
        for r in &rows {
            assert!(r.deviation <= bound * 1.0001, "{r:?} {bound}");
            assert!(r.deviation >= 0.5 * bound, "{r:?} {bound}");
        }
    }

    #[test]
    fn no_period_is_read_where_the_orbit_crosses_its_mean_twice() {
        let (period, n) = (10.0, 200);
        let mut o = orbit(period, n);
        o.hbar = (0..n)
            .map(|k| 1.0 + 0.1 * (4.0 * PI * k as f64 / n as f64).sin())
            .collect();
        let t: Vec<f64> = (0..=3000).map(|i| i as f64 * 1e-2).collect();
        let hbar: Vec<f64> = t
            .iter()
            .map(|&t| 1.0 + 0.1 * (4.0 * PI * t / period).sin())
            .collect();
        let rows = cycles(&t, &hbar, &hbar, &o);
        assert!(rows.iter().all(|r| r.period.is_none()), "{rows:?}");
    }
}

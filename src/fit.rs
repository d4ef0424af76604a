//! Fits: Richardson extrapolation in the node count.

use argmin::core::{CostFunction, Executor};
use argmin::solver::brent::BrentOpt;
use serde::Serialize;

use crate::{Error, Result};

/// A value extrapolated to infinite resolution from a ladder of node counts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Extrapolated {
    /// The limit `v_inf` of `v(N) = v_inf + C N^(-p)`.
    pub value: f64,
    /// Error estimate: with four or more node counts, the largest change of `v_inf` when one of
    /// them is left out, or the root-mean-square misfit if larger; with three, the size of the
    /// correction `|v_inf - v(N_max)|`.
    pub error: f64,
    /// Fitted convergence order `p` and coefficient `C`.
    pub order: f64,
    pub coefficient: f64,
}

/// Least-squares `(v_inf, C)` of `v = v_inf + C N^(-p)` at fixed `p`, and the sum of squared
/// residuals.
fn linear_fit(ns: &[f64], values: &[f64], p: f64) -> (f64, f64, f64) {
    let xs: Vec<f64> = ns.iter().map(|n| n.powf(-p)).collect();
    let m = xs.len() as f64;
    let (sx, sy) = (xs.iter().sum::<f64>(), values.iter().sum::<f64>());
    let sxx: f64 = xs.iter().map(|x| x * x).sum();
    let sxy: f64 = xs.iter().zip(values).map(|(x, y)| x * y).sum();
    let c = (m * sxy - sx * sy) / (m * sxx - sx * sx);
    let v = (sy - c * sx) / m;
    let sse = xs
        .iter()
        .zip(values)
        .map(|(x, y)| (y - v - c * x).powi(2))
        .sum();
    (v, c, sse)
}

struct Misfit<'a> {
    ns: &'a [f64],
    values: &'a [f64],
}

impl CostFunction for Misfit<'_> {
    type Param = f64;
    type Output = f64;
    fn cost(&self, p: &f64) -> std::result::Result<f64, argmin::core::Error> {
        Ok(linear_fit(self.ns, self.values, *p).2)
    }
}

/// Fits `v(N) = v_inf + C N^(-p)` with `p` in `[0.25, 6]` (Brent's method on the misfit, the
/// pair `(v_inf, C)` by linear least squares at each `p`).
fn fit_order(ns: &[f64], values: &[f64]) -> Result<(f64, f64, f64, f64)> {
    let solver = BrentOpt::new(0.25, 6.0);
    let result = Executor::new(Misfit { ns, values }, solver)
        .configure(|s| s.max_iters(200))
        .run()
        .map_err(|e| Error::Numerical(format!("Richardson fit failed: {e}")))?;
    let p = result
        .state()
        .best_param
        .ok_or_else(|| Error::Numerical("Richardson fit found no order".into()))?;
    let (v, c, sse) = linear_fit(ns, values, p);
    Ok((v, c, p, sse))
}

/// Richardson extrapolation of `values` measured at node counts `nodes` (at least three).
pub fn richardson(nodes: &[usize], values: &[f64]) -> Result<Extrapolated> {
    if nodes.len() < 3 || nodes.len() != values.len() {
        return Err(Error::input(
            "nodes",
            "Richardson extrapolation needs at least three node counts",
        ));
    }
    let ns: Vec<f64> = nodes.iter().map(|&n| n as f64).collect();
    let (value, coefficient, order, sse) = fit_order(&ns, values)?;
    let finest = ns
        .iter()
        .zip(values)
        .max_by(|a, b| a.0.total_cmp(b.0))
        .map(|(_, v)| *v)
        .expect("at least three values");
    let error = if ns.len() == 3 {
        (value - finest).abs()
    } else {
        let mut spread: f64 = 0.0;
        for k in 0..ns.len() {
            let (n2, v2): (Vec<f64>, Vec<f64>) = ns
                .iter()
                .zip(values)
                .enumerate()
                .filter(|(i, _)| *i != k)
                .map(|(_, (n, v))| (*n, *v))
                .unzip();
            spread = spread.max((fit_order(&n2, &v2)?.0 - value).abs());
        }
        spread.max((sse / ns.len() as f64).sqrt())
    };
    Ok(Extrapolated {
        value,
        error,
        order,
        coefficient,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn richardson_recovers_a_known_limit_and_order() {
        let nodes = [20, 30, 40, 60, 80];
        let values: Vec<f64> = nodes.iter().map(|&n| 7.837 + 3.0 / n as f64).collect();
        let e = richardson(&nodes, &values).unwrap();
        assert!((e.value - 7.837).abs() < 1e-6, "{e:?}");
        assert!((e.order - 1.0).abs() < 1e-3);
        let values: Vec<f64> = nodes[..3]
            .iter()
            .map(|&n| 2.0 - 5.0 / (n as f64).powi(2))
            .collect();
        let e = richardson(&nodes[..3], &values).unwrap();
        assert!(
            (e.value - 2.0).abs() < 1e-6 && (e.order - 2.0).abs() < 1e-3,
            "{e:?}"
        );
    }
}

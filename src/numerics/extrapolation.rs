//! The extrapolation in the node count with the known orders of the discretization, and the
//! estimated discretization error of the finest rung of a refinement (docs/model.md section 10).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::{Error, Result};

/// A value extrapolated to infinite resolution from a ladder of node counts with the known
/// orders of the discretization (docs/model.md section 10):
///
/// ```text
/// v(N) = c0 + c1 h + c2 h^2,        h = 1/(N - 1)                                    (1)
/// ```
///
/// (for a helix `h` is proportional to the helix angle per edge `dphi`: the elastic part
/// converges as `dphi^2`, the Lighthill point sums and the ends add a first-order part). A
/// free-order model `c + C N^-p` would be biased by the mixture of orders, and its spread could
/// not see the bias.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Extrapolated {
    /// The limit `c0`.
    pub value: f64,
    /// Error estimate: the larger of the change of `c0` when the second-order term is dropped
    /// (the first-order model `c0' + c1' h` through the two finest rungs: what the known
    /// orders add to the leading one) and, with four rungs or more, the largest change of `c0`
    /// when one rung is left out.
    pub error: f64,
    /// The coefficients `c1`, `c2` of (1).
    pub coefficients: [f64; 2],
}

/// Least-squares coefficients `(c0, c1, c2)` of (1) through the points `(h, v)` (at least
/// three distinct `h`).
fn known_order_fit(h: &[f64], values: &[f64]) -> Result<[f64; 3]> {
    let a = DMatrix::from_fn(h.len(), 3, |i, j| h[i].powi(j as i32));
    let b = DVector::from_column_slice(values);
    let c = a
        .svd(true, true)
        .solve(&b, 1e-14)
        .map_err(|e| Error::Numerical(format!("known-order fit failed: {e}")))?;
    Ok([c[0], c[1], c[2]])
}

/// Extrapolation (1) of `values` measured at node counts `nodes` (at least three distinct).
pub fn extrapolate(nodes: &[usize], values: &[f64]) -> Result<Extrapolated> {
    let mut rungs: Vec<(f64, f64)> = nodes
        .iter()
        .zip(values)
        .map(|(&n, &v)| (1.0 / (n as f64 - 1.0), v))
        .collect();
    rungs.sort_by(|a, b| b.0.total_cmp(&a.0));
    rungs.dedup_by(|a, b| a.0 == b.0);
    if rungs.len() < 3 || nodes.len() != values.len() || nodes.iter().any(|&n| n < 2) {
        return Err(Error::input(
            "nodes",
            "the extrapolation needs at least three distinct node counts (each >= 2)",
        ));
    }
    let (h, v): (Vec<f64>, Vec<f64>) = rungs.iter().copied().unzip();
    let [c0, c1, c2] = known_order_fit(&h, &v)?;
    // The two finest rungs (smallest h, last after the sort) through c0' + c1' h.
    let k = h.len();
    let slope = (v[k - 1] - v[k - 2]) / (h[k - 1] - h[k - 2]);
    let first_order = v[k - 1] - slope * h[k - 1];
    let mut error = (c0 - first_order).abs();
    if k >= 4 {
        for leave in 0..k {
            let keep = |i: &usize| *i != leave;
            let h2: Vec<f64> = (0..k).filter(keep).map(|i| h[i]).collect();
            let v2: Vec<f64> = (0..k).filter(keep).map(|i| v[i]).collect();
            error = error.max((known_order_fit(&h2, &v2)?[0] - c0).abs());
        }
    }
    Ok(Extrapolated {
        value: c0,
        error,
        coefficients: [c1, c2],
    })
}

/// The discretization error of the finest of successive refinements (docs/model.md section 10),
/// for `locate --accuracy`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DiscretizationError {
    /// Estimated error of the finest rung's value, `|v(N_finest) - v(infinity)|` (absolute).
    pub error: f64,
    /// The limit the estimate refers to: the known-order fit's `c0`, or the first-order
    /// Richardson limit of the two finest rungs.
    pub limit: f64,
    /// Observed order `log(|v1 - v2| / |v2 - v3|) / log(h1 / h2)` of the three finest rungs when
    /// their spacings shrink by one ratio.
    pub observed_order: Option<f64>,
    /// How the estimate was made.
    pub method: String,
}

/// The error of the finest value of a refinement (at least two rungs, `h = 1/(N - 1)`),
/// from the known orders `v(h) = c0 + c1 h + c2 h^2` (docs/model.md section 10). With
/// `Delta = v_f - v_p` the last increment:
///
/// * two rungs: the first-order Richardson estimate `e1 = |Delta| h_f / (h_p - h_f)`, the larger
///   of the two known orders' estimates when `c1` and `c2` have one sign (at a halving of `h` the
///   second-order one is a third of it);
/// * three rungs or more, when the three finest behave as the model allows (increments of one
///   sign, shrinking, with an observed order `p` between the known ones, 1 and 2, give or take
///   0.1): the larger of the known-order fit's `|v_f - c0|` (the three finest fix `c0, c1, c2`)
///   and the observed-order Richardson estimate `|Delta| h_f^p / (h_p^p - h_f^p)`. The two differ
///   when the rungs carry more than the two orders (pre-asymptotic rungs, quadrature noise);
/// * otherwise the rungs are not in the range where the known orders hold, and the estimate is
///   the conservative `e1`, and says so.
pub(crate) fn discretization_error(nodes: &[usize], values: &[f64]) -> Result<DiscretizationError> {
    if nodes.len() != values.len() || nodes.len() < 2 || nodes.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::input(
            "nodes",
            "the error estimate needs at least two rungs with increasing node counts",
        ));
    }
    let h: Vec<f64> = nodes.iter().map(|&n| 1.0 / (n as f64 - 1.0)).collect();
    let k = h.len();
    let (hp, hf, vp, vf) = (h[k - 2], h[k - 1], values[k - 2], values[k - 1]);
    let richardson = vf - (vp - vf) * hf / (hp - hf);
    let e1 = (vf - richardson).abs();
    let finest_two = format!("N = {} and {}", nodes[k - 2], nodes[k - 1]);
    let first_order = |why: String| DiscretizationError {
        error: e1,
        limit: richardson,
        observed_order: None,
        method: format!(
            "first-order Richardson from {finest_two}, |v_f - v_p| h_f/(h_p - h_f) with h = \
             1/(N - 1), the larger of the known orders' estimates{why}"
        ),
    };
    if k == 2 {
        return Ok(first_order(String::new()));
    }
    let (h3, v3) = (&h[k - 3..], &values[k - 3..]);
    let three = format!("N = {}, {}, {}", nodes[k - 3], nodes[k - 2], nodes[k - 1]);
    let (d1, d2) = (v3[1] - v3[0], v3[2] - v3[1]);
    let order = (d1 * d2 > 0.0 && d2.abs() < d1.abs())
        .then(|| observed_order(h3, d1 / d2))
        .flatten();
    let Some(p) = order.filter(|p| (0.9..=2.1).contains(p)) else {
        let seen = order.map_or(format!("increments {d1:.3e}, {d2:.3e}"), |p| {
            format!("observed order {p:.2}")
        });
        let mut e = first_order(format!(
            " (the rungs {three} are not where the known orders 1 and 2 hold: {seen})"
        ));
        e.observed_order = order;
        return Ok(e);
    };
    let [c0, _, _] = known_order_fit(h3, v3)?;
    let e2 = (vf - c0).abs();
    let ep = d2.abs() * hf.powf(p) / (hp.powf(p) - hf.powf(p));
    let (error, limit) = if e2 >= ep {
        (e2, c0)
    } else {
        (ep, vf + d2.signum() * ep)
    };
    Ok(DiscretizationError {
        error,
        limit,
        observed_order: Some(p),
        method: format!(
            "larger of the known-order fit c0 + c1 h + c2 h^2 (h = 1/(N - 1)) through {three}, \
             |v_f - c0| = {e2:.2e}, and the Richardson estimate with the observed order {p:.2}, \
             {ep:.2e}"
        ),
    })
}

/// The order `p` at which `(h1^p - h2^p) / (h2^p - h3^p)` equals `ratio` (`h1 > h2 > h3 > 0`,
/// `ratio > 1`), by bisection on `p` in `[0.05, 8]`, where the left side grows with `p`;
/// `None` outside that range.
fn observed_order(h: &[f64], ratio: f64) -> Option<f64> {
    let f = |p: f64| (h[0].powf(p) - h[1].powf(p)) / (h[1].powf(p) - h[2].powf(p)) - ratio;
    let (mut lo, mut hi) = (0.05, 8.0);
    if f(lo) > 0.0 || f(hi) < 0.0 {
        return None;
    }
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_orders_recover_the_limit_of_a_mixed_order_ladder() {
        // v = 0.5 + 0.3 h - 2 h^2 (h = 1/(N - 1)): recovered to round-off from three rungs or
        // five; the bar is the effect of the second-order term on the first-order limit.
        let law = |n: usize| {
            let h = 1.0 / (n as f64 - 1.0);
            0.5 + 0.3 * h - 2.0 * h * h
        };
        let nodes = [30, 40, 60, 70, 85];
        let values: Vec<f64> = nodes.iter().map(|&n| law(n)).collect();
        let e = extrapolate(&nodes, &values).unwrap();
        assert!((e.value - 0.5).abs() < 1e-12, "{e:?}");
        assert!((e.coefficients[0] - 0.3).abs() < 1e-9 && (e.coefficients[1] + 2.0).abs() < 1e-7);
        let (h1, h2) = (1.0 / 69.0, 1.0 / 84.0);
        let first_order = law(85) - (law(85) - law(70)) / (h2 - h1) * h2;
        assert!((e.error - (first_order - 0.5).abs()).abs() < 1e-12, "{e:?}");
        let e3 = extrapolate(&nodes[2..], &values[2..]).unwrap();
        assert!((e3.value - 0.5).abs() < 1e-10, "{e3:?}");
        // Two rungs cannot fix three coefficients.
        assert!(extrapolate(&nodes[..2], &values[..2]).is_err());
    }

    #[test]
    fn discretization_error_of_refinements_that_follow_the_known_orders_and_of_some_that_do_not() {
        let law = |n: usize| {
            let h = 1.0 / (n as f64 - 1.0);
            0.5 + 0.3 * h + 2.0 * h * h
        };
        let nodes = [60, 119, 237];
        let values: Vec<f64> = nodes.iter().map(|&n| law(n)).collect();
        // Two rungs: the first-order estimate, which at a halving of h bounds the true error of
        // the finest value (the h^2 part is estimated three times too large).
        let two = discretization_error(&nodes[..2], &values[..2]).unwrap();
        let truth = law(119) - 0.5;
        let h = [1.0 / 59.0, 1.0 / 118.0, 1.0 / 236.0];
        let expected = (law(60) - law(119)) * h[1] / (h[0] - h[1]);
        assert!((two.error - expected).abs() < 1e-14, "{two:?}");
        assert!(
            two.error > truth && two.error < 1.5 * truth,
            "{two:?} vs {truth}"
        );
        // Three rungs on the exact law: the observed order 1.108 (ln of the increments' ratio
        // over ln 2) lies between the known ones; the known-order estimate is the true error,
        // larger than the observed-order one.
        let three = discretization_error(&nodes, &values).unwrap();
        let p = three.observed_order.unwrap();
        let d = [law(119) - law(60), law(237) - law(119)];
        assert!((p - (d[0] / d[1]).ln() / 2f64.ln()).abs() < 1e-9, "{p}");
        assert!((three.error - (law(237) - 0.5)).abs() < 1e-13, "{three:?}");
        assert!((three.limit - 0.5).abs() < 1e-13);
        // Faster than the known orders (order 3): outside the model, the conservative
        // first-order estimate.
        let cubic: Vec<f64> = h.iter().map(|h| 0.5 + 40.0 * h.powi(3)).collect();
        let fast = discretization_error(&nodes, &cubic).unwrap();
        assert!(
            (fast.observed_order.unwrap() - 3.0).abs() < 1e-9,
            "{fast:?}"
        );
        assert!((fast.error - (cubic[1] - cubic[2]) * h[2] / (h[1] - h[2])).abs() < 1e-15);
        assert!(
            fast.method.contains("not where the known orders"),
            "{fast:?}"
        );
        // Oscillating rungs: no order, the first-order estimate.
        let wobbly = [0.51, 0.49, 0.505];
        let w = discretization_error(&nodes, &wobbly).unwrap();
        assert!(
            w.observed_order.is_none() && (w.error - 0.015).abs() < 1e-15,
            "{w:?}"
        );
        assert!(discretization_error(&[60], &[0.5]).is_err());
        assert!(discretization_error(&[119, 60], &[0.5, 0.6]).is_err());
    }
}

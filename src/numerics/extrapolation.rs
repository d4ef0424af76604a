//! The extrapolation in the node count with the known orders of the discretization, and the
//! estimated discretization error of the finest rung of a refinement (docs/model.md section 10).
//! The orders are the model's ([`Orders`]): first and second in general, second alone on the
//! RPY line with the clamped edge centred on the clamp.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

use crate::{Error, Result};

/// The known orders of a discretization's error in the node spacing `h` (docs/model.md
/// section 10), and the spacing it is measured in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Orders {
    /// `v(h) = c0 + c1 h + c2 h^2`, `h = 1/(N - 1)`: the elastic interior converges as `h^2`,
    /// while the clamp on the first edge (section 2) and Lighthill's point sums (section 3) add
    /// a first-order part.
    FirstAndSecond,
    /// `v(h) = c0 + c2 h^2`, `h = 1/(N - 3/2)` (the spacing `L/(N - 3/2)` of the clamped edge
    /// centred on the clamp): the RPY line with point forces at its ends, the velocity tested
    /// at the centroids and a quadrature nested across the ladder (section 9), with the centred
    /// clamp, leaves no first-order term (observed orders 2.15, 2.07, 2.04 on the
    /// representative helix over `N = 60 .. 945`). A first-order estimate would overstate its
    /// error by a factor of three at each halving.
    Second,
}

impl Orders {
    /// The node spacing `h` at `n` nodes, in units of the rod's length (up to the constant
    /// factor of a helix's angle per edge).
    pub fn spacing(self, n: usize) -> f64 {
        match self {
            Orders::FirstAndSecond => 1.0 / (n as f64 - 1.0),
            Orders::Second => 1.0 / (n as f64 - 1.5),
        }
    }

    /// The leading order `p`: 1, or 2.
    pub fn leading(self) -> i32 {
        match self {
            Orders::FirstAndSecond => 1,
            Orders::Second => 2,
        }
    }

    /// The error model in words, for reports.
    pub fn model(self) -> &'static str {
        match self {
            Orders::FirstAndSecond => "omega_b(N) = c0 + c1 h + c2 h^2, h = 1/(N - 1)",
            Orders::Second => "omega_b(N) = c0 + c2 h^2, h = 1/(N - 3/2)",
        }
    }

    /// The ratio of the next increment (from the last of `nodes` to `next`) to the last one,
    /// the start of the search for the next rung's point: with [`Orders::Second`] the
    /// second-order prediction, `(h_l^2 - h_n^2) / (h_p^2 - h_l^2)` (a quarter when the spacing
    /// halves); with [`Orders::FirstAndSecond`] half the first-order one,
    /// `(h_l - h_n) / (2 (h_p - h_l))` (also a quarter at a halving, where the first-order part
    /// alone would give a half and the second-order part pulls it down).
    pub fn next_increment_ratio(self, nodes: &[usize], next: usize) -> f64 {
        let k = nodes.len();
        let p = self.leading();
        let h = |n: usize| self.spacing(n).powi(p);
        let ratio = (h(nodes[k - 1]) - h(next)) / (h(nodes[k - 2]) - h(nodes[k - 1]));
        match self {
            Orders::FirstAndSecond => 0.5 * ratio,
            Orders::Second => ratio,
        }
    }
}

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

/// The second-order Richardson limit `c0` and coefficient `c2` of `v = c0 + c2 h^2` through two
/// rungs `(h, v)`.
fn second_order_pair(h: [f64; 2], v: [f64; 2]) -> (f64, f64) {
    let c2 = (v[0] - v[1]) / (h[0] * h[0] - h[1] * h[1]);
    (v[1] - c2 * h[1] * h[1], c2)
}

/// Extrapolation of `values` at node counts `nodes` (at least three distinct) with the known
/// orders `orders`: [`extrapolate`] for [`Orders::FirstAndSecond`]; for [`Orders::Second`] the
/// limit `c0` of `c0 + c2 h^2` through the two finest rungs, with as its error the change of
/// `c0` from the pair before. That change is what the terms beyond `h^2` do to the limit of the
/// coarser pair; at the finer pair they are at least eight times smaller (order 3 or more,
/// spacing halved), so the change bounds the error of `c0` with a margin.
pub fn extrapolate_with(orders: Orders, nodes: &[usize], values: &[f64]) -> Result<Extrapolated> {
    if orders == Orders::FirstAndSecond {
        return extrapolate(nodes, values);
    }
    let mut rungs: Vec<(usize, f64)> = nodes.iter().copied().zip(values.iter().copied()).collect();
    rungs.sort_by_key(|r| r.0);
    rungs.dedup_by_key(|r| r.0);
    if rungs.len() < 3 || nodes.len() != values.len() || nodes.iter().any(|&n| n < 2) {
        return Err(Error::input(
            "nodes",
            "the extrapolation needs at least three distinct node counts (each >= 2)",
        ));
    }
    let k = rungs.len();
    let pair = |i: usize| {
        second_order_pair(
            [orders.spacing(rungs[i].0), orders.spacing(rungs[i + 1].0)],
            [rungs[i].1, rungs[i + 1].1],
        )
    };
    let (c0, c2) = pair(k - 2);
    let (before, _) = pair(k - 3);
    Ok(Extrapolated {
        value: c0,
        error: (c0 - before).abs(),
        coefficients: [0.0, c2],
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

/// The first-order Richardson estimate of the error of `v_f`, at `N_f` nodes, from `v_p` at a
/// coarser `N_p`: `|v_f - v_p| h_f / (h_p - h_f)` with `h` the spacing of `orders`. It bounds the
/// error where the values converge monotonically at any order at least 1 (at a halving of `h`,
/// three times the second-order estimate).
pub(crate) fn first_order_error(
    orders: Orders,
    (n_p, v_p): (usize, f64),
    (n_f, v_f): (usize, f64),
) -> f64 {
    let (h_p, h_f) = (orders.spacing(n_p), orders.spacing(n_f));
    (v_f - v_p).abs() * h_f / (h_p - h_f)
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
///
/// With [`Orders::Second`] the known order is 2 alone, and the estimates are of second order:
/// from two rungs `e2 = |Delta| h_f^2 / (h_p^2 - h_f^2)` (`h = 1/(N - 3/2)`); from three, when
/// the increments have one sign and shrink, the larger of `e2` and the observed-order estimate
/// (larger only when the observed order is below 2: a first-order remnant is not ignored); else
/// the conservative `e1`, and says so.
pub(crate) fn discretization_error(
    orders: Orders,
    nodes: &[usize],
    values: &[f64],
) -> Result<DiscretizationError> {
    if nodes.len() != values.len() || nodes.len() < 2 || nodes.windows(2).any(|w| w[1] <= w[0]) {
        return Err(Error::input(
            "nodes",
            "the error estimate needs at least two rungs with increasing node counts",
        ));
    }
    if orders == Orders::Second {
        return second_order_error(nodes, values);
    }
    let h: Vec<f64> = nodes.iter().map(|&n| orders.spacing(n)).collect();
    let k = h.len();
    let (hp, hf, vp, vf) = (h[k - 2], h[k - 1], values[k - 2], values[k - 1]);
    let richardson = vf - (vp - vf) * hf / (hp - hf);
    let e1 = first_order_error(orders, (nodes[k - 2], vp), (nodes[k - 1], vf));
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
    Ok(larger_estimate(c0, (vf, d2), (hp, hf), p, |e2, ep| {
        format!(
            "larger of the known-order fit c0 + c1 h + c2 h^2 (h = 1/(N - 1)) through {three}, \
             |v_f - c0| = {e2:.2e}, and the Richardson estimate with the observed order {p:.2}, \
             {ep:.2e}"
        )
    }))
}

/// The larger of two error estimates of the finest value `v_f`: `|v_f - c0|` against the limit
/// `c0` of a fit of known order, and Richardson's with the observed order `p`,
/// `|d| h_f^p / (h_p^p - h_f^p)` (`d = v_f - v_p` the last increment, `h_p > h_f` the spacings of
/// the two finest rungs), whose limit lies that far beyond `v_f` in the direction of `d`. The
/// limit is the larger estimate's; `method(e_fit, e_p)` says how it was found.
fn larger_estimate(
    c0: f64,
    (vf, d): (f64, f64),
    (hp, hf): (f64, f64),
    p: f64,
    method: impl FnOnce(f64, f64) -> String,
) -> DiscretizationError {
    let e_fit = (vf - c0).abs();
    let e_p = d.abs() * hf.powf(p) / (hp.powf(p) - hf.powf(p));
    let (error, limit) = if e_fit >= e_p {
        (e_fit, c0)
    } else {
        (e_p, vf + d.signum() * e_p)
    };
    DiscretizationError {
        error,
        limit,
        observed_order: Some(p),
        method: method(e_fit, e_p),
    }
}

/// [`discretization_error`] with [`Orders::Second`] (at least two rungs, node counts increasing).
fn second_order_error(nodes: &[usize], values: &[f64]) -> Result<DiscretizationError> {
    let h: Vec<f64> = nodes.iter().map(|&n| Orders::Second.spacing(n)).collect();
    let k = h.len();
    let (hp, hf, vp, vf) = (h[k - 2], h[k - 1], values[k - 2], values[k - 1]);
    let (c0, _) = second_order_pair([hp, hf], [vp, vf]);
    let e2 = (vf - c0).abs();
    let finest_two = format!("N = {} and {}", nodes[k - 2], nodes[k - 1]);
    let second = format!(
        "second-order Richardson from {finest_two}, |v_f - v_p| h_f^2/(h_p^2 - h_f^2) with h = \
         1/(N - 3/2) (the RPY line with the centred clamp has no first-order term)"
    );
    if k == 2 {
        return Ok(DiscretizationError {
            error: e2,
            limit: c0,
            observed_order: None,
            method: second,
        });
    }
    let (h3, v3) = (&h[k - 3..], &values[k - 3..]);
    let three = format!("N = {}, {}, {}", nodes[k - 3], nodes[k - 2], nodes[k - 1]);
    let (d1, d2) = (v3[1] - v3[0], v3[2] - v3[1]);
    let order = (d1 * d2 > 0.0 && d2.abs() < d1.abs())
        .then(|| observed_order(h3, d1 / d2))
        .flatten();
    let Some(p) = order.filter(|p| *p >= 0.9) else {
        let seen = order.map_or(format!("increments {d1:.3e}, {d2:.3e}"), |p| {
            format!("observed order {p:.2}")
        });
        let e1 = first_order_error(Orders::Second, (nodes[k - 2], vp), (nodes[k - 1], vf));
        return Ok(DiscretizationError {
            error: e1,
            limit: vf + d2.signum() * e1,
            observed_order: order,
            method: format!(
                "first-order Richardson from {finest_two}, |v_f - v_p| h_f/(h_p - h_f) with h = \
                 1/(N - 3/2): the rungs {three} do not converge as the known order 2 allows \
                 ({seen})"
            ),
        });
    };
    Ok(larger_estimate(c0, (vf, d2), (hp, hf), p, |e2, ep| {
        format!(
            "larger of the {second}, {e2:.2e}, and the Richardson estimate with the order \
             {p:.2} observed over {three}, {ep:.2e}"
        )
    }))
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
        let two = discretization_error(Orders::FirstAndSecond, &nodes[..2], &values[..2]).unwrap();
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
        let three = discretization_error(Orders::FirstAndSecond, &nodes, &values).unwrap();
        let p = three.observed_order.unwrap();
        let d = [law(119) - law(60), law(237) - law(119)];
        assert!((p - (d[0] / d[1]).ln() / 2f64.ln()).abs() < 1e-9, "{p}");
        assert!((three.error - (law(237) - 0.5)).abs() < 1e-13, "{three:?}");
        assert!((three.limit - 0.5).abs() < 1e-13);
        // Faster than the known orders (order 3): outside the model, the conservative
        // first-order estimate.
        let cubic: Vec<f64> = h.iter().map(|h| 0.5 + 40.0 * h.powi(3)).collect();
        let fast = discretization_error(Orders::FirstAndSecond, &nodes, &cubic).unwrap();
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
        let w = discretization_error(Orders::FirstAndSecond, &nodes, &wobbly).unwrap();
        assert!(
            w.observed_order.is_none() && (w.error - 0.015).abs() < 1e-15,
            "{w:?}"
        );
        assert!(discretization_error(Orders::FirstAndSecond, &[60], &[0.5]).is_err());
        assert!(discretization_error(Orders::FirstAndSecond, &[119, 60], &[0.5, 0.6]).is_err());
    }

    /// The second-order model (RPY, centred clamp): on the exact law `0.5 + 2 h^2`
    /// (`h = 1/(N - 3/2)`) the estimates are the true errors to round-off (1e-15) and the limit
    /// is 0.5; with a cubic remnant `+ 30 h^3` the bar of the extrapolation covers the true
    /// limit; with a first-order remnant `+ 0.3 h` the observed order falls below 2 and the
    /// larger observed-order estimate is taken, close to the true error of the finest rung.
    #[test]
    fn second_order_estimates_on_second_order_ladders_and_on_some_that_are_not() {
        let nodes = [60, 119, 237, 473];
        let h = |n: usize| 1.0 / (n as f64 - 1.5);
        let exact: Vec<f64> = nodes.iter().map(|&n| 0.5 + 2.0 * h(n).powi(2)).collect();
        let two = discretization_error(Orders::Second, &nodes[..2], &exact[..2]).unwrap();
        assert!((two.error - (exact[1] - 0.5)).abs() < 1e-15, "{two:?}");
        assert!((two.limit - 0.5).abs() < 1e-15);
        let three = discretization_error(Orders::Second, &nodes[..3], &exact[..3]).unwrap();
        assert!(
            (three.observed_order.unwrap() - 2.0).abs() < 1e-9,
            "{three:?}"
        );
        assert!((three.error - (exact[2] - 0.5)).abs() < 1e-15, "{three:?}");
        let e = extrapolate_with(Orders::Second, &nodes, &exact).unwrap();
        assert!((e.value - 0.5).abs() < 1e-14 && e.error < 1e-14, "{e:?}");
        assert!((e.coefficients[1] - 2.0).abs() < 1e-9 && e.coefficients[0] == 0.0);
        // A third-order remnant: the bar (the change of the limit from the pair before,
        // measured 2.7e-6) covers the true limit (3.8e-7 away).
        let cubic: Vec<f64> = nodes
            .iter()
            .map(|&n| 0.5 + 2.0 * h(n).powi(2) + 30.0 * h(n).powi(3))
            .collect();
        let e = extrapolate_with(Orders::Second, &nodes, &cubic).unwrap();
        assert!((e.value - 0.5).abs() < e.error && e.error < 1e-5, "{e:?}");
        // A first-order remnant: observed order below 2, the observed-order estimate is taken,
        // within 10% of the finest rung's true error (measured 5% below it), where the
        // second-order estimate alone would be a third of it.
        let mixed: Vec<f64> = nodes
            .iter()
            .map(|&n| 0.5 + 0.3 * h(n) + 2.0 * h(n).powi(2))
            .collect();
        let m = discretization_error(Orders::Second, &nodes, &mixed).unwrap();
        let p = m.observed_order.unwrap();
        assert!(p > 1.0 && p < 1.5, "{m:?}");
        let truth = mixed[3] - 0.5;
        let e2 = (mixed[3] - mixed[2]) * h(473).powi(2) / (h(237).powi(2) - h(473).powi(2));
        assert!(
            (m.error / truth - 1.0).abs() < 0.1 && m.error > 2.0 * e2.abs(),
            "{m:?}"
        );
        // Oscillating rungs: the conservative first-order estimate.
        let wobbly = [0.51, 0.49, 0.505];
        let w = discretization_error(Orders::Second, &nodes[..3], &wobbly).unwrap();
        let e1 = 0.015 * h(237) / (h(119) - h(237));
        assert!(
            w.observed_order.is_none() && (w.error - e1).abs() < 1e-15,
            "{w:?}"
        );
        // The leading order predicts the next increment: a quarter at a halving of h.
        let r = Orders::Second.next_increment_ratio(&[60, 119], 237);
        assert!((r - 0.25).abs() < 0.01, "{r}");
    }
}

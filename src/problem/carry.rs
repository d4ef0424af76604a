//! A state of the rod carried from one mesh onto another of the same rod (the sequenced
//! refinement of docs/model.md section 10): positions and twist interpolated along the natural
//! arclength, to be corrected by Newton's method on the new mesh.
//!
//! With `s_i` the natural arclength of node `i` from the clamp point (the sum of the natural
//! edge lengths before it, less half the first with the clamped edge centred on the clamp, over
//! the length from the clamp to the free end), the positions are the not-a-knot cubic spline
//! through the old nodes ([`spline_slopes`]), fourth-order accurate in the old spacing up to the
//! ends; the twist angles, measured in each model's natural chart, are interpolated linearly at
//! the edges' midpoints. The clamp (`x_0`, `x_1`, `theta^0`) is the new model's own.
//!
//! The carried state is off by the old mesh's discretization error, smooth along the rod, and
//! the stiff stretching (`1e4..1e6` times the bending stiffness) turns even that into a large
//! first residual. The interpolant must add little to it. The cubic Hermite interpolant with
//! Catmull-Rom slopes that this spline replaces was second-order accurate and added 12 to 73
//! times the spline's residual on the natural helix (measured with the case of
//! `tests::a_carried_helix_converges_at_fourth_order`, `N = 31 .. 121`); on a helix of 8 turns
//! at 15 nodes per turn Newton's method diverged from the state it carried. With the spline,
//! Newton's method still diverged from the positions and the twist carried together, and
//! converged with either one taken from the finer mesh's solution instead: the sequenced
//! refinement re-solves the twist for the carried positions (`slave_twist`) before Newton's
//! method on the whole. From 5 to 10 nodes per turn the old mesh's own error is too large, and
//! the refinement follows that rung from rest instead.

use nalgebra::Vector3;

use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::params::ClampEdge;
use crate::model::rod::Config;
use crate::model::rod::frame::{Chart, rechart};
use crate::model::steady::Steady;

/// The natural arclength of each node from the clamp point over the rod's length from it to
/// the free end: from 0 at node 0 to 1, or with the clamped edge centred on the clamp
/// (docs/model.md section 2) from `-lbar_0/2` over the rest, so that a point of the rod has
/// the same value on every mesh.
fn node_arclengths(model: &Model) -> Vec<f64> {
    let mut s = vec![0.0];
    for l in &model.rod.rest_lengths {
        s.push(s[s.len() - 1] + l);
    }
    let clamp = match model.physical.clamp_edge() {
        ClampEdge::First => 0.0,
        ClampEdge::Centred => 0.5 * model.rod.rest_lengths[0],
    };
    let total = s[s.len() - 1] - clamp;
    s.iter().map(|v| (v - clamp) / total).collect()
}

/// The index `k` of the interval `[s_k, s_{k+1}]` of the increasing `s` that holds `t`.
fn interval(s: &[f64], t: f64) -> usize {
    s.partition_point(|&v| v <= t).clamp(1, s.len() - 1) - 1
}

/// The slopes `x'(s_k)` of the not-a-knot cubic spline through the nodes `x` (arclengths `s`):
/// second derivative continuous at every node, third derivative at the second and the
/// last-but-one too (de Boor, *A Practical Guide to Splines*, ch. IV): it needs no derivative at
/// the ends, and is fourth-order accurate up to them. By the tridiagonal system of the spline in
/// Hermite form (`h_k = s_{k+1} - s_k`, `d_k = (x_{k+1} - x_k) / h_k`)
///
/// ```text
/// h_k m_{k-1} + 2 (h_{k-1} + h_k) m_k + h_{k-1} m_{k+1} = 3 (h_k d_{k-1} + h_{k-1} d_k),
/// h_1 m_0 + c m_1 = ((h_0 + 2c) h_1 d_0 + h_0^2 d_1) / c,   c = h_0 + h_1,
/// ```
///
/// and the mirror of the second row at the free end, solved by elimination. With fewer than four
/// nodes the slopes are the chords'.
fn spline_slopes(s: &[f64], x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let n = x.len();
    let h: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
    let d: Vec<Vector3<f64>> = (0..n - 1).map(|k| (x[k + 1] - x[k]) / h[k]).collect();
    if n < 4 {
        return (0..n).map(|k| d[k.min(n - 2)]).collect();
    }
    // Rows (lower, diagonal, upper, right-hand side).
    let mut rows: Vec<(f64, f64, f64, Vector3<f64>)> = Vec::with_capacity(n);
    let c = h[0] + h[1];
    rows.push((
        0.0,
        h[1],
        c,
        (d[0] * ((h[0] + 2.0 * c) * h[1]) + d[1] * (h[0] * h[0])) / c,
    ));
    for k in 1..n - 1 {
        rows.push((
            h[k],
            2.0 * (h[k - 1] + h[k]),
            h[k - 1],
            (d[k - 1] * h[k] + d[k] * h[k - 1]) * 3.0,
        ));
    }
    let (a, b) = (h[n - 2], h[n - 3]);
    let c = a + b;
    rows.push((
        c,
        b,
        0.0,
        (d[n - 2] * ((a + 2.0 * c) * b) + d[n - 3] * (a * a)) / c,
    ));
    for k in 1..n {
        let factor = rows[k].0 / rows[k - 1].1;
        let (upper, rhs) = (rows[k - 1].2, rows[k - 1].3);
        rows[k].1 -= factor * upper;
        rows[k].3 -= rhs * factor;
    }
    let mut m = vec![Vector3::zeros(); n];
    for k in (0..n).rev() {
        let next = if k + 1 < n {
            m[k + 1] * rows[k].2
        } else {
            Vector3::zeros()
        };
        m[k] = (rows[k].3 - next) / rows[k].1;
    }
    m
}

/// The free unknowns of `fine` for the state `u` of `coarse`, whose twist is measured in
/// `chart`; the result's twist is measured in `fine`'s natural chart.
pub fn carry(coarse: &Model, u: &[f64], chart: &Chart, fine: &Model) -> Vec<f64> {
    let state = rechart(&Steady::new(coarse, 0.0).config(u), chart, &coarse.chart);
    carry_config(coarse, &state, fine)
}

/// The free unknowns of `fine` for the configuration `state` of `coarse`, its twist measured in
/// `coarse`'s natural chart (the result's in `fine`'s).
pub fn carry_config(coarse: &Model, state: &Config, fine: &Model) -> Vec<f64> {
    let (sc, sf) = (node_arclengths(coarse), node_arclengths(fine));
    let x = &state.x;
    let slopes = spline_slopes(&sc, x);
    let mut positions = fine.natural.clone();
    for (i, p) in positions.iter_mut().enumerate().skip(Layout::CLAMPED_NODES) {
        let t = sf[i];
        let k = interval(&sc, t);
        let h = sc[k + 1] - sc[k];
        let w = (t - sc[k]) / h;
        let (w2, w3) = (w * w, w * w * w);
        *p = x[k] * (2.0 * w3 - 3.0 * w2 + 1.0)
            + slopes[k] * (h * (w3 - 2.0 * w2 + w))
            + x[k + 1] * (-2.0 * w3 + 3.0 * w2)
            + slopes[k + 1] * (h * (w3 - w2));
    }
    let midpoints = |s: &[f64]| -> Vec<f64> { s.windows(2).map(|w| 0.5 * (w[0] + w[1])).collect() };
    let (mc, mf) = (midpoints(&sc), midpoints(&sf));
    let theta: Vec<f64> = mf
        .iter()
        .enumerate()
        .map(|(j, &t)| {
            if j == 0 {
                return 0.0;
            }
            let k = interval(&mc, t);
            let w = ((t - mc[k]) / (mc[k + 1] - mc[k])).clamp(0.0, 1.0);
            state.theta[k] + w * (state.theta[k + 1] - state.theta[k])
        })
        .collect();
    Steady::new(fine, 0.0).free_vector(&Config {
        x: positions,
        theta,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::params::Physical;

    /// The natural helix of the representative rod carried from `n` nodes onto `2n - 1`,
    /// against the finer mesh's own natural shape: (largest position error over the rod
    /// length, norm of the force residual of the carried shape less that of the exact one).
    fn carried_natural(n: usize) -> (f64, f64) {
        let mut p = Physical::representative();
        p.discretization.nodes = n;
        let coarse = Model::new(&p).unwrap();
        p.discretization.nodes = 2 * n - 1;
        let fine = Model::new(&p).unwrap();
        let u = carry_config(&coarse, &coarse.natural_config(), &fine);
        let steady = Steady::new(&fine, 0.0);
        let carried = steady.config(&u);
        let error = carried
            .x
            .iter()
            .zip(&fine.natural)
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        let exact = steady.free_vector(&fine.natural_config());
        let (r, r0) = (
            steady.residual(&u).unwrap(),
            steady.residual(&exact).unwrap(),
        );
        let excess = r.iter().zip(&r0).map(|(a, b)| (a - b).powi(2)).sum::<f64>();
        (error, excess.sqrt())
    }

    /// The spline is fourth-order accurate up to the ends (de Boor, ch. IV): the carried natural
    /// helix's largest position error falls 16 times per halving of the spacing (measured:
    /// orders 4.04, 4.02 over `N = 31, 61, 121`; with the former Catmull-Rom slopes 2.2 and
    /// 2.1), and the force residual the interpolation adds falls too, more slowly (measured
    /// `2.3e3, 1.8e2, 53`: 12.8 and 3.3 times; with Catmull-Rom slopes `2.6e4, 9.3e3, 3.9e3`).
    #[test]
    fn a_carried_helix_converges_at_fourth_order() {
        let runs: Vec<(f64, f64)> = [31, 61, 121].map(carried_natural).to_vec();
        for pair in runs.windows(2) {
            let order = (pair[0].0 / pair[1].0).log2();
            assert!((3.7..4.3).contains(&order), "order {order}: {runs:?}");
            assert!(pair[1].1 < pair[0].1 / 2.0, "{runs:?}");
        }
        assert!(runs[2].1 < 100.0, "{runs:?}");
    }
}

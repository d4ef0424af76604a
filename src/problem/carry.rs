//! A state of the rod carried from one mesh onto another of the same rod (the sequenced
//! refinement of docs/model.md section 10): positions and twist interpolated along the natural
//! arclength, to be corrected by Newton's method on the new mesh.
//!
//! With `s_i` the natural arclength of node `i` from the clamp point (the sum of the natural
//! edge lengths before it, less half the first with the clamped edge centred on the clamp, over
//! the length from the clamp to the free end), the positions are the cubic Hermite interpolant through the old
//! nodes with the Catmull-Rom slopes `x'_k = (x_{k+1} - x_{k-1}) / (s_{k+1} - s_{k-1})`
//! (one-sided at the ends), third-order accurate in the old spacing; the twist angles, measured
//! in each model's natural chart, are interpolated linearly at the edges' midpoints. The clamp
//! (`x_0`, `x_1`, `theta^0`) is the new model's own.
//!
//! The interpolant's chords are shorter than the old polygon's edges where the old mesh turns
//! by a large angle per edge, and the stiff stretching (`1e4..1e6` times the bending
//! stiffness) turns that into a large first residual: from a mesh of 15 or more nodes per turn
//! of a helix Newton's method at the new mesh converges in 5-7 iterations; from 5 to 10 per
//! turn it does not, and the refinement follows that rung from rest instead.

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

/// The Catmull-Rom slope of the nodes `x` at node `k` (arclengths `s`).
fn slope(s: &[f64], x: &[Vector3<f64>], k: usize) -> Vector3<f64> {
    let (a, b) = (k.saturating_sub(1), (k + 1).min(s.len() - 1));
    (x[b] - x[a]) / (s[b] - s[a])
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
    let mut positions = fine.natural.clone();
    for (i, p) in positions.iter_mut().enumerate().skip(Layout::CLAMPED_NODES) {
        let t = sf[i];
        let k = interval(&sc, t);
        let h = sc[k + 1] - sc[k];
        let w = (t - sc[k]) / h;
        let (w2, w3) = (w * w, w * w * w);
        *p = x[k] * (2.0 * w3 - 3.0 * w2 + 1.0)
            + slope(&sc, x, k) * (h * (w3 - 2.0 * w2 + w))
            + x[k + 1] * (-2.0 * w3 + 3.0 * w2)
            + slope(&sc, x, k + 1) * (h * (w3 - w2));
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

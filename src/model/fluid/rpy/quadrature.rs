//! The quadrature of the RPY line (the [module documentation](super), *Quadrature* and *Choice
//! of `m`): the composite two-point Gauss rule on every edge, with a power of two of cells so
//! that the points of the natural polygon stay where they are when the edges are halved.

use nalgebra::Vector3;
use std::f64::consts::PI;

/// Gauss–Legendre rule on `[0, 1]`: nodes `xi_q` and weights `g_q`, `sum g_q = 1`.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct GaussRule {
    pub(super) xi: Vec<f64>,
    pub(super) weight: Vec<f64>,
}

impl GaussRule {
    /// The composite rule of `cells` equal cells of `[0, 1]` with the two-point Gauss rule in
    /// each (exact for cubics on every cell).
    pub(super) fn composite(cells: usize) -> Self {
        let cell = Self::new(2);
        let m = cells as f64;
        let mut xi = Vec::with_capacity(2 * cells);
        let mut weight = Vec::with_capacity(2 * cells);
        for c in 0..cells {
            for (x, g) in cell.xi.iter().zip(&cell.weight) {
                xi.push((c as f64 + x) / m);
                weight.push(g / m);
            }
        }
        Self { xi, weight }
    }

    /// The `q`-point rule (exact for polynomials of degree `2q - 1`): the roots `t` of the
    /// Legendre polynomial `P_q` by Newton iteration from `cos(pi (i + 3/4) / (q + 1/2))`,
    /// `xi = (1 -+ t)/2`, `g = 1 / ((1 - t^2) P_q'(t)^2)`.
    pub(super) fn new(q: usize) -> Self {
        let mut xi = vec![0.0; q];
        let mut weight = vec![0.0; q];
        let qf = q as f64;
        for i in 0..q.div_ceil(2) {
            let mut t = (PI * (i as f64 + 0.75) / (qf + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                // P_q(t) and P_q'(t) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, t);
                for j in 2..=q {
                    let jf = j as f64;
                    let p2 = ((2.0 * jf - 1.0) * t * p1 - (jf - 1.0) * p0) / jf;
                    p0 = p1;
                    p1 = p2;
                }
                derivative = qf * (t * p1 - p0) / (t * t - 1.0);
                let step = p1 / derivative;
                t -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            let g = 1.0 / ((1.0 - t * t) * derivative * derivative);
            xi[i] = 0.5 * (1.0 - t);
            xi[q - 1 - i] = 0.5 * (1.0 + t);
            weight[i] = g;
            weight[q - 1 - i] = g;
        }
        Self { xi, weight }
    }
}

/// Gauss points per edge of the far field's rule (see the [module documentation](super), *Far
/// field*): the pairs of edges far apart take `FAR_POINTS` points on each edge instead of the
/// composite rule's `Q`, where `Q` is larger.
pub(super) const FAR_POINTS: usize = 4;

/// Two edges are far apart where their midpoints are at least `FAR_RATIO` times the longer edge
/// apart in the natural polygon (see the [module documentation](super), *Far field*).
pub(super) const FAR_RATIO: f64 = 3.0;

/// ... and still at least `FAR_RATIO_DEFORMED` times in the configuration at hand.
pub(super) const FAR_RATIO_DEFORMED: f64 = 2.0;

/// The midpoints and lengths of a polygon's edges.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Edges {
    midpoint: Vec<Vector3<f64>>,
    length: Vec<f64>,
}

impl Edges {
    pub(super) fn of(x: &[Vector3<f64>]) -> Self {
        Self {
            midpoint: x.windows(2).map(|e| 0.5 * (e[0] + e[1])).collect(),
            length: x.windows(2).map(|e| (e[1] - e[0]).norm()).collect(),
        }
    }

    /// Whether the edges `k` and `j` are at least `ratio` times the longer one apart, midpoint to
    /// midpoint, and their points at least `gap` apart.
    pub(super) fn apart(&self, k: usize, j: usize, ratio: f64, gap: f64) -> bool {
        let longer = self.length[k].max(self.length[j]);
        let distance = (self.midpoint[k] - self.midpoint[j]).norm();
        distance >= ratio * longer && distance - longer >= gap
    }
}

/// The power of two nearest to `target` (in ratio), at least 1: the cells per edge.
pub(super) fn cells_per_edge(target: f64) -> usize {
    if target <= 1.0 {
        return 1;
    }
    1 << (target.log2().round() as u32)
}

#[cfg(test)]
mod tests {
    use super::{GaussRule, cells_per_edge};

    /// The composite rule's points are nested: `m` cells on an edge are the `2m` cells of its
    /// two halves (to 1e-15); the cells per edge are the power of two nearest in ratio.
    #[test]
    fn the_rule_nests_across_a_halving() {
        let (coarse, fine) = (GaussRule::composite(4), GaussRule::composite(2));
        let halves: Vec<f64> = fine
            .xi
            .iter()
            .map(|x| 0.5 * x)
            .chain(fine.xi.iter().map(|x| 0.5 + 0.5 * x))
            .collect();
        for (a, b) in coarse.xi.iter().zip(&halves) {
            assert!((a - b).abs() < 1e-15);
        }
        assert_eq!(
            [0.3, 0.8, 1.0, 1.5, 2.9, 3.0, 6.0].map(cells_per_edge),
            [1, 1, 1, 2, 4, 4, 8]
        );
    }

    /// The `q`-point rule integrates `xi^d` over `[0, 1]` exactly (`1/(d + 1)`, to 1e-14) for
    /// `d <= 2q - 1`, with increasing nodes inside `(0, 1)` and positive weights.
    #[test]
    fn gauss_rule_is_exact_to_degree_2q_minus_1() {
        for q in 1..=64 {
            let rule = GaussRule::new(q);
            assert!(rule.xi.windows(2).all(|p| p[0] < p[1]));
            assert!(rule.xi[0] > 0.0 && rule.xi[q - 1] < 1.0);
            assert!(rule.weight.iter().all(|&g| g > 0.0));
            for d in 0..2 * q as i32 {
                let sum: f64 = rule
                    .xi
                    .iter()
                    .zip(&rule.weight)
                    .map(|(x, g)| g * x.powi(d))
                    .sum();
                let exact = 1.0 / (d + 1) as f64;
                assert!(
                    (sum - exact).abs() < 1e-14,
                    "q = {q}, degree {d}: {sum} vs {exact}"
                );
            }
        }
    }
}

//! Assembly of the mobility matrix `A(X)`.

use super::geometry::NodeGeometry;
use super::{Lighthill, Quadrature};
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use std::f64::consts::PI;

/// Adds the 3x3 block `b` to the block `(i, j)` (rows `3i..3i+3`, columns `3j..3j+3`) of `m`.
pub(super) fn add_block(m: &mut Mat<f64>, i: usize, j: usize, b: &Matrix3<f64>) {
    for c in 0..3 {
        for r in 0..3 {
            m[(3 * i + r, 3 * j + c)] += b[(r, c)];
        }
    }
}

/// Writes the 3x3 block `b` into the block `(i, j)` of `m`.
fn set_block(m: &mut Mat<f64>, i: usize, j: usize, b: &Matrix3<f64>) {
    for c in 0..3 {
        for r in 0..3 {
            m[(3 * i + r, 3 * j + c)] = b[(r, c)];
        }
    }
}

impl Lighthill {
    /// `1/(4 pi mu)`.
    pub(super) fn local_factor(&self) -> f64 {
        1.0 / (4.0 * PI * self.mu)
    }

    /// Whether the Stokeslet between two nodes at separation `r_norm` enters `A`.
    pub(super) fn couples(&self, r_norm: f64) -> bool {
        match self.quadrature {
            Quadrature::Reference => r_norm > self.delta,
            Quadrature::Original => true,
        }
    }

    /// Diagonal block `A_ii = [ (1 + L) I + (L - 1) t t^T ] / (4 pi mu w)`.
    fn diagonal_block(&self, g: &NodeGeometry) -> Matrix3<f64> {
        let c = self.local_factor() / g.w;
        // t t^T before scaling keeps the block exactly symmetric in floating point.
        Matrix3::from_diagonal_element(c * (1.0 + g.log))
            + g.t * g.t.transpose() * (c * (g.log - 1.0))
    }

    /// The mobility matrix `A(X)` (`3N x 3N`, node-major, symmetric) of the polygon `x`.
    ///
    /// Off-diagonal blocks `A_ij = A_ji = J(x_i - x_j)`,
    /// `J(r) = (I/|r| + r r^T/|r|^3) / (8 pi mu)` (zero within the cut-off for
    /// [`Quadrature::Reference`]); diagonal blocks as in the [module documentation](super).
    /// Each pair is evaluated once and written to both blocks, so `A` is exactly symmetric.
    ///
    /// # Panics
    /// If `x` has fewer than two nodes.
    pub fn mobility(&self, x: &[Vector3<f64>]) -> Mat<f64> {
        let n = x.len();
        assert!(
            n >= 2,
            "Lighthill mobility needs at least two nodes, got {n}"
        );
        let mut a = Mat::zeros(3 * n, 3 * n);
        let stokeslet = 0.5 * self.local_factor();
        for i in 0..n {
            set_block(
                &mut a,
                i,
                i,
                &self.diagonal_block(&self.node_geometry(x, i)),
            );
            for j in i + 1..n {
                let r = x[i] - x[j];
                let rn = r.norm();
                if self.couples(rn) {
                    let inv = 1.0 / rn;
                    let jb = Matrix3::from_diagonal_element(stokeslet * inv)
                        + r * r.transpose() * (stokeslet * inv * inv * inv);
                    set_block(&mut a, i, j, &jb);
                    set_block(&mut a, j, i, &jb);
                }
            }
        }
        a
    }
}

//! Shape derivative of the mobility, `B = ∂(A(X) y)/∂X` (equations on
//! [`Lighthill::mobility_derivative`]).

use super::Lighthill;
use super::mobility::add_block;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};

impl Lighthill {
    /// `B = ∂(A(X) y)/∂X` at fixed `y`: `B[(3i+a, 3j+b)] = ∂(A(X) y)_{3i+a} / ∂x_{j,b}`
    /// (`3N x 3N`, not symmetric). Analytic, `O(N^2)`.
    ///
    /// Write `(A y)_i = g_i + Σ_{j ≠ i} J(x_i - x_j) y_j` (sum over coupled pairs).
    ///
    /// **Stokeslet terms.** With `r = x_i - x_j`,
    ///
    /// ```text
    /// D(r, y) := ∂(J(r) y)/∂r
    ///          = [ -y r^T + (r·y) I + r y^T ] / (8 pi mu |r|^3)  -  3 r (r·y) r^T / (8 pi mu |r|^5),
    /// ```
    ///
    /// which adds `+D(r, y_j)` to the block `B_ii` and `-D(r, y_j)` to `B_ij`. `D` is odd in
    /// `r`, so the partner term of node `j` is `D(x_j - x_i, y_i) = -D(r, y_i)`.
    ///
    /// **Own-node terms.** `g_i = A_ii y_i = c [ (1 + L) y + (L - 1) t (t·y) ] / w` with
    /// `c = 1/(4 pi mu)`, `w = w_i`, `t = t_i`, `L = L_i(w)`, `y = y_i`. Then
    ///
    /// ```text
    /// ∂g/∂w = c L'(w) (y + t (t·y)) / w  -  g / w,
    /// ∂g/∂t = c (L - 1) [ (t·y) I + t y^T ] / w,
    /// B_ik += (∂g/∂w) (∂w/∂x_k)^T + (∂g/∂t) (∂t/∂x_k),   k ∈ {i-1, i, i+1},
    /// ```
    ///
    /// with `L' = 1/w` (interior) or `1/(2w)` (ends) where the logarithm is active, else `0`.
    /// Using `∂|e|/∂e = ê^T`, `∂ê/∂e = (I - ê ê^T)/|e| =: P(e)` and, for `t = s/|s|`,
    /// `∂t/∂s = (I - t t^T)/|s|`:
    ///
    /// * end nodes (`e` the end edge, `w = |e|/2`, `t = ê`): `∂w/∂x = ∓ê/2`, `∂t/∂x = ∓P(e)` for
    ///   the first/second node of the edge;
    /// * interior nodes: `∂w/∂x_{i-1} = -ê^{i-1}/2`, `∂w/∂x_i = (ê^{i-1} - ê^i)/2`,
    ///   `∂w/∂x_{i+1} = ê^i/2`;
    ///   - `Reference` (`s = ê^{i-1} + ê^i`, `T = (I - t t^T)/|s|`): `∂t/∂x_{i-1} = -T P(e^{i-1})`,
    ///     `∂t/∂x_i = T (P(e^{i-1}) - P(e^i))`, `∂t/∂x_{i+1} = T P(e^i)`;
    ///   - `Original` (`d = x_{i+1} - x_{i-1}`): `∂t/∂x_{i∓1} = ∓P(d)`, `∂t/∂x_i = 0`.
    ///
    /// The branch switches (Stokeslet cut off at `|r| = delta`, `L = 0` below the cut-off) are
    /// treated as locally constant.
    ///
    /// # Panics
    /// If `x` has fewer than two nodes or `y.len() != x.len()`.
    pub fn mobility_derivative(&self, x: &[Vector3<f64>], y: &[Vector3<f64>]) -> Mat<f64> {
        let n = x.len();
        assert!(
            n >= 2,
            "Lighthill mobility needs at least two nodes, got {n}"
        );
        assert_eq!(
            y.len(),
            n,
            "mobility_derivative: y has {} nodes, x has {n}",
            y.len()
        );
        let mut b = Mat::zeros(3 * n, 3 * n);
        let c = self.local_factor();
        let stokeslet = 0.5 * c;
        // Σ_j D(x_i - x_j, y_j): the Stokeslet part of B_ii.
        let mut own = vec![Matrix3::zeros(); n];
        for i in 0..n {
            for j in i + 1..n {
                let r = x[i] - x[j];
                let rn = r.norm();
                if !self.couples(rn) {
                    continue;
                }
                let inv2 = 1.0 / (rn * rn);
                let scale = stokeslet * inv2 / rn;
                let d = |y: &Vector3<f64>| {
                    let ry = r.dot(y);
                    (Matrix3::from_diagonal_element(ry) + r * y.transpose()
                        - y * r.transpose()
                        - r * r.transpose() * (3.0 * ry * inv2))
                        * scale
                };
                let dj = d(&y[j]);
                let di = d(&y[i]);
                own[i] += dj;
                own[j] -= di;
                add_block(&mut b, i, j, &-dj);
                add_block(&mut b, j, i, &di);
            }
        }
        for (i, (yi, own_i)) in y.iter().zip(&own).enumerate() {
            add_block(&mut b, i, i, own_i);
            let g = self.node_geometry(x, i);
            let (w, t, log) = (g.w, g.t, g.log);
            let ty = t.dot(yi);
            let gi = (yi * (1.0 + log) + t * ((log - 1.0) * ty)) * (c / w);
            let dg_dw = (yi + t * ty) * (c * g.dlog_dw / w) - gi / w;
            let dg_dt =
                (Matrix3::from_diagonal_element(ty) + t * yi.transpose()) * (c * (log - 1.0) / w);
            for dep in g.dependences() {
                add_block(
                    &mut b,
                    i,
                    dep.node,
                    &(dg_dw * dep.dw.transpose() + dg_dt * dep.dt),
                );
            }
        }
        b
    }
}

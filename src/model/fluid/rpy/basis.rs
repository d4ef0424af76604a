//! The force basis of the RPY line (the [module documentation](super), *The ends carry point
//! forces*): point forces at the two ends, hat functions inside, the velocity tested at each
//! basis function's centroid (`C`, tridiagonal, and its factors).

use super::quadrature::GaussRule;
use faer::Mat;
use nalgebra::Vector3;
use rayon::prelude::*;

/// The force basis of the [module documentation](self) on the natural polygon: point forces at
/// the two ends, hat functions inside (whole on an end edge), and the quadrature weights of the
/// points in it. Constant: everything is measured in natural length.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Basis {
    /// `w_j = ∫ psi_j dsigma` (1 for the point forces at the ends).
    pub(super) w: Vec<f64>,
    /// `[c_p psi_k(y_p), c_p psi_{k+1}(y_p)]` of point `p = k Q + q` on edge `k`, before `1/w`.
    pub(super) pw: Vec<[f64; 2]>,
    /// `C`: the velocity tested by `psi_i`, taken at its centroid (tridiagonal).
    pub(super) consistent: Tridiagonal,
}

/// Columns eliminated side by side by [`Tridiagonal::solve_columns`].
const COLUMNS_TOGETHER: usize = 16;

/// The factors of a tridiagonal `n x n` matrix `T` and of its transpose by Thomas' algorithm
/// (forward elimination without pivoting, stable here: `C` is strictly diagonally dominant by
/// rows, so `C^T` by columns).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Tridiagonal {
    /// `[T, T^T]`.
    pub(super) factors: [Elimination; 2],
}

/// `T = L U` with `L` lower bidiagonal (`1 / inverse_pivot` on the diagonal, `lower` below) and
/// `U` unit upper bidiagonal (`factor` above).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Elimination {
    pub(super) lower: Vec<f64>,
    pub(super) inverse_pivot: Vec<f64>,
    pub(super) factor: Vec<f64>,
}

impl Elimination {
    pub(super) fn new(lower: &[f64], diag: &[f64], upper: &[f64]) -> Self {
        let n = diag.len();
        let mut pivot = vec![diag[0]; n];
        let mut factor = vec![0.0; n];
        for i in 1..n {
            factor[i - 1] = upper[i - 1] / pivot[i - 1];
            pivot[i] = diag[i] - lower[i] * factor[i - 1];
        }
        Self {
            lower: lower.to_vec(),
            inverse_pivot: pivot.iter().map(|p| 1.0 / p).collect(),
            factor,
        }
    }
}

impl Tridiagonal {
    /// `lower[i] = T_{i,i-1}`, `diag[i] = T_ii`, `upper[i] = T_{i,i+1}`.
    pub(super) fn new(lower: &[f64], diag: &[f64], upper: &[f64]) -> Self {
        let n = diag.len();
        let lower_t: Vec<f64> = (0..n)
            .map(|i| if i > 0 { upper[i - 1] } else { 0.0 })
            .collect();
        let upper_t: Vec<f64> = (0..n)
            .map(|i| if i + 1 < n { lower[i + 1] } else { 0.0 })
            .collect();
        Self {
            factors: [
                Elimination::new(lower, diag, upper),
                Elimination::new(&lower_t, diag, &upper_t),
            ],
        }
    }

    /// Solves `T x = v` (`transposed`: `T^T x = v`) in place, entry `i` at `v[3 i + offset]`.
    pub(super) fn solve(&self, v: &mut [f64], offset: usize, transposed: bool) {
        let e = &self.factors[usize::from(transposed)];
        let n = e.inverse_pivot.len();
        v[offset] *= e.inverse_pivot[0];
        for i in 1..n {
            v[3 * i + offset] =
                (v[3 * i + offset] - e.lower[i] * v[3 * (i - 1) + offset]) * e.inverse_pivot[i];
        }
        for i in (0..n - 1).rev() {
            v[3 * i + offset] -= e.factor[i] * v[3 * (i + 1) + offset];
        }
    }

    /// `M <- (T^{-1} (x) I_3) M` (`transposed`: `T^{-T}`). Each column's elimination is a chain
    /// of dependent steps, so the columns are taken [`COLUMNS_TOGETHER`] at a time, node row by
    /// node row: their `3 COLUMNS_TOGETHER` chains advance side by side instead of one after
    /// another (the cost is then the arithmetic, not the latency of each step).
    pub(super) fn solve_columns(&self, m: &mut Mat<f64>, transposed: bool) {
        let e = &self.factors[usize::from(transposed)];
        let n = e.inverse_pivot.len();
        m.par_col_chunks_mut(COLUMNS_TOGETHER).for_each(|chunk| {
            let mut columns: Vec<&mut [f64]> = chunk
                .col_iter_mut()
                .map(|column| {
                    column
                        .try_as_col_major_mut()
                        .expect("a column of an owned matrix is contiguous")
                        .as_slice_mut()
                })
                .collect();
            for column in columns.iter_mut() {
                for v in &mut column[..3] {
                    *v *= e.inverse_pivot[0];
                }
            }
            for i in 1..n {
                let (lower, inverse_pivot) = (e.lower[i], e.inverse_pivot[i]);
                for column in columns.iter_mut() {
                    let (before, row) = column[3 * (i - 1)..3 * i + 3].split_at_mut(3);
                    for (v, b) in row.iter_mut().zip(before.iter()) {
                        *v = (*v - lower * b) * inverse_pivot;
                    }
                }
            }
            for i in (0..n - 1).rev() {
                let factor = e.factor[i];
                for column in columns.iter_mut() {
                    let (row, after) = column[3 * i..3 * i + 6].split_at_mut(3);
                    for (v, a) in row.iter_mut().zip(after.iter()) {
                        *v -= factor * a;
                    }
                }
            }
        });
    }

    /// `(T^{-1} (x) I_3) y` (`transposed`: `T^{-T}`) for node vectors `y`.
    pub(super) fn solve_vectors(&self, y: &[Vector3<f64>], transposed: bool) -> Vec<Vector3<f64>> {
        let mut v: Vec<f64> = y.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        for offset in 0..3 {
            self.solve(&mut v, offset, transposed);
        }
        v.chunks_exact(3)
            .map(|c| Vector3::new(c[0], c[1], c[2]))
            .collect()
    }
}

impl Basis {
    /// The basis on the natural polygon with edges `lbar` and the edge rule `rule`. On edge `k`
    /// the basis function of node `k` is `1 - xi` (`1` if edge `k` is the last, `0` if `k = 0`:
    /// the point force) and that of node `k + 1` is `xi` (`1` if `k = 0`, `0` if `k + 1 = N - 1`).
    pub(super) fn new(lbar: &[f64], rule: &GaussRule) -> Self {
        let edges = lbar.len();
        let n = edges + 1;
        // psi of the edge's two nodes at xi.
        let left = |k: usize, xi: f64| match (k == 0, k + 1 == edges) {
            (true, _) => 0.0,
            (false, true) => 1.0,
            (false, false) => 1.0 - xi,
        };
        let right = |k: usize, xi: f64| match (k + 1 == edges, k == 0) {
            (true, _) => 0.0,
            (false, true) => 1.0,
            (false, false) => xi,
        };
        let mut pw = Vec::with_capacity(edges * rule.xi.len());
        for (k, l) in lbar.iter().enumerate() {
            for (xi, g) in rule.xi.iter().zip(&rule.weight) {
                let c = g * l;
                pw.push([c * left(k, *xi), c * right(k, *xi)]);
            }
        }
        // w_i = ∫ psi_i and the centroid t_i of psi_i, measured from node i along the rod: from
        // edge i - 1 (psi = 1: mass l, moment -l^2/2; the hat 1 + t/l: l/2, -l^2/6) and from edge
        // i (psi = 1: l, l^2/2; the hat 1 - t/l: l/2, l^2/6).
        let (mut lower, mut diag, mut upper) = (vec![0.0; n], vec![1.0; n], vec![0.0; n]);
        let mut w = vec![1.0; n];
        for i in 1..n - 1 {
            let (before, after) = (lbar[i - 1], lbar[i]);
            let (m0, m1) = if i == 1 {
                (before, -0.5 * before * before)
            } else {
                (0.5 * before, -before * before / 6.0)
            };
            let (a0, a1) = if i + 1 == edges {
                (after, 0.5 * after * after)
            } else {
                (0.5 * after, after * after / 6.0)
            };
            w[i] = m0 + a0;
            let t = (m1 + a1) / w[i];
            // The velocity of the line at the centroid, interpolated on its edge.
            if t < 0.0 {
                (lower[i], diag[i]) = (-t / before, 1.0 + t / before);
            } else {
                (diag[i], upper[i]) = (1.0 - t / after, t / after);
            }
        }
        Self {
            w,
            pw,
            consistent: Tridiagonal::new(&lower, &diag, &upper),
        }
    }
}

#[cfg(test)]
mod tests {
    /// The basis (module documentation): the consistent matrix `C` has rows summing to 1, and
    /// the point weights of each node sum to its `w_j` (so a uniform density is reproduced).
    #[test]
    fn basis_reproduces_a_uniform_density() {
        use nalgebra::Vector3;
        for n in [2, 3, 4, 9] {
            let x: Vec<Vector3<f64>> = (0..n)
                .map(|i| Vector3::new(0.3 * i as f64, 0.1 * (i as f64).sin(), 0.0))
                .collect();
            let rpy = super::super::Rpy::new(1.0, 0.05, 3, &x);
            let basis = &rpy.basis;
            let q = rpy.points_per_edge();
            let mut mass = vec![0.0; n];
            for (p, pw) in basis.pw.iter().enumerate() {
                mass[p / q] += pw[0];
                mass[p / q + 1] += pw[1];
            }
            for (i, (m, w)) in mass.iter().zip(&basis.w).enumerate().take(n - 1).skip(1) {
                assert!((m / w - 1.0).abs() < 1e-14, "N = {n}, node {i}");
            }
            assert!(mass[0] == 0.0 && mass[n - 1] == 0.0);
            // C's rows sum to 1: apply C to a constant through C^{-1}.
            let mut v = vec![1.0; 3 * n];
            basis.consistent.solve(&mut v, 1, false);
            assert!(v.iter().all(|c| (c - 1.0).abs() < 1e-14), "N = {n}: {v:?}");
        }
    }

    /// `solve_columns` inverts `T (x) I_3` and `T^T (x) I_3`: multiplying its result by the
    /// tridiagonal matrix itself (built from its three diagonals, not from the factors) gives the
    /// matrix back, for a column count that is not a multiple of the columns taken together.
    #[test]
    fn solve_columns_inverts_the_tridiagonal_matrix() {
        use faer::Mat;
        let n = 11;
        let lower: Vec<f64> = (0..n)
            .map(|i| if i > 0 { 0.1 + 0.01 * i as f64 } else { 0.0 })
            .collect();
        let upper: Vec<f64> = (0..n)
            .map(|i| {
                if i + 1 < n {
                    0.2 - 0.01 * i as f64
                } else {
                    0.0
                }
            })
            .collect();
        let diag: Vec<f64> = (0..n).map(|i| 1.0 + 0.05 * i as f64).collect();
        let t = super::Tridiagonal::new(&lower, &diag, &upper);
        let entry = |r: usize, c: usize| match c as isize - r as isize {
            0 => diag[r],
            -1 => lower[r],
            1 => upper[r],
            _ => 0.0,
        };
        let columns = 2 * super::COLUMNS_TOGETHER + 5;
        let m = Mat::from_fn(3 * n, columns, |r, c| ((r * 7 + c * 13) % 17) as f64 - 8.0);
        for transposed in [false, true] {
            let mut x = m.clone();
            t.solve_columns(&mut x, transposed);
            for c in 0..columns {
                for r in 0..3 * n {
                    let (i, k) = (r / 3, r % 3);
                    let back: f64 = (0..n)
                        .map(|j| {
                            let tij = if transposed { entry(j, i) } else { entry(i, j) };
                            tij * x[(3 * j + k, c)]
                        })
                        .sum();
                    assert!((back - m[(r, c)]).abs() < 1e-12, "row {r}, column {c}");
                }
            }
        }
    }
}

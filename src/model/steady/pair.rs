//! The stability pair `(K, M)` of a steady state (docs/model.md section 5): the stiffness with
//! the quasi-static twist eliminated and the mass matrix `M = Z_ff`, from the blocks of the
//! velocity form.

use faer::Mat;
use faer::prelude::Solve;

use crate::Result;
use crate::model::fluid::Resistance;
use crate::numerics::parallel::{self, join_if};

use super::velocity::banded_product;
use super::{MobilityBlocks, Steady};

/// The share of the columns of `Z_ff W` that the stability pair computes on the thread that also
/// makes the inverse `Z_ff` (the rest on the other thread): with the whole of `Z_ff W` 78 ms and
/// the inverse 33 ms at RPY `N = 400`, both threads end together at `(78 - 33) / (2 78)`.
const VISCOUS_BESIDE_INVERSE: f64 = 0.29;

impl Steady<'_> {
    /// The Hessian `H` of the elastic energy over the free unknowns at `u` (the Jacobian of the
    /// force balance at rest is `-H`).
    pub(crate) fn free_hessian(&self, u: &[f64]) -> Mat<f64> {
        let (_, hessian) = self.model.rod.hessian(&self.config(u), &self.chart);
        let free = self.layout().free_indices();
        Mat::from_fn(free.len(), free.len(), |r, c| hessian[(free[r], free[c])])
    }

    /// The stability pair of docs/model.md section 5 at the free unknowns `u`: `K`, the Jacobian of
    /// the position residual with the quasi-static twist eliminated,
    /// `K = J_xx - J_xt J_tt^{-1} J_tx`, and `M = Z_ff`, the free-free block of `Z = A^{-1}`;
    /// from the blocks of the velocity form ([`Steady::stability_pair_from`]).
    pub fn stability_pair(&self, u: &[f64]) -> Result<(Mat<f64>, Mat<f64>)> {
        self.stability_pair_from(u, None)
    }

    /// [`Steady::stability_pair`] from the blocks of the velocity form at `u`, when they are at
    /// hand (the continuation corrector ends with them; else they are made here). By eq. (5)
    /// premultiplied by `Z_ff = S^{-1}`, the force balance's Jacobian is `-H` plus `Z_ff W` in
    /// its position-position block, `W = (B - Omega)_ff - C B_cf`, so
    ///
    /// ```text
    /// K = -H_xx + H_xt H_tt^{-1} H_tx + Z_ff W,        M = Z_ff,
    /// ```
    ///
    /// the elastic part from the Hessian, `Z_ff W` by a solve over the Cholesky factor of `S`
    /// (which also checks that `S` is positive definite), `M` its inverse. `Z_ff` times `S K`
    /// would give the same `K` in one product, but with the stiff elastic part enlarged by the
    /// condition number of `S` in round-off: enough, next to the double branch point of
    /// Greenhill's column at `N = 80`, to change the sign of the eigenvalues that cross there.
    ///
    /// The elastic part and the factorization of `S` are independent, and so are `Z_ff W` and
    /// the inverse: each pair runs on two threads (at RPY `N = 400` the four took about 28, 18,
    /// 78 and 33 ms one after the other), `Z_ff W` split by columns so that the thread making
    /// the inverse also takes a share of it ([`VISCOUS_BESIDE_INVERSE`]). The arithmetic is the
    /// same either way.
    pub(crate) fn stability_pair_from(
        &self,
        u: &[f64],
        blocks: Option<&MobilityBlocks>,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        let made;
        let blocks = match blocks {
            Some(b) => b,
            None => {
                made = self.linearize_velocity(u)?.blocks;
                &made
            }
        };
        let context = format!(
            "stability at omegabar = {:.6e}, N = {}",
            self.omega,
            self.layout().nodes()
        );
        let parallel = blocks.schur.nrows() >= parallel::FROM;
        let (elastic, resistance) = join_if(
            parallel,
            || self.elastic_stiffness(u),
            || Resistance::new(&blocks.schur, &context),
        );
        let (mut k, resistance) = (elastic?, resistance?);
        // `Z_ff W` column by column: its first `VISCOUS_BESIDE_INVERSE` of the columns on the
        // thread that makes the inverse, the rest on the other.
        let columns = blocks.viscous.as_ref().map_or(0, |w| w.ncols());
        let split = (VISCOUS_BESIDE_INVERSE * columns as f64) as usize;
        let solve = |from: usize, count: usize| {
            blocks
                .viscous
                .as_ref()
                .map(|w| resistance.solve(w.subcols(from, count)))
        };
        let ((inverse, left), right) = join_if(
            parallel,
            || (resistance.inverse(), solve(0, split)),
            || solve(split, columns - split),
        );
        if let (Some(left), Some(right)) = (left, right) {
            let (mut head, mut tail) = k.as_mut().split_at_col_mut(split);
            head += &left;
            tail += &right;
        }
        Ok((k, inverse))
    }

    /// The elastic part of the stability operator, `-H_xx + H_xt H_tt^{-1} H_tx`: the stiffness
    /// of the free positions with the twist relaxed.
    fn elastic_stiffness(&self, u: &[f64]) -> Result<Mat<f64>> {
        let h = self.free_hessian(u);
        let nx = self.layout().free_positions();
        let nt = h.nrows() - nx;
        let eliminated = h
            .submatrix(nx, nx, nt, nt)
            .partial_piv_lu()
            .solve(h.submatrix(nx, 0, nt, nx));
        // H_xt F = (F^T H_tx)^T with H_tx banded (a twist angle couples the nodes of its edge's
        // neighbourhood): O(n^2) instead of a dense product.
        let mut minus_ft_htx = Mat::zeros(nx, nx);
        banded_product(
            eliminated.transpose(),
            h.submatrix(nx, 0, nt, nx),
            minus_ft_htx.as_mut(),
        );
        let k = Mat::from_fn(nx, nx, |r, c| -minus_ft_htx[(c, r)] - h[(r, c)]);
        if !k.is_all_finite() {
            return Err(crate::Error::Numerical(
                "singular twist block in the stability operator".into(),
            ));
        }
        Ok(k)
    }
}

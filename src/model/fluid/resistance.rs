//! The resistance `Z = A^{-1}`, held as the Cholesky factorisation `A = L L^T` (reference
//! quadrature, where `A` must be positive definite) or as an LU factorisation (the original
//! quadrature, whose `A` is indefinite by construction).

use super::{stack_vectors, unstack_vectors};
use crate::error::ModelError;
use crate::{Error, Result};
use faer::linalg::solvers::{DenseSolveCore, Llt, PartialPivLu, Solve};
use faer::{Mat, MatRef, Side};
use nalgebra::Vector3;

/// Resistance `Z = A^{-1}` of a symmetric positive definite mobility `A`, so that the forces
/// producing nodal velocities `U` are `F = Z U`.
#[derive(Clone, Debug)]
pub struct Resistance {
    factor: Factor,
}

#[derive(Clone, Debug)]
enum Factor {
    Cholesky(Llt<f64>),
    Lu(PartialPivLu<f64>),
}

/// Checks that `a` is square with finite entries.
fn check_finite(a: &Mat<f64>, context: &str) -> Result<()> {
    if a.nrows() != a.ncols() {
        return Err(Error::Numerical(format!(
            "mobility matrix is {}x{}, not square ({context})",
            a.nrows(),
            a.ncols()
        )));
    }
    if !a.is_all_finite() {
        return Err(Error::Numerical(format!(
            "non-finite entry in the mobility matrix ({context})"
        )));
    }
    Ok(())
}

impl Resistance {
    /// Cholesky-factorises `a` (only its lower triangle is read; `A` is symmetric by
    /// construction).
    ///
    /// # Errors
    /// * [`Error::NotPositiveDefinite`] with the caller's `context` (e.g.
    ///   `"natural helix, N = 90"`) when the factorisation meets a non-positive pivot.
    /// * [`Error::Numerical`] (naming `context`) when `a` is not square or has a non-finite entry
    ///   (degenerate geometry such as coincident nodes), so no NaN is ever returned silently.
    pub fn new(a: &Mat<f64>, context: &str) -> Result<Self> {
        check_finite(a, context)?;
        let llt = a
            .llt(Side::Lower)
            .map_err(|_| ModelError::NotPositiveDefinite {
                context: context.to_owned(),
                geometry: "a non-positive pivot in the Cholesky factorization".to_owned(),
            })
            .map_err(Error::from)?;
        Ok(Self {
            factor: Factor::Cholesky(llt),
        })
    }

    /// LU-factorises a general (possibly indefinite) `a`, for the original quadrature.
    ///
    /// # Errors
    /// [`Error::Numerical`] when `a` is not square, has a non-finite entry, or is singular.
    pub(crate) fn general(a: &Mat<f64>, context: &str) -> Result<Self> {
        check_finite(a, context)?;
        let lu = a.partial_piv_lu();
        let n = a.nrows();
        let probe = lu.solve(Mat::<f64>::identity(n, n).as_ref());
        if !probe.is_all_finite() {
            return Err(Error::Numerical(format!(
                "singular mobility matrix ({context})"
            )));
        }
        Ok(Self {
            factor: Factor::Lu(lu),
        })
    }

    /// Dimension `3N` of `Z`.
    pub fn dim(&self) -> usize {
        match &self.factor {
            Factor::Cholesky(llt) => llt.L().nrows(),
            Factor::Lu(lu) => lu.L().nrows(),
        }
    }

    /// `Z rhs` for a `3N x k` right-hand side.
    ///
    /// # Panics
    /// If `rhs.nrows() != self.dim()`.
    pub fn solve(&self, rhs: MatRef<'_, f64>) -> Mat<f64> {
        assert_eq!(
            rhs.nrows(),
            self.dim(),
            "Resistance::solve: right-hand side has the wrong number of rows"
        );
        match &self.factor {
            Factor::Cholesky(llt) => llt.solve(rhs),
            Factor::Lu(lu) => lu.solve(rhs),
        }
    }

    /// `Z` itself (`3N x 3N`), for the stability pair, which needs nearly all of it. From the
    /// Cholesky factor `Z = L^{-T} L^{-1}` (`L^{-1}` triangular): about `2n^3/3` operations
    /// against `2n^3` for [`Resistance::solve`] with the identity, and exactly symmetric. From
    /// an LU factorization (the original quadrature), faer's inverse of it.
    pub(crate) fn inverse(&self) -> Mat<f64> {
        match &self.factor {
            Factor::Cholesky(llt) => llt.inverse(),
            Factor::Lu(lu) => lu.inverse(),
        }
    }

    /// `F = Z U` for nodal velocities `u` (one 3-vector per node).
    ///
    /// # Panics
    /// If `3 u.len() != self.dim()`.
    pub fn solve_vectors(&self, u: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        unstack_vectors(self.solve(stack_vectors(u).as_ref()).as_ref(), 0)
    }
}

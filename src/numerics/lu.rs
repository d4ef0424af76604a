//! Dense LU factorization with partial pivoting, `P A = L U` (faer's kernels), for the solves of
//! the size of the rod's unknowns: Newton's steps (the continuation corrector's bordered matrix,
//! the steady solve, the time step), the tangent, the shift-invert spectrum and the criticality
//! solves.
//!
//! Two differences from faer's `PartialPivLu`:
//!
//! * From [`crate::numerics::parallel::FROM`] rows the factorization runs on two threads
//!   (faer's `Par::rayon(2)`), given explicitly: faer's own type reads a process-wide setting,
//!   which would let concurrent cases of a sweep change each other's parallelism (and so their
//!   round-off) by timing. The split of the work is fixed at two parts whatever the number of
//!   threads rayon runs, so the factors are the same bits on every machine
//!   (`the_factors_do_not_depend_on_the_thread_count`).
//! * `L` (unit lower, below the diagonal) and `U` (upper, with the diagonal) stay in the one
//!   matrix the factorization overwrote, as in LAPACK: faer's type copies them into two new
//!   matrices, two more `n x n` allocations filled once per factorization.
//!
//! Solves take the same parallelism ([`parallelism`]): with a few right-hand sides they read the
//! factors once and are bound by memory, and two cores read faster than one (the Krylov-Schur
//! iteration at order 1413 about a third faster).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting::{factor, solve};
use faer::linalg::triangular_solve;
use faer::perm::{PermRef, permute_rows_in_place, permute_rows_in_place_scratch};
use faer::sparse::linalg::lu::{LuRef, NumericLu, SymbolicLu, factorize_symbolic_lu};
use faer::sparse::{SparseColMat, Triplet};
use faer::traits::ComplexField;
use faer::traits::math_utils::zero;
use faer::{Conj, Mat, MatMut, MatRef, Par};

use crate::numerics::parallel::FROM;

/// The parallelism of a dense factorization of order `n`: two threads (a fixed split) from the
/// threshold of the linearization's joins ([`FROM`]), else one. Also the Krylov certificate's
/// complex Cholesky factorization, the triangular solves of [`Lu::solve_in_place`] and the
/// Krylov operator's product by `M`: at RPY `N = 473` (order 1413) the Krylov-Schur iteration,
/// one product and two triangular solves per step, took 0.08-0.12 s on two threads against
/// 0.12-0.17 s on one (three runs of `locate` each, four spectra per run). On the 2-core
/// machine an LU of order 1593 (the bordered matrix at RPY `N = 400`) took 76-96 ms on two
/// threads against 88-113 ms on one (eight alternated runs in one process, a noisy phase of the
/// machine).
pub(crate) fn parallelism(n: usize) -> Par {
    if n >= FROM { Par::rayon(2) } else { Par::Seq }
}

/// `P A = L U`: dense, the factors held in one matrix, or sparse ([`SPARSE_FROM`]).
#[derive(Clone)]
pub struct Lu<T: ComplexField> {
    n: usize,
    factors: Factors<T>,
}

#[derive(Clone)]
enum Factors<T: ComplexField> {
    Dense(DenseFactors<T>),
    Sparse(Box<SparseFactors<T>>),
}

/// `L` and `U` in one matrix and the row permutation.
#[derive(Clone)]
struct DenseFactors<T: ComplexField> {
    lu: Mat<T>,
    forward: Vec<usize>,
    backward: Vec<usize>,
}

impl<T: ComplexField> DenseFactors<T> {
    fn perm(&self) -> PermRef<'_, usize> {
        PermRef::new_checked(&self.forward, &self.backward, self.lu.nrows())
    }
}

#[derive(Clone)]
struct SparseFactors<T: ComplexField> {
    symbolic: SymbolicLu<usize>,
    numeric: NumericLu<usize, T>,
}

/// From this order a matrix with at most [`SPARSE_DENSITY`] of its entries nonzero is factorized
/// as a sparse matrix (faer's sparse LU with partial pivoting after a fill-reducing ordering, on
/// one thread: the same bits on every machine). Such are the Jacobians of the steady solve at
/// rest, where no fluid acts and the elastic Hessian couples nodes at most two apart, and the
/// twist block: at RPY `N = 473` (order 1884) the dense factorization took about 60 ms
/// (two threads), a large part of each of the seven Newton iterations of the state at rest;
/// the sparse one costs the nonzeros' fill, `O(N)` for a band. Counting the nonzeros reads the
/// matrix once, stopping at the limit (a dense matrix pays a twentieth of a read and allocates
/// nothing); a sparse one is read a second time to collect its entries.
const SPARSE_FROM: usize = 200;
/// The largest fraction of nonzero entries factorized as a sparse matrix.
const SPARSE_DENSITY: f64 = 0.05;

/// The sparse factors of `a` where its order and its nonzeros allow ([`SPARSE_FROM`]); `None`
/// otherwise, or where the sparse factorization fails (the dense one then says what is wrong).
fn sparse_factors<T: ComplexField>(a: MatRef<'_, T>) -> Option<Factors<T>> {
    let n = a.nrows();
    if n < SPARSE_FROM {
        return None;
    }
    let limit = (SPARSE_DENSITY * (n * n) as f64) as usize;
    let zero = zero::<T>();
    // Counted before anything is allocated: a dense matrix stops the count at the limit.
    let mut count = 0;
    for j in 0..n {
        for i in 0..n {
            if a[(i, j)] != zero {
                if count == limit {
                    return None;
                }
                count += 1;
            }
        }
    }
    let mut entries = Vec::with_capacity(count);
    for j in 0..n {
        for i in 0..n {
            let v = &a[(i, j)];
            if *v != zero {
                entries.push(Triplet::new(i, j, v.clone()));
            }
        }
    }
    let matrix = SparseColMat::<usize, T>::try_new_from_triplets(n, n, &entries).ok()?;
    let symbolic = factorize_symbolic_lu(matrix.symbolic(), Default::default()).ok()?;
    let mut numeric = NumericLu::new();
    let mut scratch = MemBuffer::try_new(
        symbolic.factorize_numeric_lu_scratch::<T>(Par::Seq, Default::default()),
    )
    .ok()?;
    symbolic
        .factorize_numeric_lu(
            &mut numeric,
            matrix.as_ref(),
            Par::Seq,
            MemStack::new(&mut scratch),
            Default::default(),
        )
        .ok()?;
    Some(Factors::Sparse(Box::new(SparseFactors {
        symbolic,
        numeric,
    })))
}

impl<T: ComplexField> Lu<T> {
    /// The factorization of `a` (square), which it copies.
    pub fn new(a: MatRef<'_, T>) -> Self {
        Self::of(a.to_owned())
    }

    /// The factorization of `a` (square), overwritten by its factors where they are dense.
    pub fn of(mut a: Mat<T>) -> Self {
        let n = a.nrows();
        assert_eq!(n, a.ncols(), "LU of a {n} x {} matrix", a.ncols());
        if let Some(factors) = sparse_factors(a.as_ref()) {
            return Lu { n, factors };
        }
        let par = parallelism(n);
        let mut forward = vec![0usize; n];
        let mut backward = vec![0usize; n];
        let mut scratch = MemBuffer::new(factor::lu_in_place_scratch::<usize, T>(
            n,
            n,
            par,
            Default::default(),
        ));
        factor::lu_in_place(
            a.as_mut(),
            &mut forward,
            &mut backward,
            par,
            MemStack::new(&mut scratch),
            Default::default(),
        );
        Lu {
            n,
            factors: Factors::Dense(DenseFactors {
                lu: a,
                forward,
                backward,
            }),
        }
    }

    /// The order of the matrix.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// `rhs <- A^{-1} rhs`.
    pub(crate) fn solve_in_place(&self, rhs: MatMut<'_, T>) {
        match &self.factors {
            Factors::Dense(dense) => {
                let (lu, par) = (&dense.lu, parallelism(self.n));
                let mut scratch = MemBuffer::new(solve::solve_in_place_scratch::<usize, T>(
                    self.n,
                    rhs.ncols(),
                    par,
                ));
                // The unit lower solve reads only below the diagonal, the upper one only on and
                // above.
                solve::solve_in_place_with_conj(
                    lu.as_ref(),
                    lu.as_ref(),
                    dense.perm(),
                    Conj::No,
                    rhs,
                    par,
                    MemStack::new(&mut scratch),
                );
            }
            Factors::Sparse(f) => {
                let SparseFactors { symbolic, numeric } = f.as_ref();
                let mut scratch =
                    MemBuffer::new(symbolic.solve_in_place_scratch::<T>(rhs.ncols(), Par::Seq));
                LuRef::new_unchecked(symbolic, numeric).solve_in_place_with_conj(
                    Conj::No,
                    rhs,
                    Par::Seq,
                    MemStack::new(&mut scratch),
                );
            }
        }
    }

    /// `A^{-1} rhs`.
    pub fn solve(&self, rhs: MatRef<'_, T>) -> Mat<T> {
        let mut x = rhs.to_owned();
        self.solve_in_place(x.as_mut());
        x
    }

    /// `A^{-H} rhs` (the conjugate transpose; the transpose for a real matrix).
    pub(crate) fn solve_adjoint(&self, rhs: MatRef<'_, T>) -> Mat<T> {
        let mut x = rhs.to_owned();
        match &self.factors {
            Factors::Dense(dense) => {
                let lu = &dense.lu;
                // A = P^T L U, so A^H = U^H L^H P: solve with U^H (lower), L^H (unit upper), then
                // P^T.
                triangular_solve::solve_lower_triangular_in_place_with_conj(
                    lu.transpose(),
                    Conj::Yes,
                    x.as_mut(),
                    Par::Seq,
                );
                triangular_solve::solve_unit_upper_triangular_in_place_with_conj(
                    lu.transpose(),
                    Conj::Yes,
                    x.as_mut(),
                    Par::Seq,
                );
                let mut scratch =
                    MemBuffer::new(permute_rows_in_place_scratch::<usize, T>(self.n, x.ncols()));
                permute_rows_in_place(
                    x.as_mut(),
                    dense.perm().inverse(),
                    MemStack::new(&mut scratch),
                );
            }
            Factors::Sparse(f) => {
                let SparseFactors { symbolic, numeric } = f.as_ref();
                let mut scratch = MemBuffer::new(
                    symbolic.solve_transpose_in_place_scratch::<T>(x.ncols(), Par::Seq),
                );
                LuRef::new_unchecked(symbolic, numeric).solve_transpose_in_place_with_conj(
                    Conj::Yes,
                    x.as_mut(),
                    Par::Seq,
                    MemStack::new(&mut scratch),
                );
            }
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::c64;
    use faer::prelude::Solve;

    /// A well-conditioned test matrix of order `n` with a generic pattern of signs (pivoting
    /// happens: the diagonal is not dominant).
    fn matrix(n: usize) -> Mat<f64> {
        Mat::from_fn(n, n, |i, j| {
            ((i * 7919 + j * 104_729) % 1000) as f64 / 500.0 - 1.0 + if i == j { 2.0 } else { 0.0 }
        })
    }

    fn relative(x: &Mat<f64>, y: &Mat<f64>) -> f64 {
        (x - y).norm_l2() / y.norm_l2()
    }

    #[test]
    fn solves_agree_with_faers_partial_piv_lu() {
        for n in [5, 60, FROM + 37] {
            let a = matrix(n);
            let b = Mat::from_fn(n, 3, |i, j| ((i + 3 * j) as f64).sin());
            let ours = Lu::new(a.as_ref());
            let theirs = a.partial_piv_lu();
            let x = ours.solve(b.as_ref());
            assert!(relative(&x, &theirs.solve(&b)) < 1e-12, "n = {n}");
            // The residual of the solve itself.
            assert!(relative(&(&a * &x), &b) < 1e-12, "n = {n}");
            let xt = ours.solve_adjoint(b.as_ref());
            assert!(relative(&(a.transpose() * &xt), &b) < 1e-12, "n = {n}");
        }
    }

    /// A banded matrix of order `SPARSE_FROM + 50`, half-bandwidth 3, with a dense last row and
    /// column (a bordered band, as the twist block beside the positions), real and complex, is
    /// factorized sparse; its solves and adjoint solves agree with faer's dense LU to round-off,
    /// and its residuals are at round-off.
    #[test]
    fn a_sparse_matrix_is_factorized_sparse_and_solved_as_the_dense_one() {
        let n = SPARSE_FROM + 50;
        let entry = |i: usize, j: usize| -> f64 {
            let band = i.abs_diff(j) <= 3;
            if band || i == n - 1 || j == n - 1 {
                ((i * 7919 + j * 104_729) % 1000) as f64 / 500.0 - 1.0
                    + if i == j { 0.1 } else { 0.0 }
            } else {
                0.0
            }
        };
        let a = Mat::from_fn(n, n, entry);
        let b = Mat::from_fn(n, 2, |i, j| ((i + 3 * j) as f64).sin());
        let ours = Lu::new(a.as_ref());
        assert!(matches!(ours.factors, Factors::Sparse(_)));
        let x = ours.solve(b.as_ref());
        assert!(relative(&x, &a.partial_piv_lu().solve(&b)) < 1e-10);
        assert!(relative(&(&a * &x), &b) < 1e-12);
        let xt = ours.solve_adjoint(b.as_ref());
        assert!(relative(&(a.transpose() * &xt), &b) < 1e-12);
        let ac = Mat::from_fn(n, n, |i, j| c64::new(entry(i, j), 0.3 * entry(j, i)));
        let bc = Mat::from_fn(n, 1, |i, _| c64::new((i as f64).cos(), 1.0));
        let lu = Lu::new(ac.as_ref());
        assert!(matches!(lu.factors, Factors::Sparse(_)));
        let err = |r: Mat<c64>| r.norm_l2() / bc.norm_l2();
        assert!(err(&ac * lu.solve(bc.as_ref()) - &bc) < 1e-12);
        assert!(err(ac.adjoint() * lu.solve_adjoint(bc.as_ref()) - &bc) < 1e-12);
        // The dense test matrix of the same order stays dense.
        assert!(matches!(
            Lu::new(matrix(n).as_ref()).factors,
            Factors::Dense(_)
        ));
    }

    #[test]
    fn the_adjoint_solve_conjugates_a_complex_matrix() {
        let n = 40;
        let (re, im) = (matrix(n), matrix(n).transpose().to_owned());
        let a = Mat::from_fn(n, n, |i, j| c64::new(re[(i, j)], 0.3 * im[(i, j)]));
        let b = Mat::from_fn(n, 1, |i, _| c64::new((i as f64).cos(), 1.0));
        let lu = Lu::new(a.as_ref());
        let x = lu.solve(b.as_ref());
        let y = lu.solve_adjoint(b.as_ref());
        let err = |r: Mat<c64>| r.norm_l2() / b.norm_l2();
        assert!(err(&a * &x - &b) < 1e-12);
        assert!(err(a.adjoint() * &y - &b) < 1e-12);
    }

    #[test]
    fn the_factors_do_not_depend_on_the_thread_count() {
        let n = FROM + 100;
        let a = matrix(n);
        let b = Mat::from_fn(n, 1, |i, _| (i as f64).sqrt());
        let solve_on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool")
                .install(|| Lu::new(a.as_ref()).solve(b.as_ref()))
        };
        let (one, three) = (solve_on(1), solve_on(3));
        assert!((0..n).all(|i| one[(i, 0)].to_bits() == three[(i, 0)].to_bits()));
    }
}

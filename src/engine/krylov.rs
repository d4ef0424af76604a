//! The rightmost eigenvalues of `K v = s M v` (`M` symmetric positive definite) over one LU
//! factorization, with a certificate for the unstable count.
//!
//! **Transform.** For a real shift `sigma` that is no eigenvalue, shift-invert
//!
//! ```text
//! T = (K - sigma M)^{-1} M,        T v = theta v,        s = sigma + 1/theta              (1)
//! ```
//!
//! has the eigenvectors of the pencil; faer's Krylov-Schur (`partial_eigen`, largest `|theta|`)
//! is applied to `T` matrix-free over the one LU factorization of `K - sigma M` (each product
//! one multiplication by `M` and two triangular solves). Largest `|theta|` means nearest to
//! `sigma`: the `nev` converged values found are taken to be every eigenvalue inside the disk
//! `|s - sigma| < R`, `R` a twentieth short of the farthest one found (the usual reading of a
//! converged Krylov-Schur result; the margin keeps an unconverged neighbour just outside it).
//!
//! *Why not the Cayley transform* `(K - sigma M)^{-1}(K + sigma M)`, whose `|mu| > 1` is
//! exactly `Re s > 0`: a Moebius map that sends the imaginary axis to the unit circle sends
//! `s = infinity` onto the circle as well (`mu -> 1`), so the stiff modes of the rod
//! (stretching, `Re s` down to `-1e7` and beyond against `|s| ~ 1e2` for the modes that matter)
//! pile up at `|mu| = 1 - 2 sigma/|s|`, just inside the circle. "Every `|mu| > 1` found" would
//! then need all of them converged. Shift-invert sends them to `theta ~ 0`, where they do not
//! compete; the price is that a disk is not a half-plane, hence the bound below.
//!
//! **Where an eigenvalue can lie.** Every eigenvalue is a value of the field of values
//! `s = v* K v / v* M v` of the pencil. With `K_H = (K + K^T)/2`, `K_S = (K - K^T)/2` one has
//! `Re(e^{-i pi/4} v* K v) = v* (K_H - i K_S) v / sqrt 2`, a Hermitian form, so if
//!
//! ```text
//! G(c) = c M - (K_H - i K_S)       is Hermitian positive definite                         (2)
//! ```
//!
//! (one complex Cholesky factorization, which succeeds or not) then `Re s + Im s < c` for every
//! eigenvalue, and, `K` being real, for its conjugate: `Re s + |Im s| < c`. Every eigenvalue
//! lies in the wedge `x + |y| < c`.
//!
//! **Certificate.** Let `r <= 0` be the real part of the `keep`-th rightmost eigenvalue found
//! (`keep` at least the unstable count + 2, as in the dense path). The part of the wedge with
//! `x >= r` is the triangle with corners `(c, 0)` and `(r, +-(c - r))`. If that triangle lies
//! inside the disk, i.e.
//!
//! ```text
//! (r - sigma)^2 + (c - r)^2 < R^2     and     c - sigma < R,                              (3)
//! ```
//!
//! then no eigenvalue outside the disk has `Re s >= r`: the found set holds every eigenvalue of
//! real part `>= r`, in particular every one with `Re s > 0`. The unstable count and the
//! `keep` rightmost eigenvalues are then exactly those of the full spectrum. `c` is chosen as
//! the largest value allowed by (3) and tested with (2); where (2) fails (the field of values
//! reaches further than the disk), `nev` is doubled and the run repeated over the same
//! factorization, up to [`MAX_NEV`].
//!
//! **A missed eigenvalue.** Krylov-Schur does not prove that it found the `nev` largest
//! `|theta|`: an eigenvalue whose eigenvector is (nearly) absent from the Krylov space, such as
//! the second copy of a double eigenvalue (the two bending planes of a symmetric rod), can be
//! skipped. In shift-invert such a copy grows from round-off by `|theta| / |theta_bulk|` per
//! step, far above the bulk of the stiff spectrum at `theta ~ 0`, so in practice it is found
//! (tested); and as a check, with `Q` an orthonormal basis of the real invariant subspace of the
//! eigenvectors found,
//!
//! ```text
//! Y = (I - Q Q^T) T        has the eigenvalues of T not found,                           (5)
//! ```
//!
//! and a few power steps on `Y` must not grow a vector by more than `1/R` (an eigenvalue inside
//! the disk left out). Along the representative branches the growth times `R` stays in
//! 0.63..0.89 (the next eigenvalue outside the disk); 1 is refused.
//!
//! **Residuals.** Each eigenpair kept is checked in the original pencil,
//!
//! ```text
//! ||K v - s M v|| / ((||K|| + |s| ||M||) ||v||) <= RESIDUAL_TOL                          (4)
//! ```
//!
//! (Frobenius norms for the matrices; a backward error, dominated by the stiff `||K||`).
//!
//! **Fallback.** Any failure (a singular `K - sigma M`, Krylov-Schur not converging, a residual
//! above (4), the certificate (2)-(3) not obtained by `MAX_NEV`, growth in (5)) is returned as a
//! [`Refusal`]; [`super::stability::leading`] then falls back to the dense solver.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{cholesky_in_place, cholesky_in_place_scratch};
use faer::matrix_free::LinOp;
use faer::matrix_free::eigen::{PartialEigenParams, partial_eigen, partial_eigen_scratch};
use faer::reborrow::ReborrowMut;
use faer::{Mat, MatMut, MatRef, Par, c64};

use super::stability::{Solver, Spectrum};
use crate::numerics::lu::{Lu, parallelism};

/// Largest backward error (4) of an eigenpair that is kept.
pub const RESIDUAL_TOL: f64 = 1e-11;

/// The largest number of eigenvalues asked of Krylov-Schur before the dense solver takes over.
pub const MAX_NEV: usize = 96;

/// Fraction of the farthest eigenvalue found that the certified disk keeps.
const DISK_MARGIN: f64 = 0.95;

/// Relative tolerance of Krylov-Schur on `||T y - theta y||`, in units of the largest `|theta|`.
const KRYLOV_TOL: f64 = 1e-13;

/// Restarts allowed to Krylov-Schur.
const MAX_RESTARTS: usize = 40;

/// Why the Krylov path did not return a certified spectrum.
#[derive(Clone, Debug, PartialEq)]
pub enum Refusal {
    /// `K - sigma M` is singular to working precision.
    SingularShift,
    /// Krylov-Schur converged only `converged` of `asked` eigenvalues.
    NotConverged { asked: usize, converged: usize },
    /// An eigenpair's backward error (4) exceeds [`RESIDUAL_TOL`].
    Residual(f64),
    /// The certificate (2)-(3) was not obtained with [`MAX_NEV`] eigenvalues.
    CountInDoubt,
    /// Outside the subspace found, `T` still grows vectors by more than `1/R` (5): an
    /// eigenvalue inside the disk was missed (this many times `1/R`).
    Missed(f64),
}

/// The shift-invert operator (1), applied over the LU factorization of `K - sigma M`.
struct ShiftInvert<'a> {
    lu: &'a Lu<f64>,
    m: MatRef<'a, f64>,
}

impl std::fmt::Debug for ShiftInvert<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ShiftInvert({})", self.m.nrows())
    }
}

impl LinOp<f64> for ShiftInvert<'_> {
    fn apply_scratch(&self, _rhs_ncols: usize, _par: Par) -> StackReq {
        StackReq::EMPTY
    }
    fn nrows(&self) -> usize {
        self.m.nrows()
    }
    fn ncols(&self) -> usize {
        self.m.nrows()
    }
    fn apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, _par: Par, _: &mut MemStack) {
        self.apply_into(out, rhs);
    }
    fn conj_apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, s: &mut MemStack) {
        // A real operator is its own conjugate.
        self.apply(out, rhs, par, s)
    }
}

impl ShiftInvert<'_> {
    /// `out = T rhs`.
    fn apply_into(&self, mut out: MatMut<'_, f64>, rhs: MatRef<'_, f64>) {
        faer::linalg::matmul::matmul(
            out.rb_mut(),
            faer::Accum::Replace,
            self.m,
            rhs,
            1.0,
            parallelism(self.m.nrows()),
        );
        self.lu.solve_in_place(out);
    }
}

/// `nev` eigenpairs of largest `|theta|` of `op`, from a fixed start vector; refused unless all
/// converged.
fn partial(op: &ShiftInvert, nev: usize, tol: f64) -> Result<(Vec<c64>, Mat<c64>), Refusal> {
    let n = op.nrows();
    let params = PartialEigenParams {
        max_restarts: MAX_RESTARTS,
        ..Default::default()
    };
    // A fixed, generic start vector (reproducible results): no eigenvector of a structured
    // problem is orthogonal to it by symmetry.
    let v0 = faer::Col::from_fn(n, |i| 1.0 + ((i as f64 + 1.0) * 0.618_033_988_75).fract());
    let mut values = vec![c64::new(0.0, 0.0); nev];
    let mut vectors = Mat::<c64>::zeros(n, nev);
    let mut mem = MemBuffer::new(partial_eigen_scratch(op, nev, Par::Seq, params));
    let info = partial_eigen(
        vectors.as_mut(),
        &mut values,
        op,
        v0.as_ref(),
        tol,
        Par::Seq,
        MemStack::new(&mut mem),
        params,
    );
    if info.n_converged_eigen < nev {
        return Err(Refusal::NotConverged {
            asked: nev,
            converged: info.n_converged_eigen,
        });
    }
    Ok((values, vectors))
}

/// Power steps taken on `T` deflated of the subspace found (5).
const DEFLATED_STEPS: usize = 8;

/// The growth factor `||Y x|| / ||x||` after [`DEFLATED_STEPS`] power steps on
/// `Y = (I - Q Q^T) T`, `Q` an orthonormal basis of the real invariant subspace spanned by the
/// eigenvectors found (5).
fn deflated_growth(op: &ShiftInvert, theta: &[c64], vectors: &Mat<c64>) -> f64 {
    let n = vectors.nrows();
    // One real column per real eigenvalue, two per pair (one member of it).
    let mut columns: Vec<Vec<f64>> = Vec::new();
    for (j, t) in theta.iter().enumerate() {
        let v = vectors.col(j);
        // The member with Im < 0 of a pair found whole adds nothing.
        let whole = t.im < 0.0
            && theta
                .iter()
                .any(|u| (u - t.conj()).norm() <= 1e-12 * t.norm());
        if !whole {
            columns.push(v.iter().map(|z| z.re).collect());
        }
        if t.im != 0.0 && !whole {
            columns.push(v.iter().map(|z| z.im).collect());
        }
    }
    let basis = Mat::from_fn(n, columns.len(), |i, j| columns[j][i]);
    let q = basis.qr().compute_thin_Q();
    let project = |x: &mut Mat<f64>| {
        let coefficients = q.transpose() * &*x;
        *x -= &q * coefficients;
    };
    let mut x = Mat::from_fn(n, 1, |i, _| {
        ((i as f64 + 0.5) * 0.754_877_666_25).fract() - 0.5
    });
    project(&mut x);
    let mut growth = 0.0;
    for _ in 0..DEFLATED_STEPS {
        if x.norm_l2() == 0.0 {
            // The subspace found is the whole space.
            return 0.0;
        }
        let mut y = Mat::zeros(n, 1);
        op.apply_into(y.as_mut(), x.as_ref());
        project(&mut y);
        growth = y.norm_l2() / x.norm_l2();
        x = y;
    }
    growth
}

/// The backward errors (4) of the pairs `(s_j, v_j)`.
fn backward_errors(k: &Mat<f64>, m: &Mat<f64>, s: &[c64], v: &Mat<c64>) -> Vec<f64> {
    let n = k.nrows();
    let cols = s.len();
    let parts = Mat::from_fn(n, 2 * cols, |i, j| {
        let z = v[(i, j / 2)];
        if j % 2 == 0 { z.re } else { z.im }
    });
    let (kv, mv) = (k * &parts, m * &parts);
    // The Frobenius norms as the square roots of faer's sums of squares: its `norm_l2`, which
    // guards against overflow, took 14-16 ms per matrix here at `n = 1413` (the representative
    // helix, RPY, `N = 473`), a tenth of the certified spectrum, against 1.2 ms. A sum of
    // squares overflows only with entries near `1e154`; the largest of `K` there is `5.7e7`.
    let (k_norm, m_norm) = (k.squared_norm_l2().sqrt(), m.squared_norm_l2().sqrt());
    (0..cols)
        .map(|j| {
            let mut r2 = 0.0;
            let mut v2 = 0.0;
            for i in 0..n {
                let kvi = c64::new(kv[(i, 2 * j)], kv[(i, 2 * j + 1)]);
                let mvi = c64::new(mv[(i, 2 * j)], mv[(i, 2 * j + 1)]);
                r2 += (kvi - s[j] * mvi).norm_sqr();
                v2 += v[(i, j)].norm_sqr();
            }
            r2.sqrt() / ((k_norm + s[j].norm() * m_norm) * v2.sqrt())
        })
        .collect()
}

/// True when `c M - (K_H - i K_S)` is Hermitian positive definite (2): every eigenvalue then
/// has `Re s + |Im s| < c`.
fn wedge_holds(k: &Mat<f64>, m: &Mat<f64>, c: f64) -> bool {
    let n = k.nrows();
    // Factorized in place (only its lower triangle is read), on two threads when large.
    let mut g = Mat::from_fn(n, n, |i, j| {
        let (kij, kji) = (k[(i, j)], k[(j, i)]);
        c64::new(c * m[(i, j)] - 0.5 * (kij + kji), 0.5 * (kij - kji))
    });
    let par = crate::numerics::lu::parallelism(n);
    let mut scratch = MemBuffer::new(cholesky_in_place_scratch::<c64>(n, par, Default::default()));
    cholesky_in_place(
        g.as_mut(),
        Default::default(),
        par,
        MemStack::new(&mut scratch),
        Default::default(),
    )
    .is_ok()
}

/// The largest `c` allowed by (3) for the disk `|s - sigma| < radius` and the real part `r`.
fn largest_wedge(sigma: f64, radius: f64, r: f64) -> Option<f64> {
    let room = radius * radius - (r - sigma) * (r - sigma);
    (room > 0.0).then(|| (r + room.sqrt()).min(sigma + radius))
}

/// A good shift for the point after one whose leading spectrum is `prior`: a quarter of the
/// largest modulus among its leading eigenvalues. That is the scale of the disk the
/// certificate needs (the leading set lies within it), and a positive shift of that size keeps
/// `K - sigma M` far from singular where a real eigenvalue crosses zero (branch points and
/// folds, where `sigma = 0` would be).
pub fn shift_after(prior: &Spectrum) -> f64 {
    let scale = prior.leading.iter().map(|s| s.norm()).fold(0.0, f64::max);
    (0.25 * scale).max(f64::MIN_POSITIVE.sqrt())
}

/// The `keep` eigenvalues of largest real part of `K v = s M v` (at least the unstable count +
/// 2), and the unstable count, by shift-invert at `sigma` with the certificate of the module
/// docs; `nev` the number of eigenvalues asked first.
pub fn rightmost(
    k: &Mat<f64>,
    m: &Mat<f64>,
    keep: usize,
    sigma: f64,
    nev: usize,
) -> Result<Spectrum, Refusal> {
    let n = k.nrows();
    let shifted = Mat::from_fn(n, n, |i, j| k[(i, j)] - sigma * m[(i, j)]);
    let lu = Lu::of(shifted);
    let op = ShiftInvert {
        lu: &lu,
        m: m.as_ref(),
    };
    // The scale of |theta|: three power steps from the start vector.
    let mut x = Mat::from_fn(n, 1, |i, _| 1.0 / (1.0 + i as f64));
    let mut growth = 0.0;
    for _ in 0..3 {
        let mut y = Mat::zeros(n, 1);
        op.apply_into(y.as_mut(), x.as_ref());
        growth = y.norm_l2() / x.norm_l2();
        x = y;
    }
    if !growth.is_finite() || growth == 0.0 {
        return Err(Refusal::SingularShift);
    }
    let mut nev = nev.min(n);
    loop {
        let (theta, vectors) = partial(&op, nev, KRYLOV_TOL * growth)?;
        let values: Vec<c64> = theta
            .iter()
            .map(|t| c64::new(sigma, 0.0) + t.inv())
            .collect();
        if values
            .iter()
            .any(|s| !s.re.is_finite() || !s.im.is_finite())
        {
            return Err(Refusal::SingularShift);
        }
        let radius = DISK_MARGIN
            * values
                .iter()
                .map(|s| (s - sigma).norm())
                .fold(0.0, f64::max);
        let mut order: Vec<usize> = (0..nev).collect();
        order.sort_by(|&a, &b| {
            let (x, y) = (values[a], values[b]);
            y.re.total_cmp(&x.re).then(y.im.total_cmp(&x.im))
        });
        let unstable = values.iter().filter(|s| s.re > 0.0).count();
        let wanted = keep.max(unstable + 2).min(n);
        // The whole spectrum found (a small pencil) needs no certificate; else the `wanted`-th
        // rightmost must lie inside the disk, and then the wedge.
        let certified = nev == n
            || order.get(wanted - 1).is_some_and(|&j| {
                let r = values[j].re.min(0.0);
                (values[j] - sigma).norm() < radius
                    && largest_wedge(sigma, radius, r).is_some_and(|c| wedge_holds(k, m, c))
            });
        if certified {
            let missed = deflated_growth(&op, &theta, &vectors) * radius;
            if missed > 1.0 {
                return Err(Refusal::Missed(missed));
            }
            let kept: Vec<usize> = order[..wanted].to_vec();
            let s: Vec<c64> = kept.iter().map(|&j| values[j]).collect();
            let v = Mat::from_fn(n, wanted, |i, c| vectors[(i, kept[c])]);
            // A NaN residual counts as an infinite one.
            let worst = backward_errors(k, m, &s, &v)
                .into_iter()
                .map(|e| if e.is_nan() { f64::INFINITY } else { e })
                .fold(0.0, f64::max);
            if worst > RESIDUAL_TOL {
                return Err(Refusal::Residual(worst));
            }
            return Ok(Spectrum {
                leading: s,
                unstable,
                solver: Solver::Krylov,
            });
        }
        if nev >= MAX_NEV.min(n) {
            return Err(Refusal::CountInDoubt);
        }
        nev = (2 * nev).min(MAX_NEV).min(n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `K = blockdiag([[a, b], [-b, a]], d)`, `M = I`: a normal pencil, whose field of values is
    /// the triangle of its eigenvalues `a +- i b`, `d`.
    fn normal(a: f64, b: f64, d: f64) -> (Mat<f64>, Mat<f64>) {
        let k = Mat::from_fn(3, 3, |i, j| {
            [[a, b, 0.0], [-b, a, 0.0], [0.0, 0.0, d]][i][j]
        });
        (k, Mat::identity(3, 3))
    }

    #[test]
    fn the_wedge_test_bounds_re_plus_abs_im_of_the_field_of_values() {
        // max(Re s + |Im s|) over the field of values is max(a + |b|, d) = 2.
        let (k, m) = normal(-1.0, 3.0, 0.5);
        assert!(wedge_holds(&k, &m, 2.0 + 1e-9));
        assert!(!wedge_holds(&k, &m, 2.0 - 1e-9));
        let (k, m) = normal(-1.0, 0.5, 1.5);
        assert!(wedge_holds(&k, &m, 1.5 + 1e-9));
        assert!(!wedge_holds(&k, &m, 1.5 - 1e-9));
    }

    #[test]
    fn the_largest_wedge_puts_the_triangle_on_the_disk() {
        let (sigma, radius, r) = (1.0, 10.0, -2.0);
        let c = largest_wedge(sigma, radius, r).unwrap();
        // The corners (r, +-(c - r)) lie on the circle, (c, 0) inside it.
        let corner = ((r - sigma).powi(2) + (c - r).powi(2)).sqrt();
        assert!((corner - radius).abs() < 1e-12 && c - sigma < radius);
        // A disk that does not reach Re s = r allows no wedge.
        assert_eq!(largest_wedge(sigma, 2.5, r), None);
    }

    #[test]
    fn the_deflated_operator_shows_an_eigenvalue_left_out() {
        // M = I, K = diag(-1, -2, ..., -40), sigma = 1: theta_j = 1/(-j - 1).
        let n = 40;
        let k = Mat::from_fn(n, n, |i, j| if i == j { -(i as f64) - 1.0 } else { 0.0 });
        let m = Mat::<f64>::identity(n, n);
        let lu = Lu::of(&k - &m);
        let op = ShiftInvert {
            lu: &lu,
            m: m.as_ref(),
        };
        let found = |first: usize| {
            let theta: Vec<c64> = (first..6)
                .map(|j| c64::new(-1.0 / (j as f64 + 2.0), 0.0))
                .collect();
            let vectors = Mat::from_fn(n, theta.len(), |i, j| {
                c64::new(if i == first + j { 1.0 } else { 0.0 }, 0.0)
            });
            deflated_growth(&op, &theta, &vectors)
        };
        // All of the six nearest found: the next one, 1/8, is what remains.
        assert!((found(0) - 1.0 / 8.0).abs() < 0.02, "{}", found(0));
        // The nearest left out: it dominates what remains (1/2).
        assert!((found(1) - 0.5).abs() < 1e-3, "{}", found(1));
    }

    #[test]
    fn a_shift_on_an_eigenvalue_is_refused() {
        let (k, m) = normal(-1.0, 3.0, 0.5);
        assert_eq!(rightmost(&k, &m, 2, 0.5, 3), Err(Refusal::SingularShift));
    }
}

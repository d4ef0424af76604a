//! Linear stability: the eigenvalues of `K v = s M v` with `M` symmetric positive definite.
//!
//! Dense ([`spectrum`]): with the Cholesky factor `M = L L^T` the problem is the standard one
//! `C w = s w`, `C = L^{-1} K L^{-T}`, `w = L^T v` (same eigenvalues, a quarter of the cost of
//! the QZ algorithm), solved by faer's dense non-symmetric eigensolver.
//!
//! Krylov ([`super::krylov`]): only the rightmost eigenvalues, by shift-invert over one LU
//! factorization, with a certificate that the unstable count is that of the full spectrum.
//! [`leading`] chooses between the two ([`EigenMethod`]) and falls back to dense wherever the
//! Krylov path refuses; every spectrum says which solver gave it ([`Spectrum::solver`]), and
//! [`EigenCounts`] tallies the spectra a caller has seen (as an observer, those of a run).

use std::ops::ControlFlow;

use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Mat, Par, Side, c64};

use super::EigenMethod;
use super::arclength::Point;
use super::events::Event;
use super::krylov::{self, rightmost, shift_after};
use super::stop::Observer;
use crate::{Error, Result};

/// Size of the pencil from which `continuation.eigen = "auto"` uses the Krylov path (measured
/// with `cargo bench --bench eigen`: below it the dense solver is as fast).
pub const AUTO_KRYLOV_SIZE: usize = 150;

/// Which solver gave a spectrum.
#[derive(Clone, Debug, PartialEq)]
pub enum Solver {
    /// The dense solver, as asked.
    Dense,
    /// The Krylov path, its unstable count certified.
    Krylov,
    /// The dense solver, after the Krylov path refused (why).
    Fallback(krylov::Refusal),
}

/// A tally of how spectra were computed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EigenCounts {
    /// Certified Krylov results.
    pub krylov: usize,
    /// Dense solves (asked for, or fallbacks).
    pub dense: usize,
    /// Krylov attempts refused (each followed by a dense solve), and the last reason.
    pub fallbacks: usize,
    pub last_refusal: Option<krylov::Refusal>,
}

/// As an observer of an arclength run, the tally of the spectra of its points and events.
impl Observer<Point, Event> for EigenCounts {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        self.add(&point.spectrum);
        ControlFlow::Continue(())
    }
    fn event(&mut self, event: &Event) -> ControlFlow<()> {
        self.add(&event.spectrum);
        ControlFlow::Continue(())
    }
}

impl EigenCounts {
    /// Counts `spectrum`.
    pub fn add(&mut self, spectrum: &Spectrum) {
        match &spectrum.solver {
            Solver::Krylov => self.krylov += 1,
            Solver::Dense => self.dense += 1,
            Solver::Fallback(refusal) => {
                self.fallbacks += 1;
                self.dense += 1;
                self.last_refusal = Some(refusal.clone());
            }
        }
    }
}

/// The `keep` eigenvalues of largest real part (at least the unstable count + 2) and the
/// unstable count, by `method`. The Krylov path takes its shift from the leading spectrum of a
/// nearby state, `prior` ([`shift_after`]); without one (the first point of a branch) the shift
/// is 0, whose disk holds the eigenvalues nearest the origin: the rightmost ones of a stable
/// state at rest, whose spectrum is real and negative (the certificate decides; a singular `K`
/// is refused). Where it refuses, the dense solver answers. Krylov-Schur is first asked for
/// twice as many eigenvalues as `prior` kept (`keep` without one), plus 8, at least 24 (its
/// subspace has at least 64 vectors in any case); the certificate asks for more where it needs
/// them.
pub fn leading(
    k: &Mat<f64>,
    m: &Mat<f64>,
    keep: usize,
    method: EigenMethod,
    prior: Option<&Spectrum>,
) -> Result<Spectrum> {
    let krylov = match method {
        EigenMethod::Dense => false,
        EigenMethod::Krylov => true,
        EigenMethod::Auto => k.nrows() >= AUTO_KRYLOV_SIZE,
    };
    if krylov {
        let (sigma, nev) = match prior {
            Some(prior) => (shift_after(prior), (2 * prior.leading.len() + 8).max(24)),
            None => (0.0, (2 * keep + 8).max(24)),
        };
        return match rightmost(k, m, keep, sigma, nev) {
            Ok(s) => Ok(s),
            Err(refusal) => Ok(Spectrum {
                solver: Solver::Fallback(refusal),
                ..spectrum(k, m, keep)?
            }),
        };
    }
    spectrum(k, m, keep)
}

/// The leading part of a spectrum.
#[derive(Clone, Debug, PartialEq)]
pub struct Spectrum {
    /// The eigenvalues of largest real part, in decreasing order of real part (a complex pair
    /// appears as two entries).
    pub leading: Vec<c64>,
    /// Number of eigenvalues with a positive real part.
    pub unstable: usize,
    /// The solver that gave it.
    pub solver: Solver,
}

impl Spectrum {
    /// The largest real part.
    pub fn max_re(&self) -> f64 {
        self.leading.first().map_or(f64::NEG_INFINITY, |s| s.re)
    }

    /// The eigenvalue of `leading` nearest to `target`.
    pub fn nearest(&self, target: c64) -> c64 {
        *self
            .leading
            .iter()
            .min_by(|a, b| (**a - target).norm().total_cmp(&(**b - target).norm()))
            .expect("a spectrum has at least one eigenvalue")
    }
}

/// True for an eigenvalue with a genuine imaginary part. A (nearly) double real eigenvalue of a
/// symmetric pair, computed by a non-symmetric solver, may come out as a complex pair with an
/// imaginary part at the square root of round-off; that is not a Hopf pair.
pub fn is_complex(s: c64) -> bool {
    s.im.abs() > 1e-6 * (1.0 + s.norm())
}

/// `C = L^{-1} K L^{-T}` with `M = L L^T`.
fn reduce(k: &Mat<f64>, m: &Mat<f64>) -> Result<Mat<f64>> {
    Ok(reduce_with_factor(k, m)?.0)
}

/// `C = L^{-1} K L^{-T}` and the Cholesky factor `L` of `M = L L^T`.
pub fn reduce_with_factor(k: &Mat<f64>, m: &Mat<f64>) -> Result<(Mat<f64>, Mat<f64>)> {
    let llt = m.llt(Side::Lower).map_err(|_| {
        Error::Numerical("the stability mass matrix is not positive definite".into())
    })?;
    let l = llt.L();
    let mut left = k.clone();
    solve_lower_triangular_in_place(l, left.as_mut(), Par::Seq);
    // L^{-1} (L^{-1} K)^T = L^{-1} K^T L^{-T}, whose transpose is C.
    let mut both = left.transpose().to_owned();
    solve_lower_triangular_in_place(l, both.as_mut(), Par::Seq);
    Ok((both.transpose().to_owned(), l.to_owned()))
}

/// The eigenvalue of `K v = s M v` nearest to `target` and its eigenvector `v` (from the
/// eigenvector `w` of `C`, `v = L^{-T} w`), normalized to unit largest modulus.
pub fn mode(k: &Mat<f64>, m: &Mat<f64>, target: c64) -> Result<(c64, Vec<c64>)> {
    let (c, l) = reduce_with_factor(k, m)?;
    let eigen = c
        .eigen()
        .map_err(|e| Error::Numerical(format!("eigen decomposition failed: {e:?}")))?;
    let values: Vec<c64> = eigen.S().column_vector().iter().copied().collect();
    let index = (0..values.len())
        .min_by(|&a, &b| {
            (values[a] - target)
                .norm()
                .total_cmp(&(values[b] - target).norm())
        })
        .ok_or_else(|| Error::Numerical("empty spectrum".into()))?;
    let n = values.len();
    let w = eigen.U().col(index);
    let mut parts = Mat::from_fn(n, 2, |i, j| if j == 0 { w[i].re } else { w[i].im });
    solve_upper_triangular_in_place(l.transpose(), parts.as_mut(), Par::Seq);
    let v: Vec<c64> = (0..n)
        .map(|i| c64::new(parts[(i, 0)], parts[(i, 1)]))
        .collect();
    let scale = v.iter().map(|z| z.norm()).fold(0.0, f64::max);
    Ok((values[index], v.iter().map(|z| z / scale).collect()))
}

/// The `keep` eigenvalues of largest real part of `K v = s M v`, and the unstable count.
pub fn spectrum(k: &Mat<f64>, m: &Mat<f64>, keep: usize) -> Result<Spectrum> {
    let c = reduce(k, m)?;
    let mut values = c
        .eigenvalues()
        .map_err(|e| Error::Numerical(format!("eigenvalue solver failed: {e:?}")))?;
    if values
        .iter()
        .any(|s| !s.re.is_finite() || !s.im.is_finite())
    {
        return Err(Error::Numerical("non-finite eigenvalue".into()));
    }
    values.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
    let unstable = values.iter().filter(|s| s.re > 0.0).count();
    values.truncate(keep.max(unstable + 2).min(values.len()));
    Ok(Spectrum {
        leading: values,
        unstable,
        solver: Solver::Dense,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generalized_eigenvalues_of_a_known_pair() {
        // K = [[-2, 1], [-1, -2]] has eigenvalues -2 +- i; with M = 2 I they halve.
        let k = Mat::from_fn(2, 2, |i, j| [[-2.0, 1.0], [-1.0, -2.0]][i][j]);
        let m = Mat::from_fn(2, 2, |i, j| if i == j { 2.0 } else { 0.0 });
        let s = spectrum(&k, &m, 2).unwrap();
        assert_eq!(s.unstable, 0);
        assert!(
            (s.leading[0].re + 1.0).abs() < 1e-14 && (s.leading[0].im.abs() - 0.5).abs() < 1e-14
        );
        // A non-diagonal M: K = M diag(1, -3) has eigenvalues 1 and -3.
        let m = Mat::from_fn(2, 2, |i, j| [[2.0, 0.5], [0.5, 1.0]][i][j]);
        let d = Mat::from_fn(2, 2, |i, j| if i == j { [1.0, -3.0][i] } else { 0.0 });
        let k = &m * &d;
        let s = spectrum(&k, &m, 2).unwrap();
        assert_eq!(s.unstable, 1);
        assert!((s.leading[0].re - 1.0).abs() < 1e-12 && (s.leading[1].re + 3.0).abs() < 1e-12);
        // The eigenvector of s = 1 is e_0 (K e_0 = M d e_0 = M e_0).
        let (value, v) = mode(&k, &m, c64::new(1.0, 0.0)).unwrap();
        assert!((value.re - 1.0).abs() < 1e-12);
        assert!(
            (v[0].norm() - 1.0).abs() < 1e-12 && v[1].norm() < 1e-12,
            "{v:?}"
        );
    }
}

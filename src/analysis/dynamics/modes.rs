//! The linear modes of a steady state: the least stable eigenpair of `K v = s M v` with the
//! projection that reads its amplitude off a state, and a steady state displaced along it.

use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Mat, Par, c64};

use crate::engine::stability::reduce_with_factor;
use crate::model::Model;
use crate::model::steady::Steady;
use crate::{Error, Result};

use crate::problem::twist::slave_twist;

/// A linear mode of a steady state: `K v = s M v` (docs/model.md section 5), `v` on the free
/// positions, scaled so that its largest component has modulus 1 and is real.
#[derive(Clone, Debug)]
pub struct Mode {
    pub eigenvalue: c64,
    pub vector: Vec<c64>,
    /// `M z / (z^T M v)` with `z` the left eigenvector (`z^T K = s z^T M`): the projection.
    projector: Vec<c64>,
}

impl Mode {
    /// True for a complex pair (see [`crate::engine::stability::is_complex`]).
    pub fn is_complex(&self) -> bool {
        crate::engine::stability::is_complex(self.eigenvalue)
    }

    /// The complex amplitude `a` of this mode in a position deviation `dx` (length
    /// `3 (N - 2)`): for `dx = Re(a v) + (other modes)`, `a` (for a real mode, `dx = a v`).
    /// Along the linearized dynamics `a(t) = a(0) e^{s t}`.
    pub fn amplitude(&self, dx: &[f64]) -> c64 {
        let p: c64 = self.projector.iter().zip(dx).map(|(q, d)| *q * *d).sum();
        if self.is_complex() { p * 2.0 } else { p }
    }
}

/// The least stable mode (largest `Re s`; of a pair, the member with `Im s > 0`) of the
/// linearization at `u` (free unknowns, twist in the natural chart) at rate `omega`.
///
/// With `M = L L^T`, `C = L^{-1} K L^{-T}` has right eigenvectors `w = L^T v` and left ones
/// `q = L^T z` (faer's dense eigensolver on `C` and on `C^T`).
pub fn least_stable_mode(model: &Model, omega: f64, u: &[f64]) -> Result<Mode> {
    let (k, m) = Steady::new(model, omega).stability_pair(u)?;
    let n = k.nrows();
    let (c, l) = reduce_with_factor(&k, &m)?;
    let l = l.as_ref();
    let both = c.transpose().to_owned();
    // both = C^T.
    let fail = |e| Error::Numerical(format!("eigen solver failed: {e:?}"));
    let right = c.eigen().map_err(fail)?;
    let leftv = both.eigen().map_err(fail)?;
    let s_r = right.S();
    let pick = (0..n)
        .max_by(|&a, &b| {
            let (x, y) = (s_r[a], s_r[b]);
            x.re.total_cmp(&y.re).then(x.im.total_cmp(&y.im))
        })
        .expect("a non-empty spectrum");
    let s = s_r[pick];
    let s_l = leftv.S();
    let pick_l = (0..n)
        .min_by(|&a, &b| (s_l[a] - s).norm().total_cmp(&(s_l[b] - s).norm()))
        .expect("a non-empty spectrum");
    // v = L^{-T} w, z = L^{-T} q (real and imaginary parts separately).
    let back = |col: faer::MatRef<'_, c64>| -> Vec<c64> {
        let mut parts = Mat::from_fn(n, 2, |r, c| {
            if c == 0 {
                col[(r, 0)].re
            } else {
                col[(r, 0)].im
            }
        });
        solve_upper_triangular_in_place(l.transpose(), parts.as_mut(), Par::Seq);
        (0..n)
            .map(|r| c64::new(parts[(r, 0)], parts[(r, 1)]))
            .collect()
    };
    let mut v = back(right.U().subcols(pick, 1));
    let z = back(leftv.U().subcols(pick_l, 1));
    let big = *v
        .iter()
        .max_by(|a, b| a.norm().total_cmp(&b.norm()))
        .expect("non-empty");
    let scale = c64::new(1.0, 0.0) / big;
    for c in &mut v {
        *c *= scale;
    }
    // projector = M z / (z^T M v).
    let mz: Vec<c64> = (0..n)
        .map(|r| (0..n).map(|c| z[c] * m[(r, c)]).sum())
        .collect();
    let zmv: c64 = mz.iter().zip(&v).map(|(a, b)| *a * *b).sum();
    let projector = mz.iter().map(|a| *a / zmv).collect();
    Ok(Mode {
        eigenvalue: s,
        vector: v,
        projector,
    })
}

/// The steady state `u` (free unknowns, twist in the natural chart) displaced along `mode`:
/// positions `x + Re(amplitude e^{i phase} v)` (through [`Steady::retract`], which keeps edge
/// lengths to second order), twist re-solved. As `v` is scaled to a largest component of
/// modulus 1, `amplitude` bounds the displacement of any coordinate (units of `ell`); the modal
/// amplitude [`Mode::amplitude`] of the result is `amplitude e^{i phase}` to first order.
pub fn perturb(
    model: &Model,
    u: &[f64],
    mode: &Mode,
    amplitude: f64,
    phase: f64,
) -> Result<Vec<f64>> {
    let rot = c64::new(phase.cos(), phase.sin()) * amplitude;
    let mut du = vec![0.0; u.len()];
    for (d, v) in du.iter_mut().zip(&mode.vector) {
        *d = (rot * *v).re;
    }
    let moved = Steady::new(model, 0.0).retract(u, &du);
    slave_twist(model, &moved)
}

//! The velocity form of the steady problem (eq. 4-5 of [`super`]): the force balance's position
//! rows premultiplied by `S = Z_ff^{-1}`, whose Newton matrix needs no solve with `Z`; the
//! clamp's Schur complement and the blocks the stability pair reuses.

use faer::linalg::matmul::matmul;
use faer::prelude::Solve;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use nalgebra::Vector3;

use crate::Result;
use crate::model::dofs::Layout;
use crate::model::fluid::stack_vectors;
use crate::numerics::parallel::{self, join_if};

use super::{Drag, Steady, rotation_velocity};

impl<'a> Steady<'a> {
    /// The co-rotating velocity of the free nodes in the overdamped dynamics
    /// `Z_ff dx_f/dt = R_x(u)` (docs/model.md section 5), in mobility form: no factorization of
    /// `A` and no inverse.
    ///
    /// With `g = -dE/dx + F_gravity` the force the rod puts on the fluid at the free nodes and
    /// `F_c` the clamp reactions that keep the clamp nodes in rigid rotation,
    ///
    /// ```text
    /// A_cc F_c = (Omega X)_c - A_cf g_f,    dx_f/dt = A_ff g_f + A_fc F_c - (Omega X)_f,   (4)
    /// ```
    ///
    /// the lab velocity of the free nodes less that of rigid rotation. This is `Z_ff^{-1} R_x`:
    /// by the block inverse, `Z_ff^{-1} = S = A_ff - A_fc A_cc^{-1} A_cf` (the Schur complement
    /// of the `6 x 6` clamp block), and `S [Z Omega X]_f = (Omega X)_f - A_fc A_cc^{-1}
    /// (Omega X)_c` (from `A Z Omega X = Omega X` in blocks), so only the products `A g` and
    /// `A E_c` (`E_c` the six unit columns of the clamp) are needed. On the RPY line they are
    /// taken without assembling `A` ([`crate::model::fluid::Fluid::mobility_product`]): one pass
    /// of the kernel over the pairs of quadrature points for `g`, the clamp's columns a pass over
    /// the points of the first edges only (`cargo bench --bench fluid`: 4.7 ms at `N = 480`
    /// against 24 ms for the assembly; below about `N = 120` on the representative helix the
    /// product costs up to 1.4 times the assembly, whose dense work is small there, and the
    /// linearizations, not the residuals, dominate such runs). Lighthill's `A`, not positive by
    /// construction, is assembled and checked by a Cholesky factorization, as the resistance
    /// would be; that factorization is the only one, and nothing is solved with `3N`
    /// right-hand sides.
    pub fn free_velocity(&self, u: &[f64]) -> Result<Vec<f64>> {
        let mut v = self.velocity_residual(u)?;
        v.truncate(self.layout().free_positions());
        Ok(v)
    }

    /// The steady problem in velocity form, `V(u) = (dx_f/dt, R_t) = 0` (eq. 4 and eq. 2): the
    /// same solutions as eq. (1)-(2), whose position rows it premultiplies by `S = Z_ff^{-1}`
    /// (`dx_f/dt = S R_x`).
    pub fn velocity_residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        let config = self.config(u);
        let gradient = self.model.rod.gradient(&config, &self.chart);
        let force = self.full_residual(&gradient, None);
        let rigid = rotation_velocity(self.omega, &config.x);
        let velocity = if self.model.fluid.definite_by_construction() {
            // `A` applied to the free force and to the clamp's six unit columns, never
            // assembled (RPY: no dense work, the clamp columns' sources are local).
            let (n3, c) = (3 * config.x.len(), 3 * Layout::CLAMPED_NODES);
            let columns = Mat::from_fn(n3, 1 + c, |r, j| match j {
                0 if r >= c => force[r],
                0 => 0.0,
                j => f64::from(u8::from(r == j - 1)),
            });
            let products = self
                .model
                .fluid
                .mobility_product(&config.x, columns.as_ref());
            let context = self.context("velocity", config.x.len());
            let coupling = clamp_coupling(products.get(.., 1..), &context)?;
            free_velocity_of(products.get(.., 0..1), &coupling, &rigid)
        } else {
            let mobility = self.clamped_mobility(&config.x, "velocity")?;
            mobility.velocity(&force, &rigid)
        };
        Ok(self.with_twist_rows(velocity, &force))
    }

    /// `V(u)` and the Jacobian of Newton's method on it (docs/model.md section 4, velocity
    /// form): `S R'(u)`, the Jacobian of the force balance (1)-(2) premultiplied by
    /// `S = Z_ff^{-1}` on the position rows, which is `V'(u)` wherever `R = 0` (`V = S R`, so
    /// `V' = S R' + (dS) R`). A step solves `S R' du = -S R`: exactly the step of Newton's
    /// method on `R`, whose iterates it keeps (the exact `V'` adds the curvature of `S(X)` times
    /// the force residual: with it the corrector took 42 steps instead of 37 to the default Hopf
    /// point, 40 instead of 37 to the RPY `N = 400` one). With
    /// `y = Z Omega X` the drag, `B = d(A(X) y)/dX` at fixed `y`, `C = A_fc A_cc^{-1}` and `H`
    /// the elastic Hessian, eq. (3) premultiplied by `S` (by the block inverse `S Z_ff = I` and
    /// `S Z_fc = -C`) gives, `Omega` being block diagonal,
    ///
    /// ```text
    /// S R_x' = [ (B - Omega)_ff - C B_cf - S H_xx ,  -S H_xt ],   R_t' as in (1)-(2).       (5)
    /// ```
    ///
    /// `S H` is formed band by band (`H` couples nodes at most two apart), so the cost is one
    /// assembly of `A`, its Cholesky factorization (for `y`, and the check that `A` is positive
    /// definite), one shape derivative `B` and `O(N^2)`: none of the solve with `3N`
    /// right-hand sides of eq. (3), the largest cost of [`Steady::linearize`] at large `N`.
    pub fn linearize_velocity(&self, u: &[f64]) -> Result<VelocityLinearized> {
        let config = self.config(u);
        let x = &config.x;
        let layout = self.layout();
        let (n, nx) = (layout.free_len(), layout.free_positions());
        // The free unknowns are two contiguous runs of the full layout: positions, then angles.
        let (first_x, first_t) = (layout.x(Layout::CLAMPED_NODES, 0), layout.theta(1));
        // The pieces run two at a time where they are independent: the elastic Hessian beside
        // the mobility; then the drag (a factorization of A, the drag forces and the shape
        // derivative B at them) beside the clamp's Schur complement S with the elastic rows S H
        // (at RPY N = 400 the factorization and the second chain took about 20 ms each, B 55 ms;
        // the RPY kernels share the threads with whatever runs beside them).
        let parallel = n >= parallel::FROM;
        let ((gradient, hessian), a) = join_if(
            parallel,
            || self.model.rod.hessian(&config, &self.chart),
            || self.model.fluid.mobility(x),
        );
        let context = format!("omegabar = {:.6e}, N = {}", self.omega, x.len());
        let (dragged, clamped) = join_if(
            parallel,
            || -> Result<Option<(Drag, Mat<f64>)>> {
                if self.omega == 0.0 {
                    self.check_definite(&a, x, &context)?;
                    return Ok(None);
                }
                let resistance = self.model.fluid.factorize(&a, x, &context)?;
                let forces = resistance.solve_vectors(&rotation_velocity(self.omega, x));
                let b = self.model.fluid.mobility_derivative(x, &forces);
                Ok(Some((Drag { resistance, forces }, b)))
            },
            || -> Result<(Mat<f64>, Mat<f64>, Mat<f64>)> {
                let coupling = clamp_coupling(a.as_ref(), &context)?;
                let schur = schur_complement(&a, &coupling);
                let mut jacobian = Mat::zeros(n, n);
                for (column, first, width) in [(0, first_x, nx), (nx, first_t, n - nx)] {
                    banded_product(
                        schur.as_ref(),
                        hessian.submatrix(first_x, first, nx, width),
                        jacobian.submatrix_mut(0, column, nx, width),
                    );
                    for c in 0..width {
                        for r in nx..n {
                            jacobian[(r, column + c)] = -hessian[(first_t + r - nx, first + c)];
                        }
                    }
                }
                Ok((coupling, schur, jacobian))
            },
        );
        let (dragged, (coupling, schur, mut jacobian)) = (dragged?, clamped?);
        let (drag, b) = dragged.unzip();
        let force = self.restrict(&self.full_residual(&gradient, drag.as_ref()));
        let viscous = b.map(|b| {
            let c = 3 * Layout::CLAMPED_NODES;
            let mut w = b.submatrix(c, c, nx, nx) - &coupling * b.submatrix(0, c, c, nx);
            // -Omega: d(Omega X)_i/dx_i on the free nodes.
            for i in 0..nx / 3 {
                w[(3 * i + 1, 3 * i)] -= self.omega;
                w[(3 * i, 3 * i + 1)] += self.omega;
            }
            w
        });
        if let Some(w) = &viscous {
            let mut block = jacobian.submatrix_mut(0, 0, nx, nx);
            block += w;
        }
        let sr = &schur * Mat::from_fn(nx, 1, |r, _| force[r]);
        let residual = (0..nx)
            .map(|r| sr[(r, 0)])
            .chain(force[nx..].iter().copied())
            .collect();
        Ok(VelocityLinearized {
            residual,
            jacobian,
            blocks: MobilityBlocks { schur, viscous },
            coupling,
        })
    }

    /// The root-mean-square eigenvalue of `S = Z_ff^{-1}` at the positions `x`,
    /// `|S|_F / sqrt(n_x)`: the factor by which `S` enlarges a force of no particular shape, such
    /// as the round-off of the force balance. The continuation divides the velocity rows by it
    /// ([`crate::problem::rod::RodProblem`]), so that its tolerance measures a force, as in (1).
    pub(crate) fn typical_mobility(&self, x: &[Vector3<f64>]) -> Result<f64> {
        let s = self.clamped_mobility(x, "mobility scale")?.schur();
        Ok(s.norm_l2() / (s.nrows() as f64).sqrt())
    }

    /// The mobility at `x` split at the clamp; where it is not positive definite by
    /// construction (Lighthill) it is checked by a factorization. Errors name `what`.
    fn clamped_mobility(&self, x: &[Vector3<f64>], what: &str) -> Result<ClampedMobility> {
        let context = self.context(what, x.len());
        let a = self.model.fluid.mobility(x);
        self.check_definite(&a, x, &context)?;
        ClampedMobility::split(a, &context)
    }

    /// What an error of `what` at this rate on `nodes` nodes names.
    fn context(&self, what: &str, nodes: usize) -> String {
        format!("{what} at omegabar = {:.6e}, N = {nodes}", self.omega)
    }

    /// Where the mobility `a` at `x` is not positive definite by construction (Lighthill), its
    /// Cholesky factorization, as the resistance would be made: the error names `context`.
    fn check_definite(&self, a: &Mat<f64>, x: &[Vector3<f64>], context: &str) -> Result<()> {
        if !self.model.fluid.definite_by_construction() {
            self.model.fluid.factorize(a, x, context)?;
        }
        Ok(())
    }

    /// `velocity` (the free positions' rows) followed by the twist rows of `full`.
    fn with_twist_rows(&self, mut velocity: Vec<f64>, full: &[f64]) -> Vec<f64> {
        let fp = self.layout().free_positions();
        velocity.extend_from_slice(&self.restrict(full)[fp..]);
        velocity
    }
}

impl Steady<'_> {
    /// `dV/d omegabar = C (Omega_1 X)_c - (Omega_1 X)_f` (eq. 4 at unit rate; the clamp
    /// reactions carry the clamp's motion), zero on the angles.
    pub(crate) fn velocity_rate_derivative(&self, lin: &VelocityLinearized, u: &[f64]) -> Vec<f64> {
        let x = self.config(u).x;
        let rigid = stack_vectors(&rotation_velocity(1.0, &x));
        let c = 3 * Layout::CLAMPED_NODES;
        let carried = &lin.coupling * rigid.submatrix(0, 0, c, 1);
        let (n, nx) = (self.layout().free_len(), self.layout().free_positions());
        (0..nx)
            .map(|r| carried[(r, 0)] - rigid[(c + r, 0)])
            .chain(std::iter::repeat_n(0.0, n - nx))
            .collect()
    }

    /// `dV/dq = S w_f`, `w` the weight at unit `q` on the free nodes, zero on the angles.
    pub(crate) fn velocity_weight_derivative(&self, lin: &VelocityLinearized) -> Vec<f64> {
        let w = self.weight_derivative();
        let nx = self.layout().free_positions();
        let sw = &lin.blocks.schur * Mat::from_fn(nx, 1, |r, _| w[r]);
        (0..nx)
            .map(|r| sw[(r, 0)])
            .chain(w[nx..].iter().copied())
            .collect()
    }
}

/// The blocks of the velocity form that the stability pair needs: `S = A_ff - A_fc A_cc^{-1}
/// A_cf = Z_ff^{-1}` and the viscous block `W = (B - Omega)_ff - C B_cf` of eq. (5) (none at
/// rest), both over the free positions.
pub struct MobilityBlocks {
    pub schur: Mat<f64>,
    pub viscous: Option<Mat<f64>>,
}

/// The velocity form `V = (dx_f/dt, R_t)` and its Jacobian at one point
/// ([`Steady::linearize_velocity`]), with the pieces of the mobility that the parameter
/// derivatives and the stability pair reuse.
pub struct VelocityLinearized {
    pub residual: Vec<f64>,
    pub jacobian: Mat<f64>,
    pub blocks: MobilityBlocks,
    /// `C = A_fc A_cc^{-1}` (free positions by the six clamp coordinates).
    coupling: Mat<f64>,
}

/// The mobility `A(X)` split at the clamp (eq. 4): the coupling `C = A_fc A_cc^{-1}` of the
/// free nodes to the clamp.
struct ClampedMobility {
    a: Mat<f64>,
    coupling: Mat<f64>,
}

impl ClampedMobility {
    /// Splits `a`; a singular clamp block is an error naming `context`.
    fn split(a: Mat<f64>, context: &str) -> Result<Self> {
        let coupling = clamp_coupling(a.as_ref(), context)?;
        Ok(ClampedMobility { a, coupling })
    }

    /// The velocity of the free nodes less `rigid` (eq. 4), with the clamp reactions that carry
    /// the clamp with `rigid`, for `force` in the full layout of the unknowns (only its free
    /// positions are read) and the rigid velocities.
    fn velocity(&self, force: &[f64], rigid: &[Vector3<f64>]) -> Vec<f64> {
        let c = 3 * Layout::CLAMPED_NODES;
        let f = Mat::from_fn(self.a.nrows(), 1, |r, _| if r < c { 0.0 } else { force[r] });
        free_velocity_of((&self.a * f).as_ref(), &self.coupling, rigid)
    }

    /// `S = A_ff - C A_cf`, the Schur complement of the clamp block: `Z_ff^{-1}`.
    fn schur(&self) -> Mat<f64> {
        schur_complement(&self.a, &self.coupling)
    }
}

/// Eq. (4) from the products of the mobility: `af = A f` for the force `f` with zero clamp
/// rows, and the coupling `C = A_fc A_cc^{-1}`: the clamp reactions
/// `F_c = A_cc^{-1} ((Omega X)_c - (A f)_c)` and `dx_f/dt = (A f)_f + A_fc F_c - (Omega X)_f`.
fn free_velocity_of(af: MatRef<'_, f64>, coupling: &Mat<f64>, rigid: &[Vector3<f64>]) -> Vec<f64> {
    let c = 3 * Layout::CLAMPED_NODES;
    let n3 = af.nrows();
    let rigid = stack_vectors(rigid);
    let carried = coupling * (rigid.submatrix(0, 0, c, 1) - af.submatrix(0, 0, c, 1));
    (0..n3 - c)
        .map(|r| af[(c + r, 0)] + carried[(r, 0)] - rigid[(c + r, 0)])
        .collect()
}

/// `C = A_fc A_cc^{-1}` of the mobility `a` split at the clamp (only its first
/// six columns are read: `a` may be those alone); a singular clamp block is an error naming
/// `context`.
fn clamp_coupling(a: MatRef<'_, f64>, context: &str) -> Result<Mat<f64>> {
    let c = 3 * Layout::CLAMPED_NODES;
    let nx = a.nrows() - c;
    let cc_inverse = a
        .submatrix(0, 0, c, c)
        .partial_piv_lu()
        .solve(Mat::<f64>::identity(c, c));
    if !cc_inverse.is_all_finite() {
        return Err(crate::Error::Numerical(format!(
            "singular clamp block of the mobility ({context})"
        )));
    }
    Ok(a.submatrix(c, 0, nx, c) * &cc_inverse)
}

/// `S = A_ff - C A_cf` of the mobility `a` with the coupling `C` ([`clamp_coupling`]).
fn schur_complement(a: &Mat<f64>, coupling: &Mat<f64>) -> Mat<f64> {
    let c = 3 * Layout::CLAMPED_NODES;
    let nx = a.nrows() - c;
    a.submatrix(c, c, nx, nx) - coupling * a.submatrix(0, c, c, nx)
}

/// `out = -s h` for a dense `s` and a banded `h`: in blocks of columns, each multiplied by the
/// rows of `s` that the block's nonzero rows select (a contiguous band), so that the cost is
/// `O(n^2 w)` for a band of width `w` instead of `O(n^3)`.
pub(super) fn banded_product(s: MatRef<'_, f64>, h: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
    const BLOCK: usize = 48;
    let rows_out = out.nrows();
    for start in (0..h.ncols()).step_by(BLOCK) {
        let width = BLOCK.min(h.ncols() - start);
        let block = h.submatrix(0, start, h.nrows(), width);
        let rows = (0..h.nrows()).filter(|&r| (0..width).any(|c| block[(r, c)] != 0.0));
        let (first, last) = rows.fold((usize::MAX, 0), |(a, b), r| (a.min(r), b.max(r)));
        let mut target = out.rb_mut().submatrix_mut(0, start, rows_out, width);
        if first > last {
            target.fill(0.0);
            continue;
        }
        let band = last + 1 - first;
        matmul(
            target,
            Accum::Replace,
            s.submatrix(0, first, s.nrows(), band),
            block.submatrix(first, 0, band, width),
            -1.0,
            Par::Seq,
        );
    }
}

//! The co-rotating steady problem (docs/model.md section 4): residual, analytic Jacobian, and the
//! observables of a steady state (section 6).
//!
//! In the frame turning with the motor, a rigidly rotating state is an equilibrium of
//!
//! ```text
//! R_x(u) = -dE/dx + F_gravity - [ Z(X) Omega X ]_free = 0,      (1)
//! R_t(u) = -dE/dtheta = 0,                                       (2)
//! ```
//!
//! with `(Omega X)_i = omega e_z x x_i` the lab velocity of node `i`, `Z = A^{-1}` the
//! resistance matrix of all nodes and `u = (x_2..x_{N-1}, theta^1..theta^{N-2})` the free
//! unknowns. Since `Z A = I`, `dZ = -Z dA Z`, so the viscous Jacobian is
//!
//! ```text
//! d[Z Omega X]/dX = Z (Omega - B),    B = d(A(X) y)/dX at fixed y = Z Omega X.   (3)
//! ```
//!
//! The continuation solves the velocity form (eq. 4-5 below): the position rows premultiplied by
//! `S = Z_ff^{-1}`, whose Newton matrix needs no solve with `Z`.

use faer::linalg::matmul::matmul;
use faer::prelude::Solve;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use nalgebra::Vector3;

use crate::Result;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::fluid::{Resistance, stack_vectors};
use crate::model::rod::Config;
use crate::model::rod::frame::Chart;
use crate::numerics::parallel::{self, join_if};

/// The share of the columns of `Z_ff W` that the stability pair computes on the thread that also
/// makes the inverse `Z_ff` (the rest on the other thread): with the whole of `Z_ff W` 78 ms and
/// the inverse 33 ms at RPY `N = 400`, both threads end together at `(78 - 33) / (2 78)`.
const VISCOUS_BESIDE_INVERSE: f64 = 0.29;

/// The steady problem at one rotation rate and weight, with the chart in which twist is measured.
#[derive(Clone, Debug)]
pub struct Steady<'a> {
    pub model: &'a Model,
    /// Dimensionless rotation rate `omegabar`.
    pub omega: f64,
    /// Dimensionless weight per length `q ell^3 / EI`.
    pub weight: f64,
    /// Source chart of the reference frames.
    pub chart: Chart,
}

/// Lab-frame velocities `omega e_z x x_i` of rigid rotation.
pub fn rotation_velocity(omega: f64, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    x.iter()
        .map(|p| Vector3::new(-omega * p.y, omega * p.x, 0.0))
        .collect()
}

/// The forces `F = Z(X) Omega X` the rod exerts on the fluid in rigid rotation, with the
/// factorization of `A(X)` for further solves. `None` when `omega = 0` (no flow).
pub struct Drag {
    pub resistance: Resistance,
    pub forces: Vec<Vector3<f64>>,
}

impl<'a> Steady<'a> {
    /// The problem at `omega` with the model's own weight and its natural chart.
    pub fn new(model: &'a Model, omega: f64) -> Self {
        Steady {
            model,
            omega,
            weight: model.weight,
            chart: model.chart.clone(),
        }
    }

    fn layout(&self) -> Layout {
        self.model.rod.layout
    }

    /// The free unknowns of a configuration.
    pub fn free_vector(&self, config: &Config) -> Vec<f64> {
        config.x[Layout::CLAMPED_NODES..]
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .chain(config.theta[1..].iter().copied())
            .collect()
    }

    /// The configuration with free unknowns `u`; the clamp (`x_0`, `x_1`, `theta^0`) stays at the
    /// natural values.
    pub fn config(&self, u: &[f64]) -> Config {
        let layout = self.layout();
        let n = layout.nodes();
        let fp = layout.free_positions();
        let mut x = self.model.natural[..Layout::CLAMPED_NODES].to_vec();
        x.extend(
            u[..fp]
                .chunks_exact(3)
                .map(|c| Vector3::new(c[0], c[1], c[2])),
        );
        let mut theta = vec![0.0];
        theta.extend_from_slice(&u[fp..fp + n - 2]);
        Config { x, theta }
    }

    /// `F = Z(X) Omega X` at positions `x`; `None` when `omega = 0`.
    pub fn drag(&self, x: &[Vector3<f64>]) -> Result<Option<Drag>> {
        if self.omega == 0.0 {
            return Ok(None);
        }
        let context = format!("omegabar = {:.6e}, N = {}", self.omega, x.len());
        let resistance = self.model.fluid.resistance(x, &context)?;
        let forces = resistance.solve_vectors(&rotation_velocity(self.omega, x));
        Ok(Some(Drag { resistance, forces }))
    }

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
    /// (Omega X)_c` (from `A Z Omega X = Omega X` in blocks). Cost: one assembly of `A` and
    /// `O(N^2)`, against a factorization, a solve with `3N` right-hand sides and a second
    /// factorization for `Z_ff^{-1} R_x` from `Z`. Where `A` is not positive by construction
    /// (Lighthill), it is checked by a Cholesky factorization, as the resistance would be.
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
        let mobility = self.clamped_mobility(&config.x, "velocity")?;
        let velocity = mobility.velocity(&force, &rotation_velocity(self.omega, &config.x));
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
                let (_, coupling) = clamp_coupling(&a, &context)?;
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
    pub fn typical_mobility(&self, x: &[Vector3<f64>]) -> Result<f64> {
        let s = self.clamped_mobility(x, "mobility scale")?.schur();
        Ok(s.norm_l2() / (s.nrows() as f64).sqrt())
    }

    /// The mobility at `x` split at the clamp; where it is not positive definite by
    /// construction (Lighthill) it is checked by a factorization. Errors name `what`.
    fn clamped_mobility(&self, x: &[Vector3<f64>], what: &str) -> Result<ClampedMobility> {
        let context = format!("{what} at omegabar = {:.6e}, N = {}", self.omega, x.len());
        let a = self.model.fluid.mobility(x);
        self.check_definite(&a, x, &context)?;
        ClampedMobility::split(a, &context)
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

    /// Full-length force balance `-dE/dq + F_gravity - F_fluid` (positions) and `-dE/dtheta`.
    fn full_residual(&self, gradient: &[f64], drag: Option<&Drag>) -> Vec<f64> {
        let layout = self.layout();
        let gravity = self.model.gravity(self.weight);
        let mut r: Vec<f64> = gradient.iter().map(|g| -g).collect();
        for (i, f) in gravity.iter().enumerate() {
            for k in 0..3 {
                r[layout.x(i, k)] += f[k];
                if let Some(d) = drag {
                    r[layout.x(i, k)] -= d.forces[i][k];
                }
            }
        }
        r
    }

    /// Viscous Jacobian block `Z (Omega - B)` restricted to the free positions (eq. 3).
    fn viscous_jacobian(&self, x: &[Vector3<f64>], drag: &Drag) -> Mat<f64> {
        let layout = self.layout();
        let n3 = 3 * layout.nodes();
        let first = layout.x(Layout::CLAMPED_NODES, 0);
        let b = self.model.fluid.mobility_derivative(x, &drag.forces);
        // (Omega - B) restricted to the free position columns.
        let mut rhs = Mat::from_fn(n3, n3 - first, |p, c| -b[(p, first + c)]);
        for i in Layout::CLAMPED_NODES..layout.nodes() {
            let c = layout.x(i, 0) - first;
            rhs[(layout.x(i, 1), c)] += self.omega;
            rhs[(layout.x(i, 0), c + 1)] -= self.omega;
        }
        let zm = drag.resistance.solve(rhs.as_ref());
        Mat::from_fn(n3 - first, n3 - first, |r, c| zm[(first + r, c)])
    }

    /// The configuration a fraction `w` of the way from `u0` to `u1` with the edges interpolated
    /// in length and direction apart: `|e| = |e0| + w (|e1| - |e0|)` along the normalized
    /// `e0 + w (e1 - e0)`, nodes summed from the clamp, angles interpolated linearly. Equal to
    /// the plain interpolation to first order, but an edge that turns between the two states
    /// keeps its length instead of shortening by the chord's `w (1 - w) phi^2 / 2`, which the
    /// stretching stiffness (`EA/EI ~ 1e4..1e6`) would turn into a large residual.
    pub fn interpolate(&self, u0: &[f64], u1: &[f64], w: f64) -> Vec<f64> {
        let layout = self.layout();
        let fp = layout.free_positions();
        let (x0, x1) = (self.config(u0).x, self.config(u1).x);
        let mut x = x0[..Layout::CLAMPED_NODES].to_vec();
        for i in Layout::CLAMPED_NODES - 1..layout.edges() {
            let (e0, e1) = (x0[i + 1] - x0[i], x1[i + 1] - x1[i]);
            let length = e0.norm() + w * (e1.norm() - e0.norm());
            let next = x[i] + (e0 + (e1 - e0) * w).normalize() * length;
            x.push(next);
        }
        x[Layout::CLAMPED_NODES..]
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .chain(u0[fp..].iter().zip(&u1[fp..]).map(|(a, b)| a + w * (b - a)))
            .collect()
    }

    fn restrict(&self, full: &[f64]) -> Vec<f64> {
        self.layout()
            .free_indices()
            .iter()
            .map(|&p| full[p])
            .collect()
    }
}

impl Steady<'_> {
    /// The force balance (1)-(2) at the free unknowns `u`.
    pub fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        let config = self.config(u);
        let gradient = self.model.rod.gradient(&config, &self.chart);
        let drag = self.drag(&config.x)?;
        Ok(self.restrict(&self.full_residual(&gradient, drag.as_ref())))
    }

    /// Newton update that rotates edges instead of moving nodes along straight lines.
    ///
    /// The increment of edge `e^i` (`i >= 1`; edge 0 is clamped), `de = dx_{i+1} - dx_i`, is split
    /// into a change of length `dl = t.de` and a transverse part `de_perp`; the new edge is
    /// `(|e| + dl) (cos(phi) t + sin(phi) n)` with `phi = |de_perp|/|e|`, `n = de_perp/|de_perp|`,
    /// and the nodes follow by summing edges from the clamp. This agrees with `x + dx` to first
    /// order, so Newton's method stays quadratic, but a rotation no longer stretches the edge at
    /// second order: with the stretching stiffness `EA` some `1e4..1e6` times the bending one,
    /// that spurious stretch would otherwise throw the iterate far off (the basin of plain Newton
    /// shrinks to displacements of order `ds^2 EI/EA`). Angles are updated additively.
    pub fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        let layout = self.layout();
        let fp = layout.free_positions();
        let old = self.config(u);
        let step = self.config(du);
        let mut x = old.x[..Layout::CLAMPED_NODES].to_vec();
        for i in Layout::CLAMPED_NODES - 1..layout.edges() {
            let e = old.x[i + 1] - old.x[i];
            let dx_i = if i < Layout::CLAMPED_NODES {
                Vector3::zeros()
            } else {
                step.x[i]
            };
            let de = step.x[i + 1] - dx_i;
            let len = e.norm();
            let t = e / len;
            let dl = t.dot(&de);
            let perp = de - t * dl;
            // Rotation vector w with w x t = perp/|e|, plus the spin about t that makes it
            // perpendicular to the horizontal part t_h of t (regularized for vertical edges).
            let w0 = t.cross(&perp) / len;
            let th = Vector3::new(t.x, t.y, 0.0);
            let w = w0 - t * (w0.dot(&th) / (th.norm_squared() + 1e-2));
            let phi = w.norm();
            let direction = if phi > 0.0 {
                let k = w / phi;
                t * phi.cos() + k.cross(&t) * phi.sin() + k * (k.dot(&t) * (1.0 - phi.cos()))
            } else {
                t
            };
            let next = x[i] + direction * (len + dl);
            x.push(next);
        }
        x[Layout::CLAMPED_NODES..]
            .iter()
            .flat_map(|p| [p.x, p.y, p.z])
            .chain(u[fp..].iter().zip(&du[fp..]).map(|(a, b)| a + b))
            .collect()
    }
}

/// The steady residual and its Jacobian at one point, with the drag computed on the way.
pub struct Linearized {
    pub config: Config,
    pub residual: Vec<f64>,
    pub jacobian: Mat<f64>,
    pub drag: Option<Drag>,
}

impl Steady<'_> {
    /// Residual and analytic Jacobian (elastic Hessian + viscous part `Z (Omega - B)`, eq. 3).
    pub fn linearize(&self, u: &[f64]) -> Result<Linearized> {
        let config = self.config(u);
        let (gradient, hessian) = self.model.rod.hessian(&config, &self.chart);
        let drag = self.drag(&config.x)?;
        let residual = self.restrict(&self.full_residual(&gradient, drag.as_ref()));
        let free = self.layout().free_indices();
        let mut jacobian =
            Mat::from_fn(free.len(), free.len(), |r, c| -hessian[(free[r], free[c])]);
        if let Some(d) = &drag {
            let v = self.viscous_jacobian(&config.x, d);
            let fp = self.layout().free_positions();
            for c in 0..fp {
                for r in 0..fp {
                    jacobian[(r, c)] -= v[(r, c)];
                }
            }
        }
        Ok(Linearized {
            config,
            residual,
            jacobian,
            drag,
        })
    }

    /// `dG/d omegabar = -[Z Omega_1 X]_free` (`Omega_1` the rotation at unit rate), zero on the
    /// angles; reuses the drag of the linearization when the rate is not zero.
    pub fn rate_derivative(&self, lin: &Linearized) -> Result<Vec<f64>> {
        let unit_forces = match &lin.drag {
            Some(d) => d.forces.iter().map(|f| f / self.omega).collect(),
            None => {
                let x = &lin.config.x;
                let context = format!("omegabar = 0, N = {}", x.len());
                self.model
                    .fluid
                    .resistance(x, &context)?
                    .solve_vectors(&rotation_velocity(1.0, x))
            }
        };
        Ok(self.free_forces(&unit_forces, -1.0))
    }

    /// `dG/dq = -wbar_i e_z` on the free nodes (the weight per unit length), zero on the angles.
    pub fn weight_derivative(&self) -> Vec<f64> {
        let unit = self.model.gravity(1.0);
        self.free_forces(&unit, 1.0)
    }

    /// `dV/d omegabar = C (Omega_1 X)_c - (Omega_1 X)_f` (eq. 4 at unit rate; the clamp
    /// reactions carry the clamp's motion), zero on the angles.
    pub fn velocity_rate_derivative(&self, lin: &VelocityLinearized, u: &[f64]) -> Vec<f64> {
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
    pub fn velocity_weight_derivative(&self, lin: &VelocityLinearized) -> Vec<f64> {
        let w = self.weight_derivative();
        let nx = self.layout().free_positions();
        let sw = &lin.blocks.schur * Mat::from_fn(nx, 1, |r, _| w[r]);
        (0..nx)
            .map(|r| sw[(r, 0)])
            .chain(w[nx..].iter().copied())
            .collect()
    }

    /// `sign * f_i` on the free position unknowns, zero on the angles.
    fn free_forces(&self, forces: &[Vector3<f64>], sign: f64) -> Vec<f64> {
        let layout = self.layout();
        forces[Layout::CLAMPED_NODES..]
            .iter()
            .flat_map(|f| [sign * f.x, sign * f.y, sign * f.z])
            .chain(std::iter::repeat_n(0.0, layout.nodes() - 2))
            .collect()
    }

    /// The Hessian `H` of the elastic energy over the free unknowns at `u` (the Jacobian of the
    /// force balance at rest is `-H`).
    pub fn free_hessian(&self, u: &[f64]) -> Mat<f64> {
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
    pub fn stability_pair_from(
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

/// The mobility `A(X)` split at the clamp (eq. 4): the clamp block inverted and the coupling
/// `C = A_fc A_cc^{-1}` of the free nodes to it.
struct ClampedMobility {
    a: Mat<f64>,
    /// `A_cc^{-1}` (`6 x 6`).
    cc_inverse: Mat<f64>,
    coupling: Mat<f64>,
}

impl ClampedMobility {
    /// Splits `a`; a singular clamp block is an error naming `context`.
    fn split(a: Mat<f64>, context: &str) -> Result<Self> {
        let (cc_inverse, coupling) = clamp_coupling(&a, context)?;
        Ok(ClampedMobility {
            a,
            cc_inverse,
            coupling,
        })
    }

    /// The velocity of the free nodes less `rigid` (eq. 4), with the clamp reactions that carry
    /// the clamp with `rigid`, for `force` in the full layout of the unknowns (only its free
    /// positions are read) and the rigid velocities.
    fn velocity(&self, force: &[f64], rigid: &[Vector3<f64>]) -> Vec<f64> {
        let n3 = self.a.nrows();
        let c = 3 * Layout::CLAMPED_NODES;
        let rigid = stack_vectors(rigid);
        let mut f = Mat::from_fn(n3, 1, |r, _| if r < c { 0.0 } else { force[r] });
        let rhs = rigid.submatrix(0, 0, c, 1) - self.a.submatrix(0, 0, c, n3) * &f;
        let reactions = &self.cc_inverse * rhs;
        f.submatrix_mut(0, 0, c, 1).copy_from(&reactions);
        let v = self.a.submatrix(c, 0, n3 - c, n3) * &f - rigid.submatrix(c, 0, n3 - c, 1);
        (0..n3 - c).map(|r| v[(r, 0)]).collect()
    }

    /// `S = A_ff - C A_cf`, the Schur complement of the clamp block: `Z_ff^{-1}`.
    fn schur(&self) -> Mat<f64> {
        schur_complement(&self.a, &self.coupling)
    }
}

/// `A_cc^{-1}` and `C = A_fc A_cc^{-1}` of the mobility `a` split at the clamp; a singular clamp
/// block is an error naming `context`.
fn clamp_coupling(a: &Mat<f64>, context: &str) -> Result<(Mat<f64>, Mat<f64>)> {
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
    let coupling = a.submatrix(c, 0, nx, c) * &cc_inverse;
    Ok((cc_inverse, coupling))
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
fn banded_product(s: MatRef<'_, f64>, h: MatRef<'_, f64>, mut out: MatMut<'_, f64>) {
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

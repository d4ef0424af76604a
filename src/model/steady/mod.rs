//! The co-rotating steady problem (docs/model.md section 4): its residual and analytic Jacobian
//! (here), the velocity form the continuation solves ([`velocity`]), and the stability pair of
//! its linearized dynamics ([`pair`]): one problem, in three files for size.
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

mod pair;
mod velocity;

pub use velocity::{MobilityBlocks, VelocityLinearized};

use faer::Mat;
use nalgebra::Vector3;

use crate::Result;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::fluid::Resistance;
use crate::model::rod::Config;
use crate::model::rod::frame::Chart;

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
pub(crate) fn rotation_velocity(omega: f64, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
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
    pub(crate) fn interpolate(&self, u0: &[f64], u1: &[f64], w: f64) -> Vec<f64> {
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
    pub(crate) fn rate_derivative(&self, lin: &Linearized) -> Result<Vec<f64>> {
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
    pub(crate) fn weight_derivative(&self) -> Vec<f64> {
        let unit = self.model.gravity(1.0);
        self.free_forces(&unit, 1.0)
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
}

//! One implicit step of the overdamped rod's dynamics (docs/model.md section 5): the force
//! balance with the velocity of a linear multistep formula,
//!
//! ```text
//! G(u) = ( R_x(u) - Z_ff(x) v(x),  R_theta(u) ),      v(x) = c0 x_f + offset,
//! ```
//!
//! its exact Jacobian (with `d[Z_ff v]/dx = [Z (c0 E - B(X; Z V_full))]_ff`, `dZ = -Z dA Z`),
//! and the mass matrix `M = Z_ff` of the stability pencil.

use faer::Mat;
use nalgebra::Vector3;

use crate::Result;
use crate::engine::newton::System;
use crate::engine::periodic::StepLinearization;
use crate::model::dofs::Layout;
use crate::model::fluid::Resistance;
use crate::model::steady::{Steady, rotation_velocity};

/// One implicit step (2): `G(u) = (R_x(u) - Z_ff(x) v(x), R_theta(u))` with the velocity
/// `v(x) = c0 x_f + offset`, at the rate of `steady`.
pub struct ImplicitStep<'a> {
    pub steady: Steady<'a>,
    pub c0: f64,
    /// Length `3 (N - 2)`.
    pub offset: Vec<f64>,
}

/// `Z_ff(x) v(x)` with the factorization and the full forces `y = Z V_full` for (3).
struct Motion {
    resistance: Resistance,
    forces: Vec<Vector3<f64>>,
}

impl<'a> ImplicitStep<'a> {
    /// `Z V_full` at positions `x` (reusing `resistance` when given).
    fn motion(
        &self,
        u: &[f64],
        x: &[Vector3<f64>],
        resistance: Option<Resistance>,
    ) -> Result<Motion> {
        let resistance = match resistance {
            Some(r) => r,
            None => self
                .steady
                .model
                .fluid
                .resistance(x, &format!("time step, N = {}", x.len()))?,
        };
        let forces = resistance.solve_vectors(&self.velocity(u));
        Ok(Motion { resistance, forces })
    }

    /// `V_full`: `v(x) = c0 x_f + offset` on the free nodes, zero on the clamp.
    fn velocity(&self, u: &[f64]) -> Vec<Vector3<f64>> {
        let mut velocity = vec![Vector3::zeros(); Layout::CLAMPED_NODES];
        velocity.extend(
            u.chunks_exact(3)
                .zip(self.offset.chunks_exact(3))
                .map(|(p, o)| {
                    Vector3::new(
                        self.c0 * p[0] + o[0],
                        self.c0 * p[1] + o[1],
                        self.c0 * p[2] + o[2],
                    )
                }),
        );
        velocity
    }

    fn free(forces: &[Vector3<f64>]) -> Vec<f64> {
        forces[Layout::CLAMPED_NODES..]
            .iter()
            .flat_map(|f| [f.x, f.y, f.z])
            .collect()
    }

    /// The drag of the motion relative to the rotating frame, `Z_ff(x) v(x)` (length
    /// `3 (N - 2)`).
    pub fn motion_force(&self, u: &[f64]) -> Result<Vec<f64>> {
        let x = self.steady.config(u).x;
        Ok(Self::free(&self.motion(u, &x, None)?.forces))
    }

    /// `d[Z_ff(x) v(x)]/dx_f`, eq. (3), `3 (N - 2)` square.
    pub fn motion_jacobian(&self, u: &[f64]) -> Result<Mat<f64>> {
        let x = self.steady.config(u).x;
        let m = self.motion(u, &x, None)?;
        Ok(self.motion_jacobian_with(&x, &m))
    }

    fn motion_jacobian_with(&self, x: &[Vector3<f64>], m: &Motion) -> Mat<f64> {
        let n3 = 3 * x.len();
        let first = 3 * Layout::CLAMPED_NODES;
        let nx = n3 - first;
        let b = self.steady.model.fluid.mobility_derivative(x, &m.forces);
        let rhs = Mat::from_fn(n3, nx, |p, c| {
            let e = if p == first + c { self.c0 } else { 0.0 };
            e - b[(p, first + c)]
        });
        let z = m.resistance.solve(rhs.as_ref());
        Mat::from_fn(nx, nx, |r, c| z[(first + r, c)])
    }
}

impl ImplicitStep<'_> {
    /// The residual and Jacobian of (2) with what the sensitivities of a periodic orbit need
    /// besides ([`crate::engine::periodic`]): the mass matrix `M = Z_ff` at `u` and the
    /// derivative of (2) in `omegabar` at fixed `u` and `v`, `-[Z Omega_1 X]_free`.
    pub(crate) fn linearize_with_mass(&self, u: &[f64]) -> Result<StepLinearization> {
        let step = self.linearized(u, true)?;
        let mass = free_block_of_resistance(&step.motion.resistance, step.motion.forces.len());
        Ok(StepLinearization {
            g: step.g,
            g_u: step.j,
            mass,
            g_p: step.rate.unwrap_or_default(),
        })
    }

    /// The residual and Jacobian of (2) at `u`, the motion, and with `rate` the derivative in
    /// `omegabar`.
    fn linearized(&self, u: &[f64], rate: bool) -> Result<StepJacobian> {
        let lin = self.steady.linearize(u)?;
        let rate = if rate {
            Some(self.steady.rate_derivative(&lin)?)
        } else {
            None
        };
        let x = lin.config.x;
        let motion = self.motion(u, &x, lin.drag.map(|d| d.resistance))?;
        let drag = Self::free(&motion.forces);
        let mj = self.motion_jacobian_with(&x, &motion);
        let mut g = lin.residual;
        for (gi, d) in g.iter_mut().zip(&drag) {
            *gi -= d;
        }
        let mut j = lin.jacobian;
        for c in 0..drag.len() {
            for r in 0..drag.len() {
                j[(r, c)] -= mj[(r, c)];
            }
        }
        Ok(StepJacobian { g, j, motion, rate })
    }
}

/// The linearization of one step (2): residual, Jacobian, the motion it was made with, and the
/// rate derivative when asked for.
struct StepJacobian {
    g: Vec<f64>,
    j: Mat<f64>,
    motion: Motion,
    rate: Option<Vec<f64>>,
}

impl System for ImplicitStep<'_> {
    /// `R_x(u; 0) - [Z (Omega X + V_full)]_free` and `R_theta`: one factorization of `A`.
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        let still = Steady {
            omega: 0.0,
            ..self.steady.clone()
        };
        let mut g = still.residual(u)?;
        let x = self.steady.config(u).x;
        let resistance = self
            .steady
            .model
            .fluid
            .resistance(&x, &format!("time step, N = {}", x.len()))?;
        let rotation = rotation_velocity(self.steady.omega, &x);
        let velocity: Vec<Vector3<f64>> = rotation
            .iter()
            .zip(self.velocity(u))
            .map(|(a, b)| a + b)
            .collect();
        let drag = Self::free(&resistance.solve_vectors(&velocity));
        for (gi, d) in g.iter_mut().zip(&drag) {
            *gi -= d;
        }
        Ok(g)
    }

    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let step = self.linearized(u, false)?;
        Ok((step.g, step.j))
    }

    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.steady.retract(u, du)
    }
}

/// `M = Z_ff` at the positions of `u`.
pub(crate) fn mass(steady: &Steady, u: &[f64]) -> Result<Mat<f64>> {
    let x = steady.config(u).x;
    let resistance = steady
        .model
        .fluid
        .resistance(&x, &format!("mass matrix, N = {}", x.len()))?;
    Ok(free_block_of_resistance(&resistance, x.len()))
}

/// The free-free block `Z_ff` of `Z = A^{-1}` for `nodes` nodes.
fn free_block_of_resistance(resistance: &Resistance, nodes: usize) -> Mat<f64> {
    let n3 = 3 * nodes;
    let first = 3 * Layout::CLAMPED_NODES;
    let e = Mat::from_fn(
        n3,
        n3 - first,
        |r, c| if r == first + c { 1.0 } else { 0.0 },
    );
    let z = resistance.solve(e.as_ref());
    Mat::from_fn(n3 - first, n3 - first, |r, c| z[(first + r, c)])
}

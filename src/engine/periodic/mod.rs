//! Periodic orbits of an implicit dynamical system by shooting, their Floquet multipliers, and
//! the branch of orbits born at a Hopf point. Generic: this module never names a rod.
//!
//! # The dynamics and its period map
//!
//! The system is a semi-explicit DAE of index 1 in the unknowns `u = (x, z)` (`x` the first
//! [`ImplicitDynamics::differential`] unknowns, `z` the algebraic rest):
//!
//! ```text
//! M(u) dx/dt = F(u; p),      0 = F_z(u; p),                                          (1)
//! ```
//!
//! with `M` invertible. The period map `Phi(x0, T, p)` is `x` after time `T` from the state
//! whose differential part is `x0` (its algebraic part solved, [`ImplicitDynamics::consistent`]),
//! computed with `n` equal steps `h = T/n`: one step of the trapezoidal rule, then BDF2. Step `k`
//! solves
//!
//! ```text
//! G(u_k) = ( F(u_k; p) - M(u_k) v_k,  F_z(u_k; p) ) = 0,   v_k = c0 x_k + b_k,             (2)
//! ```
//!
//! with `c0 = 2/h`, `b_1 = -2 x_0/h - f_0` for the first step (`f_0 = M^{-1} F` at the start)
//! and `c0 = 3/(2h)`, `b_k = (-2 x_{k-1} + x_{k-2}/2)/h` after it. The trapezoidal start does not
//! damp an oscillation (backward Euler would, at second order in `w h`), and BDF2 damps it at
//! third order only, so the discrete Hopf point lies `O(w (w h)^3)` from the exact one. The
//! steps are equal, so `Phi` is a smooth function of `(x0, T, p)` (an adaptive step control would
//! make it only piecewise smooth, and Newton's method on it would stall); the price is a period
//! error of about `(2 pi / n)^2 / 3`, which the user controls by the steps per period. Each step
//! is solved by [`super::newton::Newton`] with a kept factorization as its chord (with the
//! sensitivities, that of the exact Jacobian at the step before; `c0` is the same for every
//! BDF2 step).
//!
//! **Sensitivities.** Differentiating (2) at the converged `u_k` (`G_u` its Jacobian) gives the
//! recursion for `S_k = d x_k / d(x0, T, p)`:
//!
//! ```text
//! G_u dU_k = M(u_k) (-2 S_{k-1} + S_{k-2}/2) / h  -  [0, M v_k / T, 0]  -  [0, 0, G_p]        (3)
//! G_u dU_1 = M(u_1) (-2 S_0 - h df_0) / h  -  [0, M (v_1 + f_0) / T, 0]  -  [0, 0, G_p]
//! ```
//!
//! (BDF2, then the trapezoidal first step), `S_k` the differential rows of `dU_k`,
//! `S_0 = [I, 0, 0]` (the `T` column because the terms of `v_k` in `1/h` scale with `1/T`,
//! `h = T/n`; `G_p` the derivative of (2) in the parameter at fixed `u_k`; `df_0` from
//! differentiating `F - M f_0 = 0`, `F_z = 0` at the start with its algebraic part slaved). So
//! the monodromy matrix `Phi_x = S_n[:, x0]` costs one exact linearization, one LU and one solve
//! with `n_x + 2` right-hand sides per step, for exactly the map that the shooting solves.
//!
//! # Orbits
//!
//! An orbit is a zero of
//!
//! ```text
//! Phi(x0, T, p) - x0 = 0,    xdot_ref . (x0 - x_ref) = 0,    c . (x0, T, p) = c_0,        (4)
//! ```
//!
//! the second (phase) condition pins the point of the orbit that `x0` is, with `x_ref` the
//! starting guess and `xdot_ref` the velocity at the end of its first period map (transversal
//! to the orbit), and the third one is any linear condition:
//! the parameter fixed, the amplitude along the critical mode fixed (the start at a Hopf point,
//! where `p` is a poor parameter), or the pseudo-arclength condition of the continuation.
//! Newton's method on (4) uses the exact Jacobian `[[Phi_x - I, Phi_T, Phi_p], [xdot_ref, 0, 0],
//! [c]]` from (3) ([`orbit`]).
//!
//! **Floquet multipliers** are the eigenvalues of the monodromy matrix `Phi_x` at the orbit.
//! One of them is 1 (the direction along the orbit: the discrete map has it only approximately,
//! and its computed distance from 1 is reported as an indication of the map's accuracy, seen
//! between 1e-11 and 3e-5); the orbit is stable when all the others lie inside the unit circle.

pub mod branch;
pub mod flow;
pub mod orbit;

use faer::Mat;

use super::Problem;
use crate::Result;

/// The velocity of one implicit step, `v = c0 x + offset`, eq. (2).
#[derive(Clone, Copy, Debug)]
pub struct StepVelocity<'a> {
    pub c0: f64,
    pub offset: &'a [f64],
}

impl StepVelocity<'_> {
    /// `v` at the differential unknowns `x`.
    pub fn at(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.offset)
            .map(|(x, o)| self.c0 * x + o)
            .collect()
    }
}

/// The linearization of one step (2) at `u`.
pub struct StepLinearization {
    /// `G(u)` and `G_u(u)` (all unknowns).
    pub g: Vec<f64>,
    pub g_u: Mat<f64>,
    /// `M(u)`, on the differential unknowns.
    pub mass: Mat<f64>,
    /// `dG/dp` at fixed `u` and `v`.
    pub g_p: Vec<f64>,
}

/// A system (1) that can be stepped implicitly.
pub trait ImplicitDynamics {
    /// Number of unknowns of a state (differential first, then algebraic).
    fn dim(&self) -> usize;
    /// Number of differential unknowns `n_x`.
    fn differential(&self) -> usize;
    /// `G(u)` of eq. (2) at the parameter `p`.
    fn step_residual(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<Vec<f64>>;
    /// `G`, `G_u`, `M` and `G_p` of eq. (2) at `u`.
    fn step_linearize(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<StepLinearization>;
    /// The state with differential part that of `u` and the algebraic part solved
    /// (`F_z = 0`), started from the algebraic part of `u`.
    fn consistent(&self, p: f64, u: &[f64]) -> Result<Vec<f64>>;
    /// The point reached from `u` along `du` (see [`super::newton::System::retract`]).
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        u.iter().zip(du).map(|(a, b)| a + b).collect()
    }
    /// Coordinates for the next step centred on the accepted state `u`, in which `u` keeps its
    /// values: for algebraic unknowns measured from a chart that has to follow the motion (the
    /// rod's twist angles, whose chart is singular where an edge turns opposite its tangent),
    /// carried from step to step through a period; `None` (the default) where the coordinates
    /// are global. The differential part of a step's solution does not depend on the chart its
    /// algebraic part is measured in, so neither do the period map and its sensitivities.
    fn centred_on(&self, _u: &[f64]) -> Option<Self>
    where
        Self: Sized,
    {
        None
    }
    /// The size of a differential displacement `dx` (the amplitude of an orbit is measured in
    /// it): the Euclidean norm by default. A Lyapunov coefficient predicts the mean square
    /// amplitude `2 r^2 (size(Re q)^2 + size(Im q)^2)` in it, `r` the normal-form radius.
    fn size(&self, dx: &[f64]) -> f64 {
        super::newton::norm(dx)
    }
}

/// The dynamics `du/dt = G(u, p)` of a [`Problem`] whose stability pair is `(G_u, I)` (the
/// reference problems): `M = I`, no algebraic unknowns.
pub struct VectorField<'a, P: Problem>(pub &'a P);

impl<P: Problem> ImplicitDynamics for VectorField<'_, P> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn differential(&self) -> usize {
        self.0.dim()
    }
    fn step_residual(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<Vec<f64>> {
        let g = self.0.residual(u, p)?;
        Ok(g.iter().zip(v.at(u)).map(|(g, v)| g - v).collect())
    }
    fn step_linearize(&self, p: f64, v: StepVelocity, u: &[f64]) -> Result<StepLinearization> {
        let lin = self.0.linearize(u, p)?;
        let n = self.0.dim();
        Ok(StepLinearization {
            g: lin.g.iter().zip(v.at(u)).map(|(g, v)| g - v).collect(),
            g_u: Mat::from_fn(n, n, |r, c| {
                lin.g_u[(r, c)] - if r == c { v.c0 } else { 0.0 }
            }),
            mass: Mat::identity(n, n),
            g_p: lin.g_p,
        })
    }
    fn consistent(&self, _p: f64, u: &[f64]) -> Result<Vec<f64>> {
        Ok(u.to_vec())
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.0.retract(u, du)
    }
}

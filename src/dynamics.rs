//! Time integration of the overdamped rod in the co-rotating frame (docs/model.md section 5), the
//! linear modes of a steady state, and a dynamic estimate of `omega_b` by bisection.
//!
//! # Equations
//!
//! In the frame turning with the motor the free nodes obey quasi-static force balance with the
//! twist slaved to the positions:
//!
//! ```text
//! Z_ff(X) dx_f/dt = R_x(x_f, theta; omega(t)),      R_theta(x_f, theta) = 0,        (1)
//! ```
//!
//! with `R_x`, `R_theta` the steady residual of [`Steady`] (so a steady state is a fixed point of
//! (1) and nothing else) and `Z_ff` the free-free block of `Z = A(X)^{-1}`: the force on the
//! fluid for the lab velocity `Omega X + V` (`V = 0` on the clamp nodes, `V = dx_f/dt` on the
//! free ones) is `Z (Omega X + V)`, whose free part is `[Z Omega X]_free + Z_ff dx_f/dt`. The
//! unknowns are the free unknowns `u = (x_2..x_{N-1}, theta^1..theta^{N-2})` of [`Steady`], with
//! the twist measured in the model's natural chart (as in [`crate::branch::RodProblem`]); the
//! clamp nodes are not unknowns and stay exactly at their natural positions. Time is in the
//! solver's unit `mu ell^4 / EI`, rates are `omegabar`.
//!
//! # Scheme: variable-step BDF2 with a Milne error estimate
//!
//! (1) is a stiff index-1 DAE: the spectrum of `Z_ff^{-1} K` spans from the slow shape modes
//! (`|s| ~ 1..300`) to stretching modes near `-7e6` at `N = 30`, and the twist is algebraic.
//! The method must be implicit, stiffly accurate and A-stable without damping the slow,
//! weakly (un)stable oscillation that decides `omega_b`. BDF2 is chosen over backward Euler
//! (with step doubling or an embedded estimate) because it is second order for the same cost
//! per step (one nonlinear solve of the same structure), L-stable (the stretching modes are
//! annihilated, not carried along as the trapezoidal rule would), and it applies to the DAE
//! directly: the twist rows stay `R_theta = 0` at every step. Above all, backward Euler damps an
//! oscillation `e^{i w t}` at the spurious rate `w (w h)/2`, BDF2 at `w (w h)^3/4`: at 80 steps
//! per period (`w h ~ 0.07`) that is `1e-4 w` against `4e-2 w`, and it shifts the computed
//! stability boundary of a Hopf point (whose critical mode oscillates at `Im s ~ omega`)
//! accordingly. (Error estimation by step doubling would cost three solves per step.)
//!
//! Step from `t_n` to `t_{n+1} = t_n + h` (previous step `h_1 = t_n - t_{n-1}`, `rho = h/h_1`):
//!
//! ```text
//! Z_ff(x) v(x) = R_x(x, theta; omega(t_{n+1})),   R_theta(x, theta) = 0,
//! v(x) = [ (1 + 2 rho)/(1 + rho) x - (1 + rho) x_n + rho^2/(1 + rho) x_{n-1} ] / h,       (2)
//! ```
//!
//! i.e. `v = c0 x + offset` with constants `c0`, `offset` ([`ImplicitStep`]). The first step is
//! backward Euler (`v = (x - x_0)/h`). The ratio `rho` is kept at most 2, inside the zero
//! stability limit `1 + sqrt 2` of variable-step BDF2.
//!
//! **Newton.** Each step is solved by Newton's method with the exact Jacobian of (2) and updates
//! through [`Steady::retract`], starting from the quadratic extrapolation of the last three
//! points; converged when the residual norm of (2) is below `newton_tol`. A failed solve is
//! retried with a quarter of the step. With [`DynamicsSettings::reuse_jacobian`] the factorized
//! exact Jacobian is kept over iterations and steps while it converges fast (a chord method, the
//! usual economy of stiff integrators: the elastic Hessian is most of the cost of an iteration);
//! the default is Newton's method proper. Writing the left side of (2) as the free part of
//! `Z V_full` (`V_full = v` on the free nodes, 0 on the clamp) and using `dZ = -Z dA Z`,
//!
//! ```text
//! d[Z_ff(x) v(x)]/dx = [ Z (c0 E - B(X; Z V_full)) ]_ff,                                  (3)
//! ```
//!
//! with `E` the injection of the free positions and `B(X; y) = d(A(X) y)/dX`
//! ([`crate::model::fluid::Lighthill::mobility_derivative`]); the Jacobian of (2) is that of the steady
//! residual ([`Steady::linearize`]) minus (3) in the position block.
//!
//! **Error control** (positions only: the twist is an algebraic variable, determined by the
//! positions). The predictor `x^P` is the quadratic through the last three accepted positions
//! (the first two and the initial velocity `dx/dt(0)` after the first step). With
//! `A = h (h + h_1)(h + h_1 + h_2)` and `B = h^2 (h + h_1)^2 / (2h + h_1)` the local error of (2)
//! is `y''' B/6` and `x_{n+1} - x^P = y''' (A + B)/6`, so (Milne's device)
//!
//! ```text
//! err = B / (A + B) (x_{n+1} - x^P)     (2/11 of the difference at constant steps),
//! ```
//!
//! and `err = (x_1 - x_0 - h dx/dt(0))/2` for the first (backward Euler) step. A step is accepted
//! when the root mean square of `err_i / (atol + rtol |x_i|)` is at most 1; the next step is
//! `h 0.9 err^{-1/(p+1)}` (`p` the order) clipped to `[0.2 h, 2 h]` (no growth right after a
//! rejection) and to `dt_max`. The initial twist is re-solved (slaved) and `dx/dt(0)` comes from
//! `Z_ff dx/dt = R_x` at the initial state.
//!
//! Two consequences for the user: the local error is absolute in positions (solver units,
//! `ell = 1`), so a small perturbation of a steady state needs an `atol` well below its
//! amplitude; and the step must resolve the oscillation of the critical mode (`Im s` near
//! `omega`): an A-stable method with `h |s| >> 1` damps a growing oscillation numerically and
//! would call an unstable state stable. [`bisect`] therefore caps the step at a fraction of the
//! rotation period.
//!
//! **Chart.** The energy measures the twist in a chart (reference directors parallel-transported
//! from a source frame onto the current edges, reference twist unwrapped near the source's). The
//! model's natural chart degenerates when an edge turns towards the reverse of its natural
//! direction (the transport is singular there, and the unwrapping ambiguous beyond a turn of
//! `pi`), so the integrator carries its own chart along: each step (2) is solved in the chart
//! carried to the last accepted state ([`Chart::transported`]), where the twist unknowns are
//! unchanged. Only positions enter (2) and the error estimate (the twist is algebraic); the
//! stored twists, used by the predictor alone, are re-expressed in the new chart ([`rechart`],
//! exact). Large post-buckling motions are then integrated like small ones. The samples report
//! the twist both in the natural chart ([`Sample::u`], inaccurate only where an edge points
//! nearly opposite to its natural direction) and in the carried chart ([`Sample::u_chart`],
//! [`Sample::chart`]).
//!
//! # Linear modes and bisection
//!
//! [`least_stable_mode`] gives the critical eigenpair of `K v = s M v` with a projection that
//! reads the modal amplitude off a state, [`perturb`] displaces a steady state along it, and
//! [`natural_chart_unknowns`] brings a steady state whose chart was carried along (e.g. from
//! [`solve_at`]) into the natural chart. [`bisect`] finds `omega_b` the way simulation studies
//! did, from spin-ups from rest at trial rates ([`trial`]).

use std::ops::ControlFlow;

use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::prelude::Solve;
use faer::{Mat, Par, Side, c64};
use nalgebra::Vector3;
use serde::Serialize;

use crate::branch::rest_state;
use crate::engine::newton::{
    Chord, Globalization, Iterate, Jacobians, Newton, NewtonSettings, System, norm,
};
use crate::engine::periodic::StepLinearization;
use crate::engine::stability::reduce_with_factor;
use crate::error::ensure;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::fluid::Resistance;
use crate::model::observables::height;
use crate::model::rod::Config;
use crate::model::rod::frame::Chart;
use crate::model::steady::{Steady, rotation_velocity};
use crate::numerics::lu::Lu;
use crate::solve::solve_at;
use crate::{Error, Result};

/// Settings of the integrator. Times in `mu ell^4 / EI`, lengths in `ell`.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DynamicsSettings {
    /// Relative and absolute local error tolerance on the positions.
    pub rtol: f64,
    pub atol: f64,
    /// First step (the fixed step when `adaptive` is false: then `t_end` is divided into equal
    /// steps no longer than `dt0`).
    pub dt0: f64,
    /// Smallest step before giving up, largest step.
    pub dt_min: f64,
    pub dt_max: f64,
    /// Largest number of accepted steps.
    pub max_steps: usize,
    /// Error control and step adaptation; `false` for fixed steps (no error test).
    pub adaptive: bool,
    /// Newton: converged when the Euclidean norm of the residual of (2) is at most `newton_tol`
    /// (force units `EI/ell^2`), or when the update is at round-off size.
    pub newton_tol: f64,
    /// Newton iterations before the step is rejected and retried shorter.
    pub max_newton: usize,
    /// Newton also ends when its update is at most `newton_kappa` in the error test's weighted
    /// root-mean-square norm (`atol + rtol |u_i|` per unknown), the convergence test of stiff
    /// codes (DASSL, RADAU): the solve then errs far less than the step's own local error.
    /// `0`: off, the residual test alone (which for the stiff stretching asks round-off).
    pub newton_kappa: f64,
    /// `false`: Newton's method proper, a fresh exact Jacobian at every iteration. `true`:
    /// keep the factorized exact Jacobian over iterations and steps while it converges (a
    /// chord method; about 80% of the cost of an iteration is the elastic Hessian).
    pub reuse_jacobian: bool,
}

impl Default for DynamicsSettings {
    fn default() -> Self {
        DynamicsSettings {
            rtol: 1e-6,
            atol: 1e-9,
            dt0: 1e-6,
            dt_min: 1e-14,
            dt_max: 1.0,
            max_steps: 200_000,
            adaptive: true,
            newton_tol: 1e-9,
            max_newton: 8,
            newton_kappa: 0.0,
            reuse_jacobian: false,
        }
    }
}

impl DynamicsSettings {
    /// Checks ranges: `rtol, atol >= 0` not both zero, `0 < dt_min <= dt0 <= dt_max < inf`,
    /// `max_steps >= 1`, `0 < newton_tol < 1`, `max_newton >= 1`.
    pub fn validate(&self) -> Result<()> {
        ensure(
            self.rtol >= 0.0
                && self.atol >= 0.0
                && self.rtol + self.atol > 0.0
                && (self.rtol + self.atol).is_finite(),
            "dynamics.rtol",
            format!(
                "need rtol >= 0, atol >= 0, not both zero, got rtol = {}, atol = {}",
                self.rtol, self.atol
            ),
        )?;
        ensure(
            self.dt_min > 0.0
                && self.dt_min <= self.dt0
                && self.dt0 <= self.dt_max
                && self.dt_max.is_finite(),
            "dynamics.dt0",
            format!(
                "need 0 < dt_min <= dt0 <= dt_max < inf, got dt_min = {}, dt0 = {}, dt_max = {}",
                self.dt_min, self.dt0, self.dt_max
            ),
        )?;
        ensure(
            self.max_steps >= 1,
            "dynamics.max_steps",
            format!("must be >= 1, got {}", self.max_steps),
        )?;
        ensure(
            self.newton_tol > 0.0 && self.newton_tol < 1.0,
            "dynamics.newton_tol",
            format!("must lie in (0, 1), got {}", self.newton_tol),
        )?;
        ensure(
            self.max_newton >= 1,
            "dynamics.max_newton",
            format!("must be >= 1, got {}", self.max_newton),
        )?;
        ensure(
            (0.0..1.0).contains(&self.newton_kappa),
            "dynamics.newton_kappa",
            format!("must lie in [0, 1), got {}", self.newton_kappa),
        )
    }
}

/// The rotation rate `omegabar(t)` of the motor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Rate {
    /// Constant rate.
    Fixed(f64),
    /// A motor spinning up from rest to `target` over `ramp_time`, smoothly:
    /// `omega(t) = target (3 s^2 - 2 s^3)`, `s = min(1, t/ramp_time)` (continuous acceleration,
    /// zero at both ends, so the step control meets no kink).
    Ramp { target: f64, ramp_time: f64 },
}

impl Rate {
    /// `omegabar` at time `t`.
    pub fn at(&self, t: f64) -> f64 {
        match *self {
            Rate::Fixed(w) => w,
            Rate::Ramp { target, ramp_time } => {
                let s = (t / ramp_time).clamp(0.0, 1.0);
                target * s * s * (3.0 - 2.0 * s)
            }
        }
    }

    /// The final rate.
    pub fn target(&self) -> f64 {
        match *self {
            Rate::Fixed(w) => w,
            Rate::Ramp { target, .. } => target,
        }
    }

    fn validate(&self) -> Result<()> {
        let finite = self.target().is_finite();
        let ramp = match *self {
            Rate::Fixed(_) => true,
            Rate::Ramp { ramp_time, .. } => ramp_time > 0.0 && ramp_time.is_finite(),
        };
        if finite && ramp {
            Ok(())
        } else {
            Err(Error::input(
                "dynamics.rate",
                format!("need a finite rate and a finite ramp time > 0, got {self:?}"),
            ))
        }
    }
}

/// One accepted state: time, rate, free unknowns.
///
/// `u` has its twist in the model's natural chart (converted exactly by [`rechart`] from the
/// chart the integrator carries along). That conversion goes through the parallel transport of
/// the natural directors straight onto the current edges: it loses accuracy (and gives
/// non-finite twists) when an edge points nearly opposite to its natural direction. The
/// positions of `u` are always exact; for the twist, use `u_chart` with `chart`, which are
/// well defined for any motion.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    pub t: f64,
    pub omega: f64,
    pub u: Vec<f64>,
    /// The free unknowns with the twist measured in `chart` (same positions as `u`).
    pub u_chart: Vec<f64>,
    /// The chart the integrator carries, at the positions of this sample.
    pub chart: Chart,
}

impl Sample {
    fn empty(omega: f64, chart: &Chart) -> Self {
        Sample {
            t: 0.0,
            omega,
            u: Vec::new(),
            u_chart: Vec::new(),
            chart: chart.clone(),
        }
    }
}

/// What [`integrate`] returns: the last accepted state and the counts.
#[derive(Clone, Debug)]
pub struct Trajectory {
    pub last: Sample,
    /// Accepted steps, rejected steps (error test or Newton failure), Newton iterations, and
    /// exact Jacobians evaluated and factorized (as many as the iterations unless
    /// `reuse_jacobian`).
    pub steps: usize,
    pub rejected: usize,
    pub newton_iterations: usize,
    pub jacobians: usize,
    /// True when the observer stopped the integration before `t_end`.
    pub stopped: bool,
}

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
    pub fn linearize_with_mass(&self, u: &[f64]) -> Result<StepLinearization> {
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

/// The free unknowns with the twist re-solved (`R_theta = 0`, the twist slaved) for the
/// positions of `u`, in the model's natural chart, by Newton's method on the twist block started
/// from the twist of `u`. That start must be close: the twist of a state measured in another
/// chart is not (convert it with [`natural_chart_unknowns`]). Converged when
/// `|R_theta| <= 1e-11`, or below `1e-8` once the updates stop shrinking (round-off).
pub fn slave_twist(model: &Model, u: &[f64]) -> Result<Vec<f64>> {
    slave_twist_in(model, &model.chart, u)
}

/// [`slave_twist`] with the twist measured in `chart` (the source chart of the energy).
pub fn slave_twist_in(model: &Model, chart: &Chart, u: &[f64]) -> Result<Vec<f64>> {
    slave_twist_to(model, chart, u, 1e-11)
}

/// [`slave_twist_in`] converged until `|R_theta| <= tol` (or until the updates stop shrinking
/// below `1e-8`, or reach round-off).
pub fn slave_twist_to(model: &Model, chart: &Chart, u: &[f64], tol: f64) -> Result<Vec<f64>> {
    slave_twist_with(model, chart, u, tol, Jacobians::Fresh)
}

/// [`slave_twist_to`] by the chord method on `j_tt`, the factorized twist block of a nearby
/// state (kept while the residual falls by a factor 3 per iteration): each iteration costs a
/// gradient of the energy instead of its Hessian. For states a small displacement from the one
/// `j_tt` was made at, started from its linear prediction.
pub fn slave_twist_chord(
    model: &Model,
    chart: &Chart,
    u: &[f64],
    tol: f64,
    j_tt: &Lu<f64>,
) -> Result<Vec<f64>> {
    let mut chord = Chord::holding(j_tt.clone());
    slave_twist_with(model, chart, u, tol, Jacobians::Reuse(&mut chord))
}

fn slave_twist_with(
    model: &Model,
    chart: &Chart,
    u: &[f64],
    tol: f64,
    jacobians: Jacobians,
) -> Result<Vec<f64>> {
    let block = TwistBlock {
        still: Steady {
            chart: chart.clone(),
            ..Steady::new(model, 0.0)
        },
        u: u.to_vec(),
        nx: model.rod.layout.free_positions(),
    };
    let newton = Newton {
        tol,
        max_iter: 50,
        min_steps: 0,
        globalization: Globalization::Full,
    };
    let (twist, _) = newton
        .run(&block, u[block.nx..].to_vec(), jacobians, "")
        .map_err(|_| {
            Error::Numerical(
                "the twist could not be slaved to the positions (Newton on R_theta = 0 failed)"
                    .into(),
            )
        })?;
    Ok(block.with_twist(&twist))
}

/// The twist equations `R_theta(x, theta) = 0` at the fixed positions of `u`, in the twist
/// angles alone (the twist block of the steady Jacobian).
struct TwistBlock<'a> {
    still: Steady<'a>,
    u: Vec<f64>,
    nx: usize,
}

impl TwistBlock<'_> {
    /// The free unknowns of `u` with the twist angles `twist`.
    fn with_twist(&self, twist: &[f64]) -> Vec<f64> {
        let mut u = self.u.clone();
        u[self.nx..].copy_from_slice(twist);
        u
    }
}

impl System for TwistBlock<'_> {
    /// `R_theta = -dE/dtheta` at the free angles.
    fn residual(&self, twist: &[f64]) -> Result<Vec<f64>> {
        let config = self.still.config(&self.with_twist(twist));
        let model = self.still.model;
        let g = model.rod.twist_gradient(&config, &self.still.chart);
        Ok(g[1..].iter().map(|v| -v).collect())
    }

    fn residual_and_jacobian(&self, twist: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.still.linearize(&self.with_twist(twist))?;
        let (nx, nt) = (self.nx, twist.len());
        let jacobian = Mat::from_fn(nt, nt, |a, b| lin.jacobian[(nx + a, nx + b)]);
        Ok((lin.residual[nx..].to_vec(), jacobian))
    }

    /// Round-off: the step is negligible, or it stopped shrinking with the residual below
    /// `1e-8`.
    fn settled(&self, it: &Iterate) -> Option<f64> {
        let round_off = it.step <= 1e-14 * (1.0 + norm(it.u));
        let stalled = it.step > 0.5 * it.previous_step && it.residual < 1e-8;
        (round_off || stalled).then_some(it.step)
    }
}

/// The free unknowns of `config`, whose twist is measured in `chart` (at `config.x`, e.g. a
/// [`crate::problem::steady::SteadyState`] with its carried chart), with the twist converted to the
/// model's natural chart, the one of [`integrate`] and [`crate::branch::RodProblem`].
///
/// Both charts give the same material frames when the discrete twists
/// `m_i = theta^i - theta^{i-1} + mref_i` agree (edge 0 is clamped in both), so
/// `theta_nat^j = theta^j + sum_{i <= j} (mref_i - mref_nat_i)` with `mref_nat` the reference
/// twist of the natural chart carried to `config.x`; exact, including the multiples of `2 pi`.
/// The result is then polished by [`slave_twist`].
pub fn natural_chart_unknowns(model: &Model, config: &Config, chart: &Chart) -> Result<Vec<f64>> {
    let converted = rechart(config, chart, &model.chart);
    slave_twist(model, &Steady::new(model, 0.0).free_vector(&converted))
}

/// `config` (twist measured in the chart `from`) with its twist re-expressed in the chart `to`:
/// the same positions and the same material frames and discrete twists, hence the same energy.
///
/// With `mref_from`, `mref_to` the reference twists of the two charts carried to `config.x`
/// ([`Chart::transported`], unwrapped as the energy unwraps them), the twists
/// `m_i = theta^i - theta^{i-1} + mref_i` agree (edge 0 is clamped, its director the same in
/// both) when `theta_to^j = theta^j + sum_{i <= j} (mref_from_i - mref_to_i)`; exact, including
/// the multiples of `2 pi`, as long as no edge of `config` points opposite to its tangent in
/// either chart (where the parallel transport is singular).
pub fn rechart(config: &Config, from: &Chart, to: &Chart) -> Config {
    let a = from.transported(&config.x);
    let b = to.transported(&config.x);
    let mut theta = config.theta.clone();
    let mut shift = 0.0;
    for (j, t) in theta.iter_mut().enumerate().skip(1) {
        shift += a.ref_twist[j] - b.ref_twist[j];
        *t += shift;
    }
    Config {
        x: config.x.clone(),
        theta,
    }
}

/// The history of accepted points used by the scheme.
struct History {
    /// The last three accepted points, newest first: `(t, u)`.
    points: Vec<(f64, Vec<f64>)>,
    /// `dx/dt` at the initial point (for the predictor and error estimate of the first steps).
    xdot0: Vec<f64>,
}

impl History {
    /// Coefficients `(c0, offset)` of (2) for a step `h`, the predicted unknowns and the
    /// factor `B/(A+B)` of the error estimate, for the current order.
    fn step(&self, h: f64, nx: usize) -> (f64, Vec<f64>, Vec<f64>, f64) {
        let (t0, u0) = &self.points[0];
        let x0 = &u0[..nx];
        if self.points.len() == 1 {
            let c0 = 1.0 / h;
            let offset = x0.iter().map(|x| -x / h).collect();
            let mut pred = u0.clone();
            for (p, v) in pred.iter_mut().zip(&self.xdot0) {
                *p += h * v;
            }
            return (c0, offset, pred, 0.5);
        }
        let (t1, u1) = &self.points[1];
        let h1 = t0 - t1;
        let rho = h / h1;
        let c0 = (1.0 + 2.0 * rho) / ((1.0 + rho) * h);
        let offset = x0
            .iter()
            .zip(&u1[..nx])
            .map(|(a, b)| (-(1.0 + rho) * a + rho * rho / (1.0 + rho) * b) / h)
            .collect();
        // Newton divided differences on the nodes t0, t1, t2 (t2 = t1 with the derivative when
        // only two points exist; the twist then extrapolates linearly).
        let (h2, second): (f64, Vec<f64>) = match self.points.get(2) {
            Some((t2, u2)) => {
                let h2 = t1 - t2;
                let d = u0
                    .iter()
                    .zip(u1)
                    .zip(u2)
                    .map(|((a, b), c)| ((a - b) / h1 - (b - c) / h2) / (h1 + h2))
                    .collect();
                (h2, d)
            }
            None => {
                let d = (0..u0.len())
                    .map(|i| {
                        if i < nx {
                            ((u0[i] - u1[i]) / h1 - self.xdot0[i]) / h1
                        } else {
                            0.0
                        }
                    })
                    .collect();
                (0.0, d)
            }
        };
        let pred = (0..u0.len())
            .map(|i| u0[i] + h * (u0[i] - u1[i]) / h1 + h * (h + h1) * second[i])
            .collect();
        let a = h * (h + h1) * (h + h1 + h2);
        let b = h * h * (h + h1) * (h + h1) / (2.0 * h + h1);
        (c0, offset, pred, b / (a + b))
    }

    fn push(&mut self, t: f64, u: Vec<f64>) {
        self.points.insert(0, (t, u));
        self.points.truncate(3);
    }

    /// Re-expresses the twist of the stored points, measured in `from`, in the chart `to`
    /// (only the predictor uses it: (2) and the error estimate use positions alone).
    fn rechart(&mut self, steady: &Steady, from: &Chart, to: &Chart) {
        for (_, u) in &mut self.points {
            *u = steady.free_vector(&rechart(&steady.config(u), from, to));
        }
    }
}

/// A step (2) whose Newton iteration also ends on a small update: `rms(du_i / w_i) <= kappa`
/// with the weights `w` of the error test ([`DynamicsSettings::newton_kappa`]). Where the
/// update is that small the iterate errs by at most about `kappa` (the chord contracts by 3 or
/// is rebuilt), far below the local error the step is accepted with.
struct ToleratedStep<'a> {
    step: &'a ImplicitStep<'a>,
    weights: &'a [f64],
    kappa: f64,
}

impl System for ToleratedStep<'_> {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.step.residual(u)
    }

    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        self.step.residual_and_jacobian(u)
    }

    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.step.retract(u, du)
    }

    fn settled(&self, it: &Iterate) -> Option<f64> {
        let sum: f64 = it
            .du
            .iter()
            .zip(self.weights)
            .map(|(d, w)| (d / w).powi(2))
            .sum();
        let weighted = (sum / it.du.len() as f64).sqrt();
        (weighted <= self.kappa)
            .then_some(it.step)
            .or_else(|| self.step.settled(it))
    }
}

/// A factorized step Jacobian kept across steps, and the `c0` of the step it was built for.
#[derive(Default)]
struct Factored {
    chord: Chord,
    c0: f64,
}

/// Newton's method on one step (full steps, the one solver of [`crate::engine::newton`]);
/// `Ok(None)` when it does not converge (the step is retried shorter). With `reuse_jacobian`, the
/// factorization in `cache` serves while it converges (the chord method: it is rebuilt when `c0`
/// changed by more than 20%, when the residual falls by less than a factor 3 in an iteration,
/// and once more from the start of the step if the solve fails).
fn newton_step(
    step: &ImplicitStep,
    guess: &[f64],
    settings: &DynamicsSettings,
    cache: &mut Factored,
    trajectory: &mut Trajectory,
) -> Result<Option<Vec<f64>>> {
    let newton = Newton {
        tol: settings.newton_tol,
        max_iter: settings.max_newton,
        min_steps: 0,
        globalization: Globalization::Full,
    };
    if (cache.c0 / step.c0 - 1.0).abs() > 0.2 {
        cache.chord.clear();
    }
    loop {
        // A solve that starts from a factorization of an earlier step deserves a retry with a
        // fresh one when it fails.
        let inherited = settings.reuse_jacobian && cache.chord.holds();
        let before = cache.chord.built;
        let jacobians = if settings.reuse_jacobian {
            Jacobians::Reuse(&mut cache.chord)
        } else {
            Jacobians::Fresh
        };
        let weights: Vec<f64> = guess
            .iter()
            .map(|g| settings.atol + settings.rtol * g.abs())
            .collect();
        let tolerated = ToleratedStep {
            step,
            weights: &weights,
            kappa: settings.newton_kappa,
        };
        let solved = newton.run(&tolerated, guess.to_vec(), jacobians, "in the time step");
        let (solution, steps) = match solved {
            Ok((u, report)) => (Some(u), report.iterations),
            Err(Error::NewtonFailed { iterations, .. }) => (None, iterations),
            Err(Error::NotPositiveDefinite { .. }) => (None, 0),
            Err(e) => return Err(e),
        };
        trajectory.newton_iterations += steps;
        trajectory.jacobians += if settings.reuse_jacobian {
            cache.chord.built - before
        } else {
            steps + 1
        };
        if cache.chord.built > before {
            cache.c0 = step.c0;
        }
        if solution.is_some() || !inherited {
            if solution.is_none() {
                cache.chord.clear();
            }
            return Ok(solution);
        }
        cache.chord.clear();
    }
}

/// Integrates (1) from `u0` (free unknowns, twist in the natural chart; re-slaved first) over
/// `[0, t_end]` at the rate `rate`. `observer` sees every accepted sample (the initial one
/// included) and may stop the integration by returning `ControlFlow::Break(())`.
///
/// # Errors
/// Input errors for bad settings or `u0` of the wrong length; [`Error::Numerical`] when the step
/// falls below `dt_min` or `max_steps` is exceeded; errors of the model (e.g. a mobility matrix
/// that stops being positive definite at every step tried).
pub fn integrate(
    model: &Model,
    rate: Rate,
    u0: Vec<f64>,
    t_end: f64,
    settings: &DynamicsSettings,
    observer: impl FnMut(&Sample) -> ControlFlow<()>,
) -> Result<Trajectory> {
    integrate_from(
        model,
        rate,
        Start::Initial(u0),
        t_end,
        settings,
        observer,
        None,
    )
}

/// Where an integration starts: an initial state, or the saved state of an interrupted run.
#[derive(Clone, Debug)]
pub enum Start {
    /// Free unknowns, twist in the natural chart (re-slaved first).
    Initial(Vec<f64>),
    /// An [`IntegratorState`] saved by an earlier run with the same model, rate and settings;
    /// the run continues exactly as the uninterrupted one would have.
    Resume(Box<IntegratorState>),
}

/// Everything the scheme carries from one accepted step to the next (after step `steps`, at
/// time `t`): the last three points, the initial velocity, the carried chart, the next step
/// and the counts. Saved by [`Checkpoints`], it lets an interrupted run continue bit for bit:
/// the factorized Jacobian of the chord is dropped at every save, in the saved run too.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct IntegratorState {
    pub t: f64,
    /// The next step to try.
    pub h: f64,
    /// `(t, u)`, newest first, twist measured in `chart`.
    pub points: Vec<(f64, Vec<f64>)>,
    pub xdot0: Vec<f64>,
    pub chart: Chart,
    pub steps: usize,
    pub rejected: usize,
    pub newton_iterations: usize,
    pub jacobians: usize,
}

/// Saving the integrator's state: `save` is called after every `every` accepted steps and at
/// the end of the run.
pub struct Checkpoints<'a> {
    pub every: usize,
    pub save: &'a mut dyn FnMut(&IntegratorState) -> Result<()>,
}

/// [`integrate`] from a [`Start`], saving [`IntegratorState`]s on the way when `checkpoints`
/// asks for them. A resumed run calls `observer` for the samples after the saved one only.
///
/// # Errors
/// Those of [`integrate`]; an input error when a resumed state does not fit the model; the
/// errors of `save`.
pub fn integrate_from(
    model: &Model,
    rate: Rate,
    start: Start,
    t_end: f64,
    settings: &DynamicsSettings,
    observer: impl FnMut(&Sample) -> ControlFlow<()>,
    checkpoints: Option<Checkpoints>,
) -> Result<Trajectory> {
    let mut trajectory = Trajectory {
        last: Sample::empty(rate.at(0.0), &model.chart),
        steps: 0,
        rejected: 0,
        newton_iterations: 0,
        jacobians: 0,
        stopped: false,
    };
    run(
        model,
        rate,
        start,
        t_end,
        settings,
        observer,
        checkpoints,
        &mut trajectory,
    )?;
    Ok(trajectory)
}

/// [`integrate_from`], with the counts kept in `trajectory` when it fails.
#[allow(clippy::too_many_arguments)]
fn run(
    model: &Model,
    rate: Rate,
    start: Start,
    t_end: f64,
    settings: &DynamicsSettings,
    mut observer: impl FnMut(&Sample) -> ControlFlow<()>,
    mut checkpoints: Option<Checkpoints>,
    trajectory: &mut Trajectory,
) -> Result<()> {
    settings.validate()?;
    rate.validate()?;
    let layout = model.rod.layout;
    if !(t_end.is_finite() && t_end >= 0.0) {
        return Err(Error::input(
            "dynamics.t_end",
            format!("must be finite and >= 0, got {t_end}"),
        ));
    }
    model.check_resolution()?;
    let nx = layout.free_positions();
    let steady0 = Steady::new(model, rate.at(0.0));
    let fits = |u: &[f64]| u.len() == layout.free_len();
    let (mut history, mut chart, mut t, mut h) = match start {
        Start::Initial(u0) => {
            if !fits(&u0) {
                return Err(Error::input(
                    "dynamics.u0",
                    format!(
                        "expected {} free unknowns, got {}",
                        layout.free_len(),
                        u0.len()
                    ),
                ));
            }
            let u0 = slave_twist(model, &u0)?;
            let r0 = steady0.residual(&u0)?;
            let m0 = mass(&steady0, &u0)?;
            let llt = m0.llt(Side::Lower).map_err(|_| {
                Error::Numerical("the mass matrix Z_ff is not positive definite".into())
            })?;
            let v0 = llt.solve(Mat::from_fn(nx, 1, |i, _| r0[i]));
            let history = History {
                points: vec![(0.0, u0.clone())],
                xdot0: (0..nx).map(|i| v0[(i, 0)]).collect(),
            };
            // The chart of the twist unknowns, carried along with the rod: rebased to every
            // accepted state (where the twist unknowns are then unchanged), so that the step
            // problem never measures the twist far from its chart.
            let chart = model.chart.transported(&steady0.config(&u0).x);
            trajectory.last = sample(&steady0, 0.0, rate.at(0.0), u0, &chart);
            if observer(&trajectory.last).is_break() {
                trajectory.stopped = true;
                return Ok(());
            }
            (history, chart, 0.0, settings.dt0.min(t_end))
        }
        Start::Resume(state) => {
            let state = *state;
            let edges = layout.edges();
            if state.points.is_empty()
                || !state.points.iter().all(|(_, u)| fits(u))
                || state.xdot0.len() != nx
                || state.chart.tangents.len() != edges
                || !(state.h > 0.0 && state.t.is_finite())
            {
                return Err(Error::input(
                    "--resume",
                    "the saved integrator state does not fit this model",
                ));
            }
            trajectory.steps = state.steps;
            trajectory.rejected = state.rejected;
            trajectory.newton_iterations = state.newton_iterations;
            trajectory.jacobians = state.jacobians;
            let (t, u) = state.points[0].clone();
            trajectory.last = sample(&steady0, t, rate.at(t), u, &state.chart);
            let history = History {
                points: state.points,
                xdot0: state.xdot0,
            };
            (history, state.chart, state.t, state.h)
        }
    };
    // Fixed steps: `t_end` divided into equal steps no longer than `dt0`, the times computed
    // as `t_end k/n` so that the last one is `t_end` exactly.
    let fixed = (!settings.adaptive)
        .then(|| ((t_end / settings.dt0) * (1.0 - 1e-12)).ceil().max(1.0) as usize);
    let mut just_rejected = false;
    let mut cache = Factored::default();
    while t < t_end {
        if trajectory.steps >= settings.max_steps {
            return Err(Error::Numerical(format!(
                "time integration: {} steps reached at t = {t:.6e} (t_end = {t_end:.6e})",
                settings.max_steps
            )));
        }
        let t_next = match fixed {
            Some(n) if trajectory.steps + 1 >= n => t_end,
            Some(n) => t_end * (trajectory.steps + 1) as f64 / n as f64,
            None => {
                // Land on t_end without a sliver of a last step.
                let remaining = t_end - t;
                if h >= remaining {
                    t_end
                } else if h > 0.5 * remaining {
                    t + 0.5 * remaining
                } else {
                    t + h
                }
            }
        };
        h = t_next - t;
        let (c0, offset, predicted, error_factor) = history.step(h, nx);
        let order = if history.points.len() == 1 { 1 } else { 2 };
        let step = ImplicitStep {
            steady: Steady {
                chart: chart.clone(),
                ..Steady::new(model, rate.at(t_next))
            },
            c0,
            offset,
        };
        // Newton starts from the polynomial predictor or from the one reached by the retraction
        // from the last state (edges turned, not stretched at second order), whichever has the
        // smaller residual: the polynomial's spurious stretch of turning edges can be most of
        // the residual (the buckled rod), the retraction's first-order length change worse than
        // it (a fast spin-up). The error estimate keeps the polynomial (Milne's device).
        let last = &history.points[0].1;
        let increment: Vec<f64> = predicted.iter().zip(last).map(|(p, l)| p - l).collect();
        let retracted = step.retract(last, &increment);
        let size = |u: &[f64]| step.residual(u).map_or(f64::INFINITY, |g| norm(&g));
        let guess = if size(&retracted) < size(&predicted) {
            retracted
        } else {
            predicted.clone()
        };
        let solved = newton_step(&step, &guess, settings, &mut cache, trajectory)?;
        let Some(u) = solved else {
            trajectory.rejected += 1;
            if !settings.adaptive {
                return Err(Error::Numerical(format!(
                    "time integration: Newton failed at t = {t:.6e} with the fixed step {h:.3e}"
                )));
            }
            h *= 0.25;
            just_rejected = true;
            if h < settings.dt_min {
                return Err(Error::Numerical(format!(
                    "time integration: step below dt_min = {:e} at t = {t:.6e} (Newton fails)",
                    settings.dt_min
                )));
            }
            continue;
        };
        let mut factor = 1.0;
        if settings.adaptive {
            let x_old = &history.points[0].1[..nx];
            let sum: f64 = (0..nx)
                .map(|i| {
                    let e = error_factor * (u[i] - predicted[i]);
                    let w = settings.atol + settings.rtol * u[i].abs().max(x_old[i].abs());
                    (e / w).powi(2)
                })
                .sum();
            let err = (sum / nx as f64).sqrt();
            let exponent = -1.0 / (order as f64 + 1.0);
            factor = if err > 0.0 {
                (0.9 * err.powf(exponent)).clamp(0.2, 2.0)
            } else {
                2.0
            };
            if err > 1.0 {
                trajectory.rejected += 1;
                h *= factor.min(0.9);
                just_rejected = true;
                if h < settings.dt_min {
                    return Err(Error::Numerical(format!(
                        "time integration: step below dt_min = {:e} at t = {t:.6e} (error test)",
                        settings.dt_min
                    )));
                }
                continue;
            }
            if just_rejected {
                factor = factor.min(1.0);
            }
        }
        just_rejected = false;
        t = t_next;
        trajectory.steps += 1;
        let moved = chart.transported(&steady0.config(&u).x);
        history.push(t, u.clone());
        history.rechart(&steady0, &chart, &moved);
        chart = moved;
        trajectory.last = sample(&steady0, t, rate.at(t), u, &chart);
        if observer(&trajectory.last).is_break() {
            trajectory.stopped = true;
            return Ok(());
        }
        if settings.adaptive {
            h = (h * factor).min(settings.dt_max);
        }
        if let Some(c) = checkpoints.as_mut()
            && (trajectory.steps.is_multiple_of(c.every.max(1)) || t >= t_end)
        {
            (c.save)(&IntegratorState {
                t,
                h,
                points: history.points.clone(),
                xdot0: history.xdot0.clone(),
                chart: chart.clone(),
                steps: trajectory.steps,
                rejected: trajectory.rejected,
                newton_iterations: trajectory.newton_iterations,
                jacobians: trajectory.jacobians,
            })?;
            cache = Factored::default();
        }
    }
    Ok(())
}

/// The sample at `t` of the unknowns `u_chart`, twist measured in `chart` (at their positions).
fn sample(steady: &Steady, t: f64, omega: f64, u_chart: Vec<f64>, chart: &Chart) -> Sample {
    let config = rechart(&steady.config(&u_chart), chart, &steady.model.chart);
    Sample {
        t,
        omega,
        u: steady.free_vector(&config),
        u_chart,
        chart: chart.clone(),
    }
}

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

/// Settings of [`bisect`]. Times in the solver's unit `mu ell^4 / EI`.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BisectSettings {
    /// Relative width of the final bracket.
    pub precision: f64,
    /// Duration of the spin-up from rest ([`Rate::Ramp`]).
    pub ramp_time: f64,
    /// Duration at the trial rate after the ramp. It must be several times the inverse gap
    /// between the decay rates of the critical mode and of the next one (about `1/6` for the
    /// representative helix), so that the critical mode dominates the late motion: with two
    /// oscillatory modes of close frequencies the deviation beats, and a short record misleads
    /// the growth test.
    pub hold_time: f64,
    /// Length of each of the two late windows compared by the growth test.
    pub window: f64,
    /// Unstable if the late `|hbar/hbar_s - 1|` exceeds this (a state that moved away).
    pub departure: f64,
    /// Fewest time steps per rotation period `2 pi/omega` (the largest step is the period over
    /// this): the critical oscillation (`Im s` near `omega`) must be resolved. BDF2 damps it
    /// at the spurious rate `7e-4 Im(s)` at 40 steps per period, `1e-4 Im(s)` at 80, which
    /// lowers `Re s` by as much and moves the boundary found up by that over `d Re(s)/d omega`
    /// (about `0.3%` and `0.04%` of `omega_b` for the representative helix at `N = 30`).
    pub steps_per_period: f64,
    pub dynamics: DynamicsSettings,
    pub newton: NewtonSettings,
}

impl Default for BisectSettings {
    fn default() -> Self {
        BisectSettings {
            precision: 1e-2,
            ramp_time: 0.2,
            hold_time: 1.0,
            window: 0.2,
            departure: 1e-2,
            steps_per_period: 80.0,
            dynamics: DynamicsSettings {
                rtol: 1e-5,
                atol: 1e-8,
                newton_tol: 1e-8,
                reuse_jacobian: true,
                ..DynamicsSettings::default()
            },
            newton: NewtonSettings::default(),
        }
    }
}

impl BisectSettings {
    /// Checks ranges: `0 < precision < 1`, positive finite durations with
    /// `2 window <= hold_time`, `departure > 0`, `steps_per_period >= 4`, and the nested settings.
    pub fn validate(&self) -> Result<()> {
        let positive = |v: f64| v > 0.0 && v.is_finite();
        if !(self.precision > 0.0 && self.precision < 1.0) {
            return Err(Error::input(
                "bisect.precision",
                format!("must lie in (0, 1), got {}", self.precision),
            ));
        }
        if !(positive(self.ramp_time)
            && positive(self.hold_time)
            && positive(self.window)
            && 2.0 * self.window <= self.hold_time)
        {
            return Err(Error::input(
                "bisect.hold_time",
                format!(
                    "need ramp_time, hold_time, window > 0 and 2 window <= hold_time, got {}, {}, {}",
                    self.ramp_time, self.hold_time, self.window
                ),
            ));
        }
        if !(positive(self.departure) && self.steps_per_period >= 4.0) {
            return Err(Error::input(
                "bisect.departure",
                format!(
                    "need departure > 0 and steps_per_period >= 4, got {} and {}",
                    self.departure, self.steps_per_period
                ),
            ));
        }
        self.dynamics.validate()?;
        self.newton.validate()
    }
}

/// The verdict of one trial rate.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Trial {
    pub omega: f64,
    pub stable: bool,
    /// Steady `hbar` from [`solve_at`] and the last simulated one.
    pub hbar_steady: f64,
    pub hbar_end: f64,
    /// Largest distance to the steady state (root mean square over the free positions, units of
    /// `ell`) in the window before the last and in the last one, and the growth rate
    /// `ln(last/before)/window` (solver units; compare `Re s`; `NaN` for a run that stopped
    /// early).
    pub distance_before: f64,
    pub distance_last: f64,
    pub growth: f64,
    /// True when the run stopped early because the distance grew past 4 times its largest
    /// value in the first window after the ramp.
    pub escaped: bool,
    /// Set when the integration broke down (the message): counted as unstable. From rest below
    /// `omega_b` the motion is a smooth approach to the steady state; a breakdown (Newton
    /// failing down to `dt_min`) comes from a violent departure, typically an edge turning
    /// towards the reverse of its natural direction, where the natural chart of the twist
    /// degenerates.
    pub breakdown: Option<String>,
    /// Simulated time, accepted steps, Newton iterations, exact Jacobians.
    pub t_end: f64,
    pub steps: usize,
    pub newton_iterations: usize,
    pub jacobians: usize,
}

impl Trial {
    /// One line for a log: the trial's rate relative to `omegabar_b` and its verdict.
    pub fn summary(&self, omegabar_b: f64) -> String {
        format!(
            "omega/omega_b = {:.5}: stable {}, growth {:.3}, escaped {}, breakdown {}, {} steps",
            self.omega / omegabar_b,
            self.stable,
            self.growth,
            self.escaped,
            self.breakdown.is_some(),
            self.steps
        )
    }
}

/// What [`bisect`] returns.
#[derive(Clone, Debug, Serialize)]
pub struct Bisection {
    /// Final bracket `(stable, unstable)` of `omegabar_b` and its midpoint.
    pub bracket: (f64, f64),
    pub estimate: f64,
    /// Total accepted time steps, Newton iterations and exact Jacobians over all trials.
    pub steps: usize,
    pub newton_iterations: usize,
    pub jacobians: usize,
    pub trials: Vec<Trial>,
}

/// Decides by simulation whether the steady state at `omega` (from [`solve_at`]) is what the
/// rod settles on after a spin-up from rest: ramp from the rest state to `omega` over
/// `ramp_time`, hold for `hold_time`, and measure the distance `d(t)` of the positions to the
/// steady ones. Unstable when the largest `d` in the last `window` exceeds the largest in the
/// window before (the motion grows), when the final `hbar` is off its steady value by more than
/// `departure`, when the integration breaks down ([`Trial::breakdown`]), or, ending the run
/// early, when `d` exceeds 4 times its largest value in the first window after the ramp; stable
/// otherwise (also when `d` has decayed to `1e-10`). Input errors are returned as errors.
pub fn trial(model: &Model, omega: f64, settings: &BisectSettings) -> Result<Trial> {
    settings.validate()?;
    if !(omega.is_finite() && omega != 0.0) {
        return Err(Error::input(
            "bisect.omega",
            format!("a trial rate must be finite and nonzero, got {omega}"),
        ));
    }
    let period = 2.0 * std::f64::consts::PI / omega.abs();
    let ramp_time = settings.ramp_time;
    let t_end = ramp_time + settings.hold_time;
    let window = settings.window;
    let rest = rest_state(model, &settings.newton)?;
    let h0 = height(&rest.config.x);
    let steady = solve_at(model, omega, &settings.newton)?;
    let hbar_steady = steady.observables.hbar;
    let x_steady: Vec<f64> = steady.state.config.x[Layout::CLAMPED_NODES..]
        .iter()
        .flat_map(|p| [p.x, p.y, p.z])
        .collect();
    let problem = Steady::new(model, omega);
    let u0 = problem.free_vector(&rest.config);
    let max_step = period / settings.steps_per_period;
    let dynamics = DynamicsSettings {
        dt_max: settings.dynamics.dt_max.min(max_step),
        dt0: settings.dynamics.dt0.min(max_step),
        dt_min: settings
            .dynamics
            .dt_min
            .min(settings.dynamics.dt0.min(max_step)),
        ..settings.dynamics.clone()
    };
    let nx = x_steady.len();
    let (mut before, mut last) = (0.0f64, 0.0f64);
    let mut first = 0.0f64;
    let mut escaped = false;
    let mut run_stats = Trajectory {
        last: Sample::empty(0.0, &model.chart),
        steps: 0,
        rejected: 0,
        newton_iterations: 0,
        jacobians: 0,
        stopped: false,
    };
    let mut hbar_end = 1.0;
    let outcome = run(
        model,
        Rate::Ramp {
            target: omega,
            ramp_time,
        },
        Start::Initial(u0),
        t_end,
        &dynamics,
        |s| {
            hbar_end = height(&problem.config(&s.u).x) / h0;
            let d = (s.u[..nx]
                .iter()
                .zip(&x_steady)
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                / nx as f64)
                .sqrt();
            if s.t > t_end - window {
                last = last.max(d);
            } else if s.t > t_end - 2.0 * window {
                before = before.max(d);
            }
            if s.t >= ramp_time && s.t <= ramp_time + window {
                first = first.max(d);
            } else if s.t > ramp_time + window && d > 4.0 * first {
                escaped = true;
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        },
        None,
        &mut run_stats,
    );
    let breakdown = match outcome {
        Ok(()) => None,
        Err(e) if e.is_input() => return Err(e),
        Err(e) => Some(e.to_string()),
    };
    let completed = breakdown.is_none() && !escaped;
    let growth = if completed {
        (last / before).ln() / window
    } else {
        f64::NAN
    };
    let converged = last <= 1e-10;
    let departed = (hbar_end / hbar_steady - 1.0).abs() > settings.departure;
    Ok(Trial {
        omega,
        stable: completed && (converged || (last < before && !departed)),
        hbar_steady,
        hbar_end,
        distance_before: before,
        distance_last: last,
        growth,
        escaped,
        breakdown,
        t_end: run_stats.last.t,
        steps: run_stats.steps,
        newton_iterations: run_stats.newton_iterations,
        jacobians: run_stats.jacobians,
    })
}

/// `omegabar_b` by bisection on simulations from rest (the way simulation studies found it):
/// `lo` must be stable and `hi` unstable by [`trial`] (checked, an error otherwise); the bracket
/// is halved until `|hi - lo| <= precision |hi|`. Both rates have one sign (the motor may turn
/// either way), `lo` the nearer to zero.
///
/// Near `omega_b` a verdict rests on the sign of the growth rate of the critical mode, which
/// vanishes there (`Re s ~ 0.25..0.36 (omegabar - omegabar_b)` for the representative helix at
/// `N = 30..60`) and is measured to about `+-0.1` with the default settings (BDF2 damping,
/// beating with the next mode, the finite windows): a trial within about `0.1%` of `omega_b`
/// can come out either way, well below the default precision `1e-2`. Each trial costs thousands of time steps; continuation
/// ([`crate::branch::locate`]) is two orders of magnitude faster for a far tighter bracket.
pub fn bisect(model: &Model, lo: f64, hi: f64, settings: &BisectSettings) -> Result<Bisection> {
    settings.validate()?;
    // The motor may turn either way: the bracket lies on one side of zero, `lo` nearer zero.
    if !(lo != 0.0 && lo * hi > 0.0 && hi.abs() > lo.abs() && hi.is_finite()) {
        return Err(Error::input(
            "--lo",
            format!("need finite rates of one sign with 0 < |lo| < |hi|, got lo = {lo}, hi = {hi}"),
        ));
    }
    let mut trials = vec![trial(model, lo, settings)?, trial(model, hi, settings)?];
    if !trials[0].stable || trials[1].stable {
        return Err(Error::Numerical(format!(
            "bisect: [{lo}, {hi}] is not a bracket (stable at lo: {}, at hi: {})",
            trials[0].stable, trials[1].stable
        )));
    }
    let (mut a, mut b) = (lo, hi);
    while (b - a).abs() > settings.precision * b.abs() {
        let mid = 0.5 * (a + b);
        let t = trial(model, mid, settings)?;
        if t.stable {
            a = mid;
        } else {
            b = mid;
        }
        trials.push(t);
    }
    Ok(Bisection {
        bracket: (a, b),
        estimate: 0.5 * (a + b),
        steps: trials.iter().map(|t| t.steps).sum(),
        newton_iterations: trials.iter().map(|t| t.newton_iterations).sum(),
        jacobians: trials.iter().map(|t| t.jacobians).sum(),
        trials,
    })
}

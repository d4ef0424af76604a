//! Time integration of the overdamped rod in the co-rotating frame (docs/model.md section 5): the
//! adaptive BDF2 integrator, the linear modes of a steady state, and a dynamic estimate of
//! `omega_b` by bisection.
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
//! the twist measured in the model's natural chart (as in [`crate::problem::rod::RodProblem`]); the
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

pub mod bisect;
pub mod integrator;
pub mod modes;

pub use bisect::{BisectSettings, Bisection, Trial, bisect, trial};
pub use integrator::{
    Checkpoints, DynamicsSettings, IntegratorState, Rate, Sample, Start, Trajectory, integrate,
    integrate_from,
};
pub use modes::{Mode, least_stable_mode, perturb};

//! The variable-step BDF2 integrator of the module docs of [`crate::analysis::dynamics`].

use std::ops::ControlFlow;

use faer::prelude::Solve;
use faer::{Mat, Side};
use serde::Serialize;

use crate::engine::newton::{Chord, Globalization, Iterate, Jacobians, Newton, System, norm};
use crate::error::{EngineError, ModelError, ensure};
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::{Error, Result};

use crate::model::rod::frame::rechart;
use crate::problem::step::{ImplicitStep, mass};
use crate::problem::twist::slave_twist;

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
    pub(super) fn empty(omega: f64, chart: &Chart) -> Self {
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
/// `Ok(Err(why))` when it does not converge (the step is retried shorter), with Newton's failure
/// or the model's refusal of an iterate (a mobility that is not positive definite). With `reuse_jacobian`, the
/// factorization in `cache` serves while it converges (the chord method: it is rebuilt when `c0`
/// changed by more than 20%, when the residual falls by less than a factor 3 in an iteration,
/// and once more from the start of the step if the solve fails).
fn newton_step(
    step: &ImplicitStep,
    guess: &[f64],
    settings: &DynamicsSettings,
    cache: &mut Factored,
    trajectory: &mut Trajectory,
) -> Result<std::result::Result<Vec<f64>, Error>> {
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
            Ok((u, report)) => (Ok(u), report.iterations),
            Err(e @ Error::Engine(EngineError::NewtonFailed { iterations, .. })) => {
                (Err(e), iterations)
            }
            Err(e @ Error::Model(ModelError::NotPositiveDefinite { .. })) => (Err(e), 0),
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
        if solution.is_ok() || !inherited {
            if solution.is_err() {
                cache.chord.clear();
            }
            return Ok(solution);
        }
        cache.chord.clear();
    }
}

/// What made the implicit step fail, and what to change: the fluid's operator refusing the
/// shape (Lighthill's where parts of the rod approach), or Newton's method not converging.
fn step_failure(why: &Error) -> String {
    match why {
        Error::Model(ModelError::NotPositiveDefinite { geometry, .. }) => format!(
            "the mobility of the moving rod stopped being positive definite ({geometry}); the \
             RPY line is positive definite for every shape: --set fluid.model=rpy (docs/model.md \
             section 9)"
        ),
        other => format!(
            "Newton's method on the implicit step did not converge ({other}); lower \
             integrator.dt_max or integrator.rtol, or take a fresh Jacobian at every iteration: \
             --set integrator.jacobian=newton"
        ),
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
pub(super) fn run(
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
            let seconds = model.scales.time;
            return Err(Error::Numerical(format!(
                "time integration: {} steps reached at t = {:.4} s (t_end = {:.4} s)",
                settings.max_steps,
                t * seconds,
                t_end * seconds
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
        let u = match solved {
            Ok(u) => u,
            Err(why) => {
                trajectory.rejected += 1;
                let seconds = model.scales.time;
                if !settings.adaptive {
                    return Err(Error::Numerical(format!(
                        "time integration: the implicit step failed at t = {:.4} s with the fixed \
                         step {:.3e} s: {}",
                        t * seconds,
                        h * seconds,
                        step_failure(&why)
                    )));
                }
                h *= 0.25;
                just_rejected = true;
                if h < settings.dt_min {
                    return Err(Error::Numerical(format!(
                        "time integration: the step fell below dt_min = {:.1e} s at t = {:.4} s \
                         (omega = {:.6} rad/s): {}",
                        settings.dt_min * seconds,
                        t * seconds,
                        rate.at(t) / seconds,
                        step_failure(&why)
                    )));
                }
                continue;
            }
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
                    let seconds = model.scales.time;
                    return Err(Error::Numerical(format!(
                        "time integration: the step fell below dt_min = {:.1e} s at t = {:.4} s \
                         (omega = {:.6} rad/s): the local error test failed at every step tried \
                         (error {err:.2e} of the tolerance); loosen integrator.rtol or \
                         integrator.atol, or look for a discontinuity of the motion there",
                        settings.dt_min * seconds,
                        t * seconds,
                        rate.at(t) / seconds,
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

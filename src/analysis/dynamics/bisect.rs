//! `omega_b` the way simulation studies found it: spin-ups from rest at trial rates, each judged
//! by whether the rod settles on the steady state, bisected.

use std::ops::ControlFlow;

use serde::Serialize;

use crate::analysis::solve::rest_state;
use crate::analysis::solve::solve_at;
use crate::engine::newton::NewtonSettings;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::model::steady::Steady;
use crate::{Error, Result};

use super::integrator::{DynamicsSettings, Rate, Sample, Start, Trajectory, run};

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
        self.newton
            .validate()
            .map_err(|e| e.naming_setting(|s| format!("newton.{s}")))
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
    let h0 = model.height(&rest.config.x);
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
            hbar_end = model.height(&problem.config(&s.u).x) / h0;
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
/// ([`crate::analysis::locate::locate`]) is two orders of magnitude faster for a far tighter bracket.
pub fn bisect(model: &Model, lo: f64, hi: f64, settings: &BisectSettings) -> Result<Bisection> {
    settings.validate()?;
    // The motor may turn either way: the bracket lies on one side of zero, `lo` nearer zero.
    // Rates in messages in rad/s, as the user gives them.
    let rad_s = |w: f64| model.scales.omega_from_bar(w);
    if !(lo != 0.0 && lo * hi > 0.0 && hi.abs() > lo.abs() && hi.is_finite()) {
        return Err(Error::input(
            "--lo",
            format!(
                "need finite rates of one sign with 0 < |lo| < |hi|, got lo = {} rad/s, hi = {} \
                 rad/s",
                rad_s(lo),
                rad_s(hi)
            ),
        ));
    }
    let mut trials = vec![trial(model, lo, settings)?, trial(model, hi, settings)?];
    if !trials[0].stable || trials[1].stable {
        return Err(Error::Numerical(format!(
            "bisect: [{}, {}] rad/s is not a bracket (stable at lo: {}, at hi: {})",
            rad_s(lo),
            rad_s(hi),
            trials[0].stable,
            trials[1].stable
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

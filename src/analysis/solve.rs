//! One steady state at a given rotation rate, with its observables: the `solve` command.

use serde::Serialize;

use crate::analysis::branch::trace;
use crate::analysis::refine::{OtherRule, at_nodes, error_orders, rule_error};
use crate::engine::ContinuationSettings;
use crate::engine::events::EventKind;
use crate::engine::newton::{self, NewtonReport, NewtonSettings};
use crate::engine::stop::Silent;
use crate::model::Model;
use crate::model::fluid::Fluid;
use crate::model::observables::Observables;
use crate::model::params::Physical;
use crate::model::steady::Steady;
use crate::numerics::extrapolation::first_order_error;
use crate::problem;
use crate::problem::rod::Parameter;
use crate::problem::steady::SteadyState;
use crate::{Error, Result};

/// A steady state with everything `helixbif solve` reports.
#[derive(Clone, Debug)]
pub struct Solution {
    pub state: SteadyState,
    /// The shape at rest (`omega = 0`), for `h0`.
    pub rest: SteadyState,
    pub observables: Observables,
    /// `F_p ell^2/EI` of the natural shape held rigid at the same rate.
    pub fpbar_rigid: f64,
}

/// Summary printed by `solve --json`.
#[derive(Clone, Debug, Serialize)]
pub struct SolutionSummary {
    #[serde(flatten)]
    pub observables: Observables,
    #[serde(rename = "Fp_rigid")]
    pub fp_rigid: f64,
    #[serde(rename = "Fpbar_rigid")]
    pub fpbar_rigid: f64,
    pub newton_iterations: usize,
    pub residual_norm: f64,
    pub residual_history: Vec<f64>,
    pub nodes: usize,
    /// The estimated errors of the observables ([`observable_errors`]), or why they could not
    /// be estimated (`errors_missing`).
    pub errors: Option<ObservableErrors>,
    pub errors_missing: Option<String>,
}

/// The estimated errors of a steady state's observables against the continuous model
/// (docs/model.md section 10), in their units. Each is the discretization error in `N` from
/// the same rate solved at a coarser rung of `N/2 + 1` nodes, the first-order estimate
///
/// ```text
/// e = |v_f - v_c| h_f / (h_c - h_f)      (h the spacing of the fluid model's orders)
/// ```
///
/// which bounds the error where the observables converge monotonically at any order at least 1,
/// plus on the RPY line the quadrature's own error, measured at the coarser rung with the
/// other rule of `locate`'s refinement (half the points per blob radius, or twice;
/// `(v(P) - v(r P)) / (1 - r^-2)`, docs/model.md section 9). Not the second-order estimate of
/// the RPY line's known order: at the coarse rungs a study starts from, the observables converge
/// at observed orders below 2 (on the representative helix at 0.4 rad/s, `N = 31, 60` gave a
/// second-order estimate of `Fp` at `N = 60` 15% below its difference to `N = 237`; the
/// first-order one is 2.7 times it).
#[derive(Clone, Debug, Serialize)]
pub struct ObservableErrors {
    /// The coarser rung.
    pub coarse_nodes: usize,
    #[serde(rename = "Fp")]
    pub fp: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    #[serde(rename = "Tp")]
    pub tp: f64,
    pub eta: Option<f64>,
    pub h: f64,
    pub h0: f64,
    pub hbar: f64,
    #[serde(rename = "Fpbar_rigid")]
    pub fpbar_rigid: f64,
    /// The points per blob radius of the rule the quadrature's error was measured against
    /// (RPY line; then it is in the errors).
    pub quadrature_compared_with: Option<f64>,
    /// Why the quadrature's error is not in the errors on the RPY line (no other rule, or its
    /// solve failed); absent on Lighthill's operator, which has no quadrature of its own.
    pub quadrature_missing: Option<String>,
}

/// The observables of `s` in the order of [`ObservableErrors`]' fields (`eta` NaN at rest).
fn values(s: &Solution) -> [f64; 8] {
    let o = &s.observables;
    [
        o.fp,
        o.fpbar,
        o.tp,
        o.eta.unwrap_or(f64::NAN),
        o.h,
        o.h0,
        o.hbar,
        s.fpbar_rigid,
    ]
}

/// [`ObservableErrors`] of `fine`, the solution of `physical` at its `N`, or why they could not
/// be estimated: an `N` without a coarser rung of at least 5 nodes, or a coarser rung that
/// cannot reach the rate.
pub fn observable_errors(
    physical: &Physical,
    fine: &Solution,
    settings: &NewtonSettings,
) -> std::result::Result<ObservableErrors, String> {
    let nodes = physical.discretization.nodes;
    let coarse_nodes = nodes / 2 + 1;
    if coarse_nodes < 5 {
        return Err(format!(
            "N = {nodes} has no coarser rung of at least 5 nodes"
        ));
    }
    let omegabar = fine.observables.omegabar;
    let at_coarse = |e: Error| format!("the coarser rung at N = {coarse_nodes} failed: {e}");
    let coarse_model = Model::new(&at_nodes(physical, coarse_nodes)).map_err(at_coarse)?;
    let coarse = solve_at(&coarse_model, omegabar, settings).map_err(at_coarse)?;
    let orders = error_orders(physical);
    let vc = values(&coarse);
    let mut errors: Vec<f64> = vc
        .iter()
        .zip(values(fine))
        .map(|(&c, f)| first_order_error(orders, (coarse_nodes, c), (nodes, f)))
        .collect();
    // The quadrature's own error at the coarser rung, against the other rule.
    let (mut quadrature_compared_with, mut quadrature_missing) = (None, None);
    if matches!(coarse_model.fluid, Fluid::Rpy(_)) {
        let other = OtherRule::of(physical, &coarse_model).unwrap_or_else(|e| {
            Err(format!(
                "the other quadrature rule at N = {coarse_nodes} could not be built: {e}"
            ))
        });
        let measured = other.and_then(|other| {
            let solved = solve_at(&other.model, omegabar, settings).map_err(|e| {
                format!(
                    "the solve at N = {coarse_nodes} with {} points per blob radius failed: {e}",
                    other.points_per_blob
                )
            })?;
            Ok((other, solved))
        });
        match measured {
            Ok((other, solved)) => {
                for ((e, q), c) in errors.iter_mut().zip(values(&solved)).zip(vc) {
                    *e += rule_error(c, q, other.ratio).abs();
                }
                quadrature_compared_with = Some(other.points_per_blob);
            }
            Err(why) => quadrature_missing = Some(why),
        }
    }
    let eta = fine.observables.eta.map(|_| errors[3]);
    Ok(ObservableErrors {
        coarse_nodes,
        fp: errors[0],
        fpbar: errors[1],
        tp: errors[2],
        eta,
        h: errors[4],
        h0: errors[5],
        hbar: errors[6],
        fpbar_rigid: errors[7],
        quadrature_compared_with,
        quadrature_missing,
    })
}

/// Newton iterations allowed per ramp step before the step is halved (a step inside Newton's
/// basin converges in at most about 7).
const RAMP_ITERATIONS: usize = 8;
/// Smallest ramp step, relative to the target rate, before giving up.
const RAMP_MIN_FRACTION: f64 = 1e-4;

/// `(omegabar, weight)` of `model` with the ramp's parameter at `v`.
fn loads(model: &Model, parameter: Parameter, v: f64) -> (f64, f64) {
    match parameter {
        Parameter::Omega => (v, model.weight),
        Parameter::Weight => (0.0, v),
    }
}

/// The ramp's parameter at `state`.
fn parameter_value(parameter: Parameter, state: &SteadyState) -> f64 {
    match parameter {
        Parameter::Omega => state.omega,
        Parameter::Weight => state.weight,
    }
}

/// The shape hanging at rest (`omega = 0`): Newton's method from the natural shape, the weight
/// ramped up from zero (where the natural shape is exact) when a heavy rod defeats a direct
/// solve.
pub fn rest_state(model: &Model, settings: &NewtonSettings) -> Result<SteadyState> {
    let natural = model.natural_config();
    problem::steady::solve(model, 0.0, model.weight, &natural, &model.chart, settings).or_else(
        |_| {
            let weightless =
                problem::steady::solve(model, 0.0, 0.0, &natural, &model.chart, settings)?;
            ramp(
                model,
                &weightless,
                Parameter::Weight,
                model.weight,
                settings,
            )
        },
    )
}

/// Solves for the steady state at `omegabar`: first the shape hanging at rest, then the rotating
/// state reached by ramping the rate from rest with adaptive steps (the motor spinning up). Each
/// step starts from the tangent predictor at the last state ([`predict`]), so that Newton
/// starts inside its (narrow) basin of quadratic convergence; a step whose Newton solve fails is
/// halved, an easy one doubled. The report counts every Newton iteration of the ramp (not the
/// one linearization per step that each prediction costs).
pub fn solve_at(model: &Model, omegabar: f64, settings: &NewtonSettings) -> Result<Solution> {
    // At rest no fluid acts, so any node count is admissible; a rotating state needs a
    // positive mobility (refused before any work at that size).
    if omegabar != 0.0 {
        model.check_resolution()?;
    }
    let rest = rest_state(model, settings)?;
    let state = ramp(model, &rest, Parameter::Omega, omegabar, settings)
        .map_err(|e| unreachable(model, &rest, omegabar, e))?;
    let observables =
        model.steady_observables(omegabar, &state.config.x, model.height(&rest.config.x))?;
    Ok(Solution {
        fpbar_rigid: model.rigid_thrust(omegabar)?,
        state,
        rest,
        observables,
    })
}

/// Why a ramp from rest to `omegabar` failed with `failure`: where the branch from rest turns
/// back at a fold before the rate (followed by pseudo-arclength continuation, which passes the
/// fold), there is no steady state on it at `omegabar`, and the error says so with the fold's
/// rate; otherwise `failure` itself.
fn unreachable(model: &Model, rest: &SteadyState, omegabar: f64, failure: Error) -> Error {
    if omegabar == 0.0 || failure.is_input() {
        return failure;
    }
    let Ok(branch) = trace(
        model,
        rest,
        omegabar,
        &ContinuationSettings::default(),
        false,
        &mut Silent,
    ) else {
        return failure;
    };
    let reached = branch
        .points
        .iter()
        .any(|p| p.p.abs() >= omegabar.abs() && p.p * omegabar > 0.0);
    let fold = branch
        .events
        .iter()
        .find(|e| e.kind == EventKind::Fold && e.p * omegabar > 0.0 && e.p.abs() < omegabar.abs());
    match (reached, fold) {
        (false, Some(fold)) => {
            let s = &model.scales;
            Error::Numerical(format!(
                "no steady state at omega = {} rad/s on the branch from rest: it turns back at a \
                 fold at omega = {:.6} rad/s (omegabar = {:.6e}) and does not reach that rate",
                s.omega_from_bar(omegabar),
                s.omega_from_bar(fold.p),
                fold.p
            ))
        }
        _ => failure,
    }
}

/// The problem whose solution `state` is, in the chart carried to it.
fn problem_at<'a>(model: &'a Model, state: &SteadyState) -> Steady<'a> {
    Steady {
        model,
        omega: state.omega,
        weight: state.weight,
        chart: state.chart.clone(),
    }
}

/// The tangent of the ramp at its solution `current`: `du/dv = -G_u^{-1} dG/dv` (free unknowns,
/// in the chart carried to `current`), or `None` where `G_u` is singular.
fn ramp_tangent(model: &Model, load: Parameter, current: &SteadyState) -> Result<Option<Vec<f64>>> {
    let problem = problem_at(model, current);
    let u = problem.free_vector(&current.config);
    let lin = problem.linearize(&u)?;
    let derivative = match load {
        Parameter::Omega => problem.rate_derivative(&lin)?,
        Parameter::Weight => problem.weight_derivative(),
    };
    let rhs = faer::Mat::from_fn(u.len(), 1, |i, _| -derivative[i]);
    let du = crate::numerics::lu::Lu::of(lin.jacobian).solve(rhs.as_ref());
    let tangent: Vec<f64> = (0..u.len()).map(|i| du[(i, 0)]).collect();
    Ok(tangent.iter().all(|v| v.is_finite()).then_some(tangent))
}

/// The state at load `v + dv` predicted from the solution `current` (at `v`) along its
/// `tangent`: the step `dv du/dv` applied through the retraction (edges turned and stretched,
/// not translated: a linear step would stretch turning edges at second order, which the stiff
/// stretching turns into a large residual). Without a tangent, `current` itself.
fn predict(
    model: &Model,
    current: &SteadyState,
    tangent: Option<&[f64]>,
    dv: f64,
) -> crate::model::rod::Config {
    let Some(tangent) = tangent else {
        return current.config.clone();
    };
    let problem = problem_at(model, current);
    let u = problem.free_vector(&current.config);
    let step: Vec<f64> = tangent.iter().map(|t| dv * t).collect();
    problem.config(&newton::System::retract(&problem, &u, &step))
}

/// Natural-parameter continuation of `load` from the state `start` to `target`, with the tangent
/// predictor. The step is doubled after an easy solve (at most 4 iterations), shortened after a
/// laborious one (7 or more) and halved after a failure.
pub(crate) fn ramp(
    model: &Model,
    start: &SteadyState,
    load: Parameter,
    target: f64,
    settings: &NewtonSettings,
) -> Result<SteadyState> {
    let step_settings = NewtonSettings {
        max_iter: settings.max_iter.min(RAMP_ITERATIONS),
        ..settings.clone()
    };
    let mut current = start.clone();
    // The ramp's tangent at `current`, made once per state short of the target and shared by
    // the retries from it.
    let tangent_at = |state: &SteadyState| -> Result<Option<Vec<f64>>> {
        if parameter_value(load, state) == target {
            Ok(None)
        } else {
            ramp_tangent(model, load, state)
        }
    };
    let mut tangent = tangent_at(&current)?;
    let mut step = target - parameter_value(load, start);
    let mut iterations = start.report.iterations;
    let mut history = start.report.history.clone();
    while parameter_value(load, &current) != target {
        let here = parameter_value(load, &current);
        let value = if (target - here).abs() <= step.abs() {
            target
        } else {
            here + step
        };
        let (omega, weight) = loads(model, load, value);
        let guess = predict(model, &current, tangent.as_deref(), value - here);
        match problem::steady::solve(model, omega, weight, &guess, &current.chart, &step_settings) {
            Ok(next) => {
                iterations += next.report.iterations;
                history.extend_from_slice(&next.report.history);
                match next.report.iterations {
                    0..=4 => step *= 2.0,
                    7.. => step *= 0.7,
                    _ => {}
                }
                current = next;
                tangent = tangent_at(&current)?;
            }
            Err(e) => {
                step *= 0.5;
                if step.abs() < RAMP_MIN_FRACTION * target.abs() {
                    return Err(e);
                }
            }
        }
    }
    current.report = NewtonReport {
        iterations,
        residual_norm: current.report.residual_norm,
        history,
        precision: current.report.precision,
    };
    Ok(current)
}

impl Solution {
    /// What `helixbif solve` reports: the observables of `model` with their estimated
    /// `errors` ([`observable_errors`], or why there are none).
    pub fn summary(
        &self,
        model: &Model,
        errors: std::result::Result<ObservableErrors, String>,
    ) -> SolutionSummary {
        let (errors, errors_missing) = match errors {
            Ok(e) => (Some(e), None),
            Err(why) => (None, Some(why)),
        };
        SolutionSummary {
            errors,
            errors_missing,
            observables: self.observables.clone(),
            fp_rigid: self.fpbar_rigid * model.scales.force,
            fpbar_rigid: self.fpbar_rigid,
            newton_iterations: self.state.report.iterations,
            residual_norm: self.state.report.residual_norm,
            residual_history: self.state.report.history.clone(),
            nodes: model.nodes(),
        }
    }
}

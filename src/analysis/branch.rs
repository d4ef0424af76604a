//! The branch of steady states from rest: pseudo-arclength continuation in `omegabar` from the
//! shape at rest, in either direction of rotation, and the observables along it.

use crate::Result;
use crate::engine::ContinuationSettings;
use crate::engine::arclength::{Branch, Limits, Point, follow};
use crate::engine::events::Event;
use crate::engine::stop::Observer;
use crate::model::Model;
use crate::model::observables::Observables;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::problem::rod::{Parameter, RodProblem, omega_scale};
use crate::problem::steady::SteadyState;

/// Continuation in `omegabar` from rest up to `omegabar_max`, which may be negative (the motor
/// turning clockwise seen from above): the branch is then followed towards negative rates.
pub fn trace(
    model: &Model,
    rest: &SteadyState,
    omegabar_max: f64,
    settings: &ContinuationSettings,
    stop_at_first_instability: bool,
    observer: &mut impl Observer<Point, Event>,
) -> Result<Branch> {
    let (branch, _) = trace_in_chart(
        model,
        rest,
        omegabar_max,
        settings,
        stop_at_first_instability,
        observer,
    )?;
    Ok(branch)
}

/// [`trace`], with the chart the last points and events are measured in.
pub(crate) fn trace_in_chart(
    model: &Model,
    rest: &SteadyState,
    omegabar_max: f64,
    settings: &ContinuationSettings,
    stop_at_first_instability: bool,
    observer: &mut impl Observer<Point, Event>,
) -> Result<(Branch, Chart)> {
    model.check_resolution()?;
    if !model.fluid.is_mass_matrix() {
        return Err(crate::Error::input(
            "fluid.quadrature",
            "the original quadrature's mobility is indefinite (A_ii t_i = 0), so Z_ff is no mass \
             matrix for the stability problem: continuation needs \"reference\"",
        ));
    }
    let problem = RodProblem::new(model, Parameter::Omega, omega_scale(omegabar_max));
    let u0 = problem.steady(0.0).free_vector(&rest.config);
    // A fold may take the branch back past rest, a little.
    let limits = Limits {
        p_min: omegabar_max.min(-0.5 * omegabar_max),
        p_max: omegabar_max.max(-0.5 * omegabar_max),
        stop_at_first_instability,
    };
    let direction = omegabar_max.signum();
    let branch = follow(&problem, u0, 0.0, direction, settings, &limits, observer)?;
    Ok((branch, problem.chart()))
}

/// Observables of the solution `u` at `omegabar` on a branch from `rest`.
pub fn observables_at(
    model: &Model,
    rest: &SteadyState,
    u: &[f64],
    omegabar: f64,
) -> Result<Observables> {
    let x = Steady::new(model, omegabar).config(u).x;
    model.steady_observables(omegabar, &x, model.height(&rest.config.x))
}

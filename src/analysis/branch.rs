//! The branch of steady states from rest: pseudo-arclength continuation in `omegabar` from the
//! shape at rest, in either direction of rotation, and the observables along it.

use std::ops::ControlFlow;

use crate::Result;
use crate::analysis::near_miss::{NearMisses, Seek, probe_near_misses};
use crate::engine::ContinuationSettings;
use crate::engine::arclength::{Branch, Limits, Point, follow};
use crate::engine::events::Event;
use crate::engine::newton::NewtonSettings;
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
    let traced = trace_charted(
        model,
        rest,
        omegabar_max,
        settings,
        stop_at_first_instability,
        observer,
    )?;
    Ok(traced.branch)
}

/// A branch from rest with the charts its twist angles are measured in: the continuation moves
/// the chart to each point it accepts ([`crate::engine::Problem::rechart`]), so each point has
/// its own.
pub struct Traced {
    pub branch: Branch,
    /// The chart of each point of `branch`, in order.
    pub charts: Vec<Chart>,
    /// The chart of the last point and of the events after it.
    pub chart: Chart,
}

/// Passes the points and events of a run on to `inner`, recording the problem's chart as each
/// point is told (the one it is measured in: the chart moves only when the next step starts).
struct Charting<'a, 'm, O> {
    problem: &'a RodProblem<&'m Model>,
    inner: &'a mut O,
    charts: Vec<Chart>,
}

impl<O: Observer<Point, Event>> Observer<Point, Event> for Charting<'_, '_, O> {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        self.charts.push(self.problem.chart());
        self.inner.point(point)
    }
    fn event(&mut self, event: &Event) -> ControlFlow<()> {
        self.inner.event(event)
    }
}

/// [`trace`], with the chart of every point and the last one ([`Traced`]).
pub(crate) fn trace_charted(
    model: &Model,
    rest: &SteadyState,
    omegabar_max: f64,
    settings: &ContinuationSettings,
    stop_at_first_instability: bool,
    observer: &mut impl Observer<Point, Event>,
) -> Result<Traced> {
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
    let mut charting = Charting {
        problem: &problem,
        inner: observer,
        charts: Vec::new(),
    };
    let branch = follow(
        &problem,
        u0,
        0.0,
        direction,
        settings,
        &limits,
        &mut charting,
    )?;
    Ok(Traced {
        branch,
        charts: charting.charts,
        chart: problem.chart(),
    })
}

/// The windows of instability inside the steps of a branch from rest followed to
/// `omegabar_max`, each with its loss and regain of stability, found by probing the near misses
/// of its stable points ([`crate::analysis::near_miss`], docs/model.md section 5): the events a
/// continuation sees are the changes of the unstable count between its points, and a mode that
/// crosses the axis and comes back inside one step changes none. Its states are measured in the
/// natural chart.
pub fn probe_windows(
    model: &Model,
    traced: &Traced,
    omegabar_max: f64,
    newton: &NewtonSettings,
    settings: &ContinuationSettings,
) -> Result<NearMisses> {
    let problem = RodProblem::new(model, Parameter::Omega, omega_scale(omegabar_max));
    probe_near_misses(
        model,
        &problem,
        (&traced.branch.points, &traced.charts),
        omegabar_max,
        (newton, settings),
        Seek::EveryWindow,
    )
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

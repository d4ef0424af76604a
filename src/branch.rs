//! The rotating rod as a continuation problem (parameter `omegabar` or the weight `q`), and the
//! drivers of `helixbif branch` and `helixbif locate`.

use faer::Mat;
use serde::Serialize;

use crate::Result;
use crate::continuation::arclength::{Branch, Limits, Observer, Stop, follow};
use crate::continuation::events::{Event, EventKind};
use crate::continuation::newton::{NewtonSettings, System};
use crate::continuation::{ContinuationSettings, Linearization, Problem};
use crate::model::Model;
use crate::steady::{Observables, Steady, SteadyState, height};

/// The continuation parameter of the rod.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parameter {
    /// The rotation rate `omegabar` (weight fixed at the model's).
    Omega,
    /// The weight per length `q ell^3 / EI` (no rotation): statics, e.g. Greenhill's column.
    Weight,
}

/// Typical change of a position unknown (solver units: a twentieth of the reference length) and
/// of the parameters: the units of the arclength.
const POSITION_SCALE: f64 = 5e-2;
const OMEGA_SCALE: f64 = 10.0;
const WEIGHT_SCALE: f64 = 1.0;

/// The steady rod problem `G(u; p) = 0` with `p` the chosen [`Parameter`].
pub struct RodProblem<'a> {
    pub model: &'a Model,
    pub parameter: Parameter,
}

impl<'a> RodProblem<'a> {
    /// The steady problem at parameter value `p` (twist measured in the natural chart).
    pub fn steady(&self, p: f64) -> Steady<'a> {
        let mut s = Steady::new(self.model, 0.0);
        match self.parameter {
            Parameter::Omega => s.omega = p,
            Parameter::Weight => s.weight = p,
        }
        s
    }
}

impl Problem for RodProblem<'_> {
    fn dim(&self) -> usize {
        self.model.rod.layout.free_len()
    }

    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        self.steady(p).residual(u)
    }

    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        let steady = self.steady(p);
        let lin = steady.linearize(u)?;
        let g_p = match self.parameter {
            Parameter::Omega => steady.rate_derivative(&lin)?,
            Parameter::Weight => steady.weight_derivative(),
        };
        Ok(Linearization {
            g: lin.residual,
            g_u: lin.jacobian,
            g_p,
        })
    }

    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.steady(0.0).retract(u, du)
    }

    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        self.steady(p).stability_pair_from(u, &lin.g_u)
    }

    fn scales(&self) -> (f64, f64) {
        match self.parameter {
            Parameter::Omega => (POSITION_SCALE, OMEGA_SCALE),
            Parameter::Weight => (POSITION_SCALE, WEIGHT_SCALE),
        }
    }
}

pub use crate::solve::rest_state;

/// Continuation in `omegabar` from rest up to `omegabar_max`.
pub fn trace(
    model: &Model,
    rest: &SteadyState,
    omegabar_max: f64,
    settings: &ContinuationSettings,
    stop_at_first_instability: bool,
    observer: &mut impl Observer,
) -> Result<Branch> {
    model.check_resolution()?;
    if !model.fluid.is_mass_matrix() {
        return Err(crate::Error::input(
            "fluid.quadrature",
            "the original quadrature's mobility is indefinite (A_ii t_i = 0), so Z_ff is no mass \
             matrix for the stability problem: continuation needs \"reference\"",
        ));
    }
    let problem = RodProblem {
        model,
        parameter: Parameter::Omega,
    };
    let u0 = problem.steady(0.0).free_vector(&rest.config);
    let limits = Limits {
        p_min: -omegabar_max.abs() * 0.5,
        p_max: omegabar_max,
        stop_at_first_instability,
    };
    follow(&problem, u0, 0.0, 1.0, settings, &limits, observer)
}

/// Observables of the solution `u` at `omegabar` on a branch from `rest`.
pub fn observables_at(
    model: &Model,
    rest: &SteadyState,
    u: &[f64],
    omegabar: f64,
) -> Result<Observables> {
    let steady = Steady::new(model, omegabar);
    let config = steady.config(u);
    let forces = match steady.drag(&config.x)? {
        Some(d) => d.forces,
        None => vec![nalgebra::Vector3::zeros(); model.nodes()],
    };
    Ok(model.observables(omegabar, &config.x, &forces, height(&rest.config.x)))
}

/// What `helixbif locate` reports.
#[derive(Clone, Debug, Serialize)]
pub struct Located {
    /// `hopf`, `fold`, `branch_point`, or `none` when the branch stays stable up to `omega_max`.
    pub kind: String,
    pub omega_b: Option<f64>,
    pub omegabar_b: Option<f64>,
    /// Critical frequency `Im(s)` of the mode (rad/s) and normalized (`Im(s) mu ell^4/EI`).
    pub im: Option<f64>,
    pub imbar: Option<f64>,
    #[serde(rename = "Fp")]
    pub fp: Option<f64>,
    #[serde(rename = "Fpbar")]
    pub fpbar: Option<f64>,
    pub hbar: Option<f64>,
    pub nodes: usize,
    /// Relative width of the final bracket in `omega`.
    pub precision: Option<f64>,
    /// Largest rate followed (rad/s) when no instability was found.
    pub omega_max: f64,
    pub points: usize,
    pub corrector_iterations: usize,
}

/// Follows the branch from rest to its first loss of stability and pins it down.
pub fn locate(
    model: &Model,
    omega_max: f64,
    newton: &NewtonSettings,
    settings: &ContinuationSettings,
    observer: &mut impl Observer,
) -> Result<(Located, Option<Event>)> {
    let rest = rest_state(model, newton)?;
    let omegabar_max = model.scales.omega_to_bar(omega_max);
    let branch = trace(model, &rest, omegabar_max, settings, true, observer)?;
    let points = branch.points.len();
    let corrector_iterations = branch.points.iter().map(|p| p.iterations).sum();
    let none = Located {
        kind: "none".into(),
        omega_b: None,
        omegabar_b: None,
        im: None,
        imbar: None,
        fp: None,
        fpbar: None,
        hbar: None,
        nodes: model.nodes(),
        precision: None,
        omega_max,
        points,
        corrector_iterations,
    };
    let reached = branch.points.last().map_or(0.0, |p| p.p);
    match branch.stop {
        Stop::FirstInstability => {}
        Stop::ParameterLimit if reached > omegabar_max => return Ok((none, None)),
        Stop::StepTooSmall(reason) => {
            return Err(crate::Error::Numerical(format!(
                "continuation stalled at omega = {:.6e} rad/s before any instability: {reason}",
                model.scales.omega_from_bar(reached)
            )));
        }
        Stop::ParameterLimit | Stop::MaxPoints => {
            return Err(crate::Error::Numerical(format!(
                "the branch turned back or ran out of points (continuation.max_points) at omega = \
                 {:.6e} rad/s before omega_max = {omega_max} rad/s, with no instability found",
                model.scales.omega_from_bar(reached)
            )));
        }
    }
    let event = branch
        .events
        .last()
        .expect("a first instability is an event")
        .clone();
    let o = observables_at(model, &rest, &event.u, event.p)?;
    let s = &model.scales;
    let imbar = event.eigenvalue.im.abs();
    let located = Located {
        kind: event.kind.name().into(),
        omega_b: Some(o.omega),
        omegabar_b: Some(event.p),
        im: (event.kind == EventKind::Hopf).then(|| s.omega_from_bar(imbar)),
        imbar: (event.kind == EventKind::Hopf).then_some(imbar),
        fp: Some(o.fp),
        fpbar: Some(o.fpbar),
        hbar: Some(o.hbar),
        precision: Some(event.precision),
        ..none
    };
    Ok((located, Some(event)))
}

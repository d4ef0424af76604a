//! The branch from rest and its first loss of stability: continuation in `omegabar` from the
//! shape at rest, the event that ends stability pinned down, and at a Hopf point its first
//! Lyapunov coefficient (what `helixbif locate` and `helixbif branch` compute).

use serde::Serialize;

use crate::Result;
use crate::engine::arclength::{BranchStop, Point};
use crate::engine::criticality::{Lyapunov, STARTS, Verdict, first_lyapunov_from};
use crate::engine::events::{Event, EventKind};
use crate::engine::newton::NewtonSettings;
use crate::engine::stability::Spectrum;
use crate::engine::stop::{Observer, Stop};
use crate::engine::{ContinuationSettings, Problem};
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::problem::steady::SteadyState;

use crate::analysis::branch::{Traced, observables_at, trace_charted};
use crate::analysis::near_miss::{NearMisses, Seek, probe_near_misses};
use crate::analysis::solve::rest_state;
use crate::problem::rod::{OMEGA_SCALE, Parameter, RodProblem, omega_scale};

/// What locating the first loss of stability needs besides the model: the rate (rad/s, signed)
/// up to which the branch from rest is followed, and the settings of the steady solves and of
/// the continuation.
#[derive(Clone, Copy, Debug)]
pub struct LocateSettings<'a> {
    pub omega_max: f64,
    pub newton: &'a NewtonSettings,
    pub continuation: &'a ContinuationSettings,
    /// Whether a Hopf point gets its first Lyapunov coefficient (a refinement computes it at
    /// its finest rung only).
    pub criticality: bool,
}

/// What ends the stability of the branch from rest.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Loss {
    /// The first loss of stability: a Hopf point, a fold or a branch point.
    Event(EventKind),
    /// The state at `omega = 0` is already unstable: there is nothing to locate.
    UnstableAtRest,
    /// The branch stays stable up to `omega_max`.
    None,
}

impl Loss {
    /// The name used in files and reports: the event's (`hopf`, `fold`, `branch_point`),
    /// `unstable_at_rest` or `none`.
    pub fn name(self) -> &'static str {
        match self {
            Loss::Event(kind) => kind.name(),
            Loss::UnstableAtRest => "unstable_at_rest",
            Loss::None => "none",
        }
    }
}

impl std::fmt::Display for Loss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl Serialize for Loss {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// What `helixbif locate` reports.
#[derive(Clone, Debug, Serialize)]
pub struct Located {
    /// What ends stability ([`Loss`]).
    pub kind: Loss,
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
    /// Number of unstable eigenvalues of the rest state (0 unless `kind` is
    /// `unstable_at_rest`).
    pub unstable_at_rest: usize,
    /// Largest rate followed (rad/s) when no instability was found.
    pub omega_max: f64,
    pub points: usize,
    pub corrector_iterations: usize,
    /// At a Hopf point: the first Lyapunov coefficient `l1` (solver units `EI/(mu ell^6)`, for the
    /// critical mode scaled to a largest node displacement of `ell`: [`hopf_criticality`];
    /// docs/model.md section 12), its estimated error, and the verdict `supercritical` /
    /// `subcritical` / `undetermined`.
    pub l1: Option<f64>,
    pub l1_precision: Option<f64>,
    pub criticality: Option<Verdict>,
    /// Why the coefficient of a Hopf point could not be computed, if it could not.
    pub l1_failure: Option<String>,
    /// States solved to search the near misses of the branch (a mode rising towards the axis
    /// and falling back between two points) for a window of instability inside a step
    /// ([`crate::analysis::near_miss`]; the solves that locate a window's loss are not counted).
    pub probes: usize,
    /// Where the continuation stepped over a window of instability that a probe found (the
    /// rates, rad/s, of the two points of the step it lies in): the answer is the window's loss.
    pub window_between: Option<[f64; 2]>,
    /// A near miss whose probes neither found nor excluded a window, and why.
    pub near_miss_unresolved: Option<String>,
}

/// The first Lyapunov coefficient of the Hopf point `event` of the rod's branch in `omegabar`,
/// whose state is measured in `chart` (critical mode scaled by [`RodProblem`]'s mode size: a
/// largest node displacement of `ell`).
pub fn hopf_criticality(model: &Model, event: &Event, chart: &Chart) -> Result<Lyapunov> {
    hopf_criticality_from(model, event, chart, &STARTS)
}

/// [`hopf_criticality`] with the difference tableau started at each of `starts` in turn
/// ([`first_lyapunov_from`]; one start alone measures that start's coefficient).
pub fn hopf_criticality_from(
    model: &Model,
    event: &Event,
    chart: &Chart,
    starts: &[f64],
) -> Result<Lyapunov> {
    let problem = RodProblem::new(model, Parameter::Omega, OMEGA_SCALE);
    problem.set_chart(chart.clone());
    let lin = problem.linearize(&event.u, event.p)?;
    first_lyapunov_from(&problem, &event.u, event.p, &lin, event.eigenvalue, starts)?
        .ok_or_else(|| crate::Error::Numerical("the rod defines its dynamics".into()))
}

impl Located {
    /// The report of a branch of `model` stable up to `omega_max` (rad/s), before any count.
    pub fn none(model: &Model, omega_max: f64) -> Located {
        Located {
            kind: Loss::None,
            omega_b: None,
            omegabar_b: None,
            im: None,
            imbar: None,
            fp: None,
            fpbar: None,
            hbar: None,
            nodes: model.nodes(),
            precision: None,
            unstable_at_rest: 0,
            omega_max,
            points: 0,
            corrector_iterations: 0,
            l1: None,
            l1_precision: None,
            criticality: None,
            l1_failure: None,
            probes: 0,
            window_between: None,
            near_miss_unresolved: None,
        }
    }

    /// The report of the loss of stability at `event` of `model`'s branch from `rest`, the
    /// counts those of `self` (without the Lyapunov coefficient: [`Located::with_criticality`]).
    pub fn at_event(self, model: &Model, rest: &SteadyState, event: &Event) -> Result<Located> {
        let o = observables_at(model, rest, &event.u, event.p)?;
        let s = &model.scales;
        let imbar = event.eigenvalue.im.abs();
        let hopf = event.kind == EventKind::Hopf;
        Ok(Located {
            kind: Loss::Event(event.kind),
            omega_b: Some(o.omega),
            omegabar_b: Some(event.p),
            im: hopf.then(|| s.omega_from_bar(imbar)),
            imbar: hopf.then_some(imbar),
            fp: Some(o.fp),
            fpbar: Some(o.fpbar),
            hbar: Some(o.hbar),
            precision: Some(event.precision),
            ..self
        })
    }

    /// At a Hopf point `event` (its state measured in `chart`), the report with the first
    /// Lyapunov coefficient and the verdict; a coefficient that cannot be computed does not take
    /// away `omega_b`: the report says why.
    pub fn with_criticality(self, model: &Model, event: &Event, chart: &Chart) -> Located {
        if event.kind != EventKind::Hopf {
            return self;
        }
        match hopf_criticality(model, event, chart) {
            Ok(l) => Located {
                l1: Some(l.l1),
                l1_precision: Some(l.precision),
                criticality: Some(l.verdict),
                l1_failure: None,
                ..self
            },
            Err(e) => Located {
                l1_failure: Some(e.to_string()),
                ..self
            },
        }
    }

    /// The status of a located result in a table: `ok` for a loss of stability or a branch
    /// stable throughout, else what prevents an `omega_b`.
    pub fn status(&self) -> String {
        match self.kind {
            Loss::UnstableAtRest => format!(
                "unstable_at_rest ({} unstable eigenvalues at omega = 0)",
                self.unstable_at_rest
            ),
            _ => "ok".into(),
        }
    }
}

/// The first loss of stability of a branch from rest: the event, whose state `u` has its twist
/// angles measured in `chart` (the natural chart unless the branch moved it).
#[derive(Clone, Debug)]
pub struct Critical {
    pub event: Event,
    pub chart: Chart,
    /// A state of the branch just before the event, `(u, omegabar)` (a start for following the
    /// event in a second parameter): the last point before it, or for a window found by a probe
    /// the stable end of the crossing search's final bracket.
    pub lead: (Vec<f64>, f64),
    /// The points of the branch from rest before the event, with the stable probes of its near
    /// misses among them ([`near_miss`]): `omegabar`, the node positions and the leading
    /// spectrum (what a finer mesh is checked against, docs/model.md section 10).
    pub branch: Vec<BranchState>,
}

/// A point of the branch from rest: its rate, node positions and leading spectrum.
#[derive(Clone, Debug)]
pub struct BranchState {
    pub omegabar: f64,
    pub x: Vec<nalgebra::Vector3<f64>>,
    pub spectrum: Spectrum,
}

impl Critical {
    /// The steady problem at the event, in the event's chart.
    pub fn steady<'a>(&self, model: &'a Model) -> Steady<'a> {
        let mut s = Steady::new(model, self.event.p);
        s.chart = self.chart.clone();
        s
    }
}

/// Follows the branch from rest to its first loss of stability and pins it down.
pub fn locate(
    model: &Model,
    settings: &LocateSettings,
    observer: &mut impl Observer<Point, Event>,
) -> Result<(Located, Option<Critical>)> {
    let omega_max = settings.omega_max;
    model.check_resolution()?;
    let rest = rest_state(model, settings.newton)?;
    let omegabar_max = model.scales.omega_to_bar(omega_max);
    let Traced {
        branch,
        charts,
        chart,
    } = trace_charted(
        model,
        &rest,
        omegabar_max,
        settings.continuation,
        true,
        observer,
    )?;
    let points = branch.points.len();
    let none = Located {
        points,
        corrector_iterations: branch.points.iter().map(|p| p.iterations).sum(),
        ..Located::none(model, omega_max)
    };
    let reached = branch.points.last().map_or(0.0, |p| p.p);
    let reached_omega = model.scales.omega_from_bar(reached);
    // A branch cut short (out of points, or stalled) before any event may still hold a window
    // of instability its steps stepped over: its probes come first, and the failure is the
    // answer only where they find none.
    let mut cut_short = None;
    let first = match &branch.stop {
        Stop::Own(BranchStop::FirstInstability) => Some(
            branch
                .first_loss_of_stability()
                .ok_or_else(|| {
                    crate::Error::Numerical(
                        "the branch became unstable but no event was located where it did".into(),
                    )
                })?
                .clone(),
        ),
        Stop::Own(BranchStop::UnstableAtStart) => {
            let count = branch.points[0].spectrum.unstable;
            let located = Located {
                kind: Loss::UnstableAtRest,
                unstable_at_rest: count,
                ..none
            };
            return Ok((located, None));
        }
        Stop::ParameterLimit if reached.abs() > omegabar_max.abs() => None,
        Stop::StepTooSmall(reason) => {
            cut_short = Some(format!(
                "continuation stalled at omega = {reached_omega:.6e} rad/s before any \
                 instability: {reason}"
            ));
            None
        }
        Stop::ParameterLimit => {
            return Err(crate::Error::Numerical(format!(
                "the branch turned back past omega = 0 at omega = {reached_omega:.6e} rad/s \
                 (after {points} points) before reaching omega_max = {omega_max} rad/s, with \
                 no instability found"
            )));
        }
        Stop::Observer => {
            return Err(crate::Error::Numerical(format!(
                "the continuation was ended by its observer at omega = {reached_omega:.6e} rad/s"
            )));
        }
        Stop::Own(BranchStop::Rule(reason)) => {
            return Err(crate::Error::Numerical(format!(
                "the continuation was ended by a stop rule at omega = {reached_omega:.6e} rad/s: \
                 {reason}"
            )));
        }
        Stop::MaxPoints => {
            cut_short = Some(format!(
                "the continuation used all {points} points (continuation.max_points) by omega = \
                 {reached_omega:.6e} rad/s, before omega_max = {omega_max} rad/s, with no \
                 instability found: raise continuation.max_points (or continuation.ds_max)"
            ));
            None
        }
    };
    // The stable points, searched for windows of instability inside their steps.
    let below = branch
        .points
        .iter()
        .take_while(|p| first.as_ref().is_none_or(|e| p.s < e.s))
        .count();
    let stable = &branch.points[..below];
    let problem = RodProblem::new(model, Parameter::Omega, omega_scale(omegabar_max));
    let mut misses = probe_near_misses(
        model,
        &problem,
        (stable, &charts[..below]),
        omegabar_max,
        (settings.newton, settings.continuation),
        Seek::FirstLoss,
    )?;
    let counted = Located {
        probes: misses.probes,
        near_miss_unresolved: misses.unresolved_described(model).next(),
        ..none
    };
    // A window the continuation stepped over comes first: its state is in the natural chart.
    let (event, chart, lead, window) = match (misses.windows.drain(..).next(), first) {
        (Some(window), _) => {
            let step = NearMisses::step(stable, &window);
            let near = &window.loss.near;
            let lead = (near.u.clone(), near.p);
            (window.loss.event, problem.chart(), lead, Some(step))
        }
        (None, Some(event)) => {
            let before = branch.point_before(&event);
            let lead = (before.u.clone(), before.p);
            (event, chart, lead, None)
        }
        (None, None) => {
            return match cut_short {
                None => Ok((counted, None)),
                // What the probes of the points it has did, beside why it was cut short.
                Some(why) => Err(crate::Error::Numerical(format!(
                    "{why}; {} probes of its near misses found no window of instability{}",
                    counted.probes,
                    counted
                        .near_miss_unresolved
                        .as_ref()
                        .map_or(String::new(), |why| format!(" (unresolved {why})"))
                ))),
            };
        }
    };
    let mut located = Located {
        window_between: window.map(|(a, b)| {
            [
                model.scales.omega_from_bar(a),
                model.scales.omega_from_bar(b),
            ]
        }),
        ..counted
    }
    .at_event(model, &rest, &event)?;
    if settings.criticality {
        located = located.with_criticality(model, &event, &chart);
    }
    // The branch's points below the event, each followed by the stable probes after it.
    let position = |p: f64, u: &[f64], spectrum: &Spectrum| BranchState {
        omegabar: p,
        x: Steady::new(model, p).config(u).x,
        spectrum: spectrum.clone(),
    };
    let mut states = Vec::new();
    for (i, point) in stable.iter().enumerate() {
        states.push(position(point.p, &point.u, &point.spectrum));
        let mut after: Vec<_> = misses.stable.iter().filter(|q| q.after == i).collect();
        after.sort_by(|a, b| a.p.abs().total_cmp(&b.p.abs()));
        states.extend(after.iter().map(|q| position(q.p, &q.u, &q.spectrum)));
    }
    states.retain(|state| state.omegabar.abs() < event.p.abs());
    Ok((
        located,
        Some(Critical {
            event,
            chart,
            lead,
            branch: states,
        }),
    ))
}

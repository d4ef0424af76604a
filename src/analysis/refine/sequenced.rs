//! One rung of a refinement by grid sequencing (docs/model.md section 10): the coarser rung's
//! Hopf point carried onto the finer mesh and located there by the crossing search, with the
//! certificate that it is still the first loss of stability of that mesh.

use serde::Serialize;

use super::{RungObserver, Solved, at_nodes};
use crate::analysis::locate::{BranchState, Critical, LocateSettings, Located};
use crate::analysis::solve::{ramp, rest_state};
use crate::engine::arclength::{AtParameter, stability};
use crate::engine::crossing::{CrossingSettings, eigenvalue_slope, locate_crossing};
use crate::engine::curve::others;
use crate::engine::newton::{self, NewtonReport, NewtonSettings};
use crate::model::Model;
use crate::model::rod::Config;
use crate::problem::carry::{carry, carry_config};
use crate::problem::rod::{Parameter, RodProblem, omega_scale};
use crate::problem::steady::SteadyState;
use crate::problem::twist::{natural_chart_unknowns, scaled_twist, slave_twist};
use crate::{Error, Result};

/// Why a sequenced rung's Hopf point is the first loss of stability of its mesh
/// (docs/model.md section 10): a state just below it with no unstable eigenvalue, and no
/// unstable eigenvalue on this mesh at the points of the coarsest rung's branch where a mode
/// other than the critical one came within `margin` of the axis.
#[derive(Clone, Debug, Serialize)]
pub struct Certificate {
    /// The state on the stable side of the final bracket (rad/s) and its unstable count.
    pub omega_below: f64,
    pub unstable_below: usize,
    /// How far the critical eigenvalue moved from the coarser mesh to this one, at the first
    /// sample (1/s), and the margin it sets, ten times that.
    pub shift: f64,
    pub margin: f64,
    /// The rates (rad/s) of the coarsest branch's points checked on this mesh (each with no
    /// unstable eigenvalue); the others kept a margin on it.
    pub checked: Vec<f64>,
    /// Those of them whose state on this mesh was reached by a ramp of the rate on it, its
    /// carried state not corrected by Newton's method.
    pub ramped: Vec<f64>,
}

/// The slope `d Re s / d omegabar` of the critical eigenvalue at the Hopf point of `critical`
/// on `model`, over a relative step [`SLOPE_STEP`] below it ([`eigenvalue_slope`]; one Newton
/// solve and spectrum on that rung's mesh, the coarsest unless a sequenced rung has no slope of
/// its own); where that solve fails, from the last point of its branch before it (the
/// eigenvalue tracked back to it), a continuation step away.
fn event_slope(model: &Model, critical: &Critical, settings: &LocateSettings) -> Option<f64> {
    let event = &critical.event;
    let omegabar_max = model.scales.omega_to_bar(settings.omega_max);
    let problem = RodProblem::new(model, Parameter::Omega, omega_scale(omegabar_max));
    let u = carry(model, &event.u, &critical.chart, model);
    let local = eigenvalue_slope(
        &problem,
        &u,
        event.p,
        event.eigenvalue,
        SLOPE_STEP,
        settings.continuation,
    );
    local.ok().or_else(|| {
        let lead = critical.branch.last()?;
        let s = lead.spectrum.nearest(event.eigenvalue);
        let slope = (event.eigenvalue.re - s.re) / (event.p - lead.omegabar);
        slope.is_finite().then_some(slope)
    })
}

/// The relative step of [`event_slope`]: well inside the first step of a finer rung's search
/// (its Hopf point moves by about `1e-2` relative from `N = 60` to 119, less after), and far
/// above the event tolerance.
const SLOPE_STEP: f64 = 1e-3;

/// How many times the critical eigenvalue's shift from the coarser mesh a mode of the coarsest
/// branch must stay from the axis to be left unchecked on a finer mesh (docs/model.md
/// section 10).
const K_MARGIN: f64 = 10.0;

/// Newton iterations allowed to a point of the coarsest branch carried onto a finer mesh before
/// it is reached by a ramp on that mesh instead ([`sequenced_rung`]).
const CARRIED_ITERATIONS: usize = 10;

/// How far (in units of the carried Hopf point's own correction on the finer mesh) a state
/// reached by a ramp may lie from the carried state it replaces ([`sequenced_rung`]): farther,
/// it is taken for a state of another branch, and the rung falls back.
const RAMP_REACH: f64 = 10.0;

/// One rung by sequencing (docs/model.md section 10): the Hopf point of the coarser rung
/// `coarse` carried onto the mesh of the model `fine` and located there ([`locate_crossing`]),
/// started at `predicted` (`omegabar`), and its [`Certificate`]; `Ok(Err(why))` where the
/// certificate fails (a point of the coarsest branch is unstable on this mesh, or cannot be
/// solved on it).
pub(super) fn sequenced_rung(
    fine: Model,
    coarse: &Solved,
    predicted: f64,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<std::result::Result<(Solved, Certificate), String>> {
    let critical = coarse
        .critical
        .as_ref()
        .expect("a sequenced rung follows a Hopf point");
    let nodes = fine.nodes();
    fine.check_resolution()?;
    observer.rung(&fine);
    let omegabar_max = fine.scales.omega_to_bar(settings.omega_max);
    let problem = RodProblem::new(&fine, Parameter::Omega, omega_scale(omegabar_max));
    // The twist re-solved for the carried positions: carried along with them, its error and
    // theirs together put Newton's method outside its basin where each alone did not (8 turns
    // at 15 nodes per turn, src/problem/carry.rs).
    let carried = carry(&coarse.model, &critical.event.u, &critical.chart, &fine);
    let u0 = slave_twist(&fine, &carried).map_err(|e| {
        Error::Numerical(format!(
            "the twist of the Hopf point carried from N = {} could not be re-solved on this \
             mesh: {e}",
            coarse.model.nodes()
        ))
    })?;
    let coarse_slope = coarse
        .slope
        .or_else(|| event_slope(&coarse.model, critical, settings));
    let search = CrossingSettings {
        first_step: 5e-3,
        slope: coarse_slope,
        max_evaluations: 40,
        unstable_stable_side: 0,
        // The first loss of stability from rest, met moving away from rest.
        travel: predicted.signum(),
        regain: false,
    };
    let crossing = locate_crossing(
        &problem,
        &u0,
        predicted,
        critical.event.eigenvalue,
        &search,
        settings.continuation,
    )?;
    let scales = fine.scales;
    // How far the real part of the critical eigenvalue moved from the coarser mesh at one
    // rate: its slope in `omegabar` between the event and another sample of the search (the
    // near end of the final bracket, or where the search ended at it, the first sample) times
    // the move of the crossing.
    let event = &crossing.event;
    let slope = [&crossing.near, &crossing.first]
        .into_iter()
        .find(|sample| sample.p != event.p)
        .map(|sample| (event.eigenvalue.re - sample.tracked.re) / (event.p - sample.p))
        .filter(|g| g.is_finite())
        .or(coarse_slope);
    let shift = match slope {
        Some(g) => (g * (event.p - critical.event.p)).abs(),
        None => (crossing.first.tracked.re - critical.event.eigenvalue.re).abs(),
    };
    let margin = K_MARGIN * shift;
    // The coarsest branch's points below this mesh's crossing where a mode other than the
    // critical one (tracked back from the event, point to point) came within the margin.
    let mut track = critical.event.eigenvalue;
    let mut close: Vec<&BranchState> = Vec::new();
    for state in critical.branch.iter().rev() {
        track = state.spectrum.nearest(track);
        let below = state.omegabar.abs() < crossing.near.p.abs();
        if below && others(&state.spectrum, track).max_re() > -margin {
            close.push(state);
        }
    }
    let rest = rest_state(&fine, settings.newton)?;
    // The coarsest branch comes down the rungs unchanged: its points are carried from their own
    // mesh, not from `coarse.model`'s (finer than the branch's from the third rung on, and in
    // the quadrature's measurement at the second).
    let branch_mesh = match close.first() {
        Some(state) if state.x.len() != coarse.model.nodes() => {
            let nodes = state.x.len();
            let mesh = Model::new(&at_nodes(&fine.physical, nodes)).map_err(|e| {
                Error::Numerical(format!(
                    "the coarsest branch's mesh (N = {nodes}) could not be rebuilt: {e}"
                ))
            })?;
            Some(mesh)
        }
        _ => None,
    };
    let branch_mesh = branch_mesh.as_ref().unwrap_or(&coarse.model);
    let layout = fine.rod.layout;
    let mut checked = Vec::new();
    let mut ramped = Vec::new();
    // This mesh's own states, the starts of its ramps (below): at rest, at the crossing's stable
    // end, and where ramps ended. Newton's method on a carried state: one that converges does so
    // in 3 to 6 iterations; one that has not after [`CARRIED_ITERATIONS`] is left for a ramp.
    let near = &crossing.near;
    let mut own = vec![
        rest.clone(),
        SteadyState {
            omega: near.p,
            weight: fine.weight,
            config: problem.steady(near.p).config(&near.u),
            chart: problem.chart(),
            report: NewtonReport::default(),
        },
    ];
    let carried_newton = NewtonSettings {
        max_iter: settings.newton.max_iter.min(CARRIED_ITERATIONS),
        ..settings.newton.clone()
    };
    // How far Newton's method moved the carried Hopf point's nodes on this mesh (its first
    // sample): the size of a carried state's error, against which a ramp's end is measured.
    let correction = layout.node_distance(&u0, &crossing.first.u);
    for state in close.iter().rev() {
        let omega = scales.omega_from_bar(state.omegabar);
        // The state at rest is this mesh's own. The others: the positions carried, the twist
        // started from the carried Hopf point's scaled with the rate (the twist carries the
        // motor's torque, about proportional to it below the instability), then slaved.
        let carried = (state.omegabar != 0.0).then(|| {
            let ratio = state.omegabar / critical.event.p;
            // The branch keeps positions only; the twist carried here is replaced below.
            let untwisted = Config {
                x: state.x.clone(),
                theta: vec![0.0; state.x.len() - 1],
            };
            scaled_twist(
                &fine,
                carry_config(branch_mesh, &untwisted, &fine),
                &u0,
                ratio,
            )
        });
        let guess = match &carried {
            Some(u) => slave_twist(&fine, u),
            None => natural_chart_unknowns(&fine, &rest.config, &rest.chart),
        };
        let at = AtParameter::new(&problem, state.omegabar);
        let context = format!("checking omega = {omega:e} rad/s");
        // Where Newton's method does not correct the carried state within its iterations (the
        // coarse mesh's error in the stiff stretching can put it outside the basin), this
        // mesh's own state is reached by ramping the rate from the nearest of this mesh's own
        // states, on this mesh throughout; its nodes must lie within [`RAMP_REACH`] times the
        // carried Hopf point's correction of the carried state's (the same branch, not another
        // one the ramp found).
        let solved = guess
            .and_then(|guess| newton::solve(&at, guess, &carried_newton, &context))
            .or_else(|failed| {
                let start = own
                    .iter()
                    .min_by(|a, b| {
                        let d = |s: &SteadyState| (s.omega - state.omegabar).abs();
                        d(a).total_cmp(&d(b))
                    })
                    .expect("the state at rest is one");
                let from = scales.omega_from_bar(start.omega);
                let ramp_failed = |why: String| {
                    Error::Numerical(format!(
                        "{failed}; ramped from omega = {from:e} rad/s on this mesh: {why}"
                    ))
                };
                let reached = ramp(
                    &fine,
                    start,
                    Parameter::Omega,
                    state.omegabar,
                    settings.newton,
                )
                .map_err(|e| ramp_failed(e.to_string()))?;
                let guess = natural_chart_unknowns(&fine, &reached.config, &reached.chart)?;
                let (u, report) = newton::solve(&at, guess, settings.newton, &context)
                    .map_err(|e| ramp_failed(e.to_string()))?;
                if let Some(c) = &carried {
                    let apart = layout.node_distance(&u, c);
                    if apart > RAMP_REACH * correction {
                        return Err(ramp_failed(format!(
                            "its nodes lie {apart:.3e} from the carried state's, more than \
                             {RAMP_REACH} times the carried Hopf point's correction \
                             {correction:.3e} (another branch?)"
                        )));
                    }
                }
                own.push(reached);
                ramped.push(omega);
                Ok((u, report))
            });
        let spectrum = solved.and_then(|(u, _)| {
            let lin = at.linearization_at(&u)?;
            stability(
                &problem,
                &u,
                state.omegabar,
                &lin,
                settings.continuation,
                None,
            )
        });
        let spectrum = match spectrum {
            Ok(s) => s,
            Err(e) => {
                return Ok(Err(format!(
                    "the point of the coarsest branch at omega = {omega:.6} rad/s could not be \
                     solved on this mesh to check it: {e}"
                )));
            }
        };
        if spectrum.unstable > 0 {
            return Ok(Err(format!(
                "at omega = {omega:.6} rad/s, below the sequenced point, this mesh has {} \
                 unstable eigenvalues",
                spectrum.unstable
            )));
        }
        checked.push(omega);
    }
    let base = Located {
        nodes,
        omega_max: settings.omega_max,
        points: crossing.evaluations,
        ..Located::none(&fine, settings.omega_max)
    };
    let located = base.at_event(&fine, &rest, &crossing.event)?;
    let certificate = Certificate {
        omega_below: scales.omega_from_bar(crossing.near.p),
        unstable_below: crossing.near.spectrum.unstable,
        shift: shift / scales.time,
        margin: margin / scales.time,
        checked,
        ramped,
    };
    let solved = Solved {
        slope,
        located,
        critical: Some(Critical {
            lead: (crossing.near.u.clone(), crossing.near.p),
            chart: problem.chart(),
            event: crossing.event,
            branch: critical.branch.clone(),
        }),
        model: fine,
    };
    Ok(Ok((solved, certificate)))
}

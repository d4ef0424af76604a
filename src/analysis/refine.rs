//! `omega_b` at several node counts: refined (spacing halved) until its estimated
//! discretization error is below a requested accuracy, or over a ladder and extrapolated with
//! the known orders (docs/model.md section 10).

use serde::Serialize;

use std::time::Instant;

use crate::analysis::locate::{Critical, LocateSettings, Located, Loss, locate};
use crate::engine::arclength::Point;
use crate::engine::events::Event;
use crate::engine::events::EventKind;
use crate::engine::stop::{Observer, Silent};
use crate::model::fluid::{FluidModel, rpy};
use crate::model::params::{ClampEdge, Physical};
use crate::model::{Model, admissible_max_nodes};
use crate::numerics::extrapolation::{
    DiscretizationError, Extrapolated, Orders, discretization_error, extrapolate_with,
};
use crate::{Error, Result};

mod lyapunov;
mod quadrature;
mod sequenced;

pub use lyapunov::{LyapunovError, RungLyapunov};
pub(crate) use quadrature::{OtherRule, rule_error};
pub use quadrature::{QuadratureCorrection, QuadratureError};
pub use sequenced::Certificate;
use sequenced::sequenced_rung;

/// Watches a refinement or a ladder: every rung's continuation as an engine [`Observer`], and
/// each rung's result and error estimate as they come.
pub trait RungObserver: Observer<Point, Event> {
    /// A rung starts on `model`.
    fn rung(&mut self, _model: &Model) {}
    /// The rung at `nodes` located `located`.
    fn located(&mut self, _nodes: usize, _located: &Located) {}
    /// The RPY quadrature's own error, measured at a rung (the coarsest, and the next where a
    /// correction of the answer may follow).
    fn quadrature(&mut self, _quadrature: &QuadratureError) {}
    /// The estimated relative error of the answer so far, `answered`. `estimate` is the finest
    /// rung's own discretization error.
    fn estimated(&mut self, _relative: f64, _estimate: &DiscretizationError, _answered: &Answered) {
    }
}

/// No progress to show.
impl RungObserver for Silent {}

/// `locate --extrapolate`: `omega_b` over a ladder of node counts and its limit with the known
/// orders (docs/model.md section 10, [`extrapolate_with`], [`error_orders`]).
#[derive(Serialize)]
pub struct Ladder {
    pub nodes: Vec<usize>,
    pub omega_b: Vec<f64>,
    pub omegabar_b: Vec<f64>,
    pub kinds: Vec<Loss>,
    /// The limit in `N`, on the RPY line less the quadrature's own error where it was removed
    /// (`quadrature_correction`).
    pub omega_b_extrapolated: f64,
    /// The error of the limit: the extrapolation's ([`Extrapolated::error`]) plus, on the RPY
    /// line, the error of the quadrature's correction, or the size of the quadrature's own error
    /// where none was made.
    pub omega_b_error: f64,
    pub extrapolation_error: f64,
    /// The RPY quadrature's own error, measured at the ladder's coarsest rung (as for a
    /// [`Refinement`]); `None` on Lighthill's operator.
    pub quadrature: Option<QuadratureError>,
    /// The same at the next rung, where that halves the spacing or more.
    pub quadrature_finer: Option<QuadratureError>,
    /// The quadrature's error removed from the limit, and the error of that correction.
    pub quadrature_correction: Option<QuadratureCorrection>,
    pub omegabar_b_extrapolated: f64,
    /// The error model, and its coefficients `c1`, `c2` (rad/s).
    pub model: &'static str,
    pub coefficients: [f64; 2],
    /// Largest admissible node count of the model (docs/model.md section 3); `None` for a fluid
    /// model without a resolution limit (RPY).
    pub nodes_max: Option<usize>,
}

/// `locate --accuracy EPS` (the default of `locate`): `omega_b` refined in `N` until the
/// estimated error of the answer (docs/model.md section 10) is below `EPS` relative, or the
/// model can go no further; or, without an accuracy, `omega_b` at a fixed `N` with its error
/// estimated from a coarser rung ([`estimate_at_nodes`]). The answer ([`Answer`]) is the finest
/// rung's `omega_b` with its discretization error ([`discretization_error`]), or, where the
/// model has the second order alone and the three finest rungs converge as it allows, their
/// limit in `N` with its error ([`trusted_limit`]), whichever has the smaller error in `N`; on the
/// RPY line less the quadrature's own error where it was measured twice
/// ([`QuadratureCorrection`]).
#[derive(Serialize)]
pub struct Refinement {
    /// The finest rung (its fields at the top level), except that its `omega_b` and
    /// `omegabar_b` are the answer's (the finest rung's own are in `omega_b_finest` and in
    /// `rungs`).
    #[serde(flatten)]
    pub finest: Located,
    /// Where the answer comes from.
    pub answer: Answer,
    /// Relative accuracy asked for; `None` where the rungs were fixed instead (a study that fixes
    /// `N`: its error estimated from a coarser rung, [`estimate_at_nodes`]).
    pub accuracy: Option<f64>,
    /// Whether the estimated relative error of the answer is below `accuracy`.
    pub reached: bool,
    /// Estimated error of the answer against the continuous model (rad/s) and relative: its
    /// error in `N` (the finest rung's discretization error, `estimate`, or the limit's,
    /// `extrapolation_error`) plus, on the RPY line, the size of the quadrature's own error
    /// (`quadrature`) or, where it was removed from the answer, the error of that correction
    /// (`quadrature_correction`); absent with one rung.
    pub omega_b_error: Option<f64>,
    pub relative_error: Option<f64>,
    /// The finest rung's own `omega_b` (rad/s) and its error (its discretization error plus the
    /// quadrature's), whatever the answer.
    pub omega_b_finest: Option<f64>,
    pub finest_error: Option<f64>,
    /// The error in `N` of the limit where it is the answer: the change of the limit from the
    /// pair of rungs before ([`extrapolate_with`]); without the quadrature's.
    pub extrapolation_error: Option<f64>,
    /// The discretization error in `N` of the finest rung: its size, limit, observed order and
    /// method. Boxed, as `quadrature`.
    pub estimate: Option<Box<DiscretizationError>>,
    /// The RPY line's quadrature error, measured at the coarsest rung (absent on Lighthill's
    /// operator, which has no quadrature of its own). Boxed: a refinement is moved whole.
    pub quadrature: Option<Box<QuadratureError>>,
    /// The same measured at the second rung, where the model's limit may be trusted
    /// ([`Orders::Second`]) and the next rung halves the spacing.
    pub quadrature_finer: Option<Box<QuadratureError>>,
    /// The quadrature's error removed from the answer (the limit or the finest rung's value),
    /// and the error of that correction, where both measurements were made.
    pub quadrature_correction: Option<Box<QuadratureCorrection>>,
    /// The error in `N` of the finest rung's Lyapunov coefficient, from the two rungs before it
    /// (where they have one kind of point and the coefficient was asked for); the finest's
    /// verdict (`criticality`) is then that of the sign settled in `N`
    /// ([`LyapunovError::verdict`]).
    pub lyapunov_error: Option<Box<LyapunovError>>,
    /// Every rung: node count, `omega_b`, kind.
    pub rungs: Vec<Rung>,
    /// Why the refinement ended without reaching `accuracy` (absent when it did); at a fixed
    /// `N`, why the error could not be estimated (absent when it was).
    pub stopped: Option<String>,
    /// The hydrodynamic model the rungs use.
    pub fluid: FluidModel,
}

/// Where a refinement's answer comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Answer {
    /// The finest rung's `omega_b`, with its discretization error.
    FinestRung,
    /// The limit in `N` of the three finest rungs, with its error ([`trusted_limit`]).
    Limit,
}

/// The smallest order observed over the three finest rungs at which their limit is trusted
/// ([`trusted_limit`]).
const LIMIT_MIN_ORDER: f64 = 1.5;

/// The limit in `N` of the three finest rungs `nodes`, `values` with the known order 2 alone
/// ([`extrapolate_with`]: `c0` of `c0 + c2 h^2` through the two finest, its error the change of
/// `c0` from the pair before), where that error can be trusted: on a model with the second
/// order alone ([`Orders::Second`]: the RPY line with the centred clamp), three rungs or more,
/// the last three successive halvings of the spacing (`N -> 2N - 1`; a last rung capped by
/// `--max-nodes` is not), whose increments have one sign and shrink with an observed order `p`
/// (`observed_order`, the finest rung's estimate's, [`DiscretizationError::observed_order`]) of
/// at least [`LIMIT_MIN_ORDER`]. Why the change is the error's measure: with a remainder
/// `C h^q` beyond the known term, the second-order limit of a pair errs by
/// `C h_f^q (4 - 2^q)/3` at a halving, so the change from the coarser pair is `2^q - 1` times
/// the finer limit's error: it covers it for every `q > 1`, seven times for a third-order
/// remainder (a pure second-order one leaves the finer limit exact). Below order 1 it would
/// not, and the floor on `p` keeps out rungs whose leading term is not the known one (it does
/// not fix `q`, which three rungs cannot see). Two remainder terms of opposite signs could make
/// the change small by cancellation; on the models here no first-order term of the
/// discretization exists to cancel a third-order one (docs/model.md section 9: the quadrature's
/// change with `N`, about first order, is a hundredth of the increments), and the change shrinks
/// about eightfold per halving where it was measured (section 10). `None` where it does not hold.
pub fn trusted_limit(
    orders: Orders,
    nodes: &[usize],
    values: &[f64],
    observed_order: Option<f64>,
) -> Result<Option<Extrapolated>> {
    let k = nodes.len();
    if orders != Orders::Second
        || k < 3
        || nodes[k - 3..].windows(2).any(|w| w[1] != 2 * w[0] - 1)
        || !observed_order.is_some_and(|p| p >= LIMIT_MIN_ORDER)
    {
        return Ok(None);
    }
    extrapolate_with(orders, &nodes[k - 3..], &values[k - 3..]).map(Some)
}

/// The answer of rungs whose finest value `finest` has the discretization error `estimate`,
/// on a rule whose own error of `omega_b` has the size `offset` (0 where not measured): the
/// trusted `limit` where there is one and its error in `N` is the smaller, else the finest
/// value; either less the quadrature's error where `correction` removes it (the same
/// correction whichever is chosen, so that the choice compares the errors in `N` alone), else
/// keeping it, with `offset` in its error.
fn answer(
    finest: f64,
    estimate: &DiscretizationError,
    limit: Option<Extrapolated>,
    offset: f64,
    correction: Option<QuadratureCorrection>,
) -> Answered {
    let (source, value, error, limit) = match limit {
        Some(l) if l.error <= estimate.error => (Answer::Limit, l.value, l.error, Some(l)),
        _ => (Answer::FinestRung, finest, estimate.error, None),
    };
    let (value, quadrature_part) = quadrature::corrected(value, correction.as_ref(), offset);
    Answered {
        source,
        value,
        error,
        quadrature_part,
        limit,
        correction,
    }
}

/// A refinement's answer so far ([`answer`]): where it comes from, its value (rad/s), its error
/// in `N` and the quadrature's part of its error (rad/s), the limit where that is the answer,
/// and the quadrature's correction where it was removed from the answer.
pub struct Answered {
    pub source: Answer,
    pub value: f64,
    pub error: f64,
    pub quadrature_part: f64,
    pub limit: Option<Extrapolated>,
    pub correction: Option<QuadratureCorrection>,
}

impl Answered {
    /// The whole error (rad/s): in `N` and of the quadrature.
    pub fn total(&self) -> f64 {
        self.error + self.quadrature_part
    }
}

/// One rung of a refinement.
#[derive(Clone, Serialize)]
pub struct Rung {
    pub nodes: usize,
    pub omega_b: Option<f64>,
    pub kind: Loss,
    /// How the rung found its point: `continuation` from rest, `sequenced` from the coarser
    /// rung's point, or `continuation` after sequencing was refused (`fallback` says why).
    pub method: &'static str,
    pub fallback: Option<String>,
    /// A sequenced rung's evidence that its point is still the first loss of stability.
    pub certificate: Option<Certificate>,
    /// A continuation rung's window of instability found inside a step by probing a near miss,
    /// and a near miss neither resolved nor excluded ([`Located`]).
    pub window_between: Option<[f64; 2]>,
    pub near_miss_unresolved: Option<String>,
    pub seconds: f64,
}

/// The relative accuracy of `omega_b` a refinement is asked for unless told otherwise
/// (`locate`, a `locate` study, Python's `Study.locate`).
pub const DEFAULT_ACCURACY: f64 = 1e-3;

/// The largest node count a refinement goes to unless told otherwise (`--max-nodes`): the
/// RPY line has no admissible limit, and past a few hundred nodes the dense stability solve at
/// every continuation point makes each rung cost `O(N^3)`.
pub const DEFAULT_MAX_NODES: usize = 500;

/// The default ladder: five node counts evenly spaced from half the admissible maximum to two
/// below it; without an admissible maximum (RPY), the model's `N` and two successive halvings
/// of its node spacing, `N, 2N - 1, 4N - 3`.
pub fn default_ladder(physical: &Physical) -> Vec<usize> {
    let Some(max) = admissible_max_nodes(physical) else {
        let n = physical.discretization.nodes;
        return vec![n, 2 * n - 1, 4 * n - 3];
    };
    let max = max.saturating_sub(2).max(10);
    let min = (max / 2).max(8);
    (0..5).map(|k| min + (max - min) * k / 4).collect()
}

/// The known orders of `physical`'s discretization error in `N` (docs/model.md section 10): the
/// second alone on the RPY line with the clamped edge centred on the clamp (section 9: point
/// forces at the ends, the velocity tested at the centroids and a nested quadrature leave no
/// first-order term of the fluid, and the centred clamp none of the rod; the observed order
/// is 2.15, 2.07, 2.04 over `N = 60 .. 945` on the representative helix), so the error of a
/// rung is estimated at second order, a third of the first-order estimate at each halving.
/// First and second otherwise: the clamp on the first edge holds the tangent half an edge below
/// the clamp, and Lighthill's point sums add first-order terms of their own.
pub fn error_orders(physical: &Physical) -> Orders {
    match (physical.fluid.model, physical.clamp_edge()) {
        (FluidModel::Rpy, ClampEdge::Centred) => Orders::Second,
        _ => Orders::FirstAndSecond,
    }
}

/// `physical` at `nodes` nodes.
pub(crate) fn at_nodes(physical: &Physical, nodes: usize) -> Physical {
    let mut p = physical.clone();
    p.discretization.nodes = nodes;
    p.discretization.per_turn = None;
    p
}

/// A rung's result: its model, what it located, its first loss of stability, and the slope
/// `d Re s / d omegabar` of the critical eigenvalue there (from a sequenced rung's final
/// bracket; `None` for a rung followed from rest, whose slope `sequenced::event_slope` makes
/// when a finer rung needs it).
struct Solved {
    model: Model,
    located: Located,
    critical: Option<Critical>,
    slope: Option<f64>,
}

/// One rung by continuation from rest: `locate` on `physical` at `nodes` nodes.
fn continuation_rung(
    physical: &Physical,
    nodes: usize,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Solved> {
    let model = Model::new(&at_nodes(physical, nodes))?;
    observer.rung(&model);
    let (located, critical) = locate(&model, settings, observer)?;
    Ok(Solved {
        // Made where a finer rung is sequenced from this one ([`sequenced_rung`]).
        slope: None,
        model,
        located,
        critical,
    })
}

/// The discretization error (rad/s) of a Hopf point at `omegabar = p` of `fine`, the model of
/// `physical` at its `N` nodes: the first loss of stability at `N/2 + 1` nodes, located from
/// rest, and the estimate of the two rungs with the model's known orders
/// ([`discretization_error`]). `None` below 9 nodes, or where the coarser mesh has no Hopf point
/// to compare (or cannot follow the branch). The point is not carried down: at the coarse
/// meshes of a boundary (5 to 10 nodes per turn) Newton's method does not correct a carried
/// state (docs/model.md section 10). The RPY quadrature's own error is not in it.
pub(crate) fn hopf_point_error(
    physical: &Physical,
    fine: &Model,
    p: f64,
    settings: &LocateSettings,
) -> Result<Option<f64>> {
    let nodes = fine.nodes();
    if nodes < 9 {
        return Ok(None);
    }
    let coarse_nodes = nodes / 2 + 1;
    let coarse = Model::new(&at_nodes(physical, coarse_nodes))?;
    let quiet = without_criticality(settings);
    let located = match locate(&coarse, &quiet, &mut Silent) {
        Ok((located, _)) => located,
        Err(e) if e.is_input() => return Err(e),
        // A mesh too coarse for the branch: no point to compare.
        Err(_) => return Ok(None),
    };
    let Some(omega_coarse) = located
        .omega_b
        .filter(|_| located.kind == Loss::Event(EventKind::Hopf))
    else {
        return Ok(None);
    };
    let values = [omega_coarse, fine.scales.omega_from_bar(p)];
    let estimate = discretization_error(error_orders(physical), &[coarse_nodes, nodes], &values)?;
    Ok(Some(estimate.error))
}

/// Runs `locate` at each node count of `ladder` and extrapolates.
pub fn ladder(
    physical: &Physical,
    ladder: &[usize],
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Ladder> {
    let mut distinct = ladder.to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    if distinct.len() < 3 {
        return Err(Error::input(
            "--nodes",
            format!("the extrapolation needs at least three distinct node counts, got {ladder:?}"),
        ));
    }
    // As in a refinement, rungs past the second keep the coarsest's quadrature point spacing.
    let first = distinct[0];
    let coarsest_spacing = point_spacing(&Model::new(&at_nodes(physical, first))?);
    for &n in distinct.iter().skip(2) {
        if let Some(ratio) = coarsest_spacing.and_then(|s| spacing_change(physical, n, s)) {
            return Err(Error::input(
                "--nodes",
                format!(
                    "{ladder:?}: at N = {n} the RPY quadrature's point spacing would be \
                     {ratio:.2} times that at N = {first}, which changes the quadrature's error \
                     that the limit takes as the same at every rung (docs/model.md section 10): \
                     choose rungs that halve the spacing (N, 2N - 1, 4N - 3), or, where it stops \
                     halving at one cell per edge, raise fluid.points_per_blob"
                ),
            ));
        }
    }
    let mut results = Vec::new();
    // The rungs at the two smallest node counts, where the quadrature's error is measured.
    let mut coarsest: Vec<Solved> = Vec::new();
    for &n in ladder {
        let solved = continuation_rung(physical, n, settings, observer)?;
        let located = solved.located.clone();
        observer.located(n, &located);
        if coarsest.iter().all(|c| c.located.nodes != n) {
            coarsest.push(solved);
            coarsest.sort_by_key(|c| c.located.nodes);
            coarsest.truncate(2);
        }
        let (Some(w), Some(wb)) = (located.omega_b, located.omegabar_b) else {
            return Err(Error::Numerical(format!(
                "no instability up to omega_max = {} rad/s at N = {n}: nothing to extrapolate",
                settings.omega_max
            )));
        };
        results.push((n, w, wb, located.kind));
    }
    let nodes: Vec<usize> = results.iter().map(|r| r.0).collect();
    let omega_b: Vec<f64> = results.iter().map(|r| r.1).collect();
    let omegabar_b: Vec<f64> = results.iter().map(|r| r.2).collect();
    // One event followed over the ladder: rungs that find different kinds would mix modes.
    if results.iter().any(|r| r.3 != results[0].3) {
        return Err(Error::Numerical(format!(
            "the rungs {nodes:?} find different events ({:?}): no one limit to extrapolate; \
             choose a ladder on which the first instability is of one kind",
            results.iter().map(|r| r.3.name()).collect::<Vec<_>>()
        )));
    }
    let orders = error_orders(physical);
    let e: Extrapolated = extrapolate_with(orders, &nodes, &omega_b)?;
    let ratio = omegabar_b[0] / omega_b[0];
    // On the RPY line the quadrature's error, measured at the coarsest rung and, where the next
    // halves its spacing or more (the bound of the correction needs it), at that one too, to
    // remove it from the limit ([`QuadratureCorrection`]); else its size is in the bar.
    let mut measured = Vec::new();
    if physical.fluid.model == FluidModel::Rpy {
        let halved = coarsest[1].located.nodes >= 2 * coarsest[0].located.nodes - 1;
        let at = if halved {
            &coarsest[..]
        } else {
            &coarsest[..1]
        };
        for rung in at {
            let q = quadrature::measure(physical, rung, &without_criticality(settings))?;
            observer.quadrature(&q);
            measured.push(q);
        }
    }
    let mut measured = measured.into_iter();
    let (quadrature, quadrature_finer) = (measured.next(), measured.next());
    let quadrature_correction =
        QuadratureCorrection::between(quadrature.as_ref(), quadrature_finer.as_ref());
    let (value, quadrature_part) = quadrature::corrected(
        e.value,
        quadrature_correction.as_ref(),
        quadrature::offset(quadrature.as_ref()),
    );
    Ok(Ladder {
        nodes_max: admissible_max_nodes(physical),
        kinds: results.into_iter().map(|r| r.3).collect(),
        nodes,
        omega_b,
        omegabar_b,
        omega_b_extrapolated: value,
        omega_b_error: e.error + quadrature_part,
        extrapolation_error: e.error,
        quadrature,
        quadrature_finer,
        quadrature_correction,
        omegabar_b_extrapolated: value * ratio,
        model: orders.model(),
        coefficients: e.coefficients,
    })
}

/// The node count after `n` in a refinement: the spacing halved (`2N - 1`, so that
/// `h = 1/(N - 1)` halves), capped at `max` (the admissible limit or `--max-nodes`); `None`
/// when `n` is already there.
fn refined(n: usize, max: usize) -> Option<usize> {
    let next = (2 * n - 1).min(max);
    (next > n).then_some(next)
}

/// `omega_b` at the model's own `N` with its discretization error: a coarser rung at about
/// twice the spacing (`N/2 + 1` nodes) followed from rest, then the model's `N` sequenced from
/// it, and the error estimated from the two ([`discretization_error`]); the answer is the
/// model's `N`'s. A model too coarse for a rung below it (`N < 9`), or whose coarser rung fails,
/// gets its `N` alone, without an estimate (`stopped` says why).
pub fn estimate_at_nodes(
    physical: &Physical,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Refinement> {
    let nodes = physical.discretization.nodes;
    if admissible_max_nodes(physical).is_some_and(|a| a < nodes) {
        // Outside the fluid model's range: refused with the usual message.
        Model::new(physical)?.check_resolution()?;
    }
    let coarse = nodes / 2 + 1;
    let why = if nodes < 9 {
        format!("N = {nodes} is below 9: no coarser rung to estimate the error from")
    } else {
        match refine(&at_nodes(physical, coarse), None, nodes, settings, observer) {
            Ok(r) if r.finest.nodes == nodes => return Ok(r),
            // The refinement ended at the coarser rung (no omega_b there).
            Ok(r) => r.stopped.unwrap_or_default(),
            // The coarser rung failed (a mesh too coarse for the branch).
            Err(e) if !e.is_input() => format!("the coarser rung at N = {coarse} failed: {e}"),
            Err(e) => return Err(e),
        }
    };
    // The model's own `N` alone, saying why it has no estimate.
    let mut alone = refine(physical, None, nodes, settings, observer)?;
    alone.stopped = Some(why);
    Ok(alone)
}

/// The RPY quadrature's point spacing of `model` (solver units): its longest natural edge over
/// the points per edge; `None` on Lighthill's line.
fn point_spacing(model: &Model) -> Option<f64> {
    let points = model.fluid.points_per_edge()?;
    Some(rpy::longest_edge(&model.natural) / points as f64)
}

/// The ratio of the RPY quadrature's point spacing ([`point_spacing`]) at `nodes` nodes to
/// `coarsest`, the coarsest rung's, where it lies outside `[3/4, 4/3]`; `None` within, on
/// Lighthill's line, and where the model at `nodes` cannot be built (that rung then fails on its
/// own). A refinement takes the quadrature's error as the same at every rung (the cells per edge
/// halve as the edges do, docs/model.md section 9), measures it at the coarsest rungs and removes
/// it from the limit in `N`. Once a rung has one cell per edge the next cannot halve it, its
/// points are twice as dense, and the error falls about four times (a rung capped by
/// `--max-nodes` that does not halve the spacing changes it too): the increments then carry that
/// fall, and the correction removes what is no longer there. On the representative helix at two
/// points per blob radius, refined to `1e-4` through `N = 237` (one cell per edge), 473 and 500,
/// the answer would be `0.500495 +- 5.2e-4` rad/s, `7.7e-4` from the answers at four and eight
/// points per blob radius (`0.501280 +- 3.5e-5`, `0.501261 +- 2.6e-5`), whose rungs keep their
/// spacing. A refinement of two rungs makes no correction and puts the quadrature's whole error
/// in its bar, so only a third rung or later must keep the spacing.
fn spacing_change(physical: &Physical, nodes: usize, coarsest: f64) -> Option<f64> {
    let model = Model::new(&at_nodes(physical, nodes)).ok()?;
    let ratio = point_spacing(&model)? / coarsest;
    (!(0.75..=4.0 / 3.0).contains(&ratio)).then_some(ratio)
}

/// Why a refinement whose coarsest rung is `first` stops at `n` before `next`, where the
/// quadrature's point spacing would change by `ratio` ([`spacing_change`]): what to change.
fn unnested(physical: &Physical, (first, n, next): (usize, usize, usize), ratio: f64) -> String {
    let change = format!(
        "at N = {next} the RPY quadrature's point spacing would be {ratio:.2} times that at the \
         coarsest rung (N = {first}), which changes the quadrature's error that the refinement \
         takes as the same at every rung (docs/model.md section 10)"
    );
    if next == 2 * n - 1 {
        let per_blob = (physical.fluid.points_per_blob).unwrap_or(rpy::POINTS_PER_BLOB);
        format!(
            "{change}: its cells per edge cannot halve with the edges below one cell, at \
             {per_blob} points per blob radius; raise fluid.points_per_blob (twice as many keep \
             the spacing one rung further)"
        )
    } else {
        format!(
            "{change}: N = {next}, the --max-nodes cap, does not halve the spacing of N = {n}; \
             --max-nodes {} reaches the next halving",
            2 * n - 1
        )
    }
}

/// Runs `locate` at the model's `N`, then at successively halved spacings, until the estimated
/// relative error of the answer ([`Refinement`]) is below `accuracy` (with none, until `max_nodes`),
/// the next `N` would pass the fluid model's admissible range (Lighthill, docs/model.md
/// section 3) or `max_nodes`, a third rung or later would not keep the coarsest rung's RPY
/// quadrature point spacing ([`spacing_change`]), a rung fails (the rungs before it are kept),
/// or the rungs stop finding one kind of event.
pub fn refine(
    physical: &Physical,
    accuracy: Option<f64>,
    max_nodes: usize,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Refinement> {
    let admissible = admissible_max_nodes(physical);
    let start = physical.discretization.nodes;
    let limit = admissible.map_or(max_nodes, |a| a.min(max_nodes));
    let orders = error_orders(physical);
    if start > limit {
        // The model's own N is outside the range: refused with the usual message.
        Model::new(physical)?.check_resolution()?;
    }
    let limit_reason = |n: usize| match admissible {
        Some(a) if a <= max_nodes => format!(
            "the next refinement would pass N = {a}, the largest node count at which this rod's \
             Lighthill operator is positive definite (docs/model.md section 3); fluid.model = \
             \"rpy\" has no such limit (section 9)"
        ),
        _ => format!("the next refinement would pass --max-nodes {max_nodes} (at N = {n})"),
    };
    let mut rungs: Vec<Rung> = Vec::new();
    let mut finest: Option<Solved> = None;
    // The two rungs before the finest (coarsest first), for the error in `N` of the Lyapunov
    // coefficient.
    let mut coarser: Vec<Solved> = Vec::new();
    // The estimate of the finest rung (none while it has no omega_b or another kind of event).
    let mut estimate: Option<DiscretizationError> = None;
    // The answer of the rungs so far ([`answer`]; none while `estimate` is).
    let mut answered: Option<Answered> = None;
    // The quadrature's own error, measured at the coarsest rung and the next (RPY line).
    let mut measured = quadrature::Measured::default();
    // The RPY quadrature's point spacing at the coarsest rung ([`spacing_change`]).
    let mut first_spacing: Option<f64> = None;
    // Only the finest rung's Hopf point gets its Lyapunov coefficient (below).
    let quiet = without_criticality(settings);
    let mut n = start;
    let stopped = loop {
        let started = Instant::now();
        // A finer rung starts from the coarser one's Hopf point, at the rate the rungs so far
        // predict ([`Orders::next_increment_ratio`]).
        let sequencing = finest
            .as_ref()
            .filter(|f| matches!(&f.critical, Some(c) if c.event.kind == EventKind::Hopf));
        let (solved, method, fallback, certificate) = match sequencing {
            Some(coarse) => {
                let (nodes, values) = rung_omegabars(&rungs, &coarse.located);
                let k = values.len();
                let predicted = if k >= 2 {
                    values[k - 1]
                        + (values[k - 1] - values[k - 2]) * orders.next_increment_ratio(&nodes, n)
                } else {
                    values[k - 1]
                };
                let sequenced = Model::new(&at_nodes(physical, n))
                    .and_then(|fine| sequenced_rung(fine, coarse, predicted, &quiet, observer));
                match sequenced {
                    Ok(Ok((solved, certificate))) => {
                        (Ok(solved), "sequenced", None, Some(certificate))
                    }
                    Ok(Err(why)) => (
                        continuation_rung(physical, n, &quiet, observer),
                        "continuation",
                        Some(why),
                        None,
                    ),
                    Err(e) if e.is_input() => (Err(e), "sequenced", None, None),
                    // A carried state Newton's method cannot correct (a coarse mesh), a crossing
                    // not found: this rung is followed from rest.
                    Err(e) => (
                        continuation_rung(physical, n, &quiet, observer),
                        "continuation",
                        Some(format!("sequencing failed: {e}")),
                        None,
                    ),
                }
            }
            None => (
                continuation_rung(physical, n, &quiet, observer),
                "continuation",
                None,
                None,
            ),
        };
        let solved = match solved {
            Ok(s) => s,
            Err(e) if finest.is_some() => break Some(format!("the rung at N = {n} failed: {e}")),
            Err(e) => return Err(e),
        };
        if rungs.is_empty() {
            first_spacing = point_spacing(&solved.model);
        }
        observer.located(n, &solved.located);
        let located = &solved.located;
        rungs.push(Rung {
            nodes: n,
            omega_b: located.omega_b,
            kind: located.kind,
            method,
            fallback,
            certificate,
            window_between: located.window_between,
            near_miss_unresolved: located.near_miss_unresolved.clone(),
            seconds: started.elapsed().as_secs_f64(),
        });
        estimate = None;
        answered = None;
        let kind_changed = rungs[0].kind != located.kind;
        let found = located.omega_b.is_some();
        if let Some(before) = finest.replace(solved) {
            if coarser.len() == 2 {
                coarser.remove(0);
            }
            coarser.push(before);
        }
        if !found {
            break Some(format!(
                "no omega_b at N = {n} (kind {}): nothing to refine",
                rungs[rungs.len() - 1].kind
            ));
        }
        if kind_changed {
            break Some(format!(
                "the first instability changes kind between rungs ({}): the rungs follow \
                 different modes, so no error estimate is made",
                rungs
                    .iter()
                    .map(|r| format!("N = {}: {}", r.nodes, r.kind))
                    .collect::<Vec<_>>()
                    .join(", ")
            ));
        }
        if rungs.len() >= 2 {
            let (nodes, values) = rung_values(&rungs);
            let e = discretization_error(orders, &nodes, &values)?;
            let limit = trusted_limit(orders, &nodes, &values, e.observed_order)?;
            let last = values[values.len() - 1];
            let a = answer(last, &e, limit, measured.offset(), measured.correction());
            let relative = a.total() / a.value.abs();
            observer.estimated(relative, &e, &a);
            estimate = Some(e);
            answered = Some(a);
            if accuracy.is_some_and(|a| relative < a) {
                break None;
            }
        }
        // A third rung or beyond must keep the coarsest rung's quadrature point spacing.
        if let (Some(next), Some(spacing)) = (refined(n, limit), first_spacing)
            && rungs.len() >= 2
            && let Some(ratio) = spacing_change(physical, next, spacing)
        {
            break Some(unnested(physical, (rungs[0].nodes, n, next), ratio));
        }
        // The quadrature's error (RPY line), where a finer rung follows: at the coarsest rung (a
        // single rung has no error bar to put it in), and at the next where a trusted limit
        // may follow ([`Orders::Second`], the next rung a halving), to remove it from the answer
        // ([`QuadratureCorrection`]).
        let halving = |m: usize| refined(m, limit) == Some(2 * m - 1);
        let correctable = orders == Orders::Second;
        let second = rungs.len() == 2 && correctable && halving(n) && measured.offset() > 0.0;
        if physical.fluid.model == FluidModel::Rpy
            && refined(n, limit).is_some()
            && (rungs.len() == 1 || second)
        {
            let rung = finest.as_ref().expect("the rung just solved");
            let q = quadrature::measure(physical, rung, &quiet)?;
            observer.quadrature(&q);
            let points_per_blob = q.points_per_blob;
            measured.record(q);
            // A correction may still come after the coarsest rung where the next two rungs
            // halve the spacing; what the quadrature leaves otherwise stops the refinement
            // where it is not below the accuracy.
            let may_come = !second && correctable && halving(n) && halving(2 * n - 1);
            let value = rung.located.omega_b.map_or(f64::NAN, f64::abs);
            if let (Some((what, q)), Some(a)) = (measured.left(may_come), accuracy)
                && q / value >= a
            {
                break Some(format!(
                    "{what}, {:.1e} relative at {points_per_blob} points per blob radius, is not \
                     below the accuracy at any N: raise fluid.points_per_blob (the kernels cost \
                     its square)",
                    q / value
                ));
            }
        }
        match (refined(n, limit), accuracy) {
            (Some(next), _) => n = next,
            // Fixed rungs end at max_nodes.
            (None, None) if n == max_nodes => break None,
            (None, _) => break Some(limit_reason(n)),
        }
    };
    let Solved {
        model,
        located: mut finest,
        critical,
        ..
    } = finest.expect("at least one rung ran");
    let mut lyapunov_error = None;
    if let (true, Some(c)) = (settings.criticality, &critical) {
        finest = finest.with_criticality(&model, &c.event, &c.chart);
        // Against the two rungs before, where the rungs have one kind of point (an estimate of
        // omega_b between them).
        lyapunov_error = estimate
            .as_ref()
            .and_then(|_| LyapunovError::measure(&coarser, &finest, orders));
        if let (Some(e), Some(l1), Some(precision), Some(own)) = (
            &lyapunov_error,
            finest.l1,
            finest.l1_precision,
            finest.criticality,
        ) {
            finest.criticality = Some(e.verdict(l1, precision, own));
        }
    }
    let omega_b_finest = finest.omega_b;
    let finest_error = estimate.as_ref().map(|e| e.error + measured.offset());
    // The answer where it is not the finest rung's own value (a limit, or less the
    // quadrature's error).
    if let (Some(a), Some(w)) = (&answered, omega_b_finest) {
        let ratio = finest.omegabar_b.map_or(f64::NAN, |wb| wb / w);
        finest.omega_b = Some(a.value);
        finest.omegabar_b = Some(a.value * ratio);
    }
    let answer = answered.as_ref().map_or(Answer::FinestRung, |a| a.source);
    let omega_b_error = answered.as_ref().map(Answered::total);
    let quadrature_correction = answered
        .as_ref()
        .and_then(|a| a.correction.clone().map(Box::new));
    let extrapolation_error = answered.and_then(|a| a.limit).map(|l| l.error);
    let relative_error = omega_b_error.zip(finest.omega_b).map(|(e, w)| e / w.abs());
    let reached = relative_error.zip(accuracy).is_some_and(|(r, a)| r < a);
    Ok(Refinement {
        finest,
        answer,
        accuracy,
        reached,
        omega_b_error,
        relative_error,
        omega_b_finest,
        finest_error,
        extrapolation_error,
        estimate: estimate.map(Box::new),
        quadrature: measured.coarse,
        quadrature_finer: measured.finer,
        quadrature_correction,
        lyapunov_error: lyapunov_error.map(Box::new),
        rungs,
        stopped: if reached { None } else { stopped },
        fluid: physical.fluid.model,
    })
}

/// `settings` without the Lyapunov coefficient: the rungs below the finest and the auxiliary
/// rungs (the quadrature's, a boundary point's coarser mesh) do not need it.
fn without_criticality<'a>(settings: &LocateSettings<'a>) -> LocateSettings<'a> {
    LocateSettings {
        criticality: false,
        ..*settings
    }
}

/// The node counts and `omegabar_b` of the rungs so far, the last one `last`'s.
fn rung_omegabars(rungs: &[Rung], last: &Located) -> (Vec<usize>, Vec<f64>) {
    let ratio = last
        .omegabar_b
        .zip(last.omega_b)
        .map_or(1.0, |(wb, w)| wb / w);
    rungs
        .iter()
        .filter_map(|r| r.omega_b.map(|w| (r.nodes, w * ratio)))
        .unzip()
}

/// The node counts and `omega_b` of rungs that all found one.
fn rung_values(rungs: &[Rung]) -> (Vec<usize>, Vec<f64>) {
    rungs
        .iter()
        .filter_map(|r| r.omega_b.map(|w| (r.nodes, w)))
        .unzip()
}

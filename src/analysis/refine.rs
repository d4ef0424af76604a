//! `omega_b` at several node counts: refined (spacing halved) until its estimated
//! discretization error is below a requested accuracy, or over a ladder and extrapolated with
//! the known orders (docs/model.md section 10).

use serde::Serialize;

use crate::analysis::locate::{LocateSettings, Located, Loss, locate};
use crate::engine::arclength::Point;
use crate::engine::events::Event;
use crate::engine::stop::Observer;
use crate::model::params::Physical;
use crate::model::{Model, admissible_max_nodes};
use crate::numerics::fit::{DiscretizationError, Extrapolated, discretization_error, extrapolate};
use crate::{Error, Result};

/// Watches a refinement or a ladder: every rung's continuation as an engine [`Observer`], and
/// each rung's result and error estimate as they come.
pub trait RungObserver: Observer<Point, Event> {
    /// A rung starts on `model`.
    fn rung(&mut self, _model: &Model) {}
    /// The rung at `nodes` located `located`.
    fn located(&mut self, _nodes: usize, _located: &Located) {}
    /// The estimated relative error of the finest `omega_b` so far.
    fn estimated(&mut self, _relative: f64, _estimate: &DiscretizationError) {}
}

/// `locate --extrapolate`: `omega_b` over a ladder of node counts and its limit with the known
/// orders (docs/model.md section 10, [`extrapolate`]).
#[derive(Serialize)]
pub struct Ladder {
    pub nodes: Vec<usize>,
    pub omega_b: Vec<f64>,
    pub omegabar_b: Vec<f64>,
    pub kinds: Vec<Loss>,
    pub omega_b_extrapolated: f64,
    pub omega_b_error: f64,
    pub omegabar_b_extrapolated: f64,
    /// The error model, and its coefficients `c1`, `c2` (rad/s).
    pub model: &'static str,
    pub coefficients: [f64; 2],
    /// Largest admissible node count of the model (docs/model.md section 3); `None` for a fluid
    /// model without a resolution limit (RPY).
    pub nodes_max: Option<usize>,
}

/// `locate --accuracy EPS` (the default of `locate`): `omega_b` refined in `N` until its
/// estimated discretization error (docs/model.md section 10, [`discretization_error`]) is below
/// `EPS` relative, or the model can go no further.
#[derive(Serialize)]
pub struct Refinement {
    /// The finest rung, whose `omega_b` is the answer (its fields at the top level).
    #[serde(flatten)]
    pub finest: Located,
    /// Relative accuracy asked for.
    pub accuracy: f64,
    /// Whether the estimated relative error is below `accuracy`.
    pub reached: bool,
    /// Estimated discretization error of `omega_b` (rad/s) and relative; absent with one rung.
    pub omega_b_error: Option<f64>,
    pub relative_error: Option<f64>,
    /// The estimate: its limit, observed order and method.
    pub estimate: Option<DiscretizationError>,
    /// Every rung: node count, `omega_b`, kind.
    pub rungs: Vec<Rung>,
    /// Why the refinement ended without reaching `accuracy` (absent when it did).
    pub stopped: Option<String>,
}

/// One rung of a refinement.
#[derive(Clone, Serialize)]
pub struct Rung {
    pub nodes: usize,
    pub omega_b: Option<f64>,
    pub kind: Loss,
}

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

/// `physical` at `nodes` nodes.
fn at_nodes(physical: &Physical, nodes: usize) -> Physical {
    let mut p = physical.clone();
    p.discretization.nodes = nodes;
    p.discretization.per_turn = None;
    p
}

/// One rung: `locate` on `physical` at `nodes` nodes.
fn rung(
    physical: &Physical,
    nodes: usize,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Located> {
    let model = Model::new(&at_nodes(physical, nodes))?;
    observer.rung(&model);
    let (located, _) = locate(&model, settings, observer)?;
    observer.located(nodes, &located);
    Ok(located)
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
    let mut results = Vec::new();
    for &n in ladder {
        let located = rung(physical, n, settings, observer)?;
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
    let e: Extrapolated = extrapolate(&nodes, &omega_b)?;
    let ratio = omegabar_b[0] / omega_b[0];
    Ok(Ladder {
        nodes_max: admissible_max_nodes(physical),
        kinds: results.into_iter().map(|r| r.3).collect(),
        nodes,
        omega_b,
        omegabar_b,
        omega_b_extrapolated: e.value,
        omega_b_error: e.error,
        omegabar_b_extrapolated: e.value * ratio,
        model: "omega_b(N) = c0 + c1 h + c2 h^2, h = 1/(N - 1)",
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

/// Runs `locate` at the model's `N`, then at successively halved spacings, until the estimated
/// relative error of the finest `omega_b` is below `accuracy`, the next `N` would pass the
/// fluid model's admissible range (Lighthill, docs/model.md section 3) or `max_nodes`, a rung
/// fails (the rungs before it are kept), or the rungs stop finding one kind of event.
pub fn refine(
    physical: &Physical,
    accuracy: f64,
    max_nodes: usize,
    settings: &LocateSettings,
    observer: &mut impl RungObserver,
) -> Result<Refinement> {
    let admissible = admissible_max_nodes(physical);
    let start = physical.discretization.nodes;
    let limit = admissible.map_or(max_nodes, |a| a.min(max_nodes));
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
    let mut finest: Option<Located> = None;
    // The estimate of the finest rung (none while it has no omega_b or another kind of event).
    let mut estimate: Option<DiscretizationError> = None;
    let mut n = start;
    let stopped = loop {
        let located = match rung(physical, n, settings, observer) {
            Ok(l) => l,
            Err(e) if finest.is_some() => break Some(format!("the rung at N = {n} failed: {e}")),
            Err(e) => return Err(e),
        };
        rungs.push(Rung {
            nodes: n,
            omega_b: located.omega_b,
            kind: located.kind,
        });
        estimate = None;
        let kind_changed = rungs[0].kind != located.kind;
        let found = located.omega_b.is_some();
        finest = Some(located);
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
            let e = discretization_error(&nodes, &values)?;
            let relative = e.error / values[values.len() - 1].abs();
            observer.estimated(relative, &e);
            estimate = Some(e);
            if relative < accuracy {
                break None;
            }
        }
        match refined(n, limit) {
            Some(next) => n = next,
            None => break Some(limit_reason(n)),
        }
    };
    let finest = finest.expect("at least one rung ran");
    let omega_b_error = estimate.as_ref().map(|e| e.error);
    let relative_error = omega_b_error.zip(finest.omega_b).map(|(e, w)| e / w.abs());
    let reached = relative_error.is_some_and(|r| r < accuracy);
    Ok(Refinement {
        finest,
        accuracy,
        reached,
        omega_b_error,
        relative_error,
        estimate,
        rungs,
        stopped: if reached { None } else { stopped },
    })
}

/// The node counts and `omega_b` of rungs that all found one.
fn rung_values(rungs: &[Rung]) -> (Vec<usize>, Vec<f64>) {
    rungs
        .iter()
        .filter_map(|r| r.omega_b.map(|w| (r.nodes, w)))
        .unzip()
}

//! The runs behind `helixbif branch` and `helixbif locate`: continuation with results streamed
//! to disk and progress on stderr.

use std::ops::ControlFlow;
use std::path::Path;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::analysis::locate::{Critical, Located, locate, observables_at, trace};

use crate::analysis::solve::rest_state;
use crate::engine::arclength::{BranchStop, Point};
use crate::engine::events::Event;
use crate::engine::stop::{Observer, Stop};
use crate::model::{Model, admissible_max_nodes};
use crate::numerics::fit::{DiscretizationError, Extrapolated, discretization_error, extrapolate};
use crate::problem::steady::SteadyState;
use crate::study::Study;
use crate::study::output::{CsvWriter, Meta, create_dir};
use crate::{Error, Result};

/// One row of `branch.csv`.
#[derive(Serialize)]
pub struct BranchRow {
    pub s: f64,
    pub omega: f64,
    pub omegabar: f64,
    #[serde(rename = "Fp")]
    pub fp: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    #[serde(rename = "Fpbar_rigid")]
    pub fpbar_rigid: f64,
    #[serde(rename = "Tp")]
    pub tp: f64,
    pub eta: Option<f64>,
    pub h: f64,
    pub hbar: f64,
    pub max_re: f64,
    pub n_unstable: usize,
    pub stable: bool,
}

/// One row of `events.csv`: the eigenvalue in SI (1/s) and normalized.
#[derive(Clone, Serialize)]
pub struct EventRow {
    pub kind: &'static str,
    pub omega: f64,
    pub omegabar: f64,
    pub re: f64,
    pub im: f64,
    pub rebar: f64,
    pub imbar: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    pub hbar: f64,
    pub precision: f64,
    pub unstable_before: usize,
    pub unstable_after: usize,
}

/// A progress bar over `[0, omegabar_max]`, drawn on stderr (hidden when it is not a terminal).
fn progress(omegabar_max: f64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(1000);
    let style = ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} {msg}")
        .expect("a valid template");
    bar.set_style(style);
    bar.set_prefix(what.to_string());
    bar.set_message(format!("up to omegabar = {omegabar_max:.4e}"));
    bar
}

/// Streams the points and events of a branch to CSV files and a progress bar.
struct BranchWriter<'a> {
    model: &'a Model,
    rest: &'a SteadyState,
    rigid_slope: f64,
    points: CsvWriter,
    events: CsvWriter,
    rows: Vec<BranchRow>,
    event_rows: Vec<EventRow>,
    bar: ProgressBar,
    omegabar_max: f64,
    error: Option<Error>,
}

impl BranchWriter<'_> {
    fn record(&mut self, result: Result<()>) {
        if let (Err(e), None) = (result, &self.error) {
            self.error = Some(e);
        }
    }
}

impl Observer<Point, Event> for BranchWriter<'_> {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        let result = observables_at(self.model, self.rest, &point.u, point.p).and_then(|o| {
            let row = BranchRow {
                s: point.s,
                omega: o.omega,
                omegabar: o.omegabar,
                fp: o.fp,
                fpbar: o.fpbar,
                fpbar_rigid: self.rigid_slope * o.omegabar,
                tp: o.tp,
                eta: o.eta,
                h: o.h,
                hbar: o.hbar,
                max_re: point.spectrum.max_re() / self.model.scales.time,
                n_unstable: point.spectrum.unstable,
                stable: point.spectrum.unstable == 0,
            };
            self.points.row(&row)?;
            self.rows.push(row);
            Ok(())
        });
        self.record(result);
        let fraction = (point.p / self.omegabar_max).clamp(0.0, 1.0);
        self.bar.set_position((fraction * 1000.0) as u64);
        self.bar.set_message(format!(
            "omega = {:.4} rad/s, {} unstable",
            self.model.scales.omega_from_bar(point.p),
            point.spectrum.unstable
        ));
        ControlFlow::Continue(())
    }

    fn event(&mut self, event: &Event) -> ControlFlow<()> {
        let time = self.model.scales.time;
        let result = observables_at(self.model, self.rest, &event.u, event.p).and_then(|o| {
            let row = EventRow {
                kind: event.kind.name(),
                omega: o.omega,
                omegabar: event.p,
                re: event.eigenvalue.re / time,
                im: event.eigenvalue.im / time,
                rebar: event.eigenvalue.re,
                imbar: event.eigenvalue.im,
                fpbar: o.fpbar,
                hbar: o.hbar,
                precision: event.precision,
                unstable_before: event.unstable_before,
                unstable_after: event.unstable_after,
            };
            self.events.row(&row)?;
            self.event_rows.push(row);
            Ok(())
        });
        self.record(result);
        ControlFlow::Continue(())
    }
}

/// What `helixbif branch` reports.
#[derive(Serialize)]
pub struct BranchReport {
    /// True when the continuation stalled before `omega_max`.
    pub stalled: bool,
    pub nodes: usize,
    pub points: usize,
    /// The rate of the last point (rad/s).
    pub omega_reached: f64,
    pub events: Vec<EventRow>,
    pub stop: String,
    pub seconds: f64,
    pub omega_max: f64,
    pub out: String,
}

/// The rows of a traced branch, for figures.
pub struct BranchTables {
    pub points: Vec<BranchRow>,
    pub events: Vec<EventRow>,
}

/// Follows the branch from rest to `omega_max` (rad/s), writing `branch.csv`, `events.csv` and
/// `meta.json` into `dir` as it goes. A continuation that stalls (the step fell below its
/// minimum) returns what it found, with the reason in `stop`.
pub fn run_branch(
    study: &Study,
    model: &Model,
    omega_max: f64,
    dir: &Path,
) -> Result<(BranchReport, BranchTables)> {
    let start = Instant::now();
    model.check_resolution()?;
    create_dir(dir)?;
    let rest = rest_state(model, &study.newton)?;
    let omegabar_max = model.scales.omega_to_bar(omega_max);
    let mut writer = BranchWriter {
        model,
        rest: &rest,
        rigid_slope: model.rigid_thrust(1.0)?,
        points: CsvWriter::create(&dir.join("branch.csv"))?,
        events: CsvWriter::create(&dir.join("events.csv"))?,
        rows: Vec::new(),
        event_rows: Vec::new(),
        bar: progress(omegabar_max, "branch"),
        omegabar_max,
        error: None,
    };
    let traced = trace(
        model,
        &rest,
        omegabar_max,
        &study.continuation,
        false,
        &mut writer,
    );
    writer.bar.finish_and_clear();
    if let Some(e) = writer.error {
        return Err(e);
    }
    let branch = traced?;
    let stop = match &branch.stop {
        Stop::ParameterLimit => "omega_max reached".to_string(),
        Stop::MaxPoints => "max_points reached".to_string(),
        Stop::Own(BranchStop::FirstInstability) => "first instability".to_string(),
        Stop::Own(BranchStop::UnstableAtStart) => "unstable at rest".to_string(),
        Stop::StepTooSmall(reason) => format!("step too small: {reason}"),
        Stop::Own(BranchStop::Rule(reason)) => format!("stop rule: {reason}"),
        Stop::Observer => "ended by its observer".to_string(),
    };
    let report = BranchReport {
        stalled: matches!(branch.stop, Stop::StepTooSmall(_)),
        nodes: model.nodes(),
        points: branch.points.len(),
        omega_reached: writer.rows.last().map_or(0.0, |r| r.omega),
        events: writer.event_rows.clone(),
        stop,
        seconds: start.elapsed().as_secs_f64(),
        omega_max,
        out: dir.display().to_string(),
    };
    Meta::new(study, model.scales, &report).write(&dir.join("meta.json"))?;
    let tables = BranchTables {
        points: writer.rows,
        events: writer.event_rows,
    };
    Ok((report, tables))
}

/// A spinner observer for `locate`.
struct LocateProgress<'a> {
    model: &'a Model,
    bar: ProgressBar,
    omegabar_max: f64,
}

impl Observer<Point, Event> for LocateProgress<'_> {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        self.bar
            .set_position(((point.p / self.omegabar_max).clamp(0.0, 1.0) * 1000.0) as u64);
        self.bar.set_message(format!(
            "omega = {:.5} rad/s",
            self.model.scales.omega_from_bar(point.p)
        ));
        ControlFlow::Continue(())
    }
}

/// `locate` on a model with the study's range and numerical settings.
pub fn locate_study(
    study: &Study,
    model: &Model,
    observer: &mut impl Observer<Point, Event>,
) -> Result<(Located, Option<Critical>)> {
    locate(
        model,
        study.branch.omega_max,
        &study.newton,
        &study.continuation,
        observer,
    )
}

/// `locate` on one model, with a progress bar.
pub fn run_locate(study: &Study, model: &Model) -> Result<Located> {
    Ok(run_locate_critical(study, model)?.0)
}

/// [`run_locate`], with the located event.
pub fn run_locate_critical(study: &Study, model: &Model) -> Result<(Located, Option<Critical>)> {
    let omegabar_max = model.scales.omega_to_bar(study.branch.omega_max);
    let mut observer = LocateProgress {
        model,
        bar: progress(omegabar_max, &format!("locate N = {}", model.nodes())),
        omegabar_max,
    };
    let result = locate_study(study, model, &mut observer);
    observer.bar.finish_and_clear();
    result
}

/// `locate --extrapolate`: `omega_b` over a ladder of node counts and its limit with the known
/// orders (docs/model.md section 10, [`extrapolate`]).
#[derive(Serialize)]
pub struct Ladder {
    pub nodes: Vec<usize>,
    pub omega_b: Vec<f64>,
    pub omegabar_b: Vec<f64>,
    pub kinds: Vec<String>,
    pub omega_b_extrapolated: f64,
    pub omega_b_error: f64,
    pub omegabar_b_extrapolated: f64,
    /// The error model, and its coefficients `c1`, `c2` (rad/s).
    pub model: &'static str,
    pub coefficients: [f64; 2],
    /// Largest admissible node count of the study (docs/model.md section 3); `None` for a fluid
    /// model without a resolution limit (RPY).
    pub nodes_max: Option<usize>,
}

/// The default ladder: five node counts evenly spaced from half the admissible maximum to two
/// below it; without an admissible maximum (RPY), the study's `N` and two successive halvings
/// of its node spacing, `N, 2N - 1, 4N - 3`.
pub fn default_ladder(study: &Study) -> Vec<usize> {
    let Some(max) = admissible_max_nodes(&study.physical()) else {
        let n = study.discretization.nodes;
        return vec![n, 2 * n - 1, 4 * n - 3];
    };
    let max = max.saturating_sub(2).max(10);
    let min = (max / 2).max(8);
    (0..5).map(|k| min + (max - min) * k / 4).collect()
}

/// Runs `locate` at each node count of `ladder` and extrapolates.
pub fn run_ladder(study: &Study, ladder: &[usize]) -> Result<Ladder> {
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
        let mut s = study.clone();
        s.discretization.nodes = n;
        let model = Model::new(&s.physical())?;
        let located = run_locate(&s, &model)?;
        let (Some(w), Some(wb)) = (located.omega_b, located.omegabar_b) else {
            return Err(Error::Numerical(format!(
                "no instability up to omega_max = {} rad/s at N = {n}: nothing to extrapolate",
                s.branch.omega_max
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
            results.iter().map(|r| r.3.as_str()).collect::<Vec<_>>()
        )));
    }
    let e: Extrapolated = extrapolate(&nodes, &omega_b)?;
    let ratio = omegabar_b[0] / omega_b[0];
    Ok(Ladder {
        nodes_max: admissible_max_nodes(&study.physical()),
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
    pub kind: String,
}

/// The largest node count a refinement goes to unless told otherwise (`--max-nodes`): the
/// RPY line has no admissible limit, and past a few hundred nodes the dense stability solve at
/// every continuation point makes each rung cost `O(N^3)`.
pub const DEFAULT_MAX_NODES: usize = 500;

/// The node count after `n` in a refinement: the spacing halved (`2N - 1`, so that
/// `h = 1/(N - 1)` halves), capped at `max` (the admissible limit or `--max-nodes`); `None`
/// when `n` is already there.
fn refined(n: usize, max: usize) -> Option<usize> {
    let next = (2 * n - 1).min(max);
    (next > n).then_some(next)
}

/// Runs `locate` at the study's `N`, then at successively halved spacings, until the estimated
/// relative error of the finest `omega_b` is below `accuracy`, the next `N` would pass the
/// fluid model's admissible range (Lighthill, docs/model.md section 3) or `max_nodes`, a rung
/// fails (the rungs before it are kept), or the rungs stop finding one kind of event.
pub fn run_refinement(study: &Study, accuracy: f64, max_nodes: usize) -> Result<Refinement> {
    let admissible = admissible_max_nodes(&study.physical());
    let start = study.discretization.nodes;
    let limit = admissible.map_or(max_nodes, |a| a.min(max_nodes));
    if start > limit {
        // The study's own N is outside the range: refused with the usual message.
        Model::new(&study.physical())?.check_resolution()?;
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
        let mut s = study.clone();
        s.discretization.nodes = n;
        s.discretization.per_turn = None;
        let model = Model::new(&s.physical())?;
        let located = match run_locate(&s, &model) {
            Ok(l) => l,
            Err(e) if finest.is_some() => break Some(format!("the rung at N = {n} failed: {e}")),
            Err(e) => return Err(e),
        };
        eprintln!(
            "locate N = {n}: {} ({})",
            located
                .omega_b
                .map_or("no omega_b".into(), |w| format!("omega_b = {w:.10} rad/s")),
            located.kind
        );
        rungs.push(Rung {
            nodes: n,
            omega_b: located.omega_b,
            kind: located.kind.clone(),
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
            eprintln!("  estimated relative error {relative:.2e} ({})", e.method);
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

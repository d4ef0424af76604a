//! `helixbif branch` and the `branch` study kind: the branch from rest streamed to
//! `branch.csv` and `events.csv` as it is followed, with `meta.json` and a progress bar.

use std::path::Path;
use std::time::Instant;

use indicatif::ProgressBar;
use serde::Serialize;

use crate::analysis::branch::{observables_at, trace};
use crate::analysis::solve::rest_state;
use std::ops::ControlFlow;

use crate::engine::arclength::{BranchStop, Point};
use crate::engine::events::Event;
use crate::engine::stop::{Observer, Stop};
use crate::model::Model;
use crate::model::params::ShapeParams;
use crate::problem::steady::SteadyState;
use crate::study::Study;
use crate::study::figures;
use crate::study::interrupt;
use crate::study::output::{CsvWriter, Meta, Provenance, create_dir};
use crate::study::progress::{self, progress};
use crate::{Error, Result};

/// One row of `branch.csv`.
#[derive(Serialize)]
pub(crate) struct BranchRow {
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
#[derive(Clone, Default, Serialize)]
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
        progress::set_fraction(&self.bar, point.p, (0.0, self.omegabar_max));
        self.bar.set_message(format!(
            "omega = {:.4} rad/s, {} unstable",
            self.model.scales.omega_from_bar(point.p),
            point.spectrum.unstable
        ));
        interrupt::flow()
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

/// An event of a branch as a branch study lists it: kind, rate and frequency (rad/s).
#[derive(Serialize)]
pub struct BranchEvent {
    pub kind: &'static str,
    pub omega: f64,
    pub im: f64,
}

impl BranchEvent {
    pub fn of(row: &EventRow) -> Self {
        BranchEvent {
            kind: row.kind,
            omega: row.omega,
            im: row.im,
        }
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
pub(crate) struct BranchTables {
    pub points: Vec<BranchRow>,
    pub events: Vec<EventRow>,
}

impl BranchReport {
    /// The failure that a continuation which stalled before `omega_max` is (`None` when it did
    /// not stall): where and why, and where its points are.
    pub fn stall(&self) -> Option<Error> {
        self.stall_message().map(Error::Numerical)
    }

    /// Where and why a continuation that stalled before `omega_max` stopped, and where its
    /// points are (`None` when it did not stall).
    pub fn stall_message(&self) -> Option<String> {
        self.stalled.then(|| {
            format!(
                "continuation stalled at omega = {:.6e} rad/s ({}); the {} points found are in {}",
                self.omega_reached, self.stop, self.points, self.out
            )
        })
    }
}

/// `helixbif branch`: [`run_branch`] with its figures (`hbar.svg`, `Fpbar.svg`, ...). A
/// continuation that stalled returns its report too (`stalled`); the front ends print it and
/// then fail with [`BranchReport::stall_message`] (the command line) or raise
/// [`BranchReport::stall`] with the report beside it (Python), its points on disk.
pub fn branch_report(
    study: &Study,
    model: &Model,
    omega_max: f64,
    dir: &Path,
    provenance: &Provenance,
) -> Result<BranchReport> {
    let (report, tables) = run_branch(study, model, omega_max, dir, provenance)?;
    let case = figures::DrawnBranch {
        label: &study.name,
        tables: &tables,
        rigid: matches!(study.shape, ShapeParams::Helix { .. }),
    };
    figures::branch_figures(dir, &[case])?;
    Ok(report)
}

/// Follows the branch from rest to `omega_max` (rad/s), writing `branch.csv`, `events.csv` and
/// `meta.json` into `dir` as it goes. A continuation that stalls (the step fell below its
/// minimum) returns what it found, with the reason in `stop`.
pub(crate) fn run_branch(
    study: &Study,
    model: &Model,
    omega_max: f64,
    dir: &Path,
    provenance: &Provenance,
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
        events: CsvWriter::create_with_header(&dir.join("events.csv"), &EventRow::default())?,
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
    Meta::new(study, model.scales, &report, provenance).write(&dir.join("meta.json"))?;
    let tables = BranchTables {
        points: writer.rows,
        events: writer.event_rows,
    };
    Ok((report, tables))
}

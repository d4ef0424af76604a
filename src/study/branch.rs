//! `helixbif branch` and the `branch` study kind: the branch from rest streamed to
//! `branch.csv` and `events.csv` as it is followed, with `meta.json` and a progress bar.

use std::path::Path;
use std::time::Instant;

use indicatif::ProgressBar;
use serde::Serialize;

use std::ops::ControlFlow;

use crate::analysis::branch::{observables_at, probe_windows, trace_charted};
use crate::analysis::near_miss::NearMisses;
use crate::analysis::solve::rest_state;
use crate::engine::arclength::{BranchStop, Point};
use crate::engine::events::Event;
use crate::engine::stability::Spectrum;
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
    /// A state solved by a probe of a near miss between two points of the continuation
    /// (docs/model.md section 5), its `s` interpolated linearly in `omegabar` along the step.
    pub probe: bool,
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
    /// The index of the point whose step each event lies in.
    event_steps: Vec<usize>,
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

    /// The row of the state `u` at `omegabar = p` with its `spectrum`, at arclength `s`.
    fn row(
        &self,
        s: f64,
        p: f64,
        u: &[f64],
        spectrum: &Spectrum,
        probe: bool,
    ) -> Result<BranchRow> {
        let o = observables_at(self.model, self.rest, u, p)?;
        Ok(BranchRow {
            s,
            omega: o.omega,
            omegabar: o.omegabar,
            fp: o.fp,
            fpbar: o.fpbar,
            fpbar_rigid: self.rigid_slope * o.omegabar,
            tp: o.tp,
            eta: o.eta,
            h: o.h,
            hbar: o.hbar,
            max_re: spectrum.max_re() / self.model.scales.time,
            n_unstable: spectrum.unstable,
            stable: spectrum.unstable == 0,
            probe,
        })
    }

    /// The row of `event`: its eigenvalue in SI (1/s) and normalized.
    fn event_row(&self, event: &Event) -> Result<EventRow> {
        let time = self.model.scales.time;
        let o = observables_at(self.model, self.rest, &event.u, event.p)?;
        Ok(EventRow {
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
        })
    }

    /// The probes of the branch's near misses among its rows (after the point whose step each
    /// lies in, in order along the step) and the losses and regains of the windows they found
    /// among its events, both tables rewritten in `dir` (where any probe was made).
    fn merge_probes(&mut self, dir: &Path, points: &[Point], misses: &NearMisses) -> Result<()> {
        if misses.probes == 0 {
            return Ok(());
        }
        // (the index of the step's first point, the distance from it in `omegabar`, the row)
        let mut rows = Vec::new();
        let probed = misses
            .stable
            .iter()
            .chain(misses.windows.iter().map(|w| &w.probe));
        for q in probed {
            let (a, b) = (&points[q.after], &points[q.after + 1]);
            let s = a.s + (q.p - a.p) / (b.p - a.p) * (b.s - a.s);
            let row = self.row(s, q.p, &q.u, &q.spectrum, true)?;
            rows.push((q.after, (q.p - a.p).abs(), row));
        }
        let mut events = Vec::new();
        for w in &misses.windows {
            let step = w.probe.after;
            for c in std::iter::once(&w.loss).chain(&w.regain) {
                let row = self.event_row(&c.event)?;
                events.push((step, (c.event.p - points[step].p).abs(), row));
            }
        }
        for (i, row) in std::mem::take(&mut self.rows).into_iter().enumerate() {
            rows.push((i, f64::NEG_INFINITY, row));
        }
        let steps = std::mem::take(&mut self.event_steps);
        for (row, step) in std::mem::take(&mut self.event_rows).into_iter().zip(steps) {
            events.push((step, (row.omegabar - points[step].p).abs(), row));
        }
        // Rows by step, then along it (a point before the probes of its step: a step between
        // stable points holds no fold, so `omegabar` orders it). Events by step only, each
        // step's in the order found (a window's step holds no other event, its loss comes
        // before its regain; a continuation step's, in order along it, may turn at a fold).
        rows.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        events.sort_by_key(|e| e.0);
        // Each table written beside the one on disk and renamed over it, so that an interrupted
        // run leaves one or the other whole.
        let (branch_csv, events_csv) = (dir.join("branch.csv"), dir.join("events.csv"));
        let (branch_new, events_new) = (dir.join(".branch.csv.new"), dir.join(".events.csv.new"));
        self.points = CsvWriter::create(&branch_new)?;
        for (_, _, row) in rows {
            self.points.row(&row)?;
            self.rows.push(row);
        }
        self.events = CsvWriter::create_with_header(&events_new, &EventRow::default())?;
        for (step, _, row) in events {
            self.events.row(&row)?;
            self.event_rows.push(row);
            self.event_steps.push(step);
        }
        for (new, path) in [(branch_new, branch_csv), (events_new, events_csv)] {
            std::fs::rename(&new, &path).map_err(|e| Error::Io {
                path: path.display().to_string(),
                source: e,
            })?;
        }
        Ok(())
    }
}

impl Observer<Point, Event> for BranchWriter<'_> {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        let result = self
            .row(point.s, point.p, &point.u, &point.spectrum, false)
            .and_then(|row| {
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
        // Told before the point that ends its step: the step starts at the last row.
        let step = self.rows.len().saturating_sub(1);
        let result = self.event_row(event).and_then(|row| {
            self.events.row(&row)?;
            self.event_rows.push(row);
            self.event_steps.push(step);
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
    /// States solved to search the near misses of the branch (a mode rising towards the axis
    /// and falling back between two points) for windows of instability inside its steps
    /// (docs/model.md section 5; the solves that locate a window's ends are not counted).
    pub probes: usize,
    /// The steps (the rates of their two points, rad/s) the continuation stepped over a window
    /// of instability in that a probe found: its loss and regain are among the events.
    pub windows_between: Vec<[f64; 2]>,
    /// The near misses whose probes neither found nor excluded a window, or found one whose
    /// ends could not be located: where and why.
    pub near_miss_unresolved: Vec<String>,
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
        event_steps: Vec::new(),
        bar: progress(omegabar_max, "branch"),
        omegabar_max,
        error: None,
    };
    let traced = trace_charted(
        model,
        &rest,
        omegabar_max,
        &study.continuation,
        false,
        &mut writer,
    );
    writer.bar.finish_and_clear();
    if let Some(e) = writer.error.take() {
        return Err(e);
    }
    let traced = traced?;
    let misses = if interrupt::requested() {
        NearMisses::default()
    } else {
        probe_windows(
            model,
            &traced,
            omegabar_max,
            &study.newton,
            &study.continuation,
        )?
    };
    writer.merge_probes(dir, &traced.branch.points, &misses)?;
    let branch = traced.branch;
    let omega = |p: f64| model.scales.omega_from_bar(p);
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
        probes: misses.probes,
        windows_between: misses
            .windows
            .iter()
            .map(|w| {
                let (a, b) = NearMisses::step(&branch.points, w);
                [omega(a), omega(b)]
            })
            .collect(),
        near_miss_unresolved: misses.unresolved_described(model).collect(),
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

//! `helixbif orbits`: the branch of periodic orbits born at the Hopf point that `locate` finds
//! ([`crate::analysis::orbits`]): `orbits.csv` (one row per orbit, written as each one converges, so an
//! interrupted run keeps every finished orbit), `states/orbit_<index>.json` (each orbit's start
//! and observables over a period, for `simulate --from-orbit`), `events.csv`, `meta.json`, and `amplitude.svg`,
//! `hbar.svg`, `Fpbar.svg` (time averages over a period against `omega` over the steady branch
//! from rest, which is written to `branch/`; stable parts solid, unstable dashed).

use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::analysis::locate::Loss;
use crate::analysis::locate::hopf_criticality;
use crate::engine::events::EventKind;

use crate::analysis::orbits::{OrbitRow, OrbitStart, follow_rod_orbits, hopf_start};
use crate::analysis::solve::rest_state;
use crate::engine::criticality::Verdict;
use crate::engine::periodic::branch::{
    Checkpoint, OrbitBranchSettings, OrbitEvent, OrbitEventKind, OrbitStop,
};
use crate::model::Model;
use crate::plot::{Figure, Marker, Series, Style, write_figure};
use crate::study::Study;
use crate::study::branch::run_branch;
use crate::study::figures::{FPBAR_LABEL, HBAR_LABEL, OMEGA_LABEL};
use crate::study::locate::run_locate_critical;
use crate::study::output::{CsvWriter, Meta, Provenance, create_dir, resumed_checkpoint};
use crate::study::plan::OrbitPlan;
use crate::study::progress;
use crate::{Error, Result};

/// What the command line sets.
#[derive(Clone, Debug, Serialize)]
pub struct OrbitsOptions {
    pub settings: OrbitBranchSettings,
    /// Range of `omega` (rad/s) the branch may visit.
    pub omega_range: (f64, f64),
    /// Take the branch up again from `checkpoint.json` in the output folder, when there is one.
    pub resume: bool,
}

/// The orbit branch's settings from what a study or the command line sets: the largest number
/// of orbits, the steps per period and the first orbit's normal-form radius (`ell`); the rest
/// at their defaults.
pub fn branch_settings(max_orbits: usize, steps: usize, amplitude: f64) -> OrbitBranchSettings {
    let mut settings = OrbitBranchSettings {
        amplitude,
        max_orbits,
        ..OrbitBranchSettings::default()
    };
    settings.shooting.flow.steps = steps;
    settings
}

impl OrbitsOptions {
    /// The options an orbit plan sets, the range's upper end `omega_max` unless the plan sets
    /// it.
    pub(crate) fn of_plan(plan: &OrbitPlan, omega_max: f64) -> Self {
        OrbitsOptions {
            settings: branch_settings(plan.max_orbits, plan.steps, plan.amplitude),
            omega_range: (
                plan.omega_min.unwrap_or(0.0),
                plan.omega_max.unwrap_or(omega_max),
            ),
            resume: false,
        }
    }

    /// Checks ranges: the branch settings' and `omega_min < omega_max`, both finite (fields
    /// named `orbits.*`).
    pub fn validate(&self) -> Result<()> {
        self.validate_naming(|s| format!("orbits.{s}"))
    }

    /// [`OrbitsOptions::validate`], each field named by `name` (given the field, e.g.
    /// `max_orbits`: a study key or a command-line option).
    pub fn validate_naming(&self, name: impl Fn(&str) -> String) -> Result<()> {
        self.settings
            .validate()
            .map_err(|e| e.naming_setting(&name))?;
        let (lo, hi) = self.omega_range;
        if lo.is_finite() && hi.is_finite() && lo < hi {
            Ok(())
        } else {
            Err(Error::input(
                name("omega_min"),
                format!("need finite omega_min < omega_max (rad/s), got {lo} and {hi}"),
            ))
        }
    }
}

/// One row of `events.csv`: an event bracketed by orbits `after` and `after + 1`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OrbitEventRow {
    pub kind: OrbitEventKind,
    pub after: usize,
    pub omega_from: f64,
    pub omega_to: f64,
}

/// What `helixbif orbits` reports.
#[derive(Clone, Debug, Serialize)]
pub struct OrbitsReport {
    pub nodes: usize,
    /// The Hopf point: rate (rad/s), critical frequency (rad/s), first Lyapunov coefficient.
    pub omega_hopf: f64,
    pub frequency: f64,
    pub l1: f64,
    pub criticality: Verdict,
    pub orbits: usize,
    pub stop: OrbitStop,
    pub events: Vec<OrbitEventRow>,
    pub first: Option<OrbitRow>,
    pub last: Option<OrbitRow>,
    /// The index of the first orbit computed by this run when it resumed a checkpoint.
    pub resumed_at: Option<usize>,
    pub seconds: f64,
    pub out: String,
}

/// Writes `events.csv` (rates in rad/s), returning its rows.
fn write_events(
    events: &[OrbitEvent],
    s: &crate::model::params::Scales,
    path: &Path,
) -> Result<Vec<OrbitEventRow>> {
    let rows: Vec<OrbitEventRow> = events
        .iter()
        .map(|e| OrbitEventRow {
            kind: e.kind,
            after: e.after,
            omega_from: s.omega_from_bar(e.p.0),
            omega_to: s.omega_from_bar(e.p.1),
        })
        .collect();
    let sample = OrbitEventRow {
        kind: OrbitEventKind::Fold,
        after: 0,
        omega_from: 0.0,
        omega_to: 0.0,
    };
    let mut table = CsvWriter::create_with_header(path, &sample)?;
    for e in &rows {
        table.row(e)?;
    }
    Ok(rows)
}

/// The file of orbit `index`'s start in the folder `states/` (see [`OrbitStart`]).
fn start_file_name(index: usize) -> String {
    format!("orbit_{index:04}.json")
}

/// `checkpoint.json` of an orbit branch: the engine's checkpoint and what the branch is made of,
/// which a resumed run must share (`key`, [`checkpoint_key`]; absent from the checkpoints of
/// versions that did not record it, which are not resumed).
#[derive(Serialize, Deserialize)]
struct OrbitsCheckpoint {
    #[serde(default)]
    key: Option<serde_json::Value>,
    #[serde(flatten)]
    checkpoint: Checkpoint,
}

/// What an orbit branch is made of: the study's rod, fluid, shape and discretization, and the
/// branch's settings but the number of orbits (which a resumed run may raise, as it may widen
/// the range of `omega`).
fn checkpoint_key(study: &Study, opts: &OrbitsOptions) -> Result<serde_json::Value> {
    let mut settings =
        serde_json::to_value(&opts.settings).map_err(|e| Error::Numerical(e.to_string()))?;
    if let Some(map) = settings.as_object_mut() {
        map.remove("max_orbits");
    }
    Ok(serde_json::json!({ "physical": study.physical(), "settings": settings }))
}

/// With `resume`, the checkpoint an earlier run of the same branch left in `dir`
/// ([`resumed_checkpoint`]: refused where it records other options or another study, or
/// nothing, as the checkpoints of earlier versions).
fn saved_checkpoint(
    dir: &Path,
    resume: bool,
    key: &serde_json::Value,
) -> Result<Option<Checkpoint>> {
    let saved = resumed_checkpoint(
        &dir.join("checkpoint.json"),
        resume,
        key,
        |c: &OrbitsCheckpoint| c.key.as_ref(),
    )?;
    Ok(saved.map(|c| c.checkpoint))
}

/// Whether the orbit branch `opts` of `study` can resume in `dir` ([`saved_checkpoint`]): checked
/// by a dynamics study before any of its simulations runs.
pub(crate) fn check_resumable(study: &Study, opts: &OrbitsOptions, dir: &Path) -> Result<()> {
    saved_checkpoint(dir, opts.resume, &checkpoint_key(study, opts)?).map(|_| ())
}

/// Locates the first loss of stability of `study` on `model`, and when it is a Hopf point with
/// a Lyapunov coefficient, follows the orbits born there, writing into `dir`.
///
/// # Errors
/// Bad options; [`Error::Numerical`] when the first loss of stability is not a Hopf point; the
/// shooting's error ([`crate::error::EngineError::NewtonFailed`] or a numerical one) when either starting orbit
/// fails. A later failure is the branch's stop reason, with the orbits before it on disk.
pub fn run_orbits(
    study: &Study,
    model: &Model,
    opts: &OrbitsOptions,
    dir: &Path,
    provenance: &Provenance,
) -> Result<OrbitsReport> {
    opts.validate()?;
    let (lo, hi) = opts.omega_range;
    let started = Instant::now();
    create_dir(dir)?;
    // A checkpoint of another branch is refused before anything is computed.
    let checkpoint_path = dir.join("checkpoint.json");
    let key = checkpoint_key(study, opts)?;
    let resume = saved_checkpoint(dir, opts.resume, &key)?;
    let (located, critical) = run_locate_critical(study, model)?;
    let critical = match (located.kind, critical) {
        (Loss::Event(EventKind::Hopf), Some(c)) => c,
        (kind, _) => {
            return Err(Error::Numerical(format!(
                "no Hopf point to start periodic orbits from: the first loss of stability of \
                 the branch from rest is `{kind}`"
            )));
        }
    };
    let lyapunov = hopf_criticality(model, &critical.event, &critical.chart)?;
    let (dynamics, start) = hopf_start(model, &critical, lyapunov.q.clone());
    let rest = rest_state(model, &study.newton)?;
    let h0 = model.height(&rest.config.x);
    let s = model.scales;
    let bar = progress::spinner("orbits");
    bar.set_message("the first orbits from the Hopf point");
    // On a resumed run the orbits and events before the checkpoint are kept as they were.
    let next = resume.as_ref().map_or(0, |c| c.next_index);
    let mut rows: Vec<OrbitRow> =
        crate::study::output::read_rows(&dir.join("orbits.csv"), resume.is_some())?;
    rows.retain(|r| r.index < next);
    let states = dir.join("states");
    create_dir(&states)?;
    let physical =
        serde_json::to_value(study.physical()).map_err(|e| Error::Numerical(e.to_string()))?;
    let mut csv = CsvWriter::create(&dir.join("orbits.csv"))?;
    for r in &rows {
        csv.row(r)?;
    }
    let followed = follow_rod_orbits(
        &dynamics,
        &start,
        resume.as_ref(),
        &opts.settings,
        (s.omega_to_bar(lo), s.omega_to_bar(hi)),
        h0,
        |row, start, checkpoint| {
            crate::study::interrupt::check()?;
            bar.set_message(format!(
                "orbit {}: omega = {:.6} rad/s, amplitude {:.3e} m, {}",
                row.index, row.omega, row.amplitude, row.verdict
            ));
            csv.row(row)?;
            let start = OrbitStart {
                physical: physical.clone(),
                ..start.clone()
            };
            crate::study::output::write_json_atomically(
                &states.join(start_file_name(row.index)),
                &start,
            )?;
            match checkpoint {
                Some(c) => {
                    write_events(&c.events, &s, &dir.join("events.csv"))?;
                    let saved = OrbitsCheckpoint {
                        key: Some(key.clone()),
                        checkpoint: c.clone(),
                    };
                    crate::study::output::write_json_atomically(&checkpoint_path, &saved)
                }
                None => Ok(()),
            }
        },
    );
    bar.finish_and_clear();
    let (branch, new_rows) = followed?;
    rows.extend(new_rows);
    let events = write_events(&branch.events, &s, &dir.join("events.csv"))?;
    let omega_hopf = s.omega_from_bar(critical.event.p);
    // The steady branch underneath, a little past the Hopf point (in `branch/`).
    let (_, steady) = run_branch(
        study,
        model,
        1.1 * omega_hopf,
        &dir.join("branch"),
        provenance,
    )?;
    let omegas: Vec<f64> = rows.iter().map(|r| r.omega).collect();
    let stable: Vec<bool> = rows.iter().map(|r| r.stable).collect();
    let orbit_series = |y: Vec<f64>| Series {
        label: "orbits (shooting): average over a period".into(),
        x: omegas.clone(),
        y,
        style: Style::Line,
        stable: Some(stable.clone()),
        err: None,
    };
    let steady_series = |y: Vec<f64>| Series {
        label: "steady branch (continuation)".into(),
        x: steady.points.iter().map(|r| r.omega).collect(),
        y,
        style: Style::Line,
        stable: Some(steady.points.iter().map(|r| r.stable).collect()),
        err: None,
    };
    for (name, label, series, at_hopf) in [
        (
            "amplitude.svg",
            "rms displacement from the mean shape (m)",
            vec![orbit_series(rows.iter().map(|r| r.amplitude).collect())],
            0.0,
        ),
        (
            "hbar.svg",
            HBAR_LABEL,
            vec![
                steady_series(steady.points.iter().map(|r| r.hbar).collect()),
                orbit_series(rows.iter().map(|r| r.hbar_mean).collect()),
            ],
            located.hbar.unwrap_or(f64::NAN),
        ),
        (
            "Fpbar.svg",
            FPBAR_LABEL,
            vec![
                steady_series(steady.points.iter().map(|r| r.fpbar).collect()),
                orbit_series(rows.iter().map(|r| r.fpbar_mean).collect()),
            ],
            located.fpbar.unwrap_or(f64::NAN),
        ),
    ] {
        write_figure(
            &Figure {
                title: "Periodic orbits from the Hopf point".into(),
                x_label: OMEGA_LABEL.into(),
                y_label: label.into(),
                series,
                markers: vec![Marker {
                    label: "Hopf point".into(),
                    x: omega_hopf,
                    y: at_hopf,
                }],
                ..Figure::default()
            },
            &dir.join(name),
        )?;
    }
    let report = OrbitsReport {
        nodes: model.nodes(),
        omega_hopf,
        frequency: s.omega_from_bar(start.frequency),
        l1: lyapunov.l1,
        criticality: lyapunov.verdict,
        orbits: rows.len(),
        stop: branch.stop,
        events,
        first: rows.first().cloned(),
        last: rows.last().cloned(),
        resumed_at: resume.map(|c| c.next_index),
        seconds: started.elapsed().as_secs_f64(),
        out: dir.display().to_string(),
    };
    Meta::new(study, s, (&report, opts), provenance).write(&dir.join("meta.json"))?;
    Ok(report)
}

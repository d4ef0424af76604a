//! `helixbif simulate`: the rod stepped through time from rest, from a steady state or from a
//! periodic orbit, its observables as time series (`timeseries.csv`, `shapes.csv`), their
//! late-time statistics, checkpoints for `--resume`, and figures.
//!
//! During the motion the force on the fluid includes the rod's own velocity in the co-rotating
//! frame, `F = Z (Omega X + V)`. It is obtained without differentiating the trajectory: on the
//! free nodes force balance gives `F_free = -dE/dx + F_gravity` exactly, and with the clamp
//! nodes at rest in the co-rotating frame (`V = 0` there) the clamp forces follow from the
//! mobility, `F_c = A_cc^{-1} (Omega X_c - A_cf F_free)`.

use std::ops::ControlFlow;
use std::path::Path;

use indicatif::ProgressBar;
use serde::Serialize;

use crate::analysis::dynamics::{
    Checkpoints, DynamicsSettings, IntegratorState, Rate, Sample, Start, integrate_from,
    least_stable_mode, perturb,
};
use crate::analysis::orbits::OrbitStart;
use crate::analysis::solve::rest_state;
use crate::analysis::solve::solve_at;
use crate::engine::newton::NewtonSettings;
use crate::model::Model;
use crate::model::observables::Observables;
use crate::model::observables::moving_forces;
use crate::model::steady::Steady;
use crate::plot::{Figure, Series, Style, write_figure};
use crate::problem::twist::natural_chart_unknowns;
use crate::study::Study;
use crate::study::cycles::{CycleRow, cycles};
use crate::study::figures::{FPBAR_LABEL, HBAR_LABEL, typeset};
use crate::study::output::{CsvWriter, Meta, Provenance, resumed_checkpoint};
use crate::{Error, Result};

use crate::numerics::statistics::late_statistics;

/// One row of `shapes.csv`: a node's position (m) at time `t` (s).
#[derive(Clone, Debug, Default, Serialize)]
struct ShapeRow {
    t: f64,
    node: usize,
    x: f64,
    y: f64,
    z: f64,
}

/// One row of `timeseries.csv` (SI and normalized).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub(crate) struct TimeRow {
    pub t: f64,
    pub omega: f64,
    pub hbar: f64,
    #[serde(rename = "Fp")]
    pub fp: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    #[serde(rename = "Tp")]
    pub tp: f64,
    pub eta: Option<f64>,
}

/// The start of the statistics of a simulation when none is asked for (s): the second half of the
/// run, `t_end / 2`, or the end of the spin-up ramp (`ramp_time`) of a run from rest if that is
/// later, so that the statistics never include the ramp. A run from a steady state or an orbit
/// has no ramp.
pub fn default_transient(t_end: f64, ramp_time: f64, from_rest: bool) -> f64 {
    let spin_up = if from_rest { ramp_time } else { 0.0 };
    (0.5 * t_end).max(spin_up)
}

/// How a simulation starts and what it records.
#[derive(Clone, Debug)]
pub struct SimulateOptions {
    /// Rate of the motor (rad/s).
    pub omega: f64,
    /// Duration (s).
    pub t_end: f64,
    /// Start on the steady state at `omega` (else: from rest, the motor ramped up over
    /// `ramp_time`).
    pub from_steady: bool,
    /// Perturbation along the least stable mode (largest displacement, in units of the
    /// reference length), for runs from the steady state.
    pub perturb: Option<f64>,
    /// Start on a periodic orbit (`states/orbit_<index>.json` of `helixbif orbits`), at the
    /// fixed rate `omega`; the run is then compared with the orbit period by period
    /// (`cycles.csv`, [`super::cycles`]).
    pub from_orbit: Option<OrbitOrigin>,
    /// Spin-up time (s) of a run from rest.
    pub ramp_time: f64,
    /// Statistics over `t >= transient` (s).
    pub transient: f64,
    /// Write the shape every this many accepted steps (0: never).
    pub shape_every: usize,
    /// Newton's method for the rest state and the steady state (the study's `[newton]`).
    pub newton: NewtonSettings,
    /// Continue from `checkpoint.json` in the output folder when there is one (a later
    /// `t_end` extends a finished run); else start afresh.
    pub resume: bool,
    /// What the run is made of beyond these options (the study's physical part and the
    /// integrator table), stored in the checkpoint and compared on `resume`.
    pub provenance: serde_json::Value,
}

/// A periodic orbit's start and the file it was read from.
#[derive(Clone, Debug)]
pub struct OrbitOrigin {
    pub path: String,
    pub start: OrbitStart,
}

impl OrbitOrigin {
    /// Reads `path` (an [`OrbitStart`] in JSON).
    ///
    /// # Errors
    /// [`Error::Input`] naming `--from-orbit` when the file cannot be read or is not an orbit's
    /// start.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::input("--from-orbit", format!("{}: {e}", path.display())))?;
        let start: OrbitStart = serde_json::from_str(&text).map_err(|e| {
            Error::input(
                "--from-orbit",
                format!(
                    "{} is not an orbit's start (states/orbit_<index>.json of `helixbif orbits`): {e}",
                    path.display()
                ),
            )
        })?;
        Ok(OrbitOrigin {
            path: path.display().to_string(),
            start,
        })
    }
}

/// What a simulation of `study` is made of beyond its options (for [`SimulateOptions::provenance`]):
/// the physical part and the integrator table.
pub fn simulation_provenance(study: &crate::study::Study) -> serde_json::Value {
    serde_json::json!({ "physical": study.physical(), "integrator": study.integrator })
}

/// Accepted steps between two checkpoints of a simulation.
const CHECKPOINT_EVERY: usize = 25;

/// `checkpoint.json` of a simulation: the integrator's state after an accepted step, the rows
/// of `timeseries.csv` and lines of `shapes.csv` written up to it, and what the run is made
/// of (a resumed run must be the same run).
#[derive(Serialize, serde::Deserialize)]
struct SimulationCheckpoint {
    key: serde_json::Value,
    samples: usize,
    shape_lines: usize,
    /// Wall-clock seconds the run had taken up to the save, over all its sessions.
    #[serde(default)]
    seconds: f64,
    state: IntegratorState,
}

/// The fields of a run that a resumed run must share (not `t_end`, `transient`: a finished
/// run may be extended and its statistics retaken).
fn checkpoint_key(opts: &SimulateOptions, settings: &DynamicsSettings) -> serde_json::Value {
    let mut key = serde_json::json!({
        "omega": opts.omega,
        "from_steady": opts.from_steady,
        "perturb": opts.perturb,
        "ramp_time": opts.ramp_time,
        "shape_every": opts.shape_every,
        "settings": settings,
        "provenance": opts.provenance,
    });
    if let Some(o) = &opts.from_orbit {
        key["from_orbit"] = serde_json::json!({ "path": o.path, "index": o.start.index });
    }
    key
}

/// With `opts.resume`, the checkpoint an earlier run of the same simulation left in `dir`
/// ([`resumed_checkpoint`]: refused where it records other options or another study).
fn saved_checkpoint(
    dir: &Path,
    opts: &SimulateOptions,
    settings: &DynamicsSettings,
) -> Result<Option<SimulationCheckpoint>> {
    let key = checkpoint_key(opts, settings);
    resumed_checkpoint(
        &dir.join("checkpoint.json"),
        opts.resume,
        &key,
        |c: &SimulationCheckpoint| Some(&c.key),
    )
}

/// Whether the simulation `opts` can resume in `dir` ([`saved_checkpoint`]): checked by a study
/// of several simulations for every one before any runs.
pub(crate) fn check_resumable(
    dir: &Path,
    opts: &SimulateOptions,
    settings: &DynamicsSettings,
) -> Result<()> {
    saved_checkpoint(dir, opts, settings).map(|_| ())
}

/// Keeps the first `keep` lines after `header` lines of the text file at `path` (rows an
/// interrupted run wrote after its last checkpoint are dropped; they are computed again).
fn truncate_lines(path: &Path, header: usize, keep: usize) -> Result<()> {
    let text = std::fs::read_to_string(path).map_err(crate::study::output::io_error(path))?;
    let lines: Vec<&str> = text.lines().collect();
    if lines.len() < header + keep {
        return Err(Error::input(
            "--resume",
            format!(
                "{} holds {} rows, fewer than the {keep} its checkpoint counts",
                path.display(),
                lines.len().saturating_sub(header)
            ),
        ));
    }
    let mut kept = lines[..header + keep].join("\n");
    if !kept.is_empty() {
        kept.push('\n');
    }
    std::fs::write(path, kept).map_err(crate::study::output::io_error(path))
}

/// What a simulation reports.
#[derive(Clone, Debug, Serialize)]
pub struct SimulateReport {
    pub omega: f64,
    pub t_end: f64,
    pub steps: usize,
    pub rejected: usize,
    pub newton_iterations: usize,
    /// Step Jacobians evaluated and factorized.
    pub jacobians: usize,
    pub hbar_mean: Option<f64>,
    pub hbar_std: Option<f64>,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: Option<f64>,
    #[serde(rename = "Fpbar_std")]
    pub fpbar_std: Option<f64>,
    pub eta_mean: Option<f64>,
    pub eta_std: Option<f64>,
    /// Start of the statistics (s).
    pub transient: f64,
    /// Wall-clock seconds of the run, over all its sessions (a resumed run counts the saved ones).
    pub seconds: f64,
    /// The output folder.
    pub out: String,
    /// For a run started on a periodic orbit: the orbit and the run period by period.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub orbit: Option<OrbitComparison>,
}

/// A run started on a periodic orbit against the orbit (see [`super::cycles`]).
#[derive(Clone, Debug, Serialize)]
pub struct OrbitComparison {
    pub index: usize,
    pub omega: f64,
    pub period: f64,
    pub max_multiplier: f64,
    /// The orbit's period averages.
    pub hbar_mean: f64,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: f64,
    pub cycles: Vec<CycleRow>,
}

/// Runs one simulation, writing `timeseries.csv`, `shapes.csv` (when asked) and `timeseries.svg`
/// into `dir` as it goes.
pub fn run_simulate(
    study: &Study,
    model: &Model,
    settings: &DynamicsSettings,
    opts: &SimulateOptions,
    dir: &Path,
    progress: &ProgressBar,
    provenance: &Provenance,
) -> Result<SimulateReport> {
    let start = std::time::Instant::now();
    if !opts.omega.is_finite() {
        return Err(Error::input(
            "--omega",
            format!("must be a finite number (rad/s), got {}", opts.omega),
        ));
    }
    for (field, v) in [
        ("--t-end", opts.t_end),
        ("--transient", opts.transient),
        ("--ramp-time", opts.ramp_time),
    ] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(Error::input(
                field,
                format!("must be a finite number >= 0, got {v}"),
            ));
        }
    }
    if opts.t_end <= 0.0 {
        return Err(Error::input("--t-end", "must be > 0"));
    }
    if let Some(o) = &opts.from_orbit {
        if opts.from_steady {
            return Err(Error::input(
                "--from-orbit",
                "starts on an orbit; it cannot be combined with --from-steady",
            ));
        }
        if opts.provenance.get("physical") != Some(&o.start.physical)
            || o.start.u.len() != model.rod.layout.free_len()
        {
            return Err(Error::input(
                "--from-orbit",
                format!(
                    "{} belongs to another model: its rod, fluid, shape or discretization differ \
                     from the study's",
                    o.path
                ),
            ));
        }
    }
    model.check_resolution()?;
    crate::study::output::create_dir(dir)?;
    let scales = model.scales;
    let omegabar = scales.omega_to_bar(opts.omega);
    let rest = rest_state(model, &opts.newton)?;
    let h0 = model.height(&rest.config.x);
    let steady = Steady::new(model, 0.0);
    let rate = if !opts.from_steady && opts.from_orbit.is_none() && opts.ramp_time > 0.0 {
        Rate::Ramp {
            target: omegabar,
            ramp_time: opts.ramp_time / scales.time,
        }
    } else {
        Rate::Fixed(omegabar)
    };
    let checkpoint_path = dir.join("checkpoint.json");
    let series_path = dir.join("timeseries.csv");
    let shapes_path = dir.join("shapes.csv");
    let saved = saved_checkpoint(dir, opts, settings)?;
    let key = checkpoint_key(opts, settings);
    // On a resumed run the rows up to the checkpoint are kept and read back (for the
    // statistics), the ones after it dropped: they are computed again.
    let earlier_seconds = saved.as_ref().map_or(0.0, |c| c.seconds);
    let (start_from, mut series, mut shapes, mut rows, mut count, mut shape_lines) = match saved {
        Some(saved) => {
            truncate_lines(&series_path, 1, saved.samples)?;
            let rows: Vec<TimeRow> = crate::study::output::read_rows(&series_path, true)?;
            let shapes = if opts.shape_every > 0 {
                truncate_lines(&shapes_path, 1, saved.shape_lines)?;
                Some(CsvWriter::append(&shapes_path)?)
            } else {
                None
            };
            (
                Start::Resume(Box::new(saved.state)),
                CsvWriter::append(&series_path)?,
                shapes,
                rows,
                saved.samples,
                saved.shape_lines,
            )
        }
        None => {
            let u0 = if let Some(o) = &opts.from_orbit {
                o.start.u.clone()
            } else if opts.from_steady {
                let solution = solve_at(model, omegabar, &opts.newton)?;
                let mut u =
                    natural_chart_unknowns(model, &solution.state.config, &solution.state.chart)?;
                if let Some(eps) = opts.perturb {
                    let mode = least_stable_mode(model, omegabar, &u)?;
                    u = perturb(model, &u, &mode, eps, 0.0)?;
                }
                u
            } else {
                steady.free_vector(&rest.config)
            };
            let shapes = (opts.shape_every > 0)
                .then(|| CsvWriter::create_with_header(&shapes_path, &ShapeRow::default()))
                .transpose()?;
            (
                Start::Initial(u0),
                CsvWriter::create(&series_path)?,
                shapes,
                Vec::new(),
                0,
                0,
            )
        }
    };
    let bar = progress.clone();
    bar.set_length(1000);
    let mut failure: Option<Error> = None;
    let observer = |s: &Sample| {
        let result = (|| -> Result<()> {
            let forces = moving_forces(model, &s.u_chart, &s.chart, s.omega)?;
            let x = steady.config(&s.u_chart).x;
            let o: Observables = model.observables(s.omega, &x, &forces, h0);
            let row = TimeRow {
                t: s.t * scales.time,
                omega: o.omega,
                hbar: o.hbar,
                fp: o.fp,
                fpbar: o.fpbar,
                tp: o.tp,
                eta: o.eta,
            };
            series.row(&row)?;
            if let Some(w) = shapes.as_mut()
                && count.is_multiple_of(opts.shape_every)
            {
                for (i, p) in x.iter().enumerate() {
                    let p = p * scales.length;
                    w.row(&ShapeRow {
                        t: s.t * scales.time,
                        node: i,
                        x: p.x,
                        y: p.y,
                        z: p.z,
                    })?;
                }
                shape_lines += x.len();
            }
            bar.set_position((1000.0 * row.t / opts.t_end).min(1000.0) as u64);
            bar.set_message(format!(
                "t = {:.1} of {} s, hbar = {:.3}",
                row.t, opts.t_end, row.hbar
            ));
            rows.push(row);
            count += 1;
            Ok(())
        })();
        match result {
            Ok(()) => crate::study::interrupt::flow(),
            Err(e) => {
                failure = Some(e);
                ControlFlow::Break(())
            }
        }
    };
    // The observer has written every sample up to the state being saved (rows and shape lines
    // are counted from the saved state's step count: the initial sample plus one per step).
    let every_shape = opts.shape_every.max(1);
    let nodes = model.rod.layout.nodes();
    let mut save = |state: &IntegratorState| -> Result<()> {
        let samples = state.steps + 1;
        let shape_lines = if opts.shape_every > 0 {
            samples.div_ceil(every_shape) * nodes
        } else {
            0
        };
        crate::study::output::write_json_atomically(
            &checkpoint_path,
            &SimulationCheckpoint {
                key: key.clone(),
                samples,
                shape_lines,
                seconds: earlier_seconds + start.elapsed().as_secs_f64(),
                state: state.clone(),
            },
        )
    };
    let trajectory = integrate_from(
        model,
        rate,
        start_from,
        opts.t_end / scales.time,
        settings,
        observer,
        Some(Checkpoints {
            every: CHECKPOINT_EVERY,
            save: &mut save,
        }),
    );
    bar.finish_and_clear();
    if let Some(e) = failure {
        return Err(e);
    }
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let hbar_series: Vec<f64> = rows.iter().map(|r| r.hbar).collect();
    let fpbar_series: Vec<f64> = rows.iter().map(|r| r.fpbar).collect();
    let hbar = late_statistics(&t, &hbar_series, opts.transient);
    let fpbar = late_statistics(&t, &fpbar_series, opts.transient);
    let (t_eta, y_eta): (Vec<f64>, Vec<f64>) =
        rows.iter().filter_map(|r| r.eta.map(|e| (r.t, e))).unzip();
    let eta = late_statistics(&t_eta, &y_eta, opts.transient);
    let line = |label: &str, y: &[f64]| Series {
        label: label.into(),
        x: t.clone(),
        y: y.to_vec(),
        style: Style::Line,
        stable: None,
        err: None,
    };
    for (name, label, short, y) in [
        ("hbar.svg", HBAR_LABEL, "h̄", &hbar_series),
        ("Fpbar.svg", FPBAR_LABEL, "F̄ₚ", &fpbar_series),
    ] {
        write_figure(
            &Figure {
                title: format!(
                    "Simulation at ω = {} rad/s",
                    typeset(&opts.omega.to_string())
                ),
                x_label: "t (s)".into(),
                y_label: label.into(),
                series: vec![line(short, y)],
                ..Figure::default()
            },
            &dir.join(format!("timeseries_{name}")),
        )?;
    }
    let trajectory = trajectory.map_err(|e| match (e, rows.last()) {
        (Error::Numerical(why), Some(last)) => Error::Numerical(format!(
            "the simulation at omega = {} rad/s stopped at t = {:.4} s, the last state kept \
             having hbar = {:.4} (h/h0) and Fpbar = {:.4}; the {} samples before it are in {}: \
             {why}",
            opts.omega,
            last.t,
            last.hbar,
            last.fpbar,
            rows.len(),
            dir.join("timeseries.csv").display()
        )),
        (e, _) => e,
    })?;
    let orbit = match &opts.from_orbit {
        Some(o) => {
            let rows = cycles(&t, &hbar_series, &fpbar_series, &o.start);
            let mut csv =
                CsvWriter::create_with_header(&dir.join("cycles.csv"), &CycleRow::default())?;
            for r in &rows {
                csv.row(r)?;
            }
            Some(OrbitComparison {
                index: o.start.index,
                omega: o.start.omega,
                period: o.start.period,
                max_multiplier: o.start.max_multiplier,
                hbar_mean: o.start.hbar_mean(),
                fpbar_mean: o.start.fpbar_mean(),
                cycles: rows,
            })
        }
        None => None,
    };
    let report = SimulateReport {
        omega: opts.omega,
        t_end: opts.t_end,
        steps: trajectory.steps,
        rejected: trajectory.rejected,
        newton_iterations: trajectory.newton_iterations,
        jacobians: trajectory.jacobians,
        hbar_mean: hbar.map(|s| s.0),
        hbar_std: hbar.map(|s| s.1),
        fpbar_mean: fpbar.map(|s| s.0),
        fpbar_std: fpbar.map(|s| s.1),
        eta_mean: eta.map(|s| s.0),
        eta_std: eta.map(|s| s.1),
        transient: opts.transient,
        seconds: earlier_seconds + start.elapsed().as_secs_f64(),
        out: dir.display().to_string(),
        orbit,
    };
    Meta::new(study, model.scales, &report, provenance).write(&dir.join("meta.json"))?;
    Ok(report)
}

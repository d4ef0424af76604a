//! `helixbif simulate` and the `dynamics` study kind: the rod stepped through time, its
//! observables as time series, and their late-time statistics.
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
use crate::analysis::orbits::{OrbitRow, OrbitStart};
use crate::analysis::solve::rest_state;
use crate::analysis::solve::solve_at;
use crate::engine::newton::NewtonSettings;
use crate::model::Model;
use crate::model::observables::moving_forces;
use crate::model::observables::{Observables, height};
use crate::model::steady::Steady;
use crate::plot::{Figure, Series, Style, write_figure};
use crate::problem::twist::natural_chart_unknowns;
use crate::study::branch::BranchRow;
use crate::study::cycles::{CycleRow, cycles};
use crate::study::orbits::OrbitsOptions;
use crate::study::output::CsvWriter;
use crate::study::progress;
use crate::{Error, Result};

/// One row of `timeseries.csv` (SI and normalized).
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub struct TimeRow {
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

/// Time-weighted mean and standard deviation (trapezoidal rule) of `y(t)` for `t >= from`.
pub fn late_statistics(t: &[f64], y: &[f64], from: f64) -> Option<(f64, f64)> {
    let pairs: Vec<(f64, f64)> = t
        .iter()
        .zip(y)
        .filter(|(ti, _)| **ti >= from)
        .map(|(a, b)| (*a, *b))
        .collect();
    if pairs.len() < 2 {
        return None;
    }
    let span = pairs.last()?.0 - pairs[0].0;
    if span <= 0.0 {
        return None;
    }
    let mean = trapezoid_mean(&pairs, |v| v);
    let var = trapezoid_mean(&pairs, |v| (v - mean) * (v - mean)).max(0.0);
    Some((mean, var.sqrt()))
}

/// The time average of `f(y)` over the samples `(t, y)` (sorted in `t`, spanning a positive
/// time) by the trapezoidal rule.
pub fn trapezoid_mean(points: &[(f64, f64)], f: impl Fn(f64) -> f64) -> f64 {
    let span = points[points.len() - 1].0 - points[0].0;
    points
        .windows(2)
        .map(|w| 0.5 * (f(w[0].1) + f(w[1].1)) * (w[1].0 - w[0].0))
        .sum::<f64>()
        / span
}

/// The study's `[integrator]` table: the time stepper of `helixbif simulate` and the `dynamics`
/// study, in SI units (converted to the solver's by [`IntegratorTable::settings`]).
///
/// The defaults aim at time averages of a buckled rod to three digits: a local error of `1e-4`
/// relative and 1 um absolute on node positions per step, and the factorized step Jacobian
/// reused while it converges (a chord method). Tighten `rtol`, `atol` to resolve the growth of
/// a small perturbation of a steady state.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct IntegratorTable {
    /// Relative local error tolerance on node positions (-), in `(0, 0.1]`.
    pub rtol: f64,
    /// Absolute local error tolerance on node positions (m), `> 0`.
    pub atol: f64,
    /// Largest time step (s), `> 0`.
    pub dt_max: f64,
    /// `"chord"`: keep the factorized step Jacobian over iterations and steps while Newton
    /// converges fast; `"newton"`: a fresh exact Jacobian at every iteration.
    pub jacobian: JacobianUse,
}

/// How the implicit steps use the Jacobian (see [`IntegratorTable::jacobian`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum JacobianUse {
    Chord,
    Newton,
}

impl Default for IntegratorTable {
    fn default() -> Self {
        IntegratorTable {
            rtol: 1e-4,
            atol: 1e-6,
            dt_max: 2.0,
            jacobian: JacobianUse::Chord,
        }
    }
}

/// The update at which a step's Newton iteration ends, in the error test's weighted norm
/// ([`DynamicsSettings::newton_kappa`]; DASSL's choice is about 0.3, a tenth of it is safe).
const NEWTON_KAPPA: f64 = 0.03;

impl IntegratorTable {
    /// Checks every field against its range; errors name the field.
    pub fn validate(&self) -> Result<()> {
        let checks = [
            (
                "integrator.rtol",
                self.rtol,
                self.rtol > 0.0 && self.rtol <= 0.1,
                "(0, 0.1]",
            ),
            (
                "integrator.atol",
                self.atol,
                self.atol > 0.0 && self.atol.is_finite(),
                "> 0 (m)",
            ),
            (
                "integrator.dt_max",
                self.dt_max,
                self.dt_max > 0.0 && self.dt_max.is_finite(),
                "> 0 (s)",
            ),
        ];
        for (field, value, ok, range) in checks {
            if !ok {
                return Err(Error::input(
                    field,
                    format!("must lie in {range}, got {value}"),
                ));
            }
        }
        Ok(())
    }

    /// The integrator's settings in solver units (lengths in `ell`, times in `mu ell^4/EI`).
    pub fn settings(&self, scales: &crate::model::params::Scales) -> DynamicsSettings {
        let defaults = DynamicsSettings::default();
        DynamicsSettings {
            rtol: self.rtol,
            atol: self.atol / scales.length,
            dt_max: self.dt_max / scales.time,
            dt0: defaults.dt0.min(self.dt_max / scales.time),
            reuse_jacobian: self.jacobian == JacobianUse::Chord,
            newton_kappa: NEWTON_KAPPA,
            ..defaults
        }
    }
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
    model: &Model,
    settings: &DynamicsSettings,
    opts: &SimulateOptions,
    dir: &Path,
    progress: &ProgressBar,
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
    let h0 = height(&rest.config.x);
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
    let key = checkpoint_key(opts, settings);
    let saved: Option<SimulationCheckpoint> = if opts.resume && checkpoint_path.exists() {
        let text = std::fs::read_to_string(&checkpoint_path)
            .map_err(crate::study::output::io_error(&checkpoint_path))?;
        let saved: SimulationCheckpoint = serde_json::from_str(&text)
            .map_err(|e| Error::input("--resume", format!("{}: {e}", checkpoint_path.display())))?;
        if saved.key != key {
            return Err(Error::input(
                "--resume",
                format!(
                    "{} was written by a run with other options or another study; resume with \
                     the same ones, or choose another --out",
                    checkpoint_path.display()
                ),
            ));
        }
        Some(saved)
    } else {
        None
    };
    // On a resumed run the rows up to the checkpoint are kept and read back (for the
    // statistics), the ones after it dropped: they are computed again.
    let earlier_seconds = saved.as_ref().map_or(0.0, |c| c.seconds);
    let (start_from, mut series, mut shapes, mut rows, mut count, mut shape_lines) = match saved {
        Some(saved) => {
            truncate_lines(&series_path, 1, saved.samples)?;
            let rows: Vec<TimeRow> = crate::study::output::read_rows(&series_path, true)?;
            let shapes = if opts.shape_every > 0 {
                truncate_lines(&shapes_path, 0, saved.shape_lines)?;
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
                .then(|| CsvWriter::create(&shapes_path))
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
                    w.row(&(s.t * scales.time, i, p.x, p.y, p.z))?;
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
            Ok(()) => ControlFlow::Continue(()),
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
    for (name, label, y) in [
        ("hbar.svg", "hbar = h/h0 (-)", &hbar_series),
        ("Fpbar.svg", "Fpbar = Fp ell^2/EI (-)", &fpbar_series),
    ] {
        write_figure(
            &Figure {
                title: format!("simulation at omega = {} rad/s", opts.omega),
                x_label: "t (s)".into(),
                y_label: label.into(),
                series: vec![line(label.split(' ').next().unwrap_or(label), y)],
                ..Figure::default()
            },
            &dir.join(format!("timeseries_{name}")),
        )?;
    }
    let trajectory = trajectory?;
    let orbit = match &opts.from_orbit {
        Some(o) => {
            let rows = cycles(&t, &hbar_series, &fpbar_series, &o.start);
            let mut csv = CsvWriter::create(&dir.join("cycles.csv"))?;
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
    Ok(SimulateReport {
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn late_statistics_of_a_sine_wave() {
        let t: Vec<f64> = (0..=4000).map(|i| i as f64 * 0.001).collect();
        let y: Vec<f64> = t
            .iter()
            .map(|t| 2.0 + 0.5 * (2.0 * std::f64::consts::PI * t).sin())
            .collect();
        let (mean, std) = late_statistics(&t, &y, 1.0).unwrap();
        assert!(
            (mean - 2.0).abs() < 1e-6 && (std - 0.5 / 2f64.sqrt()).abs() < 1e-6,
            "{mean} {std}"
        );
    }
}

/// One row of `dynamics.csv`: the late-time statistics at one rate.
#[derive(Clone, Debug, Serialize)]
pub struct AverageRow {
    pub omega: f64,
    pub hbar_mean: Option<f64>,
    pub hbar_std: Option<f64>,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: Option<f64>,
    #[serde(rename = "Fpbar_std")]
    pub fpbar_std: Option<f64>,
    pub eta_mean: Option<f64>,
    pub eta_std: Option<f64>,
    pub steps: usize,
    pub seconds: f64,
    pub status: String,
}

/// The `dynamics` study: a simulation from rest per rate (in parallel, each in its own folder
/// `omega_<rate>/`, resumable), `dynamics.csv`, and `hbar.svg`, `Fpbar.svg`, `eta.svg` with
/// the time averages (error bars: one standard deviation) over the continuation branch (stable
/// solid, unstable dashed) and, with `orbit_branch`, over the period averages of the periodic
/// orbits born at the Hopf point (`orbits/`). Each run's time series figures mark the steady
/// value at its rate and the orbits' period averages there. Returns the rows and the number of
/// failed runs.
pub fn run_dynamics(
    study: &crate::study::Study,
    dir: &Path,
    resume: bool,
    provenance: &crate::study::output::Provenance,
) -> Result<(Vec<AverageRow>, usize)> {
    use rayon::prelude::*;
    let Some(crate::study::Plan::Dynamics {
        omegas,
        t_end,
        transient,
        ramp_time,
        orbit_branch,
        orbits: orbit_plan,
    }) = &study.study
    else {
        return Err(Error::input("study.kind", "expected a dynamics study"));
    };
    let model = Model::new(&study.physical())?;
    model.check_resolution()?;
    let settings = study.integrator.settings(&model.scales);
    let bars = indicatif::MultiProgress::new();
    let rows: Vec<AverageRow> = omegas
        .par_iter()
        .map(|&omega| {
            let opts = SimulateOptions {
                omega,
                t_end: *t_end,
                from_steady: false,
                perturb: None,
                from_orbit: None,
                ramp_time: *ramp_time,
                transient: *transient,
                shape_every: 0,
                newton: study.newton.clone(),
                resume,
                provenance: simulation_provenance(study),
            };
            let sub = dir.join(format!("omega_{omega}"));
            let bar = bars.add(progress::bar(&format!("omega = {omega} rad/s")));
            let outcome = run_simulate(&model, &settings, &opts, &sub, &bar);
            bars.remove(&bar);
            match outcome {
                Ok(r) => AverageRow {
                    omega,
                    hbar_mean: r.hbar_mean,
                    hbar_std: r.hbar_std,
                    fpbar_mean: r.fpbar_mean,
                    fpbar_std: r.fpbar_std,
                    eta_mean: r.eta_mean,
                    eta_std: r.eta_std,
                    steps: r.steps,
                    seconds: r.seconds,
                    status: "ok".into(),
                },
                Err(e) => AverageRow {
                    omega,
                    hbar_mean: None,
                    hbar_std: None,
                    fpbar_mean: None,
                    fpbar_std: None,
                    eta_mean: None,
                    eta_std: None,
                    steps: 0,
                    seconds: 0.0,
                    status: e.to_string().replace(['\n', ','], " "),
                },
            }
        })
        .collect();
    let mut table = CsvWriter::create(&dir.join("dynamics.csv"))?;
    for r in &rows {
        table.row(r)?;
    }
    let failed = rows.iter().filter(|r| r.status != "ok").count();
    // The continuation branch underneath, and the orbits born at its Hopf point.
    let omega_max = omegas.iter().copied().fold(0.0, f64::max) * 1.05;
    let (_, branch) = crate::study::branch::run_branch(
        study,
        &model,
        omega_max,
        &dir.join("branch"),
        provenance,
    )?;
    let orbits: Vec<OrbitRow> = if *orbit_branch {
        let orbits_dir = dir.join("orbits");
        let opts = OrbitsOptions {
            resume,
            ..OrbitsOptions::of_plan(orbit_plan, omega_max)
        };
        crate::study::orbits::run_orbits(study, &model, &opts, &orbits_dir, provenance)?;
        crate::study::output::read_rows(&orbits_dir.join("orbits.csv"), true)?
    } else {
        Vec::new()
    };
    let ok: Vec<&AverageRow> = rows.iter().filter(|r| r.status == "ok").collect();
    for r in &ok {
        mark_time_series(study, dir, r.omega, &branch.points, &orbits)?;
    }
    let averaged =
        |mean: fn(&AverageRow) -> Option<f64>, std: fn(&AverageRow) -> Option<f64>| Series {
            label: "simulation: time average +- std".into(),
            x: ok.iter().map(|r| r.omega).collect(),
            y: ok.iter().map(|r| mean(r).unwrap_or(f64::NAN)).collect(),
            style: Style::Markers(crate::plot::MarkerShape::Circle),
            stable: None,
            err: Some(ok.iter().map(|r| std(r).unwrap_or(0.0)).collect()),
        };
    let line = |y: Vec<f64>| Series {
        label: "steady branch (continuation)".into(),
        x: branch.points.iter().map(|r| r.omega).collect(),
        y,
        style: Style::Line,
        stable: Some(branch.points.iter().map(|r| r.stable).collect()),
        err: None,
    };
    let orbit_line = |y: fn(&OrbitRow) -> f64| Series {
        label: "periodic orbits: period average".into(),
        x: orbits.iter().map(|r| r.omega).collect(),
        y: orbits.iter().map(y).collect(),
        style: Style::Line,
        stable: Some(orbits.iter().map(|r| r.stable).collect()),
        err: None,
    };
    let eta_of = |r: &BranchRow| r.eta.unwrap_or(f64::NAN);
    for (name, label, mut series, orbit) in [
        (
            "hbar.svg",
            "hbar = h/h0 (-)",
            vec![
                line(branch.points.iter().map(|r| r.hbar).collect()),
                averaged(|r| r.hbar_mean, |r| r.hbar_std),
            ],
            Some(orbit_line(|r| r.hbar_mean)),
        ),
        (
            "Fpbar.svg",
            "Fpbar = Fp ell^2/EI (-)",
            vec![
                line(branch.points.iter().map(|r| r.fpbar).collect()),
                averaged(|r| r.fpbar_mean, |r| r.fpbar_std),
            ],
            Some(orbit_line(|r| r.fpbar_mean)),
        ),
        (
            "eta.svg",
            "eta = Fp^2/(mu omega Tp) (-)",
            vec![
                line(branch.points.iter().map(eta_of).collect()),
                averaged(|r| r.eta_mean, |r| r.eta_std),
            ],
            None,
        ),
    ] {
        if let Some(o) = orbit
            && !orbits.is_empty()
        {
            series.push(o);
        }
        write_figure(
            &Figure {
                title: format!("{}: time averages over the steady branch", study.name),
                x_label: "omega (rad/s)".into(),
                y_label: label.into(),
                series,
                ..Figure::default()
            },
            &dir.join(name),
        )?;
    }
    Ok((rows, failed))
}

/// The value of `y` at `omega` by linear interpolation along `points` (`(omega, y, stable)` in
/// the order of the branch), once per segment that brackets `omega`.
fn crossings(points: &[(f64, f64, bool)], omega: f64) -> Vec<(f64, bool)> {
    points
        .windows(2)
        .filter(|w| (w[0].0 - omega) * (w[1].0 - omega) <= 0.0 && w[0].0 != w[1].0)
        .map(|w| {
            let s = (omega - w[0].0) / (w[1].0 - w[0].0);
            (w[0].1 + s * (w[1].1 - w[0].1), w[0].2 && w[1].2)
        })
        .collect()
}

/// Redraws `omega_<rate>/timeseries_hbar.svg` and `timeseries_Fpbar.svg` from the run's
/// `timeseries.csv`, with the steady branch's value at that rate and the period averages of the
/// orbits there as horizontal lines (dashed where unstable).
fn mark_time_series(
    study: &crate::study::Study,
    dir: &Path,
    omega: f64,
    branch: &[BranchRow],
    orbits: &[OrbitRow],
) -> Result<()> {
    let sub = dir.join(format!("omega_{omega}"));
    let rows: Vec<TimeRow> = crate::study::output::read_rows(&sub.join("timeseries.csv"), true)?;
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let t_last = t.last().copied().unwrap_or(0.0);
    let level = |label: String, (y, stable): (f64, bool)| Series {
        label,
        x: vec![0.0, t_last],
        y: vec![y, y],
        style: Style::Line,
        stable: Some(vec![stable, stable]),
        err: None,
    };
    for (name, label, y, steady, orbit) in [
        (
            "timeseries_hbar.svg",
            "hbar = h/h0 (-)",
            rows.iter().map(|r| r.hbar).collect::<Vec<_>>(),
            branch
                .iter()
                .map(|r| (r.omega, r.hbar, r.stable))
                .collect::<Vec<_>>(),
            orbits
                .iter()
                .map(|r| (r.omega, r.hbar_mean, r.stable))
                .collect::<Vec<_>>(),
        ),
        (
            "timeseries_Fpbar.svg",
            "Fpbar = Fp ell^2/EI (-)",
            rows.iter().map(|r| r.fpbar).collect(),
            branch
                .iter()
                .map(|r| (r.omega, r.fpbar, r.stable))
                .collect(),
            orbits
                .iter()
                .map(|r| (r.omega, r.fpbar_mean, r.stable))
                .collect(),
        ),
    ] {
        let mut series = vec![Series {
            label: "simulation from rest".into(),
            x: t.clone(),
            y,
            style: Style::Line,
            stable: None,
            err: None,
        }];
        for c in crossings(&steady, omega) {
            series.push(level("steady state (continuation)".into(), c));
        }
        for c in crossings(&orbit, omega) {
            series.push(level("periodic orbit: period average".into(), c));
        }
        write_figure(
            &Figure {
                title: format!("{}: simulation at omega = {omega} rad/s", study.name),
                x_label: "t (s)".into(),
                y_label: label.into(),
                series,
                ..Figure::default()
            },
            &sub.join(name),
        )?;
    }
    Ok(())
}

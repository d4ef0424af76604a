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

use faer::Mat;
use faer::prelude::Solve;
use nalgebra::Vector3;
use serde::Serialize;

use crate::branch::rest_state;
use crate::continuation::newton::NewtonSettings;
use crate::dofs::Layout;
use crate::dynamics::{
    DynamicsSettings, Rate, Sample, integrate, least_stable_mode, natural_chart_unknowns, perturb,
};
use crate::model::Model;
use crate::output::CsvWriter;
use crate::plot::{Figure, Series, Style, write_figure};
use crate::rod::frame::Chart;
use crate::solve::solve_at;
use crate::steady::{Observables, Steady, height, rotation_velocity};
use crate::{Error, Result};

/// The forces on the fluid of a moving state `u` (twist measured in `chart`, e.g. a
/// [`Sample`]'s `u_chart` and `chart`) at rate `omegabar` (see the module docs).
pub fn moving_forces(
    model: &Model,
    u: &[f64],
    chart: &Chart,
    omegabar: f64,
) -> Result<Vec<Vector3<f64>>> {
    let steady = Steady::new(model, omegabar);
    let config = steady.config(u);
    let gradient = model.rod.gradient(&config, chart);
    let gravity = model.gravity(model.weight);
    let layout = model.rod.layout;
    let n = layout.nodes();
    let c = Layout::CLAMPED_NODES;
    let free: Vec<Vector3<f64>> = (c..n)
        .map(|i| Vector3::from_fn(|k, _| -gradient[layout.x(i, k)] + gravity[i][k]))
        .collect();
    let a = model.fluid.mobility(&config.x);
    let velocity = rotation_velocity(omegabar, &config.x);
    let nc = 3 * c;
    let a_cc = Mat::from_fn(nc, nc, |r, k| a[(r, k)]);
    let rhs = Mat::from_fn(nc, 1, |r, _| {
        velocity[r / 3][r % 3]
            - (0..3 * (n - c))
                .map(|k| a[(r, nc + k)] * free[k / 3][k % 3])
                .sum::<f64>()
    });
    let clamp = a_cc.partial_piv_lu().solve(&rhs);
    if !clamp.is_all_finite() {
        return Err(Error::Numerical(
            "singular clamp block of the mobility matrix".into(),
        ));
    }
    Ok((0..c)
        .map(|i| {
            Vector3::new(
                clamp[(3 * i, 0)],
                clamp[(3 * i + 1, 0)],
                clamp[(3 * i + 2, 0)],
            )
        })
        .chain(free)
        .collect())
}

/// One row of `timeseries.csv` (SI and normalized).
#[derive(Clone, Debug, Serialize)]
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
    let integral = |f: &dyn Fn(f64) -> f64| -> f64 {
        pairs
            .windows(2)
            .map(|w| 0.5 * (f(w[0].1) + f(w[1].1)) * (w[1].0 - w[0].0))
            .sum::<f64>()
            / span
    };
    let mean = integral(&|v| v);
    let var = integral(&|v| (v - mean) * (v - mean)).max(0.0);
    Some((mean, var.sqrt()))
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
    /// Spin-up time (s) of a run from rest.
    pub ramp_time: f64,
    /// Statistics over `t >= transient` (s).
    pub transient: f64,
    /// Write the shape every this many accepted steps (0: never).
    pub shape_every: usize,
    /// Newton's method for the rest state and the steady state (the study's `[newton]`).
    pub newton: NewtonSettings,
}

/// What a simulation reports.
#[derive(Clone, Debug, Serialize)]
pub struct SimulateReport {
    pub omega: f64,
    pub t_end: f64,
    pub steps: usize,
    pub rejected: usize,
    pub newton_iterations: usize,
    pub hbar_mean: Option<f64>,
    pub hbar_std: Option<f64>,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: Option<f64>,
    #[serde(rename = "Fpbar_std")]
    pub fpbar_std: Option<f64>,
    /// Start of the statistics (s).
    pub transient: f64,
    pub seconds: f64,
    /// The output folder.
    pub out: String,
}

/// Runs one simulation, writing `timeseries.csv`, `shapes.csv` (when asked) and `timeseries.svg`
/// into `dir` as it goes.
pub fn run_simulate(
    model: &Model,
    settings: &DynamicsSettings,
    opts: &SimulateOptions,
    dir: &Path,
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
    model.check_resolution()?;
    crate::output::create_dir(dir)?;
    let scales = model.scales;
    let omegabar = scales.omega_to_bar(opts.omega);
    let rest = rest_state(model, &opts.newton)?;
    let h0 = height(&rest.config.x);
    let steady = Steady::new(model, 0.0);
    let (u0, rate) = if opts.from_steady {
        let solution = solve_at(model, omegabar, &opts.newton)?;
        let mut u = natural_chart_unknowns(model, &solution.state.config, &solution.state.chart)?;
        if let Some(eps) = opts.perturb {
            let mode = least_stable_mode(model, omegabar, &u)?;
            u = perturb(model, &u, &mode, eps, 0.0)?;
        }
        (u, Rate::Fixed(omegabar))
    } else {
        let u = steady.free_vector(&rest.config);
        let rate = if opts.ramp_time > 0.0 {
            Rate::Ramp {
                target: omegabar,
                ramp_time: opts.ramp_time / scales.time,
            }
        } else {
            Rate::Fixed(omegabar)
        };
        (u, rate)
    };
    let mut series = CsvWriter::create(&dir.join("timeseries.csv"))?;
    let mut shapes = (opts.shape_every > 0)
        .then(|| CsvWriter::create(&dir.join("shapes.csv")))
        .transpose()?;
    let mut rows: Vec<TimeRow> = Vec::new();
    let mut failure: Option<Error> = None;
    let mut count = 0usize;
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
            rows.push(row);
            if let Some(w) = shapes.as_mut()
                && count.is_multiple_of(opts.shape_every)
            {
                for (i, p) in x.iter().enumerate() {
                    let p = p * scales.length;
                    w.row(&(s.t * scales.time, i, p.x, p.y, p.z))?;
                }
            }
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
    let trajectory = integrate(
        model,
        rate,
        u0,
        opts.t_end / scales.time,
        settings,
        observer,
    );
    if let Some(e) = failure {
        return Err(e);
    }
    let t: Vec<f64> = rows.iter().map(|r| r.t).collect();
    let stat = |y: Vec<f64>| late_statistics(&t, &y, opts.transient);
    let hbar = stat(rows.iter().map(|r| r.hbar).collect());
    let fpbar = stat(rows.iter().map(|r| r.fpbar).collect());
    let line = |label: &str, y: Vec<f64>| Series {
        label: label.into(),
        x: t.clone(),
        y,
        style: Style::Line,
        stable: None,
        err: None,
    };
    for (name, label, y) in [
        (
            "hbar.svg",
            "hbar = h/h0 (-)",
            rows.iter().map(|r| r.hbar).collect::<Vec<_>>(),
        ),
        (
            "Fpbar.svg",
            "Fpbar = Fp ell^2/EI (-)",
            rows.iter().map(|r| r.fpbar).collect(),
        ),
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
    Ok(SimulateReport {
        omega: opts.omega,
        t_end: opts.t_end,
        steps: trajectory.steps,
        rejected: trajectory.rejected,
        newton_iterations: trajectory.newton_iterations,
        hbar_mean: hbar.map(|s| s.0),
        hbar_std: hbar.map(|s| s.1),
        fpbar_mean: fpbar.map(|s| s.0),
        fpbar_std: fpbar.map(|s| s.1),
        transient: opts.transient,
        seconds: start.elapsed().as_secs_f64(),
        out: dir.display().to_string(),
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
struct AverageRow {
    omega: f64,
    hbar_mean: Option<f64>,
    hbar_std: Option<f64>,
    #[serde(rename = "Fpbar_mean")]
    fpbar_mean: Option<f64>,
    #[serde(rename = "Fpbar_std")]
    fpbar_std: Option<f64>,
    steps: usize,
    seconds: f64,
    status: String,
}

/// The `dynamics` study: a simulation from rest per rate (in parallel, each in its own folder),
/// `dynamics.csv`, and `hbar.svg`, `Fpbar.svg` with the time averages (error bars: one standard
/// deviation) over the continuation branch (stable solid, unstable dashed). Returns the rows and
/// the number of failed runs.
pub fn run_dynamics(study: &crate::study::Study, dir: &Path) -> Result<(serde_json::Value, usize)> {
    use rayon::prelude::*;
    let Some(crate::study::Plan::Dynamics {
        omegas,
        t_end,
        transient,
        ramp_time,
    }) = &study.study
    else {
        return Err(Error::input("study.kind", "expected a dynamics study"));
    };
    let model = Model::new(&study.physical())?;
    model.check_resolution()?;
    let settings = DynamicsSettings {
        rtol: 1e-5,
        atol: 1e-8,
        reuse_jacobian: true,
        ..DynamicsSettings::default()
    };
    let rows: Vec<AverageRow> = omegas
        .par_iter()
        .map(|&omega| {
            let opts = SimulateOptions {
                omega,
                t_end: *t_end,
                from_steady: false,
                perturb: None,
                ramp_time: *ramp_time,
                transient: *transient,
                shape_every: 0,
                newton: study.newton.clone(),
            };
            let sub = dir.join(format!("omega_{omega}"));
            match run_simulate(&model, &settings, &opts, &sub) {
                Ok(r) => AverageRow {
                    omega,
                    hbar_mean: r.hbar_mean,
                    hbar_std: r.hbar_std,
                    fpbar_mean: r.fpbar_mean,
                    fpbar_std: r.fpbar_std,
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
    // The continuation branch underneath.
    let omega_max = omegas.iter().copied().fold(0.0, f64::max) * 1.05;
    let (_, branch) =
        crate::study::runs::run_branch(study, &model, omega_max, &dir.join("branch"))?;
    let ok: Vec<&AverageRow> = rows.iter().filter(|r| r.status == "ok").collect();
    let averaged = |label: &str,
                    mean: fn(&AverageRow) -> Option<f64>,
                    std: fn(&AverageRow) -> Option<f64>| Series {
        label: label.into(),
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
    for (name, label, series) in [
        (
            "hbar.svg",
            "hbar = h/h0 (-)",
            vec![
                line(branch.points.iter().map(|r| r.hbar).collect()),
                averaged(
                    "simulation: time average +- std",
                    |r| r.hbar_mean,
                    |r| r.hbar_std,
                ),
            ],
        ),
        (
            "Fpbar.svg",
            "Fpbar = Fp ell^2/EI (-)",
            vec![
                line(branch.points.iter().map(|r| r.fpbar).collect()),
                averaged(
                    "simulation: time average +- std",
                    |r| r.fpbar_mean,
                    |r| r.fpbar_std,
                ),
            ],
        ),
    ] {
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
    Ok((
        serde_json::to_value(&rows).map_err(|e| Error::Numerical(e.to_string()))?,
        failed,
    ))
}

//! The `dynamics` study kind: a simulation from rest per rate (in parallel, each in its own
//! folder), their time averages over the continuation branch and the periodic orbits.

use std::path::Path;

use serde::Serialize;

use crate::analysis::orbits::OrbitRow;
use crate::model::Model;
use crate::plot::{Figure, Series, Style, write_figure};
use crate::study::branch::BranchRow;
use crate::study::figures::{ETA_LABEL, FPBAR_LABEL, HBAR_LABEL, OMEGA_LABEL, typeset};
use crate::study::orbits::OrbitsOptions;
use crate::study::output::CsvWriter;
use crate::study::progress;
use crate::{Error, Result};

use crate::study::simulate::{
    SimulateOptions, TimeRow, check_resumable, run_simulate, simulation_provenance,
};

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
pub(crate) fn run_dynamics(
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
    let bars = progress::multi();
    let options = |omega: f64| SimulateOptions {
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
    let folder = |omega: f64| dir.join(format!("omega_{omega}"));
    // Every checkpoint a resumed run would go on from is checked before any simulation runs:
    // one of another run is bad input, not a failed simulation among finished ones.
    let omega_max = omegas.iter().copied().fold(0.0, f64::max) * 1.05;
    let orbit_options = OrbitsOptions {
        resume,
        ..OrbitsOptions::of_plan(orbit_plan, omega_max)
    };
    if resume {
        for &omega in omegas {
            check_resumable(&folder(omega), &options(omega), &settings)?;
        }
        if *orbit_branch {
            crate::study::orbits::check_resumable(study, &orbit_options, &dir.join("orbits"))?;
        }
    }
    let rows: Vec<AverageRow> = omegas
        .par_iter()
        .map(|&omega| {
            let opts = options(omega);
            let sub = folder(omega);
            let bar = bars.add(progress::bar(&format!("omega = {omega} rad/s")));
            let outcome = run_simulate(study, &model, &settings, &opts, &sub, &bar, provenance);
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
    let (_, branch) = crate::study::branch::run_branch(
        study,
        &model,
        omega_max,
        &dir.join("branch"),
        provenance,
    )?;
    let orbits: Vec<OrbitRow> = if *orbit_branch {
        let orbits_dir = dir.join("orbits");
        crate::study::orbits::run_orbits(study, &model, &orbit_options, &orbits_dir, provenance)?;
        crate::study::output::read_rows(&orbits_dir.join("orbits.csv"), true)?
    } else {
        Vec::new()
    };
    let ok: Vec<&AverageRow> = rows.iter().filter(|r| r.status == "ok").collect();
    for r in &ok {
        mark_time_series(dir, r.omega, &branch.points, &orbits)?;
    }
    let averaged =
        |mean: fn(&AverageRow) -> Option<f64>, std: fn(&AverageRow) -> Option<f64>| Series {
            label: "simulation: time average ± std".into(),
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
            HBAR_LABEL,
            vec![
                line(branch.points.iter().map(|r| r.hbar).collect()),
                averaged(|r| r.hbar_mean, |r| r.hbar_std),
            ],
            Some(orbit_line(|r| r.hbar_mean)),
        ),
        (
            "Fpbar.svg",
            FPBAR_LABEL,
            vec![
                line(branch.points.iter().map(|r| r.fpbar).collect()),
                averaged(|r| r.fpbar_mean, |r| r.fpbar_std),
            ],
            Some(orbit_line(|r| r.fpbar_mean)),
        ),
        (
            "eta.svg",
            ETA_LABEL,
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
                title: "Time averages of simulations over the steady branch".into(),
                x_label: OMEGA_LABEL.into(),
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
            HBAR_LABEL,
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
            FPBAR_LABEL,
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
                title: format!(
                    "Simulation from rest at ω = {} rad/s",
                    typeset(&omega.to_string())
                ),
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

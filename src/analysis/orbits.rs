//! Periodic orbits of the rod in the co-rotating frame, born at the Hopf point that `locate`
//! finds (docs/model.md section 12): the rod as an [`ImplicitDynamics`] for the generic
//! shooting of [`crate::engine::periodic`], and the orbit branch with its time averages.
//!
//! The dynamics is (1) of [`crate::analysis::dynamics`]: `Z_ff(x) dx_f/dt = R_x(x_f, theta)`,
//! `R_theta = 0`, the free positions differential and the twist algebraic, the rate
//! `omegabar` the parameter. A step of the shooting is the implicit step of the time
//! integrator ([`ImplicitStep`]). Its twist angles are measured in a chart carried from step to
//! step through the period, as the integrator carries its own ([`RodDynamics::centred_on`]),
//! each period starting from the Hopf point's chart: the collapsed rod's edges turn by up to 180
//! degrees within a period, where a fixed chart is singular. The amplitude of an orbit
//! is the root mean square over the period and over the free nodes of the displacement from
//! the orbit's mean shape (in `ell`, reported in metres): `size(dx)^2 = |dx|^2 / (N - 2)`.

use std::ops::ControlFlow;

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::analysis::locate::Critical;
use crate::engine::periodic::branch::{
    Checkpoint, HopfStart, OrbitBranch, OrbitBranchSettings, follow_orbits, resume_orbits,
};
use crate::engine::periodic::flow::carried;
use crate::engine::periodic::orbit::Orbit;
use crate::model::Model;
use crate::model::observables::moving_forces;
use crate::model::observables::thrust_and_torque;
use crate::model::steady::Steady;
use crate::problem::twist::natural_chart_unknowns;

use crate::problem::orbit::RodDynamics;

/// One row of `orbits.csv` (SI and normalized).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OrbitRow {
    pub index: usize,
    pub omega: f64,
    pub omegabar: f64,
    /// Period in the co-rotating frame (s) and normalized.
    pub period: f64,
    pub periodbar: f64,
    /// Root mean square node displacement from the mean shape (m) and over `ell`.
    pub amplitude: f64,
    pub amplitudebar: f64,
    /// Time averages over one period.
    pub hbar_mean: f64,
    #[serde(rename = "Fpbar_mean")]
    pub fpbar_mean: f64,
    #[serde(rename = "Fp_mean")]
    pub fp_mean: f64,
    #[serde(rename = "Tp_mean")]
    pub tp_mean: f64,
    /// Largest modulus of a nontrivial Floquet multiplier, their count outside the unit
    /// circle, and the verdict.
    pub max_multiplier: f64,
    pub unstable: usize,
    pub stable: bool,
    /// `stable` or `unstable`, or `undetermined` when a nontrivial multiplier lies within ten
    /// times `trivial_error` (plus `1e-9`) of the unit circle: the period map is not accurate
    /// enough to say on which side.
    pub verdict: String,
    /// `|mu_trivial - 1|`: the discretization error of the period map.
    pub trivial_error: f64,
    pub iterations: usize,
}

/// `hbar`, `Fpbar` and `Tp` (solver units) at each of an orbit's states, `t = k T / n`, at
/// `omegabar`, with `h0` the rest height; each state's twist measured in the chart carried to
/// it through the period ([`carried`]).
fn observed(dynamics: &RodDynamics, orbit: &Orbit, h0: f64) -> Result<Vec<[f64; 3]>> {
    let model = dynamics.model;
    let frames = carried(dynamics, &orbit.states);
    orbit
        .states
        .iter()
        .zip(&frames)
        .map(|(u, frame)| {
            let chart = &frame.as_ref().unwrap_or(dynamics).chart;
            let forces = moving_forces(model, u, chart, orbit.p)?;
            let x = Steady::new(model, orbit.p).config(u).x;
            let (f, t) = thrust_and_torque(&x, &forces);
            Ok([model.height(&x) / h0, f, t])
        })
        .collect()
}

/// An orbit's start (the state pinned by the phase condition) and its observables over one
/// period, saved as `states/orbit_<index>.json` so that a simulation can start on it and be
/// compared with it (`helixbif simulate --from-orbit`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OrbitStart {
    pub index: usize,
    /// Rate (rad/s) and period in the co-rotating frame (s).
    pub omega: f64,
    pub period: f64,
    /// The largest nontrivial Floquet multiplier's modulus.
    pub max_multiplier: f64,
    /// `hbar` and `Fpbar` at `t = k period / n`, `k = 0 .. n - 1`.
    pub hbar: Vec<f64>,
    #[serde(rename = "Fpbar")]
    pub fpbar: Vec<f64>,
    /// The free unknowns at `t = 0`, twist measured in the model's natural chart.
    pub u: Vec<f64>,
    /// The physical description of the model the orbit belongs to (a simulation started on it
    /// must use the same).
    pub physical: serde_json::Value,
}

impl OrbitStart {
    /// The average of `hbar` over the period (of its equally spaced samples).
    pub fn hbar_mean(&self) -> f64 {
        self.hbar.iter().sum::<f64>() / self.hbar.len() as f64
    }
    /// The average of `Fpbar` over the period.
    pub fn fpbar_mean(&self) -> f64 {
        self.fpbar.iter().sum::<f64>() / self.fpbar.len() as f64
    }
}

/// The row of `orbit` and its start ([`OrbitStart::physical`] left null).
fn orbit_row(
    dynamics: &RodDynamics,
    index: usize,
    orbit: &Orbit,
    h0: f64,
) -> Result<(OrbitRow, OrbitStart)> {
    let s = &dynamics.model.scales;
    let observed = observed(dynamics, orbit, h0)?;
    let mean = |k: usize| observed.iter().map(|o| o[k]).sum::<f64>() / observed.len() as f64;
    let (hbar, fpbar, tp) = (mean(0), mean(1), mean(2));
    let amplitude = orbit.amplitude(dynamics, None);
    let trivial_error = (orbit.trivial - faer::c64::new(1.0, 0.0)).norm();
    let margin = 10.0 * trivial_error + 1e-9;
    let verdict = if orbit
        .multipliers
        .iter()
        .any(|m| (m.norm() - 1.0).abs() <= margin)
    {
        "undetermined"
    } else if orbit.unstable == 0 {
        "stable"
    } else {
        "unstable"
    };
    let row = OrbitRow {
        index,
        omega: s.omega_from_bar(orbit.p),
        omegabar: orbit.p,
        period: orbit.period * s.time,
        periodbar: orbit.period,
        amplitude: amplitude * s.length,
        amplitudebar: amplitude,
        hbar_mean: hbar,
        fpbar_mean: fpbar,
        fp_mean: fpbar * s.force,
        tp_mean: tp * s.torque(),
        max_multiplier: orbit.max_multiplier(),
        unstable: orbit.unstable,
        stable: orbit.unstable == 0,
        verdict: verdict.into(),
        trivial_error,
        iterations: orbit.iterations,
    };
    let config = Steady {
        chart: dynamics.chart.clone(),
        ..Steady::new(dynamics.model, orbit.p)
    }
    .config(&orbit.states[0]);
    let start = OrbitStart {
        index,
        omega: row.omega,
        period: row.period,
        max_multiplier: row.max_multiplier,
        hbar: observed.iter().map(|o| o[0]).collect(),
        fpbar: observed.iter().map(|o| o[1]).collect(),
        u: natural_chart_unknowns(dynamics.model, &config, &dynamics.chart)?,
        physical: serde_json::Value::Null,
    };
    Ok((row, start))
}

/// The Hopf start of a located Hopf point: its state, rate, frequency and the critical mode
/// `q` of the Lyapunov coefficient (largest node displacement `ell`), and the dynamics in its
/// chart.
pub fn hopf_start<'a>(
    model: &'a Model,
    critical: &Critical,
    mode: (Vec<f64>, Vec<f64>),
) -> (RodDynamics<'a>, HopfStart) {
    (
        RodDynamics {
            model,
            chart: critical.chart.clone(),
        },
        HopfStart {
            u: critical.event.u.clone(),
            p: critical.event.p,
            frequency: critical.event.eigenvalue.im.abs(),
            mode,
        },
    )
}

/// Follows the orbits from a Hopf point, or from `resume` (a checkpoint of an earlier run of the
/// same branch), with `rows` called for every accepted orbit's row, its start and the
/// checkpoint after it.
pub(crate) fn follow_rod_orbits(
    dynamics: &RodDynamics,
    start: &HopfStart,
    resume: Option<&Checkpoint>,
    settings: &OrbitBranchSettings,
    omegabar_range: (f64, f64),
    h0: f64,
    mut rows: impl FnMut(&OrbitRow, &OrbitStart, Option<&Checkpoint>) -> Result<()>,
) -> Result<(OrbitBranch, Vec<OrbitRow>)> {
    let mut table = Vec::new();
    let mut failure = None;
    let observer = |k: usize, orbit: &Orbit, checkpoint: Option<&Checkpoint>| match orbit_row(
        dynamics, k, orbit, h0,
    )
    .and_then(|(row, start)| {
        rows(&row, &start, checkpoint)?;
        Ok(row)
    }) {
        Ok(row) => {
            table.push(row);
            ControlFlow::Continue(())
        }
        Err(e) => {
            failure = Some(e);
            ControlFlow::Break(())
        }
    };
    let branch = match resume {
        Some(c) => resume_orbits(dynamics, c, settings, omegabar_range, observer)?,
        None => follow_orbits(dynamics, start, settings, omegabar_range, observer)?,
    };
    if let Some(e) = failure {
        return Err(e);
    }
    Ok((branch, table))
}

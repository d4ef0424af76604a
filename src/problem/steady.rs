//! The steady problem solved by the engine's Newton: a converged steady state, the force
//! balance of [`Steady`] as a Newton [`System`] (updates through the rod's retraction).

use faer::Mat;

use crate::Result;
use crate::engine::newton::{self, NewtonReport, NewtonSettings, System};
use crate::model::Model;
use crate::model::rod::Config;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;

impl System for Steady<'_> {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        Steady::residual(self, u)
    }

    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.linearize(u)?;
        Ok((lin.residual, lin.jacobian))
    }

    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        Steady::retract(self, u, du)
    }
}

/// A converged steady state.
#[derive(Clone, Debug)]
pub struct SteadyState {
    pub omega: f64,
    pub weight: f64,
    pub config: Config,
    /// The chart carried to this configuration (the source for the next solve).
    pub chart: Chart,
    pub report: NewtonReport,
}

/// Solves the steady problem from the initial configuration `start` (measured in `chart`).
pub fn solve(
    model: &Model,
    omega: f64,
    weight: f64,
    start: &Config,
    chart: &Chart,
    settings: &NewtonSettings,
) -> Result<SteadyState> {
    let problem = Steady {
        model,
        omega,
        weight,
        chart: chart.clone(),
    };
    let context = format!(
        "at omegabar = {omega:.6e} (omega = {:.6e} rad/s), N = {}",
        model.scales.omega_from_bar(omega),
        model.nodes()
    );
    let (u, report) = newton::solve(&problem, problem.free_vector(start), settings, &context)?;
    let config = problem.config(&u);
    Ok(SteadyState {
        omega,
        weight,
        chart: chart.transported(&config.x),
        config,
        report,
    })
}

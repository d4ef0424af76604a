//! The twist slaved to the positions: `R_theta(x, theta) = 0` solved for the twist angles at
//! fixed positions (docs/model.md section 5), by Newton's method on the twist block or by the
//! chord method on a nearby factorized block; and the conversion of a state's twist into the
//! model's natural chart.

use faer::Mat;

use crate::engine::newton::{Chord, Globalization, Iterate, Jacobians, Newton, System, norm};
use crate::model::Model;
use crate::model::rod::Config;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::numerics::lu::Lu;
use crate::{Error, Result};

use crate::model::rod::frame::rechart;

/// The free unknowns `u` with its positions kept and the twist of `reference` (free unknowns of
/// the same model, natural chart) times `ratio`, the ratio of their rates: below the instability
/// the twist carries the motor's torque, about proportional to the rate. A start for
/// [`slave_twist`] where `u`'s own twist is in an unknown chart or missing.
pub fn scaled_twist(model: &Model, mut u: Vec<f64>, reference: &[f64], ratio: f64) -> Vec<f64> {
    let nx = model.rod.layout.free_positions();
    for (t, t0) in u[nx..].iter_mut().zip(&reference[nx..]) {
        *t = ratio * t0;
    }
    u
}

/// The free unknowns with the twist re-solved (`R_theta = 0`, the twist slaved) for the
/// positions of `u`, in the model's natural chart, by Newton's method on the twist block started
/// from the twist of `u`. That start must be close: the twist of a state measured in another
/// chart is not (convert it with [`natural_chart_unknowns`]). Converged when
/// `|R_theta| <= 1e-11`, or below `1e-8` once the updates stop shrinking (round-off).
pub(crate) fn slave_twist(model: &Model, u: &[f64]) -> Result<Vec<f64>> {
    slave_twist_in(model, &model.chart, u)
}

/// [`slave_twist`] with the twist measured in `chart` (the source chart of the energy).
pub fn slave_twist_in(model: &Model, chart: &Chart, u: &[f64]) -> Result<Vec<f64>> {
    slave_twist_to(model, chart, u, 1e-11)
}

/// [`slave_twist_in`] converged until `|R_theta| <= tol` (or until the updates stop shrinking
/// below `1e-8`, or reach round-off).
fn slave_twist_to(model: &Model, chart: &Chart, u: &[f64], tol: f64) -> Result<Vec<f64>> {
    slave_twist_with(model, chart, u, tol, Jacobians::Fresh)
}

/// [`slave_twist_to`] by the chord method on `j_tt`, the factorized twist block of a nearby
/// state (kept while the residual falls by a factor 3 per iteration): each iteration costs a
/// gradient of the energy instead of its Hessian. For states a small displacement from the one
/// `j_tt` was made at, started from its linear prediction.
pub(crate) fn slave_twist_chord(
    model: &Model,
    chart: &Chart,
    u: &[f64],
    tol: f64,
    j_tt: &Lu<f64>,
) -> Result<Vec<f64>> {
    let mut chord = Chord::holding(j_tt.clone());
    slave_twist_with(model, chart, u, tol, Jacobians::Reuse(&mut chord))
}

fn slave_twist_with(
    model: &Model,
    chart: &Chart,
    u: &[f64],
    tol: f64,
    jacobians: Jacobians,
) -> Result<Vec<f64>> {
    let block = TwistBlock {
        still: Steady {
            chart: chart.clone(),
            ..Steady::new(model, 0.0)
        },
        u: u.to_vec(),
        nx: model.rod.layout.free_positions(),
    };
    let newton = Newton {
        tol,
        max_iter: 50,
        min_steps: 0,
        globalization: Globalization::Full,
    };
    let (twist, _) = newton
        .run(&block, u[block.nx..].to_vec(), jacobians, "")
        .map_err(|_| {
            Error::Numerical(
                "the twist could not be slaved to the positions (Newton on R_theta = 0 failed)"
                    .into(),
            )
        })?;
    Ok(block.with_twist(&twist))
}

/// The twist equations `R_theta(x, theta) = 0` at the fixed positions of `u`, in the twist
/// angles alone (the twist block of the steady Jacobian).
struct TwistBlock<'a> {
    still: Steady<'a>,
    u: Vec<f64>,
    nx: usize,
}

impl TwistBlock<'_> {
    /// The free unknowns of `u` with the twist angles `twist`.
    fn with_twist(&self, twist: &[f64]) -> Vec<f64> {
        let mut u = self.u.clone();
        u[self.nx..].copy_from_slice(twist);
        u
    }
}

impl System for TwistBlock<'_> {
    /// `R_theta = -dE/dtheta` at the free angles.
    fn residual(&self, twist: &[f64]) -> Result<Vec<f64>> {
        let config = self.still.config(&self.with_twist(twist));
        let model = self.still.model;
        let g = model.rod.twist_gradient(&config, &self.still.chart);
        Ok(g[1..].iter().map(|v| -v).collect())
    }

    fn residual_and_jacobian(&self, twist: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.still.linearize(&self.with_twist(twist))?;
        let (nx, nt) = (self.nx, twist.len());
        let jacobian = Mat::from_fn(nt, nt, |a, b| lin.jacobian[(nx + a, nx + b)]);
        Ok((lin.residual[nx..].to_vec(), jacobian))
    }

    /// Round-off: the step is negligible, or it stopped shrinking with the residual below
    /// `1e-8`.
    fn settled(&self, it: &Iterate) -> Option<f64> {
        let round_off = it.step <= 1e-14 * (1.0 + norm(it.u));
        let stalled = it.step > 0.5 * it.previous_step && it.residual < 1e-8;
        (round_off || stalled).then_some(it.step)
    }
}

/// The free unknowns of `config`, whose twist is measured in `chart` (at `config.x`, e.g. a
/// [`crate::problem::steady::SteadyState`] with its carried chart), with the twist converted to the
/// model's natural chart, the one of [`integrate`] and [`crate::problem::rod::RodProblem`].
///
/// Both charts give the same material frames when the discrete twists
/// `m_i = theta^i - theta^{i-1} + mref_i` agree (edge 0 is clamped in both), so
/// `theta_nat^j = theta^j + sum_{i <= j} (mref_i - mref_nat_i)` with `mref_nat` the reference
/// twist of the natural chart carried to `config.x`; exact, including the multiples of `2 pi`.
/// The result is then polished by [`slave_twist`].
pub fn natural_chart_unknowns(model: &Model, config: &Config, chart: &Chart) -> Result<Vec<f64>> {
    let converted = rechart(config, chart, &model.chart);
    slave_twist(model, &Steady::new(model, 0.0).free_vector(&converted))
}

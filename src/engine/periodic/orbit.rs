//! One periodic orbit: Newton's method on the shooting system (4) of the module docs, and its
//! Floquet multipliers.

use faer::prelude::Solve;
use faer::{Mat, c64};
use serde::{Deserialize, Serialize};

use super::ImplicitDynamics;
use super::flow::{FlowSettings, period_map};
use crate::engine::newton::norm;
use crate::error::{EngineError, ensure_setting};
use crate::{Error, Result};

/// Settings of the shooting Newton iteration.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ShootingSettings {
    /// The period map's steps and step solves.
    pub flow: FlowSettings,
    /// Converged when `|Phi(x0) - x0|` (the problem's [`ImplicitDynamics::size`]) is at most
    /// `tol` times the orbit's amplitude (plus `tol^2`, for an orbit that shrinks to a point).
    pub tol: f64,
    /// Newton iterations allowed.
    pub max_iter: usize,
}

impl Default for ShootingSettings {
    fn default() -> Self {
        ShootingSettings {
            flow: FlowSettings::default(),
            tol: 1e-7,
            max_iter: 10,
        }
    }
}

impl ShootingSettings {
    /// Checks ranges: those of [`FlowSettings`], `0 < tol < 1e-2`, `max_iter >= 2`.
    pub fn validate(&self) -> Result<()> {
        self.flow.validate()?;
        ensure_setting(
            self.tol > 0.0 && self.tol < 1e-2,
            "tol",
            format!("must lie in (0, 0.01), got {}", self.tol),
        )?;
        ensure_setting(
            self.max_iter >= 2,
            "max_iter",
            format!("must be >= 2, got {}", self.max_iter),
        )
    }
}

/// The linear condition `c . (x0, T, p) = value` that completes (4).
#[derive(Clone, Debug)]
pub struct Condition {
    /// Length `n_x + 2`: the `x0` part, then `T`, then `p`.
    pub c: Vec<f64>,
    pub value: f64,
}

impl Condition {
    /// The parameter held at `p`.
    pub fn parameter(nx: usize, p: f64) -> Self {
        let mut c = vec![0.0; nx + 2];
        c[nx + 1] = 1.0;
        Condition { c, value: p }
    }
}

/// A converged periodic orbit.
#[derive(Clone, Debug)]
pub struct Orbit {
    /// The states at `t = k T / n`, `k = 0 .. n - 1` (all unknowns; `states[0]` is the point
    /// pinned by the phase condition).
    pub states: Vec<Vec<f64>>,
    pub period: f64,
    pub p: f64,
    /// Floquet multipliers, the trivial one (nearest 1) left out, by decreasing modulus.
    pub multipliers: Vec<c64>,
    /// The trivial multiplier (`1 + O((w h)^2)`).
    pub trivial: c64,
    /// Multipliers of modulus above 1 (the trivial one left out).
    pub unstable: usize,
    /// Newton iterations, and `|Phi(x0) - x0|` at the accepted orbit.
    pub iterations: usize,
    pub residual: f64,
}

impl Orbit {
    /// The largest modulus of a nontrivial multiplier.
    pub fn max_multiplier(&self) -> f64 {
        self.multipliers.first().map_or(0.0, |m| m.norm())
    }

    /// Root mean square over the period of the size of `x(t) - centre`, as
    /// [`ImplicitDynamics::size`] measures it (`None`: about the orbit's [`mean`]).
    pub fn amplitude(&self, dynamics: &impl ImplicitDynamics, centre: Option<&[f64]>) -> f64 {
        rms_amplitude(dynamics, &self.states, centre)
    }
}

/// The mean over a period of the sampled states `states` (equal steps, one period).
pub fn mean(states: &[Vec<f64>]) -> Vec<f64> {
    let n = states.len() as f64;
    let mut m = vec![0.0; states[0].len()];
    for u in states {
        for (a, b) in m.iter_mut().zip(u) {
            *a += b / n;
        }
    }
    m
}

/// Root mean square of the size of `x - centre` over the samples `states` (`centre` their mean
/// when `None`).
fn rms_amplitude(
    dynamics: &impl ImplicitDynamics,
    states: &[Vec<f64>],
    centre: Option<&[f64]>,
) -> f64 {
    let nx = dynamics.differential();
    let own;
    let centre = match centre {
        Some(c) => c,
        None => {
            own = mean(states);
            &own
        }
    };
    let sum: f64 = states
        .iter()
        .map(|u| {
            let d: Vec<f64> = (0..nx).map(|i| u[i] - centre[i]).collect();
            dynamics.size(&d).powi(2)
        })
        .sum();
    (sum / states.len() as f64).sqrt()
}

/// The Floquet multipliers of a monodromy matrix: the trivial one and the others by decreasing
/// modulus. The trivial multiplier is the one whose eigenvalue problem the orbit's velocity
/// `xdot` solves best, `min |Phi_x xdot - mu xdot|` (not simply the one nearest 1: next to a
/// Hopf point the radial multiplier is `1 + O(r^2)` and may lie nearer 1 than the trivial one
/// does numerically).
pub fn floquet(monodromy: &Mat<f64>, xdot: &[f64]) -> Result<(c64, Vec<c64>)> {
    let mut values = monodromy.eigenvalues().map_err(|e| {
        Error::Numerical(format!("Floquet multipliers: eigen solver failed: {e:?}"))
    })?;
    let n = xdot.len();
    let image: Vec<f64> = (0..n)
        .map(|r| (0..n).map(|c| monodromy[(r, c)] * xdot[c]).sum())
        .collect();
    let mismatch = |mu: c64| -> f64 {
        image
            .iter()
            .zip(xdot)
            .map(|(a, v)| (c64::new(*a, 0.0) - mu * *v).norm_sqr())
            .sum()
    };
    let trivial = (0..values.len())
        .min_by(|&a, &b| mismatch(values[a]).total_cmp(&mismatch(values[b])))
        .ok_or_else(|| Error::Numerical("Floquet multipliers of an empty system".into()))?;
    let one = values.remove(trivial);
    values.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    Ok((one, values))
}

/// Solves (4) from the guess `u0` (state; its differential part is `x_ref`), period `period`,
/// parameter `p`, with the condition `condition`. The phase condition uses the BDF2 velocity at
/// the end of the first period map from the guess (close to the velocity at the guess when the
/// guess is close to an orbit; any vector transversal to the orbit serves).
///
/// # Errors
/// [`Error::NewtonFailed`] when the iteration does not converge in `max_iter` steps or the
/// bordered matrix is singular; errors of the period map (a step that fails) as they are.
pub fn shoot(
    dynamics: &impl ImplicitDynamics,
    u0: &[f64],
    period: f64,
    p: f64,
    condition: &Condition,
    settings: &ShootingSettings,
) -> Result<Orbit> {
    settings.validate()?;
    let nx = dynamics.differential();
    let fail = |reason: String, iterations: usize, residual: f64| {
        Error::from(EngineError::NewtonFailed {
            context: format!("periodic orbit near p = {p:.6e}, T = {period:.6e}"),
            reason,
            iterations,
            residual,
        })
    };
    let x_ref = u0[..nx].to_vec();
    let mut u = u0.to_vec();
    let (mut t, mut p) = (period, p);
    let mut xdot_ref: Option<Vec<f64>> = None;
    for iteration in 0..=settings.max_iter {
        let map = period_map(dynamics, p, &u, t, &settings.flow, true)?;
        u = map.states[0].clone();
        let xdot = xdot_ref.get_or_insert_with(|| map.end_velocity.clone());
        let x0 = &u[..nx];
        let r: Vec<f64> = map.end(nx).iter().zip(x0).map(|(a, b)| a - b).collect();
        let phase: f64 = (0..nx).map(|i| xdot[i] * (x0[i] - x_ref[i])).sum();
        let y: Vec<f64> = x0.iter().copied().chain([t, p]).collect();
        let cond = condition.c.iter().zip(&y).map(|(a, b)| a * b).sum::<f64>() - condition.value;
        let residual = dynamics.size(&r);
        let sens = map.sensitivity.expect("sensitivities were asked for");
        let end_velocity = map.end_velocity;
        let mut states = map.states;
        states.pop();
        let amplitude = rms_amplitude(dynamics, &states, None);
        let xdot_norm = norm(xdot).max(f64::MIN_POSITIVE);
        let c_norm = norm(&condition.c).max(f64::MIN_POSITIVE);
        let settled = residual <= settings.tol * amplitude + settings.tol * settings.tol
            && phase.abs() <= settings.tol * xdot_norm * (amplitude + settings.tol)
            && cond.abs() <= settings.tol * c_norm * (1.0 + norm(&y));
        if settled {
            let (trivial, multipliers) = floquet(&sens.x0, &end_velocity)?;
            let unstable = multipliers.iter().filter(|m| m.norm() > 1.0).count();
            return Ok(Orbit {
                states,
                period: t,
                p,
                multipliers,
                trivial,
                unstable,
                iterations: iteration,
                residual,
            });
        }
        if !residual.is_finite() {
            return Err(fail(
                "the residual is not finite".into(),
                iteration,
                residual,
            ));
        }
        if iteration == settings.max_iter {
            return Err(fail(
                format!(
                    "no convergence to {:e} (times the amplitude {amplitude:.3e}) within {} \
                     iterations",
                    settings.tol, settings.max_iter
                ),
                iteration,
                residual,
            ));
        }
        let n = nx + 2;
        let j = Mat::from_fn(n, n, |row, col| match (row, col) {
            (row, col) if row < nx && col < nx => {
                sens.x0[(row, col)] - if row == col { 1.0 } else { 0.0 }
            }
            (row, col) if row < nx && col == nx => sens.period[row],
            (row, _) if row < nx => sens.parameter[row],
            (row, col) if row == nx => {
                if col < nx {
                    xdot[col]
                } else {
                    0.0
                }
            }
            (_, col) => condition.c[col],
        });
        let rhs = Mat::from_fn(n, 1, |row, _| {
            -if row < nx {
                r[row]
            } else if row == nx {
                phase
            } else {
                cond
            }
        });
        let dy = j.partial_piv_lu().solve(&rhs);
        if !dy.is_all_finite() {
            return Err(fail("singular shooting matrix".into(), iteration, residual));
        }
        let mut du = vec![0.0; u.len()];
        for (i, d) in du.iter_mut().enumerate().take(nx) {
            *d = dy[(i, 0)];
        }
        u = dynamics.retract(&u, &du);
        t += dy[(nx, 0)];
        p += dy[(nx + 1, 0)];
        if t.is_nan() || t <= 0.0 {
            return Err(fail(
                format!("the period became non-positive ({t:e})"),
                iteration,
                residual,
            ));
        }
    }
    unreachable!("the loop returns at its last iteration")
}

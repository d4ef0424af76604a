//! The period map `Phi(x0, T, p)` of equal BDF2 steps and its sensitivities, eqs. (2) and (3)
//! of the module docs.

use faer::Mat;
use faer::prelude::Solve;
use serde::{Deserialize, Serialize};

use super::{ImplicitDynamics, StepVelocity};
use crate::engine::newton::{Chord, Globalization, Iterate, Jacobians, Newton, System, norm};
use crate::error::ensure_setting;
use crate::numerics::lu::Lu;
use crate::{Error, Result};

/// How the period is stepped.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FlowSettings {
    /// Equal steps per period (BDF2; the period error is about `(2 pi / steps)^2 / 3`
    /// relative).
    pub steps: usize,
    /// Newton tolerance on the residual of one step (the problem's units); a step is also
    /// converged when its Newton update is below [`STEP_PRECISION`] relative.
    pub step_tol: f64,
    /// Newton iterations allowed per step.
    pub max_newton: usize,
}

impl Default for FlowSettings {
    fn default() -> Self {
        FlowSettings {
            steps: 100,
            step_tol: 1e-9,
            max_newton: 40,
        }
    }
}

impl FlowSettings {
    /// Checks ranges: `8 <= steps <= 100000`, `0 < step_tol < 1`, `max_newton >= 2`.
    pub fn validate(&self) -> Result<()> {
        ensure_setting(
            (8..=100_000).contains(&self.steps),
            "steps",
            format!("must lie in [8, 100000], got {}", self.steps),
        )?;
        ensure_setting(
            self.step_tol > 0.0 && self.step_tol < 1.0,
            "step_tol",
            format!("must lie in (0, 1), got {}", self.step_tol),
        )?;
        ensure_setting(
            self.max_newton >= 2,
            "max_newton",
            format!("must be >= 2, got {}", self.max_newton),
        )
    }
}

/// `d x_n / d(x0, T, p)`: the monodromy matrix and the derivatives in the period and the
/// parameter.
pub struct Sensitivity {
    pub x0: Mat<f64>,
    pub period: Vec<f64>,
    pub parameter: Vec<f64>,
}

/// One evaluation of the period map.
pub struct PeriodMap {
    /// The states `u_0 .. u_n` at `t = k T / n` (all unknowns); where the dynamics carries its
    /// coordinates ([`ImplicitDynamics::centred_on`]), `u_k` (`k >= 1`) is measured in the
    /// coordinates of step `k`, those of step `k - 1` centred on `u_{k - 1}` ([`carried`]).
    pub states: Vec<Vec<f64>>,
    /// `v_n`, the BDF2 velocity at the end (an approximation of `dx/dt` there, `O(h^2)`).
    pub end_velocity: Vec<f64>,
    pub sensitivity: Option<Sensitivity>,
}

impl PeriodMap {
    /// The differential part of the last state, `Phi(x0, T, p)`.
    pub fn end(&self, nx: usize) -> &[f64] {
        &self.states[self.states.len() - 1][..nx]
    }
}

/// Step (2) as a Newton system.
struct Step<'a, D: ImplicitDynamics> {
    dynamics: &'a D,
    p: f64,
    c0: f64,
    offset: &'a [f64],
}

impl<D: ImplicitDynamics> Step<'_, D> {
    fn velocity(&self) -> StepVelocity<'_> {
        StepVelocity {
            c0: self.c0,
            offset: self.offset,
        }
    }
}

impl<D: ImplicitDynamics> System for Step<'_, D> {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.dynamics.step_residual(self.p, self.velocity(), u)
    }
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.dynamics.step_linearize(self.p, self.velocity(), u)?;
        Ok((lin.g, lin.g_u))
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.dynamics.retract(u, du)
    }
    /// Settled once the Newton update is below [`STEP_PRECISION`] `(1 + |u|)`: a stiff
    /// problem's residual (the rod's stretching forces) may stall above `step_tol` at round-off
    /// while the state is exact to that precision.
    fn settled(&self, it: &Iterate) -> Option<f64> {
        (it.step <= STEP_PRECISION * (1.0 + norm(it.u))).then_some(it.step)
    }
}

/// Relative size of a Newton update at which a step's state is taken as converged.
pub const STEP_PRECISION: f64 = 1e-11;

/// `Phi(x0, T, p)` from the state `u0` (its algebraic part is re-solved first), with the
/// sensitivities (3) when `sensitivities` is set.
///
/// # Errors
/// [`Error::Numerical`] naming the step when a step's Newton iteration fails; errors of the
/// problem's evaluation as they are.
pub fn period_map<D: ImplicitDynamics>(
    dynamics: &D,
    p: f64,
    u0: &[f64],
    period: f64,
    settings: &FlowSettings,
    sensitivities: bool,
) -> Result<PeriodMap> {
    settings.validate()?;
    if !(period.is_finite() && period > 0.0) {
        return Err(Error::Numerical(format!(
            "periodic orbit: the period must be positive and finite, got {period:e}"
        )));
    }
    let nx = dynamics.differential();
    let n = settings.steps;
    let h = period / n as f64;
    let newton = Newton {
        tol: settings.step_tol,
        max_iter: settings.max_newton,
        min_steps: 0,
        globalization: Globalization::Full,
    };
    let first_state = dynamics.consistent(p, u0)?;
    // f_0 = M(u_0)^{-1} F(u_0) and, with the sensitivities, d f_0 / d(x0, T, p).
    let (f0, df0) = initial_velocity(dynamics, p, &first_state, sensitivities)?;
    let mut states = vec![first_state];
    // S_{k-1} and S_{k-2} (n_x rows, n_x + 2 columns: x0, T, p).
    let mut sens: Vec<Mat<f64>> = Vec::new();
    if sensitivities {
        sens.push(Mat::from_fn(
            nx,
            nx + 2,
            |r, c| if r == c { 1.0 } else { 0.0 },
        ));
    }
    let mut chord = Chord::default();
    let mut end_velocity = vec![0.0; nx];
    // The coordinates of the step, when the dynamics carries them (else `dynamics`'s own).
    let mut carried_coordinates: Option<D> = None;
    for k in 1..=n {
        carried_coordinates = carried_coordinates
            .as_ref()
            .unwrap_or(dynamics)
            .centred_on(&states[k - 1]);
        let dynamics = carried_coordinates.as_ref().unwrap_or(dynamics);
        let first = k == 1;
        // The trapezoidal rule first, v_1 = 2 (x_1 - x_0)/h - f_0; BDF2 after it.
        let c0 = if first { 2.0 / h } else { 1.5 / h };
        let x1 = &states[k - 1][..nx];
        let offset: Vec<f64> = (0..nx)
            .map(|i| {
                if first {
                    -2.0 * x1[i] / h - f0[i]
                } else {
                    (-2.0 * x1[i] + 0.5 * states[k - 2][i]) / h
                }
            })
            .collect();
        if k == 2 {
            // c0 changed from the trapezoidal rule to BDF2.
            chord.clear();
        }
        let mut guess = extrapolate(&states);
        if carried_coordinates.is_some() {
            // The earlier states' algebraic parts are measured in other coordinates: the last
            // one's, which keeps its values in these, starts the iteration.
            guess[nx..].copy_from_slice(&states[k - 1][nx..]);
        }
        let step = Step {
            dynamics,
            p,
            c0,
            offset: &offset,
        };
        let (u, _) = newton
            .run(
                &step,
                guess,
                Jacobians::Reuse(&mut chord),
                "in a shooting step",
            )
            .map_err(|e| {
                Error::Numerical(format!(
                    "periodic orbit: step {k} of {n} (T = {period:.6e}, p = {p:.6e}) failed: {e}"
                ))
            })?;
        let velocity = StepVelocity {
            c0,
            offset: &offset,
        };
        let v = velocity.at(&u[..nx]);
        if sensitivities {
            let lin = dynamics.step_linearize(p, velocity, &u)?;
            let lu = Lu::new(lin.g_u.as_ref());
            let s1 = &sens[sens.len() - 1];
            // h db, the change of the offset with the earlier states, eq. (3):
            // -2 S_0 - h df_0 for the trapezoidal step, -2 S_{k-1} + S_{k-2}/2 for BDF2.
            let earlier = match &df0 {
                Some(df0) if first => s1 * -2.0 - df0 * h,
                _ => s1 * -2.0 + &sens[sens.len() - 2] * 0.5,
            };
            let mut rhs = Mat::<f64>::zeros(dynamics.dim(), nx + 2);
            let mv = &lin.mass * earlier;
            for r in 0..nx {
                for c in 0..nx + 2 {
                    rhs[(r, c)] = mv[(r, c)] / h;
                }
            }
            // The explicit dependence of v on h = T/n: the terms in 1/h of v, over T.
            let scaled: Vec<f64> = if first {
                v.iter().zip(&f0).map(|(v, f)| v + f).collect()
            } else {
                v.clone()
            };
            for r in 0..nx {
                let m_v: f64 = (0..nx).map(|c| lin.mass[(r, c)] * scaled[c]).sum();
                rhs[(r, nx)] -= m_v / period;
            }
            for (r, gp) in lin.g_p.iter().enumerate() {
                rhs[(r, nx + 1)] -= gp;
            }
            let du = lu.solve(rhs.as_ref());
            if !du.is_all_finite() {
                return Err(Error::Numerical(format!(
                    "periodic orbit: singular step Jacobian at step {k} of {n}"
                )));
            }
            let next = Mat::from_fn(nx, nx + 2, |r, c| du[(r, c)]);
            sens.push(next);
            if sens.len() > 2 {
                sens.remove(0);
            }
            chord = Chord::holding(lu);
        }
        if k == n {
            end_velocity = v;
        }
        states.push(u);
    }
    let sensitivity = sensitivities.then(|| {
        let s = &sens[sens.len() - 1];
        Sensitivity {
            x0: Mat::from_fn(nx, nx, |r, c| s[(r, c)]),
            period: (0..nx).map(|r| s[(r, nx)]).collect(),
            parameter: (0..nx).map(|r| s[(r, nx + 1)]).collect(),
        }
    });
    Ok(PeriodMap {
        states,
        end_velocity,
        sensitivity,
    })
}

/// `f_0 = M(u_0)^{-1} F(u_0)` at a consistent state, and with `sensitivities` its derivative
/// in `(x0, T, p)` (`n_x` rows, `n_x + 2` columns, the `T` column zero): differentiating
/// `F(u_0) - M(u_0) f_0 = 0`, `F_z(u_0) = 0` with the algebraic part slaved gives
/// `[-M, G_z; 0, G_zz] (df_0, dz_0) = -(G_x dx_0 + G_p dp)`, `G` the step residual (2) at `v = f_0`,
/// `c0 = 0`.
fn initial_velocity(
    dynamics: &impl ImplicitDynamics,
    p: f64,
    u0: &[f64],
    sensitivities: bool,
) -> Result<(Vec<f64>, Option<Mat<f64>>)> {
    let nx = dynamics.differential();
    let dim = dynamics.dim();
    let zero = vec![0.0; nx];
    let at_rest = StepVelocity {
        c0: 0.0,
        offset: &zero,
    };
    let lin = dynamics.step_linearize(p, at_rest, u0)?;
    let f = lin
        .mass
        .partial_piv_lu()
        .solve(Mat::from_fn(nx, 1, |r, _| lin.g[r]));
    let f0: Vec<f64> = (0..nx).map(|r| f[(r, 0)]).collect();
    if !f0.iter().all(|v| v.is_finite()) {
        return Err(Error::Numerical(
            "periodic orbit: singular mass matrix at the initial state".into(),
        ));
    }
    if !sensitivities {
        return Ok((f0, None));
    }
    let moving = StepVelocity {
        c0: 0.0,
        offset: &f0,
    };
    let lin = dynamics.step_linearize(p, moving, u0)?;
    let matrix = Mat::from_fn(dim, dim, |r, c| match (r < nx, c < nx) {
        (true, true) => -lin.mass[(r, c)],
        (false, true) => 0.0,
        _ => lin.g_u[(r, c)],
    });
    let rhs = Mat::from_fn(dim, nx + 2, |r, c| {
        if c < nx {
            -lin.g_u[(r, c)]
        } else if c == nx {
            0.0
        } else {
            -lin.g_p[r]
        }
    });
    let solved = matrix.partial_piv_lu().solve(&rhs);
    if !solved.is_all_finite() {
        return Err(Error::Numerical(
            "periodic orbit: singular system for the initial velocity".into(),
        ));
    }
    Ok((f0, Some(Mat::from_fn(nx, nx + 2, |r, c| solved[(r, c)]))))
}

/// The coordinates of each of `states` (a period map's, [`PeriodMap::states`]): `None` for
/// `dynamics`'s own, else those carried to it.
pub fn carried<D: ImplicitDynamics>(dynamics: &D, states: &[Vec<f64>]) -> Vec<Option<D>> {
    let mut frames: Vec<Option<D>> = vec![None];
    for u in &states[..states.len().saturating_sub(1)] {
        let last = frames.last().and_then(Option::as_ref).unwrap_or(dynamics);
        let next = last.centred_on(u);
        frames.push(next);
    }
    frames
}

/// The next state extrapolated from the last three (quadratic), two (linear) or one.
fn extrapolate(states: &[Vec<f64>]) -> Vec<f64> {
    let k = states.len();
    let a = &states[k - 1];
    match k {
        1 => a.clone(),
        2 => a.iter().zip(&states[0]).map(|(a, b)| 2.0 * a - b).collect(),
        _ => {
            let (b, c) = (&states[k - 2], &states[k - 3]);
            (0..a.len())
                .map(|i| 3.0 * a[i] - 3.0 * b[i] + c[i])
                .collect()
        }
    }
}

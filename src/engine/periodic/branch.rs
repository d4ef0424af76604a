//! The branch of periodic orbits born at a Hopf point, followed by secant pseudo-arclength
//! continuation of (4).
//!
//! **Start.** Near a Hopf point `(x_H, p_H)` with critical eigenvalue `i w` and mode `q` (scaled
//! as the problem's Lyapunov coefficient is, [`crate::engine::Problem::mode_size`] 1, `Re q` orthogonal to `Im q`), the orbits are `x = x_H + 2 Re(r e^{i w t} q) +
//! O(r^2)` with period `2 pi / w + O(r^2)` and `p - p_H = O(r^2)` (on the side set by the sign
//! of the first Lyapunov coefficient). Two orbits are solved with the amplitude fixed instead
//! of the parameter, `Re q . (x0 - x_H) / |Re q|^2 = 2 r` at `r = r_0` and `2 r_0`, from those
//! guesses (the parameter is a poor unknown at small `r`, the amplitude a good one).
//!
//! **Continuation.** With `y = (x0 / X, T / T_0, p / P)` scaled by the first secant's change of
//! `x0`, the Hopf period and `max(|p_H|, 1)`, the predictor is `y_k + ds s_k` along the unit secant
//! `s_k = (y_k - y_{k-1}) / |y_k - y_{k-1}|`, and the corrector solves (4) with the condition
//! `s_k . (y - y_pred) = 0`, so that folds in `p` (where a subcritical branch turns back and
//! gains stability) are passed without special treatment. The step grows by 1.5 after a
//! correction of at most 3 iterations, is halved after a failure down to `ds_min`, and is at
//! most `ds_max` ([`crate::engine::step::StepControl`], never shrinking after a hard correction).
//!
//! **Events** between successive orbits: a fold where `p` turns; a change of the count of
//! multipliers outside the unit circle, typed by the multiplier that crossed (nearest the unit
//! circle at either end: real near `+1` a fold of cycles, real near `-1` period doubling, a
//! complex pair a torus bifurcation). They are bracketed by the two orbits, not localized.
//!
//! **Resuming.** After every orbit from the second on, the observer is handed a [`Checkpoint`]
//! (the last two orbits' unknowns, the scaling, the step, the next index); [`resume_orbits`]
//! continues from one exactly as the interrupted run would have.

use std::ops::ControlFlow;

use faer::c64;
use serde::{Deserialize, Serialize};

use super::ImplicitDynamics;
use super::orbit::{Condition, Orbit, ShootingSettings, shoot};
use crate::Result;
use crate::engine::step::StepControl;
use crate::error::ensure_setting;

/// Settings of the orbit branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OrbitBranchSettings {
    pub shooting: ShootingSettings,
    /// The normal-form radius `r_0` of the first orbit, `x0 = x_H + 2 r_0 Re q` for the mode of
    /// [`HopfStart`] (the second has `2 r_0`).
    pub amplitude: f64,
    /// Largest and smallest step, in units of the first secant.
    pub ds_max: f64,
    pub ds_min: f64,
    /// Largest number of orbits.
    pub max_orbits: usize,
}

impl Default for OrbitBranchSettings {
    fn default() -> Self {
        OrbitBranchSettings {
            shooting: ShootingSettings::default(),
            amplitude: 1e-3,
            ds_max: 32.0,
            ds_min: 1.0 / 64.0,
            max_orbits: 40,
        }
    }
}

impl OrbitBranchSettings {
    /// Checks ranges: the shooting's, `amplitude > 0`, `0 < ds_min <= 1 <= ds_max`,
    /// `max_orbits >= 2`; an error names the field (`ds_max` for the pair of steps), as the
    /// shooting's and the flow's do theirs (`tol`, `steps`, ...).
    pub fn validate(&self) -> Result<()> {
        self.shooting.validate()?;
        ensure_setting(
            self.amplitude > 0.0 && self.amplitude.is_finite(),
            "amplitude",
            format!("must be finite and > 0, got {}", self.amplitude),
        )?;
        ensure_setting(
            self.ds_min > 0.0
                && self.ds_min <= 1.0
                && self.ds_max >= 1.0
                && self.ds_max.is_finite(),
            "ds_max",
            format!(
                "need 0 < ds_min <= 1 <= ds_max < inf, got ds_min = {}, ds_max = {}",
                self.ds_min, self.ds_max
            ),
        )?;
        ensure_setting(
            self.max_orbits >= 2,
            "max_orbits",
            format!("must be >= 2, got {}", self.max_orbits),
        )
    }
}

/// A Hopf point to start from: the steady state (all unknowns), the parameter, the frequency
/// `w` and the critical mode `q = re + i im` on the differential unknowns, of size 1.
pub struct HopfStart {
    pub u: Vec<f64>,
    pub p: f64,
    pub frequency: f64,
    pub mode: (Vec<f64>, Vec<f64>),
}

/// What happened between two successive orbits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OrbitEventKind {
    /// The parameter turned.
    Fold,
    /// A real multiplier crossed the unit circle near `+1`.
    CycleFold,
    /// A real multiplier crossed near `-1`.
    PeriodDoubling,
    /// A complex pair crossed.
    Torus,
}

/// An event bracketed by the orbits `after` and `after + 1` of the branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrbitEvent {
    pub kind: OrbitEventKind,
    pub after: usize,
    /// The parameter at the two orbits.
    pub p: (f64, f64),
}

/// Why the branch ended.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OrbitStop {
    MaxOrbits,
    /// The parameter left `[p_min, p_max]`.
    ParameterLimit,
    /// The observer ended the run.
    Observer,
    /// The corrector failed down to the smallest step (the last reason).
    StepTooSmall(String),
}

/// A traced branch of orbits.
pub struct OrbitBranch {
    /// The orbits computed in this run; the first has index `first_index` on the branch (0 from a
    /// Hopf point, more when the run resumed a [`Checkpoint`]).
    pub orbits: Vec<Orbit>,
    pub first_index: usize,
    /// Every event of the branch, those before a resumed checkpoint included.
    pub events: Vec<OrbitEvent>,
    pub stop: OrbitStop,
}

/// What the continuation keeps of an orbit: its unknowns, its stability and multipliers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrbitSeed {
    /// The state pinned by the phase condition (all unknowns), the period, the parameter.
    pub u: Vec<f64>,
    pub period: f64,
    pub p: f64,
    pub unstable: usize,
    /// The nontrivial multipliers as `[re, im]`.
    pub multipliers: Vec<[f64; 2]>,
}

impl OrbitSeed {
    fn of(orbit: &Orbit) -> Self {
        OrbitSeed {
            u: orbit.states[0].clone(),
            period: orbit.period,
            p: orbit.p,
            unstable: orbit.unstable,
            multipliers: orbit.multipliers.iter().map(|m| [m.re, m.im]).collect(),
        }
    }

    fn unknowns(&self, nx: usize) -> Vec<f64> {
        self.u[..nx]
            .iter()
            .copied()
            .chain([self.period, self.p])
            .collect()
    }

    fn multipliers(&self) -> Vec<c64> {
        self.multipliers
            .iter()
            .map(|m| c64::new(m[0], m[1]))
            .collect()
    }
}

/// Where a branch can be taken up again: its last two orbits, the scaling of the unknowns and
/// the step, the index the next orbit will have, and the events so far. Saved after every orbit
/// (from the second on), it lets an interrupted run resume without losing any finished orbit
/// or event ([`resume_orbits`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    pub previous: OrbitSeed,
    pub last: OrbitSeed,
    pub scale: Vec<f64>,
    pub ds: f64,
    pub next_index: usize,
    /// Every event between orbits before `next_index` (absent from checkpoints written before
    /// they were kept: the events of the runs that wrote those are lost).
    #[serde(default)]
    pub events: Vec<OrbitEvent>,
}

/// Follows the orbits from `start` until one lies outside `[p_min, p_max]` (it is kept). `observer` sees every
/// accepted orbit with its index and, from the second orbit on, the checkpoint after it; it may
/// end the run.
///
/// # Errors
/// Bad settings; the failure of either starting orbit (there is no branch without them).
pub fn follow_orbits(
    dynamics: &impl ImplicitDynamics,
    start: &HopfStart,
    settings: &OrbitBranchSettings,
    range: (f64, f64),
    mut observer: impl FnMut(usize, &Orbit, Option<&Checkpoint>) -> ControlFlow<()>,
) -> Result<OrbitBranch> {
    settings.validate()?;
    let nx = dynamics.differential();
    let re = &start.mode.0;
    let re2: f64 = re.iter().map(|v| v * v).sum();
    let period0 = 2.0 * std::f64::consts::PI / start.frequency;
    let centre = start.u[..nx]
        .iter()
        .zip(re)
        .map(|(x, q)| x * q)
        .sum::<f64>()
        / re2;
    let mut orbits: Vec<Orbit> = Vec::new();
    for r in [settings.amplitude, 2.0 * settings.amplitude] {
        let mut guess = start.u.clone();
        for (g, q) in guess.iter_mut().zip(re) {
            *g += 2.0 * r * q;
        }
        let condition = Condition {
            c: re.iter().map(|q| q / re2).chain([0.0, 0.0]).collect(),
            value: centre + 2.0 * r,
        };
        let orbit = shoot(
            dynamics,
            &guess,
            period0,
            start.p,
            &condition,
            &settings.shooting,
        )?;
        orbits.push(orbit);
        let index = orbits.len() - 1;
        if index == 0 && observer(0, &orbits[0], None).is_break() {
            return Ok(OrbitBranch {
                orbits,
                first_index: 0,
                events: Vec::new(),
                stop: OrbitStop::Observer,
            });
        }
    }
    let (previous, last) = (OrbitSeed::of(&orbits[0]), OrbitSeed::of(&orbits[1]));
    let dx: f64 = (0..nx)
        .map(|i| (last.u[i] - previous.u[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let checkpoint = Checkpoint {
        previous,
        last,
        scale: std::iter::repeat_n(dx.max(f64::MIN_POSITIVE), nx)
            .chain([period0, start.p.abs().max(1.0)])
            .collect(),
        ds: 1.0,
        next_index: 2,
        events: Vec::new(),
    };
    if observer(1, &orbits[1], Some(&checkpoint)).is_break() {
        return Ok(OrbitBranch {
            orbits,
            first_index: 0,
            events: Vec::new(),
            stop: OrbitStop::Observer,
        });
    }
    let mut branch = resume_orbits(dynamics, &checkpoint, settings, range, observer)?;
    orbits.append(&mut branch.orbits);
    branch.orbits = orbits;
    branch.first_index = 0;
    Ok(branch)
}

/// Continues a branch from `checkpoint` (see [`follow_orbits`]); the orbits' indices go on from
/// its `next_index`.
///
/// # Errors
/// Bad settings, or a checkpoint whose unknowns do not fit the problem.
pub fn resume_orbits(
    dynamics: &impl ImplicitDynamics,
    checkpoint: &Checkpoint,
    settings: &OrbitBranchSettings,
    (p_min, p_max): (f64, f64),
    mut observer: impl FnMut(usize, &Orbit, Option<&Checkpoint>) -> ControlFlow<()>,
) -> Result<OrbitBranch> {
    settings.validate()?;
    let nx = dynamics.differential();
    let fits = |seed: &OrbitSeed| seed.u.len() == dynamics.dim();
    if !(fits(&checkpoint.previous) && fits(&checkpoint.last) && checkpoint.scale.len() == nx + 2) {
        return Err(crate::Error::input(
            "checkpoint",
            format!(
                "its orbits do not have the problem's {} unknowns (another model or node count)",
                dynamics.dim()
            ),
        ));
    }
    let mut state = checkpoint.clone();
    let scale = checkpoint.scale.clone();
    let scaled = |y: &[f64]| -> Vec<f64> { y.iter().zip(&scale).map(|(a, s)| a / s).collect() };
    let mut orbits = Vec::new();
    let mut events = checkpoint.events.clone();
    let stop = loop {
        let k = state.next_index;
        if k >= settings.max_orbits {
            break OrbitStop::MaxOrbits;
        }
        let (a, b) = (&state.previous, &state.last);
        if !(p_min..=p_max).contains(&b.p) {
            break OrbitStop::ParameterLimit;
        }
        let ya = scaled(&a.unknowns(nx));
        let yb = scaled(&b.unknowns(nx));
        let chord: Vec<f64> = yb.iter().zip(&ya).map(|(b, a)| b - a).collect();
        let length = chord.iter().map(|v| v * v).sum::<f64>().sqrt();
        let secant: Vec<f64> = chord.iter().map(|v| v / length).collect();
        let mut step =
            StepControl::new(state.ds, settings.ds_min, settings.ds_max).never_shrinking();
        let attempt = loop {
            let ds = step.ds();
            let predicted: Vec<f64> = yb.iter().zip(&secant).map(|(y, s)| y + ds * s).collect();
            // The guess: the last orbit's state moved along the secant (algebraic part kept).
            let mut guess = b.u.clone();
            for i in 0..nx {
                guess[i] = predicted[i] * scale[i];
            }
            let condition = Condition {
                c: secant.iter().zip(&scale).map(|(s, sc)| s / sc).collect(),
                value: secant.iter().zip(&predicted).map(|(s, y)| s * y).sum(),
            };
            let tried = shoot(
                dynamics,
                &guess,
                predicted[nx] * scale[nx],
                predicted[nx + 1] * scale[nx + 1],
                &condition,
                &settings.shooting,
            );
            match tried {
                Ok(orbit) => break Ok(orbit),
                Err(e) => {
                    if step.failed().is_err() {
                        break Err(e.to_string());
                    }
                }
            }
        };
        let orbit = match attempt {
            Ok(o) => o,
            Err(reason) => break OrbitStop::StepTooSmall(reason),
        };
        step.adapt(orbit.iterations);
        if (b.p - a.p) * (orbit.p - b.p) < 0.0 {
            events.push(OrbitEvent {
                kind: OrbitEventKind::Fold,
                after: k - 1,
                p: (b.p, orbit.p),
            });
        }
        if orbit.unstable != b.unstable {
            events.push(OrbitEvent {
                kind: crossing_kind(&b.multipliers(), &orbit.multipliers),
                after: k - 1,
                p: (b.p, orbit.p),
            });
        }
        state = Checkpoint {
            previous: state.last.clone(),
            last: OrbitSeed::of(&orbit),
            scale: scale.clone(),
            ds: step.ds(),
            next_index: k + 1,
            events: events.clone(),
        };
        orbits.push(orbit);
        if observer(k, &orbits[orbits.len() - 1], Some(&state)).is_break() {
            break OrbitStop::Observer;
        }
    };
    Ok(OrbitBranch {
        orbits,
        first_index: checkpoint.next_index,
        events,
        stop,
    })
}

/// The kind of the multiplier that crossed the unit circle between orbits of multipliers `a`
/// and `b`: the one nearest the circle at either orbit.
fn crossing_kind(a: &[c64], b: &[c64]) -> OrbitEventKind {
    let nearest = a
        .iter()
        .chain(b)
        .min_by(|x, y| (x.norm() - 1.0).abs().total_cmp(&(y.norm() - 1.0).abs()))
        .copied()
        .unwrap_or(c64::new(1.0, 0.0));
    if crate::engine::stability::is_complex(nearest) {
        OrbitEventKind::Torus
    } else if nearest.re > 0.0 {
        OrbitEventKind::CycleFold
    } else {
        OrbitEventKind::PeriodDoubling
    }
}

//! Newton's method for `G(u) = 0`: the one solver of the steady solve, the continuation
//! corrector, the implicit time step and the twist slave, each choosing its globalization, its
//! Jacobian policy and its stopping test.
//!
//! Step: `du = -G'(u)^{-1} G(u)` (dense LU with partial pivoting, faer), applied through the
//! system's retraction ([`System::retract`]). The iteration ends at `u` when `|G(u)| <= tol`, or
//! when the system judges the step `du` negligible ([`System::settled`]: round-off size by
//! default); it fails after `max_iter` steps, on a residual that is not finite and on a singular
//! Jacobian.
//!
//! **Jacobians** ([`Jacobians`]): a fresh one at every iterate (Newton's method proper), or one
//! factorization kept across iterations and solves and rebuilt only when the residual falls by
//! less than a factor 3 in an iteration (the chord method of the time step, whose Jacobian
//! changes little from one step to the next).
//!
//! **Globalization** ([`Globalization`]): full steps, for callers that shorten their own step on
//! failure (the continuation corrector, the time step); or the damped step of the steady solve, a
//! backtracking line search on the residual norm that tolerates the transient rise caused by
//! stiffness. The trial point is `retract(u, a du)` for `a = 1, 1/2, 1/4, ...`, accepted when
//! `G` can be evaluated there and
//!
//! ```text
//! |G(trial)| <= growth |G(u)|     (growth = 1e6 by default).               (1)
//! ```
//!
//! A strict decrease test (Armijo on `|G|`, or Deuflhard's natural monotonicity test on
//! `|G'(u)^{-1} G(trial)|`) stalls on a stiff, nearly inextensible rod: a good step leaves
//! position errors of relative size `1e-4`, which the stretching stiffness (`EA/EI ~ 1e4..1e6`)
//! turns into a raw residual larger than the one before, and the next full step removes them.
//! Measured on the representative helix, full steps reach the solution in fewer iterations than
//! either monotone test, which backtrack to tiny steps. Test (1) still rejects steps that cannot
//! be evaluated (the mobility matrix is not positive definite there) or that blow up, and
//! divergence ends at `max_iter`, leaving the caller to shorten its continuation step. Near the
//! solution the full step is taken and the convergence is quadratic. Converged when `|G| <= tol`,
//! or when the Newton step is at round-off size (`|du| <= 1e-13 (1 + |u|)`).

use faer::Mat;
use serde::{Deserialize, Serialize};

use crate::error::EngineError;
use crate::numerics::lu::Lu;
use crate::{Error, Result};

/// A square nonlinear system.
pub trait System {
    /// `G(u)`.
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>>;
    /// `G(u)` and its Jacobian `G'(u)`.
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)>;
    /// The point reached from `u` along the step `du`: `u + du` by default. A system may use
    /// any map that agrees with `u + du` to first order (a retraction); Newton's method then
    /// keeps its quadratic convergence, and a well-chosen map removes a stiff nonlinearity.
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        u.iter().zip(du).map(|(a, b)| a + b).collect()
    }
    /// The size of a residual, tested against the tolerance and by the line search: the
    /// Euclidean norm by default.
    fn size(&self, g: &[f64]) -> f64 {
        norm(g)
    }
    /// Whether the iteration may end at `it.u` without taking the step `it.du`, and if so the
    /// precision of `it.u` (in the system's own units). Default: the step is at round-off size,
    /// `|du| <= 1e-13 (1 + |u|)`.
    fn settled(&self, it: &Iterate) -> Option<f64> {
        (it.step <= ROUND_OFF * (1.0 + norm(it.u))).then_some(it.step)
    }
}

/// A Newton step at round-off size, relative to `1 + |u|`.
pub const ROUND_OFF: f64 = 1e-13;

/// One iterate, as [`System::settled`] sees it.
pub struct Iterate<'a> {
    /// The iterate and the Newton step from it.
    pub u: &'a [f64],
    pub du: &'a [f64],
    /// `size(G(u))`.
    pub residual: f64,
    /// `|du|` and the norm of the step before (infinite at the first iterate).
    pub step: f64,
    pub previous_step: f64,
    /// True at the last iterate allowed: the iteration fails unless it is settled here.
    pub last: bool,
}

/// How the Newton step is made safe far from the solution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Globalization {
    /// Full steps.
    Full,
    /// The largest of `du, du/2, du/4, ...` (down to `min_damping du`) after which `G` can be
    /// evaluated and `|G| <= max_growth |G(u)|`, eq. (1).
    Backtrack { min_damping: f64, max_growth: f64 },
}

/// Where the factorized Jacobian of each iterate comes from.
pub enum Jacobians<'c> {
    /// A fresh Jacobian at every iterate, factorized only where a step is taken from it (not
    /// at an iterate whose residual meets the tolerance).
    Fresh,
    /// As [`Jacobians::Fresh`], and the [`Chord`] is left holding the factorization made at the
    /// solution returned, if one was made there (the iteration ended on [`System::settled`],
    /// which needs the step); empty otherwise. A caller that solves with the same matrix
    /// afterwards (the tangent of the continuation) reuses it.
    FreshKept(&'c mut Chord),
    /// The factorization held by the [`Chord`], kept while the residual falls by at least a
    /// factor 3 per iteration.
    Reuse(&'c mut Chord),
}

/// A factorized Jacobian kept across iterations and across solves, and the count of the
/// factorizations made.
#[derive(Default)]
pub struct Chord {
    lu: Option<Lu<f64>>,
    /// Factorizations made so far.
    pub built: usize,
}

impl Chord {
    /// A chord holding `lu`, the factorization of a Jacobian made elsewhere (e.g. at a nearby
    /// solution), counted as built.
    pub fn holding(lu: Lu<f64>) -> Self {
        Chord {
            lu: Some(lu),
            built: 1,
        }
    }
    /// Drops the factorization (the next iterate builds a fresh one).
    pub fn clear(&mut self) {
        self.lu = None;
    }
    /// Whether a factorization is held.
    pub fn holds(&self) -> bool {
        self.lu.is_some()
    }
    /// The factorization held, if any, taken out of the chord.
    pub fn take(&mut self) -> Option<Lu<f64>> {
        self.lu.take()
    }
}

/// The Newton iteration: tolerance, step limit and globalization.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Newton {
    /// Converged when `size(G) <= tol`.
    pub tol: f64,
    /// Steps allowed.
    pub max_iter: usize,
    /// Steps taken before the iteration may end (by the tolerance or [`System::settled`]): 1
    /// where the starting point is a prediction, whose small residual or small first correction
    /// says less than a Newton step does (next to a fold, a point off the branch by `dp` has a
    /// residual of only `|G_p| dp`; in the stiff directions that a metric does not see, a small
    /// correction hides a residual, and a Jacobian, off by much more), 0 where the start is
    /// already a good iterate.
    pub min_steps: usize,
    pub globalization: Globalization,
}

impl From<&NewtonSettings> for Newton {
    /// The damped iteration of the steady solve, with the user's settings.
    fn from(settings: &NewtonSettings) -> Self {
        Newton {
            tol: settings.tol,
            max_iter: settings.max_iter,
            min_steps: 0,
            globalization: Globalization::Backtrack {
                min_damping: settings.min_damping,
                max_growth: settings.max_growth,
            },
        }
    }
}

/// Settings of the Newton solver.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NewtonSettings {
    /// Converged when the Euclidean norm of the residual falls below this (solver units).
    pub tol: f64,
    /// Iteration limit.
    pub max_iter: usize,
    /// Smallest line-search factor before giving up.
    pub min_damping: f64,
    /// Largest accepted growth of the residual norm in one step, eq. (1).
    pub max_growth: f64,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        NewtonSettings {
            tol: 1e-9,
            max_iter: 40,
            min_damping: 1.0 / 1024.0,
            max_growth: 1e6,
        }
    }
}

impl NewtonSettings {
    /// Checks the ranges: `0 < tol < 1`, `1 <= max_iter <= 10000`, `0 < min_damping <= 1`,
    /// `max_growth >= 1`; an error names the field ([`EngineError::Setting`]).
    pub fn validate(&self) -> Result<()> {
        if !(self.tol > 0.0 && self.tol < 1.0) {
            return Err(Error::setting(
                "tol",
                format!("must lie in (0, 1), got {}", self.tol),
            ));
        }
        if !(1..=10_000).contains(&self.max_iter) {
            return Err(Error::setting(
                "max_iter",
                format!("must lie in 1..=10000, got {}", self.max_iter),
            ));
        }
        if !(self.min_damping > 0.0 && self.min_damping <= 1.0) {
            return Err(Error::setting(
                "min_damping",
                format!("must lie in (0, 1], got {}", self.min_damping),
            ));
        }
        if !(self.max_growth.is_finite() && self.max_growth >= 1.0) {
            return Err(Error::setting(
                "max_growth",
                format!("must be a finite number >= 1, got {}", self.max_growth),
            ));
        }
        Ok(())
    }
}

/// What a converged Newton solve reports (by default: none taken).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct NewtonReport {
    /// Number of Newton steps taken.
    pub iterations: usize,
    /// Final residual norm.
    pub residual_norm: f64,
    /// Residual norm before each step and at the end (length `iterations + 1`).
    pub history: Vec<f64>,
    /// The precision [`System::settled`] gave the solution (0 when the residual met `tol`).
    #[serde(skip)]
    pub precision: f64,
}

/// Euclidean norm.
pub fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `-M^{-1} g` for a factorized `M`, or `None` when the result is not finite (singular `M`).
fn newton_step(lu: &Lu<f64>, g: &[f64]) -> Option<Vec<f64>> {
    let rhs = Mat::from_fn(g.len(), 1, |i, _| -g[i]);
    let x = lu.solve(rhs.as_ref());
    let x: Vec<f64> = (0..g.len()).map(|i| x[(i, 0)]).collect();
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Solves `G(u) = 0` from `u0` by the damped iteration with `settings` and a fresh Jacobian at
/// every iterate (the steady solve); `context` names the problem in error messages.
pub fn solve(
    system: &impl System,
    u0: Vec<f64>,
    settings: &NewtonSettings,
    context: &str,
) -> Result<(Vec<f64>, NewtonReport)> {
    Newton::from(settings).run(system, u0, Jacobians::Fresh, context)
}

impl Newton {
    /// Solves `G(u) = 0` from `u0`; `context` names the problem in error messages
    /// ([`Error::NewtonFailed`]). Errors of the system's evaluation at an iterate are returned as
    /// they are; a trial point of the line search that cannot be evaluated is a shorter step.
    pub fn run(
        &self,
        system: &impl System,
        u0: Vec<f64>,
        jacobians: Jacobians,
        context: &str,
    ) -> Result<(Vec<f64>, NewtonReport)> {
        let mut u = u0;
        let mut history: Vec<f64> = Vec::new();
        let mut previous_step = f64::INFINITY;
        let fail = |reason: String, history: &[f64]| {
            Error::from(EngineError::NewtonFailed {
                context: context.to_string(),
                reason,
                iterations: history.len().saturating_sub(1),
                residual: history.last().copied().unwrap_or(f64::NAN),
            })
        };
        let no_convergence = || {
            format!(
                "no convergence to {:e} within {} iterations",
                self.tol, self.max_iter
            )
        };
        // Newton's method proper holds the factorization of the current iterate in a chord of
        // its own, rebuilt at every iterate.
        let mut own = Chord::default();
        let (chord, reuse) = match jacobians {
            Jacobians::Fresh => (&mut own, false),
            Jacobians::FreshKept(chord) => (chord, false),
            Jacobians::Reuse(chord) => (chord, true),
        };
        // A fresh Jacobian not yet factorized (Newton's method proper factorizes it only when
        // a step is taken from its iterate).
        let mut pending: Option<Mat<f64>> = None;
        // The iterate a stale chord's step started from: where the iteration returns, with a
        // fresh Jacobian, when that step made the residual grow.
        let mut retreat: Option<Vec<f64>> = None;
        loop {
            let last = history.len() == self.max_iter;
            // Whether the chord holds the Jacobian at `u` itself.
            let mut fresh = !reuse;
            let mut g = if reuse {
                system.residual(&u)?
            } else {
                let (g, jac) = system.residual_and_jacobian(&u)?;
                chord.lu = None;
                pending = Some(jac);
                g
            };
            let mut g_norm = system.size(&g);
            if let (Some(&before), Some(start)) = (history.last(), retreat.take())
                && !last
                && (g_norm > before || g_norm.is_nan())
            {
                u = start;
                let (g_start, jac) = system.residual_and_jacobian(&u)?;
                chord.lu = Some(Lu::of(jac));
                chord.built += 1;
                fresh = true;
                g = g_start;
                g_norm = system.size(&g);
            }
            let contracting = history.last().is_none_or(|&before| g_norm <= before / 3.0);
            history.push(g_norm);
            if !g_norm.is_finite() {
                return Err(fail("the residual is not finite".into(), &history));
            }
            let report = |history: Vec<f64>, precision: f64| NewtonReport {
                iterations: history.len() - 1,
                residual_norm: g_norm,
                history,
                precision,
            };
            let stepped = history.len() > self.min_steps;
            if g_norm <= self.tol && stepped {
                return Ok((u, report(history, 0.0)));
            }
            if reuse && !fresh && (!chord.holds() || !contracting) {
                // A stale chord at the last iterate: no new factorization is worth making.
                if last {
                    return Err(fail(no_convergence(), &history));
                }
                let (_, jac) = system.residual_and_jacobian(&u)?;
                chord.lu = Some(Lu::of(jac));
                chord.built += 1;
                fresh = true;
            }
            if reuse && !fresh {
                retreat = Some(u.clone());
            }
            if let Some(jac) = pending.take() {
                chord.lu = Some(Lu::of(jac));
                chord.built += 1;
            }
            let lu = chord.lu.as_ref().expect("a factorization is held here");
            let Some(du) = newton_step(lu, &g) else {
                // A start that meets the tolerance at a singular point (a branch point) has no
                // step to take: it is the solution.
                if g_norm <= self.tol {
                    return Ok((u, report(history, 0.0)));
                }
                return Err(fail("singular Jacobian".into(), &history));
            };
            let step = norm(&du);
            let iterate = Iterate {
                u: &u,
                du: &du,
                residual: g_norm,
                step,
                previous_step,
                last,
            };
            if stepped && let Some(precision) = system.settled(&iterate) {
                return Ok((u, report(history, precision)));
            }
            if last {
                return Err(fail(no_convergence(), &history));
            }
            previous_step = step;
            u = match self.globalization {
                Globalization::Full => system.retract(&u, &du),
                Globalization::Backtrack {
                    min_damping,
                    max_growth,
                } => backtrack(system, &u, &du, g_norm, min_damping, max_growth).map_err(
                    |refused| {
                        refused.unwrap_or_else(|| {
                            fail(
                                format!(
                                    "the line search found no admissible point down to damping \
                                     {min_damping}"
                                ),
                                &history,
                            )
                        })
                    },
                )?,
            };
        }
    }
}

/// The damped step of eq. (1) from `u` along `du`: the first trial point `retract(u, a du)`,
/// `a = 1, 1/2, ...`, where `G` can be evaluated and `size(G) <= max_growth g_norm`. On failure,
/// `Err(Some(e))` when the last trial point could not be evaluated because the problem has no
/// admissible state there ([`Error::is_refused_state`]: that is the reason, not the line
/// search), else `Err(None)`.
fn backtrack(
    system: &impl System,
    u: &[f64],
    du: &[f64],
    g_norm: f64,
    min_damping: f64,
    max_growth: f64,
) -> std::result::Result<Vec<f64>, Option<Error>> {
    let mut damping = 1.0;
    // Why the last trial point could not be evaluated, if it could not.
    let mut refused = None;
    while damping >= min_damping {
        let step: Vec<f64> = du.iter().map(|d| damping * d).collect();
        let trial = system.retract(u, &step);
        match system.residual(&trial) {
            Ok(gt) if system.size(&gt) <= max_growth * g_norm => return Ok(trial),
            Ok(_) => {}
            Err(e) => refused = Some(e),
        }
        damping *= 0.5;
    }
    Err(refused.filter(Error::is_refused_state))
}

//! Two-parameter continuation of a Hopf point: the stability boundary `p_H(q)` as a curve.
//!
//! A [`Family`] gives, for every value of a second parameter `q`, a one-parameter [`Problem`]
//! in `p`. A Hopf point of the member `q` is a zero of the test function
//!
//! ```text
//! h(p, q) = Re s(p, q),                                                       (1)
//! ```
//!
//! `s` the tracked complex eigenvalue of the stability pencil `K v = s M v` at the solution
//! `u(p, q)` of `G(u, p; q) = 0`. This is the minimally augmented Hopf system (docs/model.md
//! section 11) with the state and the eigenvector eliminated: the state by Newton's method at
//! fixed `(p, q)`, the eigenvalue by the eigensolver of the one-parameter engine (with its
//! certified unstable count). What remains is one scalar equation in the plane `(p, q)`, whose
//! zero set is the curve. It is followed by pseudo-arclength continuation in the plane, in the
//! local coordinates
//!
//! ```text
//! dz = (dp / |p_k|, dq / Q)                                                   (2)
//! ```
//!
//! (`Q` the width of the range of `q` followed, `p_k` the parameter of the last point, at least
//! the member's parameter scale [`Problem::scales`], so that a step is a fraction of `p`
//! however far `p` moves along the curve, and `p` may pass zero). From the last point `z_k`
//! with unit tangent `t_k` (the chord from the point before it; at the start, orthogonal to
//! the gradient of `h` in the units of (2), `t_0 = +-(-h_q, h_p) / |grad h|`, by differences),
//! the predictor is
//! `z_k + ds t_k`, and the corrector solves `h = 0` on the line through the predicted point
//! normal to `t_k`, by the secant method whose first slope is the last corrector's. A point is
//! accepted when the next secant correction would move `p` by less than `event_tol |p|` (`|p|`
//! at least the member's parameter scale) and `q` by less than `event_tol Q`. Turning points of the curve in `q` (where the crossing speed
//! `dh/dp` vanishes) are passed as folds are in one-parameter continuation. The last step lands
//! exactly on the end of the range (corrector at fixed `q`); where it fails (the curve turns
//! back just short of the end, and no point lies there), the step is taken along the tangent
//! instead, at the same length.
//!
//! The state at a predicted point starts from the last point's, carried to the new member
//! ([`Family::carry`]: a rod moves its free nodes with its natural shape) plus the change it
//! had over the last step, scaled to the new one. There is no second derivative of `G`: the
//! price of a point is a few Newton solves from a close guess and as many spectra.
//!
//! Along the curve the rest of the spectrum (the tracked pair removed) is watched. A change of
//! its unstable count is a codimension-two point, pinned down on the curve by Brent's
//! method on the real part of the eigenvalue that crossed (each sample a point of the
//! curve): a **double Hopf** point when that eigenvalue is complex (a second oscillatory mode
//! reaches the axis), a **zero-Hopf** (fold-Hopf) point when it is real. A change of the way
//! `q` moves along the curve is a **turning point** of the curve: a sign change of the `q` part
//! of the chord, or, where a step passes the turning point and comes back short of the last
//! point's `q`, a vertex of the parabola `q(p)` through the step's ends inside the step, kept
//! where the turning point located lies inside it too. It is the extremum of `q(p)` found by
//! successive parabolic interpolation (each sample a point of the curve at fixed `p`). Where the
//! tracked pair meets on the real axis the Hopf curve ends at a **Bogdanov-Takens** point: the
//! zero of `w2 = det - tr^2 / 4` of the critical pair's block (`w^2` on the Hopf curve) along
//! the curve `tr = 0`, which goes on through it as a curve of neutral saddles (Brent's method,
//! bracketed by the curve's point past it, each sample a point of that curve; its own state,
//! no Lyapunov coefficient).
//! With [`CurveSettings::criticality`], every point carries its first Lyapunov coefficient
//! ([`super::criticality`]), and where its resolved verdicts change (`supercritical` to
//! `subcritical` or back, with or without `undetermined` points between them) the curve passes
//! a **generalized Hopf** (Bautin) point, the zero of `l1` along the curve in the step where
//! its value changed sign (Brent's method, each sample a point of the curve with its
//! coefficient), where the Hopf bifurcation turns from super- to subcritical.
//!
//! The code: `tracked.rs` holds the tracked eigenvalue and the rest of the spectrum,
//! `corrector.rs` the solved states and the secant corrector, `special.rs` the special points
//! and how each is pinned down, `trace.rs` the curve followed step by step ([`follow_curve`]).

mod corrector;
mod special;
mod trace;
mod tracked;

use faer::c64;

pub use special::{Special, SpecialKind};
pub use trace::follow_curve;
pub use tracked::others;

use super::Problem;
use super::criticality::Lyapunov;
use super::events::Event;
use super::stability::Spectrum;
use super::stop::Stop;
use crate::{Error, Result};

/// A family of one-parameter problems indexed by a second parameter `q`.
pub trait Family {
    type Member: Problem;
    /// The problem at `q`.
    fn member(&self, q: f64) -> Result<Self::Member>;
    /// A first guess for a solution of `to` from the solution `u` of `from` (by default the same
    /// unknowns).
    fn carry(&self, u: &[f64], _from: &Self::Member, _to: &Self::Member) -> Vec<f64> {
        u.to_vec()
    }
    /// Prepares the fresh member `to` to be solved from `guess`, carried from `from` (a rod takes
    /// the chart of its twist angles from `from`'s). Nothing by default.
    fn adopt(&self, _from: &Self::Member, _to: &Self::Member, _guess: &[f64]) {}
}

/// The range of `q` and the steps of a curve, in the units of (2).
#[derive(Clone, Debug, PartialEq)]
pub struct CurveSettings {
    pub q_min: f64,
    pub q_max: f64,
    /// First, smallest and largest step.
    pub ds: f64,
    pub ds_min: f64,
    pub ds_max: f64,
    /// Largest number of points.
    pub max_points: usize,
    /// Steady solves allowed to one corrector before the step is halved.
    pub max_evaluations: usize,
    /// Whether every point carries its first Lyapunov coefficient (and generalized Hopf points
    /// are located): for problems that define their dynamics ([`Problem::dynamics`]).
    pub criticality: bool,
}

impl CurveSettings {
    /// A curve over `[q_min, q_max]`: steps from a fiftieth to a twentieth of the range (or of
    /// `p`), at most 1000 points.
    pub fn new(q_min: f64, q_max: f64) -> Self {
        CurveSettings {
            q_min,
            q_max,
            ds: 0.02,
            ds_min: 1e-6,
            ds_max: 0.05,
            max_points: 1000,
            max_evaluations: 12,
            criticality: false,
        }
    }

    /// Checks the ranges; an error names the settings `curve`.
    pub(super) fn validate(&self) -> Result<()> {
        let ok = self.q_min.is_finite()
            && self.q_max.is_finite()
            && self.q_min < self.q_max
            && self.ds_min > 0.0
            && self.ds_min <= self.ds
            && self.ds <= self.ds_max
            && self.max_points >= 1
            && self.max_evaluations >= 2;
        if ok {
            Ok(())
        } else {
            Err(Error::setting(
                "curve",
                format!(
                    "need q_min < q_max, 0 < ds_min <= ds <= ds_max, max_points >= 1 and \
                     max_evaluations >= 2, got {self:?}"
                ),
            ))
        }
    }
}

/// A point of the curve: a Hopf point of the member `q` at `p`.
#[derive(Clone, Debug)]
pub struct CurvePoint {
    pub p: f64,
    pub q: f64,
    /// Arclength from the start, in the units of (2).
    pub s: f64,
    /// The solution there.
    pub u: Vec<f64>,
    /// The tracked eigenvalue (real part near zero, imaginary part the frequency, positive).
    pub eigenvalue: c64,
    /// The leading spectrum there.
    pub spectrum: Spectrum,
    /// The last secant correction not applied, relative (`|dp|/|p|` or `|dq|/Q`, the larger).
    pub precision: f64,
    /// Steady solves the point took.
    pub evaluations: usize,
    /// The first Lyapunov coefficient there (with [`CurveSettings::criticality`]; `None` where
    /// it could not be computed).
    pub lyapunov: Option<Lyapunov>,
}

impl CurvePoint {
    /// The start of a curve at a Hopf point located on a branch of the member `q`.
    pub fn at_event(event: Event, q: f64) -> Self {
        CurvePoint {
            p: event.p,
            q,
            s: 0.0,
            u: event.u,
            eigenvalue: event.eigenvalue,
            spectrum: event.spectrum,
            precision: event.precision,
            evaluations: 0,
            lyapunov: None,
        }
    }
}

/// A curve's own reasons to end ([`Stop::Own`]).
#[derive(Clone, Debug, PartialEq)]
pub enum CurveEnd {
    /// The family has no member within the smallest step past the last point (why, in the
    /// member's words: [`crate::error::EngineError::NoMember`]).
    NoMember(String),
    /// The Hopf curve ends at a Bogdanov-Takens point (its last point and special point).
    BogdanovTakens,
}

/// A followed curve.
#[derive(Clone, Debug)]
pub struct Curve {
    pub points: Vec<CurvePoint>,
    pub special: Vec<Special>,
    pub stop: Stop<CurveEnd>,
}

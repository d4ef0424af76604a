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
//! with unit tangent `t_k` (the chord from the point before it), the predictor is
//! `z_k + ds t_k`, and the corrector solves `h = 0` on the line through the predicted point
//! normal to `t_k`, by the secant method whose first slope is the last corrector's. A point is
//! accepted when the next secant correction would move `p` by less than `event_tol |p|` (`|p|`
//! at least the member's parameter scale) and `q` by less than `event_tol Q`. Turning points of the curve in `q` (where the crossing speed
//! `dh/dp` vanishes) are passed as folds are in one-parameter continuation. The last step lands
//! exactly on the end of the range (corrector at fixed `q`).
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
//! reaches the axis), a **zero-Hopf** (fold-Hopf) point when it is real. A sign change of the
//! `q` part of the tangent is a **turning point** of the curve, the extremum of `q(p)` found by
//! successive parabolic interpolation (each sample a point of the curve at fixed `p`). Where the
//! tracked pair meets on the real axis the Hopf curve ends at a **Bogdanov-Takens** point, the
//! zero of `w^2` along the curve (secant, bracketed by the first sample whose pair is real).
//! With [`CurveSettings::criticality`], every point carries its first Lyapunov coefficient
//! ([`super::criticality`]), and where it changes sign (both signs resolved) the curve passes a
//! **generalized Hopf** (Bautin) point, the zero of `l1` along the curve (Brent's method, each sample a
//! point of the curve with its coefficient), where the Hopf bifurcation turns from super- to
//! subcritical.

use std::rc::Rc;

use faer::c64;

use super::arclength::{AtParameter, stability};
use super::criticality::{Lyapunov, Verdict, first_lyapunov};
use super::events::{Event, Zeroin};
use super::newton::{self, NewtonSettings};
use super::stability::{Spectrum, is_complex};
use super::step::StepControl;
use super::{ContinuationSettings, Problem};
use crate::{Error, Result};

/// How far from the predicted point, in steps, the corrector may go (the first step, taken
/// along `q` before the curve's slope is known, needs it where the curve is steep).
const REACH: f64 = 4.0;

/// The start of the message of a failure to build a member: where the family ends, the curve
/// comes to within the smallest step of that end and stops there.
const NO_MEMBER: &str = "no member of the family there: ";

/// The start of the message of an evaluation whose tracked pair has met on the real axis.
const BECAME_REAL: &str = "the tracked pair has become real: ";

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

    fn validate(&self) -> Result<()> {
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
            Err(Error::input(
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

/// What a special point of the curve is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpecialKind {
    /// A second complex pair on the imaginary axis.
    DoubleHopf,
    /// A real eigenvalue at zero (fold-Hopf).
    ZeroHopf,
    /// The curve turns back in `q`.
    Turning,
    /// The tracked pair meets on the real axis at zero: the Hopf curve ends.
    BogdanovTakens,
    /// The first Lyapunov coefficient changes sign (Bautin point).
    GeneralizedHopf,
}

impl SpecialKind {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        match self {
            SpecialKind::DoubleHopf => "double_hopf",
            SpecialKind::ZeroHopf => "zero_hopf",
            SpecialKind::Turning => "turning",
            SpecialKind::BogdanovTakens => "bogdanov_takens",
            SpecialKind::GeneralizedHopf => "generalized_hopf",
        }
    }
}

/// A located special point.
#[derive(Clone, Debug)]
pub struct Special {
    pub kind: SpecialKind,
    /// The point of the curve where it lies.
    pub point: CurvePoint,
    /// The other eigenvalue on the axis (double Hopf, zero-Hopf); the tracked one at a turning
    /// point.
    pub other: c64,
    /// True when the other mode is unstable beyond the point in the direction of travel: the
    /// curve is no longer the first loss of stability there.
    pub gains: bool,
    /// Width of the final bracket along the curve (units of (2)); for a turning point, that of
    /// `p` (its `q`, stationary there, is known to about `event_tol`).
    pub precision: f64,
}

/// Why a curve ended.
#[derive(Clone, Debug, PartialEq)]
pub enum CurveStop {
    /// It reached an end of the range of `q`.
    Range,
    MaxPoints,
    /// The step fell below `ds_min`; the reason of the last failure.
    StepTooSmall(String),
    /// The observer ended it at a special point (the curve's last point).
    Observer,
    /// The family has no member within the smallest step past the last point (why, in the
    /// member's words).
    NoMember(String),
    /// The Hopf curve ends at a Bogdanov-Takens point (its last point and special point).
    Ended,
}

/// A followed curve.
#[derive(Clone, Debug)]
pub struct Curve {
    pub points: Vec<CurvePoint>,
    pub special: Vec<Special>,
    pub stop: CurveStop,
}

/// Sees the points and special points of a curve as they come.
pub trait CurveObserver {
    fn point(&mut self, _point: &CurvePoint) {}
    /// A special point; `true` ends the curve there.
    fn special(&mut self, _special: &Special) -> bool {
        false
    }
}

/// Follows every curve to the end of its range.
pub struct Through;
impl CurveObserver for Through {}

/// The eigenvalue of `spectrum` nearest `track`, with its imaginary part made positive; an error
/// when a complex `track` finds only a real one (the pair has met on the real axis).
fn tracked(spectrum: &Spectrum, track: c64) -> Result<c64> {
    let s = spectrum.nearest(track);
    if is_complex(track) && !is_complex(s) {
        return Err(Error::Numerical(format!(
            "{BECAME_REAL}{track} (a Bogdanov-Takens point is near)"
        )));
    }
    Ok(c64::new(s.re, s.im.abs()))
}

/// The spectrum without the tracked eigenvalue (and its conjugate), with its unstable count.
pub fn others(spectrum: &Spectrum, track: c64) -> Spectrum {
    let mut rest = spectrum.leading.clone();
    let mut remove = |target: c64| {
        if let Some(i) = (0..rest.len()).min_by(|&a, &b| {
            (rest[a] - target)
                .norm()
                .total_cmp(&(rest[b] - target).norm())
        }) {
            rest.remove(i);
        }
    };
    remove(track);
    if is_complex(track) {
        remove(track.conj());
    }
    let unstable = rest.iter().filter(|s| s.re > 0.0).count();
    Spectrum {
        leading: rest,
        unstable,
    }
}

/// A solved state of a member: the member, the parameters, the solution and its spectrum.
struct At<M> {
    member: Rc<M>,
    p: f64,
    q: f64,
    u: Vec<f64>,
    spectrum: Spectrum,
    eigenvalue: c64,
    /// Computed for accepted points and the samples that need it.
    lyapunov: Option<Lyapunov>,
}

// By hand: the member is shared, so `M` need not be `Clone`.
impl<M> Clone for At<M> {
    fn clone(&self) -> Self {
        At {
            member: self.member.clone(),
            p: self.p,
            q: self.q,
            u: self.u.clone(),
            spectrum: self.spectrum.clone(),
            eigenvalue: self.eigenvalue,
            lyapunov: self.lyapunov.clone(),
        }
    }
}

impl<M> At<M> {
    fn point(&self, s: f64, precision: f64, evaluations: usize) -> CurvePoint {
        CurvePoint {
            p: self.p,
            q: self.q,
            s,
            u: self.u.clone(),
            eigenvalue: self.eigenvalue,
            spectrum: self.spectrum.clone(),
            precision,
            evaluations,
            lyapunov: self.lyapunov.clone(),
        }
    }
}

/// One step of the curve: from `z_k`, predictor `z_k + sigma t` and correction along `n`.
#[derive(Clone, Copy)]
struct Step {
    /// The last point `(p, q)` and the scale of `p` in (2).
    p0: f64,
    q0: f64,
    p_unit: f64,
    t: (f64, f64),
    n: (f64, f64),
}

impl Step {
    fn at(&self, sigma: f64, offset: f64, q_unit: f64) -> (f64, f64) {
        (
            self.p0 + (sigma * self.t.0 + offset * self.n.0) * self.p_unit,
            self.q0 + (sigma * self.t.1 + offset * self.n.1) * q_unit,
        )
    }
}

/// A corrected point with its cost.
struct Corrected<M> {
    at: At<M>,
    evaluations: usize,
    /// `dh/d offset` of the last secant.
    slope: f64,
    precision: f64,
}

struct Tracer<'a, F: Family> {
    family: &'a F,
    settings: &'a CurveSettings,
    continuation: &'a ContinuationSettings,
    newton: NewtonSettings,
    /// `Q` of (2).
    q_unit: f64,
}

impl<F: Family> Tracer<'_, F> {
    /// The solution at `(p, q)` from the state `from` (plus `shift`), its spectrum and the
    /// eigenvalue nearest `track`.
    fn evaluate(
        &self,
        from: &At<F::Member>,
        (p, q): (f64, f64),
        shift: Option<&[f64]>,
        track: c64,
    ) -> Result<At<F::Member>> {
        let member = Rc::new(
            self.family
                .member(q)
                .map_err(|e| Error::Numerical(format!("{NO_MEMBER}{e}")))?,
        );
        let mut guess = self.family.carry(&from.u, &from.member, &member);
        if let Some(shift) = shift {
            guess.iter_mut().zip(shift).for_each(|(g, d)| *g += d);
        }
        self.family.adopt(&from.member, &member, &guess);
        let system = AtParameter::new(&*member, p);
        let context = format!("on the curve at p = {p:e}, q = {q:e}");
        let (u, _) = newton::solve(&system, guess, &self.newton, &context)?;
        // The chart is moved to the state (the same state, new coordinates; every member is
        // this evaluation's own). The linearization in the old coordinates still gives the
        // stability pair: `K`, the Jacobian of the position rows with the angles slaved, does
        // not depend on how the angles are measured, nor `M` on them at all.
        let lin = system.linearization_at(&u)?;
        member.rechart(&u, &[]);
        let spectrum = stability(
            &*member,
            &u,
            p,
            &lin,
            self.continuation,
            Some(&from.spectrum),
        )?;
        let eigenvalue = tracked(&spectrum, track)?;
        Ok(At {
            member,
            p,
            q,
            u,
            spectrum,
            eigenvalue,
            lyapunov: None,
        })
    }

    /// `at` with its first Lyapunov coefficient, if the settings ask for it. A coefficient
    /// that cannot be computed (its differences leave the problem's admissible states, e.g. a
    /// mobility that is no longer positive) is left out: the point stays a point of the curve.
    fn with_lyapunov(&self, mut at: At<F::Member>) -> At<F::Member> {
        if at.lyapunov.is_none() {
            at.lyapunov = self.lyapunov(&at.member, &at.u, at.p, at.eigenvalue);
        }
        at
    }

    /// The first Lyapunov coefficient of the solution `(u, p)` of `member` with its critical
    /// eigenvalue `s`, if the settings ask for it and it can be computed.
    fn lyapunov(&self, member: &F::Member, u: &[f64], p: f64, s: c64) -> Option<Lyapunov> {
        if !self.settings.criticality {
            return None;
        }
        member
            .linearize(u, p)
            .and_then(|lin| first_lyapunov(member, u, p, &lin, s))
            .ok()
            .flatten()
    }

    /// A special point with the coefficient of its point (special points are located from
    /// samples that do not carry one).
    fn with_criticality(&self, mut special: Special, member: &F::Member) -> Special {
        let point = &special.point;
        if point.lyapunov.is_none() && is_complex(point.eigenvalue) {
            special.point.lyapunov = self.lyapunov(member, &point.u, point.p, point.eigenvalue);
        }
        special
    }

    /// Solves `h = 0` on the line `step.at(sigma, offset)`, offset from 0, by the secant method
    /// (first slope `slope` if known), following the eigenvalue nearest `track` at first;
    /// refuses a point farther than `reach` from the line's origin.
    #[allow(clippy::too_many_arguments)]
    fn correct(
        &self,
        from: &At<F::Member>,
        step: &Step,
        sigma: f64,
        shift: Option<&[f64]>,
        slope: Option<f64>,
        track: c64,
        reach: f64,
    ) -> Result<Corrected<F::Member>> {
        let tol = self.continuation.event_tol;
        // The size of a move `dt` along the line in the acceptance test's units: relative to
        // |p| (or to the member's parameter scale where p is near zero) and to Q.
        let size = |dt: f64, at: &At<F::Member>| {
            let p_scale = at.p.abs().max(at.member.scales().1);
            (dt * step.n.0.abs() * step.p_unit / p_scale).max(dt * step.n.1.abs())
        };
        let mut a = self.evaluate(from, step.at(sigma, 0.0, self.q_unit), shift, track)?;
        let (mut t0, mut h0) = (0.0, a.eigenvalue.re);
        let mut g = slope.filter(|g| g.is_finite() && *g != 0.0);
        let mut t1 = g.map_or(1e-3 * reach, |g| -h0 / g);
        for evaluations in 1..=self.settings.max_evaluations {
            // A proposed move below the tolerance: the last point is the answer.
            if let Some(g) = g
                && size((t1 - t0).abs(), &a) <= tol
            {
                return Ok(Corrected {
                    precision: size((t1 - t0).abs(), &a),
                    at: a,
                    evaluations,
                    slope: g,
                });
            }
            if !(t1.is_finite() && t1.abs() <= reach)
                || evaluations == self.settings.max_evaluations
            {
                break;
            }
            let b = self.evaluate(&a, step.at(sigma, t1, self.q_unit), None, a.eigenvalue)?;
            let h1 = b.eigenvalue.re;
            let secant = (h1 - h0) / (t1 - t0);
            if h1 == 0.0 {
                return Ok(Corrected {
                    at: b,
                    evaluations: evaluations + 1,
                    slope: secant,
                    precision: 0.0,
                });
            }
            g = Some(secant);
            (t0, h0, a) = (t1, h1, b);
            t1 = t0 - h0 / secant;
        }
        Err(Error::Numerical(format!(
            "the Hopf test function has no zero within reach of the corrector ({} solves, \
             offset {t1:e})",
            self.settings.max_evaluations
        )))
    }
}

/// Follows the Hopf curve through `start` (a Hopf point of `member`, the member at `start.q`,
/// in whose coordinates `start.u` is), first in the direction of increasing `q` if
/// `direction > 0`, until it leaves `[q_min, q_max]`. Returns the curve and the member of its
/// last point (a curve that goes on from there starts with it).
pub fn follow_curve<F: Family>(
    family: &F,
    start: CurvePoint,
    member: Rc<F::Member>,
    direction: f64,
    settings: &CurveSettings,
    continuation: &ContinuationSettings,
    observer: &mut impl CurveObserver,
) -> Result<(Curve, Rc<F::Member>)> {
    settings.validate()?;
    continuation.validate()?;
    if !is_complex(start.eigenvalue) {
        return Err(Error::input(
            "curve start",
            format!(
                "a Hopf curve starts from a complex pair, got {}",
                start.eigenvalue
            ),
        ));
    }
    let tracer = Tracer {
        family,
        settings,
        continuation,
        newton: NewtonSettings {
            tol: continuation.tol,
            ..NewtonSettings::default()
        },
        q_unit: settings.q_max - settings.q_min,
    };
    let last = At {
        member,
        p: start.p,
        q: start.q,
        u: start.u.clone(),
        spectrum: start.spectrum.clone(),
        eigenvalue: start.eigenvalue,
        lyapunov: start.lyapunov.clone(),
    };
    let mut last = tracer.with_lyapunov(last);
    let start = CurvePoint {
        lyapunov: last.lyapunov.clone(),
        ..start
    };
    observer.point(&start);
    let mut curve = Curve {
        points: vec![start],
        special: Vec::new(),
        stop: CurveStop::MaxPoints,
    };
    let mut t = (0.0, direction.signum());
    let mut slope: Option<f64> = None;
    // The change of the state over the last step not explained by carrying it, per unit step.
    let mut drift: Option<Vec<f64>> = None;
    // The rate of change of the tracked eigenvalue along the curve over the last step.
    let mut rate: Option<c64> = None;
    let mut step_control = StepControl::new(settings.ds, settings.ds_min, settings.ds_max);
    while curve.points.len() < settings.max_points {
        let p_unit = last.p.abs().max(last.member.scales().1);
        let q_end = if t.1 > 0.0 {
            settings.q_max
        } else {
            settings.q_min
        };
        let to_end = (q_end - last.q) / (t.1 * tracer.q_unit);
        // The last step lands on the end of the range, corrected at fixed q.
        let ds = step_control.ds();
        let ending = t.1 != 0.0 && to_end > 0.0 && to_end <= ds;
        let step = Step {
            p0: last.p,
            q0: last.q,
            p_unit,
            t,
            n: if ending { (1.0, 0.0) } else { (-t.1, t.0) },
        };
        let sigma = if ending { to_end } else { ds };
        let shift: Option<Vec<f64>> = drift
            .as_ref()
            .map(|d| d.iter().map(|v| v * sigma).collect());
        // The tracked eigenvalue moves with the curve (on a rod, with the rate): predicted
        // along its rate of change over the last step.
        let predicted = last.eigenvalue + rate.unwrap_or_default() * sigma;
        let attempt = tracer
            .correct(
                &last,
                &step,
                sigma,
                shift.as_deref(),
                slope,
                predicted,
                REACH * sigma,
            )
            .and_then(|c| accept(&last, predicted, c, &step, tracer.q_unit));
        let corrected = match attempt {
            Ok(c) => c,
            Err(e) => {
                let reason = e.to_string();
                // The pair turned real within the step: the curve ends at a Bogdanov-Takens
                // point there, if one can be pinned down (else the step is only too long).
                if reason.contains(BECAME_REAL)
                    && let Some(previous) = curve.points.iter().rev().nth(1)
                    && let Ok((special, member)) = locate_bogdanov_takens(
                        &tracer,
                        previous,
                        &last,
                        &step,
                        curve.points.last().map_or(0.0, |p| p.s),
                    )
                {
                    observer.special(&special);
                    curve.special.push(special.clone());
                    observer.point(&special.point);
                    curve.points.push(special.point);
                    curve.stop = CurveStop::Ended;
                    return Ok((curve, member));
                }
                // A shorter step, also where the family ends (to come as near that end as the
                // smallest step allows).
                if step_control.failed().is_err() {
                    curve.stop = match reason.find(NO_MEMBER) {
                        Some(i) => CurveStop::NoMember(reason[i + NO_MEMBER.len()..].to_string()),
                        None => CurveStop::StepTooSmall(reason),
                    };
                    return Ok((curve, last.member));
                }
                continue;
            }
        };
        let new = tracer.with_lyapunov(corrected.at);
        let chord = ((new.p - last.p) / p_unit, (new.q - last.q) / tracer.q_unit);
        let length = chord.0.hypot(chord.1);
        let t_new = (chord.0 / length, chord.1 / length);
        let s_last = curve.points.last().map_or(0.0, |p| p.s);
        // Codimension-two points inside the step, then a turning point at its end.
        let before = others(&last.spectrum, last.eigenvalue);
        let after = others(&new.spectrum, new.eigenvalue);
        let located = (|| -> Result<Vec<(Special, Rc<F::Member>)>> {
            let mut found = Vec::new();
            if before.unstable != after.unstable {
                found.push(locate_codim2(
                    &tracer, &last, &new, &step, sigma, &before, &after, s_last,
                )?);
            }
            if let (Some(a), Some(b)) = (&last.lyapunov, &new.lyapunov)
                && resolved_signs_differ(a, b)
            {
                found.push(locate_generalized_hopf(
                    &tracer, &last, &new, &step, sigma, s_last,
                )?);
            }
            if t.1 * t_new.1 < 0.0
                && let Some(previous) = curve.points.iter().rev().nth(1)
            {
                found.push(locate_turning(
                    &tracer, previous, &last, &new, p_unit, s_last,
                )?);
            }
            Ok(found)
        })();
        // A special point that cannot be pinned down is retried from a shorter step.
        let specials = match located {
            Ok(found) => found,
            Err(e) => {
                if step_control.failed().is_err() {
                    curve.stop = CurveStop::StepTooSmall(format!("locating a special point: {e}"));
                    return Ok((curve, last.member));
                }
                continue;
            }
        };
        for (special, member) in specials {
            let special = tracer.with_criticality(special, &member);
            let stop = observer.special(&special);
            curve.special.push(special.clone());
            if stop {
                observer.point(&special.point);
                curve.points.push(special.point);
                curve.stop = CurveStop::Observer;
                return Ok((curve, member));
            }
        }
        let point = new.point(s_last + length, corrected.precision, corrected.evaluations);
        observer.point(&point);
        curve.points.push(point);
        let carried = family.carry(&last.u, &last.member, &new.member);
        drift = Some(
            new.u
                .iter()
                .zip(&carried)
                .map(|(a, b)| (a - b) / sigma)
                .collect(),
        );
        slope = Some(corrected.slope);
        rate = Some((new.eigenvalue - last.eigenvalue) / length);
        t = t_new;
        step_control.adapt(corrected.evaluations);
        last = new;
        if ending {
            curve.stop = CurveStop::Range;
            return Ok((curve, last.member));
        }
    }
    Ok((curve, last.member))
}

/// Accepts a corrected point unless its tracked eigenvalue jumped (lies farther from its
/// prediction than half the distance from the last point's to its nearest other eigenvalue)
/// or it lies behind the last point along the tangent.
fn accept<M>(
    last: &At<M>,
    predicted: c64,
    c: Corrected<M>,
    step: &Step,
    q_unit: f64,
) -> Result<Corrected<M>> {
    let gap = others(&last.spectrum, last.eigenvalue)
        .leading
        .iter()
        .map(|s| (s - last.eigenvalue).norm())
        .fold(f64::INFINITY, f64::min);
    let moved = (c.at.eigenvalue - predicted).norm();
    let along = (c.at.p - last.p) / step.p_unit * step.t.0 + (c.at.q - last.q) / q_unit * step.t.1;
    if moved > 0.5 * gap || along <= 0.0 {
        return Err(Error::Numerical(format!(
            "step rejected: the tracked eigenvalue is {moved:.3e} from its prediction (gap to \
             the next {gap:.3e}), progress along the tangent {along:.3e}"
        )));
    }
    Ok(c)
}

/// One sample of the search for a codimension-two point: the curve point at `sigma`.
struct Sample<M> {
    sigma: f64,
    at: At<M>,
    rest: Spectrum,
    precision: f64,
    evaluations: usize,
}

/// Pins down where the unstable count of the rest of the spectrum changes between `last`
/// (`sigma = 0`) and `new` (`sigma = sigma_new`) by Brent's method on the
/// real part of the eigenvalue that crossed (identified afresh in each bracket), each sample a
/// corrected point of the curve.
#[allow(clippy::too_many_arguments)]
fn locate_codim2<F: Family>(
    tracer: &Tracer<'_, F>,
    last: &At<F::Member>,
    new: &At<F::Member>,
    step: &Step,
    sigma_new: f64,
    before: &Spectrum,
    after: &Spectrum,
    s_last: f64,
) -> Result<(Special, Rc<F::Member>)> {
    let mut lo = Sample {
        sigma: 0.0,
        at: last.clone(),
        rest: before.clone(),
        precision: 0.0,
        evaluations: 0,
    };
    let mut hi = Sample {
        sigma: sigma_new,
        at: new.clone(),
        rest: after.clone(),
        precision: 0.0,
        evaluations: 0,
    };
    let base = before.unstable;
    let growing = after.unstable > base;
    let crossing = |l: &Spectrum, h: &Spectrum| super::events::crossing_eigenvalue(l, h);
    let f = |s: &Sample<F::Member>, c: c64| {
        let re = s.rest.nearest(c).re;
        if growing { re } else { -re }
    };
    let tol = tracer.continuation.event_tol;
    let ends = |lo: &Sample<F::Member>, hi: &Sample<F::Member>| {
        let c = crossing(&lo.rest, &hi.rest);
        ((lo.sigma, f(lo, c)), (hi.sigma, f(hi, c)))
    };
    let (near, far) = ends(&lo, &hi);
    let mut zeroin = Zeroin::new(near, far);
    let mut samples = 0;
    while hi.sigma - lo.sigma > tol {
        samples += 1;
        if samples > 100 {
            return Err(Error::Numerical(
                "a codimension-two point not resolved within 100 samples".into(),
            ));
        }
        // The crossing eigenvalue is identified afresh in each bracket; where that changes the
        // values at the ends, the search restarts from them.
        let (near, far) = ends(&lo, &hi);
        if !zeroin.holds(near, far) {
            zeroin = Zeroin::new(near, far);
        }
        let sigma = zeroin.propose(tol / 3.0);
        let corrected = corrected_between(
            tracer,
            (lo.sigma, &lo.at),
            (hi.sigma, &hi.at),
            sigma,
            step,
            sigma_new,
        )?;
        let rest = others(&corrected.at.spectrum, corrected.at.eigenvalue);
        let sample = Sample {
            sigma,
            at: corrected.at,
            rest,
            precision: corrected.precision,
            evaluations: corrected.evaluations,
        };
        let beyond = sample.rest.unstable != base;
        zeroin.record(sigma, f(&sample, crossing(&lo.rest, &hi.rest)), beyond);
        if beyond {
            hi = sample;
        } else {
            lo = sample;
        }
    }
    let c = crossing(&lo.rest, &hi.rest);
    let best = if f(&lo, c).abs() <= f(&hi, c).abs() {
        lo
    } else {
        hi
    };
    let other = best.rest.nearest(c);
    let kind = if is_complex(other) {
        SpecialKind::DoubleHopf
    } else {
        SpecialKind::ZeroHopf
    };
    let special = Special {
        kind,
        point: best
            .at
            .point(s_last + best.sigma, best.precision, best.evaluations),
        other: c64::new(other.re, other.im.abs()),
        gains: growing,
        precision: tol,
    };
    Ok((special, best.at.member))
}

/// The curve's point at `sigma` inside the bracket `[lo, hi]` along `step`, corrected from the
/// nearer end, the tracked eigenvalue interpolated between the ends.
fn corrected_between<F: Family>(
    tracer: &Tracer<'_, F>,
    (s_lo, lo): (f64, &At<F::Member>),
    (s_hi, hi): (f64, &At<F::Member>),
    sigma: f64,
    step: &Step,
    sigma_new: f64,
) -> Result<Corrected<F::Member>> {
    let near = if sigma - s_lo < s_hi - sigma { lo } else { hi };
    let along = (sigma - s_lo) / (s_hi - s_lo);
    let track = lo.eigenvalue + (hi.eigenvalue - lo.eigenvalue) * along;
    let reach = step.t.0.hypot(step.t.1) * sigma_new;
    tracer.correct(near, step, sigma, None, None, track, reach)
}

/// True when both coefficients have a resolved sign and the signs differ.
fn resolved_signs_differ(a: &Lyapunov, b: &Lyapunov) -> bool {
    let known = |l: &Lyapunov| l.verdict != Verdict::Undetermined;
    known(a) && known(b) && a.verdict != b.verdict
}

/// Pins down the zero of the first Lyapunov coefficient between `last` (`sigma = 0`) and `new`
/// (`sigma = sigma_new`), whose signs differ, by Brent's method on `l1`,
/// each sample a corrected point of the curve with its coefficient. It ends when the bracket is
/// within `event_tol` or when a sample's `|l1|` is within its precision (the zero is then known
/// as well as `l1` is); the precision reported is the bracket's width, or the precision of `l1`
/// over its slope along the curve when that is smaller.
fn locate_generalized_hopf<F: Family>(
    tracer: &Tracer<'_, F>,
    last: &At<F::Member>,
    new: &At<F::Member>,
    step: &Step,
    sigma_new: f64,
    s_last: f64,
) -> Result<(Special, Rc<F::Member>)> {
    let l1 = |at: &At<F::Member>| at.lyapunov.as_ref().map_or(f64::NAN, |l| l.l1);
    // Oriented so that f < 0 at `last`.
    let sign = if l1(last) < 0.0 { 1.0 } else { -1.0 };
    let (mut lo, mut hi) = ((0.0, last.clone()), (sigma_new, new.clone()));
    let tol = tracer.continuation.event_tol;
    let mut zeroin = Zeroin::new((0.0, sign * l1(last)), (sigma_new, sign * l1(new)));
    let mut best: Option<(f64, At<F::Member>)> = None;
    for _ in 0..60 {
        if hi.0 - lo.0 <= tol {
            break;
        }
        let sigma = zeroin.propose(tol / 3.0);
        let corrected =
            corrected_between(tracer, (lo.0, &lo.1), (hi.0, &hi.1), sigma, step, sigma_new)?;
        let at = tracer.with_lyapunov(corrected.at);
        let l = at.lyapunov.clone().ok_or_else(|| {
            Error::Numerical("the Lyapunov coefficient failed near a generalized Hopf point".into())
        })?;
        if l.l1.abs() <= l.precision {
            best = Some((sigma, at));
            break;
        }
        let beyond = sign * l.l1 > 0.0;
        zeroin.record(sigma, sign * l.l1, beyond);
        if beyond {
            hi = (sigma, at);
        } else {
            lo = (sigma, at);
        }
    }
    // Known to the bracket, or, where l1 itself ran out of precision, to that precision over
    // the slope of l1 along the curve.
    let slope = (l1(&hi.1) - l1(&lo.1)) / (hi.0 - lo.0);
    let width = match &best {
        Some((_, at)) => {
            let resolution = at.lyapunov.as_ref().map_or(f64::INFINITY, |l| l.precision);
            (hi.0 - lo.0).min(resolution / slope.abs())
        }
        None => hi.0 - lo.0,
    };
    let (sigma, at) = best.unwrap_or_else(|| {
        if l1(&lo.1).abs() <= l1(&hi.1).abs() {
            lo
        } else {
            hi
        }
    });
    let special = Special {
        kind: SpecialKind::GeneralizedHopf,
        point: at.point(s_last + sigma, width, 0),
        other: at.eigenvalue,
        gains: false,
        precision: width,
    };
    Ok((special, at.member))
}

/// The turning point of the curve in `q` near `last`: the extremum of `q(p)` along the curve
/// (which crosses every line `p = const` near it transversally), by successive parabolic
/// interpolation through `a`, `last` and `new`, each new sample the curve's point at the
/// parabola's vertex `p*` (corrected at fixed `p`). It stops when `p*` moves by less than
/// `sqrt(event_tol)` in the units of (2): `q` is then known to about `event_tol`, since it is
/// stationary there.
fn locate_turning<F: Family>(
    tracer: &Tracer<'_, F>,
    a: &CurvePoint,
    last: &At<F::Member>,
    new: &At<F::Member>,
    p_unit: f64,
    s_last: f64,
) -> Result<(Special, Rc<F::Member>)> {
    // The three latest samples (p, q), and the solved state nearest the vertex.
    let mut samples = [(a.p, a.q), (last.p, last.q), (new.p, new.q)];
    let mut best = if (new.q - last.q) * (new.q - a.q) > 0.0 {
        new.clone()
    } else {
        last.clone()
    };
    let (mut evaluations, mut precision) = (0, 0.0);
    let tol = tracer.continuation.event_tol.sqrt();
    let mut moved = f64::INFINITY;
    let mut rounds = 0;
    while moved > tol {
        rounds += 1;
        if rounds > 30 {
            return Err(Error::Numerical(
                "a turning point of the curve not resolved within 30 samples".into(),
            ));
        }
        let [(p0, q0), (p1, q1), (p2, q2)] = samples;
        let d01 = (q1 - q0) / (p1 - p0);
        let d12 = (q2 - q1) / (p2 - p1);
        let curvature = (d12 - d01) / (p2 - p0);
        let p_star = 0.5 * (p0 + p1) - 0.5 * d01 / curvature;
        let q_star = q0 + d01 * (p_star - p0) + curvature * (p_star - p0) * (p_star - p1);
        if !(p_star.is_finite() && q_star.is_finite()) {
            return Err(Error::Numerical(
                "no parabola through the samples near a turning point".into(),
            ));
        }
        moved = (p_star - best.p).abs() / p_unit;
        let step = Step {
            p0: p_star,
            q0: q_star,
            p_unit,
            t: (1.0, 0.0),
            n: (0.0, 1.0),
        };
        let c = tracer.correct(&best, &step, 0.0, None, None, best.eigenvalue, 1.0)?;
        evaluations += c.evaluations;
        precision = c.precision;
        samples = [samples[1], samples[2], (c.at.p, c.at.q)];
        best = c.at;
    }
    let special = Special {
        kind: SpecialKind::Turning,
        point: best.point(s_last, precision, evaluations),
        other: best.eigenvalue,
        gains: false,
        precision: tol,
    };
    Ok((special, best.member))
}

/// The Bogdanov-Takens point ahead of `last` (`sigma = 0` on `step`) where the tracked pair
/// meets on the real axis. Near it `w^2` is linear in the arclength (`w` vanishes like a square
/// root), so its secant zero through the last two complex points predicts the place; the
/// search samples the curve nine tenths of the way there, again and again (a sample that finds
/// the pair real, or no state, is retried nearer), until the predicted zero lies within
/// `event_tol` of the last sample, or no sample nearer it can be solved: the equilibrium itself
/// ceases to exist beyond a fold of the branch that meets the Hopf curve there, in a sliver
/// that narrows quadratically towards the point. The point reported lies at the predicted
/// zero, `p` and `q` extrapolated linearly from the last two samples (the state is the last
/// sample's); its precision is the distance extrapolated.
fn locate_bogdanov_takens<F: Family>(
    tracer: &Tracer<'_, F>,
    previous: &CurvePoint,
    last: &At<F::Member>,
    step: &Step,
    s_last: f64,
) -> Result<(Special, Rc<F::Member>)> {
    let tol = tracer.continuation.event_tol;
    let w2 = |s: c64| s.im * s.im;
    // (sigma, p, q, w^2) of the sample before the last one; the last one.
    let mut before = (
        previous.s - s_last,
        previous.p,
        previous.q,
        w2(previous.eigenvalue),
    );
    let (mut lo, mut lo_at) = (0.0, last.clone());
    let (mut evaluations, mut precision) = (0, 0.0);
    let mut fraction: f64 = 0.9;
    let zero_of = |before: (f64, f64, f64, f64), lo: f64, at: &At<F::Member>| {
        let (s0, _, _, y0) = before;
        let y1 = w2(at.eigenvalue);
        lo - y1 * (lo - s0) / (y1 - y0)
    };
    for _ in 0..200 {
        let zero = zero_of(before, lo, &lo_at);
        if !(zero.is_finite() && zero > lo) {
            return Err(Error::Numerical(
                "the pair turned real, but w^2 does not fall towards zero ahead".into(),
            ));
        }
        if zero - lo <= tol || fraction < 1e-3 {
            break;
        }
        let sigma = lo + fraction * (zero - lo);
        match tracer.correct(
            &lo_at,
            step,
            sigma,
            None,
            None,
            lo_at.eigenvalue,
            REACH * sigma,
        ) {
            Ok(c) => {
                evaluations += c.evaluations;
                precision = c.precision;
                before = (lo, lo_at.p, lo_at.q, w2(lo_at.eigenvalue));
                (lo, lo_at) = (sigma, c.at);
                fraction = 0.9;
            }
            Err(_) => fraction *= 0.5,
        }
    }
    let zero = zero_of(before, lo, &lo_at);
    let (s0, p0, q0, _) = before;
    let along = (zero - lo) / (lo - s0);
    let mut point = lo_at.point(s_last + zero, precision, evaluations);
    point.p = lo_at.p + along * (lo_at.p - p0);
    point.q = lo_at.q + along * (lo_at.q - q0);
    point.eigenvalue = c64::new(lo_at.eigenvalue.re, 0.0);
    let special = Special {
        kind: SpecialKind::BogdanovTakens,
        point,
        other: c64::new(0.0, 0.0),
        gains: false,
        precision: zero - lo,
    };
    Ok((special, lo_at.member))
}

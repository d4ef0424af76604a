//! Events on a branch, pinned down between two consecutive points.
//!
//! * **fold**: the branch turns back in the parameter (the `p` part of the tangent changes
//!   sign); a real eigenvalue crosses zero there;
//! * **branch point**: a real eigenvalue crosses zero while the parameter goes on;
//! * **Hopf point**: a complex pair crosses the imaginary axis;
//! * **mode exchange**: one mode gains stability while another loses it at the same place (to
//!   the precision asked), so the unstable count does not change: noticed and reported, never
//!   typed by a guess.
//!
//! Between the points `a` and `b` the branch is sampled at arclength `sigma` from `a` (predictor
//! along `a`'s tangent, corrector on the hyperplane). The bracket of an event is kept by a robust
//! test, not by the sign of an interpolated function: a sample lies beyond the event when its
//! unstable count differs from the count at the bracket's lower end (a crossing), or when its
//! tangent has turned (a fold). The Illinois variant of regula falsi on a scalar function (the
//! real part of the crossing eigenvalue, followed from sample to sample as the nearest one, or
//! the `p` part of the tangent) only proposes where to sample next; bisection takes over where
//! that function disagrees with the sides. So the final bracket always contains the change of
//! the count, even where the nearest-eigenvalue tracking jumps between two pairs.
//!
//! The search stops when the bracket in the parameter is narrower than
//! `event_tol * max(|p|, 1e-6 P)` (relative, `P` the parameter scale only guarding `p = 0`) and
//! the bracket in arclength narrower than `sqrt(event_tol)` times the step (near a fold `p` is
//! quadratic in the arclength, so a narrow bracket in `p` alone says nothing).
//!
//! A crossing event is typed by the eigenvalue that crossed inside its final bracket (the one
//! unstable on one side whose nearest eigenvalue on the other side is stable), never by
//! whichever eigenvalue lies nearest the axis elsewhere. Several crossings in one step (a branch
//! point and a Hopf point close together) are located one after the other, each from the far
//! side of the one before, and all are reported.

use faer::c64;

use super::arclength::{Metric, Point, correct, stability};
use super::stability::{Spectrum, is_complex};
use super::{ContinuationSettings, Problem};
use crate::Result;

/// The kind of an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    Fold,
    BranchPoint,
    Hopf,
    /// Two modes crossed the axis in opposite directions within the event tolerance.
    ModeExchange,
    /// An event of a caller's own [`super::arclength::Detector`], by its name.
    User(&'static str),
}

impl EventKind {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Fold => "fold",
            EventKind::BranchPoint => "branch_point",
            EventKind::Hopf => "hopf",
            EventKind::ModeExchange => "mode_exchange",
            EventKind::User(name) => name,
        }
    }
}

/// A located event.
#[derive(Clone, Debug)]
pub struct Event {
    pub kind: EventKind,
    /// The solution and parameter at the event.
    pub u: Vec<f64>,
    pub p: f64,
    /// Arclength of the event along the branch.
    pub s: f64,
    /// The critical eigenvalue there (real part near zero; imaginary part the Hopf frequency,
    /// counted positive).
    pub eigenvalue: c64,
    /// The final bracket of the parameter, and its width relative to `|p|` (or the relative
    /// uncertainty of the points that bound it, where that is larger).
    pub bracket: (f64, f64),
    pub precision: f64,
    /// Number of eigenvalues that crossed together (a Hopf pair counts once).
    pub multiplicity: usize,
    /// Unstable counts on the two sides of the event's final bracket.
    pub unstable_before: usize,
    pub unstable_after: usize,
    /// The leading spectrum at the event.
    pub spectrum: Spectrum,
}

impl Event {
    /// True for the event at which a stable branch becomes unstable.
    pub fn loses_stability(&self) -> bool {
        self.unstable_before == 0 && self.unstable_after > 0
    }
}

/// The eigenvalue that crossed between spectra `a` and `b`: an unstable eigenvalue of the side
/// with more of them whose nearest eigenvalue on the other side is stable (the one closest to
/// the axis if several; the member with `Im >= 0` of a pair). With equal counts (an exchange of
/// modes), the newly unstable eigenvalue of `b`.
pub fn crossing_eigenvalue(a: &Spectrum, b: &Spectrum) -> c64 {
    let (more, less) = if b.unstable >= a.unstable {
        (b, a)
    } else {
        (a, b)
    };
    let unstable = &more.leading[..more.unstable.min(more.leading.len())];
    let crossed = unstable
        .iter()
        .filter(|s| less.nearest(**s).re <= 0.0)
        .min_by(|x, y| x.re.total_cmp(&y.re))
        .or_else(|| unstable.last())
        .or_else(|| more.leading.first())
        .copied()
        .unwrap_or(c64::new(0.0, 0.0));
    c64::new(crossed.re, crossed.im.abs())
}

/// True when the unstable counts of `a` and `b` agree but a mode has exchanged stability with
/// another: an eigenvalue unstable at `b` whose nearest at `a` is stable, and one unstable at
/// `a` whose nearest at `b` is stable (each crossing's identity followed as the nearest
/// eigenvalue).
pub fn modes_exchanged(a: &Spectrum, b: &Spectrum) -> bool {
    let newly = |from: &Spectrum, to: &Spectrum| {
        to.leading[..to.unstable.min(to.leading.len())]
            .iter()
            .any(|s| from.nearest(*s).re <= 0.0)
    };
    a.unstable == b.unstable && a.unstable > 0 && newly(a, b) && newly(b, a)
}

/// The Illinois weights of regula falsi: an end of the bracket that stays put twice in a row
/// has its function value halved, so that the secant does not stall against it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Illinois {
    w_lo: f64,
    w_hi: f64,
    /// Which end the last sample replaced: 1 the far one, -1 the near one, 0 none yet.
    side: i8,
}

impl Illinois {
    pub(crate) fn new() -> Self {
        Illinois {
            w_lo: 1.0,
            w_hi: 1.0,
            side: 0,
        }
    }

    /// The function values at the two ends, weighted.
    pub(crate) fn weighted(&self, f_lo: f64, f_hi: f64) -> (f64, f64) {
        (f_lo * self.w_lo, f_hi * self.w_hi)
    }

    /// Records that the new sample replaced the far end (`beyond`) or the near one.
    pub(crate) fn replaced(&mut self, beyond: bool) {
        if beyond {
            self.w_hi = 1.0;
            if self.side == 1 {
                self.w_lo *= 0.5;
            }
            self.side = 1;
        } else {
            self.w_lo = 1.0;
            if self.side == -1 {
                self.w_hi *= 0.5;
            }
            self.side = -1;
        }
    }
}

/// One evaluation inside the bracket.
#[derive(Clone)]
struct Sample {
    sigma: f64,
    u: Vec<f64>,
    p: f64,
    tangent_p: f64,
    spectrum: Spectrum,
    /// The corrector's uncertainty of `p` at this sample.
    uncertainty: f64,
}

/// Samples the branch between two consecutive points `a` and `b` at arclength `sigma` from `a`.
struct Sampler<'a, P: Problem> {
    problem: &'a P,
    a: &'a Point,
    metric: &'a Metric,
    settings: &'a ContinuationSettings,
    /// The step `|s_b - s_a|`.
    step: f64,
    /// The parameter scale (guards the relative tolerance at `p = 0`).
    p_scale: f64,
    /// Whether samples need the tangent (a fold; next to a branch point it is ill-defined).
    with_tangent: bool,
}

impl<'a, P: Problem> Sampler<'a, P> {
    /// The sampler of the step from `a` to `b`.
    fn new(
        problem: &'a P,
        a: &'a Point,
        b: &Point,
        metric: &'a Metric,
        settings: &'a ContinuationSettings,
        with_tangent: bool,
    ) -> Self {
        Sampler {
            problem,
            a,
            metric,
            settings,
            step: (b.s - a.s).abs(),
            p_scale: problem.scales().1,
            with_tangent,
        }
    }

    fn at(&self, sigma: f64) -> Result<Sample> {
        let a = self.a;
        let step: Vec<f64> = a.tangent_u.iter().map(|t| sigma * t).collect();
        let predicted = self.problem.retract(&a.u, &step);
        let c = correct(
            self.problem,
            predicted,
            a.p + sigma * a.tangent_p,
            &a.tangent_u,
            a.tangent_p,
            self.metric,
            self.settings,
        )?;
        let tangent_p = if self.with_tangent {
            c.tangent(self.metric)?.1
        } else {
            a.tangent_p
        };
        let spectrum = stability(
            self.problem,
            &c.u,
            c.p,
            &c.lin,
            self.settings,
            Some(&a.spectrum),
        )?;
        Ok(Sample {
            sigma,
            u: c.u,
            p: c.p,
            tangent_p,
            spectrum,
            uncertainty: c.uncertainty,
        })
    }

    fn sample_of(&self, point: &Point) -> Sample {
        Sample {
            sigma: point.s - self.a.s,
            u: point.u.clone(),
            p: point.p,
            tangent_p: point.tangent_p,
            spectrum: point.spectrum.clone(),
            uncertainty: point.uncertainty,
        }
    }

    /// Adds `event` to `events`, as part of the last one when both are crossings of the same
    /// kind closer in `p` than the tolerance: two eigenvalues that cross where the precision
    /// asked cannot tell apart (the two bending planes of a round rod, equal but for round-off)
    /// are one event of multiplicity two, not two events in an order set by round-off.
    fn push(&self, events: &mut Vec<Event>, event: Event) {
        if let Some(last) = events.last_mut()
            && last.kind == event.kind
            && (event.p - last.p).abs() <= self.p_tol(last.p)
        {
            last.multiplicity += event.multiplicity;
            last.unstable_after = event.unstable_after;
            last.bracket = (
                last.bracket.0.min(event.bracket.0),
                last.bracket.1.max(event.bracket.1),
            );
            last.precision = last.precision.max(event.precision);
            return;
        }
        events.push(event);
    }

    /// The tolerance on the width of a bracket in `p` around `p`.
    fn p_tol(&self, p: f64) -> f64 {
        self.settings.event_tol * p.abs().max(1e-6 * self.p_scale)
    }

    /// How close to an end of the bracket `[lo, ..]` a proposed sample may come: a third of
    /// the width in arclength at which [`Sampler::converged`] accepts (in `p` through the
    /// tangent at `a`).
    fn margin(&self, lo: &Sample) -> f64 {
        let sigma_tol = self.settings.event_tol.sqrt() * self.step;
        let p_tol = self.p_tol(lo.p) / self.a.tangent_p.abs();
        sigma_tol.min(p_tol) / 3.0
    }

    fn converged(&self, lo: &Sample, hi: &Sample) -> bool {
        (hi.p - lo.p).abs() <= self.p_tol(lo.p)
            && (hi.sigma - lo.sigma).abs() <= self.settings.event_tol.sqrt() * self.step
    }

    /// Narrows `[lo, hi]` (with `beyond(lo)` false and `beyond(hi)` true) until it converges.
    /// `f` is negative on `lo`'s side when the tracking is sound; its Illinois-weighted secant
    /// proposes the next sample, bisection is the fallback.
    fn bracket(
        &self,
        mut lo: Sample,
        mut hi: Sample,
        beyond: impl Fn(&Sample) -> bool,
        f: impl Fn(&Sample, &Sample, &Sample) -> f64,
    ) -> Result<(Sample, Sample)> {
        let mut weights = Illinois::new();
        let mut iterations = 0;
        while !self.converged(&lo, &hi) {
            iterations += 1;
            if iterations > 200 {
                return Err(crate::Error::Numerical(format!(
                    "event not resolved to {:e} within 200 samples (bracket p in [{}, {}])",
                    self.settings.event_tol, lo.p, hi.p
                )));
            }
            let (f_lo, f_hi) = weights.weighted(f(&lo, &lo, &hi), f(&hi, &lo, &hi));
            let sigma = secant(&lo, &hi, f_lo, f_hi, self.margin(&lo));
            let s = self.at(sigma)?;
            let past = beyond(&s);
            if past {
                hi = s;
            } else {
                lo = s;
            }
            weights.replaced(past);
        }
        Ok((lo, hi))
    }

    /// Pins down the first change of the unstable count between `lo` and `hi` (whose counts
    /// differ); returns the event and the sample just beyond it.
    fn crossing(&self, lo: Sample, hi: Sample) -> Result<(Event, Sample)> {
        let base = lo.spectrum.unstable;
        let growing = hi.spectrum.unstable > base;
        // The eigenvalue that crosses is identified afresh in every bracket (the unstable one
        // of the far side whose nearest on the near side is stable): as the bracket narrows
        // the identification only gets safer, and the secant sees one smooth function.
        let f = |s: &Sample, l: &Sample, h: &Sample| {
            crossing_function(s, crossing_eigenvalue(&l.spectrum, &h.spectrum), growing)
        };
        let beyond = |s: &Sample| s.spectrum.unstable != base;
        let (l, h) = self.bracket(lo, hi, beyond, f)?;
        // Typed by what crossed inside the final bracket.
        let crossed = crossing_eigenvalue(&l.spectrum, &h.spectrum);
        let d = l.spectrum.unstable.abs_diff(h.spectrum.unstable);
        let (kind, multiplicity) = if is_complex(crossed) {
            (EventKind::Hopf, d.div_ceil(2))
        } else {
            (EventKind::BranchPoint, d)
        };
        let growing = h.spectrum.unstable > l.spectrum.unstable;
        let f_final = |s: &Sample, _: &Sample, _: &Sample| crossing_function(s, crossed, growing);
        let event = self.event(&l, &h, f_final, kind, crossed, multiplicity)?;
        Ok((event, h))
    }

    /// The event at the final secant estimate of the root inside `[lo, hi]`.
    fn event(
        &self,
        lo: &Sample,
        hi: &Sample,
        f: impl Fn(&Sample, &Sample, &Sample) -> f64,
        kind: EventKind,
        near: c64,
        multiplicity: usize,
    ) -> Result<Event> {
        let sigma = secant(lo, hi, f(lo, lo, hi), f(hi, lo, hi), 0.0);
        let best = self.at(sigma)?;
        let critical = best.spectrum.nearest(near);
        Ok(Event {
            kind,
            s: self.a.s + best.sigma,
            eigenvalue: c64::new(critical.re, critical.im.abs()),
            bracket: (lo.p.min(hi.p), lo.p.max(hi.p)),
            // The bracket's width, or the points' own uncertainty where that is larger.
            precision: (hi.p - lo.p)
                .abs()
                .max(lo.uncertainty)
                .max(hi.uncertainty)
                .max(best.uncertainty)
                / lo.p.abs().max(1e-6 * self.p_scale),
            multiplicity,
            unstable_before: lo.spectrum.unstable,
            unstable_after: hi.spectrum.unstable,
            u: best.u,
            p: best.p,
            spectrum: best.spectrum,
        })
    }
}

/// The secant root of `f` between `lo` and `hi` when `f` goes from non-positive to positive
/// there, kept at least `margin` inside the bracket (so that a root on an end, where the secant
/// lands exactly, is closed off by one sample just beside it instead of by bisection from the
/// other end); else the midpoint.
fn secant(lo: &Sample, hi: &Sample, f_lo: f64, f_hi: f64, margin: f64) -> f64 {
    let sigma = lo.sigma - f_lo * (hi.sigma - lo.sigma) / (f_hi - f_lo);
    let (left, right) = (lo.sigma.min(hi.sigma), lo.sigma.max(hi.sigma));
    if f_lo <= 0.0 && f_hi > 0.0 && sigma.is_finite() && right - left > 2.0 * margin {
        sigma.clamp(left + margin, right - margin)
    } else {
        0.5 * (lo.sigma + hi.sigma)
    }
}

/// The signed real part of the eigenvalue nearest `tracked` in `s` (negative on the stable side
/// of a crossing that raises the count `from -> to`).
fn crossing_function(s: &Sample, tracked: c64, growing: bool) -> f64 {
    let re = s.spectrum.nearest(tracked).re;
    if growing { re } else { -re }
}

/// Pins down the fold between the consecutive points `a` and `b` (the `p` part of the tangent
/// changes sign).
pub fn locate_fold(
    problem: &impl Problem,
    a: &Point,
    b: &Point,
    metric: &Metric,
    settings: &ContinuationSettings,
) -> Result<Event> {
    let sampler = Sampler::new(problem, a, b, metric, settings, true);
    let sign = a.tangent_p.signum();
    let beyond = |s: &Sample| s.tangent_p * sign < 0.0;
    let f = |s: &Sample, _: &Sample, _: &Sample| -s.tangent_p * sign;
    let (lo, hi) = sampler.bracket(sampler.sample_of(a), sampler.sample_of(b), beyond, f)?;
    sampler.event(&lo, &hi, f, EventKind::Fold, c64::new(0.0, 0.0), 1)
}

/// Pins down every change of the unstable count between the consecutive points `a` and `b`,
/// in order along the branch: each from the far side of the one before, typed by the
/// eigenvalue that crossed inside its final bracket. Where the counts agree but two modes
/// exchanged stability ([`modes_exchanged`]), the step is searched for the two crossings; if
/// they cannot be separated to the tolerance, one [`EventKind::ModeExchange`] is reported.
pub fn locate_crossings(
    problem: &impl Problem,
    a: &Point,
    b: &Point,
    metric: &Metric,
    settings: &ContinuationSettings,
) -> Result<Vec<Event>> {
    let sampler = Sampler::new(problem, a, b, metric, settings, false);
    let end = sampler.sample_of(b);
    let mut lo = sampler.sample_of(a);
    let mut events = Vec::new();
    // Each pass locates one change of the count (or one exchange); a step holds only a few.
    for _ in 0..16 {
        if lo.spectrum.unstable != end.spectrum.unstable {
            let (event, beyond) = sampler.crossing(lo, end.clone())?;
            sampler.push(&mut events, event);
            lo = beyond;
            continue;
        }
        if !modes_exchanged(&lo.spectrum, &end.spectrum) {
            return Ok(events);
        }
        // Find a sample whose count differs (two ordinary crossings), or narrow the exchange
        // down to the tolerance.
        let mut hi = end.clone();
        loop {
            if sampler.converged(&lo, &hi) {
                // Over a bracket this narrow the eigenvalues barely move, so the nearest-one
                // identification is sound: an exchange still seen is one; one no longer seen
                // was a mismatch of the wider step, and no event.
                if modes_exchanged(&lo.spectrum, &hi.spectrum) {
                    let near = crossing_eigenvalue(&lo.spectrum, &hi.spectrum);
                    let f = |_: &Sample, _: &Sample, _: &Sample| 0.0;
                    events.push(sampler.event(&lo, &hi, f, EventKind::ModeExchange, near, 1)?);
                }
                lo = hi;
                break;
            }
            let mid = sampler.at(0.5 * (lo.sigma + hi.sigma))?;
            if mid.spectrum.unstable != lo.spectrum.unstable {
                // The first of two ordinary crossings lies between lo and mid; the next pass
                // takes the rest of the step.
                let (event, beyond) = sampler.crossing(lo, mid)?;
                sampler.push(&mut events, event);
                lo = beyond;
                break;
            }
            if modes_exchanged(&lo.spectrum, &mid.spectrum) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
    }
    Err(crate::Error::Numerical(format!(
        "more than 16 changes of stability between p = {} and p = {}",
        a.p, b.p
    )))
}

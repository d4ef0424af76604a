//! A crossing of the imaginary axis located from a state near it, without following the branch
//! from its start (the sequenced refinement of docs/model.md section 10 carries the Hopf point
//! of a coarse mesh onto a finer one and locates it there).
//!
//! It solves the minimally augmented system of the Hopf curves ([`crate::engine::curve`]) at
//! one member,
//!
//! ```text
//! G(u, p) = 0,      h(p) = Re s(p) = 0,                                                 (1)
//! ```
//!
//! `s(p)` the eigenvalue of the stability pair at `u(p)` nearest the one tracked from the
//! prediction `s0`: each evaluation of `h` is a Newton solve at fixed `p` from the last solution,
//! and the leading spectrum there. Which side of the crossing a sample lies on comes from its
//! unstable count (certified, [`crate::engine::stability`]), as for the events of a branch
//! ([`crate::engine::events`]): from `p0` the secant method on `h` steps until the count changes,
//! then Brent's method ([`Zeroin`]) narrows the bracket `[p_near, p_beyond]` until it is
//! narrower than `event_tol |p|`, or until the interpolation puts the zero within `event_tol |p|`
//! of the sample nearest it (a smooth `h`: the secant's own error is then far smaller). The near end is a state on the stable side whose unstable count is the
//! count before the crossing, and the event's eigenvalue is the one that crossed between the
//! ends ([`crossing_eigenvalue`]).

use faer::c64;

use super::arclength::{AtParameter, stability};
use super::events::{Event, EventKind, Zeroin, crossing_eigenvalue};
use super::newton::{self, NewtonSettings};
use super::stability::{Spectrum, is_complex};
use super::{ContinuationSettings, Problem};
use crate::{Error, Result};

/// A solved state and its spectrum at one `p`.
#[derive(Clone, Debug)]
pub struct State {
    pub p: f64,
    pub u: Vec<f64>,
    pub spectrum: Spectrum,
    /// The eigenvalue tracked from the prediction (imaginary part made non-negative).
    pub tracked: c64,
}

/// A crossing located by [`locate_crossing`].
#[derive(Clone, Debug)]
pub struct Crossing {
    /// The event at the crossing (the end of the final bracket nearer the zero of `h`).
    pub event: Event,
    /// The state on the stable side of the final bracket, just below the crossing.
    pub near: State,
    /// The first evaluation, at the predicted `p0`: its tracked eigenvalue against the
    /// prediction says how far the spectrum moved from where the prediction was made.
    pub first: State,
    /// Newton solves with a spectrum.
    pub evaluations: usize,
}

/// How [`locate_crossing`] searches.
#[derive(Clone, Copy, Debug)]
pub struct CrossingSettings {
    /// The first step from `p0`, relative to `|p0|`, until the secant has two samples, where no
    /// `slope` is known.
    pub first_step: f64,
    /// The slope `dh/dp` of the test function expected near the crossing (e.g. that of a
    /// coarser mesh): the first step is then the Newton step `-h(p0)/slope`.
    pub slope: Option<f64>,
    /// Evaluations allowed (the search is refused beyond).
    pub max_evaluations: usize,
    /// The unstable count before the crossing (0 for a first loss of stability).
    pub unstable_before: usize,
}

/// The solution at `p` from `guess`, its spectrum (after `prior`) and the eigenvalue nearest
/// `track`. The samples lie close together, so the problem's coordinates stay where they are
/// (unlike along a branch, no chart is moved): every state of the search is measured in them.
fn evaluate<P: Problem>(
    problem: &P,
    guess: &[f64],
    p: f64,
    track: c64,
    prior: Option<&Spectrum>,
    newton: &NewtonSettings,
    settings: &ContinuationSettings,
) -> Result<State> {
    let system = AtParameter::new(problem, p);
    let (u, _) = newton::solve(&system, guess.to_vec(), newton, &format!("at p = {p:e}"))?;
    let lin = system.linearization_at(&u)?;
    let spectrum = stability(problem, &u, p, &lin, settings, prior)?;
    let s = spectrum.nearest(track);
    Ok(State {
        p,
        u,
        tracked: c64::new(s.re, s.im.abs()),
        spectrum,
    })
}

/// The solution guess at `p` on the line through the states `a` and `b` (interpolated inside
/// the bracket, extrapolated by the secant outside it): off the solution by `O(|p - a.p| |p -
/// b.p|)` instead of the `O(|p - b.p|)` of `b`'s own state, so Newton's method from it takes a
/// step or two fewer (all the states of a search share one chart).
fn along(a: &State, b: &State, p: f64) -> Vec<f64> {
    let t = (p - b.p) / (b.p - a.p);
    if !t.is_finite() {
        return b.u.clone();
    }
    a.u.iter()
        .zip(&b.u)
        .map(|(ua, ub)| ub + t * (ub - ua))
        .collect()
}

/// Locates where the eigenvalue tracked from `track` crosses the imaginary axis, from the
/// solution guess `u0` at `p0` near it (1). The crossing must change the unstable count from
/// `settings.unstable_before`; the state `u0` is corrected at `p0` first.
pub fn locate_crossing<P: Problem>(
    problem: &P,
    u0: &[f64],
    p0: f64,
    track: c64,
    search: &CrossingSettings,
    continuation: &ContinuationSettings,
) -> Result<Crossing> {
    let newton = NewtonSettings {
        tol: continuation.tol,
        ..NewtonSettings::default()
    };
    let tol = continuation.event_tol;
    let beyond = |s: &State| s.spectrum.unstable > search.unstable_before;
    let first = evaluate(problem, u0, p0, track, None, &newton, continuation)?;
    let mut evaluations = 1;
    let refuse = |why: &str, evaluations: usize| {
        Error::Numerical(format!(
            "no crossing of the tracked eigenvalue (predicted {track:.4e}) found from p = {p0:e}: \
             {why} after {evaluations} solves"
        ))
    };
    // The secant on h until the side changes: `last` and `before` are the two latest samples.
    // The first step: Newton's with the slope given, else a fixed fraction towards the side
    // not yet seen; at most a tenth of |p0|.
    let towards_other = if beyond(&first) { -1.0 } else { 1.0 } * p0.signum();
    let limit = 0.1 * p0.abs();
    let first_step = match search.slope.filter(|g| g.is_finite() && *g != 0.0) {
        Some(g) => (-first.tracked.re / g).clamp(-limit, limit),
        None => towards_other * search.first_step * p0.abs(),
    };
    let mut before = first.clone();
    let mut last = evaluate(
        problem,
        &first.u,
        p0 + first_step,
        first.tracked,
        Some(&first.spectrum),
        &newton,
        continuation,
    )?;
    evaluations += 1;
    while beyond(&last) == beyond(&before) {
        if evaluations >= search.max_evaluations {
            return Err(refuse("the unstable count did not change", evaluations));
        }
        let slope = (last.tracked.re - before.tracked.re) / (last.p - before.p);
        let secant = last.p - last.tracked.re / slope;
        // Towards the other side, at least as far as the last step and at most four times it.
        let step = last.p - before.p;
        let towards = if beyond(&last) {
            -p0.signum()
        } else {
            p0.signum()
        };
        let proposed = secant - last.p;
        let length = if proposed.is_finite() && proposed * towards > 0.0 {
            proposed.abs().clamp(step.abs(), 4.0 * step.abs())
        } else {
            2.0 * step.abs()
        };
        let p_next = last.p + towards * length;
        let next = evaluate(
            problem,
            &along(&before, &last, p_next),
            p_next,
            last.tracked,
            Some(&last.spectrum),
            &newton,
            continuation,
        )?;
        evaluations += 1;
        before = std::mem::replace(&mut last, next);
    }
    let (mut near, mut far) = if beyond(&last) {
        (before, last)
    } else {
        (last, before)
    };
    // Brent's method inside the bracket, the sides by the unstable count, until the bracket is
    // narrower than the tolerance or the interpolation puts the zero within the tolerance of
    // the sample nearest it (the precision is then that distance).
    let mut zeroin = Zeroin::new((near.p, near.tracked.re), (far.p, far.tracked.re));
    let width = |near: &State, far: &State| (far.p - near.p).abs() / near.p.abs().max(far.p.abs());
    let mut precision = width(&near, &far);
    while precision > tol {
        let min_step = 0.25 * tol * near.p.abs();
        let p = zeroin.propose(min_step);
        let best = if near.tracked.re.abs() <= far.tracked.re.abs() {
            &near
        } else {
            &far
        };
        let predicted = (p - best.p).abs() / best.p.abs();
        if predicted <= tol && (p - best.p).abs() > min_step {
            precision = predicted;
            break;
        }
        if evaluations >= search.max_evaluations {
            return Err(refuse("the bracket did not close", evaluations));
        }
        let from = if (p - near.p).abs() < (p - far.p).abs() {
            &near
        } else {
            &far
        };
        let sample = evaluate(
            problem,
            &along(&near, &far, p),
            p,
            from.tracked,
            Some(&from.spectrum),
            &newton,
            continuation,
        )?;
        evaluations += 1;
        let side = beyond(&sample);
        zeroin.record(sample.p, sample.tracked.re, side);
        if side {
            far = sample;
        } else {
            near = sample;
        }
        precision = width(&near, &far);
    }
    let eigenvalue = crossing_eigenvalue(&near.spectrum, &far.spectrum);
    let at = if near.tracked.re.abs() <= far.tracked.re.abs() {
        &near
    } else {
        &far
    };
    let crossed = far.spectrum.unstable - near.spectrum.unstable;
    // The event's eigenvalue at its own state (the bracket's far end may lie a first step away,
    // where the frequency differs in the fifth digit), as for the events of a branch.
    let critical = at.spectrum.nearest(eigenvalue);
    let event = Event {
        kind: if is_complex(eigenvalue) {
            EventKind::Hopf
        } else {
            EventKind::BranchPoint
        },
        u: at.u.clone(),
        p: at.p,
        s: 0.0,
        eigenvalue: c64::new(critical.re, critical.im.abs()),
        bracket: (near.p.min(far.p), near.p.max(far.p)),
        precision,
        multiplicity: if is_complex(eigenvalue) {
            crossed / 2
        } else {
            crossed
        }
        .max(1),
        unstable_before: near.spectrum.unstable,
        unstable_after: far.spectrum.unstable,
        spectrum: at.spectrum.clone(),
    };
    Ok(Crossing {
        event,
        near,
        first,
        evaluations,
    })
}

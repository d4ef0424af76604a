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
//! narrower than `event_tol |p|`, or until the secant through its ends puts the zero within
//! half of `event_tol |p|` of the near end. The precision stated is then twice that distance:
//! the secant's own error is a fraction of the distance, the bracket's width over the scale on
//! which `h` bends (measured 2% over a bracket of `1.3e-3` relative on a real part quadratic
//! in `p`). Brent's samples are moved by a quarter of the tolerance towards the near end, so
//! that where the interpolation is that accurate the sample lands on the stable side and ends
//! the search there. The near end is a state on the stable side whose unstable count is the
//! count before the crossing, and the event's eigenvalue is the one that crossed between the
//! ends ([`crossing_eigenvalue`]).

use faer::{Mat, c64};

use super::arclength::{AtParameter, stability};
use super::events::{Event, EventKind, Zeroin, crossing_eigenvalue};
use super::newton::{Chord, Jacobians, Newton, NewtonSettings};
use super::stability::{Spectrum, is_complex};
use super::{ContinuationSettings, Problem};
use crate::numerics::lu::Lu;
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

/// The Jacobian at the solution of the sample before, and its `p`.
struct Previous {
    p: f64,
    jacobian: Mat<f64>,
}

/// How near (relative to `|p|`) a sample must lie to the one before for Newton's method to run
/// as the chord method on the Jacobian there. The last samples of a search lie within `1e-4`
/// of each other; there the chord contracted the residual of the representative helix by about
/// 100 per iteration, and an iteration costs a residual (at `N = 473` about a tenth of a
/// linearization). Farther apart (the first steps of the secant, `1e-3` to `3e-2`) the
/// Jacobian of a stiff rod changes enough that the chord contracted by only 5 to 7 and often
/// had to start again, slower than Newton's method proper.
const CHORD_RANGE: f64 = 1e-4;

/// The evaluations of one search: the problem, Newton's method and the settings they share,
/// and the Jacobian of the latest sample.
struct Sampler<'a, P: Problem> {
    problem: &'a P,
    newton: Newton,
    settings: &'a ContinuationSettings,
    previous: Option<Previous>,
}

impl<'a, P: Problem> Sampler<'a, P> {
    /// The sampler of `problem`, its Newton solves to the continuation's tolerance.
    fn new(problem: &'a P, settings: &'a ContinuationSettings) -> Self {
        Sampler {
            problem,
            newton: Newton::from(&NewtonSettings {
                tol: settings.tol,
                ..NewtonSettings::default()
            }),
            settings,
            previous: None,
        }
    }

    /// The solution at `p` from `guess`, its spectrum (after `prior`) and the eigenvalue nearest
    /// `track`. The samples lie close together, so the problem's coordinates stay where they
    /// are (unlike along a branch, no chart is moved): every state of the search is measured in
    /// them. Newton's method runs as the chord method ([`Jacobians::Reuse`]: rebuilt where the
    /// residual falls by less than a factor 3 per iteration) on the Jacobian of the sample
    /// before where `p` lies within [`CHORD_RANGE`] of it, as Newton's method proper elsewhere;
    /// the solution's Jacobian is kept for the next sample.
    fn evaluate(
        &mut self,
        guess: &[f64],
        p: f64,
        track: c64,
        prior: Option<&Spectrum>,
    ) -> Result<State> {
        let system = AtParameter::new(self.problem, p);
        let context = format!("at p = {p:e}");
        let guess = guess.to_vec();
        let newton = &self.newton;
        let (u, _) = match self
            .previous
            .take()
            .filter(|j| (p - j.p).abs() <= CHORD_RANGE * p.abs())
        {
            Some(j) => {
                let mut chord = Chord::holding(Lu::of(j.jacobian));
                newton.run(&system, guess, Jacobians::Reuse(&mut chord), &context)?
            }
            None => newton.run(&system, guess, Jacobians::Fresh, &context)?,
        };
        let lin = system.linearization_at(&u)?;
        let spectrum = stability(self.problem, &u, p, &lin, self.settings, prior)?;
        self.previous = Some(Previous {
            p,
            jacobian: lin.g_u,
        });
        let s = spectrum.nearest(track);
        Ok(State {
            p,
            u,
            tracked: c64::new(s.re, s.im.abs()),
            spectrum,
        })
    }
}

/// Where the secant through the bracket's ends puts the zero of `h`, where their real parts
/// have the signs of their sides (a tracked eigenvalue that does not is not the one whose
/// crossing the counts see, and its line says nothing).
fn secant_zero(near: &State, far: &State) -> Option<f64> {
    let (a, b) = (near.tracked.re, far.tracked.re);
    (a < 0.0 && b > 0.0).then(|| near.p - a * (far.p - near.p) / (b - a))
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

/// The slope `d Re s / dp` of the eigenvalue `s` of the solution `u` at `p` (on the axis, or
/// near it), from a second solution a relative `step` below: `(Re s - Re s(p - step |p|)) /
/// (step |p|)`, the eigenvalue tracked from `s`. A secant over `step`, which the search of a
/// finer mesh takes its first step with ([`CrossingSettings::slope`]): the slope from the last
/// point of a branch before its Hopf point, a continuation step away, can be off by a factor
/// two where the eigenvalue's real part bends (on the representative helix at `N = 60`, 0.16
/// from 23 rad below against 0.37 here), and the first step then overshoots.
pub fn eigenvalue_slope<P: Problem>(
    problem: &P,
    u: &[f64],
    p: f64,
    s: c64,
    step: f64,
    continuation: &ContinuationSettings,
) -> Result<f64> {
    let mut sampler = Sampler::new(problem, continuation);
    let below = p - step * p.abs();
    let sample = sampler.evaluate(u, below, s, None)?;
    let slope = (s.re - sample.tracked.re) / (p - below);
    if slope.is_finite() {
        Ok(slope)
    } else {
        Err(Error::Numerical(format!(
            "no slope of the eigenvalue {s:.4e} at p = {p:e}"
        )))
    }
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
    let mut sampler = Sampler::new(problem, continuation);
    let tol = continuation.event_tol;
    let beyond = |s: &State| s.spectrum.unstable > search.unstable_before;
    let first = sampler.evaluate(u0, p0, track, None)?;
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
    let mut last = sampler.evaluate(
        &first.u,
        p0 + first_step,
        first.tracked,
        Some(&first.spectrum),
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
        let next = sampler.evaluate(
            &along(&before, &last, p_next),
            p_next,
            last.tracked,
            Some(&last.spectrum),
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
    // narrower than the tolerance or the secant through its ends puts the zero within half the
    // tolerance of its near end (the precision is then twice that distance).
    let mut zeroin = Zeroin::new((near.p, near.tracked.re), (far.p, far.tracked.re));
    let width = |near: &State, far: &State| (far.p - near.p).abs() / near.p.abs().max(far.p.abs());
    let mut precision = width(&near, &far);
    while precision > tol {
        let predicted = secant_zero(&near, &far).map(|z| (z - near.p).abs() / near.p.abs());
        if let Some(predicted) = predicted.filter(|&d| d <= 0.5 * tol) {
            precision = 2.0 * predicted;
            break;
        }
        let min_step = 0.25 * tol * near.p.abs();
        let proposed = zeroin.propose(min_step);
        // A quarter of the tolerance towards the near end, so that an accurate interpolation
        // samples the stable side and the search can end there.
        let biased = proposed + 0.25 * tol * proposed.abs() * (near.p - proposed).signum();
        let p = if (biased - near.p) * (far.p - near.p) > 0.0 {
            biased
        } else {
            proposed
        };
        if evaluations >= search.max_evaluations {
            return Err(refuse("the bracket did not close", evaluations));
        }
        let from = if (p - near.p).abs() < (p - far.p).abs() {
            &near
        } else {
            &far
        };
        let sample = sampler.evaluate(
            &along(&near, &far, p),
            p,
            from.tracked,
            Some(&from.spectrum),
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

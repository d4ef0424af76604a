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
//! ([`crate::engine::events`]), and the side the stable one is on is given
//! ([`CrossingSettings::regain`]): from `p0` the secant method on `h` steps until the count changes,
//! then Brent's method ([`Zeroin`]) narrows the bracket `[p_near, p_beyond]` until it is
//! narrower than `event_tol |p|`, or until the secant through its ends puts the zero within
//! half of `event_tol |p|` of the near end, the secant's own error included: estimated by the
//! distance to the zero of the inverse quadratic through a third sample (the secant's error is
//! a fraction of the distance, the bracket's width over the scale on which `h` bends: 2% over a
//! bracket of `1.3e-3` relative on the representative helix). The precision stated is then
//! twice the distance plus that error. Brent's samples are moved by a quarter of the tolerance
//! towards the near end (unless that would put them within Brent's smallest step of it), so
//! that where the interpolation is that accurate the sample lands on the stable side and ends
//! the search there. The near end is a state on the stable side, whose unstable count is
//! [`CrossingSettings::unstable_stable_side`], and the event's eigenvalue is the one that crossed
//! between the ends ([`crossing_eigenvalue`]). The event's counts before and after it are those
//! of the two ends in the direction the branch is travelled in ([`CrossingSettings::travel`]).
//! A non-finite or zero `travel` is taken as `+1`.

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
    /// The end of the final bracket on the stable side, next to the crossing.
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
    /// The unstable count on the crossing's stable side (0 where a stable branch loses or
    /// regains its stability).
    pub unstable_stable_side: usize,
    /// The direction in `p` the branch is travelled in (`-1` where negative, `+1` otherwise):
    /// the event's counts before and after the crossing are in that order.
    pub travel: f64,
    /// Whether the stable side comes after the crossing along `travel` (stability regained, the
    /// end of a window of instability); before it otherwise (stability lost).
    pub regain: bool,
}

impl CrossingSettings {
    /// The direction in `p` from the crossing towards its stable side.
    fn stable_direction(&self) -> f64 {
        let travel = if self.travel < 0.0 { -1.0 } else { 1.0 };
        if self.regain { travel } else { -travel }
    }
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

/// The secant's zero `z` of the bracket (`secant_zero`) judged by a third sample `(p, h)`,
/// `older`: its distance from the near end and its error, estimated as its distance to the zero
/// of the inverse quadratic through the three samples, `p(h)` interpolated at `h = 0`
/// (`sum_i p_i prod_{j != i} h_j / (h_j - h_i)`), both relative to `|p_near|`. The quadratic
/// sees the curvature of `h` that the secant ignores: the secant's error grows with the bracket's
/// width (2% of the distance over a bracket of `1.3e-3` relative on the representative helix),
/// so a bound on it from the width alone would hold on one problem only. `None` without a
/// secant or a third sample with a distinct `h`.
fn secant_with_error(near: &State, far: &State, older: Option<(f64, f64)>) -> Option<(f64, f64)> {
    let z = secant_zero(near, far)?;
    let (p_older, h_older) = older?;
    // (h, p) of the three samples.
    let samples = [
        (near.tracked.re, near.p),
        (far.tracked.re, far.p),
        (h_older, p_older),
    ];
    let quadratic: f64 = (0..3)
        .map(|i| {
            let (hi, pi) = samples[i];
            let weight: f64 = (0..3)
                .filter(|&j| j != i)
                .map(|j| samples[j].0 / (samples[j].0 - hi))
                .product();
            weight * pi
        })
        .sum();
    let scale = near.p.abs();
    quadratic
        .is_finite()
        .then(|| ((z - near.p).abs() / scale, (z - quadratic).abs() / scale))
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
/// `search.unstable_stable_side`, on the side `search` says is the stable one; the state `u0`
/// is corrected at `p0` first.
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
    let beyond = |s: &State| s.spectrum.unstable > search.unstable_stable_side;
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
    let to_stable = search.stable_direction();
    let towards_other = if beyond(&first) {
        to_stable
    } else {
        -to_stable
    };
    let limit = 0.1 * p0.abs();
    let first_step = match search.slope.filter(|g| g.is_finite() && *g != 0.0) {
        Some(g) => (-first.tracked.re / g).clamp(-limit, limit),
        None => towards_other * search.first_step * p0.abs(),
    };
    let mut before = first.clone();
    // The latest sample that is neither end of the bracket, `(p, Re s)`: the third point of the
    // secant's error estimate ([`secant_with_error`]).
    let mut older: Option<(f64, f64)> = None;
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
        let towards = if beyond(&last) { to_stable } else { -to_stable };
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
        let dropped = std::mem::replace(&mut before, std::mem::replace(&mut last, next));
        older = Some((dropped.p, dropped.tracked.re));
    }
    let (mut near, mut far) = if beyond(&last) {
        (before, last)
    } else {
        (last, before)
    };
    // Brent's method inside the bracket, the sides by the unstable count, until the bracket is
    // narrower than the tolerance or the secant through its ends puts the zero within half the
    // tolerance of its near end, its estimated error included (the precision is then twice
    // their sum).
    let mut zeroin = Zeroin::new((near.p, near.tracked.re), (far.p, far.tracked.re));
    let width = |near: &State, far: &State| (far.p - near.p).abs() / near.p.abs().max(far.p.abs());
    let mut precision = width(&near, &far);
    while precision > tol {
        let predicted = secant_with_error(&near, &far, older).map(|(d, e)| d + e);
        if let Some(predicted) = predicted.filter(|&d| d <= 0.5 * tol) {
            precision = 2.0 * predicted;
            break;
        }
        let min_step = 0.25 * tol * near.p.abs();
        let proposed = zeroin.propose(min_step);
        // A quarter of the tolerance towards the near end, so that an accurate interpolation
        // samples the stable side and the search can end there; not where that would put the
        // sample within Brent's smallest step of the near end (a solve that adds nothing).
        let biased = proposed + 0.25 * tol * proposed.abs() * (near.p - proposed).signum();
        let p = if (biased - near.p) * (far.p - near.p).signum() >= min_step {
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
        let replaced = if side {
            std::mem::replace(&mut far, sample)
        } else {
            std::mem::replace(&mut near, sample)
        };
        older = Some((replaced.p, replaced.tracked.re));
        precision = width(&near, &far);
    }
    let eigenvalue = crossing_eigenvalue(&near.spectrum, &far.spectrum);
    let at = if near.tracked.re.abs() <= far.tracked.re.abs() {
        &near
    } else {
        &far
    };
    let crossed = far.spectrum.unstable - near.spectrum.unstable;
    let (before, after) = if search.regain {
        (&far, &near)
    } else {
        (&near, &far)
    };
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
        unstable_before: before.spectrum.unstable,
        unstable_after: after.spectrum.unstable,
        spectrum: at.spectrum.clone(),
    };
    Ok(Crossing {
        event,
        near,
        first,
        evaluations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::engine::stability::Solver;

    /// A sample of `h(p) = (p - 1) + c (p - 1)^2` at `p`.
    fn sample(p: f64, c: f64) -> State {
        let x = p - 1.0;
        State {
            p,
            u: Vec::new(),
            spectrum: Spectrum {
                leading: Vec::new(),
                unstable: 0,
                solver: Solver::Dense,
            },
            tracked: c64::new(x + c * x * x, 1.0),
        }
    }

    /// On a real part that bends (`h = x + c x^2`, zero at `p = 1`), the secant's error over a
    /// bracket is estimated by the inverse quadratic through a third sample: to 0.1% and 4% over
    /// brackets of 1e-3 and 1e-2 (secant errors 4.2e-8 and 2.1e-5 relative), to a factor two over
    /// a bracket of 0.1 bent by 20% (4.0e-3, estimated 2.1e-3), where the terms beyond the
    /// quadratic's count. The precision stated from it, twice the distance plus the error,
    /// covers the distance from the near end to the zero in each. With no bend the estimate is
    /// zero to round-off.
    #[test]
    fn the_secant_error_is_estimated_by_the_inverse_quadratic() {
        for (width, c, within) in [(1e-3, 0.2, 0.01), (1e-2, 1.0, 0.1), (1e-1, 2.0, 0.5)] {
            let (near, far) = (sample(1.0 - 0.3 * width, c), sample(1.0 + 0.7 * width, c));
            let older = sample(1.0 + 2.0 * width, c);
            let (d, e) = secant_with_error(&near, &far, Some((older.p, older.tracked.re)))
                .expect("a bracket and a third sample");
            let z = secant_zero(&near, &far).unwrap();
            let truth = (z - 1.0).abs() / near.p;
            assert!((d - (z - near.p).abs() / near.p).abs() < 1e-15, "{d}");
            assert!(
                (e - truth).abs() < within * truth,
                "width {width}: estimated {e:.3e}, true {truth:.3e}"
            );
            assert!(2.0 * (d + e) >= (1.0 - near.p) / near.p, "width {width}");
        }
        let (near, far) = (sample(0.999, 0.0), sample(1.001, 0.0));
        let (_, e) = secant_with_error(&near, &far, Some((1.003, 0.003))).unwrap();
        assert!(e < 1e-15, "{e}");
        assert!(secant_with_error(&near, &far, None).is_none());
    }
}

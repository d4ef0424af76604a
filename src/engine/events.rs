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
//! Between the points `a` and `b` the branch is sampled at arclength `sigma` from `a` (predicted
//! by interpolating between the two states of the step nearest to `sigma`, corrected on the
//! hyperplane normal to `a`'s tangent). The bracket of an event is kept by a robust test, not by the sign
//! of an interpolated function: a sample lies beyond the event when its unstable count differs
//! from the count at the bracket's lower end (a crossing), or when its tangent has turned (a
//! fold). Brent's method ([`Zeroin`]: inverse quadratic interpolation, secant, bisection) on a
//! continuous, signed test function (the real part of the crossing eigenvalue, followed from
//! sample to sample as the nearest one, or the `p` part of the tangent) only proposes where to
//! sample next, the sign of each value taken from its side. So the final bracket always
//! contains the change of the count, even where the nearest-eigenvalue tracking jumps between
//! two pairs.
//!
//! The search stops when the bracket in the parameter is narrower than
//! `event_tol * max(|p|, 1e-6 P)` (relative, `P` the parameter scale only guarding `p = 0`) and
//! the bracket in arclength narrower than `sqrt(event_tol)` times the step (near a fold `p` is
//! quadratic in the arclength, so a narrow bracket in `p` alone says nothing). It also stops,
//! short of the tolerance in `p`, when the bracket in arclength is narrower than twice the
//! closest a sample may come to its ends: no sample can narrow it further, which on a smooth
//! branch cannot happen before the tolerance is met, but does where `p` jumps between two
//! samples a hair apart (next to a branch point the corrector may land on the other branch).
//! The event's precision is then the width reached, larger than `event_tol`, and says so.
//!
//! A crossing event is typed by the eigenvalue that crossed inside its final bracket (the one
//! unstable on one side whose nearest eigenvalue on the other side is stable), never by
//! whichever eigenvalue lies nearest the axis elsewhere. Several crossings in one step (a branch
//! point and a Hopf point close together) are located one after the other, each from the far
//! side of the one before, and all are reported.

use std::cell::RefCell;

use faer::c64;

use super::arclength::{Metric, Point, correct, stability};
use super::stability::{Spectrum, is_complex};
use super::{ContinuationSettings, Problem};
use crate::Result;

/// The kind of an event. The engine's kinds are named in snake case ([`EventKind::name`]; the
/// names in files, pinned by the boundary's round-trip test), parsed from their names by
/// `str::parse`, and listed by `EventKind::iter()` (strum's derives; a caller's own kind,
/// `User`, is named by its payload and neither parsed nor listed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, strum::EnumIter, strum::EnumString)]
#[strum(serialize_all = "snake_case")]
pub enum EventKind {
    Fold,
    BranchPoint,
    Hopf,
    /// Two modes crossed the axis in opposite directions within the event tolerance.
    ModeExchange,
    /// An event of a caller's own [`super::arclength::Detector`], by its name.
    #[strum(disabled)]
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

/// Brent's method ("zeroin", Brent 1973, ch. 4) for the zero of a scalar function inside a
/// bracket: inverse quadratic interpolation through the last three values, or the secant
/// through the last two, where that shrinks the bracket fast enough; bisection where not. Its
/// order on a smooth function is about 1.84 (the secant's 1.62, Illinois' 1.44), and it never
/// takes more than about the square of bisection's count.
///
/// The caller samples where [`Zeroin::propose`] says and tells it the value and the side
/// ([`Zeroin::record`]): the side comes from the caller's own robust test (the unstable count),
/// and a value whose sign disagrees with it (an eigenvalue tracked to the wrong mode) is taken
/// with the sign of the side, so the interpolation only ever proposes inside the bracket.
/// Ending the search is the caller's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Zeroin {
    /// `(x, f)`: the end `b` of smaller `|f|`, the other end `c` (the sign of `f` differs),
    /// and `a`, the `b` before the last sample.
    a: (f64, f64),
    b: (f64, f64),
    c: (f64, f64),
    /// The last step from `b`, and the one before.
    d: f64,
    e: f64,
}

impl Zeroin {
    /// The search between `(x0, f0)` and `(x1, f1)`, whose values have opposite signs (`f0 <= 0`
    /// on the near side, `f1 > 0` beyond, with the signs of the sides forced as in
    /// [`Zeroin::record`]).
    pub(crate) fn new(near: (f64, f64), beyond: (f64, f64)) -> Self {
        let near = (near.0, signed(near.1, false));
        let beyond = (beyond.0, signed(beyond.1, true));
        let mut z = Zeroin {
            a: near,
            b: beyond,
            c: near,
            d: beyond.0 - near.0,
            e: beyond.0 - near.0,
        };
        z.order();
        z
    }

    /// Whether the bracket's ends carry the values `near` (the side before the zero) and `far`
    /// (beyond it): false when the function has changed under the search.
    pub(crate) fn holds(&self, near: (f64, f64), far: (f64, f64)) -> bool {
        let ends = [self.b, self.c];
        let has = |(x, f): (f64, f64), beyond: bool| ends.contains(&(x, signed(f, beyond)));
        has(near, false) && has(far, true)
    }

    /// Makes `b` the end of smaller `|f|`.
    fn order(&mut self) {
        if self.c.1.abs() < self.b.1.abs() {
            self.a = self.b;
            self.b = self.c;
            self.c = self.a;
        }
    }

    /// Where to sample next: at least `min_step` from `b` (towards `c`), so that a zero found
    /// to within `min_step` is closed off by one sample beside it.
    pub(crate) fn propose(&mut self, min_step: f64) -> f64 {
        let ((a, fa), (b, fb), (c, fc)) = (self.a, self.b, self.c);
        let xm = 0.5 * (c - b);
        let bisect = if self.e.abs() >= min_step && fa.abs() > fb.abs() {
            let s = fb / fa;
            let (mut p, mut q) = if a == c {
                // Secant through b and a.
                (2.0 * xm * s, 1.0 - s)
            } else {
                // Inverse quadratic interpolation through a, b and c.
                let (q, r) = (fa / fc, fb / fc);
                (
                    s * (2.0 * xm * q * (q - r) - (b - a) * (r - 1.0)),
                    (q - 1.0) * (r - 1.0) * (s - 1.0),
                )
            };
            if p > 0.0 {
                q = -q;
            } else {
                p = -p;
            }
            // Accepted only inside the bracket and shorter than half the step before last.
            if 2.0 * p < 3.0 * xm * q - (min_step * q).abs() && p < (0.5 * self.e * q).abs() {
                self.e = self.d;
                self.d = p / q;
                false
            } else {
                true
            }
        } else {
            true
        };
        if bisect {
            self.d = xm;
            self.e = xm;
        }
        b + if self.d.abs() > min_step {
            self.d
        } else {
            min_step.copysign(xm)
        }
    }

    /// The value `f` at the sample `x` proposed last, on the far side of the zero when
    /// `beyond` (its sign forced to that side's).
    pub(crate) fn record(&mut self, x: f64, f: f64, beyond: bool) {
        self.a = self.b;
        self.b = (x, signed(f, beyond));
        if (self.b.1 > 0.0) == (self.c.1 > 0.0) {
            self.c = self.a;
            self.d = x - self.a.0;
            self.e = self.d;
        }
        self.order();
    }
}

/// `|f|` with the sign of the side: positive beyond the zero, negative before it (never zero).
fn signed(f: f64, beyond: bool) -> f64 {
    let magnitude = if f.is_finite() {
        f.abs().max(f64::MIN_POSITIVE)
    } else {
        f64::MAX
    };
    if beyond { magnitude } else { -magnitude }
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
    /// `(sigma, u, p)` of `a`, `b` and every sample so far: the predictor's support.
    states: RefCell<Vec<(f64, Vec<f64>, f64)>>,
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
            states: RefCell::new(vec![(0.0, a.u.clone(), a.p), (b.s - a.s, b.u.clone(), b.p)]),
        }
    }

    /// The branch at arclength `sigma` from `a`, corrected on the hyperplane normal to `a`'s
    /// tangent. Predicted along `a`'s tangent for the first sample of the step, then
    /// interpolated ([`Problem::interpolate`]) between the two states of the step nearest to
    /// `sigma` (`a`, `b` and the samples so far): as the samples close in on an event the
    /// prediction comes within the square of their spacing of the branch, and the corrector
    /// has one step left to take.
    fn at(&self, sigma: f64) -> Result<Sample> {
        let a = self.a;
        let (predicted, p) = {
            let states = self.states.borrow();
            let mut near: Vec<&(f64, Vec<f64>, f64)> = states.iter().collect();
            near.sort_by(|x, y| (x.0 - sigma).abs().total_cmp(&(y.0 - sigma).abs()));
            if states.len() > 2 && near[0].0 != near[1].0 {
                let ((s0, u0, p0), (s1, u1, p1)) = (near[0], near[1]);
                let w = (sigma - s0) / (s1 - s0);
                (self.problem.interpolate(u0, u1, w), p0 + w * (p1 - p0))
            } else {
                let step: Vec<f64> = a.tangent_u.iter().map(|t| sigma * t).collect();
                (self.problem.retract(&a.u, &step), a.p + sigma * a.tangent_p)
            }
        };
        let c = correct(
            self.problem,
            predicted,
            p,
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
        self.states.borrow_mut().push((sigma, c.u.clone(), c.p));
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
    /// are one event of multiplicity two, not two events in an order set by round-off. Its
    /// multiplicity is the net change of the count across the merged crossings (in pairs for a
    /// Hopf point), at least one: round-off may make the count step back and forth between
    /// samples within the tolerance of a double crossing (0, 1, 0, 2), which is still one
    /// crossing of two eigenvalues.
    fn push(&self, events: &mut Vec<Event>, event: Event) {
        if let Some(last) = events.last_mut()
            && last.kind == event.kind
            && (event.p - last.p).abs() <= self.p_tol(last.p)
        {
            let net = last.unstable_before.abs_diff(event.unstable_after);
            last.multiplicity = if last.kind == EventKind::Hopf {
                net.div_ceil(2)
            } else {
                net
            }
            .max(1);
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
    /// `f` is negative on `lo`'s side when the tracking is sound; Brent's method on it
    /// ([`Zeroin`]) proposes the next sample. `f` may depend on the bracket (the crossing
    /// eigenvalue is identified afresh in each one): where its values at the ends change with a
    /// new bracket, the search restarts from the ends with the new values.
    fn bracket(
        &self,
        mut lo: Sample,
        mut hi: Sample,
        beyond: impl Fn(&Sample) -> bool,
        f: impl Fn(&Sample, &Sample, &Sample) -> f64,
    ) -> Result<(Sample, Sample)> {
        let ends =
            |lo: &Sample, hi: &Sample| ((lo.sigma, f(lo, lo, hi)), (hi.sigma, f(hi, lo, hi)));
        let (near, far) = ends(&lo, &hi);
        let mut zeroin = Zeroin::new(near, far);
        let mut iterations = 0;
        while !self.converged(&lo, &hi) {
            iterations += 1;
            if iterations > 200 {
                return Err(crate::Error::Numerical(format!(
                    "event not resolved to {:e} within 200 samples (bracket p in [{}, {}])",
                    self.settings.event_tol, lo.p, hi.p
                )));
            }
            // Ends closer in arclength than a sample may come to either: no sample can narrow
            // the bracket. On a smooth branch that width is below the tolerance in `p` (the
            // margin is a third of it through the tangent), so this happens only where `p` jumps
            // between the ends, the corrector landing on another branch next to a branch point
            // (seen on Greenhill's column, whose two bending planes buckle together). The event
            // then carries the width it has as its precision.
            let margin = self.margin(&lo);
            if (hi.sigma - lo.sigma).abs() <= 2.0 * margin {
                break;
            }
            let (near, far) = ends(&lo, &hi);
            if !zeroin.holds(near, far) {
                zeroin = Zeroin::new(near, far);
            }
            let sigma = zeroin.propose(margin);
            let s = self.at(sigma)?;
            let past = beyond(&s);
            zeroin.record(sigma, f(&s, &lo, &hi), past);
            if past {
                hi = s;
            } else {
                lo = s;
            }
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

    /// The event at the final secant estimate of the root inside `[lo, hi]`: a new sample
    /// there, or the end of the bracket nearest to it when that lies within a hundredth of the
    /// tolerance of it in `p` (Brent's last sample usually does: the secant converges
    /// superlinearly, and a sample closer to the root would change the event by less than its
    /// stated precision, for the cost of a corrector and a spectrum).
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
        let w = (sigma - lo.sigma) / (hi.sigma - lo.sigma);
        let p_root = lo.p + w * (hi.p - lo.p);
        let nearest = if w <= 0.5 { lo } else { hi };
        let best = if (nearest.p - p_root).abs() <= 1e-2 * self.p_tol(p_root) {
            nearest.clone()
        } else {
            self.at(sigma)?
        };
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

//! The special points of a Hopf curve and how each is pinned down between two points of the
//! curve (see the module doc of [`super`]): double Hopf and zero-Hopf points (Brent's method on
//! the eigenvalue that crossed), generalized Hopf points (Brent's method on `l1`), turning points
//! (successive parabolic interpolation) and Bogdanov-Takens points (the secant zero of `w^2`).
//! Every sample is a point of the curve, corrected by [`super::corrector`].
//!
//! Their kinds are kept apart from the events of a branch ([`crate::engine::events::EventKind`])
//! and of an orbit branch: these are points of codimension two on a curve of Hopf points, found
//! by tests on the curve, not crossings on a branch of equilibria.

use std::rc::Rc;

use faer::c64;

use super::corrector::{At, Corrected, REACH, Step, Tracer};
use super::tracked::others;
use super::{CurvePoint, Family};
use crate::engine::criticality::{Lyapunov, Verdict};
use crate::engine::events::{Zeroin, crossing_eigenvalue};
use crate::engine::stability::{Spectrum, is_complex};
use crate::{Error, Result};

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
pub(super) fn locate_codim2<F: Family>(
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
    let crossing = |l: &Spectrum, h: &Spectrum| crossing_eigenvalue(l, h);
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
pub(super) fn resolved_signs_differ(a: &Lyapunov, b: &Lyapunov) -> bool {
    let known = |l: &Lyapunov| l.verdict != Verdict::Undetermined;
    known(a) && known(b) && a.verdict != b.verdict
}

/// Pins down the zero of the first Lyapunov coefficient between `last` (`sigma = 0`) and `new`
/// (`sigma = sigma_new`), whose signs differ, by Brent's method on `l1`,
/// each sample a corrected point of the curve with its coefficient. It ends when the bracket is
/// within `event_tol` or when a sample's `|l1|` is within its precision (the zero is then known
/// as well as `l1` is); the precision reported is the bracket's width, or the precision of `l1`
/// over its slope along the curve when that is smaller.
pub(super) fn locate_generalized_hopf<F: Family>(
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
pub(super) fn locate_turning<F: Family>(
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
pub(super) fn locate_bogdanov_takens<F: Family>(
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

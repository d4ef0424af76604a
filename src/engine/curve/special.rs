//! The special points of a Hopf curve and how each is pinned down between two points of the
//! curve (see the module doc of [`super`]): double Hopf and zero-Hopf points (Brent's method on
//! the eigenvalue that crossed), generalized Hopf points (Brent's method on `l1`), turning points
//! (successive parabolic interpolation) and Bogdanov-Takens points (Brent's method on `w^2`
//! continued through zero).
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
use crate::engine::criticality::Verdict;
use crate::engine::events::{Zeroin, crossing_eigenvalue};
use crate::engine::stability::{Spectrum, is_complex};
use crate::{Error, Result};

/// What a special point of the curve is. Its name in files is the variant's in snake case
/// (`double_hopf`, ...; [`SpecialKind::name`], parsed by `str::parse`), and
/// `SpecialKind::iter()` lists every kind (strum's derives).
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, strum::EnumIter, strum::IntoStaticStr, strum::EnumString,
)]
#[strum(serialize_all = "snake_case")]
pub enum SpecialKind {
    /// A second complex pair on the imaginary axis.
    DoubleHopf,
    /// A real eigenvalue at zero (fold-Hopf).
    ZeroHopf,
    /// The curve turns back in `q`.
    Turning,
    /// The tracked pair meets on the real axis at zero: the Hopf curve ends (its point carries
    /// no Lyapunov coefficient, which is not defined where the frequency vanishes).
    BogdanovTakens,
    /// The first Lyapunov coefficient changes sign (Bautin point).
    GeneralizedHopf,
}

impl SpecialKind {
    /// The name used in files.
    pub fn name(self) -> &'static str {
        self.into()
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

/// The zero of `l1` in a step where its value changed sign ([`locate_generalized_hopf`]), and
/// where the samples nearest it on either side whose sign is resolved (`|l1|` above its
/// precision) lie: as fractions of the step, `None` on a side where no sample inside the step
/// is, so that the zero is known only to the nearest resolved point of the curve beyond it.
pub(super) struct SignChange<M> {
    pub special: Special,
    pub member: Rc<M>,
    pub resolved: (Option<f64>, Option<f64>),
}

impl<M> SignChange<M> {
    /// The resolved samples' fractions of the step as arclengths, the step running from
    /// `start` over `length` along the curve.
    pub(super) fn along(mut self, start: f64, length: f64) -> Self {
        let at = |f: Option<f64>| f.map(|f| start + f * length);
        self.resolved = (at(self.resolved.0), at(self.resolved.1));
        self
    }

    /// The generalized Hopf point, its precision the distance along the curve between the
    /// resolved samples on either side ([`SignChange::along`]), or where the step has none on a
    /// side, the curve's resolved points `before` and `after` it (arclengths).
    pub(super) fn settled(mut self, before: f64, after: f64) -> (Special, Rc<M>) {
        let (lo, hi) = (
            self.resolved.0.unwrap_or(before),
            self.resolved.1.unwrap_or(after),
        );
        self.special.precision = hi - lo;
        self.special.point.precision = hi - lo;
        (self.special, self.member)
    }
}

/// Pins down the zero of the first Lyapunov coefficient between `last` (`sigma = 0`) and `new`
/// (`sigma = sigma_new`), where its value changes sign, by Brent's method on `l1`, each sample
/// a corrected point of the curve with its coefficient. It ends when the bracket is within
/// `event_tol` or when a sample's `|l1|` is within its precision (the zero is then known as well
/// as `l1` is): the point is that sample, or the end of the bracket with the smaller `|l1|`, and
/// the zero lies between the samples nearest it whose signs are resolved ([`SignChange`]; the
/// ends of the step count where their signs are resolved).
pub(super) fn locate_generalized_hopf<F: Family>(
    tracer: &Tracer<'_, F>,
    last: &At<F::Member>,
    new: &At<F::Member>,
    step: &Step,
    sigma_new: f64,
    s_last: f64,
) -> Result<SignChange<F::Member>> {
    let l1 = |at: &At<F::Member>| at.lyapunov.as_ref().map_or(f64::NAN, |l| l.l1);
    let resolved = |at: &At<F::Member>| {
        at.lyapunov
            .as_ref()
            .is_some_and(|l| l.verdict != Verdict::Undetermined)
    };
    // Oriented so that f < 0 at `last`.
    let sign = if l1(last) < 0.0 { 1.0 } else { -1.0 };
    let mut bounds = (
        resolved(last).then_some(0.0),
        resolved(new).then_some(sigma_new),
    );
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
            bounds.1 = Some(sigma);
            hi = (sigma, at);
        } else {
            bounds.0 = Some(sigma);
            lo = (sigma, at);
        }
    }
    let (sigma, at) = best.unwrap_or_else(|| {
        if l1(&lo.1).abs() <= l1(&hi.1).abs() {
            lo
        } else {
            hi
        }
    });
    // The precision is set once the resolved points on either side are known
    // ([`SignChange::settled`]).
    let special = Special {
        kind: SpecialKind::GeneralizedHopf,
        point: at.point(s_last + sigma, f64::NAN, 0),
        other: at.eigenvalue,
        gains: false,
        precision: f64::NAN,
    };
    let fraction = |b: Option<f64>| b.map(|b| b / sigma_new);
    Ok(SignChange {
        special,
        member: at.member,
        resolved: (fraction(bounds.0), fraction(bounds.1)),
    })
}

/// The turning point of the curve in `q` near `last`: the extremum of `q(p)` along the curve
/// (which crosses every line `p = const` near it transversally), by successive parabolic
/// interpolation through `before` (the point before `last`, `(p, q)`), `last` and `new`, each
/// new sample the curve's point at the parabola's vertex `p*` (corrected at fixed `p`). In the
/// first step of a curve there is no point before `last`: the curve's point halfway between
/// `last` and `new` in `p` stands in for it. It stops when `p*` moves by less than
/// `sqrt(event_tol)` in the units of (2): `q` is then known to about `event_tol`, since it is
/// stationary there.
pub(super) fn locate_turning<F: Family>(
    tracer: &Tracer<'_, F>,
    before: Option<(f64, f64)>,
    last: &At<F::Member>,
    new: &At<F::Member>,
    p_unit: f64,
    s_last: f64,
) -> Result<(Special, Rc<F::Member>)> {
    let mut evaluations = 0;
    let mut solved = vec![last.clone(), new.clone()];
    let a = match before {
        Some(a) => a,
        None => {
            let p = 0.5 * (last.p + new.p);
            let halfway = on_vertical(tracer, last, (p, 0.5 * (last.q + new.q)), p_unit)?;
            evaluations += halfway.evaluations;
            solved.push(halfway.at);
            (solved[2].p, solved[2].q)
        }
    };
    // The three latest samples (p, q), and the solved state nearest the vertex: the one with
    // the extreme `q` (the largest where the curve turns back down in `q`).
    let mut samples = [a, (last.p, last.q), (new.p, new.q)];
    let down = parabola(samples)?.2 < 0.0;
    let mut best = solved
        .into_iter()
        .max_by(|x, y| {
            if down {
                x.q.total_cmp(&y.q)
            } else {
                y.q.total_cmp(&x.q)
            }
        })
        .expect("two solved states at least");
    let mut precision = 0.0;
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
        let (p_star, q_star, _) = parabola(samples)?;
        moved = (p_star - best.p).abs() / p_unit;
        let c = on_vertical(tracer, &best, (p_star, q_star), p_unit)?;
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

/// Whether the parabola `q(p)` through `last` with the slope `dq/dp = slope` there and through
/// `new` (each `(p, q)`) has its vertex strictly inside the step from `last` to `new`: `q` turns
/// back within the step (next to a turning point the curve is the parabola
/// `q - q_t ~ (p - p_t)^2`), even where it comes back short of the last point's `q`.
pub(super) fn vertex_in_step(slope: f64, last: (f64, f64), new: (f64, f64)) -> bool {
    let h = new.0 - last.0;
    let a = (new.1 - last.1 - slope * h) / (h * h);
    let x = -slope / (2.0 * a) / h;
    x.is_finite() && 0.0 < x && x < 1.0
}

/// The slope `dq/dp` at `last` of the parabola `q(p)` through `before`, `last` and `new` (each
/// `(p, q)`).
pub(super) fn slope_through(before: (f64, f64), last: (f64, f64), new: (f64, f64)) -> f64 {
    let (d01, curvature) = divided_differences([before, last, new]);
    d01 + curvature * (last.0 - before.0)
}

/// The divided differences of `q(p)` over three samples `(p, q)`: the first over the first two,
/// `d01`, and the second, `curvature = d2q/dp2 / 2` of the parabola through them, which is
/// `q0 + d01 (p - p0) + curvature (p - p0) (p - p1)`.
fn divided_differences(samples: [(f64, f64); 3]) -> (f64, f64) {
    let [(p0, q0), (p1, q1), (p2, q2)] = samples;
    let d01 = (q1 - q0) / (p1 - p0);
    let d12 = (q2 - q1) / (p2 - p1);
    (d01, (d12 - d01) / (p2 - p0))
}

/// The vertex `(p*, q*)` of the parabola `q(p)` through three samples `(p, q)`, and its
/// curvature `d2q/dp2 / 2`.
fn parabola(samples: [(f64, f64); 3]) -> Result<(f64, f64, f64)> {
    let [(p0, q0), (p1, _), _] = samples;
    let (d01, curvature) = divided_differences(samples);
    let p_star = 0.5 * (p0 + p1) - 0.5 * d01 / curvature;
    let q_star = q0 + d01 * (p_star - p0) + curvature * (p_star - p0) * (p_star - p1);
    if !(p_star.is_finite() && q_star.is_finite()) {
        return Err(Error::Numerical(
            "no parabola through the samples near a turning point".into(),
        ));
    }
    Ok((p_star, q_star, curvature))
}

/// The curve's point on the line at `p` (the corrector started at `(p, q)`, from the state of
/// `from`), which the curve crosses transversally near a turning point in `q`.
fn on_vertical<F: Family>(
    tracer: &Tracer<'_, F>,
    from: &At<F::Member>,
    (p, q): (f64, f64),
    p_unit: f64,
) -> Result<Corrected<F::Member>> {
    let step = Step {
        p0: p,
        q0: q,
        p_unit,
        t: (1.0, 0.0),
        n: (0.0, 1.0),
        pair: false,
    };
    tracer.correct(from, &step, 0.0, None, None, from.eigenvalue, 1.0)
}

/// The Bogdanov-Takens point within the step from `last` (`sigma = 0` on `step`) to
/// `sigma_new`, where the tracked pair meets on the real axis. The curve `h = 0` of (3)
/// ([`super::tracked::critical_pair`]) goes on through the point as a curve of neutral saddles,
/// and `w2` of (3) (`w^2` on the Hopf side) changes sign there, transversally: the point is the
/// zero of `w2` along that curve. The search samples it on the step's line, each sample a
/// point of the curve `h = 0` (pair mode of the corrector, which does not fail where the pair
/// turns real), nine tenths of the way from the last sample on the Hopf side to the predicted
/// zero, or at the predicted zero once a sample past the point brackets it; a sample that
/// cannot be solved is retried nearer the last. The prediction is the zero of the parabola in
/// `sigma` through the three samples nearest it (a secant through two at first). Near the point
/// the equilibrium exists only in a sliver about the curve that narrows quadratically (a fold
/// of the equilibria is tangent to the curve there) and its state is conditioned like `1 /
/// |w2|`, so the samples cannot reach it; the parabola, exact to third order, carries the last
/// `O(sigma)` in between. The search ends when the predicted zero lies within `event_tol` of a
/// sample or of the bracket, or when no nearer sample can be solved. The point is that zero:
/// its `p`, `q` and state interpolated on the same parabola (the state the member's own there,
/// to the order of the fit, not the last sample's); its precision the change of the predicted
/// zero from the parabola through the next three samples (the distance to the nearest sample
/// where that is smaller: the prediction is only needed beyond it). It carries no Lyapunov
/// coefficient: (1) of [`crate::engine::criticality`] divides by `w`, which vanishes there, and
/// the orbits born near the point are governed by the quadratic coefficients of the
/// Bogdanov-Takens normal form, not by `l1`.
pub(super) fn locate_bogdanov_takens<F: Family>(
    tracer: &Tracer<'_, F>,
    last: &At<F::Member>,
    step: &Step,
    sigma_new: f64,
    s_last: f64,
    slope: Option<f64>,
) -> Result<(Special, Rc<F::Member>)> {
    let line = Step {
        pair: true,
        ..*step
    };
    let mut slope = slope;
    let tol = tracer.continuation.event_tol;
    let mut samples: Vec<(f64, At<F::Member>)> = vec![(0.0, last.clone())];
    let mut evaluations = 0;
    // The first sample at the end of the failed step, then as predicted.
    let mut sigma = sigma_new;
    let mut fraction: f64 = 1.0;
    for _ in 0..200 {
        let from = samples
            .iter()
            .min_by(|a, b| (a.0 - sigma).abs().total_cmp(&(b.0 - sigma).abs()))
            .expect("a sample");
        let reach = REACH * (sigma - from.0).abs().max(tol);
        match tracer.correct(&from.1, &line, sigma, None, slope, from.1.eigenvalue, reach) {
            Ok(c) => {
                evaluations += c.evaluations;
                slope = Some(c.slope);
                samples.push((sigma, c.at));
                fraction = 0.9;
            }
            Err(_) => fraction *= 0.5,
        }
        // The last sample on the Hopf side, the first past the point.
        let lo = samples
            .iter()
            .filter(|s| s.1.w2 > 0.0)
            .map(|s| s.0)
            .fold(f64::NEG_INFINITY, f64::max);
        let hi = samples
            .iter()
            .filter(|s| s.1.w2 <= 0.0)
            .map(|s| s.0)
            .fold(f64::INFINITY, f64::min);
        if samples.len() < 2 {
            if fraction < 1e-3 {
                return Err(Error::Numerical(
                    "no point of the curve could be solved ahead of the last one".into(),
                ));
            }
            sigma = fraction * sigma_new;
            continue;
        }
        // Ahead of the last sample on the Hopf side, and within the step's reach when nothing
        // brackets it yet (else the pair turned real only off the curve: a shorter step).
        let zero = predicted_zero(&samples, lo)
            .filter(|&z| z > lo && (hi.is_finite() || z - lo <= 2.0 * sigma_new))
            .ok_or_else(|| {
                Error::Numerical(
                    "the pair turned real, but w^2 does not fall to zero ahead within the step"
                        .into(),
                )
            })?;
        let nearest = samples
            .iter()
            .map(|s| (s.0 - zero).abs())
            .fold(f64::INFINITY, f64::min);
        if nearest <= tol || hi - lo <= tol || fraction < 1e-3 {
            break;
        }
        sigma = if hi.is_finite() {
            zero.clamp(lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo))
        } else {
            lo + fraction * (zero - lo)
        };
    }
    let lo = samples
        .iter()
        .filter(|s| s.1.w2 > 0.0)
        .map(|s| s.0)
        .fold(f64::NEG_INFINITY, f64::max);
    let zero = predicted_zero(&samples, lo).ok_or_else(|| {
        Error::Numerical("the pair turned real, but w^2 does not fall towards zero ahead".into())
    })?;
    samples.sort_by(|a, b| (a.0 - zero).abs().total_cmp(&(b.0 - zero).abs()));
    let nearest = (samples[0].0 - zero).abs();
    // The prediction from the next three samples, where there are as many.
    let other = (samples.len() >= 4)
        .then(|| parabola_zero(&samples[1..4], zero))
        .flatten();
    let precision = match other {
        Some(z) => (z - zero).abs().min(nearest.max(tol)),
        None => nearest.max(tol),
    };
    let fit = &samples[..samples.len().min(3)];
    let at = &fit[0].1;
    let mut point = at.point(s_last + zero, precision, evaluations);
    point.p = lagrange(fit, zero, |a| a.p);
    point.q = lagrange(fit, zero, |a| a.q);
    point.u = (0..at.u.len())
        .map(|i| lagrange(fit, zero, |a| a.u[i]))
        .collect();
    point.eigenvalue = c64::new(lagrange(fit, zero, |a| a.eigenvalue.re), 0.0);
    point.lyapunov = None;
    let special = Special {
        kind: SpecialKind::BogdanovTakens,
        point,
        other: c64::new(0.0, 0.0),
        gains: false,
        precision,
    };
    Ok((special, fit[0].1.member.clone()))
}

/// The zero of `w2` ahead of `lo` predicted from the samples: the parabola through the three
/// nearest to the secant zero of the two nearest `lo` (that secant where there are only two).
fn predicted_zero<M>(samples: &[(f64, At<M>)], lo: f64) -> Option<f64> {
    let by = |x: f64| {
        let mut sorted: Vec<&(f64, At<M>)> = samples.iter().collect();
        sorted.sort_by(|a, b| (a.0 - x).abs().total_cmp(&(b.0 - x).abs()));
        sorted
    };
    let near = by(lo);
    if near.len() < 2 {
        return None;
    }
    let (a, b) = (near[0], near[1]);
    let secant = a.0 - a.1.w2 * (a.0 - b.0) / (a.1.w2 - b.1.w2);
    if !secant.is_finite() {
        return None;
    }
    let near = by(secant);
    if near.len() < 3 {
        return Some(secant);
    }
    let three: Vec<(f64, At<M>)> = near[..3].iter().map(|s| (s.0, s.1.clone())).collect();
    parabola_zero(&three, secant).or(Some(secant))
}

/// The zero nearest `guess` of the parabola through `(sigma, w2)` of three samples, by
/// Newton's method from `guess`.
fn parabola_zero<M>(three: &[(f64, At<M>)], guess: f64) -> Option<f64> {
    let w2 = |x: f64| lagrange(three, x, |a| a.w2);
    let mut x = guess;
    for _ in 0..50 {
        let d = 1e-7 * (three[0].0 - three[2].0).abs().max(f64::MIN_POSITIVE);
        let slope = (w2(x + d) - w2(x - d)) / (2.0 * d);
        let dx = w2(x) / slope;
        if !dx.is_finite() {
            return None;
        }
        x -= dx;
        if dx.abs() <= 1e-15 * (1.0 + x.abs()) {
            break;
        }
    }
    x.is_finite().then_some(x)
}

/// The Lagrange polynomial through `(sigma, value(at))` of `nodes`, at `x`.
fn lagrange<M>(nodes: &[(f64, At<M>)], x: f64, value: impl Fn(&At<M>) -> f64) -> f64 {
    (0..nodes.len())
        .map(|i| {
            let weight: f64 = (0..nodes.len())
                .filter(|&j| j != i)
                .map(|j| (x - nodes[j].0) / (nodes[i].0 - nodes[j].0))
                .product();
            weight * value(&nodes[i].1)
        })
        .sum()
}

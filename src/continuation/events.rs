//! Events on a branch, pinned down between two consecutive points.
//!
//! * **fold**: the branch turns back in the parameter (the `p` part of the tangent changes
//!   sign); a real eigenvalue crosses zero there;
//! * **branch point**: a real eigenvalue crosses zero while the parameter goes on;
//! * **Hopf point**: a complex pair crosses the imaginary axis.
//!
//! Between the points `a` and `b` the branch is sampled at arclength `sigma` from `a` (predictor
//! along `a`'s tangent, corrector on the hyperplane) and the root of a scalar function is found by
//! the Illinois variant of regula falsi: the `p` part of the tangent for a fold, the real part of
//! the crossing eigenvalue (followed from sample to sample as the nearest one) otherwise. The
//! search stops when the bracket in the parameter is narrower than `event_tol * max(|p|, P)` (`P`
//! the parameter scale) and the bracket in arclength narrower than `sqrt(event_tol)` times the
//! step (near a fold `p` is quadratic in the arclength, so a narrow bracket in `p` alone says
//! nothing); the event is the point at the final regula falsi estimate of the root.

use faer::c64;

use super::arclength::{Metric, Point, correct, stability, tangent};
use super::stability::{Spectrum, is_complex};
use super::{ContinuationSettings, Problem};
use crate::Result;

/// The kind of an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    Fold,
    BranchPoint,
    Hopf,
}

impl EventKind {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::Fold => "fold",
            EventKind::BranchPoint => "branch_point",
            EventKind::Hopf => "hopf",
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
    /// The final bracket of the parameter, and its width relative to `max(|p|, P)`.
    pub bracket: (f64, f64),
    pub precision: f64,
    /// Number of eigenvalues that crossed together (a Hopf pair counts once).
    pub multiplicity: usize,
    /// Unstable counts at the two points around the event.
    pub unstable_before: usize,
    pub unstable_after: usize,
    /// The leading spectrum at the event.
    pub spectrum: Spectrum,
}

/// What vanishes at the event.
#[derive(Clone, Copy, Debug)]
pub enum Target {
    /// The `p` part of the tangent (a fold).
    Turning,
    /// The real part of the eigenvalue that crossed (given at `b`).
    Crossing(c64),
}

/// The eigenvalue that crossed between spectra `a` and `b`: an unstable eigenvalue of the side
/// with more of them whose nearest eigenvalue on the other side is stable (the one closest to
/// the axis if several; the member with `Im >= 0` of a pair).
pub fn crossing_eigenvalue(a: &Spectrum, b: &Spectrum) -> c64 {
    let (more, less) = if b.unstable > a.unstable {
        (b, a)
    } else {
        (a, b)
    };
    let unstable = &more.leading[..more.unstable];
    let crossed = unstable
        .iter()
        .filter(|s| less.nearest(**s).re <= 0.0)
        .min_by(|x, y| x.re.total_cmp(&y.re))
        .or_else(|| unstable.last())
        .expect("the side with more unstable eigenvalues has one");
    c64::new(crossed.re, crossed.im.abs())
}

/// One evaluation inside the bracket.
struct Sample {
    sigma: f64,
    u: Vec<f64>,
    p: f64,
    /// The tracked eigenvalue (imaginary part made non-negative).
    value: c64,
    tangent_p: f64,
    spectrum: Spectrum,
}

/// Pins down the event of kind `target` between the consecutive points `a` and `b`.
///
/// The bracket is kept by a robust test, not by the sign of the interpolated function: a sample
/// belongs to `b`'s side when its unstable count differs from `a`'s (a crossing) or when its
/// tangent has turned (a fold). Regula falsi on the tracked eigenvalue's real part (or on the
/// tangent's `p` part) only proposes where to sample next, and bisection takes over whenever
/// its values disagree with the sides. So the final bracket always contains the change of the
/// count, even where the nearest-eigenvalue tracking jumps between two pairs.
pub fn locate(
    problem: &impl Problem,
    a: &Point,
    b: &Point,
    target: Target,
    multiplicity: usize,
    metric: &Metric,
    settings: &ContinuationSettings,
) -> Result<Event> {
    let p_scale = problem.scales().1;
    let tracked_start = match target {
        Target::Crossing(value) => value,
        Target::Turning => c64::new(0.0, 0.0),
    };
    let sample_at = |sigma: f64, tracked: c64| -> Result<Sample> {
        let step: Vec<f64> = a.tangent_u.iter().map(|t| sigma * t).collect();
        let predicted = problem.retract(&a.u, &step);
        let c = correct(
            problem,
            predicted,
            a.p + sigma * a.tangent_p,
            &a.tangent_u,
            a.tangent_p,
            metric,
            settings,
        )?;
        // Only a fold needs the tangent (next to a branch point it is ill-defined).
        let tangent_p = match target {
            Target::Turning => tangent(&c.lin, metric, &a.tangent_u, a.tangent_p)?.1,
            Target::Crossing(_) => a.tangent_p,
        };
        let spectrum = stability(problem, &c.u, c.p, &c.lin, settings.eigenvalues)?;
        let value = spectrum.nearest(tracked);
        Ok(Sample {
            sigma,
            u: c.u,
            p: c.p,
            value: c64::new(value.re, value.im.abs()),
            tangent_p,
            spectrum,
        })
    };
    let from_point = |point: &Point, sigma: f64, tracked: c64| {
        let value = point.spectrum.nearest(tracked);
        Sample {
            sigma,
            u: point.u.clone(),
            p: point.p,
            value: c64::new(value.re, value.im.abs()),
            tangent_p: point.tangent_p,
            spectrum: point.spectrum.clone(),
        }
    };
    // Which side of the event a sample lies on (true: `b`'s).
    let beyond = |s: &Sample| match target {
        Target::Turning => s.tangent_p * a.tangent_p < 0.0,
        Target::Crossing(_) => s.spectrum.unstable != a.spectrum.unstable,
    };
    // The function whose root is sought, negative on `a`'s side when the tracking is sound.
    let growing = b.spectrum.unstable >= a.spectrum.unstable;
    let f = |s: &Sample| match target {
        Target::Turning => -s.tangent_p * a.tangent_p.signum(),
        Target::Crossing(_) if growing => s.value.re,
        Target::Crossing(_) => -s.value.re,
    };
    let mut lo = from_point(a, 0.0, tracked_start);
    let mut hi = from_point(b, b.s - a.s, tracked_start);
    let step = (b.s - a.s).abs();
    let converged = |lo: &Sample, hi: &Sample| {
        (hi.p - lo.p).abs() <= settings.event_tol * lo.p.abs().max(p_scale)
            && (hi.sigma - lo.sigma).abs() <= settings.event_tol.sqrt() * step
    };
    // Regula falsi between the sides when the function agrees with them, else bisection.
    let next_sigma = |lo: &Sample, hi: &Sample, weight_lo: f64, weight_hi: f64| {
        let (f_lo, f_hi) = (f(lo) * weight_lo, f(hi) * weight_hi);
        let sigma = lo.sigma - f_lo * (hi.sigma - lo.sigma) / (f_hi - f_lo);
        let inside = |x: f64| (x - lo.sigma) * (x - hi.sigma) < 0.0;
        if f_lo < 0.0 && f_hi > 0.0 && sigma.is_finite() && inside(sigma) {
            sigma
        } else {
            0.5 * (lo.sigma + hi.sigma)
        }
    };
    let tracked = |sigma: f64, lo: &Sample, hi: &Sample| {
        if (sigma - lo.sigma).abs() < (sigma - hi.sigma).abs() {
            lo.value
        } else {
            hi.value
        }
    };
    // Illinois weights: halve the function value of a side kept twice in a row.
    let (mut w_lo, mut w_hi) = (1.0, 1.0);
    let mut last_side = 0i8;
    let mut iterations = 0;
    while !converged(&lo, &hi) {
        iterations += 1;
        if iterations > 200 {
            return Err(crate::Error::Numerical(format!(
                "event not resolved to {:e} within 200 samples (bracket p in [{}, {}])",
                settings.event_tol, lo.p, hi.p
            )));
        }
        let sigma = next_sigma(&lo, &hi, w_lo, w_hi);
        let s = sample_at(sigma, tracked(sigma, &lo, &hi))?;
        if beyond(&s) {
            hi = s;
            w_hi = 1.0;
            if last_side == 1 {
                w_lo *= 0.5;
            }
            last_side = 1;
        } else {
            lo = s;
            w_lo = 1.0;
            if last_side == -1 {
                w_hi *= 0.5;
            }
            last_side = -1;
        }
    }
    let width = (hi.p - lo.p).abs() / lo.p.abs().max(p_scale);
    let bracket = (lo.p.min(hi.p), lo.p.max(hi.p));
    // The event at the final estimate of the root, inside the bracket.
    let sigma = next_sigma(&lo, &hi, 1.0, 1.0);
    let best = sample_at(sigma, tracked(sigma, &lo, &hi))?;
    // The eigenvalue nearest the imaginary axis (the one crossing there).
    let critical = *best
        .spectrum
        .leading
        .iter()
        .min_by(|x, y| x.re.abs().total_cmp(&y.re.abs()))
        .expect("a spectrum has eigenvalues");
    let kind = match target {
        Target::Turning => EventKind::Fold,
        Target::Crossing(_) if is_complex(critical) => EventKind::Hopf,
        Target::Crossing(_) => EventKind::BranchPoint,
    };
    Ok(Event {
        kind,
        u: best.u,
        p: best.p,
        s: a.s + best.sigma,
        eigenvalue: c64::new(critical.re, critical.im.abs()),
        bracket,
        precision: width,
        multiplicity,
        unstable_before: a.spectrum.unstable,
        unstable_after: b.spectrum.unstable,
        spectrum: best.spectrum,
    })
}

//! Pseudo-arclength continuation (Keller 1977) with a tangent predictor, a Newton corrector on
//! the bordered system, adaptive steps, stability at every point and event detection.
//!
//! Points `y = (u, p)` are measured with the weighted inner product
//!
//! ```text
//! <y, z> = (u_y . u_z) / (n U^2) + p_y p_z / P^2                             (1)
//! ```
//!
//! (`U`, `P` from [`Problem::scales`]), so that the arclength `s` counts typical changes of either.
//! From a point `y_0` with unit tangent `t_0` the predictor is `y_0 + ds t_0` (the `u` part applied
//! through [`Problem::retract`]); the corrector solves `G = 0` on the hyperplane through the
//! predicted point normal to `t_0`, by Newton steps on the bordered system
//!
//! ```text
//! [ G_u      G_p    ] [du]   [ -G ]
//! [ t_u^T/(nU^2) t_p/P^2 ] [dp] = [  0 ].                                    (2)
//! ```
//!
//! The tangent at the new point solves the same matrix with right-hand side `(0, 1)`, normalized
//! in (1); this keeps its orientation, so turning points (folds, where `p` turns back) are passed
//! without special treatment. The step grows by 1.5 after an easy correction (at most 3
//! iterations), shrinks by 0.7 after a hard one (6 or more) and is halved after a failure, or
//! when the corrector travelled more than half a step from the predicted point, or when the
//! chord from the last point turned by more than about 30 degrees from its tangent (signs of a
//! jump to another branch). No step moves the parameter by more than `max_parameter_step` times
//! the range followed.
//!
//! At every accepted point the leading eigenvalues of `K v = s M v` are computed
//! ([`super::stability`]). A change of the unstable count between two points is an event, pinned
//! down by [`super::events::locate_crossings`] (every change in the step, each typed by the
//! eigenvalue that crossed); a turn of the parameter is a fold ([`super::events::locate_fold`]).
//! A step across which the count changes in a way one event cannot explain (two real
//! eigenvalues, or more than one pair), or across which two modes exchange stability with no
//! change of the count, is halved, down to a sixteenth, so that the events separate; an exactly
//! double crossing (a symmetric problem, e.g. Greenhill's column) survives the halvings and is
//! reported once with its multiplicity. A corrector point is accepted only at `tol` (or when
//! its Newton correction is at round-off size), so an event's precision rests on converged
//! points. With [`Limits::stop_at_first_instability`] the run ends at the first loss of
//! stability, or at once when the starting point is already unstable. After every accepted point
//! the problem may move its chart there ([`Problem::rechart`]); the point's tangent is then
//! recomputed in the new coordinates.

use faer::Mat;
use faer::prelude::Solve;

use super::events::{self, Event, EventKind, modes_exchanged};
use super::newton::{self, NewtonSettings, System, norm};
use super::stability::{Spectrum, is_complex, leading};
use super::{ContinuationSettings, Linearization, Problem};
use crate::{Error, Result};

/// Relative size of a Newton correction at round-off level.
const ROUND_OFF: f64 = 1e-13;

/// A corrector that has used all its iterations with the residual within this many times `tol`
/// (its round-off floor, next to a singular point where Newton converges only linearly)
/// accepts the point with the size of its last correction as its stated uncertainty.
const FLOOR: f64 = 1e3;

/// Smallest cosine between successive unit tangents (a turn of at most about 30 degrees).
const MIN_TANGENT_COSINE: f64 = 0.85;

/// A point of a branch.
#[derive(Clone, Debug)]
pub struct Point {
    pub u: Vec<f64>,
    pub p: f64,
    /// Arclength from the first point.
    pub s: f64,
    /// Unit tangent in the metric (1): `u` part and `p` part.
    pub tangent_u: Vec<f64>,
    pub tangent_p: f64,
    pub spectrum: Spectrum,
    /// Corrector iterations spent on this point.
    pub iterations: usize,
    /// How far the point may lie from the branch in `p` (see [`Corrected::uncertainty`]).
    pub uncertainty: f64,
}

/// Why a continuation ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Stop {
    /// The parameter left `[p_min, p_max]`.
    ParameterLimit,
    /// `max_points` points were accepted.
    MaxPoints,
    /// The first loss of stability was found (with [`Limits::stop_at_first_instability`]).
    FirstInstability,
    /// The starting point is already unstable (with [`Limits::stop_at_first_instability`]):
    /// there is no loss of stability to find.
    UnstableAtStart,
    /// The corrector failed down to the smallest step; the reason of the last failure (a
    /// mobility that is not positive definite, when any attempt met one: it names the state).
    StepTooSmall(String),
}

/// Where a continuation stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    pub p_min: f64,
    pub p_max: f64,
    /// Stop at the first event that makes a stable branch unstable.
    pub stop_at_first_instability: bool,
}

/// A traced branch.
#[derive(Clone, Debug)]
pub struct Branch {
    pub points: Vec<Point>,
    pub events: Vec<Event>,
    pub stop: Stop,
}

impl Branch {
    /// The first event along the branch at which a stable state becomes unstable.
    pub fn first_loss_of_stability(&self) -> Option<&Event> {
        self.events.iter().find(|e| e.loses_stability())
    }
}

/// Receives the points and events as they are found (for writers and progress bars).
pub trait Observer {
    fn point(&mut self, _point: &Point) {}
    fn event(&mut self, _event: &Event) {}
}

/// An observer that ignores everything.
pub struct Silent;
impl Observer for Silent {}

/// The weighted inner product (1).
#[derive(Clone, Copy, Debug)]
pub struct Metric {
    pub wu: f64,
    pub wp: f64,
}

impl Metric {
    pub fn new(problem: &impl Problem) -> Self {
        let (us, ps) = problem.scales();
        Metric {
            wu: 1.0 / (problem.dim() as f64 * us * us),
            wp: 1.0 / (ps * ps),
        }
    }

    pub fn dot(&self, u1: &[f64], p1: f64, u2: &[f64], p2: f64) -> f64 {
        self.wu * u1.iter().zip(u2).map(|(a, b)| a * b).sum::<f64>() + self.wp * p1 * p2
    }
}

/// Solves the bordered system `[G_u G_p; r_u^T r_p] z = rhs`.
fn bordered_solve(lin: &Linearization, r_u: &[f64], r_p: f64, rhs: &[f64]) -> Option<Vec<f64>> {
    let n = lin.g.len();
    let mut a = Mat::zeros(n + 1, n + 1);
    for j in 0..n {
        for i in 0..n {
            a[(i, j)] = lin.g_u[(i, j)];
        }
        a[(j, n)] = lin.g_p[j];
        a[(n, j)] = r_u[j];
    }
    a[(n, n)] = r_p;
    let b = Mat::from_fn(n + 1, 1, |i, _| rhs[i]);
    let z = a.partial_piv_lu().solve(&b);
    let z: Vec<f64> = (0..=n).map(|i| z[(i, 0)]).collect();
    z.iter().all(|v| v.is_finite()).then_some(z)
}

/// The unit tangent at a point whose linearization is `lin`: the null vector of `[G_u G_p]`
/// with `<r, t> = 1` (so it keeps the orientation of `r`), normalized in the metric.
pub fn tangent(
    lin: &Linearization,
    metric: &Metric,
    r_u: &[f64],
    r_p: f64,
) -> Result<(Vec<f64>, f64)> {
    let n = lin.g.len();
    let mut rhs = vec![0.0; n + 1];
    rhs[n] = 1.0;
    let ru: Vec<f64> = r_u.iter().map(|v| metric.wu * v).collect();
    let z = bordered_solve(lin, &ru, metric.wp * r_p, &rhs)
        .ok_or_else(|| Error::Numerical("singular bordered matrix for the tangent".into()))?;
    let (tu, tp) = (&z[..n], z[n]);
    let len = metric.dot(tu, tp, tu, tp).sqrt();
    Ok((tu.iter().map(|v| v / len).collect(), tp / len))
}

/// A corrected point: solution, parameter, iterations and the linearization there.
pub struct Corrected {
    pub u: Vec<f64>,
    pub p: f64,
    pub iterations: usize,
    pub lin: Linearization,
    /// The size of the last Newton correction not applied, in units of `p` (0 when the
    /// residual met `tol`): the precision of the point, which the precision of an event located
    /// from it never claims to beat.
    pub uncertainty: f64,
}

/// Newton's method on the bordered system (2), from the predicted point `(u, p)` on the
/// hyperplane normal to `(t_u, t_p)`.
pub fn correct(
    problem: &impl Problem,
    mut u: Vec<f64>,
    mut p: f64,
    t_u: &[f64],
    t_p: f64,
    metric: &Metric,
    settings: &ContinuationSettings,
) -> Result<Corrected> {
    let ru: Vec<f64> = t_u.iter().map(|v| metric.wu * v).collect();
    let rp = metric.wp * t_p;
    let (u_predicted, p_predicted) = (u.clone(), p);
    for iterations in 0..=settings.max_corrector {
        let lin = problem.linearize(&u, p)?;
        let g_norm = norm(&lin.g);
        if !g_norm.is_finite() {
            return Err(Error::Numerical(
                "non-finite residual in the corrector".into(),
            ));
        }
        // Converged to `tol`, or (below) the Newton correction is negligible against the
        // precision of events.
        if g_norm <= settings.tol {
            return Ok(Corrected {
                u,
                p,
                iterations,
                lin,
                uncertainty: 0.0,
            });
        }
        // The hyperplane row: bring the iterate back onto the hyperplane through the predicted
        // point (the nonlinear update leaves it at second order).
        let drift: f64 = ru
            .iter()
            .zip(u.iter().zip(&u_predicted))
            .map(|(r, (a, b))| r * (a - b))
            .sum::<f64>()
            + rp * (p - p_predicted);
        let mut rhs: Vec<f64> = lin.g.iter().map(|v| -v).collect();
        rhs.push(-drift);
        let z = bordered_solve(&lin, &ru, rp, &rhs)
            .ok_or_else(|| Error::Numerical("singular bordered matrix in the corrector".into()))?;
        // A correction far below the precision asked of events: the point is known to a
        // hundredth of `event_tol` in `p` (and to as much, in the metric's units, in `u`),
        // and Newton's error after this correction is of the order of its square. This is
        // what ends the iteration where the residual's round-off floor lies above `tol`
        // (stiff stretching on fine, thin rods, amplified next to a branch point); a floor
        // that noise holds above this is a failure, not a point.
        let n = u.len();
        let p_unit = 1.0 / metric.wp.sqrt();
        let moved = metric.dot(&z[..n], z[n], &z[..n], z[n]).sqrt() * p_unit;
        let precise = 1e-2 * settings.event_tol * p.abs().max(1e-6 * p_unit);
        let at_floor = iterations == settings.max_corrector && g_norm <= FLOOR * settings.tol;
        if moved <= precise || norm(&z) <= ROUND_OFF * (1.0 + norm(&u) + p.abs()) || at_floor {
            return Ok(Corrected {
                u,
                p,
                iterations,
                lin,
                uncertainty: moved,
            });
        }
        if iterations == settings.max_corrector {
            break;
        }
        u = problem.retract(&u, &z[..n]);
        p += z[n];
    }
    Err(Error::Numerical(format!(
        "the corrector did not converge to {:e} in {} iterations",
        settings.tol, settings.max_corrector
    )))
}

/// Adapter: the problem at a fixed parameter, as a square system for Newton's method.
pub struct AtParameter<'a, P: Problem> {
    pub problem: &'a P,
    pub p: f64,
}

impl<P: Problem> System for AtParameter<'_, P> {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.problem.residual(u, self.p)
    }
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.problem.linearize(u, self.p)?;
        Ok((lin.g, lin.g_u))
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.problem.retract(u, du)
    }
}

/// The leading spectrum at a solution whose linearization is `lin`, by `settings.eigen`;
/// `prior` is the spectrum of a nearby point, if any (it seeds the Krylov shift).
pub fn stability(
    problem: &impl Problem,
    u: &[f64],
    p: f64,
    lin: &Linearization,
    settings: &ContinuationSettings,
    prior: Option<&Spectrum>,
) -> Result<Spectrum> {
    let (k, m) = problem.stability_pair(u, p, lin)?;
    leading(&k, &m, settings.eigenvalues, settings.eigen, prior)
}

/// How the unstable count changes between two spectra: `Ok(true)` if one event explains it,
/// `Ok(false)` if none happened, `Err(multiplicity)` if several eigenvalues crossed otherwise
/// than as one complex pair.
fn crossing(a: &Spectrum, b: &Spectrum) -> std::result::Result<bool, usize> {
    let d = a.unstable.abs_diff(b.unstable);
    let more = if b.unstable > a.unstable { b } else { a };
    match d {
        0 => Ok(false),
        1 => Ok(true),
        2 => {
            let crossed = &more.leading[more.unstable - 2..more.unstable];
            let pair = is_complex(crossed[0])
                && (crossed[0] - crossed[1].conj()).norm() <= 1e-6 * (1.0 + crossed[0].norm());
            if pair { Ok(true) } else { Err(2) }
        }
        d => Err(d),
    }
}

/// Traces the branch through the solution `(u0, p0)` (corrected first at fixed `p0`), starting in
/// the direction of increasing `p` if `direction > 0`.
pub fn follow<P: Problem>(
    problem: &P,
    u0: Vec<f64>,
    p0: f64,
    direction: f64,
    settings: &ContinuationSettings,
    limits: &Limits,
    observer: &mut impl Observer,
) -> Result<Branch> {
    settings.validate()?;
    let metric = Metric::new(problem);
    let newton_settings = NewtonSettings {
        tol: settings.tol,
        ..NewtonSettings::default()
    };
    let system = AtParameter { problem, p: p0 };
    let (u0, report) = newton::solve(
        &system,
        u0,
        &newton_settings,
        &format!("at the start p = {p0:e}"),
    )?;
    let lin = problem.linearize(&u0, p0)?;
    let zero = vec![0.0; u0.len()];
    let (tu, tp) = tangent(&lin, &metric, &zero, direction.signum() / metric.wp)?;
    let first = Point {
        spectrum: stability(problem, &u0, p0, &lin, settings, None)?,
        u: u0,
        p: p0,
        s: 0.0,
        tangent_u: tu,
        tangent_p: tp,
        iterations: report.iterations,
        uncertainty: 0.0,
    };
    observer.point(&first);
    let unstable_at_start = first.spectrum.unstable > 0;
    let mut branch = Branch {
        points: vec![first],
        events: Vec::new(),
        stop: Stop::MaxPoints,
    };
    if unstable_at_start && limits.stop_at_first_instability {
        branch.stop = Stop::UnstableAtStart;
        return Ok(branch);
    }
    let mut ds = settings.ds;
    let mut halvings = 0;
    // The first failure since the last accepted point that names a mobility that is not
    // positive definite: when the step runs out, it is the reason given.
    let mut indefinite: Option<String> = None;
    let shrink = |ds: &mut f64, e: Error, indefinite: &mut Option<String>| {
        if matches!(e, Error::NotPositiveDefinite { .. }) && indefinite.is_none() {
            *indefinite = Some(e.to_string());
        }
        *ds *= 0.5;
        (*ds < settings.ds_min).then(|| indefinite.clone().unwrap_or_else(|| e.to_string()))
    };
    while branch.points.len() < settings.max_points {
        let last = branch.points.last().expect("the branch has a first point");
        // No step moves the parameter by more than a fraction of the range followed, so that a
        // stable window between two events is not stepped over.
        let dp_max = settings.max_parameter_step * (limits.p_max - limits.p_min);
        if (ds * last.tangent_p).abs() > dp_max {
            ds = (dp_max / last.tangent_p.abs()).max(settings.ds_min);
        }
        let step: Vec<f64> = last.tangent_u.iter().map(|t| ds * t).collect();
        let predicted = problem.retract(&last.u, &step);
        let p_predicted = last.p + ds * last.tangent_p;
        let attempt = correct(
            problem,
            predicted.clone(),
            p_predicted,
            &last.tangent_u,
            last.tangent_p,
            &metric,
            settings,
        )
        .and_then(|c| {
            // Reject a step whose corrector travelled far from the predicted point or
            // whose chord turned sharply from the tangent: it may have jumped to another
            // branch.
            let du: Vec<f64> = c.u.iter().zip(&predicted).map(|(a, b)| a - b).collect();
            let dp = c.p - p_predicted;
            let travel = metric.dot(&du, dp, &du, dp).sqrt();
            let chord_u: Vec<f64> = c.u.iter().zip(&last.u).map(|(a, b)| a - b).collect();
            let chord_p = c.p - last.p;
            let chord = metric.dot(&chord_u, chord_p, &chord_u, chord_p).sqrt();
            let (chord_u, chord_p): (Vec<f64>, f64) =
                (chord_u.iter().map(|v| v / chord).collect(), chord_p / chord);
            let cosine = metric.dot(&chord_u, chord_p, &last.tangent_u, last.tangent_p);
            if travel > 0.5 * ds || cosine < MIN_TANGENT_COSINE {
                return Err(Error::Numerical(format!(
                    "step rejected (corrector travel {:.2} ds, chord turned by {:.0} degrees)",
                    travel / ds,
                    cosine.clamp(-1.0, 1.0).acos().to_degrees()
                )));
            }
            let (tu, tp) = tangent(&c.lin, &metric, &last.tangent_u, last.tangent_p)?;
            let spectrum = stability(problem, &c.u, c.p, &c.lin, settings, Some(&last.spectrum))?;
            Ok(Point {
                u: c.u,
                p: c.p,
                s: last.s + ds,
                tangent_u: tu,
                tangent_p: tp,
                spectrum,
                iterations: c.iterations,
                uncertainty: c.uncertainty,
            })
        });
        let next = match attempt {
            Ok(next) => next,
            Err(e) => {
                if let Some(reason) = shrink(&mut ds, e, &mut indefinite) {
                    branch.stop = Stop::StepTooSmall(reason);
                    return Ok(branch);
                }
                continue;
            }
        };
        // A step across which the count changes in a way one event cannot explain, or two
        // modes exchange stability, is shortened first so that the events separate.
        let exchanged = modes_exchanged(&last.spectrum, &next.spectrum);
        let ambiguous = crossing(&last.spectrum, &next.spectrum).is_err() || exchanged;
        if ambiguous && halvings < 4 && ds * 0.5 >= settings.ds_min {
            halvings += 1;
            ds *= 0.5;
            continue;
        }
        halvings = 0;
        // A fold shows as the parameter turning; a change of the unstable count is a branch or
        // Hopf point unless it is the fold's own real eigenvalue.
        let fold = last.tangent_p * next.tangent_p < 0.0;
        let count_change = last.spectrum.unstable != next.spectrum.unstable;
        let located = (|| -> Result<Vec<Event>> {
            let mut found = Vec::new();
            if fold {
                found.push(events::locate_fold(
                    problem, last, &next, &metric, settings,
                )?);
            }
            if count_change || exchanged {
                let mut crossings =
                    events::locate_crossings(problem, last, &next, &metric, settings)?;
                if fold {
                    // The real eigenvalue that passes zero at the fold is the fold's own.
                    if let Some(own) = crossings
                        .iter()
                        .position(|e| e.kind == EventKind::BranchPoint && e.multiplicity == 1)
                    {
                        crossings.remove(own);
                    }
                }
                found.extend(crossings);
            }
            Ok(found)
        })();
        let mut found = match located {
            Ok(found) => found,
            Err(e) => {
                let e = match e {
                    e @ Error::NotPositiveDefinite { .. } => e,
                    e => Error::Numerical(format!("locating an event: {e}")),
                };
                if let Some(reason) = shrink(&mut ds, e, &mut indefinite) {
                    branch.stop = Stop::StepTooSmall(reason);
                    return Ok(branch);
                }
                continue;
            }
        };
        indefinite = None;
        found.sort_by(|x, y| x.s.total_cmp(&y.s));
        for located in found {
            observer.event(&located);
            branch.events.push(located);
        }
        let first_instability = last.spectrum.unstable == 0 && next.spectrum.unstable > 0;
        ds = match next.iterations {
            0..=3 => (ds * 1.5).min(settings.ds_max),
            6.. => (ds * 0.7).max(settings.ds_min),
            _ => ds,
        };
        let outside = next.p > limits.p_max || next.p < limits.p_min;
        observer.point(&next);
        branch.points.push(next);
        if first_instability && limits.stop_at_first_instability {
            branch.stop = Stop::FirstInstability;
            return Ok(branch);
        }
        if outside {
            branch.stop = Stop::ParameterLimit;
            return Ok(branch);
        }
        let last = branch.points.last_mut().expect("a point was just pushed");
        if problem.rechart(&last.u) {
            // The same point in new coordinates: its tangent, oriented as before.
            let lin = problem.linearize(&last.u, last.p)?;
            (last.tangent_u, last.tangent_p) =
                tangent(&lin, &metric, &last.tangent_u, last.tangent_p)?;
        }
    }
    Ok(branch)
}

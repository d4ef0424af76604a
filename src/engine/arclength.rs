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
//! without special treatment. The step ([`super::step::StepControl`]) grows by 1.5 after an easy
//! correction (at most 3 iterations), shrinks by 0.7 after a hard one (6 or more) and is halved
//! after a failure, or when the corrector travelled more than half a step from the predicted
//! point, or when the chord from the last point turned by more than about 30 degrees from its
//! tangent (signs of a jump to another branch). No step moves the parameter by more than `max_parameter_step` times
//! the range followed (by default 1/60, or 1/4 where the run stops at the first loss of
//! stability), nor goes more than a hundredth of that past the range's end, nor more than 1.5
//! times past where an eigenvalue extrapolated from the last two points reaches the axis.
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
//! the problem may move its chart there ([`Problem::rechart`]) and gives the point's tangent in
//! the new coordinates.
//!
//! The run is an iterator ([`Continuation`]): its state (the last point, the step, what the step
//! control remembers) advances by one step per `next`, which yields a typed [`Outcome`]
//! (accepted with its events, rejected, or shortened); event kinds are [`Detector`] objects
//! (fold, crossings), and the ends of a run are [`StopRule`]s ([`ParameterRange`],
//! [`FirstInstability`]) that [`follow_with`] consults after every accepted point.

use std::cell::RefCell;
use std::ops::ControlFlow;

use faer::Mat;

use super::events::{self, Event, EventKind, modes_exchanged};
use super::newton::{
    self, Chord, Globalization, Iterate, Jacobians, Newton, NewtonSettings, ROUND_OFF, System, norm,
};
use super::stability::{Spectrum, is_complex, leading};
use super::step::StepControl;
use super::stop::{Observer, Stop};
use super::{ContinuationSettings, Linearization, Problem};
use crate::numerics::lu::Lu;
use crate::{Error, Result};

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

/// The arclength run's own reasons to end ([`Stop::Own`]), each given by a stop rule.
#[derive(Clone, Debug, PartialEq)]
pub enum BranchStop {
    /// The first loss of stability was found ([`FirstInstability`], with
    /// [`Limits::stop_at_first_instability`]).
    FirstInstability,
    /// The starting point is already unstable ([`FirstInstability`]): there is no loss of
    /// stability to find.
    UnstableAtStart,
    /// A stop rule of the caller's ended the run (its reason).
    Rule(String),
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
    pub stop: Stop<BranchStop>,
}

impl Branch {
    /// The first event along the branch at which a stable state becomes unstable.
    pub fn first_loss_of_stability(&self) -> Option<&Event> {
        self.events.iter().find(|e| e.loses_stability())
    }

    /// The last point of the branch before `event` (the first point if there is none).
    pub fn point_before(&self, event: &Event) -> &Point {
        self.points
            .iter()
            .rfind(|p| p.s < event.s)
            .unwrap_or(&self.points[0])
    }
}

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

/// The bordered matrix `[G_u G_p; r_u^T r_p]`.
fn bordered_matrix(lin: &Linearization, r_u: &[f64], r_p: f64) -> Mat<f64> {
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
    a
}

/// The unit tangent at a point whose linearization is `lin`: the null vector of `[G_u G_p]`
/// with `<r, t> = 1` (so it keeps the orientation of `r`), normalized in the metric.
pub fn tangent(
    lin: &Linearization,
    metric: &Metric,
    r_u: &[f64],
    r_p: f64,
) -> Result<(Vec<f64>, f64)> {
    tangent_over(lin, metric, r_u, r_p, None)
}

/// [`tangent`], over `lu` when it is the factorization of the bordered matrix
/// `[G_u G_p; w_u r_u^T w_p r_p]` already at hand (the corrector's last one, whose border row is
/// the same), else over a new one.
fn tangent_over(
    lin: &Linearization,
    metric: &Metric,
    r_u: &[f64],
    r_p: f64,
    lu: Option<&Lu<f64>>,
) -> Result<(Vec<f64>, f64)> {
    let n = lin.g.len();
    let rhs = Mat::from_fn(n + 1, 1, |i, _| if i == n { 1.0 } else { 0.0 });
    let z = match lu {
        Some(lu) => lu.solve(rhs.as_ref()),
        None => {
            let ru: Vec<f64> = r_u.iter().map(|v| metric.wu * v).collect();
            Lu::of(bordered_matrix(lin, &ru, metric.wp * r_p)).solve(rhs.as_ref())
        }
    };
    if !z.is_all_finite() {
        return Err(Error::Numerical(
            "singular bordered matrix for the tangent".into(),
        ));
    }
    let (tu, tp): (Vec<f64>, f64) = ((0..n).map(|i| z[(i, 0)]).collect(), z[(n, 0)]);
    let len = metric.dot(&tu, tp, &tu, tp).sqrt();
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
    /// The factorized bordered matrix at the point, when the corrector made it there.
    factorized: Option<Lu<f64>>,
    /// The tangent the corrector's hyperplane was normal to.
    normal: (Vec<f64>, f64),
}

impl Corrected {
    /// The unit tangent at the point, oriented along the tangent the corrector's hyperplane
    /// was normal to: [`tangent`] with that border row, over the corrector's last factorization
    /// when it made one at the point (the same matrix).
    pub fn tangent(&self, metric: &Metric) -> Result<(Vec<f64>, f64)> {
        let (r_u, r_p) = &self.normal;
        tangent_over(&self.lin, metric, r_u, *r_p, self.factorized.as_ref())
    }
}

/// Newton's method on the bordered system (2), from the predicted point `(u, p)` on the
/// hyperplane normal to `(t_u, t_p)`: full steps, a fresh Jacobian at every iterate, at least
/// one step (the predicted point is never accepted as it is).
pub fn correct(
    problem: &impl Problem,
    u: Vec<f64>,
    p: f64,
    t_u: &[f64],
    t_p: f64,
    metric: &Metric,
    settings: &ContinuationSettings,
) -> Result<Corrected> {
    let system = Bordered {
        problem,
        r_u: t_u.iter().map(|v| metric.wu * v).collect(),
        r_p: metric.wp * t_p,
        predicted: (u.clone(), p),
        metric,
        settings,
        last: RefCell::new(None),
    };
    let newton = Newton {
        tol: settings.tol,
        max_iter: settings.max_corrector,
        min_steps: 1,
        globalization: Globalization::Full,
    };
    let mut z = u;
    z.push(p);
    let mut kept = Chord::default();
    let (mut z, report) = newton.run(
        &system,
        z,
        Jacobians::FreshKept(&mut kept),
        "in the corrector",
    )?;
    let p = z.pop().expect("the parameter");
    let lin = system
        .last
        .take()
        .expect("Newton's method ends at a linearized iterate");
    Ok(Corrected {
        u: z,
        p,
        iterations: report.iterations,
        lin,
        uncertainty: report.precision,
        factorized: kept.take(),
        normal: (t_u.to_vec(), t_p),
    })
}

/// The corrector's system in the unknowns `z = (u, p)`: `G(u, p) = 0` and the hyperplane row
/// `<r, z - z_predicted> = 0` through the predicted point (`r = (w_u t_u, w_p t_p)`). The
/// nonlinear update (the retraction) leaves the hyperplane at second order; the row brings the
/// iterate back. It keeps the linearization of `G` at its latest iterate.
struct Bordered<'a, P: Problem> {
    problem: &'a P,
    r_u: Vec<f64>,
    r_p: f64,
    predicted: (Vec<f64>, f64),
    metric: &'a Metric,
    settings: &'a ContinuationSettings,
    last: RefCell<Option<Linearization>>,
}

impl<P: Problem> Bordered<'_, P> {
    /// `<r, z - z_predicted>`.
    fn drift(&self, u: &[f64], p: f64) -> f64 {
        let (u0, p0) = &self.predicted;
        self.r_u
            .iter()
            .zip(u.iter().zip(u0))
            .map(|(r, (a, b))| r * (a - b))
            .sum::<f64>()
            + self.r_p * (p - p0)
    }
}

impl<P: Problem> System for Bordered<'_, P> {
    fn residual(&self, z: &[f64]) -> Result<Vec<f64>> {
        let (u, p) = z.split_at(z.len() - 1);
        let mut g = self.problem.residual(u, p[0])?;
        g.push(self.drift(u, p[0]));
        Ok(g)
    }

    fn residual_and_jacobian(&self, z: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let (u, p) = z.split_at(z.len() - 1);
        let lin = self.problem.linearize(u, p[0])?;
        let jacobian = bordered_matrix(&lin, &self.r_u, self.r_p);
        let mut g = lin.g.clone();
        g.push(self.drift(u, p[0]));
        *self.last.borrow_mut() = Some(lin);
        Ok((g, jacobian))
    }

    fn retract(&self, z: &[f64], dz: &[f64]) -> Vec<f64> {
        let n = z.len() - 1;
        let mut next = self.problem.retract(&z[..n], &dz[..n]);
        next.push(z[n] + dz[n]);
        next
    }

    /// The residual of `G` alone: the hyperplane row is linear and met by every step.
    fn size(&self, g: &[f64]) -> f64 {
        norm(&g[..g.len() - 1])
    }

    /// A correction far below the precision asked of events: the point is known to a
    /// hundredth of `event_tol` in `p` (and to as much, in the metric's units, in `u`), and
    /// Newton's error after this correction is of the order of its square. This is what ends the
    /// iteration where the residual's round-off floor lies above `tol` (stiff stretching on fine,
    /// thin rods, amplified next to a branch point); a floor that noise holds above this is a
    /// failure, not a point. The precision is the size of the correction in units of `p`.
    fn settled(&self, it: &Iterate) -> Option<f64> {
        let n = it.u.len() - 1;
        let (u, p) = (&it.u[..n], it.u[n]);
        let p_unit = 1.0 / self.metric.wp.sqrt();
        let (du, dp) = (&it.du[..n], it.du[n]);
        let moved = self.metric.dot(du, dp, du, dp).sqrt() * p_unit;
        let precise = 1e-2 * self.settings.event_tol * p.abs().max(1e-6 * p_unit);
        let round_off = it.step <= ROUND_OFF * (1.0 + norm(u) + p.abs());
        let at_floor = it.last && it.residual <= FLOOR * self.settings.tol;
        (moved <= precise || round_off || at_floor).then_some(moved)
    }
}

/// Adapter: the problem at a fixed parameter, as a square system for Newton's method. It keeps
/// the latest linearization, so that the one Newton's method ended with (at the solution it
/// returns) need not be made again.
pub struct AtParameter<'a, P: Problem> {
    problem: &'a P,
    p: f64,
    last: RefCell<Option<(Vec<f64>, Linearization)>>,
}

impl<'a, P: Problem> AtParameter<'a, P> {
    pub fn new(problem: &'a P, p: f64) -> Self {
        AtParameter {
            problem,
            p,
            last: RefCell::new(None),
        }
    }

    /// The linearization at `u`: the latest one if it was made at `u`, else a new one.
    pub fn linearization_at(&self, u: &[f64]) -> Result<Linearization> {
        match self.last.take() {
            Some((at, lin)) if at == u => Ok(lin),
            _ => self.problem.linearize(u, self.p),
        }
    }
}

impl<P: Problem> System for AtParameter<'_, P> {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        self.problem.residual(u, self.p)
    }
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let lin = self.problem.linearize(u, self.p)?;
        let out = (lin.g.clone(), lin.g_u.clone());
        *self.last.borrow_mut() = Some((u.to_vec(), lin));
        Ok(out)
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

/// How much farther than the arclength at which an eigenvalue is predicted to reach the
/// imaginary axis the next step may go ([`crossing_ahead`]): a little, so that the crossing falls
/// inside the step, a third of the way from its end, and is bracketed by a step only a little
/// longer than the distance to it.
const LOOKAHEAD: f64 = 1.5;

/// The arclength from `b` after which one of its leading eigenvalues reaches the imaginary
/// axis, extrapolated linearly from the point before (`s_a`, `spectrum_a`). The `k`-th largest
/// real part is a continuous function along the branch, and a crossing is the first of them
/// reaching zero; each one that approaches the axis at the rate `rho = d Re s_k / ds` (from its
/// values at the two points, ranked alike) gets there after `-Re s_k / rho`. Ranks, not the
/// nearest eigenvalue: in the co-rotating frame the whole spectrum moves along the imaginary
/// axis with `omega` (modes at rest in the lab sit at `Im s ~ omega`), farther in a step than the
/// modes lie apart, so that nearest neighbours would pair different modes. A mode that overtakes
/// another is caught by the rank it rises through. `None` when none approaches.
fn crossing_ahead(s_a: f64, spectrum_a: &Spectrum, b: &Point) -> Option<f64> {
    let ds = b.s - s_a;
    b.spectrum
        .leading
        .iter()
        .zip(&spectrum_a.leading)
        .filter_map(|(now, before)| {
            let rate = (now.re - before.re) / ds;
            (now.re * rate < 0.0).then(|| -now.re / rate)
        })
        .min_by(f64::total_cmp)
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

/// What one step of a [`Continuation`] did.
#[derive(Clone, Debug)]
pub enum Outcome {
    /// A point was accepted, with the events pinned down between it and the point before.
    Accepted { point: Point, events: Vec<Event> },
    /// The step was refused (the corrector failed, the step jumped, or an event in it could not
    /// be pinned down) and is retried from the same point with `ds`.
    Rejected { ds: f64, reason: String },
    /// The step spanned crossings that one event cannot explain and is retried with `ds`, so
    /// that they separate.
    Shortened { ds: f64 },
}

/// Detects one kind of event between two consecutive points and pins it down.
pub trait Detector<P: Problem> {
    /// Whether the step from `a` to `b` holds such an event.
    fn detect(&self, a: &Point, b: &Point) -> bool;
    /// The events of the step, located.
    fn locate(
        &self,
        problem: &P,
        a: &Point,
        b: &Point,
        metric: &Metric,
        settings: &ContinuationSettings,
    ) -> Result<Vec<Event>>;
}

/// Folds: the `p` part of the tangent changes sign ([`events::locate_fold`]).
pub struct FoldDetector;

impl<P: Problem> Detector<P> for FoldDetector {
    fn detect(&self, a: &Point, b: &Point) -> bool {
        a.tangent_p * b.tangent_p < 0.0
    }
    fn locate(
        &self,
        problem: &P,
        a: &Point,
        b: &Point,
        metric: &Metric,
        settings: &ContinuationSettings,
    ) -> Result<Vec<Event>> {
        Ok(vec![events::locate_fold(problem, a, b, metric, settings)?])
    }
}

/// Branch and Hopf points, and mode exchanges: the unstable count changes, or two modes trade
/// stability ([`events::locate_crossings`]).
pub struct CrossingDetector;

impl<P: Problem> Detector<P> for CrossingDetector {
    fn detect(&self, a: &Point, b: &Point) -> bool {
        a.spectrum.unstable != b.spectrum.unstable || modes_exchanged(&a.spectrum, &b.spectrum)
    }
    fn locate(
        &self,
        problem: &P,
        a: &Point,
        b: &Point,
        metric: &Metric,
        settings: &ContinuationSettings,
    ) -> Result<Vec<Event>> {
        events::locate_crossings(problem, a, b, metric, settings)
    }
}

/// A stop rule: sees the first point and every accepted step (its two ends and the events
/// located in it), and may end the run.
pub trait StopRule {
    fn start(&mut self, _first: &Point) -> ControlFlow<Stop<BranchStop>> {
        ControlFlow::Continue(())
    }
    fn step(
        &mut self,
        before: &Point,
        after: &Point,
        events: &[Event],
    ) -> ControlFlow<Stop<BranchStop>>;
}

/// Ends the run once a point lies outside `[p_min, p_max]` (that point included).
pub struct ParameterRange {
    pub p_min: f64,
    pub p_max: f64,
}

impl StopRule for ParameterRange {
    fn step(
        &mut self,
        _before: &Point,
        after: &Point,
        _events: &[Event],
    ) -> ControlFlow<Stop<BranchStop>> {
        if after.p > self.p_max || after.p < self.p_min {
            ControlFlow::Break(Stop::ParameterLimit)
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// Ends the run at the first loss of stability, or at once when the first point is unstable.
pub struct FirstInstability;

impl StopRule for FirstInstability {
    fn start(&mut self, first: &Point) -> ControlFlow<Stop<BranchStop>> {
        if first.spectrum.unstable > 0 {
            ControlFlow::Break(Stop::Own(BranchStop::UnstableAtStart))
        } else {
            ControlFlow::Continue(())
        }
    }
    fn step(
        &mut self,
        before: &Point,
        after: &Point,
        _events: &[Event],
    ) -> ControlFlow<Stop<BranchStop>> {
        if before.spectrum.unstable == 0 && after.spectrum.unstable > 0 {
            ControlFlow::Break(Stop::Own(BranchStop::FirstInstability))
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// The state of a continuation run: the last accepted point, the step, and what the step
/// control remembers; [`Iterator::next`] advances it by one step. The run itself (problem,
/// settings, metric, detectors, largest change of `p` per step) does not change. The iterator
/// ends (`None`) when the step falls below `ds_min`, with [`Continuation::stop`] saying why.
pub struct Continuation<'a, P: Problem> {
    problem: &'a P,
    settings: &'a ContinuationSettings,
    metric: Metric,
    detectors: Vec<Box<dyn Detector<P> + 'a>>,
    /// Largest change of the parameter in one step.
    dp_max: f64,
    /// The range followed, `(p_min, p_max)`: a step is shortened to end just past it.
    range: (f64, f64),
    last: Point,
    /// The arclength and leading spectrum of the point before `last`: with `last`, the rates at
    /// which its eigenvalues move ([`crossing_ahead`]).
    before: Option<(f64, Spectrum)>,
    step: StepControl,
    /// Consecutive shortenings of the step (at most four).
    halvings: usize,
    /// The first failure since the last accepted point where the problem refused the state
    /// ([`Error::is_refused_state`]): when the step runs out, it is the reason given.
    refused: Option<String>,
    /// Whether the last point may move the chart before the next step.
    rechart: bool,
    stop: Option<Stop<BranchStop>>,
}

impl<'a, P: Problem> Continuation<'a, P> {
    /// Corrects `(u0, p0)` at fixed `p0` and starts the branch there, in the direction of
    /// increasing `p` if `direction > 0`; no step moves `p` by more than `max_parameter_step`
    /// of `limits`' range.
    pub fn start(
        problem: &'a P,
        u0: Vec<f64>,
        p0: f64,
        direction: f64,
        settings: &'a ContinuationSettings,
        limits: &Limits,
    ) -> Result<Self> {
        settings.validate()?;
        let metric = Metric::new(problem);
        let newton_settings = NewtonSettings {
            tol: settings.tol,
            ..NewtonSettings::default()
        };
        let system = AtParameter::new(problem, p0);
        let (u0, report) = newton::solve(
            &system,
            u0,
            &newton_settings,
            &format!("at the start p = {p0:e}"),
        )?;
        let lin = system.linearization_at(&u0)?;
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
        Ok(Continuation {
            problem,
            settings,
            metric,
            detectors: vec![Box::new(FoldDetector), Box::new(CrossingDetector)],
            dp_max: settings.parameter_step(limits.stop_at_first_instability)
                * (limits.p_max - limits.p_min),
            range: (limits.p_min, limits.p_max),
            last: first,
            before: None,
            step: StepControl::new(settings.ds, settings.ds_min, settings.ds_max),
            halvings: 0,
            refused: None,
            rechart: false,
            stop: None,
        })
    }

    /// The run with one more kind of event (a user's, or a codimension-two test), detected and
    /// located after the built-in ones.
    pub fn with_detector(mut self, detector: Box<dyn Detector<P> + 'a>) -> Self {
        self.detectors.push(detector);
        self
    }

    /// The last accepted point.
    pub fn current(&self) -> &Point {
        &self.last
    }

    /// Why the iterator ended, once it has.
    pub fn stop(&self) -> Option<&Stop<BranchStop>> {
        self.stop.as_ref()
    }

    /// Halves the step after a failure; ends the run below `ds_min`.
    fn refuse(&mut self, e: Error) -> Option<Result<Outcome>> {
        if e.is_refused_state() && self.refused.is_none() {
            self.refused = Some(e.to_string());
        }
        if self.step.failed().is_err() {
            let reason = self.refused.clone().unwrap_or_else(|| e.to_string());
            self.stop = Some(Stop::StepTooSmall(reason));
            return None;
        }
        Some(Ok(Outcome::Rejected {
            ds: self.step.ds(),
            reason: e.to_string(),
        }))
    }

    /// Predictor and corrector from the last point with the current step.
    fn attempt(&self) -> Result<Point> {
        let (problem, metric, last) = (self.problem, &self.metric, &self.last);
        let ds = self.step.ds();
        let step: Vec<f64> = last.tangent_u.iter().map(|t| ds * t).collect();
        let predicted = problem.retract(&last.u, &step);
        let p_predicted = last.p + ds * last.tangent_p;
        let c = correct(
            problem,
            predicted.clone(),
            p_predicted,
            &last.tangent_u,
            last.tangent_p,
            metric,
            self.settings,
        )?;
        // Reject a step whose corrector travelled far from the predicted point or whose chord
        // turned sharply from the tangent: it may have jumped to another branch.
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
        let (tu, tp) = c.tangent(metric)?;
        let spectrum = stability(
            problem,
            &c.u,
            c.p,
            &c.lin,
            self.settings,
            Some(&last.spectrum),
        )?;
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
    }

    /// The events between the last point and `next`, by every detector, in arclength order. A
    /// fold's own real eigenvalue, which passes zero there, is not also a branch point.
    fn events(&self, next: &Point) -> Result<Vec<Event>> {
        let (a, b) = (&self.last, next);
        let mut found = Vec::new();
        let mut fold = false;
        for detector in &self.detectors {
            if detector.detect(a, b) {
                let located = detector.locate(self.problem, a, b, &self.metric, self.settings)?;
                fold |= located.iter().any(|e| e.kind == EventKind::Fold);
                found.extend(located);
            }
        }
        if fold
            && let Some(own) = found
                .iter()
                .position(|e| e.kind == EventKind::BranchPoint && e.multiplicity == 1)
        {
            found.remove(own);
        }
        found.sort_by(|x, y| x.s.total_cmp(&y.s));
        Ok(found)
    }
}

impl<P: Problem> Iterator for Continuation<'_, P> {
    type Item = Result<Outcome>;

    fn next(&mut self) -> Option<Result<Outcome>> {
        if self.stop.is_some() {
            return None;
        }
        if std::mem::take(&mut self.rechart)
            && let Some(tu) = self.problem.rechart(&self.last.u, &self.last.tangent_u)
        {
            // The same point and tangent in new coordinates, renormalized in the metric.
            let last = &mut self.last;
            let len = self
                .metric
                .dot(&tu, last.tangent_p, &tu, last.tangent_p)
                .sqrt();
            last.tangent_u = tu.iter().map(|v| v / len).collect();
            last.tangent_p /= len;
        }
        // No step moves the parameter by more than a fraction of the range followed, nor goes
        // much past where an eigenvalue is predicted to reach the axis, so that a stable window
        // between two events is not stepped over.
        if (self.step.ds() * self.last.tangent_p).abs() > self.dp_max {
            self.step.set(self.dp_max / self.last.tangent_p.abs());
        }
        if let Some(ahead) = self
            .before
            .as_ref()
            .and_then(|(s, spectrum)| crossing_ahead(*s, spectrum, &self.last))
        {
            self.step.limit(LOOKAHEAD * ahead);
        }
        // A step that would leave the range ends a hundredth of the largest step past it.
        let (last_p, t_p) = (self.last.p, self.last.tangent_p);
        let (p_min, p_max) = self.range;
        let edge = if t_p > 0.0 { p_max } else { p_min };
        let to_edge = (edge - last_p) / t_p;
        if to_edge > 0.0 && self.step.ds() * t_p.abs() > (edge - last_p).abs() {
            let past = 0.01 * self.dp_max / t_p.abs();
            self.step.limit(to_edge + past);
        }
        let next = match self.attempt() {
            Ok(next) => next,
            Err(e) => return self.refuse(e),
        };
        // A step across which the count changes in a way one event cannot explain, or two
        // modes exchange stability, is shortened first so that the events separate.
        let ambiguous = crossing(&self.last.spectrum, &next.spectrum).is_err()
            || modes_exchanged(&self.last.spectrum, &next.spectrum);
        if ambiguous && self.halvings < 4 && self.step.shorten() {
            self.halvings += 1;
            return Some(Ok(Outcome::Shortened { ds: self.step.ds() }));
        }
        self.halvings = 0;
        let events = match self.events(&next) {
            Ok(events) => events,
            Err(e) => {
                let e = if e.is_refused_state() {
                    e
                } else {
                    Error::Numerical(format!("locating an event: {e}"))
                };
                return self.refuse(e);
            }
        };
        self.refused = None;
        self.step.adapt(next.iterations);
        let last = std::mem::replace(&mut self.last, next.clone());
        self.before = Some((last.s, last.spectrum));
        self.rechart = true;
        Some(Ok(Outcome::Accepted {
            point: next,
            events,
        }))
    }
}

/// Traces the branch through the solution `(u0, p0)` (corrected first at fixed `p0`), starting in
/// the direction of increasing `p` if `direction > 0`: runs a [`Continuation`] with the stop
/// rules of `limits` ([`ParameterRange`], and [`FirstInstability`] when asked) and at most
/// `max_points` points, telling `observer` every point and event.
pub fn follow<P: Problem>(
    problem: &P,
    u0: Vec<f64>,
    p0: f64,
    direction: f64,
    settings: &ContinuationSettings,
    limits: &Limits,
    observer: &mut impl Observer<Point, Event>,
) -> Result<Branch> {
    let mut range = ParameterRange {
        p_min: limits.p_min,
        p_max: limits.p_max,
    };
    let mut first_instability = FirstInstability;
    let mut rules: Vec<&mut dyn StopRule> = Vec::new();
    if limits.stop_at_first_instability {
        rules.push(&mut first_instability);
    }
    rules.push(&mut range);
    let run = Continuation::start(problem, u0, p0, direction, settings, limits)?;
    follow_with(run, &mut rules, observer)
}

/// Runs `run` to its end under the stop rules `rules` (in order; the first to break ends the
/// run) and at most `max_points` points, telling `observer` every point and event (it may end
/// the run too, [`Stop::Observer`]).
pub fn follow_with<P: Problem>(
    mut run: Continuation<'_, P>,
    rules: &mut [&mut dyn StopRule],
    observer: &mut impl Observer<Point, Event>,
) -> Result<Branch> {
    let max_points = run.settings.max_points;
    let first = run.current().clone();
    let told = observer.point(&first);
    let mut branch = Branch {
        points: vec![first],
        events: Vec::new(),
        stop: Stop::MaxPoints,
    };
    if let Some(stop) = rules
        .iter_mut()
        .find_map(|r| r.start(&branch.points[0]).break_value())
        .or(told.is_break().then_some(Stop::Observer))
    {
        branch.stop = stop;
        return Ok(branch);
    }
    while branch.points.len() < max_points {
        let Some(outcome) = run.next() else {
            branch.stop = run.stop().cloned().unwrap_or(Stop::MaxPoints);
            return Ok(branch);
        };
        let Outcome::Accepted { point, events } = outcome? else {
            continue;
        };
        let mut ended = false;
        for event in &events {
            ended |= observer.event(event).is_break();
        }
        ended |= observer.point(&point).is_break();
        let before = branch.points.last().expect("the branch has a first point");
        let stop = rules
            .iter_mut()
            .find_map(|r| r.step(before, &point, &events).break_value())
            .or(ended.then_some(Stop::Observer));
        branch.events.extend(events);
        branch.points.push(point);
        if let Some(stop) = stop {
            branch.stop = stop;
            return Ok(branch);
        }
    }
    Ok(branch)
}

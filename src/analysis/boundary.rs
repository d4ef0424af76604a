//! The stability boundary `omega_b(q)` as a curve in a second model field `q` (a [`Field`] of
//! the physical model: any number of it, or the helix ratios), by two-parameter continuation of
//! the first loss of stability ([`crate::engine::curve`], docs/model.md section 11).
//!
//! The curve starts from `locate` at the first value of `q`. It is the first loss of stability
//! of the branch from rest as long as no other mode becomes unstable below it; the rest of the
//! spectrum is watched at every point, so where a second pair reaches the axis on the curve (a
//! double Hopf point) past which it is unstable, the boundary moves to that pair's Hopf curve
//! and says where it switched. Where the curve turns back in `q` (the mode's loss and regain of
//! stability meet and vanish), the boundary jumps: it is located afresh just past the turning
//! point and followed from there. An instability can also open below the curve away from it (a
//! window of another mode, born where that mode's own Hopf curve turns in `q`), which the
//! curve's spectrum cannot see: every point is therefore checked by an independent `locate` from
//! rest up to just below it ([`WINDOW_MARGIN`]); where that finds a loss of stability, the value
//! of `q` where the window opens is bisected between the last clean point and this one, the
//! boundary switches to the new mode there and says so (a `window` point). So the first loss of
//! stability does not depend on the direction of travel: followed the other way, the same window
//! closes at a turning point of its curve, where the boundary jumps back. The end of the range is
//! checked against an independent `locate` too ([`check_end`]).
//!
//! The curve is followed at the family's `N`. Asked for an accuracy ([`PointAccuracy`]), every
//! Hopf point, once checked for a window below it, is then carried to the node count the
//! accuracy needs by `locate`'s refinement at its `q` ([`carry`]): the curve at the coarse `N`
//! finds the first loss of stability, its switches and its special points; the refinement gives
//! each point its value and error, where its first rung (from rest at the curve's `N`) finds
//! the point again; else the point is kept at the curve's `N` and says why. With a carry
//! spacing ([`PointAccuracy::spacing`]) only points that far apart in `ln q` are refined (and
//! the two on either side of a change of the RPY quadrature, where the curve's values jump),
//! and the others take the refined correction interpolated ([`carry::interpolate`]).

use std::ops::ControlFlow;
use std::rc::Rc;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::analysis::locate::{Critical, LocateSettings, Loss, locate};

use crate::analysis::branch::observables_at;
use crate::analysis::refine::hopf_point_error;
use crate::analysis::solve::rest_state;
use crate::engine::criticality::Verdict;
use crate::engine::curve::{
    CurveEnd, CurvePoint, CurveSettings, Family, Special, SpecialKind, follow_curve,
};
use crate::engine::event_curve::{EventPoint, follow_event_curve};
use crate::engine::events::EventKind;
use crate::engine::newton::NewtonSettings;
use crate::engine::stop::{Observer, Silent, Stop};
use crate::model::Model;
use crate::numerics::fit::log_slopes;
use crate::problem::family::RodFamily;
use crate::problem::rod::RodProblem;
use crate::{Error, Result};

mod carry;
mod names;
pub use carry::{Answer, PointAccuracy};
use carry::{Carried, interpolate, refined_row};

/// One point of the boundary (a row of `boundary.csv`, read back by a resumed study).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryPoint {
    /// The index of the curve the point lies on (a switch or a jump starts a new one).
    pub segment: usize,
    pub q: f64,
    /// `omega_b` at the point (rad/s): the curve's own at its `N`, or, where the point was
    /// carried to an accuracy ([`PointAccuracy`]), the answer of its refinement in `N` (the
    /// finest rung's value or the limit in `N`, on the RPY line less the quadrature's error).
    pub omega_b: f64,
    /// Estimated error of `omega_b` (rad/s). Where carried, the refinement's (in `N` and of the
    /// quadrature, as `locate` states it); else the discretization error at the curve's `N`,
    /// from the first loss of stability at `N/2 + 1` nodes (docs/model.md section 11). Empty at
    /// a fold or branch point, below 9 nodes, or where the coarser mesh has no Hopf point to
    /// compare.
    pub omega_b_error: Option<f64>,
    /// With an accuracy, at a Hopf point: whether the refinement's estimated relative error is
    /// below it (false too where the point was kept at the curve's `N`); empty without one and
    /// at fold and branch points.
    pub reached: Option<bool>,
    pub omegabar_b: f64,
    #[serde(
        serialize_with = "names::event_name",
        deserialize_with = "names::event_of_name"
    )]
    pub kind: EventKind,
    /// Frequency of the critical mode, rad/s and normalized.
    pub w: f64,
    pub wbar: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    pub hbar: f64,
    /// `-d ln omegabar_b / d ln q` along the segment (three-point differences; empty where `q`
    /// or `omegabar_b` is not positive or the segment has one point).
    pub m_loc: Option<f64>,
    /// An estimate of the error of `m_loc`: the three-point slope in `ln q` of the points'
    /// estimated relative errors of `omega_b` (the change of `m_loc` were each point's error
    /// removed). Right where that error is smooth in `q` and of one sign, as when neighbouring
    /// points come from the same rungs; where neighbours reach an accuracy at different `N`, or
    /// one's answer is a limit in `N` and the other's a rung, the jump of their errors shows in
    /// it. Empty where a point of the three states no error.
    pub m_loc_error: Option<f64>,
    /// Relative precision of the point in `omega`.
    pub precision: f64,
    /// At a Hopf point: the first Lyapunov coefficient (solver units, critical mode scaled to a
    /// largest node displacement of `ell`), its estimated error and the verdict; empty where it
    /// could not be computed (its differences displace the rod out of the fluid model's
    /// admissible states, next to Lighthill's spacing limit).
    pub l1: Option<f64>,
    pub l1_precision: Option<f64>,
    pub criticality: Option<Verdict>,
    /// The node count of the row's values: the curve's, or where carried the finest rung's (of
    /// `w`, `Fpbar`, `hbar`, `precision`, `l1`, and of `omega_b` unless that is a limit in `N`).
    pub nodes: usize,
    /// The curve's own `omega_b` (rad/s) at its node count `curve_nodes` (equal to `omega_b`
    /// and `nodes` where the point was not carried to an accuracy).
    pub curve_omega_b: f64,
    pub curve_nodes: usize,
    /// Where `omega_b` comes from: the curve, the point's own refinement, the refinements on
    /// either side interpolated (a carry spacing), or kept at the curve's `N`.
    pub answer: Answer,
    /// The RPY quadrature's points per edge of the curve's member at `q` (not written): where it
    /// changes along a curve, the curve's values jump, and no interpolation spans the change.
    #[serde(skip)]
    pub points_per_edge: Option<usize>,
}

/// A special point of the boundary (a row of `points.csv`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SpecialPoint {
    #[serde(
        serialize_with = "names::special_name",
        deserialize_with = "names::special_of_name"
    )]
    pub kind: BoundaryEvent,
    pub q: f64,
    pub omega: f64,
    pub omegabar: f64,
    /// The critical mode's frequency and the other mode's (double Hopf), rad/s.
    pub w: f64,
    pub w_other: f64,
    /// True where the boundary leaves the curve here (switch to the other mode, or jump).
    pub switch: bool,
    /// Width of the final bracket: along the curve (units of the curve's arclength), or in `q`
    /// for a window.
    pub precision: f64,
}

/// What a special point of the boundary is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoundaryEvent {
    /// A special point of the curve followed (double Hopf, zero-Hopf, turning, ...).
    Curve(SpecialKind),
    /// Another mode's window of instability opens below the curve: the boundary switches to it
    /// (`w` is the new mode's frequency, `w_other` the curve's).
    Window,
}

impl BoundaryEvent {
    /// The name used in files: the curve's special point's, or `window`.
    pub fn name(self) -> &'static str {
        match self {
            BoundaryEvent::Curve(kind) => kind.name(),
            BoundaryEvent::Window => "window",
        }
    }

    /// Whether one mode alone is involved (one frequency to report).
    pub fn one_mode(self) -> bool {
        matches!(
            self,
            BoundaryEvent::Curve(SpecialKind::Turning | SpecialKind::GeneralizedHopf)
        )
    }
}

/// The boundary found so far.
#[derive(Clone, Debug, Default)]
pub struct Boundary {
    pub points: Vec<BoundaryPoint>,
    pub special: Vec<SpecialPoint>,
    /// The curves the boundary runs on (a switch or a jump starts a new one).
    pub segments: usize,
    /// Steady solves (Newton from a close guess, with a spectrum) over the whole boundary.
    pub evaluations: usize,
    /// Independent `locate` runs from rest below the curve, up to just below each point (one per
    /// point but the first of each curve and a special point the boundary leaves the curve at,
    /// and those of the bisection where a window opens); a point carried to an accuracy is
    /// checked so before it is refined.
    pub window_checks: usize,
    /// Where the first point carried to an accuracy fell short of it, and why its refinement
    /// stopped.
    pub first_shortfall: Option<String>,
    /// The first window check below a point whose branch had a near miss that its probes
    /// neither resolved nor excluded (docs/model.md section 5): the check's verdict there,
    /// nothing unstable below the point, is not certain.
    pub first_unresolved_near_miss: Option<String>,
    /// Where the time went, beside the curve itself.
    pub time: TimeSpent,
}

/// Where the seconds of a boundary went: what the run reports of its cost, so that the part
/// worth saving (a carry spacing, a shorter range) can be seen.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct TimeSpent {
    /// The rest: following the curve (the `locate` at its start and after each jump, the
    /// corrector's steady solves and spectra, the first Lyapunov coefficient at every point, the
    /// special points; a fold or branch-point curve whole) and writing the files.
    pub curve: f64,
    /// The independent `locate` runs below the curve (and those bisecting a window's opening).
    pub window_checks: f64,
    /// The points' rows: each point's observables and, without an accuracy, its error from a
    /// coarser rung (a `locate` at `N/2 + 1` nodes); with one, its refinement in `N`.
    pub rows: f64,
    /// The independent `locate` at the end of the range.
    pub end_check: f64,
}

impl Boundary {
    /// Sets `m_loc` of every point by three-point differences of `ln omegabar_b` in `ln q` on
    /// each segment, and its error `m_loc_error` by the same differences of the points'
    /// relative errors (`omega_b_error / omega_b`, the error of `ln omegabar_b`).
    fn local_exponents(&mut self) {
        let mut start = 0;
        let rows = &mut self.points;
        while start < rows.len() {
            let segment = rows[start].segment;
            let end = start
                + rows[start..]
                    .iter()
                    .take_while(|r| r.segment == segment)
                    .count();
            let on = &rows[start..end];
            let x: Vec<f64> = on.iter().map(|r| r.q.ln()).collect();
            let y: Vec<f64> = on.iter().map(|r| r.omegabar_b.ln()).collect();
            let relative: Vec<f64> = on
                .iter()
                .map(|r| r.omega_b_error.map_or(f64::NAN, |e| e / r.omega_b.abs()))
                .collect();
            let slopes = log_slopes(&x, &y).into_iter();
            let error_slopes = log_slopes(&x, &relative).into_iter();
            for ((row, slope), error) in rows[start..end].iter_mut().zip(slopes).zip(error_slopes) {
                row.m_loc = slope.map(|d| -d);
                row.m_loc_error = error.map(f64::abs);
            }
            start = end;
        }
    }

    /// How many Hopf points of the boundary are supercritical, subcritical, undetermined, and
    /// without a coefficient.
    pub fn criticality(&self) -> Criticality {
        let mut count = Criticality::default();
        for row in self.points.iter().filter(|r| r.kind == EventKind::Hopf) {
            match row.criticality {
                Some(Verdict::Supercritical) => count.supercritical += 1,
                Some(Verdict::Subcritical) => count.subcritical += 1,
                Some(Verdict::Undetermined) => count.undetermined += 1,
                None => count.not_computed += 1,
            }
        }
        count
    }
}

/// The verdicts on the criticality of the Hopf points of a boundary.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct Criticality {
    pub supercritical: usize,
    pub subcritical: usize,
    pub undetermined: usize,
    pub not_computed: usize,
}

/// Watches a boundary as it grows: called after every new point and special point with the
/// boundary so far; an error ends the boundary there.
pub(crate) trait BoundaryObserver {
    fn grown(&mut self, boundary: &Boundary) -> Result<()>;
}

/// How far below a point of the curve (relative, in `omega`) the independent check of
/// [`loss_below`] stops: a loss of stability within it is the curve's own mode (or a double Hopf
/// point the curve locates itself), not a window.
pub const WINDOW_MARGIN: f64 = 1e-3;

/// Follows the engine's curves into a [`Boundary`], with the observables of every point, each
/// point checked for a window of instability below it.
struct Recorder<'a, O> {
    family: &'a RodFamily,
    newton: &'a NewtonSettings,
    /// The settings of the independent `locate` that checks every point.
    locate: LocateSettings<'a>,
    boundary: Boundary,
    /// The kind of the curve being followed.
    kind: EventKind,
    observer: &'a mut O,
    error: Option<Error>,
    /// The point below which a window of instability was seen; the Hopf curve ends there and
    /// the point is not recorded.
    window: Option<Seen>,
    /// The curve was just left at a special point (its point, told next, needs no check).
    left: bool,
    /// The accuracy every Hopf point is carried to, if one was asked for.
    accuracy: Option<PointAccuracy>,
    /// The curve's own values at the last point recorded (where a window's opening is
    /// bisected from, and a jump past a turning point looks from).
    last_on_curve: Option<OnCurve>,
    /// With a carry spacing: the Hopf points of the current segment not refined yet, with
    /// their rows' indices.
    uncarried: Vec<(usize, CurvePoint)>,
}

/// A point of the curve at its own `N`: `q`, the rate and the critical frequency (solver units
/// and rad/s).
#[derive(Clone, Copy)]
struct OnCurve {
    q: f64,
    omegabar: f64,
    wbar: f64,
    omega: f64,
    w: f64,
}

/// `omega_max` (rad/s, its sign the direction of the search) widened to twice `omega` where that
/// is larger: a search from rest that must reach a point of a curve at `omega`.
pub(super) fn reaching(omega_max: f64, omega: f64) -> f64 {
    omega_max.signum() * omega_max.abs().max(2.0 * omega.abs())
}

impl<O: BoundaryObserver> Recorder<'_, O> {
    /// The row of the curve's `point` (on `model`, the member at its `q`) carried to an accuracy
    /// and, where it fell short of it, why: the answer of its refinement, or where there is none
    /// to give (`carried` says why), the curve's own row, kept and marked not reached.
    fn row(
        &self,
        point: &CurvePoint,
        model: &Model,
        carried: &Carried,
    ) -> Result<(BoundaryPoint, Option<String>)> {
        let segment = self.boundary.segments - 1;
        let kept = match carried {
            Carried::Kept(why) => why.clone(),
            Carried::Refined(r) => match refined_row(r, (point.q, segment), model, point.p) {
                Ok(row) => {
                    let short = (!r.reached).then(|| {
                        r.stopped
                            .clone()
                            .unwrap_or_else(|| "the refinement stopped short".into())
                    });
                    return Ok((row, short));
                }
                Err(why) => why,
            },
        };
        let mut row = self.curve_row(point, model, true)?;
        row.reached = Some(false);
        row.answer = Answer::Kept;
        Ok((row, Some(kept)))
    }

    /// The row of the curve's own `point` on `model` (the member at its `q`), with its
    /// discretization error from `N/2 + 1` nodes where `estimate` asks for it.
    fn curve_row(
        &self,
        point: &CurvePoint,
        model: &Model,
        estimate: bool,
    ) -> Result<BoundaryPoint> {
        let rest = rest_state(model, self.newton)?;
        let o = observables_at(model, &rest, &point.u, point.p)?;
        let wbar = point.eigenvalue.im;
        // An estimate that fails (a coarser model that cannot be built) leaves the column
        // empty; it never ends the boundary.
        let omega_b_error = if self.kind == EventKind::Hopf && estimate {
            match hopf_point_error(
                &self.family.physical(point.q)?,
                model,
                point.p,
                &self.locate,
            ) {
                Ok(e) => e,
                Err(e) if e.is_input() => return Err(e),
                Err(_) => None,
            }
        } else {
            None
        };
        Ok(BoundaryPoint {
            segment: self.boundary.segments - 1,
            q: point.q,
            omega_b: o.omega,
            omega_b_error,
            reached: None,
            omegabar_b: point.p,
            kind: self.kind,
            w: model.scales.omega_from_bar(wbar),
            wbar,
            fpbar: o.fpbar,
            hbar: o.hbar,
            m_loc: None,
            m_loc_error: None,
            precision: point.precision,
            l1: point.lyapunov.as_ref().map(|l| l.l1),
            l1_precision: point.lyapunov.as_ref().map(|l| l.precision),
            criticality: point.lyapunov.as_ref().map(|l| l.verdict),
            nodes: model.nodes(),
            curve_omega_b: o.omega,
            curve_nodes: model.nodes(),
            answer: Answer::Curve,
            points_per_edge: model.fluid.points_per_edge(),
        })
    }

    fn special_point(&self, special: &Special, switch: bool) -> Result<SpecialPoint> {
        let scales = self.family.member(special.point.q)?.model.scales;
        Ok(SpecialPoint {
            kind: BoundaryEvent::Curve(special.kind),
            q: special.point.q,
            omega: scales.omega_from_bar(special.point.p),
            omegabar: special.point.p,
            w: scales.omega_from_bar(special.point.eigenvalue.im),
            w_other: scales.omega_from_bar(special.other.im),
            switch,
            precision: special.precision,
        })
    }

    /// Keeps the first error.
    fn record(&mut self, result: Result<()>) {
        if let (Err(e), None) = (result, &self.error) {
            self.error = Some(e);
        }
    }
}

impl<O: BoundaryObserver> Observer<CurvePoint, Special> for Recorder<'_, O> {
    /// Records a point of the curve, after checking that nothing loses stability below it (the
    /// first point of a curve needs no check: it was located from rest, or is a double Hopf
    /// point of the curve before); then, with an accuracy, carries it there ([`carry`]).
    fn point(&mut self, point: &CurvePoint) -> ControlFlow<()> {
        self.boundary.evaluations += point.evaluations;
        let first = self
            .boundary
            .points
            .last()
            .is_none_or(|r| r.segment + 1 < self.boundary.segments);
        let check = !first && !self.left;
        self.left = false;
        if check {
            self.boundary.window_checks += 1;
            let started = Instant::now();
            let below = loss_below(self.family, &self.locate, point.q, point.p);
            self.boundary.time.window_checks += started.elapsed().as_secs_f64();
            match below {
                Ok((None, unresolved)) => {
                    if let (Some(why), None) =
                        (unresolved, &self.boundary.first_unresolved_near_miss)
                    {
                        self.boundary.first_unresolved_near_miss = Some(format!(
                            "at {} = {}: {why}",
                            self.family.field().key(),
                            point.q
                        ));
                    }
                }
                Ok((Some(found), _)) => {
                    self.window = Some(Seen {
                        omegabar: point.p,
                        wbar: point.eigenvalue.im,
                        found,
                    });
                    return ControlFlow::Break(());
                }
                Err(e) => {
                    self.record(Err(e));
                    return ControlFlow::Break(());
                }
            }
        }
        let started = Instant::now();
        let result = self.family.member(point.q).and_then(|member| {
            let scales = member.model.scales;
            let omega = scales.omega_from_bar(point.p);
            let quadrature = member.model.fluid.points_per_edge();
            let row = match self.accuracy.filter(|_| self.kind == EventKind::Hopf) {
                Some(a) if self.quadrature_changes(quadrature, a) => {
                    self.carry_previous(a)?;
                    self.carried_row(point, &member.model, a, omega)?
                }
                Some(a) if self.refines(point.q, a) => {
                    self.carried_row(point, &member.model, a, omega)?
                }
                // Interpolated once a refined point follows it ([`Recorder::close_segment`]).
                Some(_) => {
                    self.uncarried
                        .push((self.boundary.points.len(), point.clone()));
                    BoundaryPoint {
                        reached: Some(false),
                        ..self.curve_row(point, &member.model, false)?
                    }
                }
                None => self.curve_row(point, &member.model, true)?,
            };
            let refined = row.answer == Answer::Refined;
            self.boundary.points.push(row);
            if let (true, Some(a)) = (refined, self.accuracy) {
                let start = self.segment_start();
                interpolate(&mut self.boundary.points[start..], a.accuracy);
            }
            self.last_on_curve = Some(OnCurve {
                q: point.q,
                omegabar: point.p,
                wbar: point.eigenvalue.im,
                w: scales.omega_from_bar(point.eigenvalue.im),
                omega: scales.omega_from_bar(point.p),
            });
            self.boundary.local_exponents();
            self.boundary.time.rows += started.elapsed().as_secs_f64();
            self.observer.grown(&self.boundary)
        });
        self.record(result);
        // An error (the observer's included) ends the curve at this point.
        if self.error.is_some() {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }

    /// The boundary leaves the curve where the other mode is unstable beyond a double Hopf or
    /// zero-Hopf point, and at a turning point.
    fn event(&mut self, special: &Special) -> ControlFlow<()> {
        let switch = special.gains || special.kind == SpecialKind::Turning;
        let result = self.special_point(special, switch).map(|row| {
            self.boundary.special.push(row);
        });
        self.record(result);
        // The curve ends at a Bogdanov-Takens point too.
        self.left = switch || special.kind == SpecialKind::BogdanovTakens;
        if switch {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// How a boundary starts: on a Hopf curve, or on a fold or branch-point curve.
enum CurveStart {
    Hopf(CurvePoint),
    Event(EventPoint),
}

impl CurveStart {
    /// `omegabar` of the starting event.
    fn omegabar(&self) -> f64 {
        match self {
            CurveStart::Hopf(c) => c.p,
            CurveStart::Event(e) => e.event.p,
        }
    }
}

/// The first loss of stability of the member at `q` (looked for up to `omega_max` rad/s), as
/// the start of a curve, and the member in the chart the branch reached it in.
fn start_at(
    family: &RodFamily,
    settings: &LocateSettings,
    q: f64,
    omega_max: f64,
) -> Result<(CurveStart, Rc<RodProblem<Model>>)> {
    let member = family.member(q)?;
    let at = LocateSettings {
        omega_max,
        ..*settings
    };
    let (located, critical) = locate(&member.model, &at, &mut Silent)?;
    let critical = critical.ok_or_else(|| {
        Error::Numerical(format!(
            "at {} = {q}: no loss of stability to start the boundary from ({})",
            family.field().key(),
            located.kind
        ))
    })?;
    curve_start(
        family,
        Found {
            q,
            member,
            critical,
        },
    )
}

/// A loss of stability found by `locate` on the member at `q`.
struct Found {
    q: f64,
    member: RodProblem<Model>,
    critical: Critical,
}

/// The start of the curve through the loss of stability `found`, and its member in the chart
/// the branch reached it in.
fn curve_start(family: &RodFamily, found: Found) -> Result<(CurveStart, Rc<RodProblem<Model>>)> {
    let Found {
        q,
        member,
        critical,
    } = found;
    let event = critical.event;
    let start = match event.kind {
        EventKind::Hopf => CurveStart::Hopf(CurvePoint::at_event(event, q)),
        EventKind::Fold | EventKind::BranchPoint => CurveStart::Event(EventPoint {
            q,
            event,
            lead: critical.lead,
            iterations: 0,
        }),
        kind => {
            return Err(Error::Numerical(format!(
                "at {} = {q} the first loss of stability is a {}: no curve to follow",
                family.field().key(),
                kind.name()
            )));
        }
    };
    member.set_chart(critical.chart);
    Ok((start, Rc::new(member)))
}

/// The first loss of stability of the member at `q` below the point `omegabar` (solver units)
/// of a curve: an independent `locate` from rest up to `(1 - WINDOW_MARGIN)` times its rate;
/// `None` where the branch stays stable that far, with the near miss of that branch that the
/// probes neither resolved nor excluded, if any. A member whose rest state is unstable is an
/// error: below it the boundary means nothing.
fn loss_below(
    family: &RodFamily,
    settings: &LocateSettings,
    q: f64,
    omegabar: f64,
) -> Result<(Option<Found>, Option<String>)> {
    let member = family.member(q)?;
    let limit = omegabar * (1.0 - WINDOW_MARGIN);
    let at = LocateSettings {
        omega_max: member.model.scales.omega_from_bar(limit),
        criticality: false,
        ..*settings
    };
    let (located, critical) = locate(&member.model, &at, &mut Silent)?;
    match (located.kind, critical) {
        (Loss::UnstableAtRest, _) => Err(Error::Numerical(format!(
            "at {} = {q}: the state at rest is already unstable, so the boundary ends there",
            family.field().key()
        ))),
        // The continuation's last step may pass the limit and find the curve's own loss of
        // stability beyond it: only a loss below the limit is a window.
        (_, Some(critical)) if critical.event.p.abs() < limit.abs() => Ok((
            Some(Found {
                q,
                member,
                critical,
            }),
            None,
        )),
        _ => Ok((None, located.near_miss_unresolved)),
    }
}

/// Where a window of instability opens below a curve: bisects `q` between `clean` (a point of
/// the curve, `(q, omegabar)`, with nothing unstable below it) and `seen` (a point of the curve
/// with the loss of stability found below it), the curve's `omegabar` interpolated linearly
/// between them, down to a bracket of `tol` in `q`. Returns the loss found on the side where
/// the window is open (the next curve starts from it: a window just opened is narrow, and
/// another continuation from rest may step over it) and the bracket's width.
fn window_opening(
    family: &RodFamily,
    settings: &LocateSettings,
    clean: (f64, f64, f64),
    seen: Seen,
    tol: f64,
    checks: &mut usize,
) -> Result<(Found, f64)> {
    let Seen {
        omegabar,
        wbar,
        mut found,
    } = seen;
    let q_seen = found.q;
    // The curve between the two points, `omegabar` and its frequency, by linear interpolation.
    let along = |q: f64, a: f64, b: f64| b + (b - a) * (q - q_seen) / (q_seen - clean.0);
    let mut good = clean.0;
    while (found.q - good).abs() > tol {
        let mid = 0.5 * (good + found.q);
        *checks += 1;
        let (loss, _) = loss_below(family, settings, mid, along(mid, clean.1, omegabar))?;
        // Where the curve bends, the chord can pass above it by more than the margin, and the
        // curve's own mode is found below the chord: a loss at the curve's frequency is that.
        let own_mode = |f: &Found| {
            let w = along(mid, clean.2, wbar);
            (f.critical.event.eigenvalue.im.abs() - w.abs()).abs() <= OWN_FREQUENCY * w.abs()
        };
        match loss {
            Some(closer) if !own_mode(&closer) => found = closer,
            _ => good = mid,
        }
    }
    let width = (found.q - good).abs();
    Ok((found, width))
}

/// How close (relative) to the curve's own frequency a loss of stability found while bisecting
/// a window's opening must be to count as the curve's own mode, found below the chord between
/// two points of a bending curve. The frequencies of different modes differ by far more (13% at
/// the window of `exponent_m` at `lambda = 0.1 m`); along a curve, the chord's frequency is off
/// by the same relative order as its rate, a fraction of the margin.
const OWN_FREQUENCY: f64 = 1e-2;

/// A point of a curve (`omegabar`, solver units) with a loss of stability `found` below it.
struct Seen {
    omegabar: f64,
    /// The curve's frequency there (solver units).
    wbar: f64,
    found: Found,
}

/// Follows the fold or branch-point curve from `start` to the end of the range, its points into
/// `recorder`.
fn follow_events<O: BoundaryObserver>(
    recorder: &mut Recorder<'_, O>,
    start: EventPoint,
    member: Rc<RodProblem<Model>>,
    direction: f64,
    settings: (&CurveSettings, &LocateSettings),
) -> Result<()> {
    let (curve_settings, boundary) = settings;
    let family = recorder.family;
    let kind = start.event.kind;
    let curve = follow_event_curve(
        family,
        start,
        member,
        boundary.omega_max.signum(),
        direction,
        curve_settings,
        boundary.continuation,
    )?;
    recorder.kind = kind;
    for point in &curve.points {
        let on_curve = CurvePoint {
            evaluations: point.iterations,
            ..CurvePoint::at_event(point.event.clone(), point.q)
        };
        // The curve is followed whole; the recorder stops at an error or a window.
        if recorder.point(&on_curve).is_break() {
            break;
        }
    }
    if let Some(e) = recorder.error.take() {
        return Err(e);
    }
    if let Some(seen) = recorder.window.take() {
        return Err(Error::Numerical(format!(
            "another mode loses stability below the {} curve at {} = {:.6e} (at {:.6e} rad/s): \
             boundary does not switch from a fold or branch-point curve to it",
            kind.name(),
            family.field().key(),
            seen.found.q,
            seen.found
                .member
                .model
                .scales
                .omega_from_bar(seen.found.critical.event.p)
        )));
    }
    match curve.stop {
        Stop::ParameterLimit => Ok(()),
        stop => Err(Error::Numerical(format!(
            "the {} curve stopped at {} = {:.6e}: {stop:?}",
            kind.name(),
            family.field().key(),
            curve.points.last().map_or(f64::NAN, |p| p.q)
        ))),
    }
}

/// Follows the boundary of `family` from `q = from` to `to` at the family's `N`, with
/// `accuracy` every Hopf point carried to it ([`PointAccuracy`]), telling `observer` of every
/// point: what was found, and whether the boundary reached the end of the range (what was found
/// is kept when it did not).
pub(crate) fn follow_boundary(
    family: &RodFamily,
    (settings, accuracy): (&LocateSettings, Option<PointAccuracy>),
    from: f64,
    to: f64,
    observer: &mut impl BoundaryObserver,
) -> (Boundary, Result<()>) {
    let mut recorder = Recorder {
        family,
        newton: settings.newton,
        boundary: Boundary {
            segments: 1,
            ..Boundary::default()
        },
        kind: EventKind::Hopf,
        observer,
        error: None,
        locate: *settings,
        window: None,
        left: false,
        accuracy,
        last_on_curve: None,
        uncarried: Vec::new(),
    };
    let outcome = follow_segments(&mut recorder, settings, from, to);
    (recorder.boundary, outcome)
}

/// Refuses a range that is not two different finite values, or whose ends have no valid model.
pub(crate) fn check_range(family: &RodFamily, from: f64, to: f64) -> Result<()> {
    if !(from.is_finite() && to.is_finite() && from != to) {
        return Err(Error::input(
            "--from/--to",
            format!("need two different finite values, got {from} and {to}"),
        ));
    }
    family.physical(from)?;
    family.physical(to)?;
    Ok(())
}

/// The curves of [`follow_boundary`], one after the other.
fn follow_segments<O: BoundaryObserver>(
    recorder: &mut Recorder<'_, O>,
    settings: &LocateSettings,
    from: f64,
    to: f64,
) -> Result<()> {
    let family = recorder.family;
    check_range(family, from, to)?;
    let key = family.field().key();
    let curve_settings = CurveSettings {
        criticality: true,
        ..CurveSettings::new(from.min(to), from.max(to))
    };
    let direction = (to - from).signum();
    let (mut start, mut member) = start_at(family, settings, from, settings.omega_max)?;
    loop {
        let hopf = match start {
            CurveStart::Hopf(c) => c,
            CurveStart::Event(e) => {
                return follow_events(recorder, e, member, direction, (&curve_settings, settings));
            }
        };
        recorder.kind = EventKind::Hopf;
        let (curve, last) = follow_curve(
            family,
            hopf,
            member,
            direction,
            &curve_settings,
            settings.continuation,
            recorder,
        )?;
        if recorder.error.is_none() {
            let started = Instant::now();
            let closed = recorder.close_segment();
            recorder.boundary.time.rows += started.elapsed().as_secs_f64();
            recorder.record(closed);
        }
        if let Some(e) = recorder.error.take() {
            return Err(e);
        }
        if let Some(seen) = recorder.window.take() {
            (start, member) = switch_to_window(recorder, settings, seen, (from, to))?;
            continue;
        }
        let at = || curve.points.last().map_or(from, |p| p.q);
        match curve.stop {
            Stop::ParameterLimit => return Ok(()),
            Stop::MaxPoints => {
                return Err(Error::Numerical(format!(
                    "the curve used all {} points",
                    curve_settings.max_points
                )));
            }
            Stop::StepTooSmall(reason) => {
                return Err(Error::Numerical(format!(
                    "the boundary curve stalled at {key} = {:.6e}: {reason}",
                    at()
                )));
            }
            Stop::Own(CurveEnd::NoMember(reason)) => {
                return Err(Error::Numerical(format!(
                    "the boundary curve ends at {key} = {:.6e}, past which the study has no \
                     admissible model: {reason}",
                    at()
                )));
            }
            Stop::Own(CurveEnd::BogdanovTakens) => {
                return Err(Error::Numerical(format!(
                    "the Hopf curve ends at a Bogdanov-Takens point at {key} = {:.6e}: past it \
                     the boundary is a fold curve, which boundary does not follow",
                    at()
                )));
            }
            Stop::Observer => {}
        }
        let special = curve
            .special
            .last()
            .expect("the observer stopped at a special point");
        recorder.boundary.segments += 1;
        start = if special.kind == SpecialKind::Turning {
            // Past the turning point the mode is stable: the first loss of stability is
            // elsewhere, located afresh a little beyond.
            let q = special.point.q + direction * 1e-3 * (to - from).abs();
            let reached = recorder.last_on_curve.map_or(0.0, |c| c.omega);
            let omega_max = reaching(settings.omega_max, reached);
            let (s, m) = start_at(family, settings, q, omega_max)?;
            member = m;
            s
        } else if special.kind == SpecialKind::DoubleHopf {
            let mut next = special.point.clone();
            next.eigenvalue = special.other;
            member = last;
            CurveStart::Hopf(next)
        } else {
            return Err(Error::Numerical(format!(
                "at {key} = {:.6e} a real eigenvalue reaches zero on the Hopf curve (zero-Hopf \
                 point) and is unstable beyond: the boundary becomes a fold or branch-point \
                 curve there, which boundary does not follow",
                special.point.q
            )));
        };
    }
}

/// Where a window of instability was `seen` below the curve: locates where it opens (between the
/// last recorded point and `seen`, to `1e-6` of the range), records the `window` point, and
/// starts the next curve there on the new mode.
fn switch_to_window<O: BoundaryObserver>(
    recorder: &mut Recorder<'_, O>,
    settings: &LocateSettings,
    seen: Seen,
    (from, to): (f64, f64),
) -> Result<(CurveStart, Rc<RodProblem<Model>>)> {
    let family = recorder.family;
    let on_curve = recorder
        .last_on_curve
        .expect("a window is looked for past the first point of a curve");
    let clean = (on_curve.q, on_curve.omegabar, on_curve.wbar);
    let tol = 1e-6 * (to - from).abs();
    let checks = &mut recorder.boundary.window_checks;
    let started = Instant::now();
    let opening = window_opening(family, settings, clean, seen, tol, checks);
    recorder.boundary.time.window_checks += started.elapsed().as_secs_f64();
    let (found, width) = opening?;
    let q = found.q;
    let (start, member) = curve_start(family, found)?;
    let scales = member.model.scales;
    let (omegabar, wbar) = match &start {
        CurveStart::Hopf(c) => (c.p, c.eigenvalue.im),
        CurveStart::Event(e) => (e.event.p, e.event.eigenvalue.im),
    };
    // The curve's frequency at its last point, rad/s (its member's own time scale).
    let w_other = on_curve.w;
    recorder.boundary.special.push(SpecialPoint {
        kind: BoundaryEvent::Window,
        q,
        omega: scales.omega_from_bar(omegabar),
        omegabar,
        w: scales.omega_from_bar(wbar),
        w_other,
        switch: true,
        precision: width,
    });
    recorder.observer.grown(&recorder.boundary)?;
    recorder.boundary.segments += 1;
    Ok((start, member))
}

/// `omega_b` (rad/s) of an independent `locate` at the last point of a boundary, at the curve's
/// `N` (to compare with `curve_omega_b`), looked for up to twice that point's rate; `None`
/// where it finds no loss of stability to start from.
pub(crate) fn check_end(
    family: &RodFamily,
    settings: &LocateSettings,
    last: &BoundaryPoint,
) -> Option<f64> {
    let omega_max = reaching(settings.omega_max, last.curve_omega_b);
    let (start, _) = start_at(family, settings, last.q, omega_max).ok()?;
    Some(
        family
            .member(last.q)
            .map(|m| m.model.scales.omega_from_bar(start.omegabar()))
            .unwrap_or(f64::NAN),
    )
}

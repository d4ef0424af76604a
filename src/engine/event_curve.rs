//! Two-parameter continuation of a fold or a branch point: the event located afresh at each value
//! of the second parameter `q` by a short one-parameter run.
//!
//! A fold or branch point has a real eigenvalue at zero, where the reduced test function of
//! [`super::curve`] (the real part of a tracked pair at a state solved at fixed `(p, q)`) does not
//! apply: at a fold the state itself ends. So each point of the curve is found by the
//! one-parameter engine on the member `q`, started a little before the predicted event on the
//! branch (from the last run's first point, before its event, carried to the new member and
//! corrected there: at a fold the event's own state would make Newton's method singular) and run
//! towards it until the first event of the kind followed ([`FirstOf`], a stop rule of the
//! engine's); the event is pinned down as every event of `locate` is, to `event_tol`.
//!
//! The curve is followed by natural continuation in `q`: the next event's `p` is predicted by
//! the secant through the last two points, the run starts `back` before it (three times the
//! predicted change, at least 2% of `p`) and may go as far beyond, and the step in `q` (a fraction
//! `ds` of the range, landing on its end) grows after a success and halves after a failure. A
//! fold curve is thus followed as long as it is a graph over `q`.

use std::ops::ControlFlow;
use std::rc::Rc;

use super::arclength::{
    BranchStop, Continuation, Limits, ParameterRange, Point, StopRule, follow_with,
};
use super::curve::{CurveSettings, Family};
use super::events::{Event, EventKind};
use super::step::StepControl;
use super::stop::{Silent, Stop};
use super::{ContinuationSettings, Problem};
use crate::{Error, Result};

/// A point of an event curve: the event, located on the member `q`.
#[derive(Clone, Debug)]
pub struct EventPoint {
    pub q: f64,
    pub event: Event,
    /// A solution `(u, p)` on the branch before the event, where the next run starts from (at
    /// a fold the event's own state is a poor start: Newton's method is singular there).
    pub lead: (Vec<f64>, f64),
    /// Corrector iterations of the run that located it.
    pub iterations: usize,
}

/// A followed event curve.
#[derive(Clone, Debug)]
pub struct EventCurve {
    pub points: Vec<EventPoint>,
    pub stop: Stop,
}

/// Ends a run at the first event of one kind.
pub struct FirstOf(pub EventKind);

impl StopRule for FirstOf {
    fn step(
        &mut self,
        _before: &Point,
        _after: &Point,
        events: &[Event],
    ) -> ControlFlow<Stop<BranchStop>> {
        if events.iter().any(|e| e.kind == self.0) {
            ControlFlow::Break(Stop::Own(BranchStop::Rule(format!(
                "first {}",
                self.0.name()
            ))))
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// Follows the curve of the fold or branch point `start` (located on `member`'s branch, which
/// reached it with `p` moving in `direction`) in `q`, from `start.q` to the end of the range of
/// `settings` that `q_direction` points to.
pub fn follow_event_curve<F: Family>(
    family: &F,
    start: EventPoint,
    member: Rc<F::Member>,
    direction: f64,
    q_direction: f64,
    settings: &CurveSettings,
    continuation: &ContinuationSettings,
) -> Result<EventCurve> {
    let kind = start.event.kind;
    if !matches!(kind, EventKind::Fold | EventKind::BranchPoint) {
        return Err(Error::input(
            "event curve",
            format!(
                "follows folds and branch points, got a {} point",
                kind.name()
            ),
        ));
    }
    continuation.validate()?;
    let q_unit = settings.q_max - settings.q_min;
    let q_end = if q_direction > 0.0 {
        settings.q_max
    } else {
        settings.q_min
    };
    let mut curve = EventCurve {
        points: vec![start],
        stop: Stop::MaxPoints,
    };
    let mut last_member = member;
    let mut step = StepControl::new(settings.ds, settings.ds_min, settings.ds_max);
    while curve.points.len() < settings.max_points {
        let last = curve.points.last().expect("a curve has a first point");
        let remaining = (q_end - last.q) * q_direction.signum();
        if remaining <= 0.0 {
            curve.stop = Stop::ParameterLimit;
            return Ok(curve);
        }
        let dq = (step.ds() * q_unit).min(remaining);
        let ending = dq >= remaining;
        let q = if ending {
            q_end
        } else {
            last.q + q_direction.signum() * dq
        };
        let p_last = last.event.p;
        let p_predicted = match curve.points.iter().rev().nth(1) {
            Some(before) => p_last + (p_last - before.event.p) * (q - last.q) / (last.q - before.q),
            None => p_last,
        };
        let scale = last_member.scales().1;
        let back = (3.0 * (p_predicted - p_last).abs())
            .max(0.02 * p_predicted.abs())
            .max(1e-3 * scale);
        let attempt = (|| -> Result<(EventPoint, F::Member)> {
            let member = family.member(q)?;
            let guess = family.carry(&last.lead.0, &last_member, &member);
            family.adopt(&last_member, &member, &guess);
            let limits = Limits {
                p_min: p_predicted - 4.0 * back,
                p_max: p_predicted + 4.0 * back,
                stop_at_first_instability: false,
            };
            let p_start = p_predicted - direction.signum() * back;
            let run =
                Continuation::start(&member, guess, p_start, direction, continuation, &limits)?;
            let mut first = FirstOf(kind);
            let mut range = ParameterRange {
                p_min: limits.p_min,
                p_max: limits.p_max,
            };
            let branch = follow_with(run, &mut [&mut first, &mut range], &mut Silent)?;
            let iterations = branch.points.iter().map(|p| p.iterations).sum();
            let lead = (branch.points[0].u.clone(), branch.points[0].p);
            let event = branch
                .events
                .into_iter()
                .find(|e| e.kind == kind)
                .ok_or_else(|| {
                    Error::Numerical(format!(
                        "no {} within {:e} of the predicted p = {p_predicted:e} at q = {q:e}",
                        kind.name(),
                        4.0 * back
                    ))
                })?;
            Ok((
                EventPoint {
                    q,
                    event,
                    lead,
                    iterations,
                },
                member,
            ))
        })();
        match attempt {
            Ok((point, member)) => {
                curve.points.push(point);
                last_member = Rc::new(member);
                step.grow();
                if ending {
                    curve.stop = Stop::ParameterLimit;
                    return Ok(curve);
                }
            }
            Err(e) => {
                if step.failed().is_err() {
                    curve.stop = Stop::StepTooSmall(e.to_string());
                    return Ok(curve);
                }
            }
        }
    }
    Ok(curve)
}

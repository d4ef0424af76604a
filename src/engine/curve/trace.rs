//! The curve followed point by point: [`follow_curve`] runs a [`Trace`] (the curve so far, its
//! last point solved, what the predictor learnt over the last step, the step) one step at a
//! time: the next step towards the end of the range, its predictor and corrector, the failure
//! of a step (a shorter one, or the curve's end), the special points inside an accepted step,
//! and the point taken.

use std::ops::ControlFlow;
use std::rc::Rc;

use faer::c64;

use super::corrector::{At, Corrected, REACH, Step, Tracer, accept};
use super::special::{
    SignChange, Special, SpecialKind, locate_bogdanov_takens, locate_codim2,
    locate_generalized_hopf, locate_turning, slope_through, vertex_in_step,
};
use super::tracked::others;
use super::{Curve, CurveEnd, CurvePoint, CurveSettings, Family};
use crate::engine::criticality::Verdict;
use crate::engine::newton::NewtonSettings;
use crate::engine::stability::is_complex;
use crate::engine::step::StepControl;
use crate::engine::stop::{Observer, Stop};
use crate::engine::{ContinuationSettings, Problem};
use crate::error::EngineError;
use crate::{Error, Result};

/// Follows the Hopf curve through `start` (a Hopf point of `member`, the member at `start.q`,
/// in whose coordinates `start.u` is), first in the direction of increasing `q` if
/// `direction > 0`, until it leaves `[q_min, q_max]`. `observer` sees every point and special
/// point, and may end the curve (at a special point, the curve's last point). Returns the curve
/// and the member of its last point (a curve that goes on from there starts with it).
pub fn follow_curve<F: Family>(
    family: &F,
    start: CurvePoint,
    member: Rc<F::Member>,
    direction: f64,
    settings: &CurveSettings,
    continuation: &ContinuationSettings,
    observer: &mut impl Observer<CurvePoint, Special>,
) -> Result<(Curve, Rc<F::Member>)> {
    settings.validate()?;
    continuation.validate()?;
    if !is_complex(start.eigenvalue) {
        return Err(Error::input(
            "curve start",
            format!(
                "a Hopf curve starts from a complex pair, got {}",
                start.eigenvalue
            ),
        ));
    }
    let tracer = Tracer {
        family,
        settings,
        continuation,
        newton: NewtonSettings {
            tol: continuation.tol,
            ..NewtonSettings::default()
        },
        q_unit: settings.q_max - settings.q_min,
    };
    let mut trace = Trace::start(tracer, start, member, direction);
    if observer.point(&trace.curve.points[0]).is_break() {
        trace.curve.stop = Stop::Observer;
        return Ok((trace.curve, trace.last.member));
    }
    while trace.curve.points.len() < settings.max_points {
        if let ControlFlow::Break(member) = trace.advance(observer) {
            return Ok((trace.curve, member));
        }
    }
    Ok((trace.curve, trace.last.member))
}

/// A Hopf curve being followed.
struct Trace<'a, F: Family> {
    tracer: Tracer<'a, F>,
    curve: Curve,
    /// The last point, solved.
    last: At<F::Member>,
    /// The unit tangent in the units of (2): the chord of the last step (at the start,
    /// orthogonal to the gradient of the test function).
    t: (f64, f64),
    /// Which way `q` moves along the curve at the last point (its sign): the chord's `q` part,
    /// reversed where the curve turned back in `q` within the last step and came back short of
    /// the point before ([`Trace::turning`]).
    heading: f64,
    /// The slope `dh/d offset` of the last corrector's secant.
    slope: Option<f64>,
    /// The change of the state over the last step not explained by carrying it, per unit step.
    drift: Option<Vec<f64>>,
    /// The rate of change of the tracked eigenvalue along the curve over the last step.
    rate: Option<c64>,
    /// The rate of change of `w^2` along the curve over the last step: a step that fails where
    /// it predicts `w^2 = 0` within two steps may have met a Bogdanov-Takens point.
    w2_rate: Option<f64>,
    step: StepControl,
    /// The last resolved verdict of the Lyapunov coefficient along the curve, and the
    /// arclength of its point.
    resolved: Option<(Verdict, f64)>,
    /// Why a step onto the end of the range failed since the last point: the next step is taken
    /// along the tangent instead, at the same length. Where the curve turns back in `q` just
    /// short of the end, no point at that `q` exists, and halving the step there would only
    /// walk the curve up to its turning point in ever shorter steps. A tangent step that passes
    /// the end, or turns back beyond it, is halved as before.
    ending_failed: Option<String>,
    /// The zero of `l1` located in the latest step where its value changed sign, while no
    /// resolved verdict has followed: a generalized Hopf point once the next resolved verdict
    /// differs from `resolved` ([`Trace::generalized_hopf`]).
    candidate: Option<SignChange<F::Member>>,
}

/// A special point found in a step, and the member of the family where it lies.
type Found<M> = (Special, Rc<M>);

/// What a step holds: its special points, and the zero of `l1` where its value changes sign.
type InStep<M> = (Vec<Found<M>>, Option<SignChange<M>>);

/// The next step from the last point.
struct Next {
    /// The line the point is looked for on.
    line: Step,
    /// The step along the tangent.
    sigma: f64,
    /// Whether the step lands on the end of the range (corrected at fixed `q`).
    ending: bool,
    /// The tracked eigenvalue predicted at the new point.
    predicted: c64,
}

/// The end of a curve whose landing on the end of the range `q_end` failed (why), its tangent step
/// halved down to the smallest step.
fn landing_failed<E>(q_end: f64, why: String) -> Stop<E> {
    Stop::StepTooSmall(format!(
        "landing on the end of the range, q = {q_end}: {why}"
    ))
}

impl<'a, F: Family> Trace<'a, F> {
    /// The curve's first point, `start` (with its Lyapunov coefficient, if asked for), the
    /// tangent orthogonal to the gradient of the test function there, moving `q` in
    /// `direction` ([`Tracer::tangent_at`]).
    fn start(
        tracer: Tracer<'a, F>,
        start: CurvePoint,
        member: Rc<F::Member>,
        direction: f64,
    ) -> Self {
        let last = At {
            member,
            p: start.p,
            q: start.q,
            u: start.u.clone(),
            spectrum: start.spectrum.clone(),
            eigenvalue: start.eigenvalue,
            w2: start.eigenvalue.im * start.eigenvalue.im,
            lyapunov: start.lyapunov.clone(),
        };
        let last = tracer.with_lyapunov(last);
        // Along the curve from the start; along `q` (the corrector's first slope unknown) only
        // where the gradient of the test function cannot be had.
        let (t, slope) = match tracer.tangent_at(&last, direction) {
            Ok((t, slope)) => (t, Some(slope)),
            Err(_) => ((0.0, direction.signum()), None),
        };
        let start = CurvePoint {
            lyapunov: last.lyapunov.clone(),
            ..start
        };
        let settings = tracer.settings;
        // The start's verdict as the last resolved one, where it is resolved.
        let resolved = last
            .lyapunov
            .as_ref()
            .map(|l| l.verdict)
            .filter(|v| *v != Verdict::Undetermined)
            .map(|v| (v, start.s));
        Trace {
            tracer,
            curve: Curve {
                points: vec![start],
                special: Vec::new(),
                stop: Stop::MaxPoints,
            },
            last,
            t,
            heading: t.1,
            slope,
            drift: None,
            rate: None,
            w2_rate: None,
            step: StepControl::new(settings.ds, settings.ds_min, settings.ds_max),
            resolved,
            ending_failed: None,
            candidate: None,
        }
    }

    /// The arclength of the last point.
    fn s_last(&self) -> f64 {
        self.curve.points.last().map_or(0.0, |p| p.s)
    }

    /// One step: `Break` with the member of the curve's last point when the curve ends.
    fn advance(
        &mut self,
        observer: &mut impl Observer<CurvePoint, Special>,
    ) -> ControlFlow<Rc<F::Member>> {
        let next = self.next_step();
        let corrected = match self.correct(&next) {
            Ok(c) => c,
            // Not where the member or the pair itself gave out: that is the curve's end.
            Err(e)
                if next.ending
                    && self.ending_failed.is_none()
                    && !matches!(
                        e,
                        Error::Engine(
                            EngineError::PairBecameReal { .. } | EngineError::NoMember(_)
                        )
                    ) =>
            {
                self.ending_failed = Some(e.to_string());
                return ControlFlow::Continue(());
            }
            Err(e) => return self.failed(e, &next, observer),
        };
        // A point the corrector carried past the end of the range (the normal of a step has a
        // part along `q`): the step again, shortened to land on the end (or halved, where a
        // step onto the end has failed from this point already).
        let settings = self.tracer.settings;
        let q_end = if next.line.t.1 > 0.0 {
            settings.q_max
        } else {
            settings.q_min
        };
        if !next.ending && (corrected.at.q - q_end) * next.line.t.1 > 0.0 {
            if let Some(why) = self.ending_failed.clone() {
                return self.ran_out(|| landing_failed(q_end, why));
            }
            let to_end = (q_end - self.last.q) / (next.line.t.1 * self.tracer.q_unit);
            self.step.set(to_end);
            return ControlFlow::Continue(());
        }
        let new = self.tracer.with_lyapunov(corrected.at);
        let (dp, dq) = (
            (new.p - self.last.p) / next.line.p_unit,
            (new.q - self.last.q) / self.tracer.q_unit,
        );
        let length = dp.hypot(dq);
        let t_new = (dp / length, dq / length);
        let turned = self.turning(&new, &next, t_new);
        // After a failed landing, a tangent step that turned back in `q` beyond the end of the
        // range left it and came back: halved instead, to land on the end.
        if let (Some(why), Ok((_, Some((turning, _))))) = (&self.ending_failed, &turned)
            && (turning.point.q - q_end) * next.line.t.1 > 0.0
        {
            let why = why.clone();
            return self.ran_out(|| landing_failed(q_end, why));
        }
        // A special point that cannot be pinned down is retried from a shorter step.
        let in_step = turned
            .and_then(|(heading, turning)| Ok((heading, self.specials(&new, &next, turning)?)));
        let (heading, (mut specials, sign_change)) = match in_step {
            Ok(found) => found,
            Err(e) => {
                return self
                    .ran_out(|| Stop::StepTooSmall(format!("locating a special point: {e}")));
            }
        };
        let s_last = self.s_last();
        specials.extend(self.generalized_hopf(&new, (s_last, length), sign_change));
        // In their order along the curve (a generalized Hopf point may be settled a few steps
        // after the step that holds it).
        specials.sort_by(|a, b| a.0.point.s.total_cmp(&b.0.point.s));
        for (special, member) in specials {
            let special = self.tracer.with_criticality(special, &member);
            let stop = observer.event(&special);
            self.curve.special.push(special.clone());
            if stop.is_break() {
                let _ = observer.point(&special.point);
                self.curve.points.push(special.point);
                self.curve.stop = Stop::Observer;
                return ControlFlow::Break(member);
            }
        }
        let point = new.point(
            self.s_last() + length,
            corrected.precision,
            corrected.evaluations,
        );
        let told = observer.point(&point);
        self.curve.points.push(point);
        self.heading = heading;
        self.ending_failed = None;
        self.take(
            new,
            &next,
            length,
            t_new,
            corrected.slope,
            corrected.evaluations,
        );
        if next.ending {
            self.curve.stop = Stop::ParameterLimit;
        } else if told.is_break() {
            self.curve.stop = Stop::Observer;
        } else {
            return ControlFlow::Continue(());
        }
        ControlFlow::Break(self.last.member.clone())
    }

    /// The next step: along the tangent by the step, or onto the end of the range where that is
    /// nearer (the line then at fixed `q`) and no step onto it has failed from the last point;
    /// the tracked eigenvalue predicted along its rate of change over the last step (on a rod it
    /// moves with the rate).
    fn next_step(&self) -> Next {
        let (last, t, settings) = (&self.last, self.t, self.tracer.settings);
        let p_unit = last.p.abs().max(last.member.scales().1);
        let q_end = if t.1 > 0.0 {
            settings.q_max
        } else {
            settings.q_min
        };
        let to_end = (q_end - last.q) / (t.1 * self.tracer.q_unit);
        let ds = self.step.ds();
        let ending = self.ending_failed.is_none() && t.1 != 0.0 && to_end > 0.0 && to_end <= ds;
        let sigma = if ending { to_end } else { ds };
        Next {
            line: Step {
                p0: last.p,
                q0: last.q,
                p_unit,
                t,
                n: if ending { (1.0, 0.0) } else { (-t.1, t.0) },
                pair: false,
            },
            sigma,
            ending,
            predicted: last.eigenvalue + self.rate.unwrap_or_default() * sigma,
        }
    }

    /// The predicted point corrected onto the curve (the state shifted by the drift of the
    /// last step), and accepted ([`accept`]).
    fn correct(&self, next: &Next) -> Result<Corrected<F::Member>> {
        let sigma = next.sigma;
        let shift: Option<Vec<f64>> = self
            .drift
            .as_ref()
            .map(|d| d.iter().map(|v| v * sigma).collect());
        self.tracer
            .correct(
                &self.last,
                &next.line,
                sigma,
                shift.as_deref(),
                self.slope,
                next.predicted,
                REACH * sigma,
            )
            .and_then(|c| {
                accept(
                    &self.last,
                    next.predicted,
                    c,
                    &next.line,
                    self.tracer.q_unit,
                )
            })
    }

    /// After a step that failed with `e`: where the tracked pair turned real within it, or
    /// `w^2` was to vanish within two such steps at its last rate (near the point the
    /// equilibrium exists only close to the curve, and the corrector's trials off it fail), the
    /// curve ends at a Bogdanov-Takens point there, if one can be pinned down (else the step is
    /// only too long); otherwise a shorter step, also where the family ends (to come as near
    /// that end as the smallest step allows).
    fn failed(
        &mut self,
        e: Error,
        next: &Next,
        observer: &mut impl Observer<CurvePoint, Special>,
    ) -> ControlFlow<Rc<F::Member>> {
        let vanishing = self
            .w2_rate
            .is_some_and(|r| self.last.w2 + r * 2.0 * next.sigma <= 0.0);
        if (vanishing || matches!(e, Error::Engine(EngineError::PairBecameReal { .. })))
            && let Ok((special, member)) = locate_bogdanov_takens(
                &self.tracer,
                &self.last,
                &next.line,
                next.sigma,
                self.s_last(),
                self.slope,
            )
        {
            let _ = observer.event(&special);
            self.curve.special.push(special.clone());
            let _ = observer.point(&special.point);
            self.curve.points.push(special.point);
            self.curve.stop = Stop::Own(CurveEnd::BogdanovTakens);
            return ControlFlow::Break(member);
        }
        self.ran_out(|| match e {
            Error::Engine(EngineError::NoMember(why)) => {
                Stop::Own(CurveEnd::NoMember(why.to_string()))
            }
            e => Stop::StepTooSmall(e.to_string()),
        })
    }

    /// Halves the step after a failure; below the smallest step the curve ends at its last
    /// point, for the reason `stop`.
    fn ran_out(&mut self, stop: impl FnOnce() -> Stop<CurveEnd>) -> ControlFlow<Rc<F::Member>> {
        if self.step.failed().is_err() {
            self.curve.stop = stop();
            return ControlFlow::Break(self.last.member.clone());
        }
        ControlFlow::Continue(())
    }

    /// Which way `q` moves along the curve at `new` (the chord `t_new` from the last point), and
    /// the turning point in the step, if `q` turned back in it: where the chord's `q` part
    /// differs from the way at the last point; and where it does not, but the step passed the
    /// turning point and came back short of the last point's `q`. Only the parabola `q(p)`
    /// shows that: through `new` and the last point with its slope there (from the parabola
    /// through the point before it too, or in the first step the start tangent's), its vertex
    /// lies inside the step ([`vertex_in_step`]); the turning point located from it must lie
    /// inside the step too (the parabola's vertex lies off the curve's turning point where the
    /// curve is not symmetric about it, and near a turning point in `p` it means nothing). Only
    /// where both chords move `p` the same way is the curve taken for a graph `q(p)`.
    fn turning(
        &self,
        new: &At<F::Member>,
        next: &Next,
        t_new: (f64, f64),
    ) -> Result<(f64, Option<Found<F::Member>>)> {
        let (last, t, p_unit) = (&self.last, self.t, next.line.p_unit);
        let chord = if t_new.1 == 0.0 {
            self.heading
        } else {
            t_new.1
        };
        let previous = (self.curve.points.iter().rev().nth(1)).map(|a| (a.p, a.q));
        let s_last = self.s_last();
        let locate = || locate_turning(&self.tracer, previous, last, new, p_unit, s_last);
        if self.heading * chord < 0.0 {
            return Ok((chord, Some(locate()?)));
        }
        let (at_last, at_new) = ((last.p, last.q), (new.p, new.q));
        let slope = match previous {
            Some(before) => slope_through(before, at_last, at_new),
            None => t.1 * self.tracer.q_unit / (t.0 * p_unit),
        };
        if t.0 * t_new.0 > 0.0 && vertex_in_step(slope, at_last, at_new) {
            // Not pinned down, or outside the step: a turning point past `new`, found by the
            // chord of a later step.
            if let Ok(found) = locate() {
                let p = found.0.point.p;
                if (p - last.p) * (p - new.p) < 0.0 {
                    return Ok((-chord, Some(found)));
                }
            }
        }
        Ok((chord, None))
    }

    /// The special points between the last point and `new`: codimension-two points inside the
    /// step and its `turning` point ([`Trace::turning`]); and where the
    /// sign of `l1` changes inside the step, its zero (a generalized Hopf point where resolved
    /// verdicts of both signs lie on either side: [`Trace::generalized_hopf`]).
    fn specials(
        &self,
        new: &At<F::Member>,
        next: &Next,
        turning: Option<Found<F::Member>>,
    ) -> Result<InStep<F::Member>> {
        let (tracer, last, line, sigma) = (&self.tracer, &self.last, &next.line, next.sigma);
        let s_last = self.s_last();
        let before = others(&last.spectrum, last.eigenvalue);
        let after = others(&new.spectrum, new.eigenvalue);
        let mut found = Vec::new();
        if before.unstable != after.unstable {
            found.push(locate_codim2(
                tracer, last, new, line, sigma, &before, &after, s_last,
            )?);
        }
        let sign_change = match (&last.lyapunov, &new.lyapunov) {
            (Some(a), Some(b)) if a.l1 * b.l1 < 0.0 => Some(locate_generalized_hopf(
                tracer, last, new, line, sigma, s_last,
            )?),
            _ => None,
        };
        found.extend(turning);
        Ok((found, sign_change))
    }

    /// A generalized Hopf point, where the verdict of `l1` changes between resolved ones: the
    /// zero `sign_change` of `l1` located in the step to `new` (the step from arclength `start`
    /// over `length`; if its value changed sign there) is kept as the candidate; at a point
    /// whose verdict is resolved, the candidate is reported where that verdict differs from the
    /// last resolved one, and dropped otherwise (`l1` touched zero and came back). So a change of
    /// sign through points whose `|l1|` lies within its precision is found too, at the zero in
    /// the step where the value changed sign, its precision reaching to the resolved points on
    /// either side ([`SignChange::settled`]). Where the verdict changed with no zero located (the
    /// coefficient failed, or was exactly zero, where the value changed sign), the point is
    /// reported at `new`, its precision the whole distance from the last resolved point. Called
    /// once the step is taken.
    fn generalized_hopf(
        &mut self,
        new: &At<F::Member>,
        (start, length): (f64, f64),
        sign_change: Option<SignChange<F::Member>>,
    ) -> Option<Found<F::Member>> {
        if let Some(change) = sign_change {
            self.candidate = Some(change.along(start, length));
        }
        let verdict = new
            .lyapunov
            .as_ref()
            .map(|l| l.verdict)
            .filter(|v| *v != Verdict::Undetermined)?;
        let s_new = start + length;
        let before = self.resolved.replace((verdict, s_new));
        let candidate = self.candidate.take();
        let (_, s_before) = before.filter(|(v, _)| *v != verdict)?;
        Some(match candidate {
            Some(c) => c.settled(s_before, s_new),
            None => {
                let width = s_new - s_before;
                let special = Special {
                    kind: SpecialKind::GeneralizedHopf,
                    point: new.point(s_new, width, 0),
                    other: new.eigenvalue,
                    gains: false,
                    precision: width,
                };
                (special, new.member.clone())
            }
        })
    }

    /// Takes `new` as the last point, `length` along the curve from the one before with the
    /// tangent `t_new`: what the predictor learns from the step (the drift of the state, the
    /// corrector's slope, the rate of the tracked eigenvalue), and the next step after a
    /// correction of `evaluations` solves.
    fn take(
        &mut self,
        new: At<F::Member>,
        next: &Next,
        length: f64,
        t_new: (f64, f64),
        slope: f64,
        evaluations: usize,
    ) {
        let last = &self.last;
        let carried = self.tracer.family.carry(&last.u, &last.member, &new.member);
        self.drift = Some(
            new.u
                .iter()
                .zip(&carried)
                .map(|(a, b)| (a - b) / next.sigma)
                .collect(),
        );
        self.slope = Some(slope);
        self.rate = Some((new.eigenvalue - last.eigenvalue) / length);
        self.w2_rate = Some((new.w2 - last.w2) / length);
        self.t = t_new;
        self.step.adapt(evaluations);
        self.last = new;
    }
}

//! The corrector of a Hopf curve: a solved state of a member ([`At`]), the line a point is
//! looked for on ([`Step`]), and the secant method on the test function `h = Re s` along it
//! ([`Tracer::correct`]), each evaluation a Newton solve at fixed `(p, q)` and a spectrum.

use std::rc::Rc;

use faer::c64;

use super::special::Special;
use super::tracked::{critical_pair, others, tracked};
use super::{CurvePoint, CurveSettings, Family};
use crate::engine::arclength::{AtParameter, stability};
use crate::engine::criticality::{Lyapunov, first_lyapunov};
use crate::engine::newton::{self, NewtonSettings};
use crate::engine::stability::{Spectrum, is_complex};
use crate::engine::{ContinuationSettings, Problem};
use crate::error::EngineError;
use crate::{Error, Result};

/// How far from the predicted point, in steps, the corrector may go: a curve that turns by more
/// than about `atan(REACH)` within a step is followed with a shorter one.
pub(super) const REACH: f64 = 4.0;

/// The step, in the units of (2), of the differences that give the gradient of the test
/// function at the start of a curve ([`Tracer::tangent_at`]): small against the curve's
/// curvature, large against the noise of `Re s` (a relative `1e-12` or so of the spectrum).
const GRADIENT_STEP: f64 = 1e-5;

/// A solved state of a member: the member, the parameters, the solution and its spectrum.
pub(super) struct At<M> {
    pub(super) member: Rc<M>,
    pub(super) p: f64,
    pub(super) q: f64,
    pub(super) u: Vec<f64>,
    pub(super) spectrum: Spectrum,
    pub(super) eigenvalue: c64,
    /// The squared frequency continued through zero, `w2` of (3) ([`critical_pair`]): `w^2`
    /// of the tracked eigenvalue, negative past a Bogdanov-Takens point (on a [`Step::pair`]
    /// line only, where `eigenvalue` is `(h, sqrt(max(w2, 0)))`).
    pub(super) w2: f64,
    /// Computed for accepted points and the samples that need it.
    pub(super) lyapunov: Option<Lyapunov>,
}

// By hand: the member is shared, so `M` need not be `Clone`.
impl<M> Clone for At<M> {
    fn clone(&self) -> Self {
        At {
            member: self.member.clone(),
            p: self.p,
            q: self.q,
            u: self.u.clone(),
            spectrum: self.spectrum.clone(),
            eigenvalue: self.eigenvalue,
            w2: self.w2,
            lyapunov: self.lyapunov.clone(),
        }
    }
}

impl<M> At<M> {
    /// The point of the curve at arclength `s`.
    pub(super) fn point(&self, s: f64, precision: f64, evaluations: usize) -> CurvePoint {
        CurvePoint {
            p: self.p,
            q: self.q,
            s,
            u: self.u.clone(),
            eigenvalue: self.eigenvalue,
            spectrum: self.spectrum.clone(),
            precision,
            evaluations,
            lyapunov: self.lyapunov.clone(),
        }
    }
}

/// One step of the curve: from `z_k`, predictor `z_k + sigma t` and correction along `n`.
#[derive(Clone, Copy)]
pub(super) struct Step {
    /// The last point `(p, q)` and the scale of `p` in (2).
    pub(super) p0: f64,
    pub(super) q0: f64,
    pub(super) p_unit: f64,
    pub(super) t: (f64, f64),
    pub(super) n: (f64, f64),
    /// Whether the corrector zeroes `h` of the critical pair continued through a
    /// Bogdanov-Takens point (3) rather than `Re s` of the tracked eigenvalue, which fails where
    /// the pair turns real.
    pub(super) pair: bool,
}

impl Step {
    fn at(&self, sigma: f64, offset: f64, q_unit: f64) -> (f64, f64) {
        (
            self.p0 + (sigma * self.t.0 + offset * self.n.0) * self.p_unit,
            self.q0 + (sigma * self.t.1 + offset * self.n.1) * q_unit,
        )
    }
}

/// A corrected point with its cost.
pub(super) struct Corrected<M> {
    pub(super) at: At<M>,
    pub(super) evaluations: usize,
    /// `dh/d offset` of the last secant.
    pub(super) slope: f64,
    pub(super) precision: f64,
}

/// What every correction of a curve uses: the family, the settings, and the scale `Q` of (2).
pub(super) struct Tracer<'a, F: Family> {
    pub(super) family: &'a F,
    pub(super) settings: &'a CurveSettings,
    pub(super) continuation: &'a ContinuationSettings,
    pub(super) newton: NewtonSettings,
    /// `Q` of (2).
    pub(super) q_unit: f64,
}

impl<F: Family> Tracer<'_, F> {
    /// The solution at `(p, q)` from the state `from` (plus `shift`), its spectrum and the
    /// eigenvalue nearest `track` (with `pair`, the critical pair's `h` and `w2` of (3));
    /// [`EngineError::NoMember`] where the family has no member at `q`.
    fn evaluate(
        &self,
        from: &At<F::Member>,
        (p, q): (f64, f64),
        shift: Option<&[f64]>,
        track: c64,
        pair: bool,
    ) -> Result<At<F::Member>> {
        let member = Rc::new(
            self.family
                .member(q)
                .map_err(|e| EngineError::NoMember(Box::new(e)))?,
        );
        let mut guess = self.family.carry(&from.u, &from.member, &member);
        if let Some(shift) = shift {
            guess.iter_mut().zip(shift).for_each(|(g, d)| *g += d);
        }
        self.family.adopt(&from.member, &member, &guess);
        let system = AtParameter::new(&*member, p);
        let context = format!("on the curve at p = {p:e}, q = {q:e}");
        let (u, _) = newton::solve(&system, guess, &self.newton, &context)?;
        // The chart is moved to the state (the same state, new coordinates; every member is
        // this evaluation's own). The linearization in the old coordinates still gives the
        // stability pair: `K`, the Jacobian of the position rows with the angles slaved, does
        // not depend on how the angles are measured, nor `M` on them at all.
        let lin = system.linearization_at(&u)?;
        member.rechart(&u, &[]);
        let spectrum = stability(
            &*member,
            &u,
            p,
            &lin,
            self.continuation,
            Some(&from.spectrum),
        )?;
        let (eigenvalue, w2) = if pair {
            let (h, w2) = critical_pair(&spectrum, track)?;
            (c64::new(h, w2.max(0.0).sqrt()), w2)
        } else {
            let s = tracked(&spectrum, track)?;
            (s, s.im * s.im)
        };
        Ok(At {
            member,
            p,
            q,
            u,
            spectrum,
            eigenvalue,
            w2,
            lyapunov: None,
        })
    }

    /// The tangent of the curve at its solved point `at`, before any step has shown the way:
    /// orthogonal to the gradient of the test function (1) in the units of (2),
    ///
    /// ```text
    /// t = +-(-h_q, h_p) / |grad h|,   h_p = dh/d(dp / p_unit),   h_q = dh/d(dq / Q),
    /// ```
    ///
    /// the sign that moves `q` in `direction`; with the slope `dh/d offset = grad h . n` of
    /// the test function along the first corrector's line `n = (-t_q, t_p)`. A first step along
    /// `q` alone would find a curve of slope `c` in these units `c` steps off its line, beyond
    /// the corrector's reach where `c > REACH`. The gradient is taken by forward differences
    /// of [`GRADIENT_STEP`] in each unit, towards `direction` in `q` (two more solves), the
    /// error of the direction `O(GRADIENT_STEP)` times the curvature, which the corrector
    /// removes.
    pub(super) fn tangent_at(
        &self,
        at: &At<F::Member>,
        direction: f64,
    ) -> Result<((f64, f64), f64)> {
        let p_unit = at.p.abs().max(at.member.scales().1);
        let d = GRADIENT_STEP;
        let dq = d * direction.signum();
        let h0 = at.eigenvalue.re;
        let hp = self.evaluate(at, (at.p + d * p_unit, at.q), None, at.eigenvalue, false)?;
        let hq = self.evaluate(
            at,
            (at.p, at.q + dq * self.q_unit),
            None,
            at.eigenvalue,
            false,
        )?;
        let (gp, gq) = ((hp.eigenvalue.re - h0) / d, (hq.eigenvalue.re - h0) / dq);
        let norm = gp.hypot(gq);
        if !(norm.is_finite() && norm > 0.0) {
            return Err(Error::Numerical(format!(
                "the Hopf test function has no gradient at the start of the curve \
                 (dh/dp = {gp:e}, dh/dq = {gq:e} in the curve's units)"
            )));
        }
        let mut t = (-gq / norm, gp / norm);
        if t.1 * direction < 0.0 || (t.1 == 0.0 && direction < 0.0) {
            t = (-t.0, -t.1);
        }
        let slope = gp * -t.1 + gq * t.0;
        Ok((t, slope))
    }

    /// `at` with its first Lyapunov coefficient, if the settings ask for it. A coefficient
    /// that cannot be computed (its differences leave the problem's admissible states, e.g. a
    /// mobility that is no longer positive) is left out: the point stays a point of the curve.
    pub(super) fn with_lyapunov(&self, mut at: At<F::Member>) -> At<F::Member> {
        if at.lyapunov.is_none() {
            at.lyapunov = self.lyapunov(&at.member, &at.u, at.p, at.eigenvalue);
        }
        at
    }

    /// The first Lyapunov coefficient of the solution `(u, p)` of `member` with its critical
    /// eigenvalue `s`, if the settings ask for it and it can be computed.
    fn lyapunov(&self, member: &F::Member, u: &[f64], p: f64, s: c64) -> Option<Lyapunov> {
        if !self.settings.criticality {
            return None;
        }
        member
            .linearize(u, p)
            .and_then(|lin| first_lyapunov(member, u, p, &lin, s))
            .ok()
            .flatten()
    }

    /// A special point with the coefficient of its point (special points are located from
    /// samples that do not carry one).
    pub(super) fn with_criticality(&self, mut special: Special, member: &F::Member) -> Special {
        let point = &special.point;
        if point.lyapunov.is_none() && is_complex(point.eigenvalue) {
            special.point.lyapunov = self.lyapunov(member, &point.u, point.p, point.eigenvalue);
        }
        special
    }

    /// Solves `h = 0` on the line `step.at(sigma, offset)`, offset from 0, by the secant method
    /// (first slope `slope` if known), following the eigenvalue nearest `track` at first;
    /// refuses a point farther than `reach` from the line's origin.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn correct(
        &self,
        from: &At<F::Member>,
        step: &Step,
        sigma: f64,
        shift: Option<&[f64]>,
        slope: Option<f64>,
        track: c64,
        reach: f64,
    ) -> Result<Corrected<F::Member>> {
        let tol = self.continuation.event_tol;
        // The size of a move `dt` along the line in the acceptance test's units: relative to
        // |p| (or to the member's parameter scale where p is near zero) and to Q.
        let size = |dt: f64, at: &At<F::Member>| {
            let p_scale = at.p.abs().max(at.member.scales().1);
            (dt * step.n.0.abs() * step.p_unit / p_scale).max(dt * step.n.1.abs())
        };
        let mut a = self.evaluate(
            from,
            step.at(sigma, 0.0, self.q_unit),
            shift,
            track,
            step.pair,
        )?;
        let (mut t0, mut h0) = (0.0, a.eigenvalue.re);
        let mut g = slope.filter(|g| g.is_finite() && *g != 0.0);
        let mut t1 = g.map_or(1e-3 * reach, |g| -h0 / g);
        // The evaluation before the last one: its offset, `w2` and state.
        let mut before: Option<(f64, f64, Vec<f64>)> = None;
        for evaluations in 1..=self.settings.max_evaluations {
            // A proposed move below the tolerance: the last point is the answer.
            if let Some(g) = g
                && size((t1 - t0).abs(), &a) <= tol
            {
                if step.pair
                    && let Some((tb, w2b, ub)) = &before
                {
                    // Carried along the last secant onto the zero of `h` it predicts: near a
                    // Bogdanov-Takens point `w2` and the state move along the normal like
                    // `1 / w2` times the offset, so a point left within the tolerance would
                    // carry an error of `event_tol / w2` in `w2`; moved, it carries its square.
                    let f = (t1 - t0) / (t0 - tb);
                    a.w2 += f * (a.w2 - w2b);
                    a.u.iter_mut().zip(ub).for_each(|(u, b)| *u += f * (*u - b));
                    (a.p, a.q) = step.at(sigma, t1, self.q_unit);
                }
                return Ok(Corrected {
                    precision: size((t1 - t0).abs(), &a),
                    at: a,
                    evaluations,
                    slope: g,
                });
            }
            if !(t1.is_finite() && t1.abs() <= reach)
                || evaluations == self.settings.max_evaluations
            {
                break;
            }
            let b = match self.evaluate(
                &a,
                step.at(sigma, t1, self.q_unit),
                None,
                a.eigenvalue,
                step.pair,
            ) {
                Ok(b) => b,
                // Near a Bogdanov-Takens point the equilibrium exists only in a sliver about
                // the curve: a trial outside it is retried halfway back.
                Err(_) if step.pair => {
                    t1 = t0 + 0.5 * (t1 - t0);
                    continue;
                }
                Err(e) => return Err(e),
            };
            let h1 = b.eigenvalue.re;
            let secant = (h1 - h0) / (t1 - t0);
            if h1 == 0.0 {
                return Ok(Corrected {
                    at: b,
                    evaluations: evaluations + 1,
                    slope: secant,
                    precision: 0.0,
                });
            }
            g = Some(secant);
            if step.pair {
                before = Some((t0, a.w2, a.u.clone()));
            }
            (t0, h0, a) = (t1, h1, b);
            t1 = t0 - h0 / secant;
        }
        // Why: the secant's next point lies beyond the reach (the curve turns more sharply
        // than the step allows, or `h` has no zero near the predicted point), or the solves
        // ran out while it still moved.
        let why = if t1.is_finite() && t1.abs() <= reach {
            format!(
                "it still moved by {:e} (relative) after {} solves",
                size((t1 - t0).abs(), &a),
                self.settings.max_evaluations
            )
        } else {
            format!(
                "its secant (slope {:e}) puts the zero at the offset {t1:e} along the normal \
                 (units of (2)), beyond the reach {reach:e} ({REACH} steps): the curve turns \
                 more sharply than the step allows, or h has no zero near the predicted point",
                g.unwrap_or(f64::NAN)
            )
        };
        Err(Error::Numerical(format!(
            "the Hopf test function h = Re s = {h0:e} at p = {:e}, q = {:e} has no zero within \
             reach of the corrector: {why}",
            a.p, a.q
        )))
    }
}

/// Accepts a corrected point unless its tracked eigenvalue jumped (lies farther from its
/// prediction than half the distance from the last point's to its nearest other eigenvalue)
/// or it lies behind the last point along the tangent.
pub(super) fn accept<M>(
    last: &At<M>,
    predicted: c64,
    c: Corrected<M>,
    step: &Step,
    q_unit: f64,
) -> Result<Corrected<M>> {
    let gap = others(&last.spectrum, last.eigenvalue)
        .leading
        .iter()
        .map(|s| (s - last.eigenvalue).norm())
        .fold(f64::INFINITY, f64::min);
    let moved = (c.at.eigenvalue - predicted).norm();
    let along = (c.at.p - last.p) / step.p_unit * step.t.0 + (c.at.q - last.q) / q_unit * step.t.1;
    if moved > 0.5 * gap || along <= 0.0 {
        return Err(Error::Numerical(format!(
            "step rejected: the tracked eigenvalue is {moved:.3e} from its prediction (gap to \
             the next {gap:.3e}), progress along the tangent {along:.3e}"
        )));
    }
    Ok(c)
}

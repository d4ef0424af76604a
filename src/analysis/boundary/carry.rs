//! A boundary's Hopf points carried from the curve's `N` to an accuracy (`boundary --accuracy`,
//! docs/model.md section 11): `locate`'s refinement at each point's `q`, checked to start on the
//! curve's point, and the row it gives.

use crate::Result;
use crate::analysis::boundary::{BoundaryPoint, WINDOW_MARGIN, reaching};
use crate::analysis::locate::{LocateSettings, Loss};
use crate::analysis::refine::{Refinement, refine};
use crate::engine::curve::CurvePoint;
use crate::engine::events::EventKind;
use crate::engine::stop::Silent;
use crate::model::Model;
use crate::problem::family::RodFamily;

/// Every Hopf point of a boundary carried from the curve's `N` to the node count an accuracy
/// needs (`boundary --accuracy`, docs/model.md section 11): `locate`'s refinement ([`refine`])
/// at the point's `q`, its first rung from rest at the curve's `N`, the finer ones
/// grid-sequenced from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointAccuracy {
    /// The relative accuracy of `omega_b` asked for at every point.
    pub accuracy: f64,
    /// The largest node count a point is carried to.
    pub max_nodes: usize,
}

/// What became of a Hopf point carried to an accuracy ([`carry`]).
pub(super) enum Carried {
    /// Its refinement (boxed: a refinement is large).
    Refined(Box<Refinement>),
    /// Kept at the curve's `N`, and why.
    Kept(String),
}

/// The Hopf point `point` of the curve of `family` (at `omega` rad/s) carried to `accuracy`:
/// `locate`'s refinement at its `q` from the curve's `N`, looked for up to twice the point's
/// rate where that passes `omega_max` (the curve may rise past it). Where the refinement fails,
/// or its first rung (from rest at the curve's `N`) does not find the point again within
/// [`WINDOW_MARGIN`] of its rate (next to a turning point, a window just opened or another
/// special point, where a continuation from rest may step past the mode), or it has no error
/// estimate (one rung), the point is kept at the curve's `N`, with the reason. A bad input is
/// an error.
pub(super) fn carry(
    family: &RodFamily,
    settings: &LocateSettings,
    accuracy: PointAccuracy,
    point: &CurvePoint,
    omega: f64,
) -> Result<Carried> {
    let settings = LocateSettings {
        omega_max: reaching(settings.omega_max, omega),
        ..*settings
    };
    let physical = family.physical(point.q)?;
    let refined = match refine(
        &physical,
        Some(accuracy.accuracy),
        accuracy.max_nodes,
        &settings,
        &mut Silent,
    ) {
        Ok(r) => r,
        Err(e) if e.is_input() => return Err(e),
        Err(e) => return Ok(Carried::Kept(format!("its refinement failed: {e}"))),
    };
    let first = &refined.rungs[0];
    let found_again = first.kind == Loss::Event(EventKind::Hopf)
        && first
            .omega_b
            .is_some_and(|w| (w - omega).abs() <= WINDOW_MARGIN * omega.abs());
    if !found_again {
        return Ok(Carried::Kept(format!(
            "the refinement's first rung, from rest at N = {}, finds {} rather than the \
             curve's point at {omega:.6e} rad/s (next to a turning point, a window or \
             another special point a continuation from rest may step past the mode)",
            first.nodes,
            first.omega_b.map_or(format!("{}", first.kind), |w| format!(
                "a {} at {w:.6e} rad/s",
                first.kind
            )),
        )));
    }
    // A refinement that ran one rung (`--max-nodes` at the curve's `N`, the end of Lighthill's
    // range, the quadrature's own error above the accuracy, a failed second rung) has no error
    // to state: the curve's row keeps its two-rung estimate.
    if refined.omega_b_error.is_none() {
        return Ok(Carried::Kept(format!(
            "its refinement has no error estimate: {}",
            refined.stopped.as_deref().unwrap_or("one rung")
        )));
    }
    Ok(Carried::Refined(Box::new(refined)))
}

/// The row of the Hopf point at `q` on `segment` of a boundary, carried to an accuracy by the
/// refinement `r`: the answer (value, error, whether the accuracy was reached) and the finest
/// rung's frequency, observables, precision and Lyapunov coefficient, beside the curve's own
/// `omega_b` on `model` (its `N`); where the finest rung is not a Hopf point (the rungs changed
/// mode), why.
pub(super) fn refined_row(
    r: &Refinement,
    (q, segment): (f64, usize),
    model: &Model,
    curve_omegabar: f64,
) -> std::result::Result<BoundaryPoint, String> {
    let f = &r.finest;
    let hopf = f.kind == Loss::Event(EventKind::Hopf);
    let (Some(omega_b), Some(omegabar_b), Some(w), Some(wbar), Some(fpbar), Some(hbar), true) = (
        f.omega_b,
        f.omegabar_b,
        f.im,
        f.imbar,
        f.fpbar,
        f.hbar,
        hopf,
    ) else {
        return Err(format!(
            "its refinement ends on a {} at N = {}, not on the curve's Hopf point ({})",
            f.kind,
            f.nodes,
            r.stopped.as_deref().unwrap_or("no reason given")
        ));
    };
    Ok(BoundaryPoint {
        segment,
        q,
        omega_b,
        omega_b_error: r.omega_b_error,
        reached: Some(r.reached),
        omegabar_b,
        kind: EventKind::Hopf,
        w,
        wbar,
        fpbar,
        hbar,
        m_loc: None,
        m_loc_error: None,
        precision: f.precision.unwrap_or(f64::NAN),
        l1: f.l1,
        l1_precision: f.l1_precision,
        criticality: f.criticality,
        nodes: f.nodes,
        curve_omega_b: model.scales.omega_from_bar(curve_omegabar),
        curve_nodes: model.nodes(),
    })
}

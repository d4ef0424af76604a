//! The RPY line's quadrature error of `omega_b` (docs/model.md sections 9 and 10): measured at
//! a rung by the same point with another rule, and removed from a limit in `N`.

use serde::Serialize;

use super::{Solved, at_nodes, sequenced_rung};
use crate::Result;
use crate::analysis::locate::LocateSettings;
use crate::engine::events::EventKind;
use crate::engine::stop::Silent;
use crate::model::Model;
use crate::model::fluid::rpy;
use crate::model::params::Physical;

/// The RPY line's quadrature error of `omega_b` at one rung (docs/model.md section 9): the
/// product rule's error is second order in the point spacing and, the rules being nested across
/// a halving ladder, nearly the same at every rung, so it drops out of the increments in `N`
/// and shifts their limit. It is measured by the same point with the points per blob radius
/// multiplied by `r = 1/2` (by `2` where half would fall below the smallest allowed, 2, or give
/// the same rule):
///
/// ```text
/// v(P) - v(inf) = (v(P) - v(r P)) / (1 - r^-2)                                            (1)
/// ```
///
/// (`-1/3` of the difference at `r = 1/2`, `4/3` at `r = 2`). Half the points cost a quarter of
/// the kernels' time where twice cost four times; on the representative helix at `N = 60` the
/// two give `+7.96e-5` and `+8.09e-5` rad/s (`v4, v8, v16 = 0.5104259, 0.5101870, 0.5101263`:
/// observed order 1.98), 1.6% apart.
#[derive(Clone, Debug, Serialize)]
pub struct QuadratureError {
    /// The points per blob radius of the rungs, and the other rule's.
    pub points_per_blob: f64,
    /// `None` where no other rule could be tried.
    pub compared_with: Option<f64>,
    /// The rung it was measured at.
    pub nodes: usize,
    /// `omega_b` there with the other rule (rad/s).
    pub omega_b_compared: Option<f64>,
    /// `v(P) - v(inf)` of (1) (rad/s): how far the rungs' `omega_b`, and their limit in `N`, lie
    /// above the exact quadrature's.
    pub error: Option<f64>,
    /// Why it could not be measured (then it is not in the error bar, and the report says so).
    pub failed: Option<String>,
}

/// [`QuadratureError`] at the rung `coarse` of `physical` (RPY line): the same `N` with the
/// other rule, sequenced from its Hopf point.
pub(super) fn measure(
    physical: &Physical,
    coarse: &Solved,
    settings: &LocateSettings,
) -> Result<QuadratureError> {
    let points_per_blob = physical
        .fluid
        .points_per_blob
        .unwrap_or(rpy::POINTS_PER_BLOB);
    let nodes = coarse.located.nodes;
    let mut measured = QuadratureError {
        points_per_blob,
        compared_with: None,
        nodes,
        omega_b_compared: None,
        error: None,
        failed: None,
    };
    let hopf = coarse
        .critical
        .as_ref()
        .filter(|c| c.event.kind == EventKind::Hopf);
    let (Some(critical), Some(omega_b)) = (hopf, coarse.located.omega_b) else {
        measured.failed = Some(format!(
            "the rung at N = {nodes} has no Hopf point to measure it at ({})",
            coarse.located.kind
        ));
        return Ok(measured);
    };
    let other = match OtherRule::of(physical, &coarse.model)? {
        Ok(other) => other,
        Err(why) => {
            measured.failed = Some(why);
            return Ok(measured);
        }
    };
    let compared_with = other.points_per_blob;
    measured.compared_with = Some(compared_with);
    let ratio = other.ratio;
    let compared = sequenced_rung(other.model, coarse, critical.event.p, settings, &mut Silent);
    match compared {
        Ok(Ok((solved, _))) => match solved.located.omega_b {
            Some(w) => {
                measured.omega_b_compared = Some(w);
                measured.error = Some(rule_error(omega_b, w, ratio));
            }
            None => {
                measured.failed = Some(format!(
                    "no omega_b at N = {nodes} with {compared_with} points per blob radius"
                ))
            }
        },
        Ok(Err(why)) => measured.failed = Some(why),
        Err(e) if e.is_input() => return Err(e),
        Err(e) => measured.failed = Some(e.to_string()),
    }
    Ok(measured)
}

/// The other rule a quadrature error is measured with, (1): the model of `own`'s `N` with its
/// points per blob radius `P` halved, or doubled where half falls outside
/// [`rpy::POINTS_PER_BLOB_RANGE`] or gives the same points per edge (powers of two, at least one
/// cell per edge: where both rules have one cell per edge they are the same rule and measure
/// nothing).
pub(crate) struct OtherRule {
    /// The other rule's points per blob radius, `r P`.
    pub points_per_blob: f64,
    pub model: Model,
    /// The actual ratio `r` of the two rules' points per edge (other over own).
    pub ratio: f64,
}

impl OtherRule {
    /// The other rule of `own`, the model of `physical` at some `N` (RPY line), or why neither
    /// half nor twice its points per blob radius gives one.
    pub(crate) fn of(
        physical: &Physical,
        own: &Model,
    ) -> Result<std::result::Result<OtherRule, String>> {
        let points_per_blob = physical
            .fluid
            .points_per_blob
            .unwrap_or(rpy::POINTS_PER_BLOB);
        let nodes = own.nodes();
        let points = |model: &Model| model.fluid.points_per_edge().unwrap_or(0) as f64;
        let own_points = points(own);
        for r in [0.5, 2.0] {
            if !rpy::POINTS_PER_BLOB_RANGE.contains(&(r * points_per_blob)) {
                continue;
            }
            let mut physical = at_nodes(physical, nodes);
            physical.fluid.points_per_blob = Some(r * points_per_blob);
            let model = Model::new(&physical)?;
            let other_points = points(&model);
            if other_points != own_points {
                return Ok(Ok(OtherRule {
                    points_per_blob: r * points_per_blob,
                    model,
                    ratio: other_points / own_points,
                }));
            }
        }
        Ok(Err(format!(
            "neither half nor twice {points_per_blob} points per blob radius (within [{}, {}]) \
             gives another rule at N = {nodes} ({own_points} points per edge)",
            rpy::POINTS_PER_BLOB_RANGE.start(),
            rpy::POINTS_PER_BLOB_RANGE.end()
        )))
    }
}

/// `v(P) - v(inf)` of (1), from a value with the model's rule and one with the other rule, whose
/// points per edge are `ratio` times as many.
pub(crate) fn rule_error(own: f64, other: f64, ratio: f64) -> f64 {
    (own - other) / (1.0 - ratio.powi(-2))
}

/// The quadrature's error removed from a limit in `N` (docs/model.md section 10). The rungs at
/// one rule `P` converge in `N` to `v(inf) + e(inf)`, where `e(N)` is the rule's error of a rung
/// ([`QuadratureError`]); it changes a little with `N` (on the representative helix at 8 points
/// per blob radius `e = 7.96e-5, 7.73e-5, 7.63e-5` rad/s at `N = 60, 119, 237`). It is measured
/// at the coarsest rung and the next, and the finer measurement is subtracted from the limit:
///
/// ```text
/// v(inf) = limit - e(N2),   |e(N2) - e(inf)| <= |e(N2) - e(N1)|                          (2)
/// ```
///
/// The bound holds where `e(N) - e(inf) = c h^s` with `s >= 1`: at a halving the change is
/// `c h2^s (2^s - 1)`, at least the remainder (equal at `s = 1`; measured here `s` about 1.2).
/// It does not see the error of (1) itself, the rule's next order: at `N = 60` the pairs of
/// rules (4, 8) and (8, 16) give `e` 1.6% apart, `1.3e-6` rad/s, below the change `2.3e-6`.
#[derive(Clone, Debug, Serialize)]
pub struct QuadratureCorrection {
    /// The rungs of the two measurements (the coarsest and the next).
    pub nodes: [usize; 2],
    /// `e(N2)` (rad/s), subtracted from the limit in `N`.
    pub subtracted: f64,
    /// Its error (rad/s), the bound of (2).
    pub error: f64,
}

impl QuadratureCorrection {
    /// The correction of (2) from the measurements at the coarsest rung and the next; `None`
    /// where either is missing or has no value.
    pub(super) fn between(
        coarse: Option<&QuadratureError>,
        finer: Option<&QuadratureError>,
    ) -> Option<Self> {
        let (coarse, finer) = (coarse?, finer?);
        // Two measurements of one pair of rules (not one from half the points and one from
        // twice: their formulas' own errors differ).
        if coarse.compared_with != finer.compared_with {
            return None;
        }
        let (e1, e2) = (coarse.error?, finer.error?);
        Some(Self {
            nodes: [coarse.nodes, finer.nodes],
            subtracted: e2,
            error: (e2 - e1).abs(),
        })
    }
}

/// `value` (rad/s) less the quadrature's error where `correction` removes it, and the
/// quadrature's part of its error: the correction's error, else `offset`, the size of the
/// rule's error it keeps ([`offset`]).
pub(super) fn corrected(
    value: f64,
    correction: Option<&QuadratureCorrection>,
    offset: f64,
) -> (f64, f64) {
    match correction {
        Some(c) => (value - c.subtracted, c.error),
        None => (value, offset),
    }
}

/// The size of the quadrature's error where it was measured (rad/s), else 0: what a value that
/// keeps the rule's offset adds to its error bar.
pub(super) fn offset(quadrature: Option<&QuadratureError>) -> f64 {
    quadrature.and_then(|q| q.error).map_or(0.0, f64::abs)
}

/// A refinement's measurements of the quadrature's error: at its coarsest rung, and at the next
/// where a correction may follow.
#[derive(Default)]
pub(super) struct Measured {
    pub(super) coarse: Option<Box<QuadratureError>>,
    pub(super) finer: Option<Box<QuadratureError>>,
}

impl Measured {
    /// Records a measurement: the coarsest rung's first, then the next rung's.
    pub(super) fn record(&mut self, measured: QuadratureError) {
        let slot = if self.coarse.is_none() {
            &mut self.coarse
        } else {
            &mut self.finer
        };
        *slot = Some(Box::new(measured));
    }

    /// The size of the coarsest rung's measurement ([`offset`]).
    pub(super) fn offset(&self) -> f64 {
        offset(self.coarse.as_deref())
    }

    /// The correction of (2), where both were measured.
    pub(super) fn correction(&self) -> Option<QuadratureCorrection> {
        QuadratureCorrection::between(self.coarse.as_deref(), self.finer.as_deref())
    }

    /// What the quadrature leaves in every answer to come (rad/s), and what that is: the
    /// correction's error, or the rule's whole error where no correction can come (`may_come`:
    /// one still may); `None` where nothing is known to be left.
    pub(super) fn left(&self, may_come: bool) -> Option<(&'static str, f64)> {
        match self.correction() {
            Some(c) => Some(("the error of the quadrature's correction", c.error)),
            None if may_come => None,
            None => Some(("the quadrature's own error", self.offset())).filter(|&(_, q)| q > 0.0),
        }
    }
}

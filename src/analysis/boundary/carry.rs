//! A boundary's Hopf points carried from the curve's `N` to an accuracy (`boundary --accuracy`,
//! docs/model.md section 11): `locate`'s refinement at each point's `q`, checked to start on the
//! curve's point, and the row it gives; with a spacing, only some points are refined and the
//! others take the refinement's correction interpolated in `ln q` ([`interpolate`]).

use serde::{Deserialize, Serialize};

use crate::Result;
use crate::analysis::boundary::{
    BoundaryObserver, BoundaryPoint, Recorder, WINDOW_MARGIN, reaching,
};
use crate::analysis::locate::{LocateSettings, Loss};
use crate::analysis::refine::{Refinement, refine};
use crate::engine::curve::{CurvePoint, Family};
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
    /// On a curve: the least distance in `ln q` between two points refined (0: every Hopf
    /// point); the points between take the correction of their neighbours ([`interpolate`]).
    pub spacing: f64,
}

/// Where the `omega_b` of a row of a boundary comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Answer {
    /// The curve's own value at its `N` (no accuracy asked for, a fold or branch point, or with
    /// a carry spacing a point not between two refined ones: not yet, or, where the curve
    /// stopped on a failure, for good).
    Curve,
    /// The point's own refinement in `N` ([`carry`]).
    Refined,
    /// The correction of the refined points on either side, interpolated ([`interpolate`]).
    Interpolated,
    /// Kept at the curve's `N`: its refinement gave no answer (the report says why).
    Kept,
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
        answer: Answer::Refined,
        points_per_edge: model.fluid.points_per_edge(),
    })
}

/// Carrying the points of a curve as it is followed (docs/model.md section 11).
impl<O: BoundaryObserver> Recorder<'_, O> {
    /// The row of the Hopf point `point` (at `omega` rad/s, on `model`) carried to `accuracy`
    /// ([`carry`]); the first point that falls short of it says why.
    pub(super) fn carried_row(
        &mut self,
        point: &CurvePoint,
        model: &Model,
        accuracy: PointAccuracy,
        omega: f64,
    ) -> Result<BoundaryPoint> {
        let carried = carry(self.family, &self.locate, accuracy, point, omega)?;
        let (row, short) = self.row(point, model, &carried)?;
        self.note_shortfall(point.q, short);
        Ok(row)
    }

    /// Keeps the first reason a point fell short of the accuracy, at `q`.
    fn note_shortfall(&mut self, q: f64, short: Option<String>) {
        if let (Some(why), None) = (short, &self.boundary.first_shortfall) {
            self.boundary.first_shortfall =
                Some(format!("at {} = {q}, {why}", self.family.field().key()));
        }
    }

    /// Whether the Hopf point at `q` is refined itself: every one without a carry spacing,
    /// else the first of a segment and one at least the spacing (in `ln q`) past the last
    /// refined.
    pub(super) fn refines(&self, q: f64, accuracy: PointAccuracy) -> bool {
        let segment = self.boundary.segments - 1;
        let last = self
            .boundary
            .points
            .iter()
            .rev()
            .take_while(|r| r.segment == segment)
            .find(|r| r.answer == Answer::Refined);
        accuracy.spacing <= 0.0
            || last.is_none_or(|r| (q.abs().ln() - r.q.abs().ln()).abs() >= accuracy.spacing)
    }

    /// Whether the member of the next Hopf point, whose RPY quadrature has `points_per_edge`,
    /// has another quadrature than the last row's of the same segment (with a carry spacing).
    /// The quadrature's points per edge are chosen per member from its edge lengths
    /// (docs/model.md section 9), so where they change along the curve its values jump by the
    /// change of the quadrature's error (on the thick rod of `tests/boundary.rs` at `N = 31`,
    /// `3.9e-3` of `omega_b` with two points per blob radius, `9e-4` with four): an
    /// interpolation of the refined correction across it would miss the jump, which its stated
    /// error does not see. So both points on either side of the change are refined, for the
    /// runs of one quadrature that [`interpolate`] keeps to.
    pub(super) fn quadrature_changes(
        &self,
        points_per_edge: Option<usize>,
        accuracy: PointAccuracy,
    ) -> bool {
        let segment = self.boundary.segments - 1;
        accuracy.spacing > 0.0
            && (self.boundary.points.last())
                .is_some_and(|r| r.segment == segment && r.points_per_edge != points_per_edge)
    }

    /// Refines the last row if it is a Hopf point not refined yet (before a change of the
    /// quadrature, [`Recorder::quadrature_changes`]).
    pub(super) fn carry_previous(&mut self, accuracy: PointAccuracy) -> Result<()> {
        let last = self.boundary.points.len().checked_sub(1);
        match self.uncarried.last() {
            Some(&(index, _)) if Some(index) == last => {
                self.carry_uncarried(self.uncarried.len() - 1, accuracy)
            }
            _ => Ok(()),
        }
    }

    /// Refines the `k`-th Hopf point not refined yet, in place of its row.
    fn carry_uncarried(&mut self, k: usize, accuracy: PointAccuracy) -> Result<()> {
        let (index, point) = self.uncarried.remove(k);
        let member = self.family.member(point.q)?;
        let omega = member.model.scales.omega_from_bar(point.p);
        self.boundary.points[index] = self.carried_row(&point, &member.model, accuracy, omega)?;
        Ok(())
    }

    /// The index of the first row of the current segment.
    pub(super) fn segment_start(&self) -> usize {
        let segment = self.boundary.segments - 1;
        let points = &self.boundary.points;
        points.len()
            - points
                .iter()
                .rev()
                .take_while(|r| r.segment == segment)
                .count()
    }

    /// Ends a segment followed with a carry spacing: refines its last Hopf point if it was not
    /// (where that refinement is kept at the curve's `N`, the point before it, and so on back
    /// to the last refined one), then more (each the one farthest in `ln q` from the refined
    /// ones of its run of one quadrature, [`quadrature_runs`]) until three are refined in every
    /// run that has them (the interpolation's error needs a second difference within a run),
    /// then, one at a time, the point whose interpolated answer states the largest error above
    /// the accuracy (where the correction bends more than the spacing can follow) between two
    /// refined points that reached it, until every such point reaches it; the rest are
    /// interpolated ([`interpolate`]).
    pub(super) fn close_segment(&mut self) -> Result<()> {
        let Some(accuracy) = self.accuracy.filter(|a| a.spacing > 0.0) else {
            return Ok(());
        };
        let start = self.segment_start();
        loop {
            interpolate(&mut self.boundary.points[start..], accuracy.accuracy);
            let rows = &self.boundary.points[start..];
            let runs = quadrature_runs(rows);
            // The last point past the last refined one (the segment's last point, or, where its
            // refinement was kept at the curve's N, the one before, and so on).
            let last_refined = rows
                .iter()
                .rposition(|r| r.answer == Answer::Refined)
                .map(|i| start + i);
            let past = self
                .uncarried
                .iter()
                .rposition(|(i, _)| last_refined.is_none_or(|l| *i > l));
            // The refined points of each run, in `ln q`.
            let mut refined_in = vec![Vec::new(); runs.last().map_or(0, |r| r + 1)];
            for (r, &run) in rows.iter().zip(&runs) {
                if r.answer == Answer::Refined {
                    refined_in[run].push(r.q.abs().ln());
                }
            }
            // Else, in a run of one quadrature with fewer than three refined points, the point
            // farthest from them.
            let distance = |k: usize| {
                let (index, point) = &self.uncarried[k];
                let refined = &refined_in[runs[index - start]];
                (refined.len() < 3).then(|| {
                    (refined.iter())
                        .map(|x| (point.q.abs().ln() - x).abs())
                        .fold(f64::INFINITY, f64::min)
                })
            };
            let farthest = (0..self.uncarried.len())
                .filter_map(|k| distance(k).map(|d| (k, d)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k);
            // Else the interpolated answer furthest from the accuracy (one without an error
            // first), between two refined points that reached it (next to one that did not,
            // at the node cap, refining the neighbours would not reach it either).
            let points = &self.boundary.points;
            let reached = |r: Option<&BoundaryPoint>| r.is_some_and(|r| r.reached == Some(true));
            let short = |k: usize| {
                let index = self.uncarried[k].0;
                let r = &points[index];
                let before = points[start..index]
                    .iter()
                    .rfind(|p| p.answer == Answer::Refined);
                let after = points[index..].iter().find(|p| p.answer == Answer::Refined);
                (r.answer == Answer::Interpolated
                    && r.reached == Some(false)
                    && reached(before)
                    && reached(after))
                .then(|| {
                    r.omega_b_error
                        .map_or(f64::INFINITY, |e| e / r.omega_b.abs())
                })
            };
            let worst = (0..self.uncarried.len())
                .filter_map(|k| short(k).map(|e| (k, e)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k);
            let Some(next) = past.or(farthest).or(worst) else {
                break;
            };
            self.carry_uncarried(next, accuracy)?;
        }
        self.uncarried.clear();
        self.boundary.local_exponents();
        self.observer.grown(&self.boundary)
    }
}

/// The run of one RPY quadrature each row of `rows` lies in: numbered from 0, the next where the
/// points per edge change from the row before.
fn quadrature_runs(rows: &[BoundaryPoint]) -> Vec<usize> {
    (rows.iter().enumerate())
        .scan(0, |run, (i, r)| {
            *run += usize::from(i > 0 && r.points_per_edge != rows[i - 1].points_per_edge);
            Some(*run)
        })
        .collect()
}

/// The Hopf rows of one segment of a boundary that were not refined themselves (`answer`
/// [`Answer::Curve`] or [`Answer::Interpolated`]) and lie between two refined rows `a`, `b`
/// (`answer` [`Answer::Refined`]; `accuracy` the relative accuracy asked for), given the
/// refinement's correction interpolated linearly in `x = ln q` (docs/model.md section 11):
///
/// ```text
/// delta = ln(omega_b / curve_omega_b)   at the refined rows,
/// omega_b(x) = curve_omega_b(x) exp(delta_a + t (delta_b - delta_a)),   t = (x - x_a)/(x_b - x_a),
/// e(x) = r_a + t (r_b - r_a) + (x - x_a)(x_b - x) |delta''|,
/// ```
///
/// `e` the relative error: the refined rows' relative errors `r` interpolated, plus twice the
/// error of linear interpolation, `(x - x_a)(x_b - x) |delta''| / 2`, with `|delta''|` the
/// larger of the second divided differences of `delta` over the refined triples `(a-, a, b)`
/// and `(a, b, b+)` (`2 [(d3 - d2)/(x3 - x2) - (d2 - d1)/(x2 - x1)] / (x3 - x1)`): an estimate
/// from points a spacing apart, of their own errors' noise besides, which on the thick rod of
/// `tests/boundary.rs` came out 0.88 times the error it estimates in the middle of an interval
/// (hence the factor two). With only two refined rows there is no `delta''`: the
/// row takes the interpolated value without an error and does not reach the accuracy. `w`,
/// `Fpbar`, `hbar`, `precision` and `l1` stay the curve's own; `nodes` is the finer of `a`'s
/// and `b`'s. Where the RPY quadrature's points per edge change between two rows, the curve's
/// values jump, and `delta` with them: rows are interpolated, and triples taken, only within a
/// run of one quadrature ([`Recorder::quadrature_changes`] refines both sides of a change).
pub(super) fn interpolate(rows: &mut [BoundaryPoint], accuracy: f64) {
    /// A refined row: its index, run of one quadrature, `x`, `delta`, relative error and `N`.
    struct Refined {
        index: usize,
        run: usize,
        x: f64,
        delta: f64,
        relative: Option<f64>,
        nodes: usize,
    }
    let runs = quadrature_runs(rows);
    let refined: Vec<Refined> = (rows.iter().enumerate())
        .filter(|(_, r)| r.answer == Answer::Refined)
        .map(|(index, r)| Refined {
            index,
            run: runs[index],
            x: r.q.abs().ln(),
            delta: (r.omega_b / r.curve_omega_b).ln(),
            relative: r.omega_b_error.map(|e| e / r.omega_b.abs()),
            nodes: r.nodes,
        })
        .collect();
    // |delta''| over the triple of refined rows starting at the k-th, within one run.
    let curvature = |k: usize| -> Option<f64> {
        let [p1, p2, p3] = [0, 1, 2].map(|j| refined.get(k + j));
        let (p1, p2, p3) = (p1?, p2?, p3?);
        if p1.run != p3.run {
            return None;
        }
        let slope = |a: &Refined, b: &Refined| (b.delta - a.delta) / (b.x - a.x);
        Some((2.0 * (slope(p2, p3) - slope(p1, p2)) / (p3.x - p1.x)).abs())
    };
    for (k, pair) in refined.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        if a.run != b.run {
            continue;
        }
        let bend = [k.checked_sub(1).and_then(curvature), curvature(k)]
            .into_iter()
            .flatten()
            .reduce(f64::max);
        for row in &mut rows[a.index + 1..b.index] {
            if row.kind != EventKind::Hopf || row.answer == Answer::Kept {
                continue;
            }
            let x = row.q.abs().ln();
            let t = (x - a.x) / (b.x - a.x);
            let correction = (a.delta + t * (b.delta - a.delta)).exp();
            let error = (a.relative.zip(b.relative).zip(bend))
                .map(|((ra, rb), bend)| ra + t * (rb - ra) + (x - a.x) * (b.x - x) * bend);
            // omegabar_b / omega_b is the member's time scale, the same at every N.
            let scale = row.omegabar_b / row.omega_b;
            row.omega_b = row.curve_omega_b * correction;
            row.omegabar_b = row.omega_b * scale;
            row.omega_b_error = error.map(|e| e * row.omega_b.abs());
            row.reached = Some(error.is_some_and(|e| e < accuracy));
            row.nodes = a.nodes.max(b.nodes);
            row.answer = Answer::Interpolated;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Hopf row at `q` whose curve gives `curve` rad/s; refined to `omega` +- `error` where
    /// given.
    fn row(q: f64, curve: f64, refined: Option<(f64, f64)>) -> BoundaryPoint {
        let (omega_b, omega_b_error, answer) = match refined {
            Some((w, e)) => (w, Some(e), Answer::Refined),
            None => (curve, None, Answer::Curve),
        };
        BoundaryPoint {
            segment: 0,
            q,
            omega_b,
            omega_b_error,
            reached: Some(refined.is_some()),
            omegabar_b: 2.0 * omega_b,
            kind: EventKind::Hopf,
            w: 1.0,
            wbar: 2.0,
            fpbar: 0.0,
            hbar: 1.0,
            m_loc: None,
            m_loc_error: None,
            precision: 1e-9,
            l1: None,
            l1_precision: None,
            criticality: None,
            nodes: if refined.is_some() { 241 } else { 61 },
            curve_omega_b: curve,
            curve_nodes: 61,
            answer,
            points_per_edge: None,
        }
    }

    /// With the correction `delta = ln(omega_b / curve_omega_b)` quadratic in `x = ln q`
    /// (`delta = c x^2`, `delta'' = 2c` exactly, so the second difference of any three refined
    /// points is exact), a row between two refined ones takes `curve exp(delta)` linearly
    /// interpolated, which misses the true one by exactly `(x - x_a)(x_b - x) c` in `ln omega_b`, and
    /// states that twice on top of the refined rows' relative errors interpolated; `omegabar_b`
    /// keeps the member's time scale. A row past the last refined one is left as it was.
    #[test]
    fn the_interpolated_correction_states_twice_the_error_of_linear_interpolation() {
        let c = 0.05;
        let curve = |x: f64| 10.0 + x;
        let refined = |x: f64, r: f64| {
            let w = curve(x) * (c * x * x).exp();
            row(x.exp(), curve(x), Some((w, r * w)))
        };
        let mut rows = vec![
            refined(-2.0, 1e-3),
            row(1.5f64.exp().recip(), curve(-1.5), None),
            refined(-1.0, 3e-3),
            refined(-0.5, 2e-3),
            row(0.2f64.exp(), curve(0.2), None),
        ];
        interpolate(&mut rows, 5e-2);
        let between = &rows[1];
        assert_eq!(between.answer, Answer::Interpolated);
        let (x, xa, xb) = (-1.5, -2.0, -1.0);
        let exact = curve(x) * (c * x * x).exp();
        let linear = curve(x) * (c * (xa * xa + xb * xb) / 2.0).exp();
        assert!((between.omega_b - linear).abs() <= 1e-12 * linear);
        let missed = (between.omega_b / exact).ln().abs();
        assert!((missed - (x - xa) * (xb - x) * c).abs() <= 1e-3 * missed);
        let stated = between.omega_b_error.unwrap() / between.omega_b;
        assert!((stated - (2e-3 + 2.0 * missed)).abs() <= 1e-3 * stated);
        assert_eq!(between.reached, Some(true));
        assert_eq!(between.nodes, 241);
        assert!((between.omegabar_b / between.omega_b - 2.0).abs() <= 1e-12);
        assert_eq!(rows[4].answer, Answer::Curve);
        assert_eq!(rows[4].omega_b, curve(0.2));
    }

    /// Where the quadrature's points per edge change between two rows (the curve's values jump
    /// there by `j`), no row is interpolated across the change, and no second difference spans
    /// it: a row between two refined rows of one quadrature, with the refined rows across the
    /// change farther off, takes its correction from its own run only and states the error of
    /// that run's triple, the jump being in no stated error. A row whose refined neighbours lie
    /// on either side of a change (the refinement next to it kept) is left as the curve's.
    #[test]
    fn no_interpolation_spans_a_change_of_the_quadrature() {
        // A jump large enough that a triple across it would give the larger second difference.
        let (c, j) = (0.05, 0.3);
        let curve = |x: f64| 10.0 + x;
        // The curve jumps by j at x = 0: the correction jumps by -j there.
        let refined = |x: f64, per_edge: usize| {
            let jump = if x > 0.0 { -j } else { 0.0 };
            let w = curve(x) * (c * x * x + jump).exp();
            BoundaryPoint {
                points_per_edge: Some(per_edge),
                ..row(x.exp(), curve(x), Some((w, 1e-3 * w)))
            }
        };
        let plain = |x: f64, per_edge: usize| BoundaryPoint {
            points_per_edge: Some(per_edge),
            ..row(x.exp(), curve(x), None)
        };
        let mut rows = vec![
            refined(-1.5, 8),
            refined(-1.0, 8),
            plain(-0.75, 8),
            refined(-0.5, 8),
            plain(-0.25, 8),
            plain(0.25, 4),
            refined(0.5, 4),
            refined(1.0, 4),
        ];
        interpolate(&mut rows, 5e-2);
        let between = &rows[2];
        assert_eq!(between.answer, Answer::Interpolated);
        let (x, xa, xb) = (-0.75, -1.0, -0.5);
        let missed = (between.omega_b / (curve(x) * (c * x * x).exp()))
            .ln()
            .abs();
        assert!((missed - (x - xa) * (xb - x) * c).abs() <= 1e-3 * missed);
        let stated = between.omega_b_error.unwrap() / between.omega_b;
        assert!((stated - (1e-3 + 2.0 * missed)).abs() <= 1e-3 * stated);
        for across in &rows[4..6] {
            assert_eq!(across.answer, Answer::Curve);
        }
    }
}

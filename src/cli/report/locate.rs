//! The reports of `locate`: one rung's critical point, and a refinement or a ladder in `N` with
//! the errors of its answer (docs/model.md section 10).

use std::fmt::{self, Formatter};

use super::Section;
use crate::cli::numbers::{maybe, rounded_up};

use helixbif::analysis::locate::{Located, Loss};
use helixbif::analysis::refine::{
    Answer, Ladder, LyapunovError, QuadratureCorrection, QuadratureError, Refinement,
};
use helixbif::engine::criticality::Verdict;
use helixbif::model::fluid::FluidModel;
use helixbif::study::locate::LocateResult;

impl Section for Located {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        match (self.kind, self.omega_b, self.omegabar_b) {
            (Loss::UnstableAtRest, _, _) => write!(
                f,
                "the rest state of `{study}` at N = {} is already unstable ({} eigenvalues with \
                 Re s > 0 at omega = 0): there is no loss of stability to locate \
                 (kind: unstable_at_rest)",
                self.nodes, self.unstable_at_rest
            ),
            (_, Some(w), Some(wb)) => {
                writeln!(
                    f,
                    "critical rate of `{study}` at N = {}: {}",
                    self.nodes, self.kind
                )?;
                writeln!(
                    f,
                    "  omega_b    = {w:.10} rad/s   (omegabar_b = {wb:.8e}; pinned down to {:.1e} relative at this N, which says nothing of its discretization error)",
                    self.precision.unwrap_or(f64::NAN)
                )?;
                if let Some(im) = self.im {
                    writeln!(
                        f,
                        "  frequency  = {im:.8} rad/s     (Im(s) of the critical mode, co-rotating frame)"
                    )?;
                }
                if let (Some(l1), Some(dl1), Some(verdict)) =
                    (self.l1, self.l1_precision, self.criticality)
                {
                    writeln!(
                        f,
                        "  l1         = {l1:.6e} +- {dl1:.1e}   ({verdict}; first Lyapunov coefficient at this N, +- the error of its finite differences, not of the discretization; critical mode scaled to a largest node displacement of ell, solver units)"
                    )?;
                }
                if let Some(why) = &self.l1_failure {
                    writeln!(f, "  l1         not computed: {why}")?;
                }
                writeln!(
                    f,
                    "  Fp         = {} N     (Fpbar = {})",
                    self.fp.map_or("-".into(), |v| format!("{v:.6e}")),
                    maybe(self.fpbar, 6)
                )?;
                writeln!(f, "  hbar       = {}", maybe(self.hbar, 6))?;
                for line in near_misses(self) {
                    writeln!(f, "{line}")?;
                }
                write!(
                    f,
                    "  ({} continuation points, {} corrector iterations)",
                    self.points, self.corrector_iterations
                )
            }
            _ => {
                write!(
                    f,
                    "the branch of `{study}` at N = {} stays stable up to omega_max = {} rad/s \
                     (kind: none)",
                    self.nodes, self.omega_max
                )?;
                for line in near_misses(self) {
                    write!(f, "\n{line}")?;
                }
                Ok(())
            }
        }
    }
}

/// What the probes of the branch's near misses found (docs/model.md section 5), one line each,
/// where any were made.
fn near_misses(located: &Located) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some([a, b]) = located.window_between {
        lines.push(format!(
            "  window     the continuation stepped over a window of instability inside its step \
             from omega = {a:.6e} to {b:.6e} rad/s; a probe of that near miss found it ({} probes), \
             and its loss is the answer",
            located.probes
        ));
    }
    match &located.near_miss_unresolved {
        Some(why) => lines.push(format!(
            "  WARNING    a near miss was neither resolved nor excluded, {why}: a window of \
             instability there may have been stepped over"
        )),
        None if located.window_between.is_none() && located.probes > 0 => lines.push(format!(
            "  near miss  where a mode came near the axis between points, {} probes found every \
             state stable",
            located.probes
        )),
        None => {}
    }
    lines
}

impl Section for LocateResult {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            LocateResult::Single(located) => located.show(study, f),
            LocateResult::Refined(refinement) => refinement.show(study, f),
            LocateResult::Ladder(ladder) => ladder.show(study, f),
        }
    }
}

impl Section for Ladder {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(f, "omega_b of `{study}` over a ladder of node counts:")?;
        for ((n, w), k) in self.nodes.iter().zip(&self.omega_b).zip(&self.kinds) {
            writeln!(f, "  N = {n:3}: omega_b = {w:.8} rad/s ({k})")?;
        }
        let range = match self.nodes_max {
            Some(max) => format!("admissible N <= {max}"),
            None => "no admissible-N limit".to_owned(),
        };
        write!(
            f,
            "  extrapolated: omega_b = {:.6} +- {:.6} rad/s ({}; {range})",
            self.omega_b_extrapolated, self.omega_b_error, self.model
        )?;
        match (&self.quadrature_correction, &self.quadrature) {
            (Some(c), coarse) => {
                correction_line(f, coarse.as_ref(), c)?;
                write!(
                    f,
                    "\n  error of the limit: the extrapolation's, {:.2e} rad/s, plus that of the \
                     quadrature's correction",
                    self.extrapolation_error
                )?;
            }
            (None, Some(q)) => {
                quadrature_line(f, q, Some(self.omega_b_extrapolated))?;
                if q.error.is_some() {
                    write!(
                        f,
                        "\n  error of the limit: the extrapolation's, {:.2e} rad/s, plus the size \
                         of the quadrature error",
                        self.extrapolation_error
                    )?;
                }
            }
            (None, None) => {}
        }
        Ok(())
    }
}

/// The line of the RPY quadrature's own error `q` (docs/model.md section 10): its value, where
/// it was measured, and the limit with exact quadrature from the limit in `N` (`limit`, where
/// there is one and it keeps the quadrature's error); or why it was not measured, and so is not
/// in the error.
fn quadrature_line(f: &mut Formatter<'_>, q: &QuadratureError, limit: Option<f64>) -> fmt::Result {
    match (q.error, &q.failed) {
        (Some(e), _) => {
            write!(
                f,
                "\n  quadrature error of omega_b: {e:+.2e} rad/s at {} points per blob radius \
                 (from {} at N = {}: second order in the point spacing, nearly the same at every \
                 rung",
                q.points_per_blob,
                q.compared_with.unwrap_or(f64::NAN),
                q.nodes
            )?;
            if let Some(limit) = limit {
                write!(f, "; limit with exact quadrature {:.8} rad/s", limit - e)?;
            }
            write!(f, ")")
        }
        (None, Some(why)) => write!(
            f,
            "\n  quadrature error of omega_b NOT measured, so not in the error: {why}"
        ),
        (None, None) => Ok(()),
    }
}

/// The line of the quadrature's correction `c` of an answer (a limit in `N`, or a refinement's
/// finest rung; docs/model.md section 10): both measurements (the coarser, `coarse`), what was
/// subtracted and the error of that.
fn correction_line(
    f: &mut Formatter<'_>,
    coarse: Option<&QuadratureError>,
    c: &QuadratureCorrection,
) -> fmt::Result {
    write!(
        f,
        "\n  quadrature error of omega_b: {:+.2e} rad/s at N = {}, {:+.2e} at N = {} ({} against \
         {} points per blob radius, second order in the point spacing); {:+.2e} removed from \
         the answer, with an error of {:.2e} rad/s (the change between the two rungs)",
        coarse.and_then(|q| q.error).unwrap_or(f64::NAN),
        c.nodes[0],
        c.subtracted,
        c.nodes[1],
        coarse.map_or(f64::NAN, |q| q.points_per_blob),
        coarse.and_then(|q| q.compared_with).unwrap_or(f64::NAN),
        c.subtracted,
        c.error
    )
}

/// The line of the Lyapunov coefficient's error in `N`, `e`, and the verdict it leaves
/// (docs/model.md section 12).
fn lyapunov_line(
    f: &mut Formatter<'_>,
    e: &LyapunovError,
    verdict: Option<Verdict>,
) -> fmt::Result {
    let rungs = e
        .rungs
        .iter()
        .map(|r| format!("{:.6e} +- {:.1e} at N = {}", r.l1, r.precision, r.nodes))
        .collect::<Vec<_>>()
        .join(", ");
    let rungs = if rungs.is_empty() {
        String::new()
    } else {
        format!(" (l1 = {rungs})")
    };
    match (e.error, &e.failed) {
        (Some(error), _) => {
            let settled = match verdict {
                Some(Verdict::Undetermined) | None => {
                    "undetermined: its sign is not settled in N (|l1| within its errors, or the \
                     rungs disagree)"
                        .to_owned()
                }
                Some(v) => format!("{v}: its sign settled in N"),
            };
            write!(
                f,
                "\n  error in N of l1: {error:.1e}, first order from the two finest rungs{rungs}, \
                 docs/model.md section 12; {settled}"
            )
        }
        (None, why) => write!(
            f,
            "\n  error in N of l1 NOT estimated{rungs}: {}; the verdict is the finest rung's where \
             the rungs agree in sign, else undetermined",
            why.as_deref().unwrap_or("no reason given")
        ),
    }
}

/// The node counts of a refinement's three finest rungs, those of its limit: `a, b, c`.
fn limit_rungs(r: &Refinement) -> String {
    r.rungs[r.rungs.len().saturating_sub(3)..]
        .iter()
        .map(|g| g.nodes.to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// Where a refinement's answer stands: `N = n` for the finest rung, `limit of N = a, b, c` for
/// the limit of the three finest rungs; either `less the quadrature error` where it was removed.
fn answered_at(r: &Refinement) -> String {
    let at = match r.answer {
        Answer::FinestRung => format!("N = {}", r.finest.nodes),
        Answer::Limit => format!("limit of N = {}", limit_rungs(r)),
    };
    if r.quadrature_correction.is_some() {
        format!("{at} less the quadrature error")
    } else {
        at
    }
}

impl Section for Refinement {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        let fluid = match self.fluid {
            FluidModel::Rpy => "RPY line",
            FluidModel::Lighthill => "Lighthill's operator, the paper's",
        };
        let verdict = self
            .finest
            .criticality
            .map_or(String::new(), |v| format!(", {v}"));
        let n = self.finest.nodes;
        let at = answered_at(self);
        // The one number first: omega_b with its error.
        match (self.finest.omega_b, self.omega_b_error, self.relative_error) {
            (Some(w), Some(e), Some(rel)) if self.accuracy.is_none() => writeln!(
                f,
                "omega_b = {w:.6} +- {} rad/s ({}{verdict}; estimated error {} \
                 relative at the study's N = {n}, {fluid})",
                rounded_up(e, 2),
                self.finest.kind,
                rounded_up(rel, 2)
            )?,
            (Some(w), Some(e), Some(rel)) if self.reached => writeln!(
                f,
                "omega_b = {w:.6} +- {} rad/s ({}{verdict}; converged to {} relative{}, \
                 {fluid}, {at})",
                rounded_up(e, 2),
                self.finest.kind,
                rounded_up(rel, 1),
                if self.quadrature.as_ref().is_some_and(|q| q.error.is_none()) {
                    " in N, the quadrature's error NOT measured"
                } else {
                    ""
                }
            )?,
            (Some(w), Some(e), Some(rel)) => writeln!(
                f,
                "omega_b = {w:.6} +- {} rad/s ({}{verdict}; NOT converged to {:.0e}: \
                 estimated error {} relative, {fluid}, {at})",
                rounded_up(e, 2),
                self.finest.kind,
                self.accuracy.unwrap_or(f64::NAN),
                rounded_up(rel, 2)
            )?,
            (Some(w), _, _) => writeln!(
                f,
                "omega_b = {w:.6} rad/s ({}{verdict}; error NOT estimated, {fluid}, N = {n})",
                self.finest.kind
            )?,
            _ => {}
        }
        if self.rungs.len() > 1 {
            writeln!(f, "refinement of `{study}` in N:")?;
            for r in &self.rungs {
                let how = match (&r.fallback, &r.certificate) {
                    (Some(why), _) => format!("continuation from rest; {why}"),
                    (None, Some(c)) => format!(
                        "sequenced; stable below at {:.6} rad/s{}",
                        c.omega_below,
                        if c.checked.is_empty() {
                            String::new()
                        } else {
                            format!(
                                ", {} point{} of the coarsest branch checked",
                                c.checked.len(),
                                if c.checked.len() == 1 { "" } else { "s" }
                            )
                        }
                    ),
                    (None, None) => "continuation from rest".into(),
                };
                let how = match r.window_between {
                    Some([a, b]) => format!(
                        "{how}, a window of instability inside its step from {a:.6} to {b:.6} \
                         rad/s found by probing a near miss"
                    ),
                    None => how,
                };
                writeln!(
                    f,
                    "  N = {:4}: omega_b = {} rad/s ({}, {how}; {:.1} s)",
                    r.nodes,
                    maybe(r.omega_b, 10),
                    r.kind,
                    r.seconds
                )?;
                if let Some(why) = &r.near_miss_unresolved {
                    writeln!(
                        f,
                        "  WARNING: at N = {} a near miss was neither resolved nor excluded, {why}: \
                         a window of instability below omega_b may have been stepped over",
                        r.nodes
                    )?;
                }
            }
        }
        // The finest rung's own point (the top-level omega_b may be the limit).
        let ratio = self
            .finest
            .omegabar_b
            .zip(self.finest.omega_b)
            .map_or(f64::NAN, |(wb, w)| wb / w);
        Located {
            omega_b: self.omega_b_finest,
            omegabar_b: self.omega_b_finest.map(|w| w * ratio),
            ..self.finest.clone()
        }
        .show(study, f)?;
        if let Some(est) = &self.estimate {
            write!(
                f,
                "\n  discretization error of omega_b at N = {}: {:.2e} rad/s ({}",
                self.finest.nodes, est.error, est.method
            )?;
            if let Some(p) = est.observed_order {
                write!(f, "; observed order {p:.2}")?;
            }
            write!(f, "; limit {:.8} rad/s)", est.limit)?;
        }
        let correction = self.quadrature_correction.as_deref();
        let limit = match (self.answer, self.finest.omega_b, self.extrapolation_error) {
            (Answer::Limit, Some(w), Some(e)) => {
                // The limit in N itself, before the quadrature's correction.
                let w = w + correction.map_or(0.0, |c| c.subtracted);
                write!(
                    f,
                    "\n  limit of N = {}: {w:.8} rad/s, its error in N {e:.2e} rad/s (the \
                     second-order limit of the two finest rungs; its error the change from the \
                     limit of the pair before, which covers it for a remainder of one order \
                     above 1: docs/model.md section 10)",
                    limit_rungs(self)
                )?;
                Some(w)
            }
            _ => self.estimate.as_ref().map(|est| est.limit),
        };
        match (correction, &self.quadrature) {
            (Some(c), coarse) => correction_line(f, coarse.as_deref(), c)?,
            (None, Some(q)) => {
                quadrature_line(f, q, limit)?;
                // A second measurement that could not be made (so no correction).
                if let Some(why) = self
                    .quadrature_finer
                    .as_ref()
                    .and_then(|q| q.failed.as_ref())
                {
                    write!(
                        f,
                        "\n  quadrature error NOT measured again at the second rung, so the \
                         answer keeps it: {why}"
                    )?;
                }
            }
            (None, None) => {}
        }
        if let (Some(e), Some(rel)) = (self.omega_b_error, self.relative_error) {
            let in_n = match self.answer {
                Answer::Limit => "the error of the limit in N",
                Answer::FinestRung => "the discretization error",
            };
            write!(
                f,
                "\n  error of omega_b: {e:.2e} rad/s ({rel:.2e} relative), {in_n}{}",
                if correction.is_some() {
                    " plus that of the quadrature's correction"
                } else if self.quadrature.as_ref().is_some_and(|q| q.error.is_some()) {
                    " plus the size of the quadrature error"
                } else {
                    ""
                }
            )?;
        }
        if let Some(e) = &self.lyapunov_error {
            lyapunov_line(f, e, self.finest.criticality)?;
        }
        match (&self.stopped, self.accuracy) {
            (None, Some(a)) => write!(f, "\n  accuracy {a:.1e} reached"),
            (Some(why), Some(a)) => write!(f, "\n  accuracy {a:.1e} NOT reached: {why}"),
            (Some(why), None) if self.omega_b_error.is_none() => {
                write!(f, "\n  no error estimate: {why}")
            }
            (Some(why), None) => write!(f, "\n  stopped: {why}"),
            (None, None) => Ok(()),
        }
    }
}

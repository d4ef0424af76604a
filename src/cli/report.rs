//! The text of each command's report: one value per command, `Serialize` (for `--json`) and
//! `Display` (for people, through [`Section`] and [`Text`]), printed in one place by the front end
//! so that `--json` can never be forgotten.

use std::fmt::{self, Display, Formatter};

use serde::Serialize;

mod locate;

use helixbif::analysis::boundary::BoundaryEvent;
use helixbif::analysis::dynamics::Bisection;
use helixbif::analysis::solve::SolutionSummary;
use helixbif::numerics::fit::PowerLaw;
use helixbif::study::boundary::BoundaryReport;
use helixbif::study::boundary::BoundaryStudy;
use helixbif::study::branch::BranchReport;
use helixbif::study::dynamics::AverageRow;
use helixbif::study::figures::Fitted;
use helixbif::study::orbits::OrbitsReport;
use helixbif::study::output::LeftOut;
use helixbif::study::phase::{CurveOutcome, PhaseResult};
use helixbif::study::run::StudyResult;
use helixbif::study::shapes::{CriticalMode, ShapesResult};
use helixbif::study::simulate::SimulateReport;
use helixbif::study::slurm::{SlurmScripts, SlurmSubmission};
use helixbif::study::sweep::{Reach, SweepSummary};

/// A command's result, shown as text or as one JSON value.
pub trait Report: Display {
    fn to_json(&self) -> serde_json::Value;
}

impl<T: Serialize + Display> Report for T {
    fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_else(|e| serde_json::json!({ "error": e.to_string() }))
    }
}

/// A result about one study: the study's name beside the result's own fields.
#[derive(Serialize)]
pub struct Titled<T> {
    pub study: String,
    #[serde(flatten)]
    pub result: T,
}

/// The text of a result that stands alone, without a study's name.
pub trait Text {
    fn text(&self, f: &mut Formatter<'_>) -> fmt::Result;
}

/// A result shown as its own [`Text`]; its JSON is the result's own.
#[derive(Serialize)]
#[serde(transparent)]
pub struct Plain<T>(pub T);

impl<T: Text> Display for Plain<T> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        self.0.text(f)
    }
}

/// The text of a result about the study `study`.
pub trait Section {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result;
}

impl<T: Section> Display for Titled<T> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        self.result.show(&self.study, f)
    }
}

impl Section for SolutionSummary {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        let o = &self.observables;
        let e = self.errors.as_ref();
        match (e, &self.errors_missing) {
            (Some(e), _) => writeln!(
                f,
                "steady state of `{study}` at N = {} nodes; each value +- its estimated error \
                 against the continuous model (in N from N = {}{}; docs/model.md section 10)",
                self.nodes,
                e.coarse_nodes,
                match (e.quadrature_compared_with, &e.quadrature_missing) {
                    (Some(p), _) => format!(
                        ", plus the quadrature's own error (against {p} points per blob radius)"
                    ),
                    (None, Some(why)) =>
                        format!("; the quadrature's own error NOT included: {why}"),
                    (None, None) => String::new(),
                }
            )?,
            (None, why) => writeln!(
                f,
                "steady state of `{study}` at N = {} nodes; errors NOT estimated: {}",
                self.nodes,
                why.as_deref().unwrap_or("no reason given")
            )?,
        }
        // ` +- error` of a value (nothing where the errors are not estimated).
        let pm = |error: Option<f64>| error.map_or(String::new(), |e| format!(" +- {e:.1e}"));
        writeln!(
            f,
            "  omega    = {:.6e} rad/s   (omegabar = {:.6e})",
            o.omega, o.omegabar
        )?;
        writeln!(
            f,
            "  Fp       = {:.6e}{} N   (Fpbar = {:.6e}{}; rigid helix {:.6e}{})",
            o.fp,
            pm(e.map(|e| e.fp)),
            o.fpbar,
            pm(e.map(|e| e.fpbar)),
            self.fpbar_rigid,
            pm(e.map(|e| e.fpbar_rigid))
        )?;
        writeln!(f, "  Tp       = {:.6e}{} N m", o.tp, pm(e.map(|e| e.tp)))?;
        match o.eta {
            Some(eta) => writeln!(f, "  eta      = {eta:.6e}{}", pm(e.and_then(|e| e.eta)))?,
            None => writeln!(f, "  eta      = undefined at rest")?,
        }
        writeln!(
            f,
            "  h        = {:.6e}{} m   (h0 = {:.6e}{} m, hbar = {:.6}{})",
            o.h,
            pm(e.map(|e| e.h)),
            o.h0,
            pm(e.map(|e| e.h0)),
            o.hbar,
            pm(e.map(|e| e.hbar))
        )?;
        write!(
            f,
            "  Newton   : {} iterations, residual {:.3e}; history {}",
            self.newton_iterations,
            self.residual_norm,
            self.residual_history
                .iter()
                .map(|r| format!("{r:.1e}"))
                .collect::<Vec<_>>()
                .join(" ")
        )
    }
}

impl Section for BranchReport {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "branch of `{study}` at N = {}: {} points up to omega = {:.4} rad/s ({}), {} events, \
             {:.2} s; written to {}",
            self.nodes,
            self.points,
            self.omega_reached,
            self.stop,
            self.events.len(),
            self.seconds,
            self.out
        )?;
        for e in &self.events {
            write!(
                f,
                "\n  {:<13} omega = {:.8} rad/s (omegabar = {:.6e}), eigenvalue {:+.3e} {:+.4e} i /s",
                e.kind, e.omega, e.omegabar, e.re, e.im
            )?;
        }
        for [a, b] in &self.windows_between {
            write!(
                f,
                "\n  window        the continuation stepped over a window of instability inside \
                 its step from omega = {a:.6e} to {b:.6e} rad/s; probes of that near miss found \
                 it, and its loss and regain are among the events"
            )?;
        }
        for why in &self.near_miss_unresolved {
            write!(
                f,
                "\n  WARNING       a near miss was not resolved, {why}: a window of instability \
                 there may have been stepped over"
            )?;
        }
        if self.probes > 0
            && self.windows_between.is_empty()
            && self.near_miss_unresolved.is_empty()
        {
            write!(
                f,
                "\n  near miss     where a mode came near the axis between points, {} probes \
                 found every state stable",
                self.probes
            )?;
        }
        Ok(())
    }
}

impl Section for SweepSummary {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "sweep `{study}`: {} points ({} already done, {} computed, {} failed) in {:.1} s -> {}",
            self.points, self.already_done, self.computed, self.failed, self.seconds, self.file
        )?;
        warned(self.warned, f)?;
        if let Some(reach) = &self.reach {
            reached(reach, f)?;
        }
        Ok(())
    }
}

/// How many points of a sweep file finished with a near miss left unresolved, where any did.
fn warned(count: usize, f: &mut Formatter<'_>) -> fmt::Result {
    if count == 0 {
        return Ok(());
    }
    write!(
        f,
        "\n  WARNING: {count} points have a near miss their probes neither resolved nor excluded \
         (a window of instability below omega_b may have been stepped over; column status): \
         fits and figures leave them out"
    )
}

/// How many points of a sweep file reached its accuracy.
fn reached(r: &Reach, f: &mut Formatter<'_>) -> fmt::Result {
    write!(
        f,
        "\n  omega_b carried to a relative accuracy of {:e}: reached at {} of the {} points \
         located (column reached)",
        r.accuracy,
        r.carried - r.not_reached,
        r.carried
    )
}

impl Section for SimulateReport {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "simulated `{study}` at omega = {} rad/s for {} s: {} steps ({} rejected), {:.1} s; \
             written to {}",
            self.omega, self.t_end, self.steps, self.rejected, self.seconds, self.out
        )?;
        if let (Some(h), Some(hs), Some(fp), Some(fs)) = (
            self.hbar_mean,
            self.hbar_std,
            self.fpbar_mean,
            self.fpbar_std,
        ) {
            write!(
                f,
                "\n  after t = {} s: hbar = {h:.6} +- {hs:.2e}, Fpbar = {fp:.6} +- {fs:.2e}",
                self.transient
            )?;
            if let (Some(e), Some(es)) = (self.eta_mean, self.eta_std) {
                write!(f, ", eta = {e:.6} +- {es:.2e}")?;
            }
        }
        if let Some(o) = &self.orbit {
            write!(
                f,
                "\n  started on orbit {} (period {:.6} s, largest multiplier {:.4}; period \
                 averages hbar = {:.6}, Fpbar = {:.6}); per period (cycles.csv):",
                o.index, o.period, o.max_multiplier, o.hbar_mean, o.fpbar_mean
            )?;
            for c in &o.cycles {
                write!(
                    f,
                    "\n    {:>3}: hbar = {:.6}, Fpbar = {:.6}, |hbar - orbit| <= {:.2e}, period {}",
                    c.cycle,
                    c.hbar_mean,
                    c.fpbar_mean,
                    c.deviation,
                    c.period.map_or("-".into(), |p| format!("{p:.6} s"))
                )?;
            }
        }
        Ok(())
    }
}

/// What `helixbif run` reports: the study's kind, where it wrote, and the kind's own summary.
#[derive(Serialize)]
pub struct RunReport {
    pub study: String,
    pub kind: String,
    pub seconds: f64,
    pub out: String,
    pub result: StudyResult,
}

/// The text of `run`: a line naming the study, its kind, the time and the folder, then the
/// report of the command the kind runs (`branch`, `locate`, `sweep`, `boundary`, `orbits`), or
/// the kind's own summary (`phase`, `shapes`, `dynamics`).
impl Display for RunReport {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "study `{}` ({}) done in {:.1} s; results in {}",
            self.study, self.kind, self.seconds, self.out
        )?;
        let study = self.study.as_str();
        match &self.result {
            StudyResult::Branch { cases } => {
                for (k, c) in cases.iter().enumerate() {
                    if k > 0 {
                        writeln!(f)?;
                    }
                    if cases.len() == 1 {
                        c.report.show(study, f)?;
                    } else {
                        c.report.show(&format!("{study}, case {}", c.case), f)?;
                    }
                }
                Ok(())
            }
            StudyResult::Locate { result } => result.show(study, f),
            StudyResult::Sweep { summary, fits } => {
                summary.show(study, f)?;
                for fit in fits.iter().flatten() {
                    write!(f, "\n  figure {}: ", fit.figure)?;
                    sweep_fit(&fit.fit, f)?;
                    if !fit.left_out.is_empty() {
                        write!(f, " ({} rows left out)", fit.left_out.len())?;
                    }
                }
                Ok(())
            }
            StudyResult::Phase(p) => phase(p, f),
            StudyResult::Boundary(b) => boundary_study(b, f),
            StudyResult::Shapes(s) => shapes(s, f),
            StudyResult::Dynamics { rows } => dynamics(rows, f),
            StudyResult::Orbits { report, .. } => report.show(study, f),
        }
    }
}

/// One line for the fit of a sweep figure.
fn sweep_fit(fit: &Fitted, f: &mut Formatter<'_>) -> fmt::Result {
    match fit {
        Fitted::ThroughOrigin(s) => write!(
            f,
            "slope through the origin {:.6e}, 95% CI [{:.6e}, {:.6e}], n = {}, R^2 = {:.4}",
            s.slope, s.slope_ci[0], s.slope_ci[1], s.n, s.r2
        ),
        Fitted::PowerLaw(p) => write!(
            f,
            "power law y = C x^p, p = {:.4}, 95% CI [{:.4}, {:.4}], C = {:.4e}, n = {}, R^2 = {:.4}",
            p.p, p.p_ci[0], p.p_ci[1], p.c, p.n, p.r2
        ),
        Fitted::CommonPowerLaw(c) => {
            write!(
                f,
                "common power law {} ~ C_k {}^(-m), m = {:.4}, 95% CI [{:.4}, {:.4}], n = {}, \
                 R^2 = {:.4}",
                c.y, c.x, c.m, c.m_ci[0], c.m_ci[1], c.n, c.r2
            )?;
            for s in &c.per_series_m {
                write!(
                    f,
                    "\n    {} = {} alone: m = {:.4}, 95% CI [{:.4}, {:.4}]",
                    c.series.as_deref().unwrap_or("series"),
                    s.series,
                    s.m,
                    s.m_ci[0],
                    s.m_ci[1]
                )?;
            }
            Ok(())
        }
    }
}

/// The text of a phase study: the exponent, each column's first loss of stability, the
/// boundary curve and the flagella left off the map.
fn phase(p: &PhaseResult, f: &mut Formatter<'_>) -> fmt::Result {
    write!(
        f,
        "phase diagram over lambda/l with vertical coordinate omegabar (R/lambda)^m, m = {:.4}",
        p.m
    )?;
    if let Some(a) = p.accuracy {
        write!(
            f,
            "\n  first losses of stability and the boundary curve carried to a relative accuracy \
             of {a:e}"
        )?;
    }
    for c in &p.columns {
        let error = match (c.omegabar_b_error, &c.error_missing) {
            (Some(e), _) => format!(" +- {e:.1e}"),
            (None, why) => format!(
                " (its error not estimated: {})",
                why.as_deref().unwrap_or("no reason given")
            ),
        };
        let at = match (c.nodes, c.reached) {
            (Some(n), Some(true)) => format!(" (N = {n}, accuracy reached)"),
            (Some(n), Some(false)) => format!(" (N = {n}, accuracy NOT reached)"),
            (Some(n), None) => format!(" (N = {n})"),
            (None, _) => String::new(),
        };
        let loss = match (c.omegabar_b, &c.kind) {
            (Some(w), Some(kind)) => {
                format!("first loss of stability ({kind}) at omegabar_b = {w:.6e}{error}{at}")
            }
            (Some(w), None) => {
                format!("first loss of stability at omegabar_b = {w:.6e}{error}{at}")
            }
            _ => "stable over the branch".to_owned(),
        };
        write!(
            f,
            "\n  lambda/l = {:.4}, R/lambda = {:.4}: {loss}; {} points (probes included)",
            c.lambda_over_l, c.r_over_lambda, c.points
        )?;
        if let Some(why) = &c.near_miss_unresolved {
            write!(
                f,
                "\n    WARNING: a near miss was not resolved {why}: a window of instability there \
                 may have been stepped over (below omegabar_b, or missing from the map)"
            )?;
        }
    }
    match &p.boundary_curve {
        CurveOutcome::Written { out, shortfall } => {
            write!(f, "\n  boundary curve in {out}")?;
            if let Some(s) = shortfall {
                write!(f, " ({s})")?;
            }
        }
        CurveOutcome::Failed { error } => write!(
            f,
            "\n  boundary curve not followed ({error}); the columns' first losses are joined instead"
        )?,
    }
    for s in &p.skipped_flagella {
        write!(f, "\n  left off the map: {s}")?;
    }
    Ok(())
}

/// The text of a boundary study: each curve's report with its special points, its exponents,
/// and the common fit.
fn boundary_study(b: &BoundaryStudy, f: &mut Formatter<'_>) -> fmt::Result {
    for (k, c) in b.curves.iter().enumerate() {
        if k > 0 {
            writeln!(f)?;
        }
        let resumed = if c.resumed {
            " (read back: an earlier run finished it, --resume)"
        } else {
            ""
        };
        writeln!(f, "curve `{}`{resumed}:", c.label)?;
        if let Some(r) = &c.report {
            r.text(f)?;
        }
        if let Some(e) = &c.error {
            write!(f, "\n  FAILED: {e}")?;
        }
        let error =
            |e: Option<f64>| e.map_or(" (error not estimated)".into(), |e| format!(" +- {e:.2e}"));
        if let Some([q, m]) = c.m_loc_smallest {
            write!(
                f,
                "\n  m_loc = {m:.4}{} at the smallest q = {q:.4}",
                error(c.m_loc_smallest_error)
            )?;
        }
        if let Some(m) = c.m_loc_limit {
            write!(
                f,
                "; extrapolated to q = 0: {m:.4}{}",
                error(c.m_loc_limit_error)
            )?;
        }
        if let Some(p) = &c.fit {
            write!(
                f,
                "\n  power law omegabar_b = C q^p: m = -p = {:.4}, 95% CI [{:.4}, {:.4}], n = {}",
                -p.p, -p.p_ci[1], -p.p_ci[0], p.n
            )?;
        }
    }
    if let Some(c) = &b.common_fit {
        write!(
            f,
            "\ncommon power law of the curves: m = {:.4}, 95% CI [{:.4}, {:.4}], n = {}, R^2 = {:.4}",
            -c.p, -c.p_ci[1], -c.p_ci[0], c.n, c.r2
        )?;
        for (label, p, ci) in &c.per_group {
            write!(
                f,
                "\n  {label} alone: m = {:.4}, 95% CI [{:.4}, {:.4}]",
                -p, -ci[1], -ci[0]
            )?;
        }
    }
    Ok(())
}

/// The text of a shapes study: the rates drawn and the critical mode.
fn shapes(s: &ShapesResult, f: &mut Formatter<'_>) -> fmt::Result {
    let rates: Vec<String> = s.omegas.iter().map(|w| format!("{w}")).collect();
    write!(f, "steady shapes at omega = {} rad/s", rates.join(", "))?;
    match &s.critical {
        CriticalMode::None { .. } => write!(f, "\n  the branch stays stable: no critical mode"),
        CriticalMode::Found {
            omega_b,
            event,
            eigenvalue,
        } => write!(
            f,
            "\n  critical mode ({event}) at omega_b = {omega_b:.8} rad/s, eigenvalue {:+.3e} \
             {:+.4e} i /s",
            eigenvalue[0], eigenvalue[1]
        ),
    }
}

/// The text of a dynamics study: one line per simulation.
fn dynamics(rows: &[AverageRow], f: &mut Formatter<'_>) -> fmt::Result {
    write!(
        f,
        "time averages (mean +- std) of the simulations from rest:"
    )?;
    let pm = |m: Option<f64>, s: Option<f64>| match (m, s) {
        (Some(m), Some(s)) => format!("{m:.6} +- {s:.2e}"),
        _ => "-".to_owned(),
    };
    for r in rows {
        write!(
            f,
            "\n  omega = {} rad/s: {}",
            r.omega,
            if r.status == "ok" {
                format!(
                    "hbar = {}, Fpbar = {}, eta = {}; {} steps, {:.1} s",
                    pm(r.hbar_mean, r.hbar_std),
                    pm(r.fpbar_mean, r.fpbar_std),
                    pm(r.eta_mean, r.eta_std),
                    r.steps,
                    r.seconds
                )
            } else {
                r.status.clone()
            }
        )?;
    }
    Ok(())
}

/// What `helixbif merge` reports.
#[derive(Serialize)]
pub struct MergeReport {
    pub study: String,
    pub points: usize,
    pub shards: usize,
    pub file: String,
    /// Points finished with a near miss left unresolved (status `ok; WARNING: ...`).
    pub warned: usize,
    #[serde(flatten)]
    pub reach: Option<Reach>,
}

impl Display for MergeReport {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "merged {} shards of `{}`: {} points into {}",
            self.shards, self.study, self.points, self.file
        )?;
        warned(self.warned, f)?;
        if let Some(reach) = &self.reach {
            reached(reach, f)?;
        }
        Ok(())
    }
}

/// What `helixbif fit` reports: the fit, and every row it left out with the reason.
#[derive(Serialize)]
pub struct FitReport {
    pub csv: String,
    pub x: String,
    pub y: String,
    #[serde(flatten)]
    pub fit: PowerLaw,
    pub left_out: Vec<LeftOut>,
}

impl Display for FitReport {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let (fit, x, y) = (&self.fit, &self.x, &self.y);
        writeln!(f, "{y} = C {x}^p over {} rows of {}:", fit.n, self.csv)?;
        writeln!(
            f,
            "  p = {:.6}   95% CI [{:.6}, {:.6}]",
            fit.p, fit.p_ci[0], fit.p_ci[1]
        )?;
        writeln!(
            f,
            "  C = {:.6e}   95% CI [{:.6e}, {:.6e}]",
            fit.c, fit.c_ci[0], fit.c_ci[1]
        )?;
        write!(f, "  r2 = {:.6}", fit.r2)?;
        if !self.left_out.is_empty() {
            write!(f, "\n  left out {} rows:", self.left_out.len())?;
            for l in &self.left_out {
                write!(f, "\n    {l}")?;
            }
        }
        Ok(())
    }
}

/// What `helixbif bisect` reports (rates in rad/s).
#[derive(Serialize)]
pub struct BisectReport {
    pub study: String,
    pub nodes: usize,
    pub omega_b: f64,
    pub bracket: [f64; 2],
    pub trials: usize,
    pub steps: usize,
    pub seconds: f64,
}

impl BisectReport {
    /// The report of a bisection in solver units, converted with `omega_from_bar`.
    pub fn new(
        study: &str,
        nodes: usize,
        result: &Bisection,
        omega_from_bar: impl Fn(f64) -> f64,
        seconds: f64,
    ) -> Self {
        BisectReport {
            study: study.into(),
            nodes,
            omega_b: omega_from_bar(result.estimate),
            bracket: [
                omega_from_bar(result.bracket.0),
                omega_from_bar(result.bracket.1),
            ],
            trials: result.trials.len(),
            steps: result.steps,
            seconds,
        }
    }
}

impl Display for BisectReport {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "bisection of `{}` at N = {}: omega_b in [{:.6}, {:.6}] rad/s ({} trials, {} time \
             steps, {:.1} s)",
            self.study,
            self.nodes,
            self.bracket[0],
            self.bracket[1],
            self.trials,
            self.steps,
            self.seconds
        )
    }
}

impl Text for SlurmScripts {
    fn text(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "wrote {} ({} tasks over {} points) and {}; submit with",
            self.array_script.display(),
            self.tasks,
            self.points,
            self.merge_script.display()
        )?;
        for c in &self.commands {
            write!(f, "\n  {c}")?;
        }
        Ok(())
    }
}

impl Text for SlurmSubmission {
    fn text(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "submitted array job {} ({} tasks over {} points) and merge job {} ({}); ids in {}",
            self.array_job,
            self.scripts.tasks,
            self.scripts.points,
            self.merge_job,
            self.dependency,
            self.scripts
                .array_script
                .with_file_name("slurm.json")
                .display()
        )
    }
}

impl Section for OrbitsReport {
    fn show(&self, study: &str, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "periodic orbits of `{study}` from the Hopf point at omega = {:.8} rad/s (N = {}, \
             frequency {:.6} rad/s, l1 = {:.6e}: {})",
            self.omega_hopf, self.nodes, self.frequency, self.l1, self.criticality
        )?;
        writeln!(
            f,
            "  {} orbits in {:.1} s, stopped: {:?}; written to {}",
            self.orbits, self.seconds, self.stop, self.out
        )?;
        for (name, row) in [("first", &self.first), ("last", &self.last)] {
            if let Some(r) = row {
                writeln!(
                    f,
                    "  {name}: omega = {:.8} rad/s, period {:.6} s, amplitude {:.4e} m, hbar {:.6}, \
                     Fpbar {:.6}, max |multiplier| - 1 = {:+.3e} ({})",
                    r.omega,
                    r.period,
                    r.amplitude,
                    r.hbar_mean,
                    r.fpbar_mean,
                    r.max_multiplier - 1.0,
                    r.verdict
                )?;
            }
        }
        for e in &self.events {
            writeln!(
                f,
                "  {:?} between orbits {} and {} (omega {:.8} .. {:.8} rad/s)",
                e.kind,
                e.after,
                e.after + 1,
                e.omega_from,
                e.omega_to
            )?;
        }
        Ok(())
    }
}

/// The text of a boundary report.
impl Text for BoundaryReport {
    fn text(&self, f: &mut Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "stability boundary in {} from {} to {} at N = {}: {} points on {} curve(s), {} \
             steady solves, {} independent locate runs below the curve, {:.2} s",
            self.key,
            self.from,
            self.to,
            self.nodes,
            self.points,
            self.segments,
            self.evaluations,
            self.window_checks,
            self.seconds
        )?;
        let t = &self.time;
        writeln!(
            f,
            "  time: following the curve {:.1} s (the start, steady solves, spectra, Lyapunov \
             coefficients, special points, files), window checks {:.1} s, the points' rows {:.1} s \
             ({}), the check at the end {:.1} s",
            t.curve,
            t.window_checks,
            t.rows,
            if self.accuracy.is_some() {
                "their refinements"
            } else {
                "their errors from N/2 + 1"
            },
            t.end_check
        )?;
        let worst =
            self.relative_error_max
                .map_or("no point states an error".to_string(), |[e, q]| {
                    format!(
                        "the largest estimated relative error {e:.1e} (at {} = {q:.6})",
                        self.key
                    )
                });
        match (self.accuracy, self.carried, self.not_reached) {
            (Some(a), Some(carried), Some(missed)) => writeln!(
                f,
                "  every Hopf point carried to the accuracy {a:e} (N up to {}{}): reached at {} \
                 of {carried}; {worst}",
                self.nodes_max,
                match self.interpolated {
                    Some(k) if k > 0 => format!("; {k} of them interpolated between refined ones"),
                    _ => String::new(),
                },
                carried - missed,
            )?,
            _ => writeln!(
                f,
                "  every point at N = {}, its discretization error estimated from N/2 + 1 nodes: \
                 {worst} (--accuracy, or a boundary study's accuracy, carries the points to one)",
                self.nodes
            )?,
        }
        for p in &self.special {
            let frequencies = if p.kind.one_mode() {
                format!("w = {:.5} rad/s", p.w)
            } else {
                format!("w = {:.5}, other {:.5} rad/s", p.w, p.w_other)
            };
            let bracket = if p.kind == BoundaryEvent::Window {
                format!("bracket {:.1e} in {}", p.precision, self.key)
            } else {
                format!("bracket {:.1e} along the curve", p.precision)
            };
            writeln!(
                f,
                "  {:<12} at {} = {:.8}, omega = {:.8} rad/s ({frequencies}; {bracket}){}",
                p.kind.name(),
                self.key,
                p.q,
                p.omega,
                if p.switch {
                    ": the boundary leaves the curve here"
                } else {
                    ""
                }
            )?;
        }
        if let Some(why) = &self.first_unresolved_near_miss {
            writeln!(
                f,
                "  WARNING: a window check below the curve had a near miss that its probes neither \
                 resolved nor excluded, {why}: a window of instability there may have been \
                 stepped over"
            )?;
        }
        let c = &self.criticality;
        writeln!(
            f,
            "  Hopf points: {} subcritical, {} supercritical, {} undetermined, {} without a \
             Lyapunov coefficient",
            c.subcritical, c.supercritical, c.undetermined, c.not_computed
        )?;
        match (self.check_omega_b, self.check_difference) {
            (Some(w), Some(d)) => {
                writeln!(
                    f,
                    "  check: an independent locate at the end, at N = {}, finds omega_b = {w:.8} \
                     rad/s (relative difference from the curve there {d:.2e})",
                    self.nodes
                )?;
                if d > 1e-6 {
                    writeln!(
                        f,
                        "  WARNING: they disagree: another mode loses stability first at the \
                         end, away from the curve followed"
                    )?;
                }
            }
            _ => writeln!(f, "  check: the independent locate at the end failed")?,
        }
        write!(
            f,
            "  boundary.csv, points.csv, boundary.svg, m_loc.svg in {}",
            self.out
        )
    }
}

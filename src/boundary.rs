//! `helixbif boundary`: the stability boundary `omega_b(q)` as a curve in a second model field
//! `q` (any numeric study field, or the helix ratios `shape.R_over_lambda`,
//! `shape.lambda_over_l`), by two-parameter continuation of the Hopf point
//! ([`crate::engine::curve`], docs/model.md section 11).
//!
//! The curve starts from `locate` at the first value of `q`. It is the first loss of stability
//! of the branch from rest as long as no other mode becomes unstable below it; the rest of the
//! spectrum is watched at every point, so where a second pair reaches the axis on the curve (a
//! double Hopf point) past which it is unstable, the boundary moves to that pair's Hopf curve
//! and says where it switched. Where the curve turns back in `q` (the mode's loss and regain of
//! stability meet and vanish), the boundary jumps: it is located afresh just past the turning
//! point and followed from there. An instability that opens below the curve away from it
//! (neither on it nor at a turning point) is not seen by the curve; the end of the range is
//! therefore checked against an independent `locate`, and a disagreement is reported.

use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

use crate::problem::rod::{Parameter, RodProblem, omega_scale};

use crate::analysis::locate::{locate, observables_at};
use crate::analysis::solve::rest_state;
use crate::engine::arclength::Silent;
use crate::engine::curve::{
    CurveObserver, CurvePoint, CurveSettings, CurveStop, Family, Special, SpecialKind, follow_curve,
};
use crate::engine::event_curve::{EventPoint, follow_event_curve};
use crate::engine::events::EventKind;
use crate::model::Model;
use crate::model::dofs::Layout;
use crate::numerics::fit::{PowerLaw, common_power_law, power_law};
use crate::output::{CsvWriter, create_dir};
use crate::plot::{Figure, Marker, Scale, Series, Style, write_figure};
use crate::study::plan::Case;
use crate::study::run::slug;
use crate::study::sweep::variant;
use crate::study::{LAMBDA_OVER_L, R_OVER_LAMBDA, Study, get_number, set_path, set_ratio};
use crate::{Error, Result};

/// The rod models along a second parameter: the study with `key` set to `q`, at the study's
/// node count (a `per_turn` resolution is fixed at the first value, so that the unknowns stay
/// the same along the curve).
pub struct RodFamily {
    table: toml::Table,
    key: String,
    omega_scale: f64,
    /// A helix ratio held at a value while `key` varies (the phase diagram keeps `R/lambda`
    /// while the pitch varies).
    hold: Option<(String, f64)>,
}

impl RodFamily {
    /// The family of `study` in `key`; `key` must name a number of the study (or a helix ratio).
    pub fn new(study: &Study, key: &str) -> Result<Self> {
        let mut table = study.to_table()?;
        table.remove("study");
        if let Some(d) = table
            .get_mut("discretization")
            .and_then(|d| d.as_table_mut())
        {
            d.remove("per_turn");
            d.insert(
                "nodes".into(),
                toml::Value::Integer(study.discretization.nodes as i64),
            );
        }
        if ![LAMBDA_OVER_L, R_OVER_LAMBDA].contains(&key) && get_number(&table, key).is_none() {
            return Err(Error::input(
                "--vary",
                format!(
                    "`{key}` is not a numeric field of the study (or {LAMBDA_OVER_L}, \
                     {R_OVER_LAMBDA})"
                ),
            ));
        }
        let model = Model::new(&study.physical())?;
        Ok(RodFamily {
            table,
            key: key.to_string(),
            omega_scale: omega_scale(model.scales.omega_to_bar(study.branch.omega_max)),
            hold: None,
        })
    }

    /// The family with the helix ratio `ratio` (`shape.R_over_lambda` or
    /// `shape.lambda_over_l`) set to `value` after `key` in every member.
    pub fn holding(self, ratio: &str, value: f64) -> Self {
        RodFamily {
            hold: Some((ratio.to_string(), value)),
            ..self
        }
    }

    /// The study at `q`.
    pub fn study(&self, q: f64) -> Result<Study> {
        let mut table = self.table.clone();
        if [LAMBDA_OVER_L, R_OVER_LAMBDA].contains(&self.key.as_str()) {
            set_ratio(&mut table, &self.key, q)?;
        } else {
            set_path(&mut table, &self.key, toml::Value::Float(q))?;
        }
        if let Some((ratio, value)) = &self.hold {
            set_ratio(&mut table, ratio, *value)?;
        }
        Study::from_table(table)
    }
}

impl Family for RodFamily {
    type Member = RodProblem<Model>;

    fn member(&self, q: f64) -> Result<RodProblem<Model>> {
        let model = Model::new(&self.study(q)?.physical())?;
        model.check_resolution()?;
        Ok(RodProblem::new(model, Parameter::Omega, self.omega_scale))
    }

    /// Moves every free node with the natural shape (`x + X_to - X_from`), angles unchanged.
    fn carry(&self, u: &[f64], from: &RodProblem<Model>, to: &RodProblem<Model>) -> Vec<f64> {
        let fp = from.model.rod.layout.free_positions();
        let (a, b) = (&from.model.natural, &to.model.natural);
        let mut carried = u.to_vec();
        for (i, c) in carried[..fp].chunks_exact_mut(3).enumerate() {
            let d = b[Layout::CLAMPED_NODES + i] - a[Layout::CLAMPED_NODES + i];
            for k in 0..3 {
                c[k] += d[k];
            }
        }
        carried
    }

    /// `to` measures the angles in `from`'s chart carried onto the edges of `guess`, with its
    /// own clamp frame ([`crate::model::rod::frame::Chart::with_clamp_of`]).
    fn adopt(&self, from: &RodProblem<Model>, to: &RodProblem<Model>, guess: &[f64]) {
        let x = to.steady(0.0).config(guess).x;
        to.set_chart(from.chart().transported(&x).with_clamp_of(&to.model.chart));
    }
}

/// One row of `boundary.csv`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoundaryRow {
    /// The index of the curve the row lies on (a switch or a jump starts a new one).
    pub segment: usize,
    pub q: f64,
    pub omega_b: f64,
    pub omegabar_b: f64,
    pub kind: String,
    /// Frequency of the critical mode, rad/s and normalized.
    pub w: f64,
    pub wbar: f64,
    #[serde(rename = "Fpbar")]
    pub fpbar: f64,
    pub hbar: f64,
    /// `-d ln omegabar_b / d ln q` along the segment (three-point differences; empty where `q`
    /// or `omegabar_b` is not positive or the segment has one point).
    pub m_loc: Option<f64>,
    /// Relative precision of the point in `omega`.
    pub precision: f64,
    /// At a Hopf point: the first Lyapunov coefficient (solver units, critical mode scaled to a
    /// largest node displacement of `ell`), its estimated error and the verdict; empty where it
    /// could not be computed (its differences displace the rod out of the fluid model's
    /// admissible states, next to Lighthill's spacing limit).
    pub l1: Option<f64>,
    pub l1_precision: Option<f64>,
    pub criticality: Option<String>,
}

/// One row of `points.csv`: a special point of the boundary.
#[derive(Clone, Debug, Serialize)]
pub struct PointRow {
    pub kind: &'static str,
    pub q: f64,
    pub omega: f64,
    pub omegabar: f64,
    /// The critical mode's frequency and the other mode's (double Hopf), rad/s.
    pub w: f64,
    pub w_other: f64,
    /// True where the boundary leaves the curve here (switch to the other mode, or jump).
    pub switch: bool,
    /// Width of the final bracket along the curve (units of the curve's arclength).
    pub precision: f64,
}

/// The verdicts on the criticality of the Hopf points of a boundary.
#[derive(Debug, Default, Serialize)]
pub struct Criticality {
    pub supercritical: usize,
    pub subcritical: usize,
    pub undetermined: usize,
    pub not_computed: usize,
}

impl Criticality {
    fn of(rows: &[BoundaryRow]) -> Self {
        let mut count = Criticality::default();
        for row in rows.iter().filter(|r| r.kind == EventKind::Hopf.name()) {
            match row.criticality.as_deref() {
                Some("supercritical") => count.supercritical += 1,
                Some("subcritical") => count.subcritical += 1,
                Some(_) => count.undetermined += 1,
                None => count.not_computed += 1,
            }
        }
        count
    }
}

/// What `helixbif boundary` reports.
#[derive(Debug, Serialize)]
pub struct BoundaryReport {
    pub key: String,
    pub from: f64,
    pub to: f64,
    pub nodes: usize,
    pub points: usize,
    pub segments: usize,
    pub special: Vec<PointRow>,
    /// Steady solves (Newton from a close guess, with a spectrum) over the whole curve.
    pub evaluations: usize,
    pub seconds: f64,
    /// `omega_b` of an independent `locate` at the end of the range, and its relative
    /// difference from the curve's last point.
    pub check_omega_b: Option<f64>,
    pub check_difference: Option<f64>,
    /// How many Hopf points of the curve are supercritical, subcritical, undetermined, and
    /// without a coefficient (it could not be computed).
    pub criticality: Criticality,
    pub out: String,
}

/// Streams the curve to `boundary.csv` (rewritten after every point, so that a failure keeps
/// everything found) and draws a progress bar.
struct Writer<'a> {
    family: &'a RodFamily,
    study: &'a Study,
    dir: PathBuf,
    rows: Vec<BoundaryRow>,
    special: Vec<PointRow>,
    segment: usize,
    evaluations: usize,
    bar: ProgressBar,
    range: (f64, f64),
    /// The kind of the curve being followed.
    kind: &'static str,
    error: Option<Error>,
}

impl Writer<'_> {
    fn row(&self, point: &CurvePoint) -> Result<BoundaryRow> {
        let member = self.family.member(point.q)?;
        let model = &member.model;
        let rest = rest_state(model, &self.study.newton)?;
        let o = observables_at(model, &rest, &point.u, point.p)?;
        let wbar = point.eigenvalue.im;
        Ok(BoundaryRow {
            segment: self.segment,
            q: point.q,
            omega_b: o.omega,
            omegabar_b: point.p,
            kind: self.kind.into(),
            w: model.scales.omega_from_bar(wbar),
            wbar,
            fpbar: o.fpbar,
            hbar: o.hbar,
            m_loc: None,
            precision: point.precision,
            l1: point.lyapunov.as_ref().map(|l| l.l1),
            l1_precision: point.lyapunov.as_ref().map(|l| l.precision),
            criticality: point.lyapunov.as_ref().map(|l| l.verdict.to_string()),
        })
    }

    fn write(&mut self) -> Result<()> {
        local_exponents(&mut self.rows);
        let mut csv = CsvWriter::create(&self.dir.join("boundary.csv"))?;
        for row in &self.rows {
            csv.row(row)?;
        }
        let mut csv = CsvWriter::create(&self.dir.join("points.csv"))?;
        for row in &self.special {
            csv.row(row)?;
        }
        Ok(())
    }

    fn special_row(&self, special: &Special, switch: bool) -> Result<PointRow> {
        let scales = self.family.member(special.point.q)?.model.scales;
        Ok(PointRow {
            kind: special.kind.name(),
            q: special.point.q,
            omega: scales.omega_from_bar(special.point.p),
            omegabar: special.point.p,
            w: scales.omega_from_bar(special.point.eigenvalue.im),
            w_other: scales.omega_from_bar(special.other.im),
            switch,
            precision: special.precision,
        })
    }
}

impl CurveObserver for Writer<'_> {
    fn point(&mut self, point: &CurvePoint) {
        self.evaluations += point.evaluations;
        let result = self.row(point).and_then(|row| {
            self.rows.push(row);
            self.write()
        });
        if let (Err(e), None) = (result, &self.error) {
            self.error = Some(e);
        }
        let (a, b) = self.range;
        let fraction = ((point.q - a) / (b - a)).clamp(0.0, 1.0);
        self.bar.set_position((fraction * 1000.0) as u64);
        self.bar.set_message(format!(
            "q = {:.5}, omega_b = {:.5} rad/s",
            point.q,
            self.rows.last().map_or(f64::NAN, |r| r.omega_b)
        ));
    }

    /// The boundary leaves the curve where the other mode is unstable beyond a double Hopf or
    /// zero-Hopf point, and at a turning point.
    fn special(&mut self, special: &Special) -> bool {
        let switch = special.gains || special.kind == SpecialKind::Turning;
        match self.special_row(special, switch) {
            Ok(row) => self.special.push(row),
            Err(e) => {
                self.error.get_or_insert(e);
            }
        }
        switch
    }
}

/// `-d ln omegabar_b / d ln q` at every row, by three-point differences on each segment.
fn local_exponents(rows: &mut [BoundaryRow]) {
    let mut start = 0;
    while start < rows.len() {
        let segment = rows[start].segment;
        let end = start
            + rows[start..]
                .iter()
                .take_while(|r| r.segment == segment)
                .count();
        let pts: Vec<(f64, f64)> = rows[start..end]
            .iter()
            .map(|r| (r.q.ln(), r.omegabar_b.ln()))
            .collect();
        for (i, row) in rows[start..end].iter_mut().enumerate() {
            row.m_loc = log_slope(&pts, i).map(|d| -d);
        }
        start = end;
    }
}

/// `dy/dx` at `pts[i]`: the three-point formula on an uneven grid inside, two points at the
/// ends; `None` for one point or a non-finite value (a non-positive `q` or `omegabar`).
fn log_slope(pts: &[(f64, f64)], i: usize) -> Option<f64> {
    let n = pts.len();
    let d = |a: (f64, f64), b: (f64, f64)| (b.1 - a.1) / (b.0 - a.0);
    let slope = match (i, n) {
        (_, 0 | 1) => return None,
        (0, _) => d(pts[0], pts[1]),
        (i, n) if i == n - 1 => d(pts[n - 2], pts[n - 1]),
        (i, _) => {
            let (a, b, c) = (pts[i - 1], pts[i], pts[i + 1]);
            let (h0, h1) = (b.0 - a.0, c.0 - b.0);
            (h0 * d(b, c) + h1 * d(a, b)) / (h0 + h1)
        }
    };
    slope.is_finite().then_some(slope)
}

/// The first loss of stability of the member at `q`, as the start of a curve, and the member
/// in the chart the branch reached it in.
/// How a boundary starts: on a Hopf curve, or on a fold or branch-point curve.
enum Start {
    Hopf(CurvePoint),
    Event(EventPoint),
}

impl Start {
    /// `omegabar` of the starting event.
    fn omegabar(&self) -> f64 {
        match self {
            Start::Hopf(c) => c.p,
            Start::Event(e) => e.event.p,
        }
    }
}

fn start_at(
    family: &RodFamily,
    study: &Study,
    q: f64,
    omega_max: f64,
) -> Result<(Start, Rc<RodProblem<Model>>)> {
    let member = family.member(q)?;
    let model = &member.model;
    let (located, critical) = locate(
        model,
        omega_max,
        &study.newton,
        &study.continuation,
        &mut Silent,
    )?;
    let critical = critical.ok_or_else(|| {
        Error::Numerical(format!(
            "at {} = {q}: no loss of stability to start the boundary from ({})",
            family.key, located.kind
        ))
    })?;
    let event = critical.event;
    let start = match event.kind {
        EventKind::Hopf => Start::Hopf(CurvePoint::at_event(event, q)),
        EventKind::Fold | EventKind::BranchPoint => Start::Event(EventPoint {
            q,
            event,
            lead: critical.lead,
            iterations: 0,
        }),
        kind => {
            return Err(Error::Numerical(format!(
                "at {} = {q} the first loss of stability is a {}: no curve to follow",
                family.key,
                kind.name()
            )));
        }
    };
    member.set_chart(critical.chart);
    Ok((start, Rc::new(member)))
}

/// Follows the fold or branch-point curve from `start` to the end of the range, its points into
/// `writer`.
fn follow_events(
    writer: &mut Writer<'_>,
    start: EventPoint,
    member: Rc<RodProblem<Model>>,
    direction: f64,
    settings: &CurveSettings,
) -> Result<()> {
    let (family, study) = (writer.family, writer.study);
    let kind = start.event.kind;
    let curve = follow_event_curve(
        family,
        start,
        member,
        study.branch.omega_max.signum(),
        direction,
        settings,
        &study.continuation,
    )?;
    writer.kind = kind.name();
    for point in &curve.points {
        let on_curve = CurvePoint {
            evaluations: point.iterations,
            ..CurvePoint::at_event(point.event.clone(), point.q)
        };
        writer.point(&on_curve);
    }
    if let Some(e) = writer.error.take() {
        return Err(e);
    }
    match curve.stop {
        CurveStop::Range => Ok(()),
        stop => Err(Error::Numerical(format!(
            "the {} curve stopped at {} = {:.6e}: {stop:?}",
            kind.name(),
            family.key,
            curve.points.last().map_or(f64::NAN, |p| p.q)
        ))),
    }
}

/// Follows the boundary of `study` in `key` from `from` to `to` and writes `boundary.csv`,
/// `points.csv` and the figures to `dir`.
pub fn run_boundary(
    study: &Study,
    key: &str,
    from: f64,
    to: f64,
    dir: &Path,
) -> Result<BoundaryReport> {
    let family = RodFamily::new(study, key)?;
    run_family(study, &family, from, to, dir)
}

/// [`run_boundary`] over the members of `family`.
pub fn run_family(
    study: &Study,
    family: &RodFamily,
    from: f64,
    to: f64,
    dir: &Path,
) -> Result<BoundaryReport> {
    let key = family.key.as_str();
    if !(from.is_finite() && to.is_finite() && from != to) {
        return Err(Error::input(
            "--from/--to",
            format!("need two different finite values, got {from} and {to}"),
        ));
    }
    let started = Instant::now();
    family.study(from)?;
    family.study(to)?;
    create_dir(dir)?;
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{prefix} [{elapsed_precise}] {bar:30} {msg}")
            .expect("a valid template"),
    );
    bar.set_prefix(format!("boundary in {key}"));
    let mut writer = Writer {
        family,
        study,
        dir: dir.to_path_buf(),
        rows: Vec::new(),
        special: Vec::new(),
        segment: 0,
        evaluations: 0,
        bar,
        range: (from, to),
        kind: EventKind::Hopf.name(),
        error: None,
    };
    let settings = CurveSettings {
        criticality: true,
        ..CurveSettings::new(from.min(to), from.max(to))
    };
    let direction = (to - from).signum();
    let (mut start, mut member) = start_at(family, study, from, study.branch.omega_max)?;
    let outcome = loop {
        let hopf = match start {
            Start::Hopf(c) => c,
            Start::Event(e) => break follow_events(&mut writer, e, member, direction, &settings),
        };
        writer.kind = EventKind::Hopf.name();
        let (curve, last) = match follow_curve(
            family,
            hopf,
            member,
            direction,
            &settings,
            &study.continuation,
            &mut writer,
        ) {
            Ok(c) => c,
            Err(e) => break Err(e),
        };
        if let Some(e) = writer.error.take() {
            break Err(e);
        }
        match curve.stop {
            CurveStop::Range => break Ok(()),
            CurveStop::MaxPoints => {
                break Err(Error::Numerical(format!(
                    "the curve used all {} points",
                    settings.max_points
                )));
            }
            CurveStop::StepTooSmall(reason) => {
                let q = curve.points.last().map_or(from, |p| p.q);
                break Err(Error::Numerical(format!(
                    "the boundary curve stalled at {key} = {q:.6e}: {reason}"
                )));
            }
            CurveStop::NoMember(reason) => {
                let q = curve.points.last().map_or(from, |p| p.q);
                break Err(Error::Numerical(format!(
                    "the boundary curve ends at {key} = {q:.6e}, past which the study has no \
                     admissible model: {reason}"
                )));
            }
            CurveStop::Ended => {
                let q = curve.points.last().map_or(from, |p| p.q);
                break Err(Error::Numerical(format!(
                    "the Hopf curve ends at a Bogdanov-Takens point at {key} = {q:.6e}: past it \
                     the boundary is a fold curve, which boundary does not follow"
                )));
            }
            CurveStop::Observer => {}
        }
        let special = curve
            .special
            .last()
            .expect("the observer stopped at a special point");
        writer.segment += 1;
        start = if special.kind == SpecialKind::Turning {
            // Past the turning point the mode is stable: the first loss of stability is
            // elsewhere, located afresh a little beyond.
            let q = special.point.q + direction * 1e-3 * (to - from).abs();
            let omega_max = study
                .branch
                .omega_max
                .abs()
                .max(2.0 * writer.rows.last().map_or(0.0, |r| r.omega_b.abs()))
                * study.branch.omega_max.signum();
            match start_at(family, study, q, omega_max) {
                Ok((s, m)) => {
                    member = m;
                    s
                }
                Err(e) => break Err(e),
            }
        } else if special.kind == SpecialKind::DoubleHopf {
            let mut next = special.point.clone();
            next.eigenvalue = special.other;
            member = last;
            Start::Hopf(next)
        } else {
            break Err(Error::Numerical(format!(
                "at {key} = {:.6e} a real eigenvalue reaches zero on the Hopf curve (zero-Hopf \
                 point) and is unstable beyond: the boundary becomes a fold or branch-point \
                 curve there, which boundary does not follow",
                special.point.q
            )));
        };
    };
    writer.bar.finish_and_clear();
    // What was found is kept (tables and figures) even when the curve could not be finished.
    let written = writer.write().and_then(|()| {
        let special: Vec<(String, PointRow)> = writer
            .special
            .iter()
            .map(|p| (String::new(), p.clone()))
            .collect();
        curve_figures(dir, key, &[(String::new(), writer.rows.clone())], &special)
    });
    outcome?;
    written?;
    let rows = &writer.rows;
    // An independent locate at the end of the range.
    let last = rows.last().expect("a finished curve has points");
    let omega_max = study.branch.omega_max.signum()
        * study.branch.omega_max.abs().max(2.0 * last.omega_b.abs());
    let check = start_at(family, study, last.q, omega_max).ok();
    let check_omega_b = check.map(|(c, _)| {
        family
            .member(last.q)
            .map(|m| m.model.scales.omega_from_bar(c.omegabar()))
            .unwrap_or(f64::NAN)
    });
    Ok(BoundaryReport {
        key: key.to_string(),
        from,
        to,
        nodes: study.discretization.nodes,
        points: rows.len(),
        segments: writer.segment + 1,
        special: writer.special.clone(),
        evaluations: writer.evaluations,
        seconds: started.elapsed().as_secs_f64(),
        check_difference: check_omega_b.map(|w| (w - last.omega_b).abs() / last.omega_b.abs()),
        check_omega_b,
        criticality: Criticality::of(rows),
        out: dir.display().to_string(),
    })
}

/// The text of a boundary report.
impl std::fmt::Display for BoundaryReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "stability boundary in {} from {} to {} at N = {}: {} points on {} curve(s), {} \
             steady solves, {:.2} s",
            self.key,
            self.from,
            self.to,
            self.nodes,
            self.points,
            self.segments,
            self.evaluations,
            self.seconds
        )?;
        for p in &self.special {
            let single = [SpecialKind::Turning, SpecialKind::GeneralizedHopf];
            let frequencies = if single.iter().any(|k| k.name() == p.kind) {
                format!("w = {:.5} rad/s", p.w)
            } else {
                format!("w = {:.5}, other {:.5} rad/s", p.w, p.w_other)
            };
            writeln!(
                f,
                "  {:<12} at {} = {:.8}, omega = {:.8} rad/s ({frequencies}){}",
                p.kind,
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
                    "  check: an independent locate at the end finds omega_b = {w:.8} rad/s \
                     (relative difference {d:.2e})"
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

/// What a boundary study says of one curve: where it ran, its local exponent near the small end
/// of the range and, over the stated range, a power law.
#[derive(Debug, Serialize)]
pub struct CurveSummary {
    pub label: String,
    pub report: Option<BoundaryReport>,
    /// Why the curve did not reach the end of the range (its points so far are on disk).
    pub error: Option<String>,
    /// `m_loc` at the smallest `q` of the curve.
    pub m_loc_smallest: Option<[f64; 2]>,
    /// `m_loc` extrapolated to `q = 0` by a straight line through the lowest fifth of the
    /// curve's range of `q`.
    pub m_loc_limit: Option<f64>,
    /// `omegabar_b = C q^p` over the stated range, `m = -p`.
    pub fit: Option<PowerLaw>,
}

/// The rows of a `boundary.csv`.
pub fn read_rows(path: &Path) -> Result<Vec<BoundaryRow>> {
    let mut reader = csv::Reader::from_path(path).map_err(|e| Error::Io {
        path: path.display().to_string(),
        source: std::io::Error::other(e.to_string()),
    })?;
    reader
        .deserialize()
        .map(|r| {
            r.map_err(|e| Error::Io {
                path: path.display().to_string(),
                source: std::io::Error::other(e.to_string()),
            })
        })
        .collect()
}

/// Least-squares line `y = a + b x`; `None` with fewer than three points.
fn line_intercept(points: &[(f64, f64)]) -> Option<f64> {
    let n = points.len() as f64;
    if points.len() < 3 {
        return None;
    }
    let (mx, my) = (
        points.iter().map(|p| p.0).sum::<f64>() / n,
        points.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    let a = my - b * mx;
    a.is_finite().then_some(a)
}

/// The exponents of a curve's rows: `m_loc` at the smallest `q`, its limit at `q = 0`, and the
/// power law over `fit`.
fn exponents(
    rows: &[BoundaryRow],
    fit: Option<[f64; 2]>,
) -> (Option<[f64; 2]>, Option<f64>, Option<PowerLaw>) {
    let with_m: Vec<(f64, f64)> = rows
        .iter()
        .filter_map(|r| r.m_loc.filter(|_| r.q > 0.0).map(|m| (r.q, m)))
        .collect();
    let smallest = with_m
        .iter()
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|&(q, m)| [q, m]);
    let lo = with_m.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let hi = with_m.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let low: Vec<(f64, f64)> = with_m
        .iter()
        .copied()
        .filter(|p| p.0 <= lo + 0.2 * (hi - lo))
        .collect();
    let limit = line_intercept(&low);
    let power = fit.and_then(|[a, b]| {
        let inside: Vec<&BoundaryRow> = rows.iter().filter(|r| r.q >= a && r.q <= b).collect();
        let x: Vec<f64> = inside.iter().map(|r| r.q).collect();
        let y: Vec<f64> = inside.iter().map(|r| r.omegabar_b).collect();
        power_law(&x, &y).ok()
    });
    (smallest, limit, power)
}

/// A boundary study: a curve per case in `key` over `range`, each in its own folder (the
/// study's own when there is one case), the curves drawn together (`boundary.svg`,
/// `m_loc.svg`), and with `fit`, one power law shared by the curves over that range
/// (`fit.json`: `m`, its interval, the range; the exponent the phase study reads). Returns the
/// summary and the curves that did not finish.
pub fn run_study(
    study: &Study,
    key: &str,
    (from, to): (f64, f64),
    cases: &[Case],
    fit: Option<[f64; 2]>,
    dir: &Path,
) -> Result<(Value, Vec<String>)> {
    let mut summaries = Vec::new();
    let mut failures = Vec::new();
    let mut all_rows = Vec::new();
    let mut all_special = Vec::new();
    for case in cases {
        let s = variant(study, case, &[], &[])?;
        let sub = if cases.len() == 1 {
            dir.to_path_buf()
        } else {
            dir.join(slug(&case.label))
        };
        let (report, error) = match run_boundary(&s, key, from, to, &sub) {
            Ok(r) => (Some(r), None),
            Err(e) if e.is_input() => return Err(e),
            Err(e) => {
                failures.push(format!("{}: {e}", case.label));
                (None, Some(e.to_string()))
            }
        };
        let rows = read_rows(&sub.join("boundary.csv")).unwrap_or_default();
        let (m_loc_smallest, m_loc_limit, power) = exponents(&rows, fit);
        if let Some(r) = &report {
            all_special.extend(r.special.iter().map(|p| (case.label.clone(), p.clone())));
        }
        all_rows.push((case.label.clone(), rows));
        summaries.push(CurveSummary {
            label: case.label.clone(),
            report,
            error,
            m_loc_smallest,
            m_loc_limit,
            fit: power,
        });
    }
    let common = fit.and_then(|[a, b]| {
        let groups: Vec<(String, Vec<f64>, Vec<f64>)> = all_rows
            .iter()
            .map(|(label, rows)| {
                let inside: Vec<&BoundaryRow> =
                    rows.iter().filter(|r| r.q >= a && r.q <= b).collect();
                (
                    label.clone(),
                    inside.iter().map(|r| r.q).collect(),
                    inside.iter().map(|r| r.omegabar_b).collect(),
                )
            })
            .collect();
        common_power_law(&groups).ok()
    });
    if let (Some(c), Some(range)) = (&common, fit) {
        let value = json!({
            "m": -c.p,
            "m_ci": [-c.p_ci[1], -c.p_ci[0]],
            "range": range,
            "source": "boundary curves (one power law shared by the curves over the range)",
        });
        let path = dir.join("fit.json");
        std::fs::write(&path, format!("{value:#}\n")).map_err(crate::output::io_error(&path))?;
    }
    curve_figures(dir, key, &all_rows, &all_special)?;
    Ok((
        json!({ "kind": "boundary", "curves": summaries, "common_fit": common }),
        failures,
    ))
}

/// Boundary curves drawn together (`boundary.svg`: `omegabar_b` against `q` on logarithmic
/// axes; `m_loc.svg`: `m_loc` against `q`), a line per curve and segment, labelled by the curve's
/// label (none for a lone unlabelled curve), the special points marked.
fn curve_figures(
    dir: &Path,
    key: &str,
    curves: &[(String, Vec<BoundaryRow>)],
    special: &[(String, PointRow)],
) -> Result<()> {
    let series = |y: fn(&BoundaryRow) -> f64| -> Vec<Series> {
        curves
            .iter()
            .flat_map(|(label, rows)| {
                let segments = rows.last().map_or(0, |r| r.segment + 1);
                (0..segments).map(move |k| {
                    let on: Vec<&BoundaryRow> = rows.iter().filter(|r| r.segment == k).collect();
                    Series {
                        label: if segments > 1 {
                            format!("{label} (curve {})", k + 1)
                        } else {
                            label.clone()
                        },
                        x: on.iter().map(|r| r.q).collect(),
                        y: on.iter().map(|r| y(r)).collect(),
                        style: Style::Line,
                        stable: None,
                        err: None,
                    }
                })
            })
            .collect()
    };
    let markers: Vec<Marker> = special
        .iter()
        .map(|(_, p)| Marker {
            label: p.kind.replace('_', " "),
            x: p.q,
            y: p.omegabar,
        })
        .collect();
    let omega = Figure {
        title: "stability boundaries".into(),
        x_label: key.to_string(),
        y_label: "omegabar_b = omega_b mu ell^4/EI (-)".into(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: series(|r| r.omegabar_b),
        markers,
        ..Figure::default()
    };
    write_figure(&omega, &dir.join("boundary.svg"))?;
    let exponent = Figure {
        title: "local exponent".into(),
        x_label: key.to_string(),
        y_label: "m_loc = -d ln omegabar_b / d ln q (-)".into(),
        series: series(|r| r.m_loc.unwrap_or(f64::NAN)),
        ..Figure::default()
    };
    write_figure(&exponent, &dir.join("m_loc.svg"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_local_slope_is_second_order_on_an_uneven_grid() {
        // y = sin(x) on uneven points: the three-point derivative errs by O(h^2).
        let error = |h: f64| {
            let x: Vec<f64> = (0..12)
                .map(|i| 1.0 + h * (i as f64 + 0.3 * (i % 3) as f64))
                .collect();
            let pts: Vec<(f64, f64)> = x.iter().map(|&x| (x, x.sin())).collect();
            (1..pts.len() - 1)
                .map(|i| (log_slope(&pts, i).unwrap() - pts[i].0.cos()).abs())
                .fold(0.0, f64::max)
        };
        let (coarse, fine) = (error(0.02), error(0.01));
        let order = (coarse / fine).log2();
        assert!((order - 2.0).abs() < 0.2, "observed order {order}");
        assert!(log_slope(&[(1.0, 2.0)], 0).is_none());
    }

    #[test]
    fn the_limit_of_a_straight_line_is_its_intercept() {
        let points: Vec<(f64, f64)> = (0..5)
            .map(|i| (0.1 * i as f64, 2.1 + 3.0 * 0.1 * i as f64))
            .collect();
        assert!((line_intercept(&points).unwrap() - 2.1).abs() < 1e-14);
        assert!(line_intercept(&points[..2]).is_none());
    }
}

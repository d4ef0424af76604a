//! `helixbif locate` and the `locate` study kind: `omega_b` of a study at its node count, refined
//! in `N` to an accuracy, or over a ladder of node counts, with progress on stderr.

use indicatif::ProgressBar;
use serde::Serialize;

use crate::Result;
use crate::analysis::locate::{Critical, Located, locate};
use crate::analysis::refine::{
    Answered, Ladder, QuadratureError, Refinement, RungObserver, default_ladder, estimate_at_nodes,
    ladder, refine,
};
use std::ops::ControlFlow;

use crate::engine::arclength::Point;
use crate::engine::events::Event;
use crate::engine::stop::Observer;
use crate::model::Model;
use crate::numerics::extrapolation::DiscretizationError;
use crate::study::Study;
use crate::study::interrupt;
use crate::study::progress::{self, progress};

/// How `locate` treats the node count.
#[derive(Clone, Debug, PartialEq)]
pub enum Resolution {
    /// The study's `N` only.
    Single,
    /// The study's `N`, with its discretization error estimated from a coarser rung.
    Fixed,
    /// Refined until the estimated error is below `accuracy` (relative), at most `max_nodes`.
    Refine { accuracy: f64, max_nodes: usize },
    /// Over a ladder of node counts (empty: the default one), extrapolated.
    Ladder(Vec<usize>),
}

/// What `locate` finds, by [`Resolution`]; the JSON is the result's own.
#[derive(Serialize)]
#[serde(untagged)]
pub enum LocateResult {
    Single(Located),
    Refined(Refinement),
    Ladder(Ladder),
}

impl LocateResult {
    /// What the result falls short of: a refinement of an `omega_b` that did not reach its
    /// accuracy, with the estimated error and why it stopped (a branch stable throughout, or
    /// unstable at rest, has no `omega_b` to refine: that is its answer).
    pub fn shortfall(&self) -> Option<String> {
        let LocateResult::Refined(r) = self else {
            return None;
        };
        let accuracy = r.accuracy?;
        (!r.reached && r.finest.omega_b.is_some()).then(|| {
            let estimate = r
                .relative_error
                .map_or("no error estimate".to_string(), |e| {
                    format!("the estimated relative error of omega_b is {e:.1e}")
                });
            format!(
                "accuracy {:.0e} not reached at N = {}: {estimate}; {}",
                accuracy,
                r.finest.nodes,
                r.stopped.as_deref().unwrap_or("")
            )
        })
    }
}

/// A progress bar over the branch of each rung, and a note on stderr for each rung's result.
struct LocateProgress {
    bar: ProgressBar,
    /// The scale of the rate of the rung running, and its range `omegabar_max`.
    time: f64,
    omegabar_max: f64,
}

impl LocateProgress {
    fn new() -> Self {
        LocateProgress {
            bar: ProgressBar::hidden(),
            time: 1.0,
            omegabar_max: 1.0,
        }
    }

    /// A bar for a rung on `model` with the study's range.
    fn start(&mut self, study: &Study, model: &Model) {
        self.time = model.scales.time;
        self.omegabar_max = model.scales.omega_to_bar(study.branch.omega_max);
        self.bar = progress(self.omegabar_max, &format!("locate N = {}", model.nodes()));
    }
}

impl Observer<Point, Event> for LocateProgress {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        progress::set_fraction(&self.bar, point.p, (0.0, self.omegabar_max));
        self.bar
            .set_message(format!("omega = {:.5} rad/s", point.p / self.time));
        interrupt::flow()
    }
}

/// The rungs of a refinement or a ladder: a bar each, then a note of what it found.
struct RungProgress<'a> {
    study: &'a Study,
    progress: LocateProgress,
}

impl Observer<Point, Event> for RungProgress<'_> {
    fn point(&mut self, point: &Point) -> ControlFlow<()> {
        self.progress.point(point)
    }
}

impl RungObserver for RungProgress<'_> {
    fn rung(&mut self, model: &Model) {
        self.progress.start(self.study, model);
    }

    fn located(&mut self, nodes: usize, located: &Located) {
        self.progress.bar.finish_and_clear();
        progress::note(&format!(
            "locate N = {nodes}: {} ({})",
            located
                .omega_b
                .map_or("no omega_b".into(), |w| format!("omega_b = {w:.10} rad/s")),
            located.kind
        ));
    }

    fn quadrature(&mut self, quadrature: &QuadratureError) {
        progress::note(&match (quadrature.error, &quadrature.failed) {
            (Some(e), _) => format!(
                "  quadrature error {e:+.2e} rad/s at N = {} ({} against {} points per blob radius)",
                quadrature.nodes,
                quadrature.points_per_blob,
                quadrature.compared_with.unwrap_or(f64::NAN)
            ),
            (None, why) => format!(
                "  quadrature error not measured: {}",
                why.as_deref().unwrap_or("")
            ),
        });
    }

    fn estimated(&mut self, relative: f64, estimate: &DiscretizationError, answered: &Answered) {
        let quadrature = match &answered.correction {
            Some(c) => format!(
                "; plus the error of the quadrature's correction, {:.2e} rad/s",
                c.error
            ),
            None if answered.quadrature_part > 0.0 => format!(
                "; plus the quadrature error, {:.2e} rad/s",
                answered.quadrature_part
            ),
            None => String::new(),
        };
        let answer = match (&answered.limit, &answered.correction) {
            (Some(l), Some(c)) => format!(
                "the limit of the three finest rungs less the quadrature error {:+.2e}, {:.8} \
                 rad/s, its error in N {:.2e} rad/s",
                c.subtracted, answered.value, l.error
            ),
            (Some(l), None) => format!(
                "the limit of the three finest rungs, {:.8} rad/s, its error in N {:.2e} rad/s",
                l.value, l.error
            ),
            (None, Some(c)) => format!(
                "the finest rung less the quadrature error {:+.2e}: {}",
                c.subtracted, estimate.method
            ),
            (None, None) => format!("the finest rung: {}", estimate.method),
        };
        progress::note(&format!(
            "  estimated relative error {relative:.2e} ({answer}{quadrature})"
        ));
    }
}

/// `locate` on one model of the study, with a progress bar.
pub fn run_locate(study: &Study, model: &Model) -> Result<Located> {
    Ok(run_locate_critical(study, model)?.0)
}

/// [`run_locate`], with the located event.
pub fn run_locate_critical(study: &Study, model: &Model) -> Result<(Located, Option<Critical>)> {
    let mut observer = LocateProgress::new();
    observer.start(study, model);
    let result = locate(model, &study.locate_settings(), &mut observer);
    observer.bar.finish_and_clear();
    result
}

/// `omega_b` of `study` by `resolution`.
pub fn locate_study(study: &Study, resolution: &Resolution) -> Result<LocateResult> {
    let physical = study.physical();
    let settings = study.locate_settings();
    let mut observer = RungProgress {
        study,
        progress: LocateProgress::new(),
    };
    Ok(match resolution {
        Resolution::Single => LocateResult::Single(run_locate(study, &Model::new(&physical)?)?),
        Resolution::Refine {
            accuracy,
            max_nodes,
        } => LocateResult::Refined(refine(
            &physical,
            Some(*accuracy),
            *max_nodes,
            &settings,
            &mut observer,
        )?),
        Resolution::Fixed => {
            LocateResult::Refined(estimate_at_nodes(&physical, &settings, &mut observer)?)
        }
        Resolution::Ladder(nodes) => {
            let nodes = if nodes.is_empty() {
                default_ladder(&physical)
            } else {
                nodes.clone()
            };
            LocateResult::Ladder(ladder(&physical, &nodes, &settings, &mut observer)?)
        }
    })
}

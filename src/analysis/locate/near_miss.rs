//! The branch from rest checked for windows of instability inside its steps: at every near miss
//! of its points (a local maximum of the largest real part of the spectrum whose parabola comes
//! near the axis, [`crate::engine::near_miss`]) the state is solved at the probes of the search
//! and its spectrum computed; where one is unstable, the window's loss of stability is located
//! from it by the crossing search ([`locate_crossing`]) and is the first loss (docs/model.md
//! section 5). A probe whose state lies farther from the nearest of the three points around it
//! than the outer two lie apart (the largest move of a node) is taken for a state of another
//! branch: the near miss is then unresolved. A window whose loss the crossing search cannot
//! locate is a numerical failure that says where the window is: the continuation's own event
//! would not be the first loss.

use crate::Result;
use crate::analysis::locate::{LocateSettings, node_distance};
use crate::engine::arclength::{AtParameter, Point, stability};
use crate::engine::crossing::{Crossing, CrossingSettings, locate_crossing};
use crate::engine::near_miss::{Peak, Probe, Sample, probe_at, search};
use crate::engine::newton::{self, NewtonSettings};
use crate::engine::stability::Spectrum;
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::problem::rod::RodProblem;
use crate::problem::twist::{natural_chart_unknowns, scaled_twist, slave_twist};

/// A window of instability the continuation stepped over, found by a probe and located.
pub struct Window {
    /// The loss of stability at the window's start; its state is measured in the natural chart.
    pub crossing: Crossing,
    /// The step of the branch (`omegabar` of its two points) it lies in.
    pub step: (f64, f64),
}

/// What the near misses of a branch came to.
#[derive(Default)]
pub struct NearMisses {
    /// Probes solved.
    pub probes: usize,
    /// The first window found.
    pub window: Option<Window>,
    /// The first near miss (`omegabar` of its highest sample) whose search neither found nor
    /// excluded a window, and why.
    pub unresolved: Option<(f64, String)>,
    /// The stable probes, states between the points where a mode came near the axis: what a
    /// finer mesh's certificate checks besides the points (docs/model.md section 10).
    pub stable: Vec<Probed>,
}

/// A probe's state (natural chart) and spectrum, and the index of the branch's point before it.
pub struct Probed {
    pub after: usize,
    pub p: f64,
    pub u: Vec<f64>,
    pub spectrum: Spectrum,
}

/// The near misses of the stable points `points` of a branch of `problem` (in order along it)
/// searched one after the other until a window is found whose loss lies within `limit` (the
/// largest `|omegabar|` followed). `reference` is a state `(u, omegabar)` of the branch, its
/// twist measured in `chart` (the event's or the last point's): a probe's guess has the
/// positions of the branch's point nearest it and that twist, in the natural chart, scaled with
/// the rate (the twist carries the motor's torque, about proportional to the rate) and re-solved
/// for those positions; it is converted once, at the first probe.
pub fn probe_near_misses(
    model: &Model,
    problem: &RodProblem<&Model>,
    points: &[&Point],
    reference: (&[f64], &Chart, f64),
    limit: f64,
    settings: &LocateSettings,
) -> Result<NearMisses> {
    let nx = model.rod.layout.free_positions();
    let sample = |p: &Point| Sample {
        p: p.p,
        re: p.spectrum.max_re(),
    };
    // The probes solve to the continuation's tolerance, as its points and the crossing search do.
    let newton = NewtonSettings {
        tol: settings.continuation.tol,
        ..settings.newton.clone()
    };
    let mut twist: Option<Vec<f64>> = None;
    let mut found = NearMisses::default();
    for (k, run) in points.windows(3).enumerate() {
        let [l, m, r] = [sample(run[0]), sample(run[1]), sample(run[2])];
        if probe_at(l, m, r).is_none() {
            continue;
        }
        let tol = settings.continuation.event_tol * m.p.abs();
        let peak = search(l, m, r, tol, |p| {
            let near = run
                .iter()
                .min_by(|a, b| (a.p - p).abs().total_cmp(&(b.p - p).abs()))
                .expect("three points");
            // The nearest probe's state is the guess where it is nearer than the nearest point.
            let guess = match found
                .stable
                .iter()
                .min_by(|a, b| (a.p - p).abs().total_cmp(&(b.p - p).abs()))
                .filter(|q| (q.p - p).abs() < (near.p - p).abs())
            {
                Some(q) => q.u.clone(),
                None => {
                    let twist = match &mut twist {
                        Some(t) => t,
                        empty => {
                            let (u, chart, _) = reference;
                            let config = Steady::new(model, 0.0).config(u);
                            empty.insert(natural_chart_unknowns(model, &config, chart)?)
                        }
                    };
                    let u = scaled_twist(model, near.u.clone(), twist, p / reference.2);
                    slave_twist(model, &u)?
                }
            };
            let at = AtParameter::new(problem, p);
            let omega = model.scales.omega_from_bar(p);
            let context = format!("probing a near miss at omega = {omega:e} rad/s");
            let (u, _) = newton::solve(&at, guess, &newton, &context)?;
            // The probe's state lies between the points around it, not on another branch.
            let apart = run
                .iter()
                .map(|q| node_distance(&u[..nx], &q.u[..nx]))
                .fold(f64::INFINITY, f64::min);
            let span = node_distance(&run[0].u[..nx], &run[2].u[..nx]);
            if apart > span {
                return Err(crate::Error::Numerical(format!(
                    "{context}: the state found lies {apart:.3e} from the branch's nearest point, \
                     farther than the points around it lie apart ({span:.3e}): another branch?"
                )));
            }
            let lin = at.linearization_at(&u)?;
            let spectrum = stability(
                problem,
                &u,
                p,
                &lin,
                settings.continuation,
                Some(&near.spectrum),
            )?;
            let unstable = spectrum.unstable > 0;
            if !unstable {
                found.stable.push(Probed {
                    after: k + usize::from(!before_middle(run, p)),
                    p,
                    u: u.clone(),
                    spectrum: spectrum.clone(),
                });
            }
            Ok(Probe {
                sample: Sample {
                    p,
                    re: spectrum.max_re(),
                },
                unstable,
                state: (u, spectrum),
            })
        });
        match peak {
            Peak::Below { probes, .. } => found.probes += probes,
            Peak::Unresolved {
                probes,
                highest,
                why,
            } => {
                found.probes += probes;
                found.unresolved.get_or_insert((highest.p, why));
            }
            Peak::Window {
                probes,
                unstable,
                stable,
            } => {
                found.probes += probes;
                let (u, spectrum): (Vec<f64>, Spectrum) = unstable.state;
                let p = unstable.sample.p;
                let slope = (unstable.sample.re - stable.re) / (p - stable.p);
                let crossing_search = CrossingSettings {
                    first_step: 5e-3,
                    slope: Some(slope),
                    max_evaluations: 40,
                    unstable_before: 0,
                };
                let track = spectrum.leading[0];
                let crossing = locate_crossing(
                    problem,
                    &u,
                    p,
                    track,
                    &crossing_search,
                    settings.continuation,
                )
                .map_err(|e| {
                    let omega = model.scales.omega_from_bar(p);
                    crate::Error::Numerical(format!(
                        "a window of instability at omega = {omega:e} rad/s, which the \
                         continuation stepped over (found by probing a near miss), could not be \
                         located: {e}"
                    ))
                })?;
                // A window past the range followed is not this branch's to report.
                if crossing.event.p.abs() > limit.abs() {
                    continue;
                }
                let step = if before_middle(run, p) {
                    (run[0].p, run[1].p)
                } else {
                    (run[1].p, run[2].p)
                };
                found.window = Some(Window { crossing, step });
                return Ok(found);
            }
        }
    }
    Ok(found)
}

/// Whether `p` lies before the middle point of `run` along the branch.
fn before_middle(run: &[&Point], p: f64) -> bool {
    (p - run[1].p) * (run[1].p - run[0].p) < 0.0
}

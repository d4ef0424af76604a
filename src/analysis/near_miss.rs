//! The branch from rest checked for windows of instability inside its steps: at every near miss
//! of its stable points (a local maximum of the largest real part of the spectrum whose parabola
//! comes near the axis, [`crate::engine::near_miss`]) the state is solved at the probes of the
//! search and its spectrum computed; where one is unstable, the window's loss of stability is
//! located from it by the crossing search ([`locate_crossing`]), and for a whole branch its
//! regain too (docs/model.md section 5). A probe starts from the nearest point's state (its twist
//! converted to the natural chart from the chart the continuation measured it in), or from the
//! nearest stable probe's where that is nearer. A probe whose state lies farther from the nearest
//! of the three points around it
//! than the outer two lie apart (the largest move of a node) is taken for a state of another
//! branch: the near miss is then unresolved. Where the first loss is sought (`locate`), a window
//! whose loss the crossing search cannot locate is a numerical failure that says where the
//! window is: the continuation's own event would not be the first loss. Along a whole branch it
//! is one more unresolved near miss, and so is an end located outside the part of the step
//! between the probe and the stable sample on its side (another crossing than the window's).

use crate::Result;
use crate::engine::ContinuationSettings;
use crate::engine::arclength::{AtParameter, Point, stability};
use crate::engine::crossing::{Crossing, CrossingSettings, locate_crossing};
use crate::engine::near_miss::{Peak, Probe, Sample, probe_at, search};
use crate::engine::newton::{self, NewtonSettings};
use crate::engine::stability::Spectrum;
use crate::model::Model;
use crate::model::rod::frame::Chart;
use crate::model::steady::Steady;
use crate::problem::rod::RodProblem;
use crate::problem::twist::natural_chart_unknowns;

/// What the near misses are searched for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Seek {
    /// The first window's loss of stability (`locate`): the search ends at it.
    FirstLoss,
    /// Every window, each with its loss and its regain of stability (`branch`).
    EveryWindow,
}

/// A window of instability the continuation stepped over, found by a probe and located; its
/// states are measured in the natural chart.
pub struct Window {
    /// The loss of stability at the window's start.
    pub loss: Crossing,
    /// The regain of stability at its end ([`Seek::EveryWindow`]).
    pub regain: Option<Crossing>,
    /// The unstable probe that found it.
    pub probe: Probed,
}

/// What the near misses of a branch came to.
#[derive(Default)]
pub struct NearMisses {
    /// Probes solved.
    pub probes: usize,
    /// The windows found and located, in order along the branch.
    pub windows: Vec<Window>,
    /// The near misses (`omegabar` of the highest sample) whose search neither found nor
    /// excluded a window, or found one that could not be located, and why.
    pub unresolved: Vec<(f64, String)>,
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

impl NearMisses {
    /// The `omegabar` of the two points of the step a window lies in.
    pub fn step(points: &[Point], window: &Window) -> (f64, f64) {
        let a = window.probe.after;
        (points[a].p, points[a + 1].p)
    }

    /// Each unresolved near miss as reports state it: where, in rad/s of `model`, and why.
    pub fn unresolved_described<'a>(
        &'a self,
        model: &'a Model,
    ) -> impl Iterator<Item = String> + 'a {
        self.unresolved.iter().map(|(p, why)| {
            let omega = model.scales.omega_from_bar(*p);
            format!("near omega = {omega:.6e} rad/s: {why}")
        })
    }
}

/// The near misses among the points of a branch of `problem` (in order along it, `charts` the
/// chart each is measured in): at every three stable points in a row, searched one after the
/// other for what `seek` asks, each window's loss within `limit` (the largest `|omegabar|`
/// followed). The probes solve their states with `newton` at the continuation's tolerance,
/// as its points and the crossing search do.
pub fn probe_near_misses(
    model: &Model,
    problem: &RodProblem<&Model>,
    (points, charts): (&[Point], &[Chart]),
    limit: f64,
    (newton, continuation): (&NewtonSettings, &ContinuationSettings),
    seek: Seek,
) -> Result<NearMisses> {
    let sample = |p: &Point| Sample {
        p: p.p,
        re: p.spectrum.max_re(),
    };
    let newton = NewtonSettings {
        tol: continuation.tol,
        ..newton.clone()
    };
    let layout = model.rod.layout;
    // Each point's unknowns with the twist in the natural chart, converted when first needed.
    let mut natural: Vec<Option<Vec<f64>>> = vec![None; points.len()];
    let mut found = NearMisses::default();
    for (k, run) in points.windows(3).enumerate() {
        if run.iter().any(|q| q.spectrum.unstable > 0) {
            continue;
        }
        let [l, m, r] = [sample(&run[0]), sample(&run[1]), sample(&run[2])];
        if probe_at(l, m, r).is_none() {
            continue;
        }
        let tol = continuation.event_tol * m.p.abs();
        let peak = search(l, m, r, tol, |p| {
            let (i, near) = (k..k + 3)
                .map(|i| (i, &points[i]))
                .min_by(|a, b| (a.1.p - p).abs().total_cmp(&(b.1.p - p).abs()))
                .expect("three points");
            // The nearest probe's state is the guess where it is nearer than the nearest point.
            let guess = match found
                .stable
                .iter()
                .min_by(|a, b| (a.p - p).abs().total_cmp(&(b.p - p).abs()))
                .filter(|q| (q.p - p).abs() < (near.p - p).abs())
            {
                Some(q) => q.u.clone(),
                None => match &mut natural[i] {
                    Some(u) => u.clone(),
                    empty => {
                        let config = Steady::new(model, 0.0).config(&near.u);
                        empty
                            .insert(natural_chart_unknowns(model, &config, &charts[i])?)
                            .clone()
                    }
                },
            };
            let at = AtParameter::new(problem, p);
            let omega = model.scales.omega_from_bar(p);
            let context = format!("probing a near miss at omega = {omega:e} rad/s");
            let (u, _) = newton::solve(&at, guess, &newton, &context)?;
            // The probe's state lies between the points around it, not on another branch.
            let apart = run
                .iter()
                .map(|q| layout.node_distance(&u, &q.u))
                .fold(f64::INFINITY, f64::min);
            let span = layout.node_distance(&run[0].u, &run[2].u);
            if apart > span {
                return Err(crate::Error::Numerical(format!(
                    "{context}: the state found lies {apart:.3e} from the branch's nearest point, \
                     farther than the points around it lie apart ({span:.3e}): another branch?"
                )));
            }
            let lin = at.linearization_at(&u)?;
            let spectrum = stability(problem, &u, p, &lin, continuation, Some(&near.spectrum))?;
            let unstable = spectrum.unstable > 0;
            if !unstable {
                found.stable.push(Probed {
                    after: step_start(k, run, p),
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
        let (probes, unstable, before, after) = match peak {
            Peak::Below { probes, .. } => {
                found.probes += probes;
                continue;
            }
            Peak::Unresolved {
                probes,
                highest,
                why,
            } => {
                found.probes += probes;
                found.unresolved.push((highest.p, why));
                continue;
            }
            Peak::Window {
                probes,
                unstable,
                before,
                after,
            } => (probes, unstable, before, after),
        };
        found.probes += probes;
        let (u, spectrum): (Vec<f64>, Spectrum) = unstable.state;
        let p = unstable.sample.p;
        let travel = (run[2].p - run[0].p).signum();
        // The crossing from the unstable probe towards the stable sample on one side, which must
        // lie between the two.
        let locate = |stable: Sample, regain: bool| {
            let crossing_search = CrossingSettings {
                first_step: 5e-3,
                slope: Some((unstable.sample.re - stable.re) / (p - stable.p)),
                max_evaluations: 40,
                unstable_stable_side: 0,
                travel,
                regain,
            };
            locate_crossing(
                problem,
                &u,
                p,
                spectrum.leading[0],
                &crossing_search,
                continuation,
            )
            .map_err(|e| e.to_string())
            .and_then(|crossing| {
                let at = crossing.event.p;
                if (at - p) * (at - stable.p) <= 0.0 {
                    Ok(crossing)
                } else {
                    Err(format!(
                        "the crossing found, at omega = {:e} rad/s, lies outside the step",
                        model.scales.omega_from_bar(at)
                    ))
                }
            })
            .map_err(|e| {
                let omega = model.scales.omega_from_bar(p);
                let end = if regain { "end" } else { "start" };
                format!(
                    "a window of instability at omega = {omega:e} rad/s, which the continuation \
                     stepped over (found by probing a near miss): its {end} could not be \
                     located: {e}"
                )
            })
        };
        let probe = Probed {
            after: step_start(k, run, p),
            p,
            u: u.clone(),
            spectrum: spectrum.clone(),
        };
        let loss = match (locate(before, false), seek) {
            (Ok(loss), _) => loss,
            (Err(why), Seek::FirstLoss) => return Err(crate::Error::Numerical(why)),
            (Err(why), Seek::EveryWindow) => {
                found.unresolved.push((p, why));
                continue;
            }
        };
        // A window past the range followed is not this branch's to report.
        if loss.event.p.abs() > limit.abs() {
            continue;
        }
        let regain = match seek {
            Seek::FirstLoss => None,
            Seek::EveryWindow => match locate(after, true) {
                Ok(regain) => Some(regain),
                Err(why) => {
                    found.unresolved.push((p, why));
                    None
                }
            },
        };
        found.windows.push(Window {
            loss,
            regain,
            probe,
        });
        if seek == Seek::FirstLoss {
            break;
        }
    }
    Ok(found)
}

/// The index of the point that starts the step holding `p` among the three points `run`, the
/// first of which has the index `k`: `k` where `p` lies before the middle point along the
/// branch, `k + 1` after it.
fn step_start(k: usize, run: &[Point], p: f64) -> usize {
    let before_middle = (p - run[1].p) * (run[1].p - run[0].p) < 0.0;
    k + usize::from(!before_middle)
}

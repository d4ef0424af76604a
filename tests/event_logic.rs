//! The event logic of the continuation engine on small problems whose events are known exactly:
//! two events in one step, an exchange of unstable modes, the relative precision of `--tol`,
//! honest precision when the residual has a floor, and the reason a run stops where the model
//! cannot be evaluated.

use faer::Mat;
use helixbif::engine::arclength::{Branch, BranchStop, Limits, follow};
use helixbif::engine::events::EventKind;
use helixbif::engine::newton::{self, NewtonSettings, System};
use helixbif::engine::reference::{Analytic, Jacobian, Reference, Residual};
use helixbif::engine::stop::{Silent, Stop};
use helixbif::engine::{ContinuationSettings, Linearization, Problem};
use helixbif::error::ModelError;
use helixbif::{Error, Result};

fn settings() -> ContinuationSettings {
    ContinuationSettings {
        ds: 0.1,
        ds_max: 0.5,
        ..ContinuationSettings::default()
    }
}

fn run(problem: &impl Problem, u0: Vec<f64>, p0: f64, p_max: f64, first: bool) -> Branch {
    let limits = Limits {
        p_min: p0 - 1.0,
        p_max,
        stop_at_first_instability: first,
    };
    follow(problem, u0, p0, 1.0, &settings(), &limits, &mut Silent).unwrap()
}

/// A pitchfork `u0' = (p - b) u0 - u0^3` beside a Hopf normal form whose pair has real part
/// `p - h`: a branch point at `p = b` and a Hopf point at `p = h` on the trivial branch.
fn branch_and_hopf(b: f64, h: f64) -> Reference {
    Analytic {
        dim: 3,
        g: Box::new(move |u: &[f64], p: f64| {
            let r2 = u[1] * u[1] + u[2] * u[2];
            vec![
                (p - b) * u[0] - u[0].powi(3),
                (p - h) * u[1] - u[2] - u[1] * r2,
                u[1] + (p - h) * u[2] - u[2] * r2,
            ]
        }) as Residual,
        g_u: Box::new(move |u: &[f64], p: f64| {
            let (x, y) = (u[1], u[2]);
            vec![
                vec![p - b - 3.0 * u[0] * u[0], 0.0, 0.0],
                vec![0.0, p - h - 3.0 * x * x - y * y, -1.0 - 2.0 * x * y],
                vec![0.0, 1.0 - 2.0 * x * y, p - h - x * x - 3.0 * y * y],
            ]
        }) as Jacobian,
        g_p: Box::new(|u: &[f64], _: f64| vec![u[0], u[1], u[2]]) as Residual,
    }
}

#[test]
fn a_branch_point_and_a_hopf_point_in_one_step_are_both_located_and_typed() {
    // 1e-3 apart: closer than a sixteenth of any step, so one step holds both.
    let problem = branch_and_hopf(0.0, 1e-3);
    let branch = run(&problem, vec![0.0; 3], -1.0, 1.0, false);
    let kinds: Vec<(EventKind, f64)> = branch.events.iter().map(|e| (e.kind, e.p)).collect();
    assert_eq!(kinds.len(), 2, "{kinds:?}");
    assert_eq!(kinds[0].0, EventKind::BranchPoint, "{kinds:?}");
    assert_eq!(kinds[1].0, EventKind::Hopf, "{kinds:?}");
    assert!(kinds[0].1.abs() <= 1e-10, "{kinds:?}");
    assert!((kinds[1].1 - 1e-3).abs() <= 1e-8 * 1e-3, "{kinds:?}");
    let hopf = &branch.events[1];
    assert!((hopf.eigenvalue.im - 1.0).abs() < 1e-6);
    assert_eq!((hopf.unstable_before, hopf.unstable_after), (1, 3));
    assert_eq!(branch.events[0].multiplicity, 1);
    assert_eq!(hopf.multiplicity, 1);
}

#[test]
fn the_first_loss_of_stability_is_the_first_event_not_the_last() {
    // The Hopf point comes first (p = 0), the branch point right after (p = 1e-3): the
    // instability is the Hopf point, with its frequency.
    let problem = branch_and_hopf(1e-3, 0.0);
    // Steps of a fixed length (no halving), so that one step holds both events.
    let fixed = ContinuationSettings {
        ds: 0.1,
        ds_min: 0.1,
        ds_max: 0.1,
        ..ContinuationSettings::default()
    };
    let limits = Limits {
        p_min: -2.0,
        p_max: 1.0,
        stop_at_first_instability: true,
    };
    let branch = follow(
        &problem,
        vec![0.0; 3],
        -0.95,
        1.0,
        &fixed,
        &limits,
        &mut Silent,
    )
    .unwrap();
    assert_eq!(branch.events.len(), 2, "{:?}", branch.events);
    assert_eq!(branch.stop, Stop::Own(BranchStop::FirstInstability));
    let first = branch.first_loss_of_stability().expect("an instability");
    assert_eq!(first.kind, EventKind::Hopf);
    assert!(first.p.abs() <= 1e-10, "{}", first.p);
    assert!((first.eigenvalue.im - 1.0).abs() < 1e-6);
    assert_eq!(branch.events.last().unwrap().kind, EventKind::BranchPoint);
}

/// Two Hopf normal forms: pair A with real part `p` (frequency 1), pair B with real part
/// `e - p` (frequency 2). From `p = -1` pair B is unstable; A gains instability at `p = 0`
/// and B loses it at `p = e`: the unstable count is 2 on both sides of the pair of events.
fn exchange(e: f64) -> Reference {
    fn block(re: f64, w: f64, x: f64, y: f64) -> [f64; 2] {
        let r2 = x * x + y * y;
        [re * x - w * y - x * r2, w * x + re * y - y * r2]
    }
    fn jac(re: f64, w: f64, x: f64, y: f64) -> [[f64; 2]; 2] {
        [
            [re - 3.0 * x * x - y * y, -w - 2.0 * x * y],
            [w - 2.0 * x * y, re - x * x - 3.0 * y * y],
        ]
    }
    Analytic {
        dim: 4,
        g: Box::new(move |u: &[f64], p: f64| {
            let a = block(p, 1.0, u[0], u[1]);
            // Pair B is subcritical-free and unstable for p < e: a linear block suffices.
            let (x, y) = (u[2], u[3]);
            let b = [(e - p) * x - 2.0 * y, 2.0 * x + (e - p) * y];
            vec![a[0], a[1], b[0], b[1]]
        }) as Residual,
        g_u: Box::new(move |u: &[f64], p: f64| {
            let a = jac(p, 1.0, u[0], u[1]);
            vec![
                vec![a[0][0], a[0][1], 0.0, 0.0],
                vec![a[1][0], a[1][1], 0.0, 0.0],
                vec![0.0, 0.0, e - p, -2.0],
                vec![0.0, 0.0, 2.0, e - p],
            ]
        }) as Jacobian,
        g_p: Box::new(|u: &[f64], _: f64| vec![u[0], u[1], -u[2], -u[3]]) as Residual,
    }
}

#[test]
fn two_modes_exchanging_stability_in_one_step_give_two_hopf_points() {
    let problem = exchange(1e-3);
    let branch = run(&problem, vec![0.0; 4], -1.0, 1.0, false);
    let events: Vec<(EventKind, f64, usize, usize, f64)> = branch
        .events
        .iter()
        .map(|e| {
            (
                e.kind,
                e.p,
                e.unstable_before,
                e.unstable_after,
                e.eigenvalue.im,
            )
        })
        .collect();
    assert_eq!(events.len(), 2, "{events:?}");
    let (a, b) = (events[0], events[1]);
    assert_eq!((a.0, a.2, a.3), (EventKind::Hopf, 2, 4), "{events:?}");
    assert_eq!((b.0, b.2, b.3), (EventKind::Hopf, 4, 2), "{events:?}");
    assert!(
        a.1.abs() <= 1e-10 && (b.1 - 1e-3).abs() <= 1e-11,
        "{events:?}"
    );
    // Each is typed by its own mode: frequency 1 gains stability, frequency 2 loses it.
    assert!(
        (a.4 - 1.0).abs() < 1e-6 && (b.4 - 2.0).abs() < 1e-6,
        "{events:?}"
    );
}

#[test]
fn a_simultaneous_exchange_is_reported_as_such_not_missed() {
    let problem = exchange(0.0);
    let branch = run(&problem, vec![0.0; 4], -1.0, 1.0, false);
    assert_eq!(branch.events.len(), 1, "{:?}", branch.events);
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::ModeExchange);
    assert!(e.p.abs() <= 1e-8, "{}", e.p);
    assert_eq!((e.unstable_before, e.unstable_after), (2, 2));
}

#[test]
fn event_tolerance_is_relative_also_at_small_parameters() {
    // A Hopf point at p = 0.01 whose critical real part is nonlinear (and monotone) in p.
    let c = 0.01;
    let problem = Analytic {
        dim: 2,
        g: Box::new(move |u: &[f64], p: f64| {
            let re = (p - c) + 30.0 * (p - c).powi(3);
            vec![re * u[0] - u[1], u[0] + re * u[1]]
        }) as Residual,
        g_u: Box::new(move |_: &[f64], p: f64| {
            let re = (p - c) + 30.0 * (p - c).powi(3);
            vec![vec![re, -1.0], vec![1.0, re]]
        }) as Jacobian,
        g_p: Box::new(move |u: &[f64], p: f64| {
            let d = 1.0 + 90.0 * (p - c).powi(2);
            vec![d * u[0], d * u[1]]
        }) as Residual,
    };
    let tol = 1e-4;
    let s = ContinuationSettings {
        event_tol: tol,
        ..settings()
    };
    let limits = Limits {
        p_min: -1.0,
        p_max: 1.0,
        stop_at_first_instability: true,
    };
    let branch = follow(
        &problem,
        vec![0.0, 0.0],
        -0.5,
        1.0,
        &s,
        &limits,
        &mut Silent,
    )
    .unwrap();
    let e = branch.first_loss_of_stability().unwrap();
    assert_eq!(e.kind, EventKind::Hopf);
    let width = e.bracket.1 - e.bracket.0;
    assert!(
        width <= tol * c,
        "bracket {:?} wider than {tol} relative",
        e.bracket
    );
    assert!(e.precision <= tol, "{}", e.precision);
    assert!((e.p - c).abs() <= tol * c, "{} vs {c}", e.p);
}

#[test]
fn a_residual_floor_above_tol_shows_in_the_stated_precision() {
    // The Brusselator's Hopf point at b = 1 + a^2, with a deterministic noise of size 1e-7 on
    // the residual (ten times the round-off floor that `continuation.tol = 1e-9` assumes):
    // points cannot be known better than ~1e-7, and the event must not claim more.
    let a = 2.0;
    let noise = 1e-7;
    let wiggle = move |u: &[f64], b: f64| noise * (1e7 * (u[0] + 2.0 * u[1] + 3.0 * b)).sin();
    let problem = Analytic {
        dim: 2,
        g: Box::new(move |u: &[f64], b: f64| {
            let (x, y) = (u[0], u[1]);
            let n = wiggle(u, b);
            vec![a - (b + 1.0) * x + x * x * y + n, b * x - x * x * y - n]
        }) as Residual,
        g_u: Box::new(|u: &[f64], b: f64| {
            let (x, y) = (u[0], u[1]);
            vec![
                vec![-(b + 1.0) + 2.0 * x * y, x * x],
                vec![b - 2.0 * x * y, -x * x],
            ]
        }) as Jacobian,
        g_p: Box::new(|u: &[f64], _| vec![-u[0], u[0]]) as Residual,
    };
    let limits = Limits {
        p_min: 0.0,
        p_max: 8.0,
        stop_at_first_instability: true,
    };
    let result = follow(
        &problem,
        vec![a, 1.0 / a],
        1.0,
        1.0,
        &settings(),
        &limits,
        &mut Silent,
    )
    .unwrap();
    let exact = 1.0 + a * a;
    match result.first_loss_of_stability() {
        Some(e) => {
            let error = (e.p - exact).abs() / exact;
            assert!(
                e.precision >= 1e-9,
                "precision {:e} claimed on points known to ~1e-7",
                e.precision
            );
            assert!(
                error <= 10.0 * e.precision,
                "error {error:e} against a stated precision {:e}",
                e.precision
            );
        }
        None => assert!(
            matches!(result.stop, Stop::StepTooSmall(_)),
            "{:?}",
            result.stop
        ),
    }
}

/// A problem that cannot be evaluated beyond `p = 0.5`, as a mobility that loses positive
/// definiteness.
struct Indefinite;

fn indefinite(p: f64) -> Result<()> {
    if p > 0.5 {
        Err(ModelError::NotPositiveDefinite {
            context: format!("p = {p}"),
            geometry: "closest approach 0.5 delta".into(),
        }
        .into())
    } else {
        Ok(())
    }
}

impl Problem for Indefinite {
    fn dim(&self) -> usize {
        1
    }
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        indefinite(p)?;
        Ok(vec![-u[0] + p])
    }
    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        Ok(Linearization {
            g: self.residual(u, p)?,
            g_u: Mat::from_fn(1, 1, |_, _| -1.0),
            g_p: vec![1.0],
        })
    }
    fn stability_pair(
        &self,
        _u: &[f64],
        _p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        Ok((lin.g_u.clone(), Mat::identity(1, 1)))
    }
}

#[test]
fn a_continuation_that_meets_an_indefinite_mobility_says_so() {
    let limits = Limits {
        p_min: -1.0,
        p_max: 2.0,
        stop_at_first_instability: false,
    };
    let branch = follow(
        &Indefinite,
        vec![0.0],
        0.0,
        1.0,
        &settings(),
        &limits,
        &mut Silent,
    )
    .unwrap();
    let Stop::StepTooSmall(reason) = &branch.stop else {
        panic!("{:?}", branch.stop)
    };
    assert!(
        reason.contains("not positive definite") && reason.contains("closest approach"),
        "{reason}"
    );
    assert!(branch.points.last().unwrap().p <= 0.5);
}

/// `G(u) = u - 10`, whose model cannot be evaluated at `u > 1e-4`: every trial of the line
/// search fails there.
struct Cornered;

impl System for Cornered {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        if u[0] > 1e-4 {
            return Err(ModelError::NotPositiveDefinite {
                context: format!("u = {}", u[0]),
                geometry: "smallest node spacing 3.1 delta".into(),
            }
            .into());
        }
        Ok(vec![u[0] - 10.0])
    }
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        Ok((self.residual(u)?, Mat::from_fn(1, 1, |_, _| 1.0)))
    }
}

#[test]
fn newton_reports_the_indefinite_mobility_not_a_bare_line_search_failure() {
    let result = newton::solve(&Cornered, vec![0.0], &NewtonSettings::default(), "test");
    match result {
        Err(Error::Model(ModelError::NotPositiveDefinite { geometry, .. })) => {
            assert!(geometry.contains("node spacing"), "{geometry}")
        }
        other => panic!("expected the mobility's error, got {other:?}"),
    }
}

/// A Hopf pair whose real part bends with the parameter, `r(p) = (p^2 - 4) + a (p^2 - 4)^2`
/// (`a = 2`), through a state that moves with it (`u0 = p^2`, so every solve has work): the
/// Hopf point is at `p = 2`, where `dr/dp = 4` exactly. With `sign = -1` the real part is `-r`:
/// unstable below `p = 2`, stable above (the end of a window of instability).
fn bent_hopf(sign: f64) -> Reference {
    let a = 2.0;
    let r = move |u0: f64| sign * ((u0 - 4.0) + a * (u0 - 4.0).powi(2));
    let dr = move |u0: f64| sign * (1.0 + 2.0 * a * (u0 - 4.0));
    Analytic {
        dim: 3,
        g: Box::new(move |u: &[f64], p: f64| {
            let (x, y) = (u[1], u[2]);
            vec![p * p - u[0], r(u[0]) * x - y, x + r(u[0]) * y]
        }) as Residual,
        g_u: Box::new(move |u: &[f64], _: f64| {
            let (x, y) = (u[1], u[2]);
            vec![
                vec![-1.0, 0.0, 0.0],
                vec![dr(u[0]) * x, r(u[0]), -1.0],
                vec![dr(u[0]) * y, 1.0, r(u[0])],
            ]
        }) as Jacobian,
        g_p: Box::new(|_: &[f64], p: f64| vec![2.0 * p, 0.0, 0.0]) as Residual,
    }
}

/// The crossing search of a sequenced rung ([`locate_crossing`]) from a state off the Hopf
/// point, with a slope half again too steep: it ends within the event tolerance of the exact
/// `p = 2`, on the stable side (the event is the bracket's near end, unstable count 0 and
/// `Re s <= 0`), and its stated precision covers its distance to the zero. The slope of the
/// eigenvalue over a relative step `1e-3` below the point equals the closed-form secant of
/// `r(p)` to the Newton tolerance, within 2% of `dr/dp = 4`.
#[test]
fn a_crossing_is_located_from_a_nearby_state_on_its_stable_side() {
    use faer::c64;
    use helixbif::engine::crossing::{CrossingSettings, eigenvalue_slope, locate_crossing};
    let problem = bent_hopf(1.0);
    let continuation = ContinuationSettings::default();
    let search = CrossingSettings {
        first_step: 5e-3,
        slope: Some(6.0),
        max_evaluations: 40,
        unstable_stable_side: 0,
        travel: 1.0,
        regain: false,
    };
    let u0 = [2.1f64 * 2.1, 0.0, 0.0];
    let crossing = locate_crossing(
        &problem,
        &u0,
        2.1,
        c64::new(0.0, 1.0),
        &search,
        &continuation,
    )
    .unwrap();
    let event = &crossing.event;
    let tol = continuation.event_tol;
    let distance = (event.p - 2.0).abs() / 2.0;
    assert!(event.kind == EventKind::Hopf, "{:?}", event.kind);
    assert!(distance <= tol, "p = {}", event.p);
    assert!(distance <= event.precision, "{distance:e} {event:?}");
    assert_eq!(event.unstable_before, 0);
    assert_eq!(event.spectrum.unstable, 0);
    assert!(event.eigenvalue.re <= 0.0, "{}", event.eigenvalue);
    // Seven solves here, from 5% away with the wrong slope; the search allows forty.
    assert!(crossing.evaluations <= 10, "{}", crossing.evaluations);
    let r = |p: f64| (p * p - 4.0) + 2.0 * (p * p - 4.0).powi(2);
    let slope = eigenvalue_slope(
        &problem,
        &event.u,
        event.p,
        event.eigenvalue,
        1e-3,
        &continuation,
    )
    .unwrap();
    let below = event.p * (1.0 - 1e-3);
    let secant = (r(event.p) - r(below)) / (event.p - below);
    assert!((slope - secant).abs() < 1e-6, "{slope} against {secant}");
    // The secant's own error against dr/dp = 4 is r''/2 times the step: 33 * 2e-3 = 0.066.
    assert!((slope - 4.0).abs() < 0.02 * 4.0, "{slope}");
}

/// The crossing search with the stable side on either side of the crossing at `p = 2`, the
/// branch travelled either way: stability regained at increasing `p` on the mirrored
/// `bent_hopf` (stable above), and at decreasing `p` on `bent_hopf` itself (stable below), and
/// lost at decreasing `p` on the mirrored one. From an unstable state 5% away with a slope half
/// again too steep, and from a stable one 5% away without a slope, each ends within the event
/// tolerance of `p = 2` with the near end on the stable side, the counts before and after in
/// the direction of travel, the precision covering the distance.
#[test]
fn a_regain_of_stability_is_located_from_either_side() {
    use faer::c64;
    use helixbif::engine::crossing::{CrossingSettings, locate_crossing};
    let continuation = ContinuationSettings::default();
    let tol = continuation.event_tol;
    // (sign of the real part above p = 2, travel, regain, the stable side's sign from p = 2)
    let cases = [
        (-1.0, 1.0, true, 1.0),
        (1.0, -1.0, true, -1.0),
        (-1.0, -1.0, false, 1.0),
    ];
    for (sign, travel, regain, stable_side) in cases {
        let problem = bent_hopf(sign);
        // h = sign r(p), r' = 4 at p = 2: the slope 1.5 times too steep.
        let steep = 6.0 * sign;
        let unstable_p0 = 2.0 - 0.1 * stable_side;
        let stable_p0 = 2.0 + 0.1 * stable_side;
        let counts = if travel * stable_side > 0.0 {
            (2, 0)
        } else {
            (0, 2)
        };
        for (p0, slope) in [(unstable_p0, Some(steep)), (stable_p0, None)] {
            let case = format!("sign {sign}, travel {travel}, regain {regain}, from {p0}");
            let search = CrossingSettings {
                first_step: 5e-3,
                slope,
                max_evaluations: 40,
                unstable_stable_side: 0,
                travel,
                regain,
            };
            let u0 = [p0 * p0, 0.0, 0.0];
            let crossing = locate_crossing(
                &problem,
                &u0,
                p0,
                c64::new(0.0, 1.0),
                &search,
                &continuation,
            )
            .unwrap_or_else(|e| panic!("{case}: {e}"));
            let event = &crossing.event;
            let distance = (event.p - 2.0).abs() / 2.0;
            assert!(event.kind == EventKind::Hopf, "{case}: {:?}", event.kind);
            assert!(distance <= tol, "{case}: p = {}", event.p);
            assert!(
                distance <= event.precision,
                "{case}: {distance:e} {event:?}"
            );
            assert_eq!(
                (event.unstable_before, event.unstable_after),
                counts,
                "{case}"
            );
            assert!(
                (crossing.near.p - 2.0) * stable_side > 0.0 && crossing.near.spectrum.unstable == 0,
                "{case}: near end at {}",
                crossing.near.p
            );
            assert!(
                crossing.evaluations <= 12,
                "{case}: {}",
                crossing.evaluations
            );
        }
    }
}

//! The continuation engine alone, on canonical problems with exact answers: the event kind is
//! right and its location error is below the tolerance asked.

use std::ops::ControlFlow;

use helixbif::engine::arclength::{
    BranchStop, Continuation, Detector, Limits, Metric, Outcome, Point, StopRule, follow,
    follow_with,
};
use helixbif::engine::events::{Event, EventKind};
use helixbif::engine::reference::{Reference, brusselator, fold, hopf_normal_form, pitchfork};
use helixbif::engine::stop::{Silent, Stop};
use helixbif::engine::{ContinuationSettings, Problem};

fn settings() -> ContinuationSettings {
    ContinuationSettings {
        ds: 0.1,
        ds_max: 0.5,
        ..ContinuationSettings::default()
    }
}

fn limits(p_min: f64, p_max: f64) -> Limits {
    Limits {
        p_min,
        p_max,
        stop_at_first_instability: false,
    }
}

fn run(
    problem: &impl Problem,
    u0: Vec<f64>,
    p0: f64,
    direction: f64,
    l: Limits,
) -> helixbif::engine::arclength::Branch {
    follow(problem, u0, p0, direction, &settings(), &l, &mut Silent).unwrap()
}

#[test]
fn fold_of_the_quadratic_is_found_and_passed() {
    // u^2 = p from (u, p) = (-1, 1) towards smaller p: around the fold at p = 0 and back up.
    let branch = run(&fold(), vec![-1.0], 1.0, -1.0, limits(-1.0, 1.0));
    assert_eq!(branch.stop, Stop::ParameterLimit);
    assert_eq!(branch.events.len(), 1);
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::Fold);
    assert!(e.p.abs() <= 1e-8, "fold at p = {:e}", e.p);
    assert!(e.u[0].abs() < 1e-4);
    assert_eq!((e.unstable_before, e.unstable_after), (0, 1));
    // The branch really turned: it ends on the u > 0 side.
    assert!(branch.points.last().unwrap().u[0] > 0.9);
}

#[test]
fn perfect_pitchfork_has_a_branch_point() {
    let branch = run(&pitchfork(0.0), vec![0.0], -1.0, 1.0, limits(-2.0, 1.0));
    assert_eq!(branch.events.len(), 1);
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::BranchPoint);
    assert!(e.p.abs() <= 1e-8, "branch point at p = {:e}", e.p);
}

#[test]
fn imperfect_pitchfork_is_smooth_on_one_branch_and_folds_on_the_other() {
    let eps = 0.01;
    // Primary branch (u > 0): no event from p = -1 to p = 1.
    let branch = run(&pitchfork(eps), vec![eps], -1.0, 1.0, limits(-2.0, 1.0));
    assert!(
        branch.events.is_empty(),
        "{:?}",
        branch.events.iter().map(|e| e.p).collect::<Vec<_>>()
    );
    assert!(branch.points.iter().all(|p| p.spectrum.unstable == 0));
    // Lower branch from p = 2 down: a fold at p = 3 (eps/2)^(2/3).
    let exact = 3.0 * (eps / 2.0).powf(2.0 / 3.0);
    let branch = run(
        &pitchfork(eps),
        vec![-(2.0f64).sqrt()],
        2.0,
        -1.0,
        limits(-1.0, 3.0),
    );
    let e = branch
        .events
        .iter()
        .find(|e| e.kind == EventKind::Fold)
        .expect("a fold");
    assert!(
        (e.p - exact).abs() <= 1e-8 * exact,
        "fold at {} vs {exact}",
        e.p
    );
    assert!((e.u[0] + (eps / 2.0).cbrt()).abs() < 1e-3);
}

#[test]
fn hopf_point_of_the_normal_form() {
    let branch = run(
        &hopf_normal_form(),
        vec![0.0, 0.0],
        -1.0,
        1.0,
        limits(-2.0, 1.0),
    );
    assert_eq!(branch.events.len(), 1);
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::Hopf);
    assert!(e.p.abs() <= 1e-8, "Hopf at p = {:e}", e.p);
    assert!(
        (e.eigenvalue.im - 1.0).abs() < 1e-7,
        "frequency {}",
        e.eigenvalue.im
    );
    assert_eq!((e.unstable_before, e.unstable_after), (0, 2));
}

#[test]
fn brusselator_hopf_at_b_equal_one_plus_a_squared() {
    let a = 2.0;
    let branch = run(
        &brusselator(a),
        vec![a, 1.0 / a],
        1.0,
        1.0,
        limits(0.0, 8.0),
    );
    assert_eq!(branch.events.len(), 1);
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::Hopf);
    let exact = 1.0 + a * a;
    assert!(
        (e.p - exact).abs() <= 1e-8 * exact,
        "Hopf at b = {} vs {exact}",
        e.p
    );
    assert!(
        (e.eigenvalue.im - a).abs() < 1e-6,
        "frequency {} vs {a}",
        e.eigenvalue.im
    );
    // The steady state is (a, b/a) at every point.
    for p in &branch.points {
        assert!((p.u[0] - a).abs() < 1e-9 && (p.u[1] - p.p / a).abs() < 1e-9);
    }
}

/// A problem that counts the stability evaluations asked of it: one per accepted point, one per
/// sample inside an event's bracket.
struct Counted<P> {
    inner: P,
    stability: std::cell::Cell<usize>,
}

impl<P: Problem> Problem for Counted<P> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn residual(&self, u: &[f64], p: f64) -> helixbif::Result<Vec<f64>> {
        self.inner.residual(u, p)
    }
    fn linearize(&self, u: &[f64], p: f64) -> helixbif::Result<helixbif::engine::Linearization> {
        self.inner.linearize(u, p)
    }
    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        lin: &helixbif::engine::Linearization,
    ) -> helixbif::Result<(faer::Mat<f64>, faer::Mat<f64>)> {
        self.stability.set(self.stability.get() + 1);
        self.inner.stability_pair(u, p, lin)
    }
}

/// The event search converges superlinearly on its test function (the real part of the
/// crossing eigenvalue, the parameter part of the tangent): from a step of 0.5 to a bracket
/// of 1e-10 relative, bisection alone would need about 32 samples per search
/// (log2(0.5 / 5e-10)); Brent's method needs a handful (at most 7 here). A fold costs two
/// searches (the tangent's turn, then the count change of its own real eigenvalue, which is
/// then recognized as the fold's). Each event is also located to the tolerance asked.
#[test]
fn events_are_pinned_down_in_a_few_samples_not_by_bisection() {
    let tight = ContinuationSettings {
        event_tol: 1e-10,
        ..settings()
    };
    type Case = (&'static str, usize, Vec<f64>, f64, f64, Limits, f64);
    let cases: Vec<(Case, _)> = vec![
        (
            (
                "hopf (Brusselator, a = 2)",
                1,
                vec![2.0, 0.5],
                1.0,
                1.0,
                limits(0.0, 8.0),
                5.0,
            ),
            brusselator(2.0),
        ),
        (
            (
                "branch point (pitchfork)",
                1,
                vec![0.0],
                -1.0,
                1.0,
                limits(-2.0, 1.0),
                0.0,
            ),
            pitchfork(0.0),
        ),
        (
            (
                "fold (imperfect pitchfork, eps = 0.01)",
                2,
                vec![-(2.0f64).sqrt()],
                2.0,
                -1.0,
                limits(-1.0, 3.0),
                3.0 * 0.005f64.powf(2.0 / 3.0),
            ),
            pitchfork(0.01),
        ),
    ];
    for ((name, searches, u0, p0, direction, l, exact), inner) in cases {
        let problem = Counted {
            inner,
            stability: std::cell::Cell::new(0),
        };
        let branch = follow(&problem, u0, p0, direction, &tight, &l, &mut Silent).unwrap();
        let e = branch.events.first().expect(name);
        assert!(
            (e.p - exact).abs() <= 1e-10 * exact.abs().max(1e-6),
            "{name}: at {} vs {exact}",
            e.p
        );
        let samples = problem.stability.get() - branch.points.len();
        assert!(samples <= 7 * searches, "{name}: {samples} samples");
    }
}

/// `u' = J(p) u` in two rotation blocks: the pair `p - 1 +- i (2 + 3p)`, which crosses the axis
/// at `p = 1` while its frequency grows fast, and the stable pair `-3 +- 11i`. Over a long step
/// from `p = 0` to `p = 3` the crossing eigenvalue at the far end (`2 + 11i`) lies nearer the
/// stable pair (distance 5) than its own value at the crossing (`5i`, distance 6.3): a search
/// that identified the crossing mode by its value at the first far end would read the stable
/// pair on the unstable side, see no sign change and fall back to bisection.
fn racing_pair() -> helixbif::engine::reference::Reference {
    let jacobian = |p: f64| {
        let (re, w) = (p - 1.0, 2.0 + 3.0 * p);
        vec![
            vec![re, -w, 0.0, 0.0],
            vec![w, re, 0.0, 0.0],
            vec![0.0, 0.0, -3.0, -11.0],
            vec![0.0, 0.0, 11.0, -3.0],
        ]
    };
    helixbif::engine::reference::Analytic {
        dim: 4,
        g: Box::new(move |u, p| {
            jacobian(p)
                .iter()
                .map(|row| row.iter().zip(u).map(|(a, b)| a * b).sum())
                .collect()
        }),
        g_u: Box::new(move |_, p| jacobian(p)),
        g_p: Box::new(|u, _| vec![u[0] + 3.0 * u[1], u[1] - 3.0 * u[0], 0.0, 0.0]),
    }
}

#[test]
fn a_crossing_mode_whose_frequency_races_is_still_pinned_down_by_the_secant() {
    let wide = ContinuationSettings {
        ds: 3.0,
        ds_max: 4.0,
        max_parameter_step: Some(1.0),
        event_tol: 1e-10,
        ..settings()
    };
    let problem = Counted {
        inner: racing_pair(),
        stability: std::cell::Cell::new(0),
    };
    let branch = follow(
        &problem,
        vec![0.0; 4],
        0.0,
        1.0,
        &wide,
        &limits(-1.0, 3.0),
        &mut Silent,
    )
    .unwrap();
    let e = branch.events.first().expect("the Hopf point");
    assert_eq!(e.kind, EventKind::Hopf);
    assert!((e.p - 1.0).abs() <= 1e-10, "Hopf at {}", e.p);
    assert!(
        (e.eigenvalue.im - 5.0).abs() < 1e-8,
        "frequency {}",
        e.eigenvalue.im
    );
    let samples = problem.stability.get() - branch.points.len();
    assert!(samples <= 6, "{samples} samples");
}

/// Two real eigenvalues `p - 1` and `p - 1 - 5e-9` cross the axis closer together than the
/// event tolerance can resolve (a double eigenvalue split by round-off): one branch point of
/// multiplicity two, whichever of them the search meets first.
#[test]
fn crossings_closer_than_the_tolerance_are_one_event_with_their_multiplicity() {
    let split = 5e-9;
    let jacobian = move |p: f64| vec![vec![p - 1.0, 0.0], vec![0.0, p - 1.0 - split]];
    let problem = helixbif::engine::reference::Analytic {
        dim: 2,
        g: Box::new(move |u: &[f64], p: f64| vec![(p - 1.0) * u[0], (p - 1.0 - split) * u[1]]),
        g_u: Box::new(move |_: &[f64], p: f64| jacobian(p)),
        g_p: Box::new(|u: &[f64], _: f64| vec![u[0], u[1]]),
    };
    let branch = follow(
        &problem,
        vec![0.0; 2],
        0.0,
        1.0,
        &settings(),
        &limits(-1.0, 3.0),
        &mut Silent,
    )
    .unwrap();
    assert_eq!(
        branch.events.len(),
        1,
        "{:?}",
        branch.events.iter().map(|e| e.p).collect::<Vec<_>>()
    );
    let e = &branch.events[0];
    assert_eq!(e.kind, EventKind::BranchPoint);
    assert_eq!(
        (e.multiplicity, e.unstable_before, e.unstable_after),
        (2, 0, 2)
    );
    assert!((e.p - 1.0).abs() <= 1e-8, "at {}", e.p);
}

/// A user event: the branch's `u` passes a level, placed by linear interpolation on the step
/// (enough for this test; the engine's own detectors sample corrected points).
struct LevelCrossing(f64);

impl Detector<Reference> for LevelCrossing {
    fn detect(&self, a: &Point, b: &Point) -> bool {
        (a.u[0] - self.0) * (b.u[0] - self.0) < 0.0
    }
    fn locate(
        &self,
        _problem: &Reference,
        a: &Point,
        b: &Point,
        _metric: &Metric,
        _settings: &ContinuationSettings,
    ) -> helixbif::Result<Vec<Event>> {
        let t = (self.0 - a.u[0]) / (b.u[0] - a.u[0]);
        Ok(vec![Event {
            kind: EventKind::User("level"),
            u: vec![self.0],
            p: a.p + t * (b.p - a.p),
            s: a.s + t * (b.s - a.s),
            eigenvalue: a.spectrum.leading[0],
            bracket: (a.p.min(b.p), a.p.max(b.p)),
            precision: 0.0,
            multiplicity: 1,
            unstable_before: a.spectrum.unstable,
            unstable_after: b.spectrum.unstable,
            spectrum: a.spectrum.clone(),
        }])
    }
}

/// A user stop rule: ends the run once the state passes `u = 0.5`.
struct PastHalf;

impl StopRule for PastHalf {
    fn step(
        &mut self,
        _before: &Point,
        after: &Point,
        _events: &[Event],
    ) -> ControlFlow<Stop<BranchStop>> {
        if after.u[0] > 0.5 {
            ControlFlow::Break(Stop::Own(BranchStop::Rule("u passed 0.5".into())))
        } else {
            ControlFlow::Continue(())
        }
    }
}

#[test]
fn the_run_is_an_iterator_of_typed_steps_that_takes_user_detectors_and_stop_rules() {
    // u^2 = p from (-1, 1) towards smaller p, around the fold at p = 0 and up the other side.
    let problem = fold();
    let s = settings();
    let l = limits(-1.0, 1.0);
    let mut run = Continuation::start(&problem, vec![-1.0], 1.0, -1.0, &s, &l).unwrap();
    let mut kinds = Vec::new();
    for outcome in run.by_ref().take(40) {
        if let Outcome::Accepted { events, .. } = outcome.unwrap() {
            kinds.extend(events.iter().map(|e| e.kind));
        }
    }
    // Forty steps pass the fold (p back above 0, on the u > 0 side).
    assert_eq!(kinds, vec![EventKind::Fold]);
    assert!(run.current().u[0] > 0.0 && run.current().p > 0.0);

    // The same run with a detector of its own and a stop rule of its own.
    let run = Continuation::start(&problem, vec![-1.0], 1.0, -1.0, &s, &l)
        .unwrap()
        .with_detector(Box::new(LevelCrossing(0.25)));
    let mut rule = PastHalf;
    let branch = follow_with(run, &mut [&mut rule], &mut Silent).unwrap();
    assert_eq!(
        branch.stop,
        Stop::Own(BranchStop::Rule("u passed 0.5".into()))
    );
    let names: Vec<&str> = branch.events.iter().map(|e| e.kind.name()).collect();
    assert_eq!(names, ["fold", "level"]);
    let level = &branch.events[1];
    // On u^2 = p the level u = 0.25 lies at p = 1/16, inside the step the detector saw and to
    // within the chord's interpolation error there: on the branch u = sqrt(p) (u > 0), the chord
    // from u_a to u_b misses the parabola by at most (u_b - u_a)^2 / 4 in p.
    let (p_a, p_b) = level.bracket;
    assert!(p_a <= 0.0625 && 0.0625 <= p_b, "{:?}", level.bracket);
    let chord = (p_b.sqrt() - p_a.sqrt()).powi(2) / 4.0;
    assert!((level.p - 0.0625).abs() <= chord, "{} vs {chord}", level.p);
    assert!(branch.points.last().unwrap().u[0] > 0.5);
    assert!(branch.points[branch.points.len() - 2].u[0] <= 0.5);
}

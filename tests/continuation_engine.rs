//! The continuation engine alone, on canonical problems with exact answers: the event kind is
//! right and its location error is below the tolerance asked.

use helixbif::continuation::arclength::{Limits, Silent, Stop, follow};
use helixbif::continuation::events::EventKind;
use helixbif::continuation::reference::{brusselator, fold, hopf_normal_form, pitchfork};
use helixbif::continuation::{ContinuationSettings, Problem};

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
) -> helixbif::continuation::arclength::Branch {
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

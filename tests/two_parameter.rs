//! Two-parameter continuation of Hopf points (`continuation::curve`) on problems with exact
//! curves: the Brusselator's Hopf curve, a double Hopf point where the first loss of stability
//! changes mode, and a curve that turns back in the second parameter.

use std::ops::ControlFlow;
use std::rc::Rc;

use helixbif::engine::arclength::{Branch, Limits, follow};
use helixbif::engine::criticality::Verdict;
use helixbif::engine::curve::{
    Curve, CurveEnd, CurvePoint, CurveSettings, Special, SpecialKind, follow_curve, others,
};
use helixbif::engine::event_curve::{EventPoint, follow_event_curve};
use helixbif::engine::events::EventKind;
use helixbif::engine::reference::{
    Members, OBLIQUE_BT, bautin, bogdanov_takens, bogdanov_takens_oblique, brusselator, cusp,
    double_hopf, hopf_circle, hopf_cubic_fold, hopf_line, shifted_pitchfork,
};
use helixbif::engine::stop::{Observer, Silent, Stop};
use helixbif::engine::{ContinuationSettings, Problem};

fn settings() -> ContinuationSettings {
    ContinuationSettings {
        event_tol: 1e-10,
        tol: 1e-12,
        ..ContinuationSettings::default()
    }
}

/// The branch of `problem` from `(u0, p0)` towards `p_end`, up to its first loss of stability.
fn to_first_loss(problem: &impl Problem, u0: Vec<f64>, p0: f64, p_end: f64) -> Branch {
    let limits = Limits {
        p_min: p0.min(p_end) - 1.0,
        p_max: p0.max(p_end),
        stop_at_first_instability: true,
    };
    let direction = (p_end - p0).signum();
    follow(
        problem,
        u0,
        p0,
        direction,
        &settings(),
        &limits,
        &mut Silent,
    )
    .unwrap()
}

/// The first Hopf point of `problem` on its branch from `(u0, p0)` towards `p_end`, located by
/// the one-parameter engine, as the start of a curve at `q`.
fn start(problem: &impl Problem, u0: Vec<f64>, p0: f64, p_end: f64, q: f64) -> CurvePoint {
    let branch = to_first_loss(problem, u0, p0, p_end);
    let event = branch
        .first_loss_of_stability()
        .expect("a Hopf point")
        .clone();
    CurvePoint::at_event(event, q)
}

#[test]
fn the_brusselator_hopf_curve_is_b_equals_one_plus_a_squared() {
    // Members in a, parameter b; steady state (a, b/a); Hopf at b = 1 + a^2, frequency a.
    let family = Members(brusselator);
    let a0 = 0.5;
    let first = start(&brusselator(a0), vec![a0, 1.0 / a0], 1.0, 3.0, a0);
    let (curve, _) = follow_curve(
        &family,
        first,
        Rc::new(brusselator(a0)),
        1.0,
        &CurveSettings::new(0.5, 3.0),
        &settings(),
        &mut Silent,
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::ParameterLimit);
    assert!(curve.points.len() >= 20, "{} points", curve.points.len());
    let end = curve.points.last().unwrap();
    assert!((end.q - 3.0).abs() <= 1e-14, "ends at a = {}", end.q);
    for point in &curve.points {
        let (a, b) = (point.q, point.p);
        let exact = 1.0 + a * a;
        assert!(
            (b - exact).abs() <= 1e-8 * exact,
            "a = {a}: b = {b}, exact {exact}"
        );
        assert!(
            (point.eigenvalue.im - a).abs() <= 1e-8 * a,
            "a = {a}: frequency {}, exact {a}",
            point.eigenvalue.im
        );
        assert!((point.u[0] - a).abs() <= 1e-9 && (point.u[1] - b / a).abs() <= 1e-9);
    }
    assert!(curve.special.is_empty(), "{:?}", curve.special);
    let worst = curve
        .points
        .iter()
        .map(|p| (p.p - 1.0 - p.q * p.q).abs() / (1.0 + p.q * p.q))
        .fold(0.0, f64::max);
    println!(
        "Brusselator: {} points, worst relative error of b {worst:e}",
        curve.points.len()
    );
}

/// Ends the curve at a double Hopf point past which the other mode is unstable (where the first
/// loss of stability switches curve), as the boundary driver does.
struct FirstLoss {
    found: Vec<Special>,
}

impl Observer<CurvePoint, Special> for FirstLoss {
    fn event(&mut self, special: &Special) -> ControlFlow<()> {
        self.found.push(special.clone());
        if special.kind == SpecialKind::DoubleHopf && special.gains {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

fn double_hopf_q() -> f64 {
    (5.2f64.sqrt() - 2.0) / 0.6
}

#[test]
fn a_double_hopf_point_is_located_and_the_first_loss_of_stability_moves_to_the_other_curve() {
    let family = Members(double_hopf);
    let settings_curve = CurveSettings::new(0.0, 1.0);
    let first = start(&double_hopf(0.0), vec![0.0; 4], -0.5, 2.0, 0.0);
    assert!((first.p - 0.0).abs() < 1e-9 && (first.eigenvalue.im - 1.0).abs() < 1e-9);
    let mut observer = FirstLoss { found: Vec::new() };
    let (curve, member): (Curve, _) = follow_curve(
        &family,
        first,
        Rc::new(double_hopf(0.0)),
        1.0,
        &settings_curve,
        &settings(),
        &mut observer,
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::Observer);
    // The first curve: p = q + 0.3 q^2, frequency 1, up to the double Hopf point.
    for point in &curve.points {
        let exact = point.q + 0.3 * point.q * point.q;
        assert!(
            (point.p - exact).abs() <= 1e-8,
            "q = {}: p = {}",
            point.q,
            point.p
        );
        assert!((point.eigenvalue.im - 1.0).abs() <= 1e-8);
    }
    let special = curve.special.last().unwrap();
    assert_eq!(special.kind, SpecialKind::DoubleHopf);
    assert!(special.gains);
    let q_star = double_hopf_q();
    let (q, p) = (special.point.q, special.point.p);
    println!(
        "double Hopf at q = {q} (error {:e}), p = {p} (error {:e}), {} points before it",
        q - q_star,
        p - (1.0 - q_star),
        curve.points.len()
    );
    assert!(
        (q - q_star).abs() <= 1e-6,
        "double Hopf at q = {q}, exact {q_star}"
    );
    assert!((p - (1.0 - q_star)).abs() <= 1e-6, "double Hopf at p = {p}");
    assert!(
        (special.other.im - 2.0).abs() <= 1e-6,
        "second frequency {}",
        special.other
    );

    // From there the first loss of stability is the second mode: p = 1 - q, frequency 2.
    let mut second = special.point.clone();
    second.eigenvalue = special.other;
    let (next, _) = follow_curve(
        &family,
        second,
        member,
        1.0,
        &settings_curve,
        &settings(),
        &mut Silent,
    )
    .unwrap();
    assert_eq!(next.stop, Stop::ParameterLimit);
    assert!(next.points.len() >= 5);
    for point in &next.points[1..] {
        assert!(
            (point.p - (1.0 - point.q)).abs() <= 1e-8,
            "q = {}: p = {}",
            point.q,
            point.p
        );
        assert!((point.eigenvalue.im - 2.0).abs() <= 1e-8);
        // Past the switch the first curve's mode is stable on this one.
        assert_eq!(
            others(&point.spectrum, point.eigenvalue).unstable,
            0,
            "q = {}",
            point.q
        );
    }
}

#[test]
fn a_curve_that_turns_back_in_q_is_passed_and_its_turning_point_located() {
    // The unit circle from (p, q) = (1, 0), q increasing: it turns back at (0, 1).
    let family = Members(hopf_circle);
    let first = start(&hopf_circle(0.0), vec![0.0; 2], 0.0, 2.0, 0.0);
    assert!((first.p - 1.0).abs() < 1e-9);
    let mut observer = FirstLoss { found: Vec::new() };
    let (curve, _) = follow_curve(
        &family,
        first,
        Rc::new(hopf_circle(0.0)),
        1.0,
        &CurveSettings::new(-0.5, 1.5),
        &settings(),
        &mut observer,
    )
    .unwrap();
    // Past the turning point the curve comes back down to q = -0.5 on the side p < 0.
    assert_eq!(curve.stop, Stop::ParameterLimit);
    let end = curve.points.last().unwrap();
    assert!(
        (end.q + 0.5).abs() <= 1e-14 && end.p < 0.0,
        "ends at {:?}",
        (end.p, end.q)
    );
    for point in &curve.points {
        let r = point.p.hypot(point.q);
        assert!(
            (r - 1.0).abs() <= 1e-8,
            "{:?} off the circle by {}",
            (point.p, point.q),
            r - 1.0
        );
    }
    let turning = of_kind(&curve, SpecialKind::Turning);
    assert_eq!(turning.len(), 1, "{:?}", curve.special);
    let t = &turning[0].point;
    println!("turning point at (p, q) = ({:e}, 1 {:+e})", t.p, t.q - 1.0);
    // q is stationary there: known to the event tolerance; p to its square root.
    assert!((t.q - 1.0).abs() <= 1e-9, "turning at q = {}", t.q);
    assert!(t.p.abs() <= 1e-4, "turning at p = {}", t.p);
}

/// A turning point passed inside one step is located in that step, whether the step lands past
/// it by more than the last point's distance (the chord's `q` part changes sign) or by less
/// (`q` comes back short of the last point's, the chord keeps its sign, and only the parabola
/// `q(p)` through the last points shows the turn); in the curve's first step (started 0.005
/// from the turning point in `p`, with no point before it: the start tangent gives the slope,
/// and a sample halfway along the step stands in for the point before) and in a later one
/// (started 0.1 from it). Two curves: the unit circle, symmetric about its turning point
/// `(0, 1)`, and `q = 1 - p^2 - p^3`, which is not, so that the parabola's vertex lies off the
/// turning point (a step that lands next to it must not report it twice, nor one that stops
/// short of it report it early). Constant steps of many lengths put the turning point at
/// different places within a step.
#[test]
fn a_turning_point_passed_inside_a_step_is_located_in_that_step_wherever_it_lands() {
    type Curve0 = fn(f64) -> helixbif::engine::reference::Reference;
    let circle: (&str, Curve0, fn(f64) -> f64) = ("circle", hopf_circle, |p| (1.0 - p * p).sqrt());
    let cubic: (&str, Curve0, fn(f64) -> f64) =
        ("cubic", hopf_cubic_fold, |p| 1.0 - p * p * (1.0 + p));
    let steps: Vec<f64> = (0..24).map(|k| 0.0055 * 1.09f64.powi(k)).collect();
    for (name, member, q_of) in [circle, cubic] {
        for p0 in [5e-3, 0.1] {
            let mut short = 0;
            for &ds in &steps {
                let q0 = q_of(p0);
                let first = start(&member(q0), vec![0.0; 2], 0.0, 2.0, q0);
                assert!((first.p - p0).abs() < 1e-9, "starts at p = {}", first.p);
                let settings_curve = CurveSettings {
                    ds,
                    ds_max: ds,
                    ..CurveSettings::new(0.9, 1.5)
                };
                let (curve, _) = follow_curve(
                    &Members(member),
                    first,
                    Rc::new(member(q0)),
                    1.0,
                    &settings_curve,
                    &settings(),
                    &mut Silent,
                )
                .unwrap();
                let case = format!("{name}, p0 = {p0}, ds = {ds:.5}");
                // The step that passes p = 0, and whether it lands short of the last point's q.
                let across = curve
                    .points
                    .windows(2)
                    .find(|w| w[0].p > 0.0 && w[1].p < 0.0)
                    .unwrap_or_else(|| panic!("{case}: no step passes p = 0"));
                let comes_back_short = across[1].q > across[0].q;
                short += usize::from(comes_back_short);
                let turning = of_kind(&curve, SpecialKind::Turning);
                assert_eq!(turning.len(), 1, "{case}: {:?}", curve.special);
                let t = &turning[0].point;
                println!(
                    "{case}: step from p = {:+.3e} to {:+.3e} (short {comes_back_short}), \
                     turning point at (p, q) = ({:+.2e}, 1 {:+.1e})",
                    across[0].p,
                    across[1].p,
                    t.p,
                    t.q - 1.0
                );
                assert!((t.q - 1.0).abs() <= 1e-9, "{case}: turning at q = {}", t.q);
                assert!(t.p.abs() <= 1e-4, "{case}: turning at p = {}", t.p);
                // Found in the step that passes it (a special point carries the arclength of
                // the point its step starts from), before the point past it is told.
                assert_eq!(t.s, across[0].s, "{case}: found in another step");
                assert_eq!(curve.stop, Stop::ParameterLimit, "{case}");
            }
            // Both kinds of landing occur.
            assert!(
                (2..steps.len() - 1).contains(&short),
                "{name}, p0 = {p0}: {short} of {} steps land short",
                steps.len()
            );
        }
    }
}

/// The step of [`circle_from_below`], and its largest.
const CIRCLE_STEP: f64 = 0.05;

/// The unit circle's Hopf curve followed from `q = 0.9` (`p > 0`) towards larger `q`, the range
/// `[0.9, q_max]`, at steps of [`CIRCLE_STEP`].
fn circle_from_below(q_max: f64) -> Curve {
    let q0 = 0.9;
    let first = start(&hopf_circle(q0), vec![0.0; 2], 0.0, 2.0, q0);
    let settings_curve = CurveSettings {
        ds: CIRCLE_STEP,
        ds_max: CIRCLE_STEP,
        ..CurveSettings::new(q0, q_max)
    };
    follow_curve(
        &Members(hopf_circle),
        first,
        Rc::new(hopf_circle(q0)),
        1.0,
        &settings_curve,
        &settings(),
        &mut Silent,
    )
    .unwrap()
    .0
}

/// A range that ends just past a turning point (the unit circle followed from `q = 0.9` up to
/// its top `q = 1`, the range ending at `q = 1.0002` to `1.002`, whose units of `q`, the range's
/// width, differ by 2%): the step onto the end finds no point there, and the curve is followed
/// through the turning point at the same step and back down to `q = 0.9`, in as many points
/// wherever the range ends (within two) and at most 30% more than the curve's arclength in
/// largest steps, the turning point located to `1e-9` and the curve ended at the range's lower
/// end. A range ending just short of the top (`0.998` to `0.9998`) ends there, on the circle,
/// with no turning point.
#[test]
fn a_range_ending_just_past_a_turning_point_costs_no_extra_steps() {
    let mut counts = Vec::new();
    for q_max in [1.0002, 1.0005, 1.001, 1.002] {
        let curve = circle_from_below(q_max);
        let turning = of_kind(&curve, SpecialKind::Turning);
        assert_eq!(turning.len(), 1, "q_max = {q_max}: {:?}", curve.special);
        assert!((turning[0].point.q - 1.0).abs() <= 1e-9, "q_max = {q_max}");
        assert_eq!(curve.stop, Stop::ParameterLimit, "q_max = {q_max}");
        let last = curve.points.last().unwrap();
        assert!(
            (last.q - 0.9).abs() < 1e-9 && last.p < 0.0,
            "q_max = {q_max}: ends at {last:?}"
        );
        // Most steps at the largest step: no more than 30% over the curve's arclength in
        // steps of `ds_max` (56 points over an arclength of 2.25 in steps of 0.05).
        let steps = last.s / CIRCLE_STEP;
        assert!(
            (curve.points.len() as f64) < 1.3 * steps + 2.0,
            "q_max = {q_max}: {} points over {steps:.1} largest steps",
            curve.points.len()
        );
        counts.push(curve.points.len());
    }
    println!("points {counts:?}");
    let (fewest, most) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
    assert!(most - fewest <= 2, "points {counts:?}");
    // A range ending just short of the top: the curve reaches its end and stops there, before
    // the turning point.
    for q_max in [0.998, 0.9995, 0.9998] {
        let curve = circle_from_below(q_max);
        assert_eq!(curve.stop, Stop::ParameterLimit, "q_max = {q_max}");
        assert!(
            of_kind(&curve, SpecialKind::Turning).is_empty(),
            "q_max = {q_max}"
        );
        let last = curve.points.last().unwrap();
        let p_end = (1.0 - q_max * q_max).sqrt();
        assert!(
            (last.q - q_max).abs() < 1e-9 && (last.p - p_end).abs() < 1e-6,
            "q_max = {q_max}: ends at {last:?}"
        );
    }
}

#[test]
fn a_hopf_curve_ends_at_its_bogdanov_takens_point() {
    // From q = -1 (Hopf at p = 0, frequency 1) towards q > 0: the pair meets at zero at q = 0.
    let family = Members(bogdanov_takens);
    let x0 = (1.0 - 0.2f64.sqrt()) / 2.0;
    // The stable equilibrium at p = 0.2, followed down in p to its Hopf point.
    let first = start(&bogdanov_takens(-1.0), vec![x0, 0.0], 0.2, -1.0, -1.0);
    assert!(first.p.abs() < 1e-9 && (first.eigenvalue.im - 1.0).abs() < 1e-9);
    let mut observer = FirstLoss { found: Vec::new() };
    let (curve, _) = follow_curve(
        &family,
        first,
        Rc::new(bogdanov_takens(-1.0)),
        1.0,
        &CurveSettings::new(-1.0, 0.5),
        &settings(),
        &mut observer,
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::Own(CurveEnd::BogdanovTakens));
    for point in &curve.points[..curve.points.len() - 1] {
        assert!(point.p.abs() <= 1e-8, "q = {}: p = {}", point.q, point.p);
        let w = (-point.q).sqrt();
        assert!(
            (point.eigenvalue.im - w).abs() <= 1e-8 * (1.0 + w),
            "q = {}",
            point.q
        );
    }
    let bt = curve.special.last().unwrap();
    assert_eq!(bt.kind, SpecialKind::BogdanovTakens);
    println!(
        "Bogdanov-Takens at (p, q) = ({:e}, {:e}), stated precision {:e}, {} points before it",
        bt.point.p,
        bt.point.q,
        bt.precision,
        curve.points.len() - 1
    );
    assert!(bt.point.q.abs() <= 1e-6 && bt.point.p.abs() <= 1e-6);
    // The error lies within the stated precision (a distance along the curve, q's unit 1.5).
    assert!(bt.point.q.abs() <= 1.5 * bt.precision + 1e-12);
    assert_eq!(observer.found.len(), 1);
}

/// The first loss of stability of `problem` from `(u0, p0)` with `p` increasing, as the start
/// of an event curve at `q`.
fn start_event(problem: &impl Problem, u0: Vec<f64>, p0: f64, q: f64) -> EventPoint {
    let branch = to_first_loss(problem, u0, p0, p0 + 10.0);
    let event = branch.first_loss_of_stability().unwrap().clone();
    let before = branch.point_before(&event);
    EventPoint {
        q,
        lead: (before.u.clone(), before.p),
        event,
        iterations: 0,
    }
}

#[test]
fn the_fold_curve_of_the_cusp_is_p_equals_two_thirds_q_to_the_three_halves() {
    // From q = 1 (fold at p = 2 (1/3)^(3/2)) to q = 3, on the branch from u = -2.
    let first = start_event(&cusp(1.0), vec![-2.0], -6.0, 1.0);
    assert_eq!(first.event.kind, EventKind::Fold);
    let curve = follow_event_curve(
        &Members(cusp),
        first,
        Rc::new(cusp(1.0)),
        1.0,
        1.0,
        &CurveSettings::new(1.0, 3.0),
        &settings(),
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::ParameterLimit);
    assert!(curve.points.len() >= 10, "{} points", curve.points.len());
    assert!((curve.points.last().unwrap().q - 3.0).abs() < 1e-15);
    let mut worst: f64 = 0.0;
    for point in &curve.points {
        let exact = 2.0 * (point.q / 3.0).powf(1.5);
        worst = worst.max((point.event.p - exact).abs() / exact);
        assert_eq!(point.event.kind, EventKind::Fold);
        assert!(
            (point.event.u[0] + (point.q / 3.0).sqrt()).abs() < 1e-4,
            "u at q = {}",
            point.q
        );
    }
    println!(
        "cusp: {} fold points, worst relative error of p {worst:e}",
        curve.points.len()
    );
    assert!(worst <= 1e-8, "{worst}");
}

#[test]
fn the_branch_point_curve_of_the_shifted_pitchfork_is_p_equals_q() {
    let first = start_event(&shifted_pitchfork(0.0), vec![0.0], -1.0, 0.0);
    assert_eq!(first.event.kind, EventKind::BranchPoint);
    let curve = follow_event_curve(
        &Members(shifted_pitchfork),
        first,
        Rc::new(shifted_pitchfork(0.0)),
        1.0,
        1.0,
        &CurveSettings::new(0.0, 1.0),
        &settings(),
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::ParameterLimit);
    for point in &curve.points {
        assert_eq!(point.event.kind, EventKind::BranchPoint);
        assert!(
            (point.event.p - point.q).abs() <= 1e-8,
            "q = {}: p = {}",
            point.q,
            point.event.p
        );
    }
    assert!(curve.points.len() >= 10);
}

/// The special points of `curve` of one kind.
fn of_kind(curve: &Curve, kind: SpecialKind) -> Vec<&Special> {
    curve.special.iter().filter(|s| s.kind == kind).collect()
}

/// The Hopf curve `p = 0` of the Bautin normal form with cubic coefficient `c(q)`, followed
/// over `q` in `[-1, 1]` with the Lyapunov coefficient at every point.
fn bautin_curve(c: impl Fn(f64) -> f64 + Copy + 'static) -> Curve {
    let family = Members(move |q| bautin(c(q)));
    let mut curve_settings = CurveSettings::new(-1.0, 1.0);
    curve_settings.criticality = true;
    let first = start(&bautin(c(-1.0)), vec![0.0, 0.0], -0.5, 0.5, -1.0);
    let (curve, _) = follow_curve(
        &family,
        first,
        Rc::new(bautin(c(-1.0))),
        1.0,
        &curve_settings,
        &settings(),
        &mut Silent,
    )
    .unwrap();
    curve
}

#[test]
fn a_generalized_hopf_point_is_located_where_the_lyapunov_coefficient_changes_sign() {
    // Bautin normal form with cubic coefficient c(q) = q + 0.5 q^2 - 0.3: the Hopf curve is
    // p = 0, l1 = 2 c(q), zero at q* = sqrt(1.6) - 1.
    let c = |q: f64| q + 0.5 * q * q - 0.3;
    let curve = bautin_curve(c);
    assert_eq!(curve.stop, Stop::ParameterLimit);
    for point in &curve.points {
        let l = point
            .lyapunov
            .as_ref()
            .expect("every point has its coefficient");
        let exact = 2.0 * c(point.q);
        assert!(
            (l.l1 - exact).abs() <= 1e-6 * exact.abs().max(1e-3),
            "q = {}: l1 {} against {exact}",
            point.q,
            l.l1
        );
    }
    let gh = of_kind(&curve, SpecialKind::GeneralizedHopf);
    assert_eq!(gh.len(), 1, "{:?}", curve.special);
    let exact = 1.6f64.sqrt() - 1.0;
    let error = (gh[0].point.q - exact).abs();
    println!(
        "generalized Hopf point at q = {} (error {error:e})",
        gh[0].point.q
    );
    assert!(error <= 1e-6, "at q = {}, exact {exact}", gh[0].point.q);
    assert!(gh[0].point.p.abs() <= 1e-9);
}

#[test]
fn a_steep_hopf_curve_takes_its_first_step_along_the_gradient_of_the_test_function() {
    // Re s = p - c q: the Hopf curve p = c q, of slope c in the curve's units at its start at the
    // origin (dp / max(|p|, 1) against dq / 1). Along q the first step would find the curve
    // c steps off its line.
    for c in [5.0, 50.0] {
        let family = Members(move |q| hopf_line(c, q));
        let first = start(&hopf_line(c, 0.0), vec![0.0; 2], -0.5, 2.0, 0.0);
        assert!(
            first.p.abs() < 1e-9,
            "slope {c}: Hopf point at p = {}",
            first.p
        );
        let (curve, _) = follow_curve(
            &family,
            first,
            Rc::new(hopf_line(c, 0.0)),
            1.0,
            &CurveSettings::new(0.0, 1.0),
            &settings(),
            &mut Silent,
        )
        .unwrap();
        println!(
            "slope {c}: {} points, stop {:?}, second point at {:?}",
            curve.points.len(),
            curve.stop,
            curve.points.get(1).map(|p| (p.p, p.q))
        );
        assert_eq!(curve.stop, Stop::ParameterLimit, "slope {c}");
        assert!((curve.points.last().unwrap().q - 1.0).abs() <= 1e-14);
        for point in &curve.points {
            let exact = c * point.q;
            assert!(
                (point.p - exact).abs() <= 1e-8 * exact.abs().max(1.0),
                "slope {c}: q = {}: p = {}, exact {exact}",
                point.q,
                point.p
            );
            assert!((point.eigenvalue.im - 1.0).abs() <= 1e-8);
        }
        // The first step went along the curve: its point is on it, ahead of the start in q.
        assert!(curve.points[1].q > 0.0);
    }
}

#[test]
fn an_obliquely_approached_bogdanov_takens_point_is_located_with_its_own_state_and_no_l1() {
    // The curve p = 0.5 + 2 dq + dq^2/2 (dq = q - 0.3), state (q/2, 0), frequency
    // sqrt(-(dq + 0.3 (p - 0.5))), from q = -0.7 towards its Bogdanov-Takens point (0.5, 0.3).
    let (p_bt, q_bt) = OBLIQUE_BT;
    let hopf_p = |q: f64| {
        let dq = q - q_bt;
        p_bt + 2.0 * dq + 0.5 * dq * dq
    };
    let q0 = -0.7;
    let p0 = hopf_p(q0);
    // The stable equilibrium a little above the Hopf point, followed down in p to it.
    let (b1, b2) = (0.3, (q0 - q_bt) + 0.3 * (p0 + 0.3 - p_bt));
    let e0 = (-b2 - (b2 * b2 - 4.0 * b1).sqrt()) / 2.0;
    let family = Members(bogdanov_takens_oblique);
    let first = start(
        &bogdanov_takens_oblique(q0),
        vec![0.5 * q0 + e0, 0.0],
        p0 + 0.3,
        p0 - 1.0,
        q0,
    );
    assert!((first.p - p0).abs() < 1e-9, "Hopf point at p = {}", first.p);
    let mut curve_settings = CurveSettings::new(q0, 0.8);
    curve_settings.criticality = true;
    let mut observer = FirstLoss { found: Vec::new() };
    let (curve, _) = follow_curve(
        &family,
        first,
        Rc::new(bogdanov_takens_oblique(q0)),
        1.0,
        &curve_settings,
        &settings(),
        &mut observer,
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::Own(CurveEnd::BogdanovTakens));
    let n = curve.points.len();
    for point in &curve.points[..n - 1] {
        let dq = point.q - q_bt;
        assert!(
            (point.p - hopf_p(point.q)).abs() <= 1e-8,
            "q = {}: p = {}",
            point.q,
            point.p
        );
        let w = (-(dq + 0.3 * (point.p - p_bt))).sqrt();
        assert!((point.eigenvalue.im - w).abs() <= 1e-7, "q = {}", point.q);
    }
    let bt = curve.special.last().unwrap();
    assert_eq!(bt.kind, SpecialKind::BogdanovTakens);
    let point = &bt.point;
    let (ep, eq) = (point.p - p_bt, point.q - q_bt);
    println!(
        "oblique Bogdanov-Takens at (p, q) = ({}, {}): errors ({ep:e}, {eq:e}), stated precision \
         {:e}, state {:?}, eigenvalue {}, l1 {:?}, {} points before it",
        point.p,
        point.q,
        bt.precision,
        point.u,
        point.eigenvalue,
        point.lyapunov.as_ref().map(|l| l.l1),
        n - 1
    );
    // Located to the event tolerance (1e-10 in the units of (2)), within ten times it.
    assert!(
        ep.abs() <= 1e-9 && eq.abs() <= 1e-9,
        "errors {ep:e}, {eq:e}"
    );
    // The error lies within the stated precision (a distance along the curve in the units of
    // (2): q's unit 1.5, p's 1, the curve's slope 2 in p against q).
    assert!(
        eq.abs() <= 1.5 * bt.precision + 1e-12,
        "{eq:e} against {:e}",
        bt.precision
    );
    // Its own state: the equilibrium (q/2, 0) of the member there, a double zero eigenvalue.
    assert!(
        (point.u[0] - 0.5 * point.q).abs() <= 1e-9 && point.u[1].abs() <= 1e-12,
        "state {:?} at q = {}",
        point.u,
        point.q
    );
    let residual = bogdanov_takens_oblique(point.q)
        .residual(&point.u, point.p)
        .unwrap();
    // The residual is that of the exact state at a point off by the location error (`b1`,
    // of slope 1 in p): within ten times the event tolerance.
    assert!(
        residual.iter().all(|r| r.abs() <= 1e-9),
        "residual {residual:?}"
    );
    assert!(
        point.eigenvalue.norm() <= 1e-3,
        "eigenvalue {}",
        point.eigenvalue
    );
    // No Lyapunov coefficient: it has no meaning where the frequency vanishes.
    assert!(point.lyapunov.is_none(), "{:?}", point.lyapunov);
    assert_eq!(observer.found.len(), 1);
}

/// A sign change of `l1` through points where it is not resolved (its precision larger than its
/// value) is a generalized Hopf point all the same: with the cubic coefficient `c(q) = k (q -
/// 0.3)^3`, `k = 1e-7`, the point at `q = 0.29` is `undetermined` between a supercritical one at
/// 0.19 and a subcritical one at 0.39, and the zero (where `|l1|` falls within its precision
/// over `|q - 0.3| < 0.04`) is located within its stated precision, which reaches to the
/// nearest samples of resolved sign on either side.
#[test]
fn a_generalized_hopf_point_is_located_across_a_point_of_unresolved_sign() {
    let c = |q: f64| 1e-7 * (q - 0.3).powi(3);
    let curve = bautin_curve(c);
    let verdict = |q: f64| {
        curve
            .points
            .iter()
            .find(|p| (p.q - q).abs() < 1e-6)
            .and_then(|p| p.lyapunov.as_ref())
            .map(|l| l.verdict)
    };
    // The situation the test is about (the steps of the curve put points there).
    assert_eq!(verdict(0.19), Some(Verdict::Supercritical));
    assert_eq!(verdict(0.29), Some(Verdict::Undetermined));
    assert_eq!(verdict(0.39), Some(Verdict::Subcritical));
    let gh = of_kind(&curve, SpecialKind::GeneralizedHopf);
    assert_eq!(gh.len(), 1, "{:?}", curve.special);
    // Where |l1| is within its precision (|q - 0.3| < 0.04), and within the stated precision
    // (along the curve, in units of the range of q, 2, on this curve p = 0).
    let (q, precision) = (gh[0].point.q, 2.0 * gh[0].precision);
    assert!(
        (q - 0.3).abs() < 0.04 && (q - 0.3).abs() <= precision,
        "at q = {q} +- {precision:e}, exact 0.3"
    );
}

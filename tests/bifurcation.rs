//! Continuation of the rod: Greenhill's column, agreement with `solve`, convergence of `omega_b`
//! for the representative helix, and a branch followed around two folds.

use crate::common;

use common::straight_rod;
use helixbif::analysis::branch::{observables_at, trace};
use helixbif::analysis::locate::{LocateSettings, hopf_criticality, hopf_criticality_from, locate};
use helixbif::analysis::solve::rest_state;
use helixbif::analysis::solve::solve_at;
use helixbif::engine::ContinuationSettings;
use helixbif::engine::arclength::{BranchStop, Limits, follow};
use helixbif::engine::criticality::Verdict;
use helixbif::engine::events::EventKind;
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stop::{Silent, Stop};
use helixbif::model::Model;
use helixbif::model::params::{Handedness, Physical, ShapeParams};
use helixbif::numerics::extrapolation::extrapolate;
use helixbif::problem::rod::{Parameter, RodProblem};
use helixbif::study::branch::branch_report;
use helixbif::study::output::Provenance;

/// Greenhill's column: a straight rod clamped at the bottom, standing up, buckling under its
/// own weight at `q L^3 / EI = 7.8373` (continuum).
fn greenhill(nodes: usize) -> f64 {
    let physical = straight_rod(1.0, 1e-3, 180.0, nodes);
    let model = Model::new(&physical).unwrap();
    let problem = RodProblem::new(
        &model,
        Parameter::Weight,
        helixbif::problem::rod::WEIGHT_SCALE,
    );
    let u0 = problem.steady(0.0).free_vector(&model.natural_config());
    let settings = ContinuationSettings {
        ds: 1.0,
        ..ContinuationSettings::default()
    };
    let limits = Limits {
        p_min: -1.0,
        p_max: 20.0,
        stop_at_first_instability: true,
    };
    let branch = follow(&problem, u0, 0.0, 1.0, &settings, &limits, &mut Silent).unwrap();
    assert_eq!(branch.stop, Stop::Own(BranchStop::FirstInstability));
    let event = branch.events.last().unwrap();
    assert_eq!(event.kind, EventKind::BranchPoint);
    // The two bending planes of the round rod buckle together.
    assert_eq!(event.multiplicity, 2);
    event.p
}

#[test]
fn greenhill_column_buckles_under_its_own_weight() {
    let exact = 7.8373;
    let nodes = [20, 40, 80];
    let q: Vec<f64> = nodes.iter().map(|&n| greenhill(n)).collect();
    println!("Greenhill q L^3/EI at N = {nodes:?}: {q:?}");
    let errors: Vec<f64> = q.iter().map(|v| (v - exact).abs()).collect();
    // First order in 1/N: the error halves as N doubles (the clamped first edge).
    for w in errors.windows(2) {
        let ratio = w[0] / w[1];
        assert!(
            ratio > 1.6 && ratio < 2.6,
            "error ratio {ratio}: {errors:?}"
        );
    }
    let extrapolated = extrapolate(&nodes, &q).unwrap();
    println!("known orders: {extrapolated:?}");
    assert!(
        (extrapolated.value - exact).abs() < 2e-3 * exact,
        "{extrapolated:?}"
    );
}

#[test]
fn branch_points_agree_with_solve() {
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = 30;
    let model = Model::new(&physical).unwrap();
    let newton = NewtonSettings::default();
    let rest = rest_state(&model, &newton).unwrap();
    let branch = trace(
        &model,
        &rest,
        150.0,
        &ContinuationSettings::default(),
        false,
        &mut Silent,
    )
    .unwrap();
    let checked = agree_with_solve(&model, &rest, branch.points.iter().skip(1).step_by(2));
    assert!(checked >= 3);
}

/// Checks that the observables (thrust, torque, height) of each branch point agree with an
/// independent ramped Newton solve at its rate to 1e-8 relative; returns how many were checked.
fn agree_with_solve<'a>(
    model: &Model,
    rest: &helixbif::problem::steady::SteadyState,
    points: impl Iterator<Item = &'a helixbif::engine::arclength::Point>,
) -> usize {
    let mut checked = 0;
    for point in points {
        let from_branch = observables_at(model, rest, &point.u, point.p).unwrap();
        let solved = solve_at(model, point.p, &NewtonSettings::default())
            .unwrap()
            .observables;
        for (a, b) in [
            (from_branch.fp, solved.fp),
            (from_branch.tp, solved.tp),
            (from_branch.hbar, solved.hbar),
            (from_branch.h, solved.h),
        ] {
            assert!(
                (a - b).abs() <= 1e-8 * b.abs(),
                "omegabar {}: {a} vs {b}",
                point.p
            );
        }
        checked += 1;
    }
    checked
}

#[test]
fn omega_b_does_not_depend_on_the_continuation_steps_and_sits_on_the_axis() {
    // A neighbour of the representative helix whose spectrum has two complex pairs close to
    // each other near omega_b: the located event must not depend on the step size, and the
    // critical eigenvalue must lie on the imaginary axis.
    let study = helixbif::study::Study::load(
        None,
        &["rod.E=1004000".into(), "discretization.nodes=61".into()],
    )
    .unwrap();
    let model = Model::new(&study.physical()).unwrap();
    let newton = NewtonSettings::default();
    let mut results = Vec::new();
    for ds_max in [4.0, 1.0] {
        let settings = ContinuationSettings {
            ds_max,
            ..ContinuationSettings::default()
        };
        let (located, event) = locate(
            &model,
            &LocateSettings {
                omega_max: 2.0,
                newton: &newton,
                continuation: &settings,
                criticality: true,
            },
            &mut Silent,
        )
        .unwrap();
        let event = event.unwrap().event;
        assert!(
            event.eigenvalue.re.abs() < 1e-5 * event.eigenvalue.norm(),
            "critical eigenvalue {} off the axis",
            event.eigenvalue
        );
        results.push(located.omega_b.unwrap());
    }
    assert!(
        (results[0] - results[1]).abs() < 1e-7 * results[0],
        "{results:?}"
    );
}

#[test]
fn omega_b_of_the_representative_helix_converges_in_n() {
    let newton = NewtonSettings::default();
    let settings = ContinuationSettings::default();
    let mut results = Vec::new();
    let mut coefficients = Vec::new();
    for nodes in [30, 40, 60, 80] {
        let mut physical = Physical::representative_lighthill();
        physical.discretization.nodes = nodes;
        let model = Model::new(&physical).unwrap();
        let (located, event) = locate(
            &model,
            &LocateSettings {
                omega_max: 2.0,
                newton: &newton,
                continuation: &settings,
                criticality: true,
            },
            &mut Silent,
        )
        .unwrap();
        let event = event.expect("an instability below 2 rad/s").event;
        assert_eq!(located.kind.name(), "hopf");
        assert!(located.precision.unwrap() <= 1e-8);
        // The critical mode oscillates in the co-rotating frame near the rotation rate.
        let im = located.im.unwrap();
        let omega_b = located.omega_b.unwrap();
        assert!(
            im > 0.5 * omega_b && im < 1.5 * omega_b,
            "Im(s) {im} vs omega_b {omega_b}"
        );
        assert_eq!(event.unstable_before, 0);
        results.push(omega_b);
        // The first Lyapunov coefficient is resolved (docs/model.md section 12).
        let (l1, dl1) = (located.l1.unwrap(), located.l1_precision.unwrap());
        assert!(dl1 < 1e-3 * l1.abs(), "N = {nodes}: l1 {l1} +- {dl1}");
        assert_ne!(located.criticality, Some(Verdict::Undetermined));
        coefficients.push(l1);
    }
    println!("omega_b at N = 30, 40, 60, 80: {results:?}");
    println!("l1 at N = 30, 40, 60, 80: {coefficients:?}");
    // The side of the Hopf point does not depend on the resolution.
    assert!(
        coefficients
            .iter()
            .all(|l| l.signum() == coefficients[0].signum()),
        "{coefficients:?}"
    );
    // The observed order over N = 40, 60, 80 in the helix angle per edge
    // dphi = 2 pi l/(lambda (N - 1)), against the dphi^2 law of docs/model.md section 10 (the
    // Lighthill point sums add a first-order part, so 2 +- 0.5): the root in p of
    // (w40 - w60)/(w60 - w80) = (h40^p - h60^p)/(h60^p - h80^p), by bisection.
    let h = |n: f64| 2.0 * std::f64::consts::PI * 4.0 / (n - 1.0);
    let ratio = (results[1] - results[2]) / (results[2] - results[3]);
    let f =
        |p: f64| (h(40.0).powf(p) - h(60.0).powf(p)) / (h(60.0).powf(p) - h(80.0).powf(p)) - ratio;
    let (mut lo, mut hi) = (0.1, 6.0);
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if f(lo) * f(mid) <= 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    println!("observed order {lo:.3}");
    assert!((lo - 2.0).abs() < 0.5, "observed order {lo}");
    // Regression: the value at N = 60 (Lighthill's operator; docs/implementation.md), which an
    // independent implementation of the same model reproduced to 7 digits.
    assert!(
        (results[2] / 0.522_184_200_7 - 1.0).abs() < 1e-8,
        "omega_b at N = 60 moved: {}",
        results[2]
    );
}

#[test]
fn a_branch_with_two_folds_is_followed_around_both() {
    // The representative helix turned the other way (left-handed at omega > 0): the branch
    // folds back at omega ~ 0.26 rad/s and forward again at ~ 0.12 rad/s (an S-shaped curve).
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = 40;
    if let ShapeParams::Helix { handedness, .. } = &mut physical.shape {
        *handedness = Handedness::Left;
    }
    let model = Model::new(&physical).unwrap();
    let rest = rest_state(&model, &NewtonSettings::default()).unwrap();
    let omegabar_max = model.scales.omega_to_bar(0.6);
    let branch = trace(
        &model,
        &rest,
        omegabar_max,
        &ContinuationSettings::default(),
        false,
        &mut Silent,
    )
    .unwrap();
    let folds: Vec<_> = branch
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Fold)
        .collect();
    // Past the S the branch (followed with the chart of the twist angles moved along it) folds
    // twice more near 0.29 rad/s, then stops where two turns come within 3.5 delta of each other
    // and the Lighthill operator loses positivity: the S is the first two folds.
    assert!(
        folds.len() >= 2,
        "{:?}",
        branch
            .events
            .iter()
            .map(|e| (e.kind, e.p))
            .collect::<Vec<_>>()
    );
    let (upper, lower) = (folds[0].p, folds[1].p);
    assert!(upper > lower);
    // Each fold is a turning point: the branch before the first fold stays below it, and the
    // part between the folds stays above the second.
    let max_before_lower = branch
        .points
        .iter()
        .take_while(|q| q.tangent_p > 0.0)
        .map(|q| q.p)
        .fold(f64::MIN, f64::max);
    assert!(
        max_before_lower <= upper * (1.0 + 1e-9),
        "{max_before_lower} vs fold {upper}"
    );
    let min_between = branch
        .points
        .iter()
        .skip_while(|q| q.tangent_p > 0.0)
        .take_while(|q| q.tangent_p < 0.0)
        .map(|q| q.p)
        .fold(f64::MAX, f64::min);
    assert!(
        min_between >= lower * (1.0 - 1e-9),
        "{min_between} vs fold {lower}"
    );
    // After the second fold the branch goes up in omega again.
    let last = branch.points.last().unwrap();
    assert!(last.tangent_p > 0.0 && last.p > lower);
    println!(
        "folds at omega = {:.8} and {:.8} rad/s",
        model.scales.omega_from_bar(upper),
        model.scales.omega_from_bar(lower)
    );
}

#[test]
fn axis_clamp_against_the_helix_clamp_on_the_representative_helix() {
    // docs/model.md section 8: the lab clamp (first edge on the axis, radial connector) against the
    // reference clamp (the helix's own end). Both lose stability at a Hopf point; the connector
    // lets the helix's top swing about the axis, which lowers omega_b by a few percent.
    let omega_b = |clamp: &str| {
        let study = helixbif::study::Study::load(
            None,
            &[
                "fluid.model=lighthill".into(),
                format!("shape.clamp={clamp}"),
            ],
        )
        .unwrap();
        let model = Model::new(&study.physical()).unwrap();
        let (located, _) = locate(
            &model,
            &LocateSettings {
                omega_max: 2.0,
                newton: &NewtonSettings::default(),
                continuation: &ContinuationSettings::default(),
                criticality: true,
            },
            &mut Silent,
        )
        .unwrap();
        assert_eq!(located.kind.name(), "hopf");
        located.omega_b.unwrap()
    };
    let (own, axis) = (omega_b("helix"), omega_b("axis"));
    println!("omega_b at N = 60: helix clamp {own:.8} rad/s, axis clamp {axis:.8} rad/s");
    // A clamp that lets the helix's top swing is a softer support, and softening a structure
    // lowers its critical load (Rayleigh's principle): the axis clamp buckles first.
    assert!(axis < own, "{own} vs {axis}");
    // Regression pins of both, to the precision located.
    assert!((own / 0.522_184_200_7 - 1.0).abs() < 1e-8, "{own}");
    assert!((axis / 0.496_069_272 - 1.0).abs() < 1e-8, "{axis}");
}

#[test]
fn the_tight_arc_is_followed_past_the_edge_that_turns_against_its_natural_tangent() {
    // fig2's R/L = 0.29 arc curls up as it turns: near 0.947 rad/s an edge points against its
    // natural tangent, where the transport of reference frames from the natural chart is
    // singular (the continuation used to stall there, on either fluid). With the chart moved
    // along the branch it is followed to 2 rad/s on Lighthill (N = 22) and to 3.5 rad/s on the
    // RPY line (N = 40), and its points agree with independent ramped Newton solves (whose
    // chart is carried solve to solve).
    follow_the_tight_arc(&[], 2.0, 3);
    follow_the_tight_arc(&["fluid.model=\"rpy\"", "discretization.nodes=40"], 3.5, 3);
}

/// The tight arc of fig2 with `overrides`, traced to `omega_max` (rad/s): it gets there, past an
/// edge turned against its natural tangent, and every `every`-th point beyond 1 rad/s agrees
/// with `solve_at` to 1e-8.
fn follow_the_tight_arc(overrides: &[&str], omega_max: f64, every: usize) {
    let mut set: Vec<String> = vec!["shape={kind=\"arc\",L=0.12,R=0.0348}".into()];
    set.extend(overrides.iter().map(|s| s.to_string()));
    let study = helixbif::study::Study::from_path(
        Some(std::path::Path::new(
            "studies/fig2_straight_and_curved.toml",
        )),
        &set,
    )
    .unwrap();
    let model = Model::new(&study.physical()).unwrap();
    let newton = NewtonSettings::default();
    let rest = rest_state(&model, &newton).unwrap();
    let omegabar_max = model.scales.omega_to_bar(omega_max);
    let branch = trace(
        &model,
        &rest,
        omegabar_max,
        &ContinuationSettings::default(),
        false,
        &mut Silent,
    )
    .unwrap();
    assert!(
        matches!(branch.stop, Stop::ParameterLimit),
        "{overrides:?}: {:?}",
        branch.stop
    );
    // The rod did pass the singular set of the natural chart.
    let natural: Vec<_> = model
        .natural
        .windows(2)
        .map(|e| (e[1] - e[0]).normalize())
        .collect();
    let steady = helixbif::model::steady::Steady::new(&model, 0.0);
    let most_turned = branch
        .points
        .iter()
        .flat_map(|p| {
            let x = steady.config(&p.u).x;
            let edges: Vec<_> = x.windows(2).map(|e| (e[1] - e[0]).normalize()).collect();
            edges
                .iter()
                .zip(&natural)
                .map(|(a, b)| a.dot(b))
                .collect::<Vec<_>>()
        })
        .fold(1.0, f64::min);
    assert!(most_turned < -0.99, "{most_turned}");
    let past = branch
        .points
        .iter()
        .filter(|p| model.scales.omega_from_bar(p.p) > 1.0)
        .step_by(every);
    let checked = agree_with_solve(&model, &rest, past);
    assert!(checked >= 2, "{overrides:?}: {checked}");
}

/// `studies/exponent_m.toml` on the RPY line at 15 nodes per turn, at `lambda/l` and
/// `R/lambda`, with the `extra` overrides.
fn exponent_m_rod(
    lambda_over_l: f64,
    r_over_lambda: f64,
    extra: &[&str],
) -> helixbif::study::Study {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/studies/exponent_m.toml");
    let mut overrides = vec![
        "fluid.model=rpy".to_string(),
        "discretization.per_turn=15".to_string(),
        format!("shape.lambda_over_l={lambda_over_l}"),
        format!("shape.R_over_lambda={r_over_lambda}"),
    ];
    overrides.extend(extra.iter().map(|s| s.to_string()));
    helixbif::study::Study::from_path(Some(path.as_ref()), &overrides).unwrap()
}

/// `exponent_m.toml`'s `lambda/l = 0.25` rod on the RPY line (15 nodes per turn, `N = 61`) at
/// `R/lambda = 0.3725`, followed from rest up to 30 rad/s: a mode rises through the axis at
/// 0.01452 rad/s and falls back at 0.01528, a window of instability about 5% wide that lies
/// inside one step of the continuation (which stops at the next mode's loss, 0.01732). The probe
/// of that step's near miss must find the window inside the step it names, and its loss must be
/// the first loss of stability that an independent continuation finds with short steps (up to
/// 0.018 rad/s in steps of at most 0.0005 rad/s, against the 0.0038 rad/s of the step that holds
/// the window), to `1e-7` relative, with the same critical frequency; the short
/// steps' regain of stability must lie inside that step too.
#[test]
fn a_window_of_instability_inside_one_step_is_found_by_probing_its_near_miss() {
    let study = exponent_m_rod(0.25, 0.3725, &[]);
    let model = Model::new(&study.physical()).unwrap();
    assert_eq!(model.nodes(), 61);
    let settings = |omega_max: f64| LocateSettings {
        omega_max,
        newton: &study.newton,
        continuation: &study.continuation,
        criticality: false,
    };
    let (located, critical) = locate(&model, &settings(30.0), &mut Silent).unwrap();
    let [below, above] = located
        .window_between
        .expect("the window inside the step is found");
    let omega_b = located.omega_b.unwrap();
    assert!(
        below < omega_b && omega_b < above,
        "{omega_b} outside the step [{below}, {above}]"
    );
    assert!(located.near_miss_unresolved.is_none());
    assert_eq!(located.kind.name(), "hopf");
    assert!(critical.unwrap().event.eigenvalue.re.abs() < 1e-6);

    // Cut short after the step that holds the window (14 points, to 0.01678 rad/s, below the
    // next loss), the branch has no event and `locate` answers the window all the same; cut
    // short before that step (12 points, to 0.01192 rad/s) it fails, saying why.
    let cut = |points: usize| {
        let continuation = ContinuationSettings {
            max_points: points,
            ..study.continuation.clone()
        };
        let settings = LocateSettings {
            continuation: &continuation,
            ..settings(30.0)
        };
        locate(&model, &settings, &mut Silent).map(|(l, _)| l)
    };
    let short = cut(14).unwrap();
    assert_eq!(short.points, 14);
    assert!(
        (short.omega_b.unwrap() - omega_b).abs() < 1e-9 * omega_b,
        "{:?} against {omega_b}",
        short.omega_b
    );
    assert_eq!(short.window_between, located.window_between);
    let error = cut(12).unwrap_err().to_string();
    assert!(error.contains("continuation.max_points"), "{error}");

    // The same branch with short steps sees the window's loss and regain, then the next loss.
    let rest = rest_state(&model, &study.newton).unwrap();
    let omegabar_max = model.scales.omega_to_bar(0.018);
    let short = ContinuationSettings {
        max_parameter_step: Some(0.0005 / 0.018),
        ..study.continuation.clone()
    };
    let branch = trace(&model, &rest, omegabar_max, &short, false, &mut Silent).unwrap();
    let hopf: Vec<_> = branch
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Hopf)
        .collect();
    assert!(hopf.len() >= 3, "{} Hopf points", hopf.len());
    assert!(hopf[0].loses_stability() && !hopf[1].loses_stability());
    let first = model.scales.omega_from_bar(hopf[0].p);
    let regained = model.scales.omega_from_bar(hopf[1].p);
    assert!(
        (omega_b - first).abs() < 1e-7 * first,
        "probed {omega_b}, short steps {first}"
    );
    assert!(
        regained > omega_b && regained < above,
        "regained at {regained}, outside the step [{below}, {above}]"
    );
    let im = |s: f64| model.scales.omega_from_bar(s);
    assert!(
        (located.im.unwrap() - im(hopf[0].eigenvalue.im.abs())).abs() < 1e-6 * located.im.unwrap(),
        "frequency {} against {}",
        located.im.unwrap(),
        im(hopf[0].eigenvalue.im.abs())
    );

    // `branch` with the long steps (its first 20 points, to 0.037 rad/s) probes the same near
    // miss and lists the window's loss and regain before the next loss, as the short steps do.
    let long = exponent_m_rod(0.25, 0.3725, &["continuation.max_points=20"]);
    let dir = common::temp_dir("branch_window");
    let report = branch_report(&long, &model, 30.0, &dir, &Provenance::default()).unwrap();
    assert_eq!(
        report.windows_between.len(),
        1,
        "{:?}",
        report.windows_between
    );
    let [from, to] = report.windows_between[0];
    assert!(
        from < first && regained < to,
        "the window [{first}, {regained}] outside the step [{from}, {to}]"
    );
    assert!(report.near_miss_unresolved.is_empty());
    assert!(report.events.len() >= 3, "{} events", report.events.len());
    for (listed, short) in report.events.iter().zip(&hopf) {
        let omega = model.scales.omega_from_bar(short.p);
        assert_eq!(listed.kind, "hopf");
        assert_eq!(
            (listed.unstable_before, listed.unstable_after),
            (short.unstable_before, short.unstable_after)
        );
        assert!(
            (listed.omega - omega).abs() < 1e-7 * omega,
            "branch {}, short steps {omega}",
            listed.omega
        );
    }
    // The probes are rows of branch.csv inside the step, in order along it, one unstable.
    let mut table = csv::Reader::from_path(dir.join("branch.csv")).unwrap();
    let header = table.headers().unwrap().clone();
    let column = |name: &str| header.iter().position(|h| h == name).unwrap();
    let (omega, n_unstable, probe) = (column("omega"), column("n_unstable"), column("probe"));
    let rows: Vec<(f64, usize, bool)> = table
        .records()
        .map(|r| {
            let r = r.unwrap();
            (
                r[omega].parse().unwrap(),
                r[n_unstable].parse().unwrap(),
                r[probe].parse().unwrap(),
            )
        })
        .collect();
    assert!(
        rows.windows(2).all(|w| w[0].0 < w[1].0),
        "rows out of order"
    );
    let probes: Vec<_> = rows.iter().filter(|r| r.2).collect();
    assert!(probes.iter().all(|r| from < r.0 && r.0 < to));
    assert!(
        probes
            .iter()
            .any(|r| r.1 == 2 && first < r.0 && r.0 < regained)
    );
}

/// On a stiff rod the first difference tableau of `l1` stops at its round-off floor before it has
/// converged, and the wider one settles the sign (src/engine/criticality.rs, `STARTS`): the RPY
/// rod of `exponent_m` at `lambda/l = 0.125`, `R/lambda = 0.4`, `N = 121`, whose terms of `l1`
/// cancel to a millionth (the first tableau undetermined there is this test's premise). Each
/// tableau alone is measured; their values agree within the sum of their stated precisions (a
/// consistency check: the two extrapolations share the rows from the first step down), and
/// `locate`'s coefficient is the wider one's. The coverage of each start's precision is checked
/// against closed forms in tests/criticality.rs.
#[test]
fn the_wider_tableau_settles_l1_on_a_rod_whose_terms_cancel_to_a_millionth() {
    let study = exponent_m_rod(0.125, 0.4, &[]);
    let model = Model::new(&study.physical()).unwrap();
    assert_eq!(model.nodes(), 121);
    let settings = LocateSettings {
        omega_max: 1.0,
        newton: &study.newton,
        continuation: &study.continuation,
        criticality: false,
    };
    let (located, critical) = locate(&model, &settings, &mut Silent).unwrap();
    assert_eq!(located.kind.name(), "hopf");
    let critical = critical.unwrap();
    let (event, chart) = (&critical.event, &critical.chart);
    let first = hopf_criticality_from(&model, event, chart, &[1.0]).unwrap();
    let wider = hopf_criticality_from(&model, event, chart, &[4.0]).unwrap();
    let both = hopf_criticality(&model, event, chart).unwrap();
    println!(
        "l1: first tableau {:e} +- {:e}, wider {:e} +- {:e}",
        first.l1, first.precision, wider.l1, wider.precision
    );
    assert_eq!(first.verdict, Verdict::Undetermined);
    assert_ne!(wider.verdict, Verdict::Undetermined);
    assert!(wider.precision < 0.5 * first.precision);
    assert!(
        (first.l1 - wider.l1).abs() <= first.precision + wider.precision,
        "the two tableaus disagree beyond their precisions"
    );
    assert_eq!((both.l1, both.verdict), (wider.l1, wider.verdict));
}

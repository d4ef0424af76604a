//! The refinement in `N` by grid sequencing (docs/model.md section 10): a finer rung started
//! from the coarser rung's Hopf point finds the same point as a continuation from rest at that
//! node count, to the event tolerance, with its certificate; where the carried state cannot be
//! corrected (a mesh of a few nodes per turn) the rung is followed from rest and says why.

use helixbif::analysis::locate::{LocateSettings, locate};
use helixbif::analysis::refine::{
    Answer, QuadratureError, Refinement, error_orders, ladder, refine, trusted_limit,
};
use helixbif::engine::ContinuationSettings;
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stop::Silent;
use helixbif::model::Model;
use helixbif::model::fluid::FluidModel;
use helixbif::model::params::{ClampEdge, Physical};

fn settings<'a>(
    newton: &'a NewtonSettings,
    continuation: &'a ContinuationSettings,
) -> LocateSettings<'a> {
    LocateSettings {
        omega_max: 2.0,
        newton,
        continuation,
        criticality: false,
    }
}

/// The study file `study` with `sets` refined to two rungs, the second at `fine` nodes: that rung
/// is sequenced and finds the point of a continuation from rest at `fine` nodes, to the event
/// tolerance. Returns the refinement.
fn sequenced_as_from_rest(study: &str, sets: &[&str], omega_max: f64, fine: usize) -> Refinement {
    use helixbif::study::Study;
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
    let study = Study::from_path(Some(study.as_ref()), &sets).unwrap();
    let mut physical = study.physical();
    let located = LocateSettings {
        omega_max,
        ..settings(&newton, &continuation)
    };
    let refined = refine(&physical, None, fine, &located, &mut Silent).unwrap();
    let rung = &refined.rungs[1];
    assert_eq!(rung.nodes, fine);
    assert_eq!(rung.method, "sequenced", "{:?}", rung.fallback);
    physical.discretization.nodes = fine;
    physical.discretization.per_turn = None;
    let model = Model::new(&physical).unwrap();
    let (direct, _) = locate(&model, &located, &mut Silent).unwrap();
    let (a, b) = (rung.omega_b.unwrap(), direct.omega_b.unwrap());
    assert!(
        (a - b).abs() <= 2.0 * continuation.event_tol * b,
        "sequenced {a} against continuation {b}"
    );
    refined
}

#[test]
fn a_sequenced_rung_finds_the_point_of_a_continuation_from_rest() {
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let mut physical = Physical::representative_lighthill();
    physical.fluid.model = FluidModel::Rpy;
    physical.discretization.nodes = 60;
    // Two rungs: N = 60 from rest, N = 119 sequenced (no accuracy: the rungs up to 119).
    let refined = refine(
        &physical,
        None,
        119,
        &settings(&newton, &continuation),
        &mut Silent,
    )
    .unwrap();
    assert_eq!(refined.rungs.len(), 2);
    let fine = &refined.rungs[1];
    assert_eq!(fine.method, "sequenced", "{:?}", fine.fallback);
    let certificate = fine.certificate.as_ref().unwrap();
    assert_eq!(certificate.unstable_below, 0);
    assert!(certificate.omega_below <= fine.omega_b.unwrap());
    // The same node count followed from rest.
    physical.discretization.nodes = 119;
    let model = Model::new(&physical).unwrap();
    let (direct, _) = locate(&model, &settings(&newton, &continuation), &mut Silent).unwrap();
    let (a, b) = (fine.omega_b.unwrap(), direct.omega_b.unwrap());
    assert!(
        (a - b).abs() <= 2.0 * continuation.event_tol * b,
        "sequenced {a} against continuation {b}"
    );
    // The critical frequency too, taken at the event's own state: each event lies within the
    // event tolerance of the zero, and the frequency moves with the rate at a relative rate of
    // order one, so to the same tolerance (measured: 4.1e-9 apart).
    let (wa, wb) = (refined.finest.im.unwrap(), direct.im.unwrap());
    assert!(
        (wa - wb).abs() <= 2.0 * continuation.event_tol * wb,
        "frequency: sequenced {wa} against continuation {wb}"
    );
}

/// A long helix at 15 nodes per turn (fig. 4d's rod on the RPY line: 8 turns, `N = 121`): the
/// carried state's positions and twist, each off by the coarse mesh's discretization error,
/// took Newton's method out of its basin together when the positions were interpolated with
/// Catmull-Rom slopes and the twist carried as it was (the rung fell back to a continuation
/// from rest, 14 to 17 s); with the spline and the twist re-solved for the positions the rung
/// at `N = 241` is sequenced and finds the point of the continuation from rest.
#[test]
fn a_long_helix_at_fifteen_nodes_per_turn_is_sequenced() {
    let sets = ["fluid.model=rpy", "discretization.per_turn=15"];
    let refined = sequenced_as_from_rest("studies/fig4d_phase.toml", &sets, 0.15, 241);
    assert_eq!(refined.rungs[0].nodes, 121);
}

/// A point of the coarsest branch checked on a mesh that is not the next rung's: the
/// quadrature's error measured at the second rung (the thick rod of `tests/boundary.rs` on the
/// RPY line, from `N = 61`, refined to `1e-3`: the rungs 61, 121, 241), whose certificate checks
/// points of the `N = 61` branch: the points are carried from the coarsest mesh, whose branch
/// the rungs hand down (they were carried as if from the second rung's mesh, an index out of
/// bounds that stopped a sweep of narrow helices). The quadrature's error comes out at both
/// rungs, within a tenth, as the RPY quadrature has the same point spacing at every `N` (here 8
/// and 4 points per edge; docs/model.md section 10): measured `6.370e-3` and `6.171e-3` rad/s at
/// `N = 61` and 121 (3% apart, against 12% between `N = 31` and 61: the rule's error moves with
/// the mesh it integrates on, to second order).
#[test]
fn the_coarsest_branch_is_checked_from_its_own_mesh() {
    use helixbif::study::Study;
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let sets = [
        "fluid.model=rpy".to_string(),
        "rod.r0=6.32e-3".into(),
        "discretization.nodes=61".into(),
    ];
    let physical = Study::load(None, &sets).unwrap().physical();
    let located = LocateSettings {
        omega_max: 300.0,
        ..settings(&newton, &continuation)
    };
    let refined = refine(&physical, Some(1e-3), 500, &located, &mut Silent).unwrap();
    let nodes: Vec<usize> = refined.rungs.iter().map(|r| r.nodes).collect();
    assert_eq!(nodes, [61, 121, 241]);
    assert_eq!(refined.rungs[1].method, "sequenced");
    let error = |q: Option<&QuadratureError>, nodes: usize| {
        let q = q.expect("the quadrature's error measured");
        assert_eq!(q.nodes, nodes);
        q.error.unwrap_or_else(|| panic!("{:?}", q.failed))
    };
    let (coarse, finer) = (
        error(refined.quadrature.as_deref(), 61),
        error(refined.quadrature_finer.as_deref(), 121),
    );
    assert!(
        (finer - coarse).abs() <= 0.1 * coarse.abs(),
        "{coarse} against {finer}"
    );
}

/// Points of the coarsest branch that Newton's method cannot correct once carried onto the finer
/// mesh (fig. 4c's widest helix on the RPY line, `R/lambda = 0.5`, from 15 nodes per turn: at
/// `N = 121` the carried states at 0.0023 and 0.150 rad/s, which the certificate checks, are
/// outside the basin; the rung fell back to a continuation from rest) are reached by ramping the
/// rate on the finer mesh from its own nearest state (at rest, or the crossing's stable end):
/// the rung is sequenced, checks them by ramps, and finds the point of the continuation from
/// rest.
#[test]
fn points_newton_cannot_correct_once_carried_are_reached_by_a_ramp_on_the_finer_mesh() {
    let sets = [
        "fluid.model=rpy",
        "discretization.per_turn=15",
        "shape.R_over_lambda=0.5",
    ];
    let refined = sequenced_as_from_rest("studies/fig4c_radius.toml", &sets, 3.0, 121);
    assert_eq!(refined.rungs[0].nodes, 61);
    let certificate = refined.rungs[1].certificate.as_ref().unwrap();
    for omega in [2.3098e-3, 0.15024] {
        let near = |c: &f64| (c - omega).abs() <= 1e-4 * omega;
        assert!(
            certificate.checked.iter().any(near) && certificate.ramped.iter().any(near),
            "{omega} not among the points checked by a ramp: {certificate:?}"
        );
    }
}

#[test]
fn a_rung_that_cannot_be_sequenced_is_followed_from_rest_and_says_why() {
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = 20;
    // Five nodes per turn: the carried state is too far from the finer mesh's for Newton.
    let refined = refine(
        &physical,
        Some(1e-9),
        39,
        &settings(&newton, &continuation),
        &mut Silent,
    )
    .unwrap();
    let fine = &refined.rungs[1];
    assert_eq!(fine.method, "continuation");
    assert!(
        fine.fallback
            .as_deref()
            .is_some_and(|w| w.starts_with("sequencing failed")),
        "{:?}",
        fine.fallback
    );
    assert!(fine.omega_b.is_some());
}

/// A study that fixes `N` keeps it and states its discretization error, from a coarser rung
/// (`N/2 + 1`) and its own; a refinement's answer may be the limit of its three finest rungs,
/// with the error of the limit. On a helix of its own (three turns, `l = 0.15 m`, RPY line,
/// `N = 40`) each stated error covers the error against a refinement to `N = 625` (its answer
/// the limit of 157, 313, 625) with that refinement's own estimated error added, and is no more
/// than a few times that error (an estimate, not a bound so loose that it says nothing).
#[test]
fn the_errors_stated_at_a_fixed_n_and_of_a_limit_cover_the_error_against_a_finer_computation() {
    use helixbif::analysis::refine::estimate_at_nodes;
    use helixbif::study::Study;
    helixbif::numerics::process::configure();
    let overrides = ["shape.l=0.15".to_string(), "discretization.nodes=40".into()];
    let study = Study::load(None, &overrides).unwrap();
    let physical = study.physical();
    assert_eq!(physical.fluid.model, FluidModel::Rpy);
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let settings = settings(&newton, &continuation);
    let fixed = estimate_at_nodes(&physical, &settings, &mut Silent).unwrap();
    let nodes: Vec<usize> = fixed.rungs.iter().map(|r| r.nodes).collect();
    assert_eq!(nodes, [21, 40]);
    assert_eq!(fixed.finest.nodes, 40);
    assert!(fixed.accuracy.is_none() && fixed.stopped.is_none());
    let stated = fixed.omega_b_error.unwrap();
    let value = fixed.finest.omega_b.unwrap();
    let finer = refine(&physical, None, 625, &settings, &mut Silent).unwrap();
    assert_eq!(finer.finest.nodes, 625);
    assert_eq!(finer.answer, Answer::Limit);
    let reference = finer.finest.omega_b.unwrap();
    let reference_error = finer.omega_b_error.unwrap();
    let actual = (value - reference).abs();
    assert!(
        actual + reference_error <= stated && stated <= 5.0 * actual,
        "N = 40: {value} +- {stated}; limit of N = 157, 313, 625: {reference} +- \
         {reference_error}"
    );
    // The limit of the rungs 40, 79, 157 as their refinement states it (not its answer there:
    // the rung at 40 is not yet asymptotic, and the limit's error is above the finest rung's):
    // its error in N covers its distance to the limit of 157, 313, 625, which shares no pair of
    // rungs with it, with that limit's own error in N added, and is no more than twenty times
    // that distance.
    let coarse = refine(&physical, None, 157, &settings, &mut Silent).unwrap();
    let (nodes, values): (Vec<usize>, Vec<f64>) = coarse
        .rungs
        .iter()
        .map(|r| (r.nodes, r.omega_b.unwrap()))
        .unzip();
    assert_eq!(nodes, [40, 79, 157]);
    let observed = coarse.estimate.as_ref().unwrap().observed_order;
    let limit = trusted_limit(error_orders(&physical), &nodes, &values, observed)
        .unwrap()
        .expect("the rungs converge at an order of at least 1.5");
    assert_eq!(coarse.answer, Answer::FinestRung);
    // That limit keeps the quadrature's error: compared with the finer limit before its
    // correction.
    let reference = reference + finer.quadrature_correction.as_ref().unwrap().subtracted;
    let reference_error = finer.extrapolation_error.unwrap();
    let actual = (limit.value - reference).abs();
    assert!(
        actual + reference_error <= limit.error && limit.error <= 20.0 * actual,
        "limit of N = 40, 79, 157: {} +- {}; of 157, 313, 625: {reference} +- \
         {reference_error}",
        limit.value,
        limit.error
    );
    // Rungs of a second-order law with a third-order remainder give a limit whose stated error
    // covers its own; with a last rung that is not a halving (capped by `--max-nodes`), the
    // change of the limit no longer measures its error, and no limit is given.
    let law = |n: usize| {
        let h = 1.0 / (n as f64 - 1.5);
        0.5 + 3.0 * h * h + 40.0 * h * h * h
    };
    let orders = error_orders(&physical);
    let halved = [119, 237, 473].map(law);
    let limit = trusted_limit(orders, &[119, 237, 473], &halved, Some(2.0))
        .unwrap()
        .unwrap();
    assert!((limit.value - 0.5).abs() < limit.error, "{limit:?}");
    let capped = [237, 473, 500];
    let values = capped.map(law);
    assert!(
        trusted_limit(orders, &capped, &values, Some(2.0))
            .unwrap()
            .is_none()
    );
}

/// The quadrature's own error (docs/model.md section 10), measured at the coarsest rung from 8
/// and 4 points per blob radius as `(v4 - v8) / 3`, predicts the difference to a rule it did
/// not use, 32 points per blob radius: `v8 - v32 = e (1 - 1/16)`, to 5% (measured: 2.7%; from 8
/// and 16 it was 0.2%). A thick rod (`r0 = 6.32 mm`, four times the representative's) keeps the
/// finer rules cheap.
#[test]
fn the_quadrature_error_measured_at_the_coarsest_rung_predicts_a_finer_rule() {
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let settings = LocateSettings {
        omega_max: 300.0,
        ..settings(&newton, &continuation)
    };
    let mut physical = Physical::representative_lighthill();
    physical.fluid.model = FluidModel::Rpy;
    physical.rod.r0 = 6.32e-3;
    physical.discretization.nodes = 21;
    // Two rungs (21, 41): the quadrature is measured at the coarsest where a finer one follows.
    let refined = refine(&physical, None, 41, &settings, &mut Silent).unwrap();
    let quadrature = refined.quadrature.as_ref().unwrap();
    assert_eq!(quadrature.nodes, 21);
    assert_eq!(
        (quadrature.points_per_blob, quadrature.compared_with),
        (8.0, Some(4.0))
    );
    let e = quadrature.error.unwrap();
    let v8 = refined.rungs[0].omega_b.unwrap();
    physical.fluid.points_per_blob = Some(32.0);
    let (direct, _) = locate(&Model::new(&physical).unwrap(), &settings, &mut Silent).unwrap();
    let difference = v8 - direct.omega_b.unwrap();
    let predicted = e * (1.0 - 1.0 / 16.0);
    assert!(
        (difference - predicted).abs() < 0.05 * difference.abs(),
        "v8 - v32 = {difference:e}, predicted {predicted:e}"
    );
    // Measured again at the second rung (a third follows, and the model's limit may be trusted),
    // the error changes by the bound of the correction of a limit, |e(41) - e(21)| (1.3e-3
    // rad/s, 4.4e-5 relative). An accuracy below that is out of reach at every N: the refinement
    // stops at the second rung and says what would reach it. With the clamp on the first edge
    // (first and second orders: no limit, so no correction) the rule's whole error (1.3e-4
    // relative) is what remains, and an accuracy of 1e-4 stops at the coarsest rung.
    physical.fluid.points_per_blob = None;
    let short = refine(&physical, Some(3e-5), 81, &settings, &mut Silent).unwrap();
    assert_eq!(short.rungs.len(), 2);
    assert!(!short.reached);
    let why = short.stopped.as_deref().unwrap();
    assert!(
        why.contains("correction") && why.contains("raise fluid.points_per_blob"),
        "{why}"
    );
    let finer_rule = short.quadrature_finer.as_ref().unwrap();
    assert_eq!(finer_rule.nodes, 41);
    let e41 = finer_rule.error.unwrap();
    let mut first_edge = physical.clone();
    first_edge.discretization.clamp_edge = Some(ClampEdge::First);
    let shorter = refine(&first_edge, Some(1e-4), 81, &settings, &mut Silent).unwrap();
    assert_eq!(shorter.rungs.len(), 1);
    let why = shorter.stopped.as_deref().unwrap();
    assert!(
        why.contains("own error") && why.contains("raise fluid.points_per_blob"),
        "{why}"
    );
    // `locate --extrapolate` measures it at its ladder's two coarsest rungs (whatever the order
    // of the ladder; the second halves the spacing) and removes it from the limit as a
    // refinement does (docs/model.md section 10): less `e(41)`, with the error `|e(41) - e(21)|`.
    let extrapolated = ladder(&physical, &[41, 21, 81], &settings, &mut Silent).unwrap();
    let measured = extrapolated.quadrature.as_ref().unwrap();
    assert_eq!(measured.nodes, 21);
    assert!((measured.error.unwrap() - e).abs() <= 1e-9 * e.abs());
    let correction = extrapolated.quadrature_correction.as_ref().unwrap();
    assert_eq!(correction.nodes, [21, 41]);
    assert!((correction.subtracted - e41).abs() <= 1e-9 * e41.abs());
    // The same ladder with 32 points per blob radius. The distance between the two limits in N
    // is the quadrature's effect on the limit (measured: 3.1e-3 against |e| = 5.0e-3 rad/s; not
    // `e (1 - 1/16)` exactly, since the rule's error changes with N). Each less its own rule's
    // error, they agree within the two corrections' errors, and much better than the limits
    // (measured: 3.5e-4 rad/s apart, against errors 1.3e-3 and 7.7e-5).
    physical.fluid.points_per_blob = Some(32.0);
    let finer = ladder(&physical, &[21, 41, 81], &settings, &mut Silent).unwrap();
    let finer_correction = finer.quadrature_correction.as_ref().unwrap();
    let limit = |l: &helixbif::analysis::refine::Ladder| {
        l.omega_b_extrapolated + l.quadrature_correction.as_ref().unwrap().subtracted
    };
    let distance = limit(&extrapolated) - limit(&finer);
    assert!(
        distance.abs() <= e.abs() && distance.abs() > 0.1 * e.abs(),
        "limits {} (8 points per blob radius), {} (32); quadrature error {e:e}",
        limit(&extrapolated),
        limit(&finer)
    );
    let corrected = extrapolated.omega_b_extrapolated - finer.omega_b_extrapolated;
    let bound = correction.error + finer_correction.error;
    assert!(
        corrected.abs() <= bound && corrected.abs() < 0.5 * distance.abs(),
        "corrected limits {} (8) and {} (32) are {corrected:e} apart; bound {bound:e}",
        extrapolated.omega_b_extrapolated,
        finer.omega_b_extrapolated
    );
}

/// The helix of its own of the two tests below (three turns, `l = 0.15 m`) at `points`
/// quadrature points per blob radius, refined from `N = 40` to at most 313 without an accuracy.
fn three_turns_refined(points: f64) -> Refinement {
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let settings = settings(&newton, &continuation);
    refine(&three_turns(points), None, 313, &settings, &mut Silent).unwrap()
}

/// The helix of its own of the tests below (three turns, `l = 0.15 m`, `N = 40`) at `points`
/// quadrature points per blob radius.
fn three_turns(points: f64) -> Physical {
    let overrides = [
        "shape.l=0.15".to_string(),
        "discretization.nodes=40".into(),
        format!("fluid.points_per_blob={points}"),
    ];
    helixbif::study::Study::load(None, &overrides)
        .unwrap()
        .physical()
}

/// The quadrature's correction of a limit (docs/model.md section 10) on a helix of its own
/// (three turns, `l = 0.15 m`, rungs 40, 79, 157, 313): the limits at 8 and at 16 points per
/// blob radius, each less its own rule's error as measured at its first two rungs, agree within
/// the sum of the two corrections' stated errors, and far better than the limits themselves
/// (which keep their rules' errors). Measured: 0.85029001 and 0.85029366 rad/s, 3.7e-6 apart,
/// against stated errors 1.6e-5 and 3.6e-6; the limits 0.85047097 and 0.85033894, 1.3e-4 apart.
#[test]
fn the_limits_at_two_rules_less_their_quadrature_errors_agree_within_the_stated_errors() {
    helixbif::numerics::process::configure();
    let at_rule = |points: f64| {
        let refined = three_turns_refined(points);
        assert_eq!(
            refined.answer,
            Answer::Limit,
            "{points} points per blob radius"
        );
        let correction = refined.quadrature_correction.clone().unwrap();
        assert_eq!(correction.nodes, [40, 79]);
        let answer = refined.finest.omega_b.unwrap();
        (answer, answer + correction.subtracted, correction.error)
    };
    let (a8, l8, e8) = at_rule(8.0);
    let (a16, l16, e16) = at_rule(16.0);
    let corrected = (a8 - a16).abs();
    assert!(
        corrected <= e8 + e16 && corrected < 0.25 * (l8 - l16).abs(),
        "8 points: {a8} +- {e8:e} (limit {l8}); 16 points: {a16} +- {e16:e} (limit {l16})"
    );
}

/// The error in `N` of the Lyapunov coefficient (docs/model.md section 12) on a helix of its
/// own (two turns, `l = 0.1 m`, Hopf point near 2.17 rad/s): the error stated at `N = 209` (from
/// the rungs 53, 105, 209) covers the change to `N = 417`, a rung it did not use, and the
/// verdict is the sign; from the rungs 27, 53, 105, whose increments do not yet shrink as at
/// first order (0.069, 0.048), no error is stated. Measured: `l1 = 0.44052, 0.48809, 0.50210,
/// 0.50566` at `N = 53, 105, 209, 417`, stated error at 209 `1.39e-2` against a change of
/// `3.6e-3` (and `4.8e-3` to the second-order limit of 209 and 417); at 417, `3.6e-3`.
#[test]
fn the_error_of_l1_in_n_covers_a_finer_rung_it_did_not_use() {
    use helixbif::engine::criticality::Verdict;
    use helixbif::study::Study;
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let with_l1 = LocateSettings {
        omega_max: 6.0,
        criticality: true,
        ..settings(&newton, &continuation)
    };
    let from = |nodes: usize, max: usize| {
        let overrides = [
            "shape.l=0.1".to_string(),
            format!("discretization.nodes={nodes}"),
        ];
        let physical = Study::load(None, &overrides).unwrap().physical();
        refine(&physical, None, max, &with_l1, &mut Silent).unwrap()
    };
    let at_209 = from(53, 209);
    let stated = at_209.lyapunov_error.as_ref().unwrap();
    let rungs: Vec<usize> = stated.rungs.iter().map(|r| r.nodes).collect();
    assert_eq!(rungs, [53, 105]);
    let error = stated.error.unwrap();
    let l1_209 = at_209.finest.l1.unwrap();
    let at_417 = from(53, 417);
    let l1_417 = at_417.finest.l1.unwrap();
    assert!(
        (l1_417 - l1_209).abs() <= error && error < 0.1 * l1_209.abs(),
        "l1 = {l1_209} +- {error:e} at N = 209, {l1_417} at 417"
    );
    assert_eq!(at_209.finest.criticality, Some(Verdict::Subcritical));
    // The error at 417 from 105, 209, 417: smaller, as the rungs converge.
    let finer = at_417.lyapunov_error.as_ref().unwrap().error.unwrap();
    assert!(
        finer < 0.5 * error,
        "{finer:e} at 417 against {error:e} at 209"
    );
    // Rungs before the range where l1 converges at first order: no error stated.
    let coarse = from(27, 105);
    let refused = coarse.lyapunov_error.as_ref().unwrap();
    assert!(refused.error.is_none());
    assert!(
        refused
            .failed
            .as_deref()
            .is_some_and(|why| why.contains("do not shrink")),
        "{:?}",
        refused.failed
    );
}

/// The RPY quadrature's points stay where they were from one rung to the next only while the
/// coarser rung has at least two cells per edge (docs/model.md section 9). On a helix of its
/// own (three turns, `l = 0.15 m`, rungs from `N = 40`) at two points per blob radius, the
/// refinement stops at the rung with one cell per edge and says why, and the error it states
/// there covers the difference to the refinement at eight points per blob radius, whose rungs
/// stay nested to `N = 313`. Measured: stopped at `N = 157`, `0.851808 +- 2.1e-3` rad/s
/// against `0.850290 +- 1.9e-4` at eight points (the limit of 79, 157, 313); a refinement
/// carried on to 313 finds rungs that do not converge as the known order allows, and answers
/// with the finest rung's `0.848392 +- 3.7e-3`.
#[test]
fn the_refinement_stops_where_a_finer_rung_would_move_the_quadratures_points() {
    helixbif::numerics::process::configure();
    let (coarse, fine) = (three_turns_refined(2.0), three_turns_refined(8.0));
    assert_eq!(fine.finest.nodes, 313, "{:?}", fine.stopped);
    assert!(coarse.finest.nodes < 313);
    let why = coarse.stopped.clone().unwrap();
    assert!(why.contains("point spacing would be"), "{why}");
    let (a, e) = (
        coarse.finest.omega_b.unwrap(),
        coarse.omega_b_error.unwrap(),
    );
    let (b, f) = (fine.finest.omega_b.unwrap(), fine.omega_b_error.unwrap());
    assert!(
        (a - b).abs() <= e + f,
        "two points per blob radius: {a} +- {e:e} at N = {}; eight: {b} +- {f:e}",
        coarse.finest.nodes
    );
}

/// An `--extrapolate` ladder whose third rung or later would not keep the coarsest rung's RPY
/// quadrature point spacing is refused before any rung is solved, as bad input on `--nodes`
/// (docs/model.md section 10): the helix of the tests above at two points per blob radius, whose
/// rung at `N = 157` has one cell per edge, with the rungs 40, 79, 157, 313.
#[test]
fn a_ladder_that_would_change_the_quadratures_spacing_is_refused() {
    helixbif::numerics::process::configure();
    let (newton, continuation) = (NewtonSettings::default(), ContinuationSettings::default());
    let settings = settings(&newton, &continuation);
    let rungs = [40, 79, 157, 313];
    let Err(refused) = ladder(&three_turns(2.0), &rungs, &settings, &mut Silent) else {
        panic!("the ladder was run");
    };
    assert!(refused.is_input(), "{refused}");
    let message = refused.to_string();
    assert!(
        message.contains("--nodes") && message.contains("N = 313"),
        "{message}"
    );
}

/// The precision of a located Hopf point is that of the zero of `Re s(p)` as the Newton solves
/// give the states (docs/model.md section 10); it leaves out their own error, the solves'
/// tolerance. That error is far below it: with the corrector's tolerance tightened from the
/// default `1e-9` to `1e-12`, every rung of two refinements (the representative helix from
/// `N = 60` to 237, and the three-turn helix of the tests above from 40 to 157: a continuation
/// from rest and two sequenced rungs each) moves by less than a tenth of the event tolerance
/// every rung is located to. Measured: at most 1.1e-10 relative (the representative's
/// `N = 237`), against the event tolerance `1e-8`.
#[test]
fn the_newton_error_of_the_states_moves_omega_b_far_less_than_the_event_tolerance() {
    helixbif::numerics::process::configure();
    let newton = NewtonSettings::default();
    let representative = helixbif::study::Study::load(None, &[]).unwrap().physical();
    for (physical, fine) in [(representative, 237), (three_turns(8.0), 157)] {
        let at = |tol: f64| {
            let continuation = ContinuationSettings {
                tol,
                ..ContinuationSettings::default()
            };
            let refined = refine(
                &physical,
                None,
                fine,
                &settings(&newton, &continuation),
                &mut Silent,
            )
            .unwrap();
            assert_eq!(refined.rungs.len(), 3);
            let methods: Vec<&str> = refined.rungs.iter().map(|r| r.method).collect();
            assert_eq!(methods, ["continuation", "sequenced", "sequenced"]);
            refined
                .rungs
                .iter()
                .map(|r| r.omega_b.unwrap())
                .collect::<Vec<f64>>()
        };
        let (default, tight) = (at(ContinuationSettings::default().tol), at(1e-12));
        let tolerance = ContinuationSettings::default().event_tol;
        for (a, b) in default.iter().zip(&tight) {
            let moved = (a - b).abs() / b;
            assert!(
                moved < 0.1 * tolerance,
                "omega_b {a} at the default tolerance, {b} at 1e-12: {moved:.2e} relative"
            );
        }
    }
}

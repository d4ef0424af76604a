//! The Krylov path of the stability problem (src/continuation/krylov.rs) against the dense
//! solver: on pencils built with a known spectrum, along the representative branch, and through
//! `locate`.

use crate::common;

use common::SplitMix64;
use faer::{Mat, Side, c64};
use std::cell::RefCell;

use helixbif::problem::rod::{Parameter, RodProblem, omega_scale};

use helixbif::analysis::locate::{LocateSettings, locate};

use helixbif::analysis::solve::rest_state;
use helixbif::engine::arclength::{Limits, follow};
use helixbif::engine::krylov::{Refusal, rightmost, shift_after};
use helixbif::engine::newton::NewtonSettings;
use helixbif::engine::stability::{EigenCounts, Solver, Spectrum, leading, spectrum};
use helixbif::engine::stop::{Silent, Stop};
use helixbif::engine::{ContinuationSettings, EigenMethod, Linearization, Problem};
use helixbif::model::Model;
use helixbif::model::params::Physical;

/// The largest relative difference between two lists of eigenvalues, entry by entry.
fn relative_difference(a: &[c64], b: &[c64]) -> f64 {
    assert_eq!(a.len(), b.len(), "{a:?} vs {b:?}");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm() / y.norm().max(1e-300))
        .fold(0.0, f64::max)
}

/// A pencil with the eigenvalues `values` (a complex value stands for its conjugate pair):
/// `M = L L^T` symmetric positive definite (random, seeded), `K = L Q (D + N) Q^T L^T` with `Q`
/// orthogonal (random), `D` block diagonal (a 2x2 block `[[a, b], [-b, a]]` per pair) and `N`
/// a small coupling strictly above the diagonal blocks among the first `coupled` unknowns.
/// `L^{-1} K L^{-T} = Q (D + N) Q^T` is block upper triangular in the basis `Q`, so the
/// eigenvalues are exactly those of `D`, and the pencil is not normal.
fn pencil(values: &[c64], coupled: usize, seed: u64) -> (Mat<f64>, Mat<f64>) {
    let n: usize = values.iter().map(|s| if s.im != 0.0 { 2 } else { 1 }).sum();
    let mut rng = SplitMix64(seed);
    let a = Mat::from_fn(n, n, |_, _| rng.uniform());
    let m = &a * a.transpose() * (1.0 / n as f64) + Mat::<f64>::identity(n, n);
    let l = m.llt(Side::Lower).unwrap().L().to_owned();
    let sym = &a + a.transpose();
    let q = sym.self_adjoint_eigen(Side::Lower).unwrap().U().to_owned();
    let mut d = Mat::<f64>::zeros(n, n);
    let mut block = vec![0; n];
    let mut i = 0;
    for (b, v) in values.iter().enumerate() {
        d[(i, i)] = v.re;
        block[i] = b;
        if v.im != 0.0 {
            d[(i + 1, i + 1)] = v.re;
            d[(i, i + 1)] = v.im;
            d[(i + 1, i)] = -v.im;
            block[i + 1] = b;
            i += 2;
        } else {
            i += 1;
        }
    }
    for i in 0..coupled {
        for j in 0..coupled {
            if block[i] < block[j] {
                d[(i, j)] = 5.0 * rng.uniform();
            }
        }
    }
    let k = &l * &q * &d * q.transpose() * l.transpose();
    (k, m)
}

/// A spectrum like the rod's: complex pairs fanning out from the imaginary axis (two with
/// `Re s > 0`, one just left of it), real eigenvalues on both sides of zero, and a stiff tail
/// down to `-1e6`.
fn rod_like(shift: f64) -> Vec<c64> {
    let mut values = vec![
        c64::new(2.0 + shift, 250.0),
        c64::new(1e-3 + shift, 120.0),
        c64::new(-1e-3 + shift, 310.0),
        c64::new(0.5 + shift, 0.0),
        c64::new(-0.7 + shift, 0.0),
        c64::new(-40.0, 200.0),
        c64::new(-90.0, 80.0),
        c64::new(-150.0, 0.0),
    ];
    for j in 0..160 {
        values.push(c64::new(-300.0 * 1.06f64.powi(j), 0.0));
    }
    values.push(c64::new(-1e6, 0.0));
    values
}

#[test]
fn krylov_finds_the_rightmost_eigenvalues_of_pencils_with_a_known_spectrum() {
    for (seed, shift, double) in [
        (1, 0.0, false),
        (2, -3.0, false),
        (3, 1.5, false),
        (4, 0.0, true),
    ] {
        let mut values = rod_like(shift);
        if double {
            // A double unstable real eigenvalue and a double pair next to the axis, as in a
            // symmetric problem, uncoupled: each counts twice.
            values.splice(3..3, [c64::new(0.3, 0.0), c64::new(0.3, 0.0)]);
            values.splice(0..0, [c64::new(-0.2, 180.0), c64::new(-0.2, 180.0)]);
        }
        let (k, m) = pencil(&values, if double { 0 } else { 13 }, seed);
        let dense = spectrum(&k, &m, 6).unwrap();
        // The shift comes from a neighbouring pencil, as along a branch.
        let (k0, m0) = pencil(&rod_like(shift - 0.5), 13, seed + 10);
        let prior = spectrum(&k0, &m0, 6).unwrap();
        let krylov = rightmost(&k, &m, 6, shift_after(&prior), 24).unwrap();
        let exact_unstable: usize = values
            .iter()
            .filter(|s| s.re > 0.0)
            .map(|s| if s.im != 0.0 { 2 } else { 1 })
            .sum();
        println!(
            "seed {seed}: unstable exact {exact_unstable}, dense {}, krylov {}; leading {:?}",
            dense.unstable, krylov.unstable, krylov.leading
        );
        assert_eq!(krylov.unstable, dense.unstable);
        assert_eq!(krylov.unstable, exact_unstable);
        let mut exact: Vec<c64> = values
            .iter()
            .flat_map(|s| {
                let pair = (s.im != 0.0).then(|| s.conj());
                std::iter::once(*s).chain(pair)
            })
            .collect();
        exact.sort_by(|a, b| b.re.total_cmp(&a.re).then(b.im.total_cmp(&a.im)));
        let exact_difference = relative_difference(&krylov.leading, &exact[..krylov.leading.len()]);
        println!(
            "  Krylov vs the exact spectrum, largest relative difference {exact_difference:.2e}"
        );
        assert!(exact_difference < 1e-8);
        let difference = relative_difference(&krylov.leading, &dense.leading);
        println!("  Krylov vs dense, largest relative difference {difference:.2e}");
        assert!(difference < 1e-8, "{krylov:?} vs {dense:?}");
    }
}

#[test]
fn an_unstable_pair_beyond_the_krylov_budget_is_left_to_the_dense_solver() {
    // 120 eigenvalues clustered near the axis (more than the Krylov path may ask for) and an
    // unstable pair far up the imaginary axis: the disk of found eigenvalues cannot reach it,
    // the count is in doubt, and `leading` answers with the dense solver.
    let mut values: Vec<c64> = (0..120)
        .map(|j| c64::new(-1.0 - 0.05 * j as f64, 0.0))
        .collect();
    values.push(c64::new(0.2, 2000.0));
    let (k, m) = pencil(&values, 20, 7);
    let prior = Spectrum {
        leading: values[..6].to_vec(),
        unstable: 0,
        solver: Solver::Dense,
    };
    let refused = rightmost(&k, &m, 6, shift_after(&prior), 24);
    assert_eq!(refused, Err(Refusal::CountInDoubt));
    let answer = leading(&k, &m, 6, EigenMethod::Krylov, Some(&prior)).unwrap();
    let mut counts = EigenCounts::default();
    counts.add(&answer);
    println!("{counts:?}");
    assert_eq!((counts.fallbacks, counts.dense, counts.krylov), (1, 1, 0));
    assert_eq!(answer.unstable, 2);
    assert_eq!(
        answer,
        Spectrum {
            solver: Solver::Fallback(Refusal::CountInDoubt),
            ..spectrum(&k, &m, 6).unwrap()
        }
    );
}

/// The rod problem, recording every stability pair the engine asks for (each in the chart the
/// branch is in at that moment: the chart moves along the branch, docs/model.md section 2).
struct Recording<'a> {
    inner: RodProblem<&'a Model>,
    pairs: RefCell<Vec<(Mat<f64>, Mat<f64>)>>,
}

impl Problem for Recording<'_> {
    fn dim(&self) -> usize {
        self.inner.dim()
    }
    fn residual(&self, u: &[f64], p: f64) -> helixbif::Result<Vec<f64>> {
        self.inner.residual(u, p)
    }
    fn linearize(&self, u: &[f64], p: f64) -> helixbif::Result<Linearization> {
        self.inner.linearize(u, p)
    }
    fn retract(&self, u: &[f64], du: &[f64]) -> Vec<f64> {
        self.inner.retract(u, du)
    }
    fn stability_pair(
        &self,
        u: &[f64],
        p: f64,
        lin: &Linearization,
    ) -> helixbif::Result<(Mat<f64>, Mat<f64>)> {
        let pair = self.inner.stability_pair(u, p, lin)?;
        self.pairs.borrow_mut().push(pair.clone());
        Ok(pair)
    }
    fn scales(&self) -> (f64, f64) {
        self.inner.scales()
    }
    fn rechart(&self, u: &[f64], tangent: &[f64]) -> Option<Vec<f64>> {
        self.inner.rechart(u, tangent)
    }
}

/// Follows the branch from rest to `omega_max` (rad/s) with the dense solver, in steps of at most
/// `step` of the range where given (else the default), and checks, on every stability pair met, that the Krylov path (shifted from the previous pair's spectrum)
/// gives the same unstable count and the same leading eigenvalues to 1e-8; returns the number
/// of pairs and of unstable ones.
fn branch_agrees(
    label: &str,
    physical: &Physical,
    omega_max: f64,
    step: Option<f64>,
) -> (usize, usize) {
    let model = Model::new(physical).unwrap();
    let rest = rest_state(&model, &NewtonSettings::default()).unwrap();
    let omegabar_max = model.scales.omega_to_bar(omega_max);
    let settings = ContinuationSettings {
        eigen: EigenMethod::Dense,
        max_parameter_step: step,
        ..ContinuationSettings::default()
    };
    let problem = Recording {
        inner: RodProblem::new(&model, Parameter::Omega, omega_scale(omegabar_max)),
        pairs: RefCell::new(Vec::new()),
    };
    let u0 = problem.inner.steady(0.0).free_vector(&rest.config);
    let limits = Limits {
        p_min: -0.5 * omegabar_max,
        p_max: omegabar_max,
        stop_at_first_instability: false,
    };
    let branch = follow(&problem, u0, 0.0, 1.0, &settings, &limits, &mut Silent).unwrap();
    assert!(
        matches!(branch.stop, Stop::ParameterLimit),
        "{label}: {:?}",
        branch.stop
    );
    let pairs = problem.pairs.into_inner();
    let mut worst: f64 = 0.0;
    let mut unstable_points = 0;
    let mut before: Option<Spectrum> = None;
    for (k, m) in &pairs {
        let dense = spectrum(k, m, 6).unwrap();
        if let Some(previous) = &before {
            let krylov = rightmost(k, m, 6, shift_after(previous), 24)
                .unwrap_or_else(|e| panic!("{label}: refused: {e:?}"));
            // The event search samples the crossing itself, where the critical eigenvalue's
            // real part is at round-off level and its sign is no verdict of either solver.
            let on_the_axis = dense.leading.iter().any(|s| s.re.abs() <= 1e-7 * s.norm());
            if !on_the_axis {
                assert_eq!(
                    krylov.unstable, dense.unstable,
                    "{label}: {:?}",
                    dense.leading
                );
            }
            worst = worst.max(relative_difference(&krylov.leading, &dense.leading));
            unstable_points += usize::from(krylov.unstable > 0);
        }
        before = Some(dense);
    }
    println!(
        "{label}: {} stability pairs ({unstable_points} unstable), largest relative difference \
         of the leading eigenvalues {worst:.2e}",
        pairs.len()
    );
    assert!(worst < 1e-8, "{worst}");
    (pairs.len(), unstable_points)
}

/// The representative helix at `nodes` (Lighthill) up to 0.8 rad/s, past its Hopf point.
fn helix_branch_agrees(nodes: usize) {
    let mut physical = Physical::representative_lighthill();
    physical.discretization.nodes = nodes;
    let (_, unstable) = branch_agrees(&format!("helix, N = {nodes}"), &physical, 0.8, None);
    assert!(unstable > 0);
}

#[test]
fn krylov_and_dense_agree_along_the_representative_branch_at_30_nodes() {
    helix_branch_agrees(30);
}

#[test]
fn krylov_and_dense_agree_along_the_representative_branch_at_60_nodes() {
    helix_branch_agrees(60);
}

#[test]
fn krylov_and_dense_agree_along_the_representative_branch_at_85_nodes() {
    helix_branch_agrees(85);
}

#[test]
fn krylov_and_dense_agree_on_the_rpy_line_at_240_nodes() {
    // A few points of the branch from rest on the RPY-regularized fluid (docs/model.md section
    // 9), where the pencil has 714 unknowns: steps of at most an eighth of the range.
    let mut physical = Physical::representative_lighthill();
    physical.fluid.model = helixbif::model::fluid::FluidModel::Rpy;
    physical.discretization.nodes = 240;
    branch_agrees("helix, RPY, N = 240", &physical, 0.15, Some(0.125));
}

#[test]
fn krylov_and_dense_agree_along_the_tight_arc_branch() {
    // The R/L = 0.29 arc of studies/fig2_straight_and_curved.toml (22 nodes), to 2 rad/s: past
    // 0.947 rad/s, where the chart of the twist angles moves.
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("studies/fig2_straight_and_curved.toml"),
    )
    .unwrap();
    let study = helixbif::study::Study::load(
        Some(&text),
        &["shape={kind=\"arc\", L=0.12, R=0.0348}".into()],
    )
    .unwrap();
    let (points, _) = branch_agrees("arc, R/L = 0.29", &study.physical(), 2.0, None);
    assert!(points > 10);
}

#[test]
fn located_omega_b_does_not_depend_on_the_eigensolver() {
    for nodes in [30, 60, 85] {
        let mut physical = Physical::representative_lighthill();
        physical.discretization.nodes = nodes;
        let model = Model::new(&physical).unwrap();
        let omega_b = |eigen| {
            let settings = ContinuationSettings {
                eigen,
                ..ContinuationSettings::default()
            };
            let mut tally = EigenCounts::default();
            let (located, _) = locate(
                &model,
                &LocateSettings {
                    omega_max: 2.0,
                    newton: &NewtonSettings::default(),
                    continuation: &settings,
                    criticality: true,
                },
                &mut tally,
            )
            .unwrap();
            (located.omega_b.unwrap(), tally)
        };
        let (dense, dense_counts) = omega_b(EigenMethod::Dense);
        let (krylov, krylov_counts) = omega_b(EigenMethod::Krylov);
        println!(
            "N = {nodes}: omega_b dense {dense:.12}, krylov {krylov:.12} (relative {:.1e}); \
             {krylov_counts:?}",
            (krylov / dense - 1.0).abs()
        );
        assert_eq!(dense_counts.krylov, 0);
        // Every spectrum of the branch is Krylov's, the first point's too (shift 0, no spectrum before it).
        assert_eq!(krylov_counts.fallbacks, 0, "{krylov_counts:?}");
        assert_eq!(krylov_counts.dense, 0, "{krylov_counts:?}");
        assert!(krylov_counts.krylov > 10);
        assert!((krylov / dense - 1.0).abs() < 1e-9);
    }
}

#[test]
fn the_canonical_problems_give_the_same_events_with_either_eigensolver() {
    use helixbif::engine::reference::{Reference, brusselator, fold, hopf_normal_form, pitchfork};
    type Found = (Vec<(f64, usize, usize)>, EigenCounts);
    let events = |problem: &dyn Fn(EigenMethod) -> Found| {
        let (dense, _) = problem(EigenMethod::Dense);
        let (krylov, counts) = problem(EigenMethod::Krylov);
        // A pencil of one or two unknowns whose eigenvalue passes zero (the fold) has an
        // eigenvalue far below the shift: there shift-invert is accurate only to round-off of
        // the shift, the backward error check refuses it, and the dense solver answers.
        println!("{dense:?} vs {krylov:?}: {counts:?}");
        assert!(counts.krylov > counts.fallbacks);
        assert_eq!(dense.len(), krylov.len());
        for (d, k) in dense.iter().zip(&krylov) {
            assert_eq!((d.1, d.2), (k.1, k.2));
            assert!(
                (d.0 - k.0).abs() <= 1e-9 * d.0.abs().max(1e-6),
                "{d:?} vs {k:?}"
            );
        }
    };
    let run =
        |problem: &Reference, u0: Vec<f64>, p0: f64, direction: f64, range: (f64, f64), eigen| {
            let settings = ContinuationSettings {
                ds: 0.1,
                ds_max: 0.5,
                eigen,
                ..ContinuationSettings::default()
            };
            let limits = Limits {
                p_min: range.0,
                p_max: range.1,
                stop_at_first_instability: false,
            };
            let mut tally = EigenCounts::default();
            let events = follow(problem, u0, p0, direction, &settings, &limits, &mut tally)
                .unwrap()
                .events
                .iter()
                .map(|e| (e.p, e.unstable_before, e.unstable_after))
                .collect::<Vec<_>>();
            (events, tally)
        };
    events(&|eigen| run(&fold(), vec![-1.0], 1.0, -1.0, (-1.0, 1.0), eigen));
    events(&|eigen| run(&pitchfork(0.0), vec![0.0], -1.0, 1.0, (-2.0, 1.0), eigen));
    events(&|eigen| {
        run(
            &hopf_normal_form(),
            vec![0.0, 0.0],
            -1.0,
            1.0,
            (-2.0, 1.0),
            eigen,
        )
    });
    events(&|eigen| {
        run(
            &brusselator(2.0),
            vec![2.0, 0.5],
            1.0,
            1.0,
            (0.0, 8.0),
            eigen,
        )
    });
}

#[test]
fn the_eigensolver_is_a_study_setting() {
    let study = helixbif::study::Study::load(None, &["continuation.eigen=krylov".into()]).unwrap();
    assert_eq!(study.continuation.eigen, EigenMethod::Krylov);
    assert_eq!(
        helixbif::study::Study::load(None, &[])
            .unwrap()
            .continuation
            .eigen,
        EigenMethod::Auto
    );
    let bad = helixbif::study::Study::load(None, &["continuation.eigen=arnoldi".into()])
        .expect_err("an unknown solver is refused");
    assert!(bad.is_input());
    assert!(bad.to_string().contains("continuation.eigen"), "{bad}");
}

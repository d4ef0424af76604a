//! Periodic orbits by shooting (`continuation::periodic`) against closed forms: the period
//! map's sensitivities against finite differences, the orbits of the Hopf normal form (radius,
//! period and Floquet multiplier exact, with the BDF2 error falling as `h^2`), and the
//! Brusselator's orbits against the amplitude the first Lyapunov coefficient predicts.

use std::ops::ControlFlow;

use faer::c64;
use helixbif::engine::Problem;
use helixbif::engine::criticality::first_lyapunov;
use helixbif::engine::periodic::VectorField;
use helixbif::engine::periodic::branch::{
    Checkpoint, HopfStart, OrbitBranchSettings, OrbitEventKind, follow_orbits, resume_orbits,
};
use helixbif::engine::periodic::flow::{FlowSettings, period_map};
use helixbif::engine::periodic::orbit::{Condition, ShootingSettings, shoot};
use helixbif::engine::reference::{Jacobian, Reference, Residual, brusselator, hopf_cubic};

/// A Hopf point at the origin, `p = 0`, of frequency `w`, with the mode `(1, -i)/sqrt 2` of
/// the planar normal forms.
fn origin(w: f64) -> HopfStart {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    HopfStart {
        u: vec![0.0, 0.0],
        p: 0.0,
        frequency: w,
        mode: (vec![s, 0.0], vec![0.0, -s]),
    }
}

/// Branch settings with `steps` per period, tight tolerances, the first radius `amplitude`.
fn branch_settings(steps: usize, amplitude: f64, max_orbits: usize) -> OrbitBranchSettings {
    OrbitBranchSettings {
        shooting: ShootingSettings {
            flow: flow(steps),
            tol: 1e-10,
            max_iter: 10,
        },
        amplitude,
        max_orbits,
        ..OrbitBranchSettings::default()
    }
}

fn flow(steps: usize) -> FlowSettings {
    FlowSettings {
        steps,
        step_tol: 1e-13,
        max_newton: 12,
    }
}

#[test]
fn the_period_map_sensitivities_match_finite_differences() {
    let a = 1.5;
    let problem = brusselator(a);
    let field = VectorField(&problem);
    let (u, t, b) = ([1.2, 1.9], 2.7, 3.1);
    let settings = flow(60);
    let map = period_map(&field, b, &u, t, &settings, true).unwrap();
    let sens = map.sensitivity.unwrap();
    let end = |u: &[f64], t: f64, b: f64| -> Vec<f64> {
        period_map(&field, b, u, t, &settings, false)
            .unwrap()
            .end(2)
            .to_vec()
    };
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for col in 0..4 {
        let shifted = |s: f64| {
            let mut y = [u[0], u[1], t, b];
            y[col] += s;
            end(&y[..2], y[2], y[3])
        };
        let (plus, minus) = (shifted(h), shifted(-h));
        for r in 0..2 {
            let fd = (plus[r] - minus[r]) / (2.0 * h);
            let exact = match col {
                0 | 1 => sens.x0[(r, col)],
                2 => sens.period[r],
                _ => sens.parameter[r],
            };
            worst = worst.max((fd - exact).abs() / (1.0 + exact.abs()));
        }
    }
    eprintln!("period map sensitivities: worst relative difference {worst:.2e}");
    assert!(worst < 1e-7, "{worst:e}");
}

/// The normal form with `a = -1` and a twist `b` of the frequency: orbits of radius
/// `sqrt(p)`, period `2 pi / (w + b p)`, nontrivial multiplier `exp(-2 p T)`.
#[test]
fn orbits_of_the_hopf_normal_form_are_exact_to_the_order_of_the_scheme() {
    let (w, b) = (1.3, 0.4);
    let problem = hopf_cubic(w, -1.0, b);
    let field = VectorField(&problem);
    let mut errors = Vec::new();
    for steps in [100, 200] {
        let settings = ShootingSettings {
            flow: flow(steps),
            tol: 1e-10,
            max_iter: 10,
        };
        let p = 0.09;
        let exact_t = 2.0 * std::f64::consts::PI / (w + b * p);
        let orbit = shoot(
            &field,
            &[0.25, 0.0],
            2.0 * std::f64::consts::PI / w,
            p,
            &Condition::parameter(2, p),
            &settings,
        )
        .unwrap();
        let radius = orbit.amplitude(&field, Some(&[0.0, 0.0]));
        let multiplier = orbit.multipliers[0];
        let exact_mu = (-2.0 * p * exact_t).exp();
        let e = (
            (radius / p.sqrt() - 1.0).abs(),
            (orbit.period / exact_t - 1.0).abs(),
            (multiplier.re / exact_mu - 1.0).abs(),
            (orbit.trivial - c64::new(1.0, 0.0)).norm(),
        );
        eprintln!(
            "steps {steps}: radius error {:.2e}, period error {:.2e}, multiplier error {:.2e}, \
             trivial multiplier off 1 by {:.2e}, iterations {}",
            e.0, e.1, e.2, e.3, orbit.iterations
        );
        assert!(multiplier.im.abs() < 1e-12);
        assert_eq!(orbit.unstable, 0);
        errors.push(e);
    }
    let (coarse, fine) = (errors[0], errors[1]);
    // Halving h divides the period and multiplier errors by about 4 (second order) and the
    // radius error by about 8 (BDF2 damps an oscillation at third order in w h).
    for (c, f, low, high, name) in [
        (coarse.0, fine.0, 6.5, 10.0, "radius"),
        (coarse.1, fine.1, 3.5, 4.5, "period"),
        (coarse.2, fine.2, 3.5, 5.0, "multiplier"),
    ] {
        assert!(f < 1e-3, "{name} error {f:e} at 200 steps");
        let ratio = c / f;
        assert!((low..high).contains(&ratio), "{name}: error ratio {ratio}");
    }
}

/// The branch from the Hopf point at `p = 0` of the supercritical normal form grows as
/// `r = sqrt(p)` with stable orbits; of the subcritical one (`a = +1`), backwards with
/// unstable orbits.
#[test]
fn the_orbit_branch_leaves_the_hopf_point_on_the_side_of_its_criticality() {
    let w = 1.0;
    for a in [-1.0, 1.0] {
        let problem = hopf_cubic(w, a, 0.0);
        let field = VectorField(&problem);
        let start = origin(w);
        let settings = branch_settings(200, 0.02, 12);
        let branch = follow_orbits(&field, &start, &settings, (-0.5, 0.5), |_, _, _| {
            ControlFlow::Continue(())
        })
        .unwrap();
        assert!(branch.orbits.len() >= 5, "{} orbits", branch.orbits.len());
        let mut worst: f64 = 0.0;
        for o in &branch.orbits {
            assert!(o.p * a < 0.0, "a = {a}: orbit at p = {}", o.p);
            let radius = o.amplitude(&field, Some(&[0.0, 0.0]));
            worst = worst.max((radius * radius + o.p / a).abs());
            assert_eq!(o.unstable, usize::from(a > 0.0), "a = {a}, p = {}", o.p);
        }
        let last = branch.orbits.last().unwrap();
        eprintln!(
            "a = {a}: {} orbits to p = {:.4}, radius {:.4}; worst |r^2 - p/a| {worst:.2e}",
            branch.orbits.len(),
            last.p,
            last.amplitude(&field, None)
        );
        // BDF2 damps an oscillation at about 0.4 w (w h)^3 = 1.3e-5 (200 steps): the
        // discrete Hopf point, and so every r^2, moves by that much.
        assert!(worst < 3e-5, "{worst:e}");
        assert!(branch.events.is_empty(), "{:?}", branch.events);
    }
}

/// A subcritical branch that turns: `r' = p r + r^3 - r^5` has orbits `p = r^4 - r^2`, a fold
/// at `r^2 = 1/2`, `p = -1/4`, unstable below it and stable above.
/// `r' = (p + r^2 - r^4) r`, `phi' = 1` in Cartesian form.
fn quintic() -> Reference {
    helixbif::engine::reference::Analytic {
        dim: 2,
        g: Box::new(|u: &[f64], p: f64| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            let g = p + r2 - r2 * r2;
            vec![g * x - y, x + g * y]
        }) as Residual,
        g_u: Box::new(|u: &[f64], p: f64| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            let g = p + r2 - r2 * r2;
            let dg = 2.0 - 4.0 * r2;
            vec![
                vec![g + dg * x * x, -1.0 + dg * x * y],
                vec![1.0 + dg * x * y, g + dg * y * y],
            ]
        }) as Jacobian,
        g_p: Box::new(|u: &[f64], _| vec![u[0], u[1]]) as Residual,
    }
}

/// The branch of [`quintic`] from its Hopf point until `r^2 > 1.2`, `observer` also seeing
/// every orbit and checkpoint (it may break first).
fn quintic_branch(
    mut observer: impl FnMut(
        usize,
        &helixbif::engine::periodic::orbit::Orbit,
        Option<&Checkpoint>,
    ) -> ControlFlow<()>,
) -> helixbif::engine::periodic::branch::OrbitBranch {
    let problem = quintic();
    let field = VectorField(&problem);
    follow_orbits(
        &field,
        &origin(1.0),
        &branch_settings(200, 0.05, 60),
        (-1.0, 0.5),
        |k, o, c| {
            let r2 = o.states[0][0].powi(2) + o.states[0][1].powi(2);
            if r2 > 1.2 || observer(k, o, c).is_break() {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    )
    .unwrap()
}

#[test]
fn a_subcritical_branch_turns_at_its_fold_and_becomes_stable() {
    let problem = quintic();
    let field = VectorField(&problem);
    let branch = quintic_branch(|_, _, _| ControlFlow::Continue(()));
    let folds: Vec<_> = branch
        .events
        .iter()
        .filter(|e| e.kind == OrbitEventKind::Fold)
        .collect();
    let stability: Vec<_> = branch
        .events
        .iter()
        .filter(|e| e.kind == OrbitEventKind::CycleFold)
        .collect();
    eprintln!("events {:?}", branch.events);
    assert_eq!(folds.len(), 1);
    assert_eq!(stability.len(), 1);
    let (p0, p1) = folds[0].p;
    assert!(p0.min(p1) > -0.26 && p0.max(p1) < -0.2, "{p0} {p1}");
    for o in &branch.orbits {
        let r2 = o.amplitude(&field, Some(&[0.0, 0.0])).powi(2);
        assert!((o.p - (r2 * r2 - r2)).abs() < 2e-3, "p {} r2 {r2}", o.p);
        if (r2 - 0.5).abs() > 0.05 {
            assert_eq!(o.unstable, usize::from(r2 < 0.5), "r2 {r2}");
        }
    }
}

/// Near the Brusselator's Hopf point `b = 1 + a^2` the orbits' mean square amplitude about the
/// steady state is `-2 Re s / (w l1)` (`l1` for `<q, q> = 1`), `Re s = (b - 1 - a^2)/2`: it grows
/// with `b` at the slope `-1 / (w l1)`. The slope is compared (the discrete Hopf point lies
/// `O(w (w h)^3)` away from the exact one, which shifts the amplitudes but not their slope).
#[test]
fn brusselator_orbits_grow_at_the_rate_the_lyapunov_coefficient_predicts() {
    let a = 2.0;
    let problem = brusselator(a);
    let bh = 1.0 + a * a;
    let uh = [a, bh / a];
    let lin = problem.linearize(&uh, bh).unwrap();
    let lyap = first_lyapunov(&problem, &uh, bh, &lin, c64::new(0.0, a))
        .unwrap()
        .unwrap();
    assert!(lyap.l1 < 0.0, "the Brusselator is supercritical");
    let field = VectorField(&problem);
    let start = HopfStart {
        u: uh.to_vec(),
        p: bh,
        frequency: a,
        mode: lyap.q.clone(),
    };
    let settings = branch_settings(400, 0.01, 4);
    let branch = follow_orbits(
        &field,
        &start,
        &settings,
        (bh - 1.0, bh + 1.0),
        |_, _, _| ControlFlow::Continue(()),
    )
    .unwrap();
    let points: Vec<(f64, f64)> = branch
        .orbits
        .iter()
        .map(|o| (o.p, o.amplitude(&field, Some(&[a, o.p / a])).powi(2)))
        .collect();
    let predicted = -1.0 / (a * lyap.l1);
    let mut errors = Vec::new();
    for pair in points.windows(2) {
        let slope = (pair[1].1 - pair[0].1) / (pair[1].0 - pair[0].0);
        errors.push((slope / predicted - 1.0).abs());
        eprintln!(
            "b - b_H from {:.3e} to {:.3e}: slope of the mean square amplitude {slope:.5},              predicted {predicted:.5}",
            pair[0].0 - bh,
            pair[1].0 - bh
        );
    }
    for o in &branch.orbits {
        assert!(o.p > bh);
        assert_eq!(o.unstable, 0);
    }
    eprintln!("relative errors of the slope {errors:?}");
    assert!(errors[0] < 1e-2, "{errors:?}");
    // The error is O(b - b_H): it grows along the branch.
    assert!(errors[0] < errors[errors.len() - 1], "{errors:?}");
}

/// A branch interrupted after its fifth orbit and resumed from the checkpoint it was handed
/// gives the same orbits as the uninterrupted run.
#[test]
fn a_resumed_branch_continues_exactly_as_the_uninterrupted_one() {
    let problem = hopf_cubic(1.0, -1.0, 0.3);
    let field = VectorField(&problem);
    let start = origin(1.0);
    let settings = branch_settings(100, 0.02, 8);
    let whole = follow_orbits(&field, &start, &settings, (-1.0, 1.0), |_, _, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(whole.orbits.len(), 8);
    let mut saved = None;
    let interrupted = follow_orbits(&field, &start, &settings, (-1.0, 1.0), |k, _, c| {
        saved = c.cloned();
        if k == 4 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    })
    .unwrap();
    assert_eq!(interrupted.orbits.len(), 5);
    // The checkpoint goes through its file format.
    let text = serde_json::to_string(&saved.unwrap()).unwrap();
    let checkpoint: Checkpoint = serde_json::from_str(&text).unwrap();
    assert_eq!(checkpoint.next_index, 5);
    let resumed = resume_orbits(&field, &checkpoint, &settings, (-1.0, 1.0), |_, _, _| {
        ControlFlow::Continue(())
    })
    .unwrap();
    assert_eq!(resumed.first_index, 5);
    assert_eq!(resumed.orbits.len(), 3);
    for (a, b) in resumed.orbits.iter().zip(&whole.orbits[5..]) {
        assert!(
            (a.p - b.p).abs() <= 1e-12 * (1.0 + b.p.abs()),
            "{} {}",
            a.p,
            b.p
        );
        assert!((a.period - b.period).abs() <= 1e-12 * b.period);
    }
}

/// A branch interrupted after its fold and its change of stability, and resumed from the
/// checkpoint (through its file format), reports the same events as the uninterrupted run.
#[test]
fn a_resumed_branch_keeps_the_events_found_before_the_interruption() {
    let whole = quintic_branch(|_, _, _| ControlFlow::Continue(()));
    assert_eq!(whole.events.len(), 2, "{:?}", whole.events);
    let last_event = whole.events.iter().map(|e| e.after + 1).max().unwrap();
    let mut saved = None;
    quintic_branch(|k, _, c| {
        saved = c.cloned();
        if k == last_event + 1 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    let text = serde_json::to_string(&saved.unwrap()).unwrap();
    let checkpoint: Checkpoint = serde_json::from_str(&text).unwrap();
    assert_eq!(checkpoint.events, whole.events);
    let problem = quintic();
    let field = VectorField(&problem);
    let resumed = resume_orbits(
        &field,
        &checkpoint,
        &branch_settings(200, 0.05, 60),
        (-1.0, 0.5),
        |_, o, _| {
            let r2 = o.states[0][0].powi(2) + o.states[0][1].powi(2);
            if r2 > 1.2 {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        },
    )
    .unwrap();
    assert_eq!(resumed.first_index, last_event + 2);
    assert_eq!(resumed.events, whole.events);
    assert_eq!(
        resumed.first_index + resumed.orbits.len(),
        whole.orbits.len()
    );
}

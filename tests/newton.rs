//! The one Newton solver (`continuation::newton`) on a system with a known root: Newton's method
//! proper converges quadratically, the chord method linearly with one factorization, kept across
//! solves; the line search brings a far start into the basin with a monotone residual.

use faer::Mat;
use helixbif::Result;
use helixbif::engine::newton::{Chord, Globalization, Jacobians, Newton, System};
use helixbif::numerics::lu::Lu;

/// `G(x, y) = (x^2 + y^2 - 4, x y - 1)`: roots where the circle of radius 2 meets the hyperbola
/// `x y = 1`, `x = sqrt(2 + sqrt 3) = 1.9318516525781366`, `y = 1/x` in the first quadrant.
struct CircleHyperbola;

const X_ROOT: f64 = 1.931_851_652_578_136_6;

impl System for CircleHyperbola {
    fn residual(&self, u: &[f64]) -> Result<Vec<f64>> {
        Ok(vec![u[0] * u[0] + u[1] * u[1] - 4.0, u[0] * u[1] - 1.0])
    }
    fn residual_and_jacobian(&self, u: &[f64]) -> Result<(Vec<f64>, Mat<f64>)> {
        let jac = Mat::from_fn(2, 2, |i, j| match (i, j) {
            (0, 0) => 2.0 * u[0],
            (0, 1) => 2.0 * u[1],
            (1, 0) => u[1],
            _ => u[0],
        });
        Ok((self.residual(u)?, jac))
    }
}

fn newton(tol: f64, globalization: Globalization) -> Newton {
    Newton {
        tol,
        max_iter: 60,
        min_steps: 0,
        globalization,
    }
}

fn error(u: &[f64]) -> f64 {
    ((u[0] - X_ROOT).powi(2) + (u[1] - 1.0 / X_ROOT).powi(2)).sqrt()
}

#[test]
fn newton_proper_converges_quadratically_and_the_chord_linearly_with_one_factorization() {
    let start = vec![2.1, 0.6];
    let (u, report) = newton(1e-14, Globalization::Full)
        .run(&CircleHyperbola, start.clone(), Jacobians::Fresh, "test")
        .unwrap();
    assert!(error(&u) < 1e-14, "error {:e}", error(&u));
    // Quadratic: |G_{k+1}| <= C |G_k|^2 with a modest C once in the basin.
    let h = &report.history;
    for k in 1..h.len() - 1 {
        if h[k] < 1e-2 && h[k + 1] > 1e-15 {
            assert!(h[k + 1] <= 5.0 * h[k] * h[k], "history {h:?}");
        }
    }
    let mut chord = Chord::default();
    let (v, chord_report) = newton(1e-12, Globalization::Full)
        .run(
            &CircleHyperbola,
            start,
            Jacobians::Reuse(&mut chord),
            "test",
        )
        .unwrap();
    assert!(error(&v) < 1e-11, "chord error {:e}", error(&v));
    assert!(chord_report.iterations > report.iterations);
    // A factor of at least 3 per iteration keeps the first factorization.
    assert_eq!(chord.built, 1, "{:?}", chord_report.history);
    // Kept across solves: a second solve from a nearby start factorizes nothing.
    let (w, _) = newton(1e-12, Globalization::Full)
        .run(
            &CircleHyperbola,
            vec![1.95, 0.5],
            Jacobians::Reuse(&mut chord),
            "test",
        )
        .unwrap();
    assert!(error(&w) < 1e-11);
    assert_eq!(chord.built, 1);
}

#[test]
fn the_line_search_reaches_the_root_monotonically_from_a_far_start_and_a_failure_names_its_context()
{
    // The damped step with no growth allowed (max_growth = 1: a monotone residual) reaches the
    // root from far off.
    let start = vec![20.0, 0.05];
    let damped = newton(
        1e-13,
        Globalization::Backtrack {
            min_damping: 1.0 / 1024.0,
            max_growth: 1.0,
        },
    );
    let (u, report) = damped
        .run(&CircleHyperbola, start.clone(), Jacobians::Fresh, "test")
        .unwrap();
    assert!(error(&u) < 1e-13, "{u:?}");
    for pair in report.history.windows(2) {
        assert!(pair[1] <= pair[0], "not monotone: {:?}", report.history);
    }
    let limited = Newton {
        max_iter: 3,
        ..newton(1e-13, Globalization::Full)
    };
    let failed = limited.run(&CircleHyperbola, start, Jacobians::Fresh, "far start");
    let message = failed.unwrap_err().to_string();
    assert!(
        message.contains("far start") && message.contains("3 iterations"),
        "{message}"
    );
}

#[test]
fn a_stale_chord_whose_step_makes_the_residual_grow_is_dropped_at_the_point_it_started_from() {
    // The factorized Jacobian of a far point (a chord inherited from elsewhere, e.g. an earlier
    // time step): from `start` its step overshoots and the residual grows.
    let start = vec![2.1, 0.6];
    let far = [0.4, -1.5];
    let (_, stale) = CircleHyperbola.residual_and_jacobian(&far).unwrap();
    let mut chord = Chord::holding(Lu::new(stale.as_ref()));
    let (u, report) = newton(1e-12, Globalization::Full)
        .run(
            &CircleHyperbola,
            start.clone(),
            Jacobians::Reuse(&mut chord),
            "test",
        )
        .unwrap();
    let h = &report.history;
    println!("history {h:?}, built {}", chord.built);
    // The stale step made the residual grow; the iteration went back to `start` (the same
    // residual, to the bit), factorized there, and converged with that one factorization.
    let g0 = h[0];
    assert!(h[1] == g0, "back at the start: {h:?}");
    assert!(error(&u) < 1e-11, "error {:e}", error(&u));
    assert_eq!(chord.built, 2, "{h:?}");
    // Without the retreat the chord would be rebuilt at the grown iterate: the history never
    // holds a residual above the start's.
    assert!(h.iter().all(|&g| g <= g0), "{h:?}");
}

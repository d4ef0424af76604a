//! The first Lyapunov coefficient (`continuation::criticality`) against closed forms: the Hopf
//! normal form with known coefficients (plain and in curved coordinates, where the differences
//! are not exact), the Brusselator, and the amplitude of the Brusselator's periodic orbit from a
//! long simulation (the square-root law, independent of the formula).

use std::rc::Rc;

use faer::{Mat, c64};
use helixbif::Result;
use helixbif::engine::arclength::{Limits, follow};
use helixbif::engine::criticality::{
    Lyapunov, STARTS, Verdict, first_lyapunov, first_lyapunov_from,
};
use helixbif::engine::curve::{CurvePoint, CurveSettings, follow_curve};
use helixbif::engine::reference::{Members, brusselator, hopf_cubic};
use helixbif::engine::stop::{Silent, Stop};
use helixbif::engine::{ContinuationSettings, Field, Linearization, Problem};

fn lyapunov_at(problem: &impl Problem, u: &[f64], p: f64, s: c64) -> Lyapunov {
    let lin = problem.linearize(u, p).unwrap();
    first_lyapunov(problem, u, p, &lin, s)
        .unwrap()
        .expect("dynamics defined")
}

/// The coefficient of the tableau started at `start` alone (in units of the first start).
fn lyapunov_from(problem: &impl Problem, u: &[f64], p: f64, s: c64, start: f64) -> Lyapunov {
    let lin = problem.linearize(u, p).unwrap();
    first_lyapunov_from(problem, u, p, &lin, s, &[start])
        .unwrap()
        .expect("dynamics defined")
}

#[test]
fn the_normal_form_gives_its_coefficient_and_its_verdict() {
    for (w, a, b) in [(1.0, -1.0, 0.0), (1.7, -0.8, 0.3), (0.6, 0.45, -1.2)] {
        let l = lyapunov_at(&hopf_cubic(w, a, b), &[0.0, 0.0], 0.0, c64::new(0.0, w));
        let exact = 2.0 * a / w;
        eprintln!(
            "normal form w {w} a {a}: l1 {:e}, relative error {:.1e}, precision {:.1e}",
            l.l1,
            (l.l1 / exact - 1.0).abs(),
            l.precision
        );
        assert!(
            (l.l1 - exact).abs() <= 1e-6 * exact.abs(),
            "w {w} a {a}: l1 {} against {exact}",
            l.l1
        );
        assert!(
            l.precision < 1e-6 * exact.abs(),
            "precision {}",
            l.precision
        );
        assert!((l.l1 - exact).abs() <= l.precision);
        let expected = if a < 0.0 {
            Verdict::Supercritical
        } else {
            Verdict::Subcritical
        };
        assert_eq!(l.verdict, expected);
        assert!((l.frequency - w).abs() < 1e-15);
    }
    // A degenerate point (a = 0: no cubic term) is not given a side.
    let l = lyapunov_at(
        &hopf_cubic(1.3, 0.0, 0.7),
        &[0.0, 0.0],
        0.0,
        c64::new(0.0, 1.3),
    );
    assert!(l.l1.abs() < 1e-9, "{}", l.l1);
    assert_eq!(l.verdict, Verdict::Undetermined);
}

/// The normal form `f` seen through the near-identity change of coordinates
/// `u = phi(v) = v + k (0.4 v1 v2 + 0.3 sin(v2)^2, 0.5 v1^2 - 0.2 (exp(v1 v2) - 1))`: the
/// dynamics `v' = Dphi(v)^{-1} f(phi(v))` has the same linear part at 0 and the same Lyapunov
/// coefficient, but its differences are not exact (no polynomial of low degree; `k` sets how
/// far from it). With `c > 0` each component of the field is rounded to the grid of `c`'s
/// last bit (`(f + c) - c`): the round-off of terms of size `c` that cancel, as a stiff rod's
/// do, without changing `l1`.
struct Curved {
    w: f64,
    a: f64,
    b: f64,
    k: f64,
    c: f64,
}

impl Curved {
    fn field(&self, v: &[f64], p: f64) -> Vec<f64> {
        let (v1, v2) = (v[0], v[1]);
        let e = (v1 * v2).exp();
        // `k` on each term: at `k = 1` the same floating-point operations as without it.
        let k = self.k;
        let u = [
            v1 + k * 0.4 * v1 * v2 + k * 0.3 * v2.sin().powi(2),
            v2 + k * 0.5 * v1 * v1 - k * 0.2 * (e - 1.0),
        ];
        let f = (hopf_cubic(self.w, self.a, self.b).g)(&u, p);
        // Dphi = [[1 + 0.4 k v2, k (0.4 v1 + 0.6 sin v2 cos v2)], [k (v1 - 0.2 v2 e),
        // 1 - 0.2 k v1 e]].
        let (j11, j12) = (
            1.0 + k * 0.4 * v2,
            k * (0.4 * v1 + 0.6 * v2.sin() * v2.cos()),
        );
        let (j21, j22) = (k * (v1 - 0.2 * v2 * e), 1.0 - k * 0.2 * v1 * e);
        let det = j11 * j22 - j12 * j21;
        let c = self.c;
        vec![
            ((j22 * f[0] - j12 * f[1]) / det + c) - c,
            ((-j21 * f[0] + j11 * f[1]) / det + c) - c,
        ]
    }
}

impl Problem for Curved {
    fn dim(&self) -> usize {
        2
    }
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        Ok(self.field(u, p))
    }
    /// The Jacobian by central differences (step 1e-6, error ~1e-12): the linear part.
    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        let h = 1e-6;
        let column = |j: usize| {
            let mut plus = u.to_vec();
            let mut minus = u.to_vec();
            plus[j] += h;
            minus[j] -= h;
            let (fp, fm) = (self.field(&plus, p), self.field(&minus, p));
            [(fp[0] - fm[0]) / (2.0 * h), (fp[1] - fm[1]) / (2.0 * h)]
        };
        let (c0, c1) = (column(0), column(1));
        Ok(Linearization {
            g: self.field(u, p),
            g_u: Mat::from_fn(2, 2, |i, j| if j == 0 { c0[i] } else { c1[i] }),
            g_p: u.to_vec(),
        })
    }
    fn stability_pair(
        &self,
        _u: &[f64],
        _p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        Ok((lin.g_u.clone(), Mat::identity(2, 2)))
    }
    fn dynamics(&self, u: &[f64], p: f64) -> Option<Result<Field<'_>>> {
        let u = u.to_vec();
        Some(Ok(Box::new(move |y: &[f64]| {
            let at: Vec<f64> = u.iter().zip(y).map(|(a, b)| a + b).collect();
            Ok(self.field(&at, p))
        })))
    }
}

#[test]
fn the_coefficient_is_invariant_under_a_curved_change_of_coordinates() {
    // Each start of the tableau alone (the wider one serves where the first is undetermined).
    for ((w, a, b), start) in [(1.0, -1.0, 0.0), (1.7, -0.8, 0.3), (0.6, 0.45, -1.2)]
        .into_iter()
        .flat_map(|c| STARTS.map(|start| (c, start)))
    {
        let l = lyapunov_from(
            &Curved {
                w,
                a,
                b,
                k: 1.0,
                c: 0.0,
            },
            &[0.0, 0.0],
            0.0,
            c64::new(0.0, w),
            start,
        );
        let exact = 2.0 * a / w;
        eprintln!(
            "curved w {w} a {a}, start {start}: l1 {:e}, relative error {:.1e}, precision {:.1e}",
            l.l1,
            (l.l1 / exact - 1.0).abs(),
            l.precision
        );
        assert!(
            (l.l1 - exact).abs() <= 1e-6 * exact.abs(),
            "w {w} a {a}: l1 {} against {exact} (precision {:e})",
            l.l1,
            l.precision
        );
        // The stated precision covers the error.
        assert!((l.l1 - exact).abs() <= l.precision);
    }
}

/// Closed form for the Brusselator `x' = a - (b + 1) x + x^2 y`, `y' = b x - x^2 y` at its Hopf
/// point `b = 1 + a^2` (frequency `a`), for `<q, q> = 1`: `l1 = -(a^2 + 2) / (2 a (2 a^2 + 1))`:
/// Kuznetsov's invariant formula (Elements of Applied Bifurcation Theory, 3rd ed., eq. 3.20)
/// evaluated symbolically (sympy, exact derivatives; `l1` does not depend on the phase of `q`).
/// Its sign, supercritical for every `a > 0`, is the classic result (e.g. the worked
/// Mathematica example "Hopf bifurcation analysis", mathematica.stackexchange.com, question
/// 159731).
fn brusselator_l1(a: f64) -> f64 {
    -(a * a + 2.0) / (2.0 * a * (2.0 * a * a + 1.0))
}

#[test]
fn the_brusselator_matches_its_closed_form() {
    for a in [0.5, 1.0, 2.0, 3.0] {
        let b = 1.0 + a * a;
        let l = lyapunov_at(&brusselator(a), &[a, b / a], b, c64::new(0.0, a));
        let exact = brusselator_l1(a);
        eprintln!(
            "Brusselator a {a}: l1 {:e}, relative error {:.1e}, precision {:.1e}",
            l.l1,
            (l.l1 / exact - 1.0).abs(),
            l.precision
        );
        assert!(
            (l.l1 - exact).abs() <= 1e-6 * exact.abs(),
            "a {a}: l1 {} against {exact}",
            l.l1
        );
        assert!((l.l1 - exact).abs() <= l.precision);
        assert_eq!(l.verdict, Verdict::Supercritical);
    }
}

/// The half peak-to-peak amplitude of `x` on the attracting orbit of the Brusselator at `(a, b)`,
/// by RK4 from `start` over `t_end`, measured over the last `2 pi / a * 3` of time.
fn simulated_amplitude(a: f64, b: f64, start: [f64; 2], t_end: f64) -> f64 {
    let f = |u: [f64; 2]| {
        let (x, y) = (u[0], u[1]);
        [a - (b + 1.0) * x + x * x * y, b * x - x * x * y]
    };
    let dt = 0.01;
    let steps = (t_end / dt) as usize;
    let window = (3.0 * 2.0 * std::f64::consts::PI / a / dt) as usize;
    let mut u = start;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..steps {
        let add = |u: [f64; 2], d: [f64; 2], c: f64| [u[0] + c * d[0], u[1] + c * d[1]];
        let k1 = f(u);
        let k2 = f(add(u, k1, 0.5 * dt));
        let k3 = f(add(u, k2, 0.5 * dt));
        let k4 = f(add(u, k3, dt));
        for i in 0..2 {
            u[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
        }
        if k + window >= steps {
            lo = lo.min(u[0]);
            hi = hi.max(u[0]);
        }
    }
    0.5 * (hi - lo)
}

#[test]
fn the_brusselator_orbit_grows_as_the_square_root_the_coefficient_predicts() {
    // Past the Hopf point b = 1 + a^2 + eps the orbit is y = z q e^{i w t} + c.c. with
    // |z|^2 = -sigma' eps / (w l1), sigma' = d Re s / db = 1/2: the amplitude of x is
    // 2 |z| |q_x|, up to a relative O(eps).
    let a = 1.0;
    let b_h = 1.0 + a * a;
    let l = lyapunov_at(&brusselator(a), &[a, b_h / a], b_h, c64::new(0.0, a));
    let q_x = (l.q.0[0].powi(2) + l.q.1[0].powi(2)).sqrt();
    let mut errors = Vec::new();
    for eps in [4e-3, 1e-3] {
        let predicted = 2.0 * (-0.5 * eps / (a * l.l1)).sqrt() * q_x;
        let b = b_h + eps;
        let start = [a + predicted, b / a];
        let simulated = simulated_amplitude(a, b, start, 8.0 / eps);
        errors.push((simulated / predicted - 1.0).abs());
    }
    eprintln!("orbit amplitude against the square-root law, eps = 4e-3, 1e-3: {errors:?}");
    assert!(errors[1] < 2e-3, "relative errors {errors:?}");
    // O(eps): four times smaller eps, about four times smaller error.
    assert!(errors[1] < 0.4 * errors[0], "relative errors {errors:?}");
}

#[test]
fn the_stated_precision_of_l1_covers_its_error_along_the_brusselator_hopf_curve() {
    // The Hopf curve b = 1 + a^2 over a in [0.2, 6] with every point's coefficient (steps of
    // at most 0.005 in the curve's units: about 750 points), and the coefficient at 400 points
    // b = 1 + a^2 spaced evenly in a over the same range, against the closed form
    // [`brusselator_l1`]: the error exceeds the stated precision nowhere.
    let family = Members(brusselator);
    let a0 = 0.2;
    let b0 = 1.0 + a0 * a0;
    let continuation = ContinuationSettings {
        event_tol: 1e-10,
        tol: 1e-12,
        ..ContinuationSettings::default()
    };
    let branch = follow(
        &brusselator(a0),
        vec![a0, (b0 - 0.5) / a0],
        b0 - 0.5,
        1.0,
        &continuation,
        &Limits {
            p_min: 0.0,
            p_max: b0 + 1.0,
            stop_at_first_instability: true,
        },
        &mut Silent,
    )
    .unwrap();
    let event = branch.first_loss_of_stability().unwrap().clone();
    let mut settings = CurveSettings::new(a0, 6.0);
    settings.criticality = true;
    settings.ds = 0.005;
    settings.ds_max = 0.005;
    let (curve, _) = follow_curve(
        &family,
        CurvePoint::at_event(event, a0),
        Rc::new(brusselator(a0)),
        1.0,
        &settings,
        &continuation,
        &mut Silent,
    )
    .unwrap();
    assert_eq!(curve.stop, Stop::ParameterLimit);
    let mut exceeded = Vec::new();
    let mut worst: f64 = 0.0;
    for point in &curve.points {
        let l = point
            .lyapunov
            .as_ref()
            .expect("every point has its coefficient");
        let error = (l.l1 - brusselator_l1(point.q)).abs();
        worst = worst.max(error / l.precision);
        if error > l.precision {
            exceeded.push((point.q, error, l.precision));
        }
    }
    eprintln!(
        "Brusselator curve: {} points, precision exceeded at {} (worst error / precision {worst:.2})",
        curve.points.len(),
        exceeded.len()
    );
    // At the exact Hopf points, each start of the tableau alone: the precision of the wider
    // one (which serves where the first leaves the sign undetermined) covers its error too.
    let mut missed = Vec::new();
    for start in STARTS {
        let mut worst_exact: f64 = 0.0;
        for k in 0..400 {
            let a = a0 + (6.0 - a0) * k as f64 / 399.0;
            let b = 1.0 + a * a;
            let l = lyapunov_from(&brusselator(a), &[a, b / a], b, c64::new(0.0, a), start);
            let error = (l.l1 - brusselator_l1(a)).abs();
            worst_exact = worst_exact.max(error / l.precision);
            if error > l.precision {
                missed.push((start, a, error, l.precision));
            }
        }
        eprintln!(
            "Brusselator, 400 exact Hopf points, start {start}: worst error / precision \
             {worst_exact:.2}"
        );
    }
    assert!(exceeded.is_empty(), "{exceeded:?}");
    assert!(missed.is_empty(), "{missed:?}");
}

/// Where the first tableau leaves the sign of `l1` undetermined, the one started four times
/// wider is tried and kept when it settles it ([`STARTS`]); where neither does, the one of least
/// precision is kept. On the curved normal form (`w = 1`, `a = 3e-4`: `l1 = 6e-4`) with its
/// field rounded as terms of size `1e4` that cancel would round it, at `k = 10` the first start
/// gives `9.7e-5 +- 4.1e-3` and the wider `6.039e-4 +- 1.7e-5` (error `3.9e-6`); at `k = 20`,
/// where the wider start's steps reach the coordinates' own scale, `3.7e-4 +- 5.9e-4` and
/// `0.23 +- 2e2`. Each answer's precision covers its error against the closed form.
#[test]
fn the_wider_tableau_is_kept_where_it_settles_what_the_first_leaves_undetermined() {
    let (w, a, b) = (1.0, 3e-4, 0.5);
    let exact = 2.0 * a / w;
    let s = c64::new(0.0, w);
    for (k, settled_by_the_wider) in [(10.0, true), (20.0, false)] {
        let field = Curved { w, a, b, k, c: 1e4 };
        let [first, wider] = STARTS.map(|start| lyapunov_from(&field, &[0.0, 0.0], 0.0, s, start));
        let kept = lyapunov_at(&field, &[0.0, 0.0], 0.0, s);
        eprintln!(
            "k {k}: first {:e} +- {:.1e}, wider {:e} +- {:.1e}, kept {:e} +- {:.1e}",
            first.l1, first.precision, wider.l1, wider.precision, kept.l1, kept.precision
        );
        assert_eq!(first.verdict, Verdict::Undetermined);
        for l in [&first, &wider, &kept] {
            assert!(
                (l.l1 - exact).abs() <= l.precision,
                "{} +- {}",
                l.l1,
                l.precision
            );
        }
        if settled_by_the_wider {
            assert_eq!(wider.verdict, Verdict::Subcritical);
            assert_eq!((kept.l1, kept.precision), (wider.l1, wider.precision));
            assert_eq!(kept.verdict, Verdict::Subcritical);
            assert!((kept.l1 - exact).abs() < 0.05 * exact);
        } else {
            assert_eq!(wider.verdict, Verdict::Undetermined);
            assert!(first.precision < wider.precision);
            assert_eq!((kept.l1, kept.precision), (first.l1, first.precision));
            assert_eq!(kept.verdict, Verdict::Undetermined);
        }
    }
}

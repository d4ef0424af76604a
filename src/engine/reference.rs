//! Canonical problems with exact answers, for the tests and benchmarks of the engine. Compiled
//! with the feature `reference-problems` only, which the tests and benchmarks get through the
//! crate's dev-dependency on itself (Cargo.toml).

use faer::Mat;

use super::{Field, Linearization, Problem};
use crate::Result;

/// A small dense problem given by closures: `G(u, p)`, `G_u`, `G_p`; stability pair `(G_u, I)`.
pub struct Analytic<G, J, P>
where
    G: Fn(&[f64], f64) -> Vec<f64>,
    J: Fn(&[f64], f64) -> Vec<Vec<f64>>,
    P: Fn(&[f64], f64) -> Vec<f64>,
{
    pub dim: usize,
    pub g: G,
    pub g_u: J,
    pub g_p: P,
}

impl<G, J, P> Problem for Analytic<G, J, P>
where
    G: Fn(&[f64], f64) -> Vec<f64> + Sync,
    J: Fn(&[f64], f64) -> Vec<Vec<f64>>,
    P: Fn(&[f64], f64) -> Vec<f64>,
{
    fn dim(&self) -> usize {
        self.dim
    }
    fn residual(&self, u: &[f64], p: f64) -> Result<Vec<f64>> {
        Ok((self.g)(u, p))
    }
    fn linearize(&self, u: &[f64], p: f64) -> Result<Linearization> {
        let j = (self.g_u)(u, p);
        Ok(Linearization {
            g: (self.g)(u, p),
            g_u: Mat::from_fn(self.dim, self.dim, |r, c| j[r][c]),
            g_p: (self.g_p)(u, p),
        })
    }
    fn stability_pair(
        &self,
        _u: &[f64],
        _p: f64,
        lin: &Linearization,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        Ok((lin.g_u.clone(), Mat::identity(self.dim, self.dim)))
    }
    /// `du/dt = G(u + y, p)`.
    fn dynamics(&self, u: &[f64], p: f64) -> Option<Result<Field<'_>>> {
        let (u, g) = (u.to_vec(), &self.g);
        Some(Ok(Box::new(move |y: &[f64]| {
            let at: Vec<f64> = u.iter().zip(y).map(|(a, b)| a + b).collect();
            Ok(g(&at, p))
        })))
    }
}

/// Boxed closure types of the reference problems.
pub type Residual = Box<dyn Fn(&[f64], f64) -> Vec<f64> + Sync>;
pub type Jacobian = Box<dyn Fn(&[f64], f64) -> Vec<Vec<f64>> + Sync>;
/// A reference problem.
pub type Reference = Analytic<Residual, Jacobian, Residual>;

/// Fold: `du/dt = u^2 - p`; the branch `p = u^2` turns back at `p = 0` (stable for `u < 0`).
pub fn fold() -> Reference {
    Analytic {
        dim: 1,
        g: Box::new(|u, p| vec![u[0] * u[0] - p]),
        g_u: Box::new(|u, _| vec![vec![2.0 * u[0]]]),
        g_p: Box::new(|_, _| vec![-1.0]),
    }
}

/// Pitchfork with imperfection `eps`: `du/dt = p u - u^3 + eps`. For `eps = 0` the trivial branch
/// loses stability at a branch point `p = 0`; for `eps > 0` the branch through `u > 0` is smooth
/// and stable, and the other one has a fold at `p = 3 (eps/2)^(2/3)`, `u = -(eps/2)^(1/3)`.
pub fn pitchfork(eps: f64) -> Reference {
    Analytic {
        dim: 1,
        g: Box::new(move |u, p| vec![p * u[0] - u[0].powi(3) + eps]),
        g_u: Box::new(|u, p| vec![vec![p - 3.0 * u[0] * u[0]]]),
        g_p: Box::new(|u, _| vec![u[0]]),
    }
}

/// Hopf normal form: `x' = p x - y - x r^2`, `y' = x + p y - y r^2`; the origin has eigenvalues
/// `p +- i`: a Hopf point at `p = 0` with frequency 1.
pub fn hopf_normal_form() -> Reference {
    hopf_unfolded(|p| p, |_| 1.0)
}

/// The Hopf normal form with cubic coefficients `a + i b`: `x' = p x - w y + (a x - b y) r^2`,
/// `y' = w x + p y + (b x + a y) r^2`. In polar coordinates `r' = p r + a r^3`,
/// `phi' = w + b r^2`: for `p a < 0` the orbit `r^2 = -p/a` of period `2 pi / (w + b r^2)`, with
/// the nontrivial Floquet multiplier `exp(-2 p T)`. With `<q, q> = 1` (`y = z q + conj(z q)`, `|y|^2 = 2 |z|^2`)
/// `c1 = 2 (a + i b)` and `l1 = 2 a / w`.
pub fn hopf_cubic(w: f64, a: f64, b: f64) -> Reference {
    Analytic {
        dim: 2,
        g: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            vec![
                p * x - w * y + (a * x - b * y) * r2,
                w * x + p * y + (b * x + a * y) * r2,
            ]
        }),
        g_u: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            vec![
                vec![
                    p + a * r2 + 2.0 * x * (a * x - b * y),
                    -w - b * r2 + 2.0 * y * (a * x - b * y),
                ],
                vec![
                    w + b * r2 + 2.0 * x * (b * x + a * y),
                    p + a * r2 + 2.0 * y * (b * x + a * y),
                ],
            ]
        }),
        g_p: Box::new(|u, _| vec![u[0], u[1]]),
    }
}

/// Brusselator with parameter `p = b`: `x' = a - (b + 1) x + x^2 y`, `y' = b x - x^2 y`; the
/// steady state `(a, b/a)` has a Hopf point at `b = 1 + a^2` with frequency `a`.
pub fn brusselator(a: f64) -> Reference {
    Analytic {
        dim: 2,
        g: Box::new(move |u, b| {
            let (x, y) = (u[0], u[1]);
            vec![a - (b + 1.0) * x + x * x * y, b * x - x * x * y]
        }),
        g_u: Box::new(|u, b| {
            let (x, y) = (u[0], u[1]);
            vec![
                vec![-(b + 1.0) + 2.0 * x * y, x * x],
                vec![b - 2.0 * x * y, -x * x],
            ]
        }),
        g_p: Box::new(|u, _| vec![-u[0], u[0]]),
    }
}

/// A two-parameter family given by a closure `q -> member` (members solved from the same
/// unknowns).
pub struct Members<F>(pub F);

impl<F: Fn(f64) -> Reference> super::curve::Family for Members<F> {
    type Member = Reference;
    fn member(&self, q: f64) -> Result<Reference> {
        Ok((self.0)(q))
    }
}

/// Two uncoupled Hopf normal forms `z_k' = (mu_k + i w_k) z_k - z_k |z_k|^2` with
/// `mu_1 = p - q - 0.3 q^2`, `w_1 = 1` and `mu_2 = p + q - 1`, `w_2 = 2`, unknowns
/// `(x_1, y_1, x_2, y_2)`. The origin's Hopf curves in `(p, q)` are `p = q + 0.3 q^2` and
/// `p = 1 - q`; they cross at the double Hopf point `q = (sqrt(5.2) - 2)/0.6`. Below both
/// curves the origin is stable, so the first loss of stability in `p` moves from the first
/// curve to the second there.
pub fn double_hopf(q: f64) -> Reference {
    let mu = move |p: f64| [p - q - 0.3 * q * q, p + q - 1.0];
    const W: [f64; 2] = [1.0, 2.0];
    Analytic {
        dim: 4,
        g: Box::new(move |u, p| {
            let mu = mu(p);
            (0..2)
                .flat_map(|k| {
                    let (x, y) = (u[2 * k], u[2 * k + 1]);
                    let r2 = x * x + y * y;
                    [mu[k] * x - W[k] * y - x * r2, W[k] * x + mu[k] * y - y * r2]
                })
                .collect()
        }),
        g_u: Box::new(move |u, p| {
            let mu = mu(p);
            let mut j = vec![vec![0.0; 4]; 4];
            for k in 0..2 {
                let (x, y) = (u[2 * k], u[2 * k + 1]);
                let (r, c) = (2 * k, 2 * k);
                j[r][c] = mu[k] - 3.0 * x * x - y * y;
                j[r][c + 1] = -W[k] - 2.0 * x * y;
                j[r + 1][c] = W[k] - 2.0 * x * y;
                j[r + 1][c + 1] = mu[k] - x * x - 3.0 * y * y;
            }
            j
        }),
        g_p: Box::new(|u, _| u.to_vec()),
    }
}

/// A Hopf normal form with `mu = p^2 + q^2 - 1`, frequency 1: its Hopf curve is the unit circle
/// in `(p, q)`, which turns back in `q` at `(0, +-1)`.
pub fn hopf_circle(q: f64) -> Reference {
    hopf_unfolded(move |p| p * p + q * q - 1.0, |p| 2.0 * p)
}

/// A Hopf normal form with `mu = p^2 + p^3 + q - 1`, frequency 1: its Hopf curve
/// `q = 1 - p^2 - p^3` turns back in `q` at `(0, 1)`, where, unlike the circle's, it is not
/// symmetric about its turning point.
pub fn hopf_cubic_fold(q: f64) -> Reference {
    hopf_unfolded(
        move |p| p * p * (1.0 + p) + q - 1.0,
        |p| p * (2.0 + 3.0 * p),
    )
}

/// The Hopf normal form `z' = (mu(p) + i) z - |z|^2 z` in `u = (Re z, Im z)`, `dmu = mu'`: its
/// steady state `u = 0` has the eigenvalues `mu(p) +- i`, a Hopf point where `mu` vanishes.
fn hopf_unfolded(
    mu: impl Fn(f64) -> f64 + Copy + Send + Sync + 'static,
    dmu: impl Fn(f64) -> f64 + Send + Sync + 'static,
) -> Reference {
    Analytic {
        dim: 2,
        g: Box::new(move |u, p| {
            let r2 = u[0] * u[0] + u[1] * u[1];
            let m = mu(p);
            vec![m * u[0] - u[1] - u[0] * r2, u[0] + m * u[1] - u[1] * r2]
        }),
        g_u: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            let m = mu(p);
            vec![
                vec![m - 3.0 * x * x - y * y, -1.0 - 2.0 * x * y],
                vec![1.0 - 2.0 * x * y, m - x * x - 3.0 * y * y],
            ]
        }),
        g_p: Box::new(move |u, p| {
            let d = dmu(p);
            vec![d * u[0], d * u[1]]
        }),
    }
}

/// Bogdanov-Takens normal form `x' = y`, `y' = p + q x + x^2 - x y`. Its equilibria `(x0, 0)`,
/// `x0^2 + q x0 + p = 0`, have trace `-x0` and determinant `-(q + 2 x0)`: a Hopf curve `p = 0`
/// (`x0 = 0`) for `q < 0` with frequency `sqrt(-q)`, which ends at the Bogdanov-Takens point
/// `p = q = 0`.
pub fn bogdanov_takens(q: f64) -> Reference {
    Analytic {
        dim: 2,
        g: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            vec![y, p + q * x + x * x - x * y]
        }),
        g_u: Box::new(move |u, _| {
            let (x, y) = (u[0], u[1]);
            vec![vec![0.0, 1.0], vec![q + 2.0 * x - y, -x]]
        }),
        g_p: Box::new(|_, _| vec![0.0, 1.0]),
    }
}

/// Cusp normal form `u' = p + q u - u^3`. For `q > 0` its equilibria `p = u^3 - q u` fold where
/// `q = 3 u^2`: at `p = +-2 (q/3)^(3/2)`; the branch from large negative `u` (stable) loses
/// stability at the fold `p = 2 (q/3)^(3/2)`, `u = -sqrt(q/3)`.
pub fn cusp(q: f64) -> Reference {
    Analytic {
        dim: 1,
        g: Box::new(move |u, p| vec![p + q * u[0] - u[0].powi(3)]),
        g_u: Box::new(move |u, _| vec![vec![q - 3.0 * u[0] * u[0]]]),
        g_p: Box::new(|_, _| vec![1.0]),
    }
}

/// Pitchfork `u' = (p - q) u - u^3`: the trivial branch loses stability at the branch point
/// `p = q`.
pub fn shifted_pitchfork(q: f64) -> Reference {
    Analytic {
        dim: 1,
        g: Box::new(move |u, p| vec![(p - q) * u[0] - u[0].powi(3)]),
        g_u: Box::new(move |u, p| vec![vec![p - q - 3.0 * u[0] * u[0]]]),
        g_p: Box::new(|u, _| vec![u[0]]),
    }
}

/// Bautin (generalized Hopf) normal form with cubic coefficient `c`:
/// `x' = p x - y + (c r^2 - r^4) x`, `y' = x + p y + (c r^2 - r^4) y`, i.e. in polar coordinates
/// `r' = p r + c r^3 - r^5`. The origin has a Hopf point at `p = 0` with frequency 1 and first
/// Lyapunov coefficient `2 c` (for `<q, q> = 1`): supercritical for `c < 0`, subcritical for
/// `c > 0`, a generalized Hopf point at `c = 0`.
pub fn bautin(c: f64) -> Reference {
    Analytic {
        dim: 2,
        g: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            let g = c * r2 - r2 * r2;
            vec![p * x - y + g * x, x + p * y + g * y]
        }),
        g_u: Box::new(move |u, p| {
            let (x, y) = (u[0], u[1]);
            let r2 = x * x + y * y;
            let g = c * r2 - r2 * r2;
            // d g / d x = 2 x (c - 2 r^2), likewise in y.
            let dg = 2.0 * (c - 2.0 * r2);
            vec![
                vec![p + g + x * x * dg, -1.0 + x * y * dg],
                vec![1.0 + x * y * dg, p + g + y * y * dg],
            ]
        }),
        g_p: Box::new(|u, _| vec![u[0], u[1]]),
    }
}

/// A Hopf normal form with `mu = p - c q`, frequency 1: its Hopf curve is the line `p = c q`,
/// of slope `c` in the units of a curve over a range of `q` of width 1 while `|p| <= 1` (the
/// curve's units `(dp / max(|p|, 1), dq / Q)`): a curve steep in those units from its start at
/// the origin.
pub fn hopf_line(c: f64, q: f64) -> Reference {
    hopf_unfolded(move |p| p - c * q, |_| 1.0)
}

/// The Bogdanov-Takens point of [`bogdanov_takens_oblique`], `(p, q)`.
pub const OBLIQUE_BT: (f64, f64) = (0.5, 0.3);

/// The Bogdanov-Takens normal form `x' = y`, `y' = b1 + b2 e + e^2 - e y` in the shifted
/// coordinate `e = x - q / 2`, unfolded by `b1 = dp - 2 dq - dq^2 / 2`, `b2 = dq + 0.3 dp`
/// (`dp = p - 0.5`, `dq = q - 0.3`). The equilibria `(q/2 + e0, 0)`, `e0^2 + b2 e0 + b1 = 0`,
/// have trace `-e0` and determinant `-(b2 + 2 e0)`: the Hopf curve is `b1 = 0`, i.e.
/// `p = 0.5 + 2 dq + dq^2 / 2`, with the state `(q/2, 0)` and the frequency
/// `sqrt(-b2) = sqrt(-(dq + 0.3 (2 dq + dq^2 / 2)))`, for `dq < 0`. It ends at the
/// Bogdanov-Takens point [`OBLIQUE_BT`] (state `(0.15, 0)`, a double zero eigenvalue), which
/// it reaches at an angle to both axes, curved, with a state that moves along it. Beyond that
/// point the curve of zero trace goes on as a curve of neutral saddles (`e0 = 0`, eigenvalues
/// `+-sqrt(b2)`); the fold of the equilibria, `b2^2 = 4 b1`, touches it there.
pub fn bogdanov_takens_oblique(q: f64) -> Reference {
    let (p_bt, q_bt) = OBLIQUE_BT;
    let dq = q - q_bt;
    let unfold = move |p: f64| {
        let dp = p - p_bt;
        (dp - 2.0 * dq - 0.5 * dq * dq, dq + 0.3 * dp)
    };
    Analytic {
        dim: 2,
        g: Box::new(move |u, p| {
            let (b1, b2) = unfold(p);
            let (e, y) = (u[0] - 0.5 * q, u[1]);
            vec![y, b1 + b2 * e + e * e - e * y]
        }),
        g_u: Box::new(move |u, p| {
            let (_, b2) = unfold(p);
            let (e, y) = (u[0] - 0.5 * q, u[1]);
            vec![vec![0.0, 1.0], vec![b2 + 2.0 * e - y, -e]]
        }),
        g_p: Box::new(move |u, _| {
            let e = u[0] - 0.5 * q;
            vec![0.0, 1.0 + 0.3 * e]
        }),
    }
}

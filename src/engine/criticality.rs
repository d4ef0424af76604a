//! The first Lyapunov coefficient of a Hopf point: whether the periodic orbits born there are
//! stable and grow continuously (supercritical, `l1 < 0`) or unstable, with a jump and hysteresis
//! (subcritical, `l1 > 0`).
//!
//! The dynamics is `M(y) dy/dt = F(y)`, i.e. `dy/dt = f(y)` with `f = M^{-1} F`, given by the
//! problem's [`Problem::dynamics`] in the coordinates of its stability pair, `y = 0` the steady
//! state; `Df(0) = A = M^{-1} K`. With `A q = i w q`, `A^T p = -i w p`, `<q, q> = 1` and
//! `<p, q> = 1` (`<a, b> = a^H b`), Kuznetsov's invariant formula (Elements of Applied
//! Bifurcation Theory, 3rd ed., eq. 3.20 and section 8.7.1) reads
//!
//! ```text
//! l1 = Re[ <p, C(q,q,qb)> - 2 <p, B(q, A^{-1} B(q,qb))> + <p, B(qb, (2 i w - A)^{-1} B(q,q))> ] / (2 w)   (1)
//! ```
//!
//! with `B`, `C` the second and third derivatives of `f` at 0 as symmetric multilinear forms
//! (`qb` the conjugate of `q`). On the normal form `dz/dt = (mu + i w) z + c1 z |z|^2` this is
//! `Re c1 / w`, for the `z` with `y = z q + conj(z q)`; so `l1` depends on the normalization
//! of `q`, its sign does not. It is reported for `q` scaled to the problem's
//! [`Problem::mode_size`] 1 (Euclidean by default, i.e. `<q, q> = 1`; `l1` scales as `|q|^2`).
//! The state-dependent mass matrix enters through `f = M^{-1} F`: `B` and `C` contain the
//! derivatives of `M`.
//!
//! **Without `A^{-1}`.** With `A = M^{-1} K` at the steady state: `q` is the right eigenvector
//! of the pencil, `(K - s M) q = 0`; `p = M r` with `(K^T - conj(s) M) r = 0`, so
//! `<p, b> = r^H M b`; `A^{-1} b = K^{-1} M b` and `(2 i w - A)^{-1} b = (2 i w M - K)^{-1} M b`.
//!
//! **Derivatives by differences** of `f` along real directions (a problem gives `f`, not its
//! second and third derivatives; for the rod they include the shape derivatives of the mobility
//! and the slaved twist), by central differences with polarization:
//!
//! ```text
//! B(a, a) = [f(h a) - 2 f(0) + f(-h a)] / h^2,
//! B(a, b) = [f(h a + h b) - f(h a - h b) - f(-h a + h b) + f(-h a - h b)] / (4 h^2),
//! D3(a)   = C(a, a, a) = [f(2 h a) - 2 f(h a) + 2 f(-h a) - f(-2 h a)] / (2 h^3),
//! C(a, b, b) = [D3(a + b) + D3(a - b) - 2 D3(a)] / 6,   C(a, a, b) = [D3(a + b) - D3(a - b) - 2 D3(b)] / 6,
//! ```
//!
//! all with errors `O(h^2)`; complex arguments by multilinearity (`q = qr + i qi`:
//! `B(q, qb) = B(qr, qr) + B(qi, qi)`, `B(q, q) = B(qr, qr) - B(qi, qi) + 2 i B(qr, qi)`,
//! `C(q, q, qb) = C(qr, qr, qr) + C(qr, qi, qi) + i [C(qr, qr, qi) + C(qi, qi, qi)]`). The value is
//! computed at the steps `h0, h0/2, h0/4, ...` and extrapolated to `h = 0` by Ridders' tableau
//! ([`extrapolated`]); the reported precision is [`SAFETY`] times the tableau's error estimate
//! (at least the distance to a neighbouring row's extrapolation) plus a round-off
//! allowance of `2e-8` times the sum of the moduli of the three terms of (1) (they cancel to a
//! large extent on a stiff problem). Where `|l1|` does not exceed that precision, a second
//! tableau starts four times wider ([`STARTS`]: where the terms cancel to a millionth, the
//! first stops at the round-off floor before it has converged) and the one of least precision
//! is kept. The verdict is `supercritical` or `subcritical` only when `|l1|` exceeds the
//! precision; otherwise it is `undetermined`: a degenerate (generalized) Hopf point, or one the
//! differences cannot resolve.
//!
//! **Cost.** One step needs `f` at 36 to 44 points (the stencils share `f(0)`, `f(+-h a)` and,
//! from the second step on, `f(+-2 h a)`), in two batches whose points are known in advance:
//! those of the forms of `q` alone, then those of the two forms with the solutions of the
//! linear systems. Each batch is evaluated on every core ([`Problem::dynamics`] is shared
//! between threads). `K` and `2 i w M - K` are factorized once for every step, and the left
//! vector is found over the adjoint of the right vector's factorization.

use std::cell::RefCell;
use std::collections::{HashMap, HashSet};

use faer::{Mat, c64};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::{Linearization, Problem};
use crate::numerics::lu::Lu;
use crate::{Error, Result};

/// The step `h` of the differences, relative to the typical size of a unit vector of the
/// problem (`sqrt(n)` times its per-unknown scale): the first tableau's start ([`STARTS`]).
const STEP: f64 = 5e-3;

/// The starts of the tableaus [`first_lyapunov`] tries, in units of the first (`STEP`): the second,
/// four times wider, only where the first leaves the sign undetermined. On a stiff problem the
/// terms of (1) cancel to a millionth (the RPY rod of `exponent_m`, `lambda/l = 0.125`,
/// `R/lambda = 0.4`, `N = 121`: terms of size 81, `l1` about `1e-4` before scaling), so that the
/// truncation error at the first step is thirty times `l1` while round-off takes over after three
/// halvings: the first tableau stops before it has converged (`l1 = 1.9e-3 +- 6.8e-3` there,
/// undetermined). Started four times wider it has two more rows above the same round-off
/// floor and resolves it (`2.8e-3 +- 1.5e-3`, subcritical). Its rows from the third on are the
/// first tableau's (the same points of the field, looked up: there 72 new evaluations of the
/// field beside the first tableau's 153).
pub const STARTS: [f64; 2] = [1.0, 4.0];

/// Round-off of the differences, relative to the moduli of the terms of (1): about
/// `1e-16 |f| / h^3` with `h ~ 1e-2`, where `|f|` is the size of the field's terms before they
/// cancel, which can exceed the size of the terms of (1) by a hundred times or more (the
/// Brusselator at `a = 5`: terms of `f` about `a b = 130`, `|l1| = 0.04`; errors of `2e-8`
/// there). `1e-8` missed them; `2e-8` with [`SAFETY`] covers them (error at most 0.99 of the
/// precision over 400 points of the Brusselator's Hopf curve) while the rod's `l1` keeps a
/// relative precision below `1e-3` (tests/bifurcation.rs; `3e-8` took it to `1.2e-3`).
const ROUND_OFF: f64 = 2e-8;

/// The side of a Hopf point the periodic orbits are born on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// `l1 < 0`: stable orbits past the Hopf point, amplitude growing as a square root.
    Supercritical,
    /// `l1 > 0`: unstable orbits before it; past it the motion jumps to a distant attractor.
    Subcritical,
    /// `|l1|` within its precision.
    Undetermined,
}

impl Verdict {
    /// The verdict of a coefficient `l1` whose sign is `settled` (by its precision, or also by
    /// its error in `N`): the side its sign gives, else `undetermined`.
    pub fn of(l1: f64, settled: bool) -> Verdict {
        match (settled, l1 < 0.0) {
            (false, _) => Verdict::Undetermined,
            (true, true) => Verdict::Supercritical,
            (true, false) => Verdict::Subcritical,
        }
    }
}

impl std::fmt::Display for Verdict {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(match self {
            Verdict::Supercritical => "supercritical",
            Verdict::Subcritical => "subcritical",
            Verdict::Undetermined => "undetermined",
        })
    }
}

/// The first Lyapunov coefficient of a Hopf point, eq. (1).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Lyapunov {
    /// `l1`, in the problem's units (time^-1 per unit squared of its coordinates), for the
    /// critical mode scaled to [`Problem::mode_size`] 1 (`<q, q> = 1` by default).
    pub l1: f64,
    /// Estimated error of `l1`.
    pub precision: f64,
    pub verdict: Verdict,
    /// The frequency `w` used.
    pub frequency: f64,
    /// The critical eigenvector `q` of mode size 1, `Re q` orthogonal to `Im q`, `|Re q| >=
    /// |Im q|` (real and imaginary parts): the shape of the small orbit `y = 2 Re(z q e^{i w t})`.
    #[serde(skip)]
    pub q: (Vec<f64>, Vec<f64>),
}

/// The first Lyapunov coefficient at the Hopf point `(u, p)` of `problem` (linearization `lin`,
/// critical eigenvalue `s`, `Im s > 0`), or `None` when the problem does not define its
/// dynamics ([`Problem::dynamics`]). The tableau starts at `5e-3 sqrt(n)` times the problem's
/// per-unknown scale, and four times wider where that leaves the sign undetermined
/// ([`STARTS`]; the one of least precision is kept).
pub fn first_lyapunov(
    problem: &impl Problem,
    u: &[f64],
    p: f64,
    lin: &Linearization,
    s: c64,
) -> Result<Option<Lyapunov>> {
    first_lyapunov_from(problem, u, p, lin, s, &STARTS)
}

/// [`first_lyapunov`] with the tableau started at each of `starts` in turn (in units of the
/// first start, `5e-3 sqrt(n)` times the problem's per-unknown scale), stopping once a tableau
/// settles the sign of `l1`; of the tableaus tried, the one of least precision is kept (so a
/// later tableau that settles the sign with a larger precision than an earlier one's leaves
/// the earlier, undetermined answer). One start alone measures what that start's tableau gives
/// (tests/criticality.rs checks each start's precision against closed forms).
pub fn first_lyapunov_from(
    problem: &impl Problem,
    u: &[f64],
    p: f64,
    lin: &Linearization,
    s: c64,
    starts: &[f64],
) -> Result<Option<Lyapunov>> {
    let w = s.im.abs();
    if w <= 0.0 {
        return Err(Error::Numerical(
            "the Lyapunov coefficient needs a complex pair (w > 0)".into(),
        ));
    }
    let s = c64::new(s.re, w);
    let (k, m) = problem.stability_pair(u, p, lin)?;
    let n = k.nrows();
    let Some(field) = problem.dynamics(u, p) else {
        return Ok(None);
    };
    let field = field?;
    let forms = Forms::new(&*field, n)?;
    let (q, pencil) = right_vector(&k, &m, s)?;
    let r = left_vector(&pencil, &m, &q)?;
    // K and 2 i w M - K, factorized once for every step h.
    let shifted = Mat::from_fn(n, n, |i, j| c64::new(-k[(i, j)], 2.0 * w * m[(i, j)]));
    let critical = Critical {
        m: &m,
        k: Lu::of(k),
        resonant: Lu::of(shifted),
        q,
        r,
        w,
    };
    let h0 = STEP * problem.scales().0 * (n as f64).sqrt();
    // Tableaus until one settles the sign; of those tried, the one of least precision. A later
    // start that fails leaves the earlier ones' answer.
    let mut best: Option<(f64, f64)> = None;
    for start in starts {
        let (l1, precision) = match extrapolated(|h| critical.coefficient(&forms, h), start * h0) {
            Ok(found) => found,
            Err(e) if best.is_none() => return Err(e),
            Err(_) => break,
        };
        if best.is_none_or(|(_, least)| precision < least) {
            best = Some((l1, precision));
        }
        if l1.abs() > precision {
            break;
        }
    }
    let (l1, precision) = best.ok_or_else(|| {
        Error::Internal("the Lyapunov coefficient needs at least one start of its tableau".into())
    })?;
    // Scaled to the problem's mode size: q -> q / size divides l1 by size^2.
    let (re, im) = parts(&critical.q);
    let size = problem.mode_size(&re, &im);
    let square = size * size;
    let (l1, precision) = (l1 / square, precision / square);
    let verdict = Verdict::of(l1, l1.abs() > precision);
    Ok(Some(Lyapunov {
        l1,
        precision,
        verdict,
        frequency: w,
        q: (
            re.iter().map(|v| v / size).collect(),
            im.iter().map(|v| v / size).collect(),
        ),
    }))
}

/// Factor of the tableau's error estimate in the precision of `l1` ([`extrapolated`]): the
/// largest ratio of error to estimate seen along the Brusselator's Hopf curve (4.7), with the
/// margin the rod's precision (tests/bifurcation.rs, `1e-3` relative) leaves room for.
const SAFETY: f64 = 8.0;

/// Steps tried at most (halving each time).
const LEVELS: usize = 10;

/// Ridders' extrapolation of `value(h)` to `h = 0` for an error with even powers of `h`: the
/// Richardson tableau over `h_k = h0 2^-k`, `T[k][j] = T[k][j-1] + (T[k][j-1] - T[k-1][j-1]) /
/// (4^j - 1)`, each entry with the error estimate `max(|T[k][j] - T[k][j-1]|, |T[k][j] -
/// T[k-1][j-1]|)`. The entry with the smallest estimate wins; the halving stops when the
/// diagonal has become worse than twice that (round-off has taken over), when that estimate has
/// fallen below the round-off allowance (which no smaller step improves on), or after
/// [`LEVELS`].
///
/// That estimate compares the winner with the two entries it was made from; where they agree
/// by chance (the round-off of the differences, which grows as `h^-3`, passing through the
/// truncation error), it is smaller than the error, which it then missed by up to 17 times on
/// a rod's Hopf curve. The estimate returned is therefore also at least the distance of the
/// winner to the best entry of a neighbouring row, `min_{r = k* +- 1} |T* - T_r*|` (`T_r*` the
/// entry of least estimate in row `r`): an independent extrapolation from one more or one less
/// step, which differs from the winner by about the larger of their errors. Both are still
/// estimates picked as the least of many (biased low), and the round-off of the winning step,
/// `eps |f| / h^3` with `|f|` the size of the field's terms before they cancel, is not in them:
/// along the Brusselator's Hopf curve the error still reached 4.7 times that estimate. The
/// estimate returned is [`SAFETY`] times it, a bound in practice (tests/criticality.rs checks
/// its coverage along that curve against the closed form), plus the round-off allowance
/// ([`ROUND_OFF`] times the scale of the terms at the winning step).
fn extrapolated(mut value: impl FnMut(f64) -> Result<(f64, f64)>, h0: f64) -> Result<(f64, f64)> {
    let mut previous: Vec<f64> = Vec::new();
    // (value, estimate, scale, row) of the winner, and of each row's best entry.
    let mut best = (f64::NAN, f64::INFINITY, 0.0, 0);
    let mut rows: Vec<(f64, f64)> = Vec::new();
    let mut h = h0;
    for k in 0..LEVELS {
        let (v, scale) = value(h)?;
        let mut row = vec![v];
        let mut row_best = (f64::NAN, f64::INFINITY);
        for j in 1..=k {
            let factor = 4f64.powi(j as i32) - 1.0;
            let t = row[j - 1] + (row[j - 1] - previous[j - 1]) / factor;
            let error = (t - row[j - 1]).abs().max((t - previous[j - 1]).abs());
            if error < row_best.1 {
                row_best = (t, error);
            }
            if error < best.1 {
                best = (t, error, scale, k);
            }
            row.push(t);
        }
        rows.push(row_best);
        // Round-off has taken over, or the error estimate has fallen below the round-off
        // allowance, which no smaller step can improve on.
        if k > 0
            && ((row[k] - previous[k - 1]).abs() >= 2.0 * best.1 || best.1 <= ROUND_OFF * best.2)
        {
            break;
        }
        previous = row;
        h *= 0.5;
    }
    if !best.0.is_finite() {
        return Err(Error::Numerical(
            "the differences of the Lyapunov coefficient did not converge".into(),
        ));
    }
    let (value, estimate, scale, k) = best;
    let neighbour = [k.wrapping_sub(1), k + 1]
        .iter()
        .filter_map(|&r| rows.get(r))
        .map(|&(t, _)| (t - value).abs())
        .filter(|d| d.is_finite())
        .fold(f64::INFINITY, f64::min);
    let estimate = if neighbour.is_finite() {
        estimate.max(neighbour)
    } else {
        estimate
    };
    Ok((value, SAFETY * estimate + ROUND_OFF * scale))
}

/// Complex column vector of a slice.
fn column(v: &[c64]) -> Mat<c64> {
    Mat::from_fn(v.len(), 1, |i, _| v[i])
}

/// Relative shift of inverse iteration off the eigenvalue (which may be exact, making the pencil
/// exactly singular): each step then reduces the other components by about this factor.
const SHIFT: f64 = 1e-9;

/// The null vector of `K - s M`: two steps of inverse iteration from a fixed start (shifted by
/// [`SHIFT`]), scaled to `<q, q> = 1` with `Re q` orthogonal to `Im q` and `|Re q| >= |Im q|`;
/// with the factorization of the shifted pencil, whose adjoint gives the left vector.
fn right_vector(k: &Mat<f64>, m: &Mat<f64>, s: c64) -> Result<(Vec<c64>, Lu<c64>)> {
    let n = k.nrows();
    let s = s + SHIFT * s.norm();
    let pencil = Mat::from_fn(n, n, |i, j| c64::new(k[(i, j)], 0.0) - s * m[(i, j)]);
    let mut v = start(n);
    let lu = Lu::of(pencil);
    for _ in 0..2 {
        let x = lu.solve(column(&v).as_ref());
        v = (0..n).map(|i| x[(i, 0)]).collect();
        v = normalized(&v)?;
    }
    // Rotate the phase: with q = e^{i phi} v, Re q . Im q = 0 when
    // tan(2 phi) = -2 Re v . Im v / (|Re v|^2 - |Im v|^2).
    let (rr, ii, ri) = v.iter().fold((0.0, 0.0, 0.0), |(a, b, c), z| {
        (a + z.re * z.re, b + z.im * z.im, c + z.re * z.im)
    });
    let mut phi = 0.5 * (-2.0 * ri).atan2(rr - ii);
    let rotate = |phi: f64| -> Vec<c64> {
        let e = c64::new(phi.cos(), phi.sin());
        v.iter().map(|z| z * e).collect()
    };
    let mut q = rotate(phi);
    let (re, im) = q
        .iter()
        .fold((0.0, 0.0), |(a, b), z| (a + z.re * z.re, b + z.im * z.im));
    if im > re {
        phi += std::f64::consts::FRAC_PI_2;
        q = rotate(phi);
    }
    Ok((q, lu))
}

/// `r` with `(K^T - conj(s) M) r = 0`, by inverse iteration as in [`right_vector`] over the
/// adjoint of its factorized pencil `K - s M` (`M` symmetric), scaled so that
/// `<p, q> = r^H M q = 1` (`p = M r`, the left eigenvector of `A = M^{-1} K`).
fn left_vector(pencil: &Lu<c64>, m: &Mat<f64>, q: &[c64]) -> Result<Vec<c64>> {
    let n = m.nrows();
    let mut r = start(n);
    for _ in 0..2 {
        let x = pencil.solve_adjoint(column(&r).as_ref());
        r = (0..n).map(|i| x[(i, 0)]).collect();
        r = normalized(&r)?;
    }
    let mq = real_times(m, q);
    let pq: c64 = r.iter().zip(&mq).map(|(a, b)| a.conj() * b).sum();
    if !(pq.norm() > 0.0 && pq.norm().is_finite()) {
        return Err(Error::Numerical(
            "the left and right critical eigenvectors are orthogonal (not a simple pair)".into(),
        ));
    }
    // r^H M q = 1: divide r by conj(pq).
    Ok(r.iter().map(|z| z / pq.conj()).collect())
}

/// A start vector for inverse iteration that is not orthogonal to any eigenvector in general.
fn start(n: usize) -> Vec<c64> {
    (0..n)
        .map(|i| {
            let t = i as f64 + 1.0;
            c64::new((0.7 * t).sin() + 1.1, (1.3 * t).cos())
        })
        .collect()
}

/// `v / |v|`, refused when `v` is not finite.
fn normalized(v: &[c64]) -> Result<Vec<c64>> {
    let len = v.iter().map(|z| z.norm_sqr()).sum::<f64>().sqrt();
    if !(len.is_finite() && len > 0.0) {
        return Err(Error::Numerical(
            "inverse iteration for the critical eigenvector broke down".into(),
        ));
    }
    Ok(v.iter().map(|z| z / len).collect())
}

/// `M v` for a real matrix and a complex vector.
fn real_times(m: &Mat<f64>, v: &[c64]) -> Vec<c64> {
    (0..m.nrows())
        .map(|i| (0..m.ncols()).map(|j| v[j] * m[(i, j)]).sum())
        .collect()
}

/// A difference formula for a multilinear form of the field: `scale sum_k c_k f(y_k)`.
struct Stencil {
    terms: Vec<(f64, Vec<f64>)>,
    scale: f64,
}

impl Stencil {
    /// `B(a, b)` at step `h`, the arguments scaled to unit length first; `None` (the form is
    /// zero) when either is zero.
    fn b(a: &[f64], b: &[f64], h: f64) -> Option<Stencil> {
        let (la, lb) = (length(a), length(b));
        if la == 0.0 || lb == 0.0 {
            return None;
        }
        let (a, b) = (scaled(a, 1.0 / la), scaled(b, 1.0 / lb));
        Some(if a == b {
            Stencil {
                terms: vec![
                    (1.0, point(&[(h, &a)])),
                    (-2.0, vec![0.0; a.len()]),
                    (1.0, point(&[(-h, &a)])),
                ],
                scale: la * lb / (h * h),
            }
        } else {
            Stencil {
                terms: vec![
                    (1.0, point(&[(h, &a), (h, &b)])),
                    (-1.0, point(&[(h, &a), (-h, &b)])),
                    (-1.0, point(&[(-h, &a), (h, &b)])),
                    (1.0, point(&[(-h, &a), (-h, &b)])),
                ],
                scale: la * lb / (4.0 * h * h),
            }
        })
    }

    /// `C(a, a, a)` at step `h`, the argument scaled to unit length first (as in
    /// [`Stencil::b`], so that the two share `f(+-h a)`); `None` when `a` is zero.
    fn d3(a: &[f64], h: f64) -> Option<Stencil> {
        let la = length(a);
        if la == 0.0 {
            return None;
        }
        let a = scaled(a, 1.0 / la);
        Some(Stencil {
            terms: vec![
                (1.0, point(&[(2.0 * h, &a)])),
                (-2.0, point(&[(h, &a)])),
                (2.0, point(&[(-h, &a)])),
                (-1.0, point(&[(-2.0 * h, &a)])),
            ],
            scale: la * la * la / (2.0 * h * h * h),
        })
    }

    /// The four real forms of `B(x, y)` for complex `x`, `y`: `B(xr, yr)`, `B(xi, yi)`,
    /// `B(xr, yi)`, `B(xi, yr)`.
    fn b_complex(x: &[c64], y: &[c64], h: f64) -> [Option<Stencil>; 4] {
        let (xr, xi) = parts(x);
        let (yr, yi) = parts(y);
        [
            Stencil::b(&xr, &yr, h),
            Stencil::b(&xi, &yi, h),
            Stencil::b(&xr, &yi, h),
            Stencil::b(&xi, &yr, h),
        ]
    }
}

/// `sum_k c_k v_k`, the point at which a stencil evaluates the field.
fn point(terms: &[(f64, &[f64])]) -> Vec<f64> {
    (0..terms[0].1.len())
        .map(|i| terms.iter().map(|(c, v)| c * v[i]).sum())
        .collect()
}

/// The multilinear forms of the field by differences.
struct Forms<'a> {
    field: &'a (dyn Fn(&[f64]) -> Result<Vec<f64>> + Sync),
    n: usize,
    /// Every `f(y)` evaluated, by the bits of `y`, `f(0)` among them: the stencils share points
    /// (`f(+-h a)` serves `B(a, a)` and `C(a, a, a)`; `f(+-2 h a)` at step `h` is `f(+-h' a)`
    /// at the step before, `h' = 2 h` exactly), and only an identical `y` is looked up.
    evaluated: RefCell<HashMap<Vec<u64>, Vec<f64>>>,
}

fn key(y: &[f64]) -> Vec<u64> {
    y.iter().map(|v| v.to_bits()).collect()
}

impl<'a> Forms<'a> {
    /// The forms of `field` in `n` unknowns, with `f(0)` evaluated (zero at an exact steady
    /// state; kept in the second differences).
    fn new(field: &'a (dyn Fn(&[f64]) -> Result<Vec<f64>> + Sync), n: usize) -> Result<Self> {
        let zero = vec![0.0; n];
        let f0 = field(&zero)?;
        Ok(Forms {
            field,
            n,
            evaluated: RefCell::new(HashMap::from([(key(&zero), f0)])),
        })
    }

    /// Evaluates the field at every point of `stencils` not evaluated yet, on every core (the
    /// evaluations are independent, and each is stored by itself: the values do not depend on
    /// the number of threads).
    fn evaluate<'s>(&self, stencils: impl IntoIterator<Item = &'s Stencil>) -> Result<()> {
        // The points not evaluated yet, each once, with its key.
        let mut missing: Vec<(Vec<u64>, &[f64])> = Vec::new();
        {
            let evaluated = self.evaluated.borrow();
            let mut seen = HashSet::new();
            for stencil in stencils {
                for (_, y) in &stencil.terms {
                    let k = key(y);
                    if !evaluated.contains_key(&k) && seen.insert(k.clone()) {
                        missing.push((k, y));
                    }
                }
            }
        }
        let values: Vec<Result<Vec<f64>>> =
            missing.par_iter().map(|(_, y)| (self.field)(y)).collect();
        let mut evaluated = self.evaluated.borrow_mut();
        for ((k, _), f) in missing.into_iter().zip(values) {
            evaluated.insert(k, f?);
        }
        Ok(())
    }

    /// The value of a stencil (zero for `None`), its points evaluated first where they are not.
    fn value(&self, stencil: &Option<Stencil>) -> Result<Vec<f64>> {
        let Some(stencil) = stencil else {
            return Ok(vec![0.0; self.n]);
        };
        self.evaluate([stencil])?;
        let evaluated = self.evaluated.borrow();
        let values: Vec<&Vec<f64>> = stencil
            .terms
            .iter()
            .map(|(_, y)| &evaluated[&key(y)])
            .collect();
        Ok((0..self.n)
            .map(|i| {
                stencil.scale
                    * stencil
                        .terms
                        .iter()
                        .zip(&values)
                        .map(|((c, _), f)| c * f[i])
                        .sum::<f64>()
            })
            .collect())
    }

    /// `B(x, y)` for complex `x`, `y` from its four real forms ([`Stencil::b_complex`]).
    fn b_complex(&self, forms: &[Option<Stencil>; 4]) -> Result<Vec<c64>> {
        let [rr, ii, ri, ir] = forms.each_ref().map(|s| self.value(s));
        let (rr, ii, ri, ir) = (rr?, ii?, ri?, ir?);
        Ok((0..self.n)
            .map(|k| c64::new(rr[k] - ii[k], ri[k] + ir[k]))
            .collect())
    }
}

/// What eq. (1) needs at a Hopf point besides the differences: `M`, `K` and `2 i w M - K`
/// factorized, the right and left critical vectors and the frequency.
struct Critical<'a> {
    m: &'a Mat<f64>,
    k: Lu<f64>,
    resonant: Lu<c64>,
    q: Vec<c64>,
    r: Vec<c64>,
    w: f64,
}

impl Critical<'_> {
    /// Eq. (1) at the difference step `h`, and the sum of the moduli of its three terms (over
    /// `2 w`): the size below which cancellation leaves `l1` unresolved. The field is
    /// evaluated in two batches: the points of the forms of `q` alone, then those of the forms
    /// with the solutions of the two linear systems.
    fn coefficient(&self, forms: &Forms, h: f64) -> Result<(f64, f64)> {
        let (m, q, r, w) = (self.m, &self.q, &self.r, self.w);
        let n = q.len();
        let (qr, qi) = parts(q);
        let qb: Vec<c64> = q.iter().map(|z| z.conj()).collect();
        // <p, b> = r^H M b.
        let project = |b: &[c64]| -> c64 {
            let mb = real_times(m, b);
            r.iter().zip(&mb).map(|(a, b)| a.conj() * b).sum()
        };
        // C(q, q, qb) by polarization of the cubes; B(q, qb) (real) and B(q, q).
        let sum: Vec<f64> = qr.iter().zip(&qi).map(|(a, b)| a + b).collect();
        let diff: Vec<f64> = qr.iter().zip(&qi).map(|(a, b)| a - b).collect();
        let of_q = [
            Stencil::d3(&qr, h),
            Stencil::d3(&qi, h),
            Stencil::d3(&sum, h),
            Stencil::d3(&diff, h),
            Stencil::b(&qr, &qr, h),
            Stencil::b(&qi, &qi, h),
            Stencil::b(&qr, &qi, h),
        ];
        forms.evaluate(of_q.iter().flatten())?;
        let [c_r, c_i, c_s, c_d, b_rr, b_ii, b_ri] = of_q.each_ref().map(|s| forms.value(s));
        let (c_r, c_i, c_s, c_d) = (c_r?, c_i?, c_s?, c_d?);
        let (b_rr, b_ii, b_ri) = (b_rr?, b_ii?, b_ri?);
        let c_rii: Vec<f64> = (0..n)
            .map(|k| (c_s[k] + c_d[k] - 2.0 * c_r[k]) / 6.0)
            .collect();
        let c_rri: Vec<f64> = (0..n)
            .map(|k| (c_s[k] - c_d[k] - 2.0 * c_i[k]) / 6.0)
            .collect();
        let c_qqqb: Vec<c64> = (0..n)
            .map(|k| c64::new(c_r[k] + c_rii[k], c_rri[k] + c_i[k]))
            .collect();
        let b_qqb: Vec<f64> = (0..n).map(|k| b_rr[k] + b_ii[k]).collect();
        let b_qq: Vec<c64> = (0..n)
            .map(|k| c64::new(b_rr[k] - b_ii[k], 2.0 * b_ri[k]))
            .collect();
        // A^{-1} B(q, qb) = K^{-1} M B(q, qb) (real).
        let mb = m * Mat::from_fn(n, 1, |i, _| b_qqb[i]);
        let a_inv = self.k.solve(mb.as_ref());
        let a_inv: Vec<c64> = (0..n).map(|i| c64::new(a_inv[(i, 0)], 0.0)).collect();
        // (2 i w - A)^{-1} B(q, q) = (2 i w M - K)^{-1} M B(q, q).
        let second = self.resonant.solve(column(&real_times(m, &b_qq)).as_ref());
        let second: Vec<c64> = (0..n).map(|i| second[(i, 0)]).collect();
        if !second
            .iter()
            .chain(&a_inv)
            .all(|z| z.re.is_finite() && z.im.is_finite())
        {
            return Err(Error::Numerical(
                "the Lyapunov coefficient needs K and 2 i w M - K regular (a zero or a 2:1 \
                 resonant eigenvalue at the Hopf point)"
                    .into(),
            ));
        }
        let first = Stencil::b_complex(q, &a_inv, h);
        let other = Stencil::b_complex(&qb, &second, h);
        forms.evaluate(first.iter().chain(&other).flatten())?;
        let b1 = forms.b_complex(&first)?;
        let b2 = forms.b_complex(&other)?;
        let terms = [project(&c_qqqb), -2.0 * project(&b1), project(&b2)];
        let value: c64 = terms.iter().sum();
        let scale: f64 = terms.iter().map(|t| t.norm()).sum();
        Ok((value.re / (2.0 * w), scale / (2.0 * w)))
    }
}

fn parts(v: &[c64]) -> (Vec<f64>, Vec<f64>) {
    (
        v.iter().map(|z| z.re).collect(),
        v.iter().map(|z| z.im).collect(),
    )
}

fn length(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn scaled(v: &[f64], c: f64) -> Vec<f64> {
    v.iter().map(|x| c * x).collect()
}

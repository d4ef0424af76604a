//! Bending and twisting at one interior node of the discrete rod (Bergou et al. 2008, 2010).
//!
//! The stencil of node `i` holds the two adjacent edges `e0 = e^{i-1}`, `e1 = e^i` and their twist
//! angles `theta0`, `theta1`: eight unknowns. With `t = e/|e|`, reference directors `a` carried by
//! parallel transport from the chart onto the current edges, `b = t x a`, and material directors
//! `m1 = cos(theta) a + sin(theta) b`, `m2 = -sin(theta) a + cos(theta) b`:
//!
//! * curvature binormal `kb = 2 e0 x e1 / (|e0||e1| + e0.e1)`,
//! * material curvatures `kappa1 = 1/2 (m2_0 + m2_1).kb`, `kappa2 = -1/2 (m1_0 + m1_1).kb`,
//! * twist `m = theta1 - theta0 + mref` (`mref`: angle from the transport of `a_0` onto edge `i` to `a_1`),
//! * `E = EI/(2 lbar) [(kappa1 - kappa1bar)^2 + (kappa2 - kappa2bar)^2] + GJ/(2 lbar) (m - mbar)^2`.
//!
//! The energy is written once, generic over the scalar. Its exact gradient and Hessian come from
//! forward-mode automatic differentiation (`num-dual`): the chain rule carried out to machine
//! precision, through the transport of the reference frame, so no term (such as the finite
//! transport term missing from the printed Hessian of Bergou et al. 2010) can be forgotten.
//!
//! The Hessian ([`BendTwist::hessian`]) follows the structure of the stencil instead of carrying
//! an 8 x 8 second derivative through every operation:
//!
//! 1. each edge's frame `(t, a, b)` is a function of that edge alone: second-order jets in its
//!    three components (forward AD);
//! 2. the curvature binormal is scale free, `kb = 2 t0 x t1 / (1 + t0.t1)`, so the projections
//!    `A_k = a_k.kb`, `B_k = b_k.kb` and the reference twist depend on the six edge components
//!    only, through seven dot products of one vector of each frame ([`Dots`]); being bilinear,
//!    their jets in the six variables are written down from the two edge jets (gradient
//!    `[J_x^T y; J_y^T x]`, Hessian blocks `sum y_i hess x_i`, `J_x^T J_y`, `sum x_i hess y_i`),
//!    and the few operations from them to the projections and `mref` run on six-variable jets;
//! 3. the angles enter only through `m2_k.kb = cos(theta_k) B_k - sin(theta_k) A_k` and
//!    `-m1_k.kb = -(cos(theta_k) A_k + sin(theta_k) B_k)`, and the twist through
//!    `theta1 - theta0`, and the energy is quadratic in the strains: the eight-variable gradient
//!    and Hessian follow from the jets of stage 2 by the chain rule through the strains, written
//!    out ([`BendTwist::energy_jet`]).
//!
//! Stages 1 and 2 run the same generic code as [`strains`] ([`edge_frame`], [`projections`]), and
//! the whole is tested against the plain eight-variable forward derivative of
//! [`BendTwist::energy`] to 1e-12 (and against finite differences in `tests/rod_derivatives.rs`);
//! it costs a fraction of that derivative.

use nalgebra::{Const, RealField, SMatrix, SVector, U1, Vector3, convert};
use num_dual::{Derivative, Dual2SVec64, DualSVec64, gradient};

use super::frame::transport;

/// Number of unknowns of a stencil: `(e0, e1, theta0, theta1)`.
pub(crate) const STENCIL: usize = 8;

/// Everything a bend-twist stencil needs besides its unknowns.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BendTwist {
    /// Chart tangents and directors of the two edges (the source of the parallel transport).
    pub source_t: [Vector3<f64>; 2],
    pub source_d: [Vector3<f64>; 2],
    /// Multiple of `2 pi` added to the principal reference twist.
    pub twist_offset: f64,
    /// Natural Voronoi length `lbar_i`.
    pub lbar: f64,
    /// Natural material curvatures and twist.
    pub kappa_bar: [f64; 2],
    pub twist_bar: f64,
    pub ei: f64,
    pub gj: f64,
}

/// The frame of one edge `e`: unit tangent `t = e/|e|`, reference director `a` (the chart
/// director `source_d` parallel-transported from the chart tangent `source_t` onto `t`) and
/// `b = t x a`.
fn edge_frame<T: RealField + Copy>(
    source_t: &Vector3<f64>,
    source_d: &Vector3<f64>,
    e: &Vector3<T>,
) -> [Vector3<T>; 3] {
    let c = |a: &Vector3<f64>| a.map(convert::<f64, T>);
    let t = e / e.norm();
    let a = transport(&c(source_t), &t, &c(source_d));
    [t, a, t.cross(&a)]
}

/// The seven dot products across a stencil's two frames `(t, a, b)` on which the projections
/// and the reference twist depend ([`projections`]): `c = t0.t1`, `t1.a0`, `t1.b0`, `t0.a1`,
/// `t0.b1`, `a0.a1`, `a0.b1`.
#[derive(Clone, Copy, Debug)]
struct Dots<T> {
    c: T,
    t1a0: T,
    t1b0: T,
    t0a1: T,
    t0b1: T,
    a0a1: T,
    a0b1: T,
}

/// The frame vectors whose dot products make [`Dots`], in its order: `(i0, i1)`, vector `i0` of
/// edge 0's frame `(t, a, b)` with vector `i1` of edge 1's.
const DOT_PAIRS: [(usize, usize); 7] = [(0, 0), (1, 0), (2, 0), (0, 1), (0, 2), (1, 1), (1, 2)];

impl<T: RealField + Copy> Dots<T> {
    /// The dot products of the two frames.
    fn of(f0: &[Vector3<T>; 3], f1: &[Vector3<T>; 3]) -> Self {
        Self::from_fn(|i0, i1| f0[i0].dot(&f1[i1]))
    }

    /// The dot products given by `dot(i0, i1)` of frame vectors `f0[i0].f1[i1]`, in the order of
    /// [`DOT_PAIRS`].
    fn from_fn(dot: impl Fn(usize, usize) -> T) -> Self {
        let [c, t1a0, t1b0, t0a1, t0b1, a0a1, a0b1] = DOT_PAIRS.map(|(i0, i1)| dot(i0, i1));
        Dots {
            c,
            t1a0,
            t1b0,
            t0a1,
            t0b1,
            a0a1,
            a0b1,
        }
    }
}

/// The projections `[A_0, B_0, A_1, B_1]` (`A_k = a_k.kb`, `B_k = b_k.kb`) of the curvature
/// binormal `kb = 2 t0 x t1 / (1 + t0.t1)` on the two reference frames, and the reference twist
/// `mref`, the signed angle about `t1` from `P a0` (the transport of `a0` from `t0` to `t1`) to
/// `a1`. Both frames orthonormal, everything reduces to the seven dot products of [`Dots`]:
/// with `c = t0.t1`,
///
/// ```text
/// A_0 = -2 (t1.b0)/(1 + c),   B_0 = 2 (t1.a0)/(1 + c),
/// A_1 =  2 (t0.b1)/(1 + c),   B_1 = -2 (t0.a1)/(1 + c),
/// P a0 = c a0 - (t1.a0) t0 - (t1.b0) (t0 x t1)/(1 + c),
/// P a0 . a1 = c (a0.a1) - (t1.a0)(t0.a1) - (t1.b0)(t0.b1)/(1 + c),
/// (P a0 x a1) . t1 = -P a0 . b1 = -c (a0.b1) + (t1.a0)(t0.b1) - (t1.b0)(t0.a1)/(1 + c),
/// mref = atan2((P a0 x a1) . t1, P a0 . a1) + twist_offset
/// ```
///
/// (from `b = t x a`, `t x b = -a` and the cyclic triple product); the same values as
/// [`super::frame::reference_twist`] and the binormal's definition, at half the operations.
fn projections<T: RealField + Copy>(d: &Dots<T>, twist_offset: f64) -> ([T; 4], T) {
    let inv = T::one() / (T::one() + d.c);
    let two_inv = inv * convert(2.0);
    let projections = [
        -d.t1b0 * two_inv,
        d.t1a0 * two_inv,
        d.t0b1 * two_inv,
        -d.t0a1 * two_inv,
    ];
    let cos = d.c * d.a0a1 - d.t1a0 * d.t0a1 - d.t1b0 * d.t0b1 * inv;
    let sin = -d.c * d.a0b1 + d.t1a0 * d.t0b1 - d.t1b0 * d.t0a1 * inv;
    (projections, sin.atan2(cos) + convert(twist_offset))
}

/// Material curvatures `(kappa1, kappa2)` and twist `m` from the projections of
/// [`projections`], the reference twist and the two angles: with
/// `m1 = cos(theta) a + sin(theta) b`, `m2 = -sin(theta) a + cos(theta) b`,
/// `kappa1 = 1/2 sum_k m2_k.kb`, `kappa2 = -1/2 sum_k m1_k.kb`, `m = theta1 - theta0 + mref`.
fn material_strains<T: RealField + Copy>(
    [a0, b0, a1, b1]: [T; 4],
    mref: T,
    theta: [T; 2],
) -> (T, T, T) {
    let (s0, c0) = theta[0].sin_cos();
    let (s1, c1) = theta[1].sin_cos();
    let half: T = convert(0.5);
    let kappa1 = (c0 * b0 - s0 * a0 + c1 * b1 - s1 * a1) * half;
    let kappa2 = -(c0 * a0 + s0 * b0 + c1 * a1 + s1 * b1) * half;
    (kappa1, kappa2, theta[1] - theta[0] + mref)
}

/// The unknowns of a stencil from its two edge vectors and two angles.
pub(crate) fn unknowns(
    e0: &Vector3<f64>,
    e1: &Vector3<f64>,
    theta0: f64,
    theta1: f64,
) -> SVector<f64, STENCIL> {
    SVector::<f64, STENCIL>::from_column_slice(&[
        e0.x, e0.y, e0.z, e1.x, e1.y, e1.z, theta0, theta1,
    ])
}

/// Material curvatures `(kappa1, kappa2)` and twist `m` of a stencil.
pub(crate) fn strains<T: RealField + Copy>(s: &BendTwist, v: &SVector<T, STENCIL>) -> (T, T, T) {
    let e0 = Vector3::new(v[0], v[1], v[2]);
    let e1 = Vector3::new(v[3], v[4], v[5]);
    let f0 = edge_frame(&s.source_t[0], &s.source_d[0], &e0);
    let f1 = edge_frame(&s.source_t[1], &s.source_d[1], &e1);
    let (projections, mref) = projections(&Dots::of(&f0, &f1), s.twist_offset);
    material_strains(projections, mref, [v[6], v[7]])
}

/// The value `x` as the jet of variable `index` of `N`.
fn variable<const N: usize>(x: f64, index: usize) -> Dual2SVec64<N> {
    Dual2SVec64::from_re(x).derivative(index)
}

impl BendTwist {
    /// Bending plus twisting energy of the stencil.
    pub fn energy<T: RealField + Copy>(&self, v: &SVector<T, STENCIL>) -> T {
        let (k1, k2, m) = strains(self, v);
        self.energy_of_strains(k1, k2, m)
    }

    /// `EI/(2 lbar) [(kappa1 - kappa1bar)^2 + (kappa2 - kappa2bar)^2] + GJ/(2 lbar) (m - mbar)^2`.
    fn energy_of_strains<T: RealField + Copy>(&self, k1: T, k2: T, m: T) -> T {
        let d1 = k1 - convert(self.kappa_bar[0]);
        let d2 = k2 - convert(self.kappa_bar[1]);
        let dm = m - convert(self.twist_bar);
        let scale: T = convert(0.5 / self.lbar);
        (d1 * d1 * convert(self.ei) + d2 * d2 * convert(self.ei) + dm * dm * convert(self.gj))
            * scale
    }

    /// Energy and exact gradient.
    pub fn gradient(&self, v: &SVector<f64, STENCIL>) -> (f64, SVector<f64, STENCIL>) {
        gradient(|w| self.energy(&w), v)
    }

    /// The exact derivatives `dE/dtheta0`, `dE/dtheta1` of the energy with respect to the two
    /// angles. The angles enter only the last stage (the material strains from the projections
    /// and the reference twist, [`material_strains`]), so the frames and projections are plain
    /// numbers and only that stage carries first-order jets, in the two angles: a fraction of
    /// the cost of [`BendTwist::gradient`], for the twist balance `dE/dtheta = 0` alone.
    pub(crate) fn twist_gradient(&self, v: &SVector<f64, STENCIL>) -> [f64; 2] {
        let edge = |k: usize| Vector3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
        let f0 = edge_frame(&self.source_t[0], &self.source_d[0], &edge(0));
        let f1 = edge_frame(&self.source_t[1], &self.source_d[1], &edge(1));
        let (projections, mref) = projections(&Dots::of(&f0, &f1), self.twist_offset);
        let plain = DualSVec64::<2>::from_re;
        let theta = [plain(v[6]).derivative(0), plain(v[7]).derivative(1)];
        let (k1, k2, m) = material_strains(projections.map(plain), plain(mref), theta);
        let d = self
            .energy_of_strains(k1, k2, m)
            .eps
            .unwrap_generic(Const::<2>, U1);
        [d[0], d[1]]
    }

    /// Energy, exact gradient and exact Hessian, in the three stages of the
    /// [module documentation](self).
    pub fn hessian(
        &self,
        v: &SVector<f64, STENCIL>,
    ) -> (f64, SVector<f64, STENCIL>, SMatrix<f64, STENCIL, STENCIL>) {
        let frame = |k: usize| -> [Vector3<Dual2SVec64<3>>; 3] {
            let e = Vector3::from_fn(|c, _| variable::<3>(v[3 * k + c], c));
            edge_frame(&self.source_t[k], &self.source_d[k], &e)
        };
        let dots = cross_dots(&frame(0), &frame(1));
        let (projections, mref) = projections(&dots, self.twist_offset);
        self.energy_jet(projections, mref, [v[6], v[7]])
    }

    /// Stage 3: the energy, its gradient and Hessian in the eight unknowns from the jets (in the
    /// six edge components) of the projections `[A_0, B_0, A_1, B_1]` and of `mref`, and the two
    /// angles, by the chain rule through the strains `s = (kappa1, kappa2, m)` of
    /// [`material_strains`], on which the energy is quadratic,
    /// `E = 1/2 (s - sbar)^T W (s - sbar)`, `W = diag(EI, EI, GJ)/lbar`:
    ///
    /// ```text
    /// grad E = sum_i W_i (s_i - sbar_i) grad s_i,
    /// hess E = sum_i W_i [grad s_i grad s_i^T + (s_i - sbar_i) hess s_i],
    /// ```
    ///
    /// with, for `kappa1 = 1/2 sum_k (cos th_k B_k - sin th_k A_k)`,
    /// `kappa2 = -1/2 sum_k (cos th_k A_k + sin th_k B_k)` and `m = th_1 - th_0 + mref`,
    /// the edge block of `hess kappa` the same combinations of the Hessians of `A_k`, `B_k`, the
    /// mixed block `d/d th_k` of the edge gradient, and the angle block diagonal,
    /// `d^2 kappa1/d th_k^2 = -1/2 (cos th_k B_k - sin th_k A_k)`,
    /// `d^2 kappa2/d th_k^2 = 1/2 (cos th_k A_k + sin th_k B_k)`; `m` is linear in the angles.
    #[allow(clippy::type_complexity)]
    fn energy_jet(
        &self,
        [a0, b0, a1, b1]: [Dual2SVec64<6>; 4],
        mref: Dual2SVec64<6>,
        theta: [f64; 2],
    ) -> (f64, SVector<f64, STENCIL>, SMatrix<f64, STENCIL, STENCIL>) {
        let grad = |x: &Dual2SVec64<6>| x.v1.unwrap_generic(U1, Const::<6>).transpose();
        let hess = |x: &Dual2SVec64<6>| x.v2.unwrap_generic(Const::<6>, Const::<6>);
        let (s0, c0) = theta[0].sin_cos();
        let (s1, c1) = theta[1].sin_cos();
        let (a, b) = ([a0, a1], [b0, b1]);
        let (sin, cos) = ([s0, s1], [c0, c1]);
        // Values, gradients (8) and Hessians (8 x 8) of kappa1, kappa2, m.
        let mut g = [SVector::<f64, STENCIL>::zeros(); 3];
        let mut h = [SMatrix::<f64, STENCIL, STENCIL>::zeros(); 3];
        let mut value = [0.0; 3];
        for k in 0..2 {
            let (ga, gb) = (grad(&a[k]), grad(&b[k]));
            let (ha, hb) = (hess(&a[k]), hess(&b[k]));
            let (ar, br) = (a[k].re, b[k].re);
            let th = 6 + k;
            // kappa1 += 1/2 (cos B - sin A)
            value[0] += 0.5 * (cos[k] * br - sin[k] * ar);
            let mut edge = g[0].fixed_rows_mut::<6>(0);
            edge += (gb * cos[k] - ga * sin[k]) * 0.5;
            g[0][th] = 0.5 * (-sin[k] * br - cos[k] * ar);
            let mut block = h[0].fixed_view_mut::<6, 6>(0, 0);
            block += (hb * cos[k] - ha * sin[k]) * 0.5;
            let mixed = (gb * (-sin[k]) - ga * cos[k]) * 0.5;
            h[0].fixed_view_mut::<6, 1>(0, th).copy_from(&mixed);
            h[0].fixed_view_mut::<1, 6>(th, 0)
                .copy_from(&mixed.transpose());
            h[0][(th, th)] = -0.5 * (cos[k] * br - sin[k] * ar);
            // kappa2 += -1/2 (cos A + sin B)
            value[1] -= 0.5 * (cos[k] * ar + sin[k] * br);
            let mut edge = g[1].fixed_rows_mut::<6>(0);
            edge -= (ga * cos[k] + gb * sin[k]) * 0.5;
            g[1][th] = 0.5 * (sin[k] * ar - cos[k] * br);
            let mut block = h[1].fixed_view_mut::<6, 6>(0, 0);
            block -= (ha * cos[k] + hb * sin[k]) * 0.5;
            let mixed = (ga * sin[k] - gb * cos[k]) * 0.5;
            h[1].fixed_view_mut::<6, 1>(0, th).copy_from(&mixed);
            h[1].fixed_view_mut::<1, 6>(th, 0)
                .copy_from(&mixed.transpose());
            h[1][(th, th)] = 0.5 * (cos[k] * ar + sin[k] * br);
        }
        value[2] = theta[1] - theta[0] + mref.re;
        g[2].fixed_rows_mut::<6>(0).copy_from(&grad(&mref));
        g[2][6] = -1.0;
        g[2][7] = 1.0;
        h[2].fixed_view_mut::<6, 6>(0, 0).copy_from(&hess(&mref));
        let weight = [self.ei, self.ei, self.gj].map(|w| w / self.lbar);
        let rest = [self.kappa_bar[0], self.kappa_bar[1], self.twist_bar];
        let mut energy = 0.0;
        let mut gradient = SVector::<f64, STENCIL>::zeros();
        let mut hessian = SMatrix::<f64, STENCIL, STENCIL>::zeros();
        for i in 0..3 {
            let d = value[i] - rest[i];
            energy += 0.5 * weight[i] * d * d;
            gradient.axpy(weight[i] * d, &g[i], 1.0);
            hessian.ger(weight[i], &g[i], &g[i], 1.0);
            hessian += h[i] * (weight[i] * d);
        }
        (energy, gradient, hessian)
    }
}

/// Stage 2: the seven [`Dots`] across the two edge frames (jets in each edge's own three
/// components) as jets in the six: each is bilinear, one vector of each edge, so with
/// `D = x . y`, `x` from edge 0 and `y` from edge 1,
///
/// ```text
/// grad D = [J_x^T y ; J_y^T x],
/// hess D = [ sum_i y_i hess x_i    J_x^T J_y          ]
///          [ J_y^T J_x             sum_i x_i hess y_i ]
/// ```
///
/// directly, instead of carrying six-variable jets through the products.
fn cross_dots(
    f0: &[Vector3<Dual2SVec64<3>>; 3],
    f1: &[Vector3<Dual2SVec64<3>>; 3],
) -> Dots<Dual2SVec64<6>> {
    let grad = |x: &Dual2SVec64<3>| x.v1.unwrap_generic(U1, Const::<3>);
    let hess = |x: &Dual2SVec64<3>| x.v2.unwrap_generic(Const::<3>, Const::<3>);
    Dots::from_fn(|i0, i1| {
        let (x, y) = (&f0[i0], &f1[i1]);
        let mut value = 0.0;
        let mut gradient = SMatrix::<f64, 1, 6>::zeros();
        let mut hessian = SMatrix::<f64, 6, 6>::zeros();
        for c in 0..3 {
            let (xc, yc) = (&x[c], &y[c]);
            let (gx, gy) = (grad(xc), grad(yc));
            value += xc.re * yc.re;
            let mut part = gradient.fixed_view_mut::<1, 3>(0, 0);
            part += gx * yc.re;
            let mut part = gradient.fixed_view_mut::<1, 3>(0, 3);
            part += gy * xc.re;
            let mut block = hessian.fixed_view_mut::<3, 3>(0, 0);
            block += hess(xc) * yc.re;
            let mut block = hessian.fixed_view_mut::<3, 3>(3, 3);
            block += hess(yc) * xc.re;
            let mut block = hessian.fixed_view_mut::<3, 3>(0, 3);
            block += gx.transpose() * gy;
        }
        let mixed = hessian.fixed_view::<3, 3>(0, 3).transpose();
        hessian.fixed_view_mut::<3, 3>(3, 0).copy_from(&mixed);
        Dual2SVec64::new(value, Derivative::some(gradient), Derivative::some(hessian))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    /// The strains against their definitions (binormal, material directors, reference twist by
    /// explicit transport), and the staged Hessian against the plain eight-variable forward
    /// derivative of the same energy, at stencils whose edges have turned far from their chart
    /// tangents (so the transport is finite) and with twisted, stretched edges; to 1e-12
    /// relative. The angle derivatives of [`BendTwist::twist_gradient`] against the same.
    #[test]
    fn staged_hessian_equals_the_plain_forward_derivative() {
        let rotation = |axis: Vector3<f64>, angle: f64| {
            nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle)
        };
        for (seed, turn) in [(0.3, 0.2), (1.1, 1.0), (-0.7, 2.3)] {
            let t0 = Vector3::new(1.0, 0.2 * seed, 0.1).normalize();
            let t1 = Vector3::new(0.9, 0.4, -0.3 * seed).normalize();
            let d = |t: &Vector3<f64>| t.cross(&Vector3::new(0.3, -0.5, 1.0)).normalize();
            let stencil = BendTwist {
                source_t: [t0, t1],
                source_d: [d(&t0), d(&t1)],
                twist_offset: 2.0 * std::f64::consts::PI,
                lbar: 0.07,
                kappa_bar: [0.11, -0.04],
                twist_bar: 0.02,
                ei: 1.0,
                gj: 0.7,
            };
            let r: Matrix3<f64> = rotation(Vector3::new(seed, 1.0, 0.4), turn).into();
            let e0 = r * t0 * 0.071;
            let e1 = r * rotation(Vector3::new(0.0, 0.3, 1.0), 0.4 * turn) * t1 * 0.066;
            let v = unknowns(&e0, &e1, 0.3 * seed, -0.2 + turn);
            // The strains against their definitions, term by term: the binormal from the edge
            // vectors, the material directors, the reference twist by explicit transport.
            let (k1, k2, m) = strains(&stencil, &v);
            let kb = e0.cross(&e1) * (2.0 / (e0.norm() * e1.norm() + e0.dot(&e1)));
            let directors = |k: usize, e: &Vector3<f64>| {
                let t = e.normalize();
                let a = transport(&stencil.source_t[k], &t, &stencil.source_d[k]);
                let (sin, cos) = v[6 + k].sin_cos();
                (
                    t,
                    a,
                    a * cos + t.cross(&a) * sin,
                    t.cross(&a) * cos - a * sin,
                )
            };
            let (t0n, a0, m1_0, m2_0) = directors(0, &e0);
            let (t1n, a1, m1_1, m2_1) = directors(1, &e1);
            let mref = crate::model::rod::frame::reference_twist(
                &t0n,
                &a0,
                &t1n,
                &a1,
                stencil.twist_offset,
            );
            assert!((k1 - 0.5 * (m2_0 + m2_1).dot(&kb)).abs() < 1e-13);
            assert!((k2 + 0.5 * (m1_0 + m1_1).dot(&kb)).abs() < 1e-13);
            assert!((m - (v[7] - v[6] + mref)).abs() < 1e-13);
            let (e, g, h) = stencil.hessian(&v);
            let (e_ref, g_ref, h_ref) = num_dual::hessian(|w| stencil.energy(&w), &v);
            let scale_g = g_ref.amax();
            let scale_h = h_ref.amax();
            assert!(
                (e - e_ref).abs() <= 1e-12 * e_ref.abs(),
                "energy {e} vs {e_ref}"
            );
            assert!(
                (g - g_ref).amax() <= 1e-12 * scale_g,
                "gradient {g} vs {g_ref}"
            );
            assert!(
                (h - h_ref).amax() <= 1e-12 * scale_h,
                "Hessian {h} vs {h_ref}"
            );
            let twist = stencil.twist_gradient(&v);
            assert!(
                (twist[0] - g_ref[6]).abs().max((twist[1] - g_ref[7]).abs()) <= 1e-12 * scale_g,
                "twist gradient {twist:?} vs {g_ref}"
            );
        }
    }
}

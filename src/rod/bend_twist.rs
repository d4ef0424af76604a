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
//!    three components;
//! 2. the curvature binormal is scale free, `kb = 2 t0 x t1 / (1 + t0.t1)`, so the projections
//!    `A_k = a_k.kb`, `B_k = b_k.kb` and the reference twist depend on the six edge components
//!    only: jets in six variables, seeded from the two edge jets;
//! 3. the angles enter only through `m2_k.kb = cos(theta_k) B_k - sin(theta_k) A_k` and
//!    `-m1_k.kb = -(cos(theta_k) A_k + sin(theta_k) B_k)`, and the twist through
//!    `theta1 - theta0`: jets in all eight unknowns for these last few operations.
//!
//! Every stage is the same generic code as [`strains`], so the two agree to round-off (tested
//! against the plain eight-variable derivative of [`BendTwist::energy`]).

use nalgebra::{Const, RealField, SMatrix, SVector, U1, Vector3, convert};
use num_dual::{Derivative, Dual2SVec64, DualSVec64, gradient};

use super::frame::transport;

/// Number of unknowns of a stencil: `(e0, e1, theta0, theta1)`.
pub const STENCIL: usize = 8;

/// Everything a bend-twist stencil needs besides its unknowns.
#[derive(Clone, Copy, Debug)]
pub struct BendTwist {
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

/// The projections `[A_0, B_0, A_1, B_1]` (`A_k = a_k.kb`, `B_k = b_k.kb`) of the curvature
/// binormal `kb = 2 t0 x t1 / (1 + t0.t1)` on the two reference frames, and the reference twist
/// `mref`, the signed angle about `t1` from `P a0` (the transport of `a0` from `t0` to `t1`) to
/// `a1`. Both frames orthonormal, everything reduces to seven dot products across the stencil:
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
fn frame_projections<T: RealField + Copy>(
    f0: &[Vector3<T>; 3],
    f1: &[Vector3<T>; 3],
    twist_offset: f64,
) -> ([T; 4], T) {
    let [t0, a0, b0] = f0;
    let [t1, a1, b1] = f1;
    let c = t0.dot(t1);
    let (t1a0, t1b0) = (t1.dot(a0), t1.dot(b0));
    let (t0a1, t0b1) = (t0.dot(a1), t0.dot(b1));
    let inv = T::one() / (T::one() + c);
    let two_inv = inv * convert(2.0);
    let projections = [
        -t1b0 * two_inv,
        t1a0 * two_inv,
        t0b1 * two_inv,
        -t0a1 * two_inv,
    ];
    let cos = c * a0.dot(a1) - t1a0 * t0a1 - t1b0 * t0b1 * inv;
    let sin = -c * a0.dot(b1) + t1a0 * t0b1 - t1b0 * t0a1 * inv;
    (projections, sin.atan2(cos) + convert(twist_offset))
}

/// Material curvatures `(kappa1, kappa2)` and twist `m` from the projections of
/// [`frame_projections`], the reference twist and the two angles: with
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
pub fn unknowns(
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
pub fn strains<T: RealField + Copy>(s: &BendTwist, v: &SVector<T, STENCIL>) -> (T, T, T) {
    let e0 = Vector3::new(v[0], v[1], v[2]);
    let e1 = Vector3::new(v[3], v[4], v[5]);
    let f0 = edge_frame(&s.source_t[0], &s.source_d[0], &e0);
    let f1 = edge_frame(&s.source_t[1], &s.source_d[1], &e1);
    let (projections, mref) = frame_projections(&f0, &f1, s.twist_offset);
    material_strains(projections, mref, [v[6], v[7]])
}

/// The jet `x` in `M` variables as a jet in `N >= M` variables, of which its own are
/// `offset .. offset + M` (the others enter with zero derivatives).
fn embed<const M: usize, const N: usize>(x: &Dual2SVec64<M>, offset: usize) -> Dual2SVec64<N> {
    let mut gradient = SMatrix::<f64, 1, N>::zeros();
    let mut hessian = SMatrix::<f64, N, N>::zeros();
    gradient
        .fixed_view_mut::<1, M>(0, offset)
        .copy_from(&x.v1.unwrap_generic(U1, Const::<M>));
    hessian
        .fixed_view_mut::<M, M>(offset, offset)
        .copy_from(&x.v2.unwrap_generic(Const::<M>, Const::<M>));
    Dual2SVec64::new(x.re, Derivative::some(gradient), Derivative::some(hessian))
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
    pub fn twist_gradient(&self, v: &SVector<f64, STENCIL>) -> [f64; 2] {
        let edge = |k: usize| Vector3::new(v[3 * k], v[3 * k + 1], v[3 * k + 2]);
        let f0 = edge_frame(&self.source_t[0], &self.source_d[0], &edge(0));
        let f1 = edge_frame(&self.source_t[1], &self.source_d[1], &edge(1));
        let (projections, mref) = frame_projections(&f0, &f1, self.twist_offset);
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
        let frame = |k: usize| -> [Vector3<Dual2SVec64<6>>; 3] {
            let e = Vector3::from_fn(|c, _| variable::<3>(v[3 * k + c], c));
            edge_frame(&self.source_t[k], &self.source_d[k], &e)
                .map(|w| w.map(|x| embed::<3, 6>(&x, 3 * k)))
        };
        let (projections, mref) = frame_projections(&frame(0), &frame(1), self.twist_offset);
        let lift = |x: &Dual2SVec64<6>| embed::<6, STENCIL>(x, 0);
        let theta = [variable(v[6], 6), variable(v[7], 7)];
        let (k1, k2, m) = material_strains(projections.map(|x| lift(&x)), lift(&mref), theta);
        let e = self.energy_of_strains(k1, k2, m);
        (
            e.re,
            e.v1.unwrap_generic(U1, Const::<STENCIL>).transpose(),
            e.v2.unwrap_generic(Const::<STENCIL>, Const::<STENCIL>),
        )
    }
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
            let mref =
                crate::rod::frame::reference_twist(&t0n, &a0, &t1n, &a1, stencil.twist_offset);
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

//! Four `f64` handled side by side by the RPY quadrature kernels ([`super::rpy`]).
//!
//! A plain array with element-wise operations, each a loop over the lanes that the compiler
//! turns into vector instructions of the widest kind the function it is inlined into may use:
//! two SSE2 registers in the baseline x86-64 copy of a kernel, one AVX register in the copy
//! compiled for AVX2 and FMA. `wide::f64x4`, used before, fixes its representation when the
//! crate is compiled (two SSE2 registers on the default target), so in the copy compiled for
//! AVX2 it still ran as pairs of 128-bit operations (seen in the disassembly).
//!
//! Every lane is computed by the same IEEE operation whatever the registers (no operation is
//! fused: Rust contracts no `a * b + c` into an FMA by itself), so every copy gives the same bits.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// Lanes per vector.
pub(crate) const LANES: usize = 4;

/// One `f64` per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Lanes(pub [f64; LANES]);

/// A lane-wise condition (see [`Lanes::select`]).
#[derive(Clone, Copy, Debug)]
pub struct Mask([bool; LANES]);

/// `f(i)` for every lane `i`, written out as a loop the compiler vectorizes.
#[inline(always)]
fn lanewise(f: impl Fn(usize) -> f64) -> Lanes {
    let mut out = [0.0; LANES];
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(i);
    }
    Lanes(out)
}

impl Lanes {
    pub(crate) const ZERO: Lanes = Lanes([0.0; LANES]);

    /// `v` in every lane.
    #[inline(always)]
    pub(crate) fn splat(v: f64) -> Lanes {
        Lanes([v; LANES])
    }

    /// The `LANES` entries of `v` from `at` on.
    #[inline(always)]
    pub fn load(v: &[f64], at: usize) -> Lanes {
        Lanes(
            v[at..at + LANES]
                .try_into()
                .expect("a slice of LANES entries"),
        )
    }

    #[inline(always)]
    pub fn sqrt(self) -> Lanes {
        lanewise(|i| self.0[i].sqrt())
    }

    /// Where `self > other`.
    #[inline(always)]
    pub(crate) fn gt(self, other: Lanes) -> Mask {
        let mut out = [false; LANES];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.0[i] > other.0[i];
        }
        Mask(out)
    }

    /// Where `self >= other`.
    #[inline(always)]
    pub(crate) fn ge(self, other: Lanes) -> Mask {
        let mut out = [false; LANES];
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.0[i] >= other.0[i];
        }
        Mask(out)
    }

    /// The sum of the lanes, `(l0 + l2) + (l1 + l3)`.
    #[inline(always)]
    pub fn sum(self) -> f64 {
        let [a, b, c, d] = self.0;
        (a + c) + (b + d)
    }
}

impl Mask {
    /// `if_true` where the condition holds, `if_false` elsewhere.
    #[inline(always)]
    pub(crate) fn select(self, if_true: Lanes, if_false: Lanes) -> Lanes {
        lanewise(|i| {
            if self.0[i] {
                if_true.0[i]
            } else {
                if_false.0[i]
            }
        })
    }
}

/// The arithmetic operators lane by lane, between two vectors and with a scalar on either side.
macro_rules! lanewise_operator {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, other: Lanes) -> Lanes {
                lanewise(|i| self.0[i] $op other.0[i])
            }
        }
        impl $trait<f64> for Lanes {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, other: f64) -> Lanes {
                lanewise(|i| self.0[i] $op other)
            }
        }
        impl $trait<Lanes> for f64 {
            type Output = Lanes;
            #[inline(always)]
            fn $method(self, other: Lanes) -> Lanes {
                lanewise(|i| self $op other.0[i])
            }
        }
    };
}

lanewise_operator!(Add, add, +);
lanewise_operator!(Sub, sub, -);
lanewise_operator!(Mul, mul, *);
lanewise_operator!(Div, div, /);

impl AddAssign for Lanes {
    #[inline(always)]
    fn add_assign(&mut self, other: Lanes) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a += b;
        }
    }
}

impl Neg for Lanes {
    type Output = Lanes;
    #[inline(always)]
    fn neg(self) -> Lanes {
        lanewise(|i| -self.0[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each operation is the scalar one in every lane.
    #[test]
    fn lanes_compute_the_scalar_operations() {
        let a = Lanes([1.0, -2.0, 0.0, 9.0]);
        let b = Lanes([3.0, 0.5, 0.0, -4.0]);
        assert_eq!((a + b).0, [4.0, -1.5, 0.0, 5.0]);
        assert_eq!((a - b).0, [-2.0, -2.5, 0.0, 13.0]);
        assert_eq!((a * b).0, [3.0, -1.0, 0.0, -36.0]);
        assert_eq!((a / Lanes::splat(2.0)).0, [0.5, -1.0, 0.0, 4.5]);
        assert_eq!((2.0 - a).0, [1.0, 4.0, 2.0, -7.0]);
        assert_eq!((-a).0, [-1.0, 2.0, -0.0, -9.0]);
        assert_eq!(Lanes([4.0, 9.0, 0.0, 2.25]).sqrt().0, [2.0, 3.0, 0.0, 1.5]);
        assert_eq!(a.gt(b).select(a, b).0, [3.0, 0.5, 0.0, 9.0]);
        assert_eq!(a.ge(b).select(a, b).0, [3.0, 0.5, 0.0, 9.0]);
        assert_eq!(Lanes::ZERO.gt(b).select(a, b).0, [3.0, 0.5, 0.0, 9.0]);
        assert_eq!(Lanes([1.0, 2.0, 4.0, 8.0]).sum(), 15.0);
        let mut c = a;
        c += b;
        assert_eq!(c, a + b);
        assert_eq!(
            Lanes::load(&[0.0, 1.0, 2.0, 3.0, 4.0], 1).0,
            [1.0, 2.0, 3.0, 4.0]
        );
    }
}

//! Eight `f64` handled side by side by the RPY quadrature kernels ([`super::rpy`]).
//!
//! A plain array with element-wise operations, each a loop over the lanes that the compiler
//! turns into vector instructions of the widest kind the function it is inlined into may use:
//! one AVX-512 register in the copy of a kernel compiled for AVX-512, two AVX registers in the
//! copy compiled for AVX2 and FMA, four SSE2 registers in the baseline x86-64 copy. `wide::f64x4`,
//! used before, fixed its representation when the crate was compiled (two SSE2 registers on the
//! default target), so in the copy compiled for AVX2 it still ran as pairs of 128-bit operations
//! (seen in the disassembly). Eight lanes fill an AVX-512 register (checked in the disassembly:
//! the AVX-512 copy of the velocity kernel works on `zmm` registers only); with four, the
//! AVX-512 copy would have used half of each.
//!
//! Every lane is computed by the same IEEE operation whatever the registers (no operation is
//! fused: Rust contracts no `a * b + c` into an FMA by itself), so every copy gives the same bits.

use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// Lanes per vector.
pub(crate) const LANES: usize = 8;

/// One `f64` per lane.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
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

    /// The sum of the lanes, `((l0 + l4) + (l2 + l6)) + ((l1 + l5) + (l3 + l7))` (the halves
    /// added lane by lane, twice, then the last two).
    #[inline(always)]
    pub fn sum(self) -> f64 {
        let [a, b, c, d, e, f, g, h] = self.0;
        ((a + e) + (c + g)) + ((b + f) + (d + h))
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

    /// The bits of every lane.
    fn bits(v: Lanes) -> [u64; LANES] {
        v.0.map(f64::to_bits)
    }

    /// Each operation is the scalar one in every lane (bit for bit, signed zeros included).
    #[test]
    fn lanes_compute_the_scalar_operations() {
        let a = Lanes([1.0, -2.0, 0.0, 9.0, 0.5, -7.0, 3.0, 100.0]);
        let b = Lanes([3.0, 0.5, -0.0, -4.0, 2.0, -7.0, -1.0, 0.25]);
        let scalar =
            |f: &dyn Fn(f64, f64) -> f64| bits(Lanes(std::array::from_fn(|i| f(a.0[i], b.0[i]))));
        assert_eq!(bits(a + b), scalar(&|x, y| x + y));
        assert_eq!(bits(a - b), scalar(&|x, y| x - y));
        assert_eq!(bits(a * b), scalar(&|x, y| x * y));
        assert_eq!(bits(a / b), scalar(&|x, y| x / y));
        assert_eq!(bits(2.0 - a), scalar(&|x, _| 2.0 - x));
        assert_eq!(bits(-a), scalar(&|x, _| -x));
        assert_eq!(bits(b.sqrt()), scalar(&|_, y| y.sqrt()));
        assert_eq!(
            bits(a.gt(b).select(a, b)),
            scalar(&|x, y| if x > y { x } else { y })
        );
        assert_eq!(
            bits(a.ge(b).select(a, b)),
            scalar(&|x, y| if x >= y { x } else { y })
        );
        // 0 > -0 is false, 0 >= -0 is true: the two conditions pick different zeros.
        assert_ne!(bits(a.gt(b).select(a, b))[2], bits(a.ge(b).select(a, b))[2]);
        let powers = Lanes(std::array::from_fn(|i| (1u64 << i) as f64));
        assert_eq!(powers.sum(), 255.0);
        // The order of the sum: 1e16 + 1 - 1e16 in lanes 0, 4, 2 gives 0, not 1.
        let mut cancel = Lanes::ZERO;
        (cancel.0[0], cancel.0[4], cancel.0[2]) = (1e16, 1.0, -1e16);
        assert_eq!(cancel.sum(), ((1e16 + 1.0) + -1e16) + 0.0);
        let mut c = a;
        c += b;
        assert_eq!(c, a + b);
        let v: Vec<f64> = (0..=LANES).map(|i| i as f64).collect();
        assert_eq!(
            Lanes::load(&v, 1).0,
            std::array::from_fn(|i| (i + 1) as f64)
        );
    }
}

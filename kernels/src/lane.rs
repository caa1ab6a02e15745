//! W strands in lanes: [`Lane`], the value the step computes in when it advances W
//! strands of one N per call (one strand per lane), with the masks that take the place
//! of the scalar step's branches (docs/architecture.md, "Strands in lanes").
//!
//! [`Lanes`] is W values of a [`Float`] in an array. Every operation is the scalar's IEEE
//! operation done lane by lane, in the scalar's order and without fused multiply-add, so
//! each lane gives the bits the scalar code gives for its strand (checked in the tests).
//! The array form is what the compiler turns into vector instructions of the width the
//! surrounding code is compiled for: a caller that wants AVX2 or AVX-512 monomorphises
//! its lane code inside a `#[target_feature]` function (as the kernels' AVX2 paths do),
//! choosing the width at run time with [`widest_f64_lanes`] and [`widest_f32_lanes`].
//!
//! A branch of the scalar step becomes a [`Lane::select`] of both sides (both computed)
//! where they are cheap, or a test of [`Mask::any`] around the rare side. This is the
//! first part of the plan; the step does not compute in lanes yet. An `f64` or `f32` on
//! either side of an operation with lanes of its type acts on every lane, so that code
//! written for one element runs on lanes unchanged (the generated closed forms' `*_lanes`
//! copies).

use crate::float::Float;

pub mod lu;
pub mod soa;
use core::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Sub};

/// Which lanes a comparison held for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Mask<const W: usize>(pub [bool; W]);

impl<const W: usize> Mask<W> {
    /// Whether it holds in any lane.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0.iter().any(|&m| m)
    }
    /// Whether it holds in every lane.
    #[inline(always)]
    pub fn all(self) -> bool {
        self.0.iter().all(|&m| m)
    }
    /// How many lanes hold.
    #[inline(always)]
    pub fn count(self) -> usize {
        self.0.iter().filter(|&&m| m).count()
    }
}

impl<const W: usize> BitAnd for Mask<W> {
    type Output = Self;
    /// Lane by lane, both.
    #[inline(always)]
    fn bitand(self, other: Self) -> Self {
        Mask(core::array::from_fn(|k| self.0[k] & other.0[k]))
    }
}

impl<const W: usize> BitOr for Mask<W> {
    type Output = Self;
    /// Lane by lane, either.
    #[inline(always)]
    fn bitor(self, other: Self) -> Self {
        Mask(core::array::from_fn(|k| self.0[k] | other.0[k]))
    }
}

impl<const W: usize> Not for Mask<W> {
    type Output = Self;
    /// Lane by lane, not.
    #[inline(always)]
    fn not(self) -> Self {
        Mask(self.0.map(|m| !m))
    }
}

/// A value of W lanes the step computes in, one strand per lane.
pub trait Lane:
    Copy
    + core::fmt::Debug
    + PartialEq
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// The type of one lane.
    type Scalar: Float;
    /// Which lanes a comparison held for.
    type Mask: Copy;
    /// The number of lanes.
    const WIDTH: usize;
    /// `x` in every lane.
    fn splat(x: Self::Scalar) -> Self;
    /// Lane k is `f(k)`.
    fn from_fn(f: impl FnMut(usize) -> Self::Scalar) -> Self;
    /// Lane `k` (< [`Self::WIDTH`]).
    fn lane(self, k: usize) -> Self::Scalar;
    /// Set lane `k` (< [`Self::WIDTH`]) to `x`.
    fn set_lane(&mut self, k: usize, x: Self::Scalar);
    /// The square root of each lane.
    fn sqrt(self) -> Self;
    /// The absolute value of each lane.
    fn abs(self) -> Self;
    /// The sine and cosine of each lane.
    fn sin_cos(self) -> (Self, Self);
    /// The lanes where `self < other` (false with a NaN).
    fn lt(self, other: Self) -> Self::Mask;
    /// The lanes where `self <= other` (false with a NaN).
    fn le(self, other: Self) -> Self::Mask;
    /// `a` where `mask` holds, else `b`.
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self;
}

/// W values of `T`, one per lane.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lanes<T, const W: usize>(pub [T; W]);

macro_rules! lane_wise {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl<T: Float, const W: usize> $trait for Lanes<T, W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: Self) -> Self {
                Lanes(core::array::from_fn(|k| self.0[k] $op rhs.0[k]))
            }
        }
    )*};
}

lane_wise!(Add add +, Sub sub -, Mul mul *, Div div /);

macro_rules! lane_wise_assign {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl<T: Float, const W: usize> core::ops::$trait for Lanes<T, W> {
            #[inline(always)]
            fn $method(&mut self, rhs: Self) {
                *self = *self $op rhs;
            }
        }
    )*};
}

// what nalgebra's matrices of lanes need (`Matrix3<Lanes<f64, 4>>`: the step's small
// algebra written once for one strand and for W)
lane_wise_assign!(AddAssign add_assign +, SubAssign sub_assign -, MulAssign mul_assign *, DivAssign div_assign /);

impl<T: Float, const W: usize> Default for Lanes<T, W> {
    /// Zero in every lane.
    #[inline(always)]
    fn default() -> Self {
        Lanes([T::zero(); W])
    }
}

impl<T: Float, const W: usize> crate::lanes::Real for Lanes<T, W> {
    type Scalar = T;
    #[inline(always)]
    fn splat(x: T) -> Self {
        Lanes([x; W])
    }
}

impl<T: Float, const W: usize> num_traits::Zero for Lanes<T, W> {
    #[inline(always)]
    fn zero() -> Self {
        Lanes([T::zero(); W])
    }
    /// Whether every lane is zero (nalgebra skips a term only when all lanes may).
    #[inline(always)]
    fn is_zero(&self) -> bool {
        self.0.iter().all(|x| x.is_zero())
    }
}

impl<T: Float, const W: usize> num_traits::One for Lanes<T, W> {
    #[inline(always)]
    fn one() -> Self {
        Lanes([T::one(); W])
    }
}

// a scalar on either side acts on every lane, its operand order kept (`2.0 * x` is
// `[2.0 * x₀, …]`): the generated closed forms run on lanes as written for one element
macro_rules! scalar_wise {
    ($scalar:ty: $($trait:ident $method:ident $op:tt),*) => {$(
        impl<const W: usize> $trait<$scalar> for Lanes<$scalar, W> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, rhs: $scalar) -> Self {
                Lanes(self.0.map(|x| x $op rhs))
            }
        }
        impl<const W: usize> $trait<Lanes<$scalar, W>> for $scalar {
            type Output = Lanes<$scalar, W>;
            #[inline(always)]
            fn $method(self, rhs: Lanes<$scalar, W>) -> Lanes<$scalar, W> {
                Lanes(rhs.0.map(|x| self $op x))
            }
        }
    )*
        impl<const W: usize> From<$scalar> for Lanes<$scalar, W> {
            /// `x` in every lane.
            #[inline(always)]
            fn from(x: $scalar) -> Self {
                Lanes([x; W])
            }
        }
    };
}

scalar_wise!(f64: Add add +, Sub sub -, Mul mul *, Div div /);
scalar_wise!(f32: Add add +, Sub sub -, Mul mul *, Div div /);

impl<T: Float, const W: usize> Neg for Lanes<T, W> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Lanes(self.0.map(|x| -x))
    }
}

impl<T: Float, const W: usize> Lane for Lanes<T, W> {
    type Scalar = T;
    type Mask = Mask<W>;
    const WIDTH: usize = W;
    #[inline(always)]
    fn splat(x: T) -> Self {
        Lanes([x; W])
    }
    #[inline(always)]
    fn from_fn(f: impl FnMut(usize) -> T) -> Self {
        Lanes(core::array::from_fn(f))
    }
    #[inline(always)]
    fn lane(self, k: usize) -> T {
        self.0[k]
    }
    #[inline(always)]
    fn set_lane(&mut self, k: usize, x: T) {
        self.0[k] = x;
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        Lanes(self.0.map(|x| x.sqrt()))
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Lanes(self.0.map(|x| x.abs()))
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let pairs = self.0.map(|x| x.sin_cos());
        (Lanes(pairs.map(|p| p.0)), Lanes(pairs.map(|p| p.1)))
    }
    #[inline(always)]
    fn lt(self, other: Self) -> Mask<W> {
        Mask(core::array::from_fn(|k| self.0[k] < other.0[k]))
    }
    #[inline(always)]
    fn le(self, other: Self) -> Mask<W> {
        Mask(core::array::from_fn(|k| self.0[k] <= other.0[k]))
    }
    #[inline(always)]
    fn select(mask: Mask<W>, a: Self, b: Self) -> Self {
        Lanes(core::array::from_fn(|k| {
            if mask.0[k] {
                a.0[k]
            } else {
                b.0[k]
            }
        }))
    }
}

/// The widest vector of f64 this CPU computes in, in lanes: 8 with AVX-512, 4 with AVX2,
/// 2 otherwise (SSE2, NEON) — the width a caller monomorphises its lane code for.
#[cfg(feature = "std")]
pub fn widest_f64_lanes() -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return 8;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return 4;
        }
    }
    2
}

/// [`widest_f64_lanes`] for f32: twice as many lanes.
#[cfg(feature = "std")]
pub fn widest_f32_lanes() -> usize {
    2 * widest_f64_lanes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::ComplexField;

    /// Values that exercise the IEEE cases: signed zeros, subnormal, huge, NaN, ±∞.
    const VALUES: [f64; 8] = [
        0.0,
        -0.0,
        1.5e-310,
        -3.25,
        7.0e300,
        f64::NAN,
        f64::INFINITY,
        0.1,
    ];

    fn same(a: f64, b: f64) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// Each lane of each operation gives the scalar operation's bits on its lane's values,
    /// for every pair of the values (rotated through the lanes).
    #[test]
    fn every_lane_is_the_scalar_operation() {
        for shift in 0..8 {
            let a = Lanes::<f64, 8>::from_fn(|k| VALUES[k]);
            let b = Lanes::<f64, 8>::from_fn(|k| VALUES[(k + shift) % 8]);
            let (s, c) = a.sin_cos();
            for k in 0..8 {
                let (x, y) = (VALUES[k], VALUES[(k + shift) % 8]);
                assert!(same((a + b).lane(k), x + y));
                assert!(same((a - b).lane(k), x - y));
                assert!(same((a * b).lane(k), x * y));
                assert!(same((a / b).lane(k), x / y));
                assert!(same((-a).lane(k), -x));
                assert!(same(a.sqrt().lane(k), x.sqrt()));
                assert!(same(a.abs().lane(k), x.abs()));
                let (sx, cx) = ComplexField::sin_cos(x);
                assert!(same(s.lane(k), sx));
                assert!(same(c.lane(k), cx));
                assert_eq!(a.lt(b).0[k], x < y);
                assert_eq!(a.le(b).0[k], x <= y);
                let m = a.lt(b);
                let chosen = Lanes::select(m, a, b).lane(k);
                assert!(same(chosen, if x < y { x } else { y }));
            }
        }
    }

    /// A scalar on either side of an operation acts on every lane in its order.
    #[test]
    fn scalars_act_on_every_lane_in_order() {
        for &y in &VALUES {
            let a = Lanes::<f64, 8>::from_fn(|k| VALUES[k]);
            for k in 0..8 {
                let x = VALUES[k];
                assert!(same((a + y).lane(k), x + y));
                assert!(same((y - a).lane(k), y - x));
                assert!(same((a - y).lane(k), x - y));
                assert!(same((y * a).lane(k), y * x));
                assert!(same((y / a).lane(k), y / x));
                assert!(same((a / y).lane(k), x / y));
                assert!(same(Lanes::<f64, 8>::from(y).lane(k), y));
            }
        }
        let b = Lanes::<f32, 16>::from_fn(|k| k as f32 - 3.5);
        assert_eq!((1.5f32 - b).lane(2).to_bits(), (1.5f32 - -1.5).to_bits());
    }

    /// A comparison with a NaN holds in no lane; the mask operations are lane-wise.
    #[test]
    fn masks_follow_ieee_comparisons() {
        let a = Lanes::<f64, 4>([1.0, f64::NAN, 3.0, -0.0]);
        let b = Lanes::<f64, 4>([2.0, 0.0, f64::NAN, 0.0]);
        assert_eq!(a.lt(b), Mask([true, false, false, false]));
        assert_eq!(a.le(b), Mask([true, false, false, true]));
        let m = a.le(b);
        assert!(m.any() && !m.all());
        assert_eq!(m.count(), 2);
        assert_eq!(!m, Mask([false, true, true, false]));
        assert_eq!(m & a.lt(b), Mask([true, false, false, false]));
        assert_eq!((m | Mask([false, true, false, false])).count(), 3);
    }

    /// f32 lanes are f32's operations.
    #[test]
    fn f32_lanes_are_f32_operations() {
        let a = Lanes::<f32, 16>::from_fn(|k| k as f32 * 0.37 - 2.0);
        let b = Lanes::<f32, 16>::splat(1.3);
        for k in 0..16 {
            let x = k as f32 * 0.37 - 2.0;
            assert_eq!((a * b + a).lane(k).to_bits(), (x * 1.3 + x).to_bits());
            let (sx, _) = ComplexField::sin_cos(x);
            assert_eq!(a.sin_cos().0.lane(k).to_bits(), sx.to_bits());
        }
    }

    /// The widths offered are those of the CPU's vectors.
    #[cfg(feature = "std")]
    #[test]
    fn the_widest_lanes_are_a_vector_width() {
        let w = widest_f64_lanes();
        assert!([2, 4, 8].contains(&w), "{w}");
        assert_eq!(widest_f32_lanes(), 2 * w);
    }
}

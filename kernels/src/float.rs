//! The floating-point type the step computes in: [`Float`], implemented by `f64` (the
//! runtime's type, and the default everywhere) and `f32` (what game engines store).
//!
//! Every generic function of the kernels is written once over `T: Float`; monomorphised
//! for `f64` it performs the operations of the f64 code, in the same order, so it gives
//! the same bits. The trait adds to nalgebra's [`RealField`] (which gives `sqrt`, `abs`,
//! `max`, `is_finite`, … from std or libm, as the kernels' [`crate::math`] does) what the
//! kernels need beyond it: conversions from the `f64` constants of the source, the
//! type's machine epsilon for round-off tolerances, and four lanes of the type for the
//! rotary-inertia quadrature.
//!
//! Round-off tolerances scale with the type's epsilon: the residual of an eigenpair, the
//! convergence of the QL and Jacobi iterations ([`Float::EPSILON`], [`Float::roundoff`])
//! and the energy balance's allowance for the round-off of an energy
//! ([`Float::ENERGY_ROUNDOFF`]: 4504 ε in f64, 64 ε in f32, see
//! [`crate::energy::ROUNDOFF_F32`]); tolerances that are not round-off (how far an
//! element may turn in one step, how much coupling a reused eigenbasis may have, the
//! energy the balance lets a step create) are the same in both types.

use crate::energy::{ROUNDOFF, ROUNDOFF_F32};
use crate::lanes::{F32x4, Real, F4};
use core::cmp::Ordering;
use nalgebra::RealField;

/// What the step's small algebra (nalgebra's fixed-size vectors and matrices, the
/// element moments, the suffix bodies) needs of its scalar: the arithmetic of one
/// strand's [`Float`], or of W strands' [`crate::lane::Lanes`], one per lane. Code
/// written over it is the same operations in the same order for one strand and for W,
/// so each lane gives the one strand's bits (docs/architecture.md, "Strands in lanes").
pub trait Arith:
    nalgebra::Scalar
    + Copy
    + Default
    + Send
    + Sync
    + num_traits::Zero
    + num_traits::One
    + nalgebra::ClosedAddAssign
    + nalgebra::ClosedSubAssign
    + nalgebra::ClosedMulAssign
    + nalgebra::ClosedDivAssign
    + core::ops::Neg<Output = Self>
{
}

impl<T> Arith for T where
    T: nalgebra::Scalar
        + Copy
        + Default
        + Send
        + Sync
        + num_traits::Zero
        + num_traits::One
        + nalgebra::ClosedAddAssign
        + nalgebra::ClosedSubAssign
        + nalgebra::ClosedMulAssign
        + nalgebra::ClosedDivAssign
        + core::ops::Neg<Output = T>
{
}

/// A scalar type of the step: `f64` or `f32`.
pub trait Float:
    Arith + RealField + Copy + Default + core::iter::Sum + core::fmt::Debug + Send + Sync + 'static
{
    /// Four lanes of the type (the rotary-inertia quadrature evaluates four points at
    /// once): [`F4`] for `f64`, [`F32x4`] for `f32`.
    type Lanes: Real<Scalar = Self> + Default + PartialEq + core::fmt::Debug + Send + Sync;
    /// Machine epsilon (`f64::EPSILON`, `f32::EPSILON`).
    const EPSILON: Self;
    /// `EPSILON / f64::EPSILON` (1 for `f64`, 2²⁹ for `f32`): by how much a round-off
    /// tolerance written for `f64` grows in this type.
    const EPSILON_RATIO: f64;
    /// `"f64"` or `"f32"`.
    const NAME: &'static str;
    /// Relative round-off allowed in an energy of the energy balance: [`ROUNDOFF`] in
    /// `f64`, [`ROUNDOFF_F32`] in `f32` (see there why the two are not in the ratio of the
    /// epsilons).
    const ENERGY_ROUNDOFF: Self;
    /// `x` rounded to the type (exact for `f64`).
    fn of(x: f64) -> Self;
    /// The value as `f64` (exact).
    fn as_f64(self) -> f64;
    /// A round-off tolerance written for `f64`, `x`, in this type: `x · EPSILON_RATIO`
    /// (`x` itself in `f64`).
    #[inline(always)]
    fn roundoff(x: f64) -> Self {
        Self::of(x * Self::EPSILON_RATIO)
    }
    /// Whether the two values have the same bits.
    fn same_bits(self, other: Self) -> bool;
    /// The power of two just above the finite positive `self` (1 for a subnormal
    /// value, or one so large that its double would overflow).
    fn power_of_two_above(self) -> Self;
    /// The IEEE total order (`f64::total_cmp`).
    fn total_order(&self, other: &Self) -> Ordering;
    /// Not a number.
    fn nan() -> Self;
    /// Whether the value is not a number.
    #[inline(always)]
    #[allow(clippy::eq_op)]
    fn not_a_number(self) -> bool {
        self != self
    }
    /// Lane `k` (< 4) of `lanes`.
    fn lane(lanes: &Self::Lanes, k: usize) -> Self;
    /// Set lane `k` (< 4) of `lanes` to `x`.
    fn set_lane(lanes: &mut Self::Lanes, k: usize, x: Self);
}

impl Float for f64 {
    type Lanes = F4;
    const EPSILON: f64 = f64::EPSILON;
    const EPSILON_RATIO: f64 = 1.0;
    const NAME: &'static str = "f64";
    const ENERGY_ROUNDOFF: f64 = ROUNDOFF;
    #[inline(always)]
    fn of(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn as_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn same_bits(self, other: f64) -> bool {
        self.to_bits() == other.to_bits()
    }
    fn power_of_two_above(self) -> f64 {
        let exponent = (self.to_bits() >> 52) & 0x7ff;
        if exponent == 0 || exponent >= 0x7fe {
            return 1.0;
        }
        f64::from_bits((exponent + 1) << 52)
    }
    #[inline(always)]
    fn total_order(&self, other: &f64) -> Ordering {
        self.total_cmp(other)
    }
    #[inline(always)]
    fn nan() -> f64 {
        f64::NAN
    }
    #[inline(always)]
    fn lane(lanes: &F4, k: usize) -> f64 {
        lanes.0[k]
    }
    #[inline(always)]
    fn set_lane(lanes: &mut F4, k: usize, x: f64) {
        lanes.0[k] = x;
    }
}

impl Float for f32 {
    type Lanes = F32x4;
    const EPSILON: f32 = f32::EPSILON;
    const EPSILON_RATIO: f64 = f32::EPSILON as f64 / f64::EPSILON;
    const NAME: &'static str = "f32";
    const ENERGY_ROUNDOFF: f32 = ROUNDOFF_F32;
    #[inline(always)]
    fn of(x: f64) -> f32 {
        x as f32
    }
    #[inline(always)]
    fn as_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn same_bits(self, other: f32) -> bool {
        self.to_bits() == other.to_bits()
    }
    fn power_of_two_above(self) -> f32 {
        let exponent = (self.to_bits() >> 23) & 0xff;
        if exponent == 0 || exponent >= 0xfe {
            return 1.0;
        }
        f32::from_bits((exponent + 1) << 23)
    }
    #[inline(always)]
    fn total_order(&self, other: &f32) -> Ordering {
        self.total_cmp(other)
    }
    #[inline(always)]
    fn nan() -> f32 {
        f32::NAN
    }
    #[inline(always)]
    fn lane(lanes: &F32x4, k: usize) -> f32 {
        lanes.0[k]
    }
    #[inline(always)]
    fn set_lane(lanes: &mut F32x4, k: usize, x: f32) {
        lanes.0[k] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_and_powers_of_two() {
        assert_eq!(f32::EPSILON_RATIO, (1u64 << 29) as f64);
        assert_eq!(<f64 as Float>::roundoff(1e-12), 1e-12);
        assert!((<f32 as Float>::roundoff(1e-12) - 5.37e-4).abs() < 1e-6);
        for x in [1e-30f64, 0.3, 0.5, 1.0, 3.0, 1e30] {
            let p = x.power_of_two_above();
            assert!(p > x && p <= 2.0 * x, "{x}: {p}");
            let p = (x as f32).power_of_two_above();
            assert!(p > x as f32 && p <= 2.0 * x as f32, "{x}: {p}");
        }
        assert_eq!(f32::MAX.power_of_two_above(), 1.0);
        assert!(f32::nan().not_a_number() && !1.0f32.not_a_number());
    }
}

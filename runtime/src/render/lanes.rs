//! Eight f32 lanes for keeping the render strands out of the bodies
//! ([`super::clearance`]): the keep-out is written once, generic over [`Lanes`], and runs
//! on `wide::f32x8` (two SSE registers in a default x86-64 build, one AVX register in a
//! build for AVX) or, on an x86-64 CPU with AVX2 found at run time, on [`Avx`] (one AVX
//! register, whatever the build), inside code compiled for AVX2
//! ([`super::semi_interpolation`]; the kernels choose their AVX2 paths the same way).
//! Only IEEE operations one lane at a time (no fused multiply-add): every path gives the
//! same bits. A mask is a value whose lanes are all
//! ones (true) or all zeros (false), as SIMD compares give them.

use std::fmt::Debug;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};
use wide::f32x8;

/// Eight f32 lanes, and masks of eight lanes.
pub(super) trait Lanes:
    Copy
    + Debug
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + BitAnd<Output = Self>
    + BitOr<Output = Self>
{
    /// `v` in every lane.
    fn splat(v: f32) -> Self;
    /// The lanes `v`.
    fn from_array(v: [f32; 8]) -> Self;
    /// The lanes.
    fn to_array(self) -> [f32; 8];
    /// Square root of each lane.
    fn sqrt(self) -> Self;
    /// The larger of each pair of lanes.
    fn max(self, rhs: Self) -> Self;
    /// The smaller of each pair of lanes.
    fn min(self, rhs: Self) -> Self;
    /// Mask of the lanes where `self < rhs` (false with a NaN).
    fn lt(self, rhs: Self) -> Self;
    /// Mask of the lanes where `self <= rhs` (false with a NaN).
    fn le(self, rhs: Self) -> Self;
    /// Mask of the lanes where `self > rhs` (false with a NaN).
    fn gt(self, rhs: Self) -> Self;
    /// Mask of the lanes where `self == rhs` (false with a NaN).
    fn eq(self, rhs: Self) -> Self;
    /// Mask of the lanes where `self != rhs` (true with a NaN).
    fn ne(self, rhs: Self) -> Self;
    /// For a mask: `a` in its true lanes, `b` in the others.
    fn select(self, a: Self, b: Self) -> Self;
    /// For a mask: bit i set where lane i is true.
    fn bitmask(self) -> u32;

    /// For a mask: whether no lane is true.
    #[inline(always)]
    fn none(self) -> bool {
        self.bitmask() == 0
    }
    /// For a mask: whether some lane is true.
    #[inline(always)]
    fn any(self) -> bool {
        self.bitmask() != 0
    }
}

impl Lanes for f32x8 {
    #[inline(always)]
    fn splat(v: f32) -> Self {
        f32x8::splat(v)
    }
    #[inline(always)]
    fn from_array(v: [f32; 8]) -> Self {
        f32x8::new(v)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 8] {
        f32x8::to_array(self)
    }
    #[inline(always)]
    fn sqrt(self) -> Self {
        f32x8::sqrt(self)
    }
    #[inline(always)]
    fn max(self, rhs: Self) -> Self {
        f32x8::max(self, rhs)
    }
    #[inline(always)]
    fn min(self, rhs: Self) -> Self {
        f32x8::min(self, rhs)
    }
    #[inline(always)]
    fn lt(self, rhs: Self) -> Self {
        self.simd_lt(rhs)
    }
    #[inline(always)]
    fn le(self, rhs: Self) -> Self {
        self.simd_le(rhs)
    }
    #[inline(always)]
    fn gt(self, rhs: Self) -> Self {
        self.simd_gt(rhs)
    }
    #[inline(always)]
    fn eq(self, rhs: Self) -> Self {
        self.simd_eq(rhs)
    }
    #[inline(always)]
    fn ne(self, rhs: Self) -> Self {
        self.simd_ne(rhs)
    }
    #[inline(always)]
    fn select(self, a: Self, b: Self) -> Self {
        f32x8::select(self, a, b)
    }
    #[inline(always)]
    fn bitmask(self) -> u32 {
        self.to_bitmask()
    }
}

#[cfg(target_arch = "x86_64")]
pub(super) use avx::Avx;

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::Lanes;
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

    /// Eight f32 lanes in one AVX register.
    ///
    /// Its operations are AVX instructions: a value of this type is only ever made inside
    /// the keep-out's AVX2 path, which [`super::super::semi_interpolation`] enters after
    /// `is_x86_feature_detected!("avx2")` (every `unsafe` block below relies on that).
    #[derive(Clone, Copy, Debug)]
    pub struct Avx(__m256);

    macro_rules! binary {
        ($trait:ident, $method:ident, $intrinsic:ident) => {
            impl $trait for Avx {
                type Output = Avx;
                #[inline(always)]
                fn $method(self, rhs: Avx) -> Avx {
                    // SAFETY: AVX is present (see the type's documentation)
                    Avx(unsafe { $intrinsic(self.0, rhs.0) })
                }
            }
        };
    }

    binary!(Add, add, _mm256_add_ps);
    binary!(Sub, sub, _mm256_sub_ps);
    binary!(Mul, mul, _mm256_mul_ps);
    binary!(Div, div, _mm256_div_ps);
    binary!(BitAnd, bitand, _mm256_and_ps);
    binary!(BitOr, bitor, _mm256_or_ps);

    // SAFETY (every block below): AVX is present (see the type's documentation); the
    // loads and stores go through arrays of exactly eight f32
    impl Lanes for Avx {
        #[inline(always)]
        fn splat(v: f32) -> Self {
            Avx(unsafe { _mm256_set1_ps(v) })
        }
        #[inline(always)]
        fn from_array(v: [f32; 8]) -> Self {
            Avx(unsafe { _mm256_loadu_ps(v.as_ptr()) })
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut out = [0.0; 8];
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
        #[inline(always)]
        fn sqrt(self) -> Self {
            Avx(unsafe { _mm256_sqrt_ps(self.0) })
        }
        #[inline(always)]
        fn max(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_max_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn min(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_min_ps(self.0, rhs.0) })
        }
        #[inline(always)]
        fn lt(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn le(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn gt(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn eq(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn ne(self, rhs: Self) -> Self {
            Avx(unsafe { _mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, rhs.0) })
        }
        #[inline(always)]
        fn select(self, a: Self, b: Self) -> Self {
            // blendv takes the second operand where the mask's sign bit is set
            Avx(unsafe { _mm256_blendv_ps(b.0, a.0, self.0) })
        }
        #[inline(always)]
        fn bitmask(self) -> u32 {
            unsafe { _mm256_movemask_ps(self.0) as u32 }
        }
    }
}

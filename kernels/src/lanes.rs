//! Small fixed-size algebra over a scalar that is `f64` or [`F4`], four `f64` lanes (or
//! `f32` and [`F32x4`] in the f32 step), so that one source evaluates an integrand at
//! one quadrature point or at four at once (the rotary-inertia quadrature, [`crate::moments::rotary`]); and [`F4`]'s mixed
//! operations with `f64`, so that the generated closed forms of four elements run as one
//! (`superhelix-generated`'s `*_closed_x4` functions).
//!
//! Every operation takes its terms in the order nalgebra does for `Matrix3<f64>` and
//! `Vector3<f64>` (a product's column sum left to right, a dot product `(a₀b₀ + a₁b₁) +
//! a₂b₂`, the cross product's component formulas), so each lane gives the bits nalgebra
//! gives for that point (checked in the tests). nalgebra's own generic code over a SIMD
//! scalar (simba's `AutoF64x4`) does not serve here: its matrices go through `try_map`
//! closures and `memcpy` calls that are not inlined, and the rotary quadrature is 20 %
//! slower with it instead of faster.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// What the small algebra below needs of its scalar: a ring's operations with zero
/// and one. Every scalar of the step is one (`f64`, `f32`, [`F4`], [`F32x4`], and the
/// lanes of [`crate::lane::Lanes`]).
pub trait Ring:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Neg<Output = Self>
    + num_traits::Zero
    + num_traits::One
{
}

impl<T> Ring for T where
    T: Copy
        + Add<Output = T>
        + Sub<Output = T>
        + Mul<Output = T>
        + Neg<Output = T>
        + num_traits::Zero
        + num_traits::One
{
}

/// A scalar of the lane algebra: `f64`, `f32`, [`F4`] or [`F32x4`].
pub trait Real: Ring {
    /// The type of one lane.
    type Scalar;
    /// All lanes `x`.
    fn splat(x: Self::Scalar) -> Self;
}

impl Real for f64 {
    type Scalar = f64;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        x
    }
}

impl Real for f32 {
    type Scalar = f32;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
}

/// Four `f64` lanes; every operation acts lane by lane.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(32))]
pub struct F4(pub [f64; 4]);

/// Four `f32` lanes (the rotary-inertia quadrature of the f32 step); every operation
/// acts lane by lane.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C, align(16))]
pub struct F32x4(pub [f32; 4]);

macro_rules! lane_op {
    ($lanes:ident, $trait:ident, $f:ident, $op:tt) => {
        impl $trait for $lanes {
            type Output = $lanes;
            #[inline(always)]
            fn $f(self, b: $lanes) -> $lanes {
                let a = self.0;
                let b = b.0;
                $lanes([a[0] $op b[0], a[1] $op b[1], a[2] $op b[2], a[3] $op b[3]])
            }
        }
    };
}
lane_op!(F4, Add, add, +);
lane_op!(F4, Sub, sub, -);
lane_op!(F4, Mul, mul, *);
lane_op!(F4, Div, div, /);
lane_op!(F32x4, Add, add, +);
lane_op!(F32x4, Sub, sub, -);
lane_op!(F32x4, Mul, mul, *);
lane_op!(F32x4, Div, div, /);

impl Neg for F32x4 {
    type Output = F32x4;
    #[inline(always)]
    fn neg(self) -> F32x4 {
        let a = self.0;
        F32x4([-a[0], -a[1], -a[2], -a[3]])
    }
}

macro_rules! zero_one {
    ($lanes:ident, $t:ty) => {
        impl num_traits::Zero for $lanes {
            #[inline(always)]
            fn zero() -> Self {
                $lanes([0.0; 4])
            }
            #[inline(always)]
            fn is_zero(&self) -> bool {
                self.0.iter().all(|&x| x == 0.0)
            }
        }
        impl num_traits::One for $lanes {
            #[inline(always)]
            fn one() -> Self {
                $lanes([1.0; 4])
            }
        }
    };
}
zero_one!(F4, f64);
zero_one!(F32x4, f32);

impl Real for F32x4 {
    type Scalar = f32;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        F32x4([x; 4])
    }
}

// an `f64` on either side acts on every lane, its operand order kept (`2.0 * x` is
// `[2.0 * x₀, …]`): the generated closed forms run on F4 as written for f64
macro_rules! scalar_op {
    ($trait:ident, $f:ident, $op:tt) => {
        impl $trait<f64> for F4 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, b: f64) -> F4 {
                let a = self.0;
                F4([a[0] $op b, a[1] $op b, a[2] $op b, a[3] $op b])
            }
        }
        impl $trait<F4> for f64 {
            type Output = F4;
            #[inline(always)]
            fn $f(self, b: F4) -> F4 {
                let b = b.0;
                F4([self $op b[0], self $op b[1], self $op b[2], self $op b[3]])
            }
        }
    };
}
scalar_op!(Add, add, +);
scalar_op!(Sub, sub, -);
scalar_op!(Mul, mul, *);
scalar_op!(Div, div, /);

impl From<f64> for F4 {
    #[inline(always)]
    fn from(x: f64) -> F4 {
        F4([x; 4])
    }
}

impl F4 {
    /// `(sin x, cos x)` lane by lane (`f64::sin_cos`).
    #[inline(always)]
    pub fn sin_cos(self) -> (F4, F4) {
        let [a, b, c, d] = self.0.map(crate::math::sin_cos);
        (F4([a.0, b.0, c.0, d.0]), F4([a.1, b.1, c.1, d.1]))
    }
    /// `√x` lane by lane.
    #[inline(always)]
    pub fn sqrt(self) -> F4 {
        F4(self.0.map(crate::math::sqrt))
    }
}

impl Neg for F4 {
    type Output = F4;
    #[inline(always)]
    fn neg(self) -> F4 {
        let a = self.0;
        F4([-a[0], -a[1], -a[2], -a[3]])
    }
}

impl Real for F4 {
    type Scalar = f64;
    #[inline(always)]
    fn splat(x: f64) -> Self {
        F4([x; 4])
    }
}

/// A 3-vector.
pub type V<T> = [T; 3];
/// A 3 × 3 matrix by columns: `m[c][r]`.
pub type M<T> = [[T; 3]; 3];

/// `a + b`.
#[inline(always)]
pub fn add<T: Ring>(a: &V<T>, b: &V<T>) -> V<T> {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a · s`.
#[inline(always)]
pub fn scale<T: Ring>(a: &V<T>, s: T) -> V<T> {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a · b`, as `(a₀b₀ + a₁b₁) + a₂b₂`.
#[inline(always)]
pub fn dot<T: Ring>(a: &V<T>, b: &V<T>) -> T {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`.
#[inline(always)]
pub fn cross<T: Ring>(a: &V<T>, b: &V<T>) -> V<T> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `[a]×`, the matrix of `x ↦ a × x`.
#[inline(always)]
pub fn cross_matrix<T: Ring>(a: &V<T>) -> M<T> {
    let z = T::zero();
    [[z, a[2], -a[1]], [-a[2], z, a[0]], [a[1], -a[0], z]]
}

/// `m x`: the columns times x's entries, summed left to right.
#[inline(always)]
pub fn mat_vec<T: Ring>(m: &M<T>, x: &V<T>) -> V<T> {
    let row = |r: usize| m[0][r] * x[0] + m[1][r] * x[1] + m[2][r] * x[2];
    [row(0), row(1), row(2)]
}

/// `a b`.
#[inline(always)]
pub fn mat_mul<T: Ring>(a: &M<T>, b: &M<T>) -> M<T> {
    [mat_vec(a, &b[0]), mat_vec(a, &b[1]), mat_vec(a, &b[2])]
}

/// `aᵀ`.
#[inline(always)]
pub fn transpose<T: Ring>(a: &M<T>) -> M<T> {
    [
        [a[0][0], a[1][0], a[2][0]],
        [a[0][1], a[1][1], a[2][1]],
        [a[0][2], a[1][2], a[2][2]],
    ]
}

/// `a − b` when `subtract`, else `a + b`, entry by entry.
#[inline(always)]
pub fn mat_add<T: Ring>(a: &M<T>, b: &M<T>, subtract: bool) -> M<T> {
    let mut out = *a;
    for c in 0..3 {
        for r in 0..3 {
            out[c][r] = if subtract {
                a[c][r] - b[c][r]
            } else {
                a[c][r] + b[c][r]
            };
        }
    }
    out
}

/// `a s`, entry by entry.
#[inline(always)]
pub fn mat_scale<T: Ring>(a: &M<T>, s: T) -> M<T> {
    [scale(&a[0], s), scale(&a[1], s), scale(&a[2], s)]
}

/// `a − b`.
#[inline(always)]
pub fn sub<T: Ring>(a: &V<T>, b: &V<T>) -> V<T> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a bᵀ`, entry (r, c) = a_r b_c (nalgebra's product of a column and a row).
#[inline(always)]
pub fn outer<T: Ring>(a: &V<T>, b: &V<T>) -> M<T> {
    [scale(a, b[0]), scale(a, b[1]), scale(a, b[2])]
}

/// nalgebra's `Matrix3::identity() * t − a`: the identity's entries times t (1·t and
/// 0·t), less a.
#[inline(always)]
pub fn identity_times_minus<T: Ring>(t: T, a: &M<T>) -> M<T> {
    let (one, zero) = (T::one() * t, T::zero() * t);
    let id = [[one, zero, zero], [zero, one, zero], [zero, zero, one]];
    mat_add(&id, a, true)
}

/// nalgebra's `dot` of two 3 × 3 matrices (entry by entry, column by column): its sum
/// from zero with, per column, the four (here zero) partial sums of its unrolled loop
/// added first, then the column's three products.
#[inline(always)]
pub fn mat_dot<T: Ring>(a: &M<T>, b: &M<T>) -> T {
    let zero = T::zero();
    let mut res = zero;
    for c in 0..3 {
        for _ in 0..4 {
            res = res + (zero + zero);
        }
        for r in 0..3 {
            res = res + a[c][r] * b[c][r];
        }
    }
    res
}

/// nalgebra's `a.component_mul(b).sum()`: the entries' products summed from zero,
/// column by column.
#[inline(always)]
pub fn sum_of_products<T: Ring>(a: &M<T>, b: &M<T>) -> T {
    let mut res = T::zero();
    for c in 0..3 {
        for r in 0..3 {
            res = res + a[c][r] * b[c][r];
        }
    }
    res
}

/// nalgebra's `trace()`: `((0 + a₀₀) + a₁₁) + a₂₂`.
#[inline(always)]
pub fn trace<T: Ring>(a: &M<T>) -> T {
    T::zero() + a[0][0] + a[1][1] + a[2][2]
}

/// nalgebra's 3-vector as [`V`] (its storage).
#[inline(always)]
pub fn v3<T: nalgebra::Scalar>(a: &nalgebra::Vector3<T>) -> &V<T> {
    &a.data.0[0]
}

/// nalgebra's 3 × 3 matrix as [`M`] (its storage, by columns).
#[inline(always)]
pub fn m3<T: nalgebra::Scalar>(a: &nalgebra::Matrix3<T>) -> &M<T> {
    &a.data.0
}

/// [`V`] as nalgebra's 3-vector.
#[inline(always)]
pub fn vector<T: nalgebra::Scalar>(a: V<T>) -> nalgebra::Vector3<T> {
    nalgebra::Vector3::from_array_storage(nalgebra::ArrayStorage([a]))
}

/// [`M`] as nalgebra's 3 × 3 matrix.
#[inline(always)]
pub fn matrix<T: nalgebra::Scalar>(a: M<T>) -> nalgebra::Matrix3<T> {
    nalgebra::Matrix3::from_array_storage(nalgebra::ArrayStorage(a))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    fn v(a: &Vector3<f64>) -> V<f64> {
        [a[0], a[1], a[2]]
    }
    fn m(a: &Matrix3<f64>) -> M<f64> {
        core::array::from_fn(|c| core::array::from_fn(|r| a[(r, c)]))
    }

    /// Each operation gives nalgebra's bits, over inputs spanning many magnitudes (where
    /// a different order of the terms would round differently).
    #[test]
    fn operations_match_nalgebra_bit_for_bit() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let unit = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            unit * 10f64.powi((state % 9) as i32 - 4)
        };
        let mut differing = 0;
        for _ in 0..2000 {
            let a = Vector3::from_fn(|_, _| next());
            let b = Vector3::from_fn(|_, _| next());
            let ma = Matrix3::from_fn(|_, _| next());
            let mb = Matrix3::from_fn(|_, _| next());
            let s = next();
            let checks = [
                v(&a.cross(&b)) == cross(&v(&a), &v(&b)),
                a.dot(&b) == dot(&v(&a), &v(&b)),
                v(&(ma * a)) == mat_vec(&m(&ma), &v(&a)),
                m(&(ma * mb)) == mat_mul(&m(&ma), &m(&mb)),
                m(&(a.cross_matrix() * mb)) == mat_mul(&cross_matrix(&v(&a)), &m(&mb)),
                m(&(ma + mb.transpose())) == mat_add(&m(&ma), &transpose(&m(&mb)), false),
                m(&((ma - b.cross_matrix()) * s))
                    == mat_scale(&mat_add(&m(&ma), &cross_matrix(&v(&b)), true), s),
                v(&(a * s + b)) == add(&scale(&v(&a), s), &v(&b)),
            ];
            differing += checks.iter().filter(|ok| !**ok).count();
        }
        assert_eq!(differing, 0);
    }

    /// F4 acts lane by lane: each lane of a product of F4 matrices is the f64 product.
    #[test]
    fn lanes_are_independent_f64_computations() {
        let f = |k: usize, c: usize, r: usize| ((k * 7 + c * 3 + r) as f64).sin() * 1e3;
        let a: M<F4> = core::array::from_fn(|c| {
            core::array::from_fn(|r| F4(core::array::from_fn(|k| f(k, c, r))))
        });
        let b = transpose(&a);
        let p = mat_mul(&a, &cross_matrix(&b[1]));
        for k in 0..4 {
            let ak: M<f64> = core::array::from_fn(|c| core::array::from_fn(|r| a[c][r].0[k]));
            let pk = mat_mul(&ak, &cross_matrix(&transpose(&ak)[1]));
            for c in 0..3 {
                for r in 0..3 {
                    assert_eq!(p[c][r].0[k].to_bits(), pk[c][r].to_bits());
                }
            }
        }
    }
}

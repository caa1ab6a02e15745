//! The few elementary functions the kernels call, from std when the `std` feature is on
//! (the runtime's build: the same bits as the rest of the runtime) and from `libm`
//! otherwise (an engine's `no_std` build).

/// √x.
#[inline(always)]
pub fn sqrt(x: f64) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::sqrt(x);
    #[cfg(not(feature = "std"))]
    return libm::sqrt(x);
}

/// (sin x, cos x).
#[inline(always)]
pub fn sin_cos(x: f64) -> (f64, f64) {
    #[cfg(feature = "std")]
    return std::primitive::f64::sin_cos(x);
    #[cfg(not(feature = "std"))]
    return libm::sincos(x);
}

/// sin x.
#[inline(always)]
pub fn sin(x: f64) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::sin(x);
    #[cfg(not(feature = "std"))]
    return libm::sin(x);
}

/// cos x.
#[inline(always)]
pub fn cos(x: f64) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::cos(x);
    #[cfg(not(feature = "std"))]
    return libm::cos(x);
}

/// ⌈x⌉.
#[inline(always)]
pub fn ceil(x: f64) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::ceil(x);
    #[cfg(not(feature = "std"))]
    return libm::ceil(x);
}

/// The largest integer not above x.
#[inline(always)]
pub fn floor(x: f64) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::floor(x);
    #[cfg(not(feature = "std"))]
    return libm::floor(x);
}

/// √x in f32 (for the generated f32 kernels).
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(feature = "std")]
    return std::primitive::f32::sqrt(x);
    #[cfg(not(feature = "std"))]
    return libm::sqrtf(x);
}

/// (sin x, cos x) in f32.
#[inline(always)]
pub fn sin_cosf(x: f32) -> (f32, f32) {
    #[cfg(feature = "std")]
    return std::primitive::f32::sin_cos(x);
    #[cfg(not(feature = "std"))]
    return libm::sincosf(x);
}

/// sin x in f32.
#[inline(always)]
pub fn sinf(x: f32) -> f32 {
    #[cfg(feature = "std")]
    return std::primitive::f32::sin(x);
    #[cfg(not(feature = "std"))]
    return libm::sinf(x);
}

/// cos x in f32.
#[inline(always)]
pub fn cosf(x: f32) -> f32 {
    #[cfg(feature = "std")]
    return std::primitive::f32::cos(x);
    #[cfg(not(feature = "std"))]
    return libm::cosf(x);
}

/// The elementary functions as methods, for code generated once for both `f64` and the
/// four-lane [`crate::lanes::F4`] (`x.sqrt()`, `x.sin_cos()`), and for the generated f32
/// kernels: on `f64` and `f32` in a `no_std` build they come from this trait (the
/// functions above); with std, the types' own methods (the same functions) take
/// precedence.
pub trait Elementary: Sized {
    /// √x.
    fn sqrt(self) -> Self;
    /// (sin x, cos x).
    fn sin_cos(self) -> (Self, Self);
    /// sin x.
    fn sin(self) -> Self;
    /// cos x.
    fn cos(self) -> Self;
}

impl Elementary for f64 {
    #[inline(always)]
    fn sqrt(self) -> f64 {
        sqrt(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (f64, f64) {
        sin_cos(self)
    }
    #[inline(always)]
    fn sin(self) -> f64 {
        sin(self)
    }
    #[inline(always)]
    fn cos(self) -> f64 {
        cos(self)
    }
}

/// xⁿ for an integer n.
#[inline(always)]
pub fn powi(x: f64, n: i32) -> f64 {
    #[cfg(feature = "std")]
    return std::primitive::f64::powi(x, n);
    #[cfg(not(feature = "std"))]
    return libm::pow(x, n as f64);
}

impl Elementary for f32 {
    #[inline(always)]
    fn sqrt(self) -> f32 {
        sqrtf(self)
    }
    #[inline(always)]
    fn sin_cos(self) -> (f32, f32) {
        sin_cosf(self)
    }
    #[inline(always)]
    fn sin(self) -> f32 {
        sinf(self)
    }
    #[inline(always)]
    fn cos(self) -> f32 {
        cosf(self)
    }
}

//! The floating-point type the generated code computes in ([`Float`]).
//!
//! The generator's own arithmetic (the symbolic engine, the measurements) is f64
//! throughout. With [`Float::F32`] the emitted functions take and return `f32`, their
//! literals are the constants rounded to `f32`, and the switch and Taylor degree are
//! chosen by measuring the branches *evaluated in f32 arithmetic* against an f64
//! reference (see [`crate::branch`] and [`crate::point`]).

use proc_macro2::TokenStream;
use quote::quote;

/// Floating-point type of the generated code.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Float {
    /// `f64` (the checked-in kernels the runtime uses).
    #[default]
    F64,
    /// `f32` (what game engines use): see the module docs.
    F32,
}

impl Float {
    /// `"f64"` or `"f32"`.
    pub fn name(self) -> &'static str {
        match self {
            Float::F64 => "f64",
            Float::F32 => "f32",
        }
    }

    /// Unit round-off `u` of the type: 2^-53 (f64), 2^-24 (f32); a correctly rounded
    /// operation errs by at most `u` relative.
    pub fn unit_roundoff(self) -> f64 {
        match self {
            Float::F64 => f64::EPSILON / 2.0,
            Float::F32 => f32::EPSILON as f64 / 2.0,
        }
    }

    /// `x` rounded to the type (unchanged for f64).
    pub fn round(self, x: f64) -> f64 {
        match self {
            Float::F64 => x,
            Float::F32 => x as f32 as f64,
        }
    }

    /// The type as tokens: `f64` or `f32`.
    pub(crate) fn ty(self) -> TokenStream {
        match self {
            Float::F64 => quote!(f64),
            Float::F32 => quote!(f32),
        }
    }
}

impl std::fmt::Display for Float {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

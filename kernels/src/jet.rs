//! Second-order forward-mode derivatives in three variables (the Darboux vector d of one
//! element): value, gradient and Hessian. Used by the generic kernel to differentiate
//! the per-element closed forms exactly — no finite differences anywhere.

use crate::helix_functions::Series3;
use core::ops::{Add, Mul, Neg, Sub};

/// A scalar with its gradient and Hessian with respect to three variables.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Jet {
    /// Value.
    pub v: f64,
    /// Gradient.
    pub g: [f64; 3],
    /// Hessian (symmetric).
    pub h: [[f64; 3]; 3],
}

impl Jet {
    /// Zero with zero derivatives. The operations below build on this constant rather
    /// than on `Default::default()`: the derived default goes through `[T; 3]`'s
    /// generic `default`, and whether the compiler inlines that one into `Mul` depended
    /// on unrelated code elsewhere in the crate (one such change made the generic
    /// kernel 15 % slower).
    pub const ZERO: Jet = Jet {
        v: 0.0,
        g: [0.0; 3],
        h: [[0.0; 3]; 3],
    };
    /// A constant.
    pub fn constant(v: f64) -> Jet {
        Jet { v, ..Jet::ZERO }
    }
    /// The i-th independent variable, at value v.
    pub fn var(v: f64, i: usize) -> Jet {
        let mut j = Jet::constant(v);
        j.g[i] = 1.0;
        j
    }
    /// Compose with f(z), given f, f' and f'' at z = self.v.
    pub fn compose(self, f: Series3) -> Jet {
        let mut out = Jet {
            v: f.f,
            ..Jet::ZERO
        };
        for i in 0..3 {
            out.g[i] = f.d1 * self.g[i];
            for j in 0..3 {
                out.h[i][j] = f.d2 * self.g[i] * self.g[j] + f.d1 * self.h[i][j];
            }
        }
        out
    }
    /// Multiply by a constant.
    pub fn scale(self, s: f64) -> Jet {
        let mut out = self;
        out.v *= s;
        for i in 0..3 {
            out.g[i] *= s;
            for j in 0..3 {
                out.h[i][j] *= s;
            }
        }
        out
    }
}

impl Add for Jet {
    type Output = Jet;
    fn add(self, o: Jet) -> Jet {
        let mut out = self;
        out.v += o.v;
        for i in 0..3 {
            out.g[i] += o.g[i];
            for j in 0..3 {
                out.h[i][j] += o.h[i][j];
            }
        }
        out
    }
}

impl Neg for Jet {
    type Output = Jet;
    fn neg(self) -> Jet {
        self.scale(-1.0)
    }
}

impl Sub for Jet {
    type Output = Jet;
    fn sub(self, o: Jet) -> Jet {
        self + (-o)
    }
}

impl Mul for Jet {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        let mut out = Jet {
            v: self.v * o.v,
            ..Jet::ZERO
        };
        for i in 0..3 {
            out.g[i] = self.g[i] * o.v + self.v * o.g[i];
            for j in 0..3 {
                out.h[i][j] = self.h[i][j] * o.v
                    + self.v * o.h[i][j]
                    + self.g[i] * o.g[j]
                    + self.g[j] * o.g[i];
            }
        }
        out
    }
}

impl Mul<Jet> for f64 {
    type Output = Jet;
    fn mul(self, o: Jet) -> Jet {
        o.scale(self)
    }
}

/// Cross product of two jet 3-vectors.
pub fn cross(a: &[Jet; 3], b: &[Jet; 3]) -> [Jet; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    #[allow(unused_imports)]
    use std::{format, vec, vec::Vec};

    #[test]
    fn product_rule_on_a_cubic() {
        // f = x0^2 x1 + 3 x2, at (1, 2, 3)
        let x0 = Jet::var(1.0, 0);
        let x1 = Jet::var(2.0, 1);
        let x2 = Jet::var(3.0, 2);
        let f = x0 * x0 * x1 + 3.0 * x2;
        assert_eq!(f.v, 11.0);
        assert_eq!(f.g, [4.0, 1.0, 3.0]);
        assert_eq!(f.h[0][0], 4.0);
        assert_eq!(f.h[0][1], 2.0);
        assert_eq!(f.h[1][0], 2.0);
        assert_eq!(f.h[1][1], 0.0);
        assert_eq!(f.h[2][2], 0.0);
    }
}

//! Numbers of the symbolic engine: exact rationals with a floating-point fallback.
//!
//! Every constant in the graph is a [`Num`]: an exact [`Rational`] (i128 numerator and
//! denominator, reduced, denominator positive) as long as the arithmetic stays in range,
//! otherwise an `f64`. Exactness matters where terms must cancel to zero: the Taylor
//! branch of an integral only has no division by W if the negative powers of W cancel
//! exactly, and they do, because they come from the first few Taylor coefficients
//! (small factorials). Only the high-order coefficients (e.g. 1/35!) can overflow i128,
//! and those never need to cancel; they fall back to `f64` with one rounding.
//!
//! A float result that is an integer below 2^53 is turned back into an exact rational,
//! so that equal values have one representation (hash-consing relies on it).

use std::cmp::Ordering;
use std::fmt;
use std::ops::{Mul, Neg};

/// An exact rational number `num / den`, reduced, with `den > 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Rational {
    num: i128,
    den: i128,
}

/// Greatest common divisor of |a| and |b| (saturated to i128::MAX for |i128::MIN|).
fn gcd(a: i128, b: i128) -> i128 {
    let (mut a, mut b) = (a.unsigned_abs(), b.unsigned_abs());
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    i128::try_from(a).unwrap_or(i128::MAX)
}

impl Rational {
    /// Zero.
    pub const ZERO: Rational = Rational { num: 0, den: 1 };

    /// `num / den`, reduced; `None` if `den == 0` or the reduction overflows.
    pub fn new(num: i128, den: i128) -> Option<Rational> {
        if den == 0 {
            return None;
        }
        let g = gcd(num, den).max(1);
        let (mut n, mut d) = (num / g, den / g);
        if d < 0 {
            n = n.checked_neg()?;
            d = d.checked_neg()?;
        }
        Some(Rational { num: n, den: d })
    }
    /// The integer `n`.
    pub fn int(n: i64) -> Rational {
        Rational {
            num: n as i128,
            den: 1,
        }
    }
    /// Numerator.
    pub fn numer(&self) -> i128 {
        self.num
    }
    /// Denominator (positive).
    pub fn denom(&self) -> i128 {
        self.den
    }
    /// Is it zero?
    pub fn is_zero(&self) -> bool {
        self.num == 0
    }
    /// Nearest `f64` (one rounding when both parts are below 2^53).
    pub fn to_f64(&self) -> f64 {
        self.num as f64 / self.den as f64
    }
    /// Exact sum, `None` on overflow.
    pub fn checked_add(self, o: Rational) -> Option<Rational> {
        let g = gcd(self.den, o.den);
        let a = self.num.checked_mul(o.den / g)?;
        let b = o.num.checked_mul(self.den / g)?;
        let den = (self.den / g).checked_mul(o.den)?;
        Rational::new(a.checked_add(b)?, den)
    }
    /// Exact product, `None` on overflow.
    pub fn checked_mul(self, o: Rational) -> Option<Rational> {
        let g1 = gcd(self.num, o.den).max(1);
        let g2 = gcd(o.num, self.den).max(1);
        let n = (self.num / g1).checked_mul(o.num / g2)?;
        let d = (self.den / g2).checked_mul(o.den / g1)?;
        Rational::new(n, d)
    }
    /// Exact reciprocal, `None` for zero.
    pub fn recip(self) -> Option<Rational> {
        Rational::new(self.den, self.num)
    }
    /// Numeric comparison (exact when the cross products fit, else through f64).
    pub fn cmp_value(&self, o: &Rational) -> Ordering {
        match (self.num.checked_mul(o.den), o.num.checked_mul(self.den)) {
            (Some(a), Some(b)) => a.cmp(&b),
            _ => self.to_f64().total_cmp(&o.to_f64()),
        }
    }
}

impl std::ops::Neg for Rational {
    type Output = Rational;
    fn neg(self) -> Rational {
        Rational {
            num: -self.num,
            den: self.den,
        }
    }
}

impl fmt::Display for Rational {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 {
            write!(f, "{}", self.num)
        } else {
            write!(f, "{}/{}", self.num, self.den)
        }
    }
}

/// A constant: exact rational when possible, else a float (see the module docs).
#[derive(Clone, Copy, Debug)]
pub enum Num {
    /// Exact value.
    Exact(Rational),
    /// Rounded value (only after an exact operation overflowed, or from a float input).
    Float(f64),
}

impl PartialEq for Num {
    fn eq(&self, o: &Num) -> bool {
        match (self, o) {
            (Num::Exact(a), Num::Exact(b)) => a == b,
            (Num::Float(a), Num::Float(b)) => a.to_bits() == b.to_bits(),
            _ => false,
        }
    }
}
impl Eq for Num {}
impl std::hash::Hash for Num {
    fn hash<H: std::hash::Hasher>(&self, h: &mut H) {
        match self {
            Num::Exact(r) => {
                0u8.hash(h);
                r.hash(h)
            }
            Num::Float(x) => {
                1u8.hash(h);
                x.to_bits().hash(h)
            }
        }
    }
}

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Num::Exact(r) => write!(f, "{r}"),
            Num::Float(x) => write!(f, "{x:e}"),
        }
    }
}

impl Num {
    /// Zero.
    pub const ZERO: Num = Num::Exact(Rational { num: 0, den: 1 });
    /// One.
    pub const ONE: Num = Num::Exact(Rational { num: 1, den: 1 });

    /// The integer `n`.
    pub fn int(n: i64) -> Num {
        Num::Exact(Rational::int(n))
    }
    /// `n / d` exactly (panics on `d == 0`: a generator-side programming error).
    pub fn ratio(n: i64, d: i64) -> Num {
        Num::Exact(Rational::new(n as i128, d as i128).expect("zero denominator"))
    }
    /// From a float; integers below 2^53 become exact.
    pub fn float(x: f64) -> Num {
        let x = if x == 0.0 { 0.0 } else { x };
        if x.fract() == 0.0 && x.abs() < 9.007_199_254_740_992e15 {
            Num::int(x as i64)
        } else {
            Num::Float(x)
        }
    }
    /// Value as f64.
    pub fn to_f64(&self) -> f64 {
        match self {
            Num::Exact(r) => r.to_f64(),
            Num::Float(x) => *x,
        }
    }
    /// Exact value, if any.
    pub fn exact(&self) -> Option<Rational> {
        match self {
            Num::Exact(r) => Some(*r),
            Num::Float(_) => None,
        }
    }
    /// Is it (exactly) zero?
    pub fn is_zero(&self) -> bool {
        match self {
            Num::Exact(r) => r.is_zero(),
            Num::Float(x) => *x == 0.0,
        }
    }
    /// Is it exactly one?
    pub fn is_one(&self) -> bool {
        *self == Num::ONE
    }
    /// Strictly negative?
    pub fn is_negative(&self) -> bool {
        match self {
            Num::Exact(r) => r.num < 0,
            Num::Float(x) => *x < 0.0,
        }
    }
    /// Reciprocal (a zero gives a float infinity).
    pub fn recip(self) -> Num {
        if let Num::Exact(r) = self {
            if let Some(q) = r.recip() {
                return Num::Exact(q);
            }
        }
        Num::float(1.0 / self.to_f64())
    }
    /// Integer power.
    pub fn powi(self, e: i32) -> Num {
        let base = if e < 0 { self.recip() } else { self };
        let mut out = Num::ONE;
        for _ in 0..e.unsigned_abs() {
            out = out.mul(base);
        }
        out
    }
    /// Absolute value.
    pub fn abs(self) -> Num {
        if self.is_negative() {
            self.neg()
        } else {
            self
        }
    }
}

impl std::ops::Add for Num {
    type Output = Num;
    fn add(self, o: Num) -> Num {
        if let (Num::Exact(a), Num::Exact(b)) = (self, o) {
            if let Some(r) = a.checked_add(b) {
                return Num::Exact(r);
            }
        }
        Num::float(self.to_f64() + o.to_f64())
    }
}

impl std::ops::Mul for Num {
    type Output = Num;
    fn mul(self, o: Num) -> Num {
        if let (Num::Exact(a), Num::Exact(b)) = (self, o) {
            if let Some(r) = a.checked_mul(b) {
                return Num::Exact(r);
            }
        }
        Num::float(self.to_f64() * o.to_f64())
    }
}

impl std::ops::Neg for Num {
    type Output = Num;
    fn neg(self) -> Num {
        match self {
            Num::Exact(r) => Num::Exact(-r),
            Num::Float(x) => Num::float(-x),
        }
    }
}

impl std::ops::Sub for Num {
    type Output = Num;
    fn sub(self, o: Num) -> Num {
        self + (-o)
    }
}

impl std::ops::Div for Num {
    type Output = Num;
    // a quotient is a product with the reciprocal
    #[allow(clippy::suspicious_arithmetic_impl)]
    fn div(self, o: Num) -> Num {
        self * o.recip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_arithmetic_and_fallback() {
        let a = Num::ratio(1, 6);
        assert_eq!(a.mul(Num::int(3)), Num::ratio(1, 2));
        assert_eq!(a + a + a - Num::ratio(1, 2), Num::ZERO);
        // 1/40! overflows i128 and falls back to a float
        let mut f = Num::ONE;
        for k in 1..=40 {
            f = f / Num::int(k);
        }
        assert!(matches!(f, Num::Float(_)));
        assert!((f.to_f64() * 8.159_152_832_478_977e47 - 1.0).abs() < 1e-14);
        assert_eq!(Num::float(3.0), Num::int(3));
    }
}

//! Exact integration over one element, `∫_0^l … du`, in two branches.
//!
//! The integrand is expanded into `Σ c · m · u^n · trig(k W u)` (`TPoly`); then
//! - **closed form**: each `∫_0^l u^n cos/sin(ω u) du` (ω = kW) by the integration by
//!   parts recursion
//!   `I_c(n) = l^n sin(ωl)/ω − (n/ω) I_s(n−1)`, `I_s(n) = −l^n cos(ωl)/ω + (n/ω) I_c(n−1)`,
//!   `I_c(0) = sin(ωl)/ω`, `I_s(0) = (1 − cos(ωl))/ω`; a result in `(d, W, l)` with
//!   negative powers of W, exact but losing digits as `W l → 0`;
//! - **Taylor series**: each trig factor replaced by its Taylor series in `W u`, then
//!   integrated term by term and truncated to total degree `order` in W. The negative
//!   powers of W cancel exactly (exact rational arithmetic, see [`crate::number`]),
//!   because the integrand is an analytic, even function of W; the result is a
//!   polynomial in `W, l, d` with no division. A left-over negative power is reported as
//!   [`CodegenError::NotRegular`].

use crate::graph::{Graph, Id};
use crate::helix::HelixSymbols;
use crate::number::{Num, Rational};
use crate::poly::{horner, mono_mul, mono_take, mono_var, Expander, Mono, TPoly, Trig, TrigKind};
use crate::CodegenError;
use std::collections::HashMap;
use std::ops::{Div, Mul, Neg};

/// Both branches of one element integral.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ElementIntegral {
    /// Closed form in `d, W, l` (for `W l` above the switch).
    pub closed: Id,
    /// Taylor branch: polynomial in `d, W, l` (for `W l` below the switch).
    pub series: Id,
    /// Degree in W at which the Taylor branch is truncated.
    pub series_order: u32,
}

/// A term of a result: trig factor, monomial, coefficient.
type Term = (Trig, Mono, Num);

/// One term of a base integral: `coef · l^lp · W^wp · trig(k W l)`.
type BaseTerm = (TrigKind, i32, i32, Num);

/// Expansion, integration and reconstruction with shared caches.
pub(crate) struct Integrator {
    pub h: HelixSymbols,
    ex: Expander,
    base: HashMap<(TrigKind, i32, Rational), Vec<BaseTerm>>,
    angles: HashMap<(Trig, bool), Id>,
    /// Write `sin(n W l)`, `cos(n W l)` for integer n ≥ 2 through the multiple-angle
    /// recurrences from `sin(W l)`, `cos(W l)` (one `sin_cos` call in the emitted code).
    pub multiple_angles: bool,
}

impl Integrator {
    pub fn new(h: HelixSymbols, multiple_angles: bool) -> Integrator {
        Integrator {
            h,
            ex: Expander::new(h.u, h.w),
            base: HashMap::new(),
            angles: HashMap::new(),
            multiple_angles,
        }
    }

    /// The integrand as a [`TPoly`] in `u`.
    pub fn expand(&mut self, g: &mut Graph, e: Id) -> Result<TPoly, CodegenError> {
        Ok((*self.ex.expand(g, e)?).clone())
    }

    /// `∫_0^l u^n trig(k W u) du` as a list of terms.
    fn base(&mut self, kind: TrigKind, n: i32, k: Rational) -> Vec<BaseTerm> {
        if let Some(b) = self.base.get(&(kind, n, k)) {
            return b.clone();
        }
        let ik = Num::Exact(k).recip();
        let mut v: Vec<BaseTerm> = Vec::new();
        match kind {
            TrigKind::One => v.push((TrigKind::One, n + 1, 0, Num::ratio(1, n as i64 + 1))),
            TrigKind::Cos => {
                v.push((TrigKind::Sin, n, -1, ik));
                if n > 0 {
                    let f = Num::int(-(n as i64)).mul(ik);
                    for (t, a, b, c) in self.base(TrigKind::Sin, n - 1, k) {
                        v.push((t, a, b - 1, f.mul(c)));
                    }
                }
            }
            TrigKind::Sin => {
                v.push((TrigKind::Cos, n, -1, ik.neg()));
                if n == 0 {
                    v.push((TrigKind::One, 0, -1, ik));
                } else {
                    let f = Num::int(n as i64).mul(ik);
                    for (t, a, b, c) in self.base(TrigKind::Cos, n - 1, k) {
                        v.push((t, a, b - 1, f.mul(c)));
                    }
                }
            }
        }
        self.base.insert((kind, n, k), v.clone());
        v
    }

    /// Closed-form integral of an expanded integrand; trig factors now mean
    /// `trig(k W l)`.
    pub fn closed(&mut self, p: &TPoly) -> Result<TPoly, CodegenError> {
        let (u, l, w) = (self.h.u, self.h.l, self.h.w);
        let mut out = TPoly::default();
        for ((t, m), c) in &p.terms {
            let (n, rest) = mono_take(m, u);
            if n < 0 {
                return Err(CodegenError::Unsupported("negative power of u".into()));
            }
            for (kind, lp, wp, bc) in self.base(t.kind, n, t.k) {
                let mm = mono_mul(&rest, &mono_mul(&mono_var(l, lp), &mono_var(w, wp)));
                let tt = if kind == TrigKind::One {
                    Trig::ONE
                } else {
                    Trig { kind, k: t.k }
                };
                out.add_term(tt, mm, c.mul(bc));
            }
        }
        Ok(out)
    }

    /// Taylor-branch integral, truncated to degree `order` in W.
    pub fn series(&mut self, p: &TPoly, order: u32) -> Result<TPoly, CodegenError> {
        let (u, l, w) = (self.h.u, self.h.l, self.h.w);
        let order = order as i32;
        let mut out = TPoly::default();
        for ((t, m), c) in &p.terms {
            let (n, rest) = mono_take(m, u);
            if n < 0 {
                return Err(CodegenError::Unsupported("negative power of u".into()));
            }
            let (ew, _) = mono_take(&rest, w);
            // coefficient of (W u)^j in the Taylor series of the trig factor
            let (mut j, mut coef) = match t.kind {
                TrigKind::One => (0, Num::ONE),
                TrigKind::Cos => (0, Num::ONE),
                TrigKind::Sin => (1, Num::Exact(t.k)),
            };
            let k2 = Num::Exact(t.k).mul(Num::Exact(t.k));
            while ew + j <= order {
                let mm = mono_mul(&rest, &mono_mul(&mono_var(w, j), &mono_var(l, n + j + 1)));
                out.add_term(Trig::ONE, mm, c.mul(coef).div(Num::int((n + j + 1) as i64)));
                if t.kind == TrigKind::One {
                    break;
                }
                coef = coef.mul(k2).neg().div(Num::int(((j + 1) * (j + 2)) as i64));
                j += 2;
            }
        }
        if let Some(((_, m), _)) = out.terms.iter().find(|((_, m), _)| mono_take(m, w).0 < 0) {
            return Err(CodegenError::NotRegular(format!(
                "a negative power of W survives in the Taylor branch (monomial {m:?})"
            )));
        }
        Ok(out)
    }

    /// The DAG node of `trig(k W l)`, written with the symbol `x = W l` if `scaled`.
    fn trig_atom(&mut self, g: &mut Graph, t: Trig, scaled: bool) -> Id {
        if let Some(&a) = self.angles.get(&(t, scaled)) {
            return a;
        }
        let is_int = t.k.denom() == 1 && t.k.numer() >= 1;
        let a = if self.multiple_angles && is_int && t.k.numer() >= 2 {
            // s_n = 2 c_1 s_{n−1} − s_{n−2},  c_n = 2 c_1 c_{n−1} − c_{n−2}
            let n = t.k.numer();
            let prev = |i: i128, kind| Trig {
                kind,
                k: Rational::new(i, 1).expect("integer"),
            };
            let c1 = self.trig_atom(g, prev(1, TrigKind::Cos), scaled);
            let a1 = self.trig_atom(g, prev(n - 1, t.kind), scaled);
            let a2 = if n == 2 {
                if t.kind == TrigKind::Cos {
                    g.one()
                } else {
                    g.zero()
                }
            } else {
                self.trig_atom(g, prev(n - 2, t.kind), scaled)
            };
            let two = g.int(2);
            let x = g.mul(&[two, c1, a1]);
            g.sub(x, a2)
        } else {
            let k = g.constant(Num::Exact(t.k));
            let arg = if scaled {
                g.mul2(k, self.h.x)
            } else {
                g.mul(&[k, self.h.w, self.h.l])
            };
            match t.kind {
                TrigKind::Cos => g.cos(arg),
                TrigKind::Sin => g.sin(arg),
                TrigKind::One => g.one(),
            }
        };
        self.angles.insert((t, scaled), a);
        a
    }

    /// Rewrite a result in `(d, W, l)` as `l^p · Q(d l, W l)` if it is homogeneous:
    /// every monomial `d^a W^b l^c` with the same `c − |a| − b = p` (true of any
    /// integral of the element's geometry, by dimension). Returns `p` and the terms of
    /// Q in the symbols `dl_i`, `x`; `None` if some other variable occurs or the degrees
    /// differ.
    fn rescale(&self, p: &TPoly) -> Option<(i32, Vec<Term>)> {
        let h = &self.h;
        let mut degree = None;
        let mut out = Vec::with_capacity(p.terms.len());
        for ((t, m), c) in &p.terms {
            let mut el = 0;
            let mut rest = 0;
            let mut mm: Mono = Vec::with_capacity(m.len());
            for &(v, e) in m {
                if v == h.l {
                    el = e;
                } else if v == h.w {
                    rest += e;
                    mm.push((h.x, e));
                } else if let Some(i) = h.d.iter().position(|&di| di == v) {
                    rest += e;
                    mm.push((h.dl[i], e));
                } else {
                    return None;
                }
            }
            mm.sort();
            if *degree.get_or_insert(el - rest) != el - rest {
                return None;
            }
            out.push((*t, mm, *c));
        }
        Some((degree.unwrap_or(0), out))
    }

    /// A result (trig factors meaning `trig(k W l)`) as a DAG node: `l^p · Q(d l, W l)`
    /// when homogeneous (bounded intermediate values, fewer operations), else in
    /// `(d, W, l)`; nested Horner-style (d outermost, then trig factors, then x).
    pub fn build_dag(&mut self, g: &mut Graph, p: &TPoly) -> Id {
        let h = self.h;
        let (scale, terms, vars) = match self.rescale(p) {
            Some((deg, t)) => (Some(deg), t, [h.dl[0], h.dl[1], h.dl[2], h.x, h.l]),
            None => {
                let t = p
                    .terms
                    .iter()
                    .map(|((t, m), c)| (*t, m.clone(), *c))
                    .collect();
                (None, t, [h.d[0], h.d[1], h.d[2], h.w, h.l])
            }
        };
        let mut atoms = Vec::new();
        let mut mterms: Vec<(Mono, Num)> = Vec::with_capacity(terms.len());
        for (t, m, c) in terms {
            if t.kind == TrigKind::One {
                mterms.push((m, c));
            } else {
                let a = self.trig_atom(g, t, scale.is_some());
                if !atoms.contains(&a) {
                    atoms.push(a);
                }
                mterms.push((mono_mul(&m, &mono_var(a, 1)), c));
            }
        }
        // Order: the d-variables outermost, then the trig factors, then x (or W, l)
        // innermost: the results are then sums of d-monomials times short
        // polynomials in x, cos x, sin x, which many outputs share — after factoring
        // out a constant (normalize) — and CSE finds them.
        let mut order: Vec<Id> = vars[..3].to_vec();
        order.extend(&atoms);
        order.extend(&vars[3..]);
        let q = horner(g, mterms, &order, true);
        match scale {
            Some(deg) => {
                let lp = g.pow(h.l, deg);
                g.mul2(lp, q)
            }
            None => q,
        }
    }
}

impl Graph {
    /// Closed-form `∫_0^l e du` (see the module docs).
    pub fn integrate_closed(&mut self, h: &HelixSymbols, e: Id) -> Result<Id, CodegenError> {
        let mut it = Integrator::new(*h, false);
        let p = it.expand(self, e)?;
        let c = it.closed(&p)?;
        Ok(it.build_dag(self, &c))
    }

    /// Taylor-branch `∫_0^l e du`, truncated to degree `order` in W.
    pub fn integrate_series(
        &mut self,
        h: &HelixSymbols,
        e: Id,
        order: u32,
    ) -> Result<Id, CodegenError> {
        let mut it = Integrator::new(*h, false);
        let p = it.expand(self, e)?;
        let s = it.series(&p, order)?;
        Ok(it.build_dag(self, &s))
    }

    /// Both branches of `∫_0^l e du`.
    pub fn integrate_element(
        &mut self,
        h: &HelixSymbols,
        e: Id,
        series_order: u32,
    ) -> Result<ElementIntegral, CodegenError> {
        let mut it = Integrator::new(*h, false);
        let p = it.expand(self, e)?;
        let c = it.closed(&p)?;
        let s = it.series(&p, series_order)?;
        Ok(ElementIntegral {
            closed: it.build_dag(self, &c),
            series: it.build_dag(self, &s),
            series_order,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_integrals_in_both_branches() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        // ∫_0^l u² cos(2Wu) du = l² s/(2W) + l c/(2W²) − s/(4W³), s = sin 2Wl, c = cos 2Wl
        let two = g.int(2);
        let arg = g.mul(&[two, h.w, h.u]);
        let c2 = g.cos(arg);
        let u2 = g.pow(h.u, 2);
        let e = g.mul2(u2, c2);
        let r = g.integrate_element(&h, e, 40).unwrap();
        for (d, l) in [([0.3f64, 0.4, 1.2], 0.9f64), ([30.0, -4.0, 12.0], 0.2)] {
            let w: f64 = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let (s, c) = (2.0 * w * l).sin_cos();
            let exact = l * l * s / (2.0 * w) + l * c / (2.0 * w * w) - s / (4.0 * w * w * w);
            let b = h.bindings(d, l, 0.0);
            let closed = g.eval(r.closed, &b);
            assert!(
                (closed - exact).abs() < 1e-14 * exact.abs(),
                "{closed} vs {exact}"
            );
            if w * l < 2.0 {
                let series = g.eval(r.series, &b);
                assert!(
                    (series - exact).abs() < 1e-13 * exact.abs(),
                    "{series} vs {exact}"
                );
            }
        }
    }

    #[test]
    fn odd_function_of_w_is_not_regular() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        // sin(Wu)/W² ~ u/W at W → 0: no Taylor branch without division by W
        let wu = g.mul2(h.w, h.u);
        let s = g.sin(wu);
        let iw2 = g.pow(h.w, -2);
        let e = g.mul2(s, iw2);
        assert!(matches!(
            g.integrate_series(&h, e, 10),
            Err(CodegenError::NotRegular(_))
        ));
        // trig of something else than a multiple of W u is reported, not mis-integrated
        let uu = g.mul2(h.u, h.u);
        let bad = g.sin(uu);
        assert!(matches!(
            g.integrate_closed(&h, bad),
            Err(CodegenError::Unsupported(_))
        ));
    }
}

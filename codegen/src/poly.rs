//! Expanded canonical form of an integrand, and the way back to the DAG.
//!
//! A [`TPoly`] is a finite sum `Σ c · m · trig(k Ω t)`: `c` an exact (or float)
//! constant, `m` a monomial (product of integer powers of variables; a variable is any
//! node `Id`, usually a symbol, otherwise an opaque subexpression free of `t`), and
//! `trig` one of `1`, `cos(k Ω t)`, `sin(k Ω t)` with a rational `k > 0`. Products of
//! trig factors are reduced by the product-to-sum formulas, so every term carries at
//! most one. Before integration `t = u`; after it, `t = l`.
//!
//! [`horner`] turns a sum of monomials back into the DAG, nested Horner-style over a
//! given variable order (negative powers are nested in `1/v`), which both cuts the
//! operation count and makes equal sub-polynomials one node, for CSE.

use crate::graph::{Graph, Id, Node};
use crate::number::{Num, Rational};
use crate::CodegenError;
use std::collections::{BTreeMap, HashMap};
use std::ops::{Add, Mul, Neg};
use std::rc::Rc;

/// A monomial: `(variable, exponent)` pairs sorted by variable, no zero exponent.
pub(crate) type Mono = Vec<(Id, i32)>;

/// Product of two monomials.
pub(crate) fn mono_mul(a: &Mono, b: &Mono) -> Mono {
    let mut out = Vec::with_capacity(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() || j < b.len() {
        if j == b.len() || (i < a.len() && a[i].0 < b[j].0) {
            out.push(a[i]);
            i += 1;
        } else if i == a.len() || b[j].0 < a[i].0 {
            out.push(b[j]);
            j += 1;
        } else {
            let e = a[i].1 + b[j].1;
            if e != 0 {
                out.push((a[i].0, e));
            }
            i += 1;
            j += 1;
        }
    }
    out
}

/// Exponent of `v` in `m` (0 if absent), and `m` without `v`.
pub(crate) fn mono_take(m: &Mono, v: Id) -> (i32, Mono) {
    let e = m.iter().find(|p| p.0 == v).map_or(0, |p| p.1);
    (e, m.iter().copied().filter(|p| p.0 != v).collect())
}

/// Monomial `v^e` (empty for `e == 0`).
pub(crate) fn mono_var(v: Id, e: i32) -> Mono {
    if e == 0 {
        vec![]
    } else {
        vec![(v, e)]
    }
}

/// Which trigonometric factor a term carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) enum TrigKind {
    /// No factor.
    One,
    /// `cos(k Ω t)`.
    Cos,
    /// `sin(k Ω t)`.
    Sin,
}

/// A trig factor `kind(k Ω t)`, normalized: `k > 0`, or `kind = One` and `k = 0`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub(crate) struct Trig {
    pub kind: TrigKind,
    pub k: Rational,
}

impl Trig {
    pub const ONE: Trig = Trig {
        kind: TrigKind::One,
        k: Rational::ZERO,
    };

    /// `kind(k ·)` normalized to `sign · Trig` (sign 0 for `sin 0`).
    pub fn make(kind: TrigKind, k: Rational) -> (i64, Trig) {
        let neg = k.cmp_value(&Rational::ZERO).is_lt();
        let k = if neg { k.neg() } else { k };
        match kind {
            TrigKind::One => (1, Trig::ONE),
            _ if k.is_zero() => (if kind == TrigKind::Cos { 1 } else { 0 }, Trig::ONE),
            TrigKind::Cos => (1, Trig { kind, k }),
            TrigKind::Sin => (if neg { -1 } else { 1 }, Trig { kind, k }),
        }
    }
}

/// Product of two trig factors as a sum `Σ (coefficient, factor)`.
fn trig_mul(a: Trig, b: Trig) -> Vec<(Num, Trig)> {
    use TrigKind::*;
    if a.kind == One {
        return vec![(Num::ONE, b)];
    }
    if b.kind == One {
        return vec![(Num::ONE, a)];
    }
    let half = Num::ratio(1, 2);
    let sum = a.k.checked_add(b.k).expect("trig frequency overflow");
    let dif = a.k.checked_add(b.k.neg()).expect("trig frequency overflow");
    // (kind of the result, frequency, sign) pairs from the product-to-sum formulas
    let parts: [(TrigKind, Rational, i64); 2] = match (a.kind, b.kind) {
        (Cos, Cos) => [(Cos, dif, 1), (Cos, sum, 1)],
        (Sin, Sin) => [(Cos, dif, 1), (Cos, sum, -1)],
        (Sin, Cos) => [(Sin, sum, 1), (Sin, dif, 1)],
        (Cos, Sin) => [(Sin, sum, 1), (Sin, dif, -1)],
        _ => unreachable!(),
    };
    let mut out = Vec::with_capacity(2);
    for (kind, k, s) in parts {
        let (s2, t) = Trig::make(kind, k);
        if s * s2 != 0 {
            out.push((half.mul(Num::int(s * s2)), t));
        }
    }
    out
}

/// A sum of terms `c · monomial · trig` (see the module docs).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct TPoly {
    pub terms: BTreeMap<(Trig, Mono), Num>,
}

impl TPoly {
    pub fn constant(c: Num) -> TPoly {
        let mut p = TPoly::default();
        p.add_term(Trig::ONE, vec![], c);
        p
    }
    pub fn monomial(m: Mono, c: Num) -> TPoly {
        let mut p = TPoly::default();
        p.add_term(Trig::ONE, m, c);
        p
    }
    pub fn add_term(&mut self, t: Trig, m: Mono, c: Num) {
        if c.is_zero() {
            return;
        }
        use std::collections::btree_map::Entry;
        match self.terms.entry((t, m)) {
            Entry::Vacant(v) => {
                v.insert(c);
            }
            Entry::Occupied(mut o) => {
                let s = o.get().add(c);
                if s.is_zero() {
                    o.remove();
                } else {
                    *o.get_mut() = s;
                }
            }
        }
    }
    pub fn add_assign(&mut self, o: &TPoly) {
        for ((t, m), c) in &o.terms {
            self.add_term(*t, m.clone(), *c);
        }
    }
    pub fn mul(&self, o: &TPoly) -> TPoly {
        let mut out = TPoly::default();
        for ((ta, ma), ca) in &self.terms {
            for ((tb, mb), cb) in &o.terms {
                let m = mono_mul(ma, mb);
                let c = ca.mul(*cb);
                for (s, t) in trig_mul(*ta, *tb) {
                    out.add_term(t, m.clone(), c.mul(s));
                }
            }
        }
        out
    }
    pub fn pow(&self, mut e: u32) -> TPoly {
        let mut out = TPoly::constant(Num::ONE);
        let mut base = self.clone();
        while e > 0 {
            if e & 1 == 1 {
                out = out.mul(&base);
            }
            e >>= 1;
            if e > 0 {
                base = base.mul(&base);
            }
        }
        out
    }
    /// The only term, if there is exactly one.
    pub fn single(&self) -> Option<(Trig, &Mono, Num)> {
        if self.terms.len() == 1 {
            let ((t, m), c) = self.terms.iter().next()?;
            Some((*t, m, *c))
        } else {
            None
        }
    }
}

/// Turns DAG expressions into [`TPoly`]s, with trig arguments of the form `k · Ω · t`.
pub(crate) struct Expander {
    /// The variable `t` of the trig arguments (the integration variable).
    pub t: Id,
    /// The frequency symbol Ω (`W` for the helix).
    pub omega: Id,
    memo: HashMap<Id, Rc<TPoly>>,
    dep: HashMap<Id, bool>,
}

impl Expander {
    pub fn new(t: Id, omega: Id) -> Expander {
        Expander {
            t,
            omega,
            memo: HashMap::new(),
            dep: HashMap::new(),
        }
    }

    fn depends(&mut self, g: &Graph, id: Id) -> bool {
        g.depends_on(id, self.t, &mut self.dep)
    }

    /// Expand `id` (memoized per node).
    pub fn expand(&mut self, g: &mut Graph, id: Id) -> Result<Rc<TPoly>, CodegenError> {
        if let Some(p) = self.memo.get(&id) {
            return Ok(p.clone());
        }
        let p = match g.node(id).clone() {
            Node::Const(c) => TPoly::constant(c),
            Node::Sym(_) => TPoly::monomial(mono_var(id, 1), Num::ONE),
            Node::Add(ch) => {
                let mut p = TPoly::default();
                for c in ch.iter() {
                    let q = self.expand(g, *c)?;
                    p.add_assign(&q);
                }
                p
            }
            Node::Mul(ch) => {
                let mut p = TPoly::constant(Num::ONE);
                for c in ch.iter() {
                    let q = self.expand(g, *c)?;
                    p = p.mul(&q);
                }
                p
            }
            Node::Pow(b, e) if e > 0 => self.expand(g, b)?.pow(e as u32),
            Node::Pow(b, e) => {
                let q = self.expand(g, b)?;
                match q.single() {
                    Some((t, m, c)) if t == Trig::ONE => {
                        let m: Mono = m.iter().map(|&(v, x)| (v, x * e)).collect();
                        TPoly::monomial(m, c.powi(e))
                    }
                    _ if !self.depends(g, b) => TPoly::monomial(mono_var(b, e), Num::ONE),
                    _ => {
                        return Err(CodegenError::Unsupported(format!(
                            "negative power of a sum that depends on the integration variable (node {})",
                            b.0
                        )))
                    }
                }
            }
            Node::Sin(a) | Node::Cos(a) => {
                if !self.depends(g, a) {
                    TPoly::monomial(mono_var(id, 1), Num::ONE)
                } else {
                    let kind = if matches!(g.node(id), Node::Sin(_)) {
                        TrigKind::Sin
                    } else {
                        TrigKind::Cos
                    };
                    let q = self.expand(g, a)?;
                    let arg = q.single().filter(|(t, m, _)| {
                        *t == Trig::ONE
                            && **m == mono_mul(&mono_var(self.omega, 1), &mono_var(self.t, 1))
                    });
                    let Some((_, _, Num::Exact(k))) = arg else {
                        return Err(CodegenError::Unsupported(format!(
                            "trig argument (node {}) is not a rational multiple of Ω·t",
                            a.0
                        )));
                    };
                    let (s, t) = Trig::make(kind, k);
                    let mut p = TPoly::default();
                    p.add_term(t, vec![], Num::int(s));
                    p
                }
            }
        };
        let p = Rc::new(p);
        self.memo.insert(id, p.clone());
        Ok(p)
    }
}

/// Build `Σ c · m` in the DAG, nested Horner-style: the first variable of `order` that
/// occurs is factored out (positive powers nested in `v`, negative ones in `1/v`),
/// then the next, recursively; variables not in `order` come last, by `Id`.
pub(crate) fn horner(g: &mut Graph, terms: Vec<(Mono, Num)>, order: &[Id], normalize: bool) -> Id {
    if terms.is_empty() {
        return g.zero();
    }
    // With `normalize`, factor out the coefficient of the smallest monomial (when
    // exact), so that polynomials equal up to a constant factor become one node.
    let lead = terms.iter().min_by(|a, b| a.0.cmp(&b.0)).map(|t| t.1);
    if let Some(c0) = lead.filter(|c| normalize && c.exact().is_some() && !c.is_one()) {
        if terms.iter().all(|t| t.1.exact().is_some()) {
            let scaled: Vec<(Mono, Num)> = terms.into_iter().map(|(m, c)| (m, c / c0)).collect();
            let q = horner(g, scaled, order, normalize);
            let k = g.constant(c0);
            return g.mul2(k, q);
        }
    }
    let occurs = |v: Id| terms.iter().any(|(m, _)| m.iter().any(|p| p.0 == v));
    let var = order
        .iter()
        .copied()
        .find(|&v| occurs(v))
        .or_else(|| terms.iter().flat_map(|(m, _)| m.iter().map(|p| p.0)).min());
    let Some(v) = var else {
        let s = terms.iter().fold(Num::ZERO, |a, (_, c)| a.add(*c));
        return g.constant(s);
    };
    let mut groups: BTreeMap<i32, Vec<(Mono, Num)>> = BTreeMap::new();
    for (m, c) in terms {
        let (e, rest) = mono_take(&m, v);
        groups.entry(e).or_default().push((rest, c));
    }
    let mut parts = Vec::new();
    if let Some(t0) = groups.remove(&0) {
        parts.push(horner(g, t0, order, normalize));
    }
    let mut pos = Vec::new();
    let mut neg = Vec::new();
    for (e, t) in groups {
        if e > 0 {
            pos.push((e, t));
        } else {
            neg.push((-e, t));
        }
    }
    neg.reverse();
    for (sign, chain) in [(1, pos), (-1, neg)] {
        if chain.is_empty() {
            continue;
        }
        let exps: Vec<i32> = chain.iter().map(|c| c.0).collect();
        let polys: Vec<Id> = chain
            .into_iter()
            .map(|(_, t)| horner(g, t, order, normalize))
            .collect();
        let n = polys.len();
        let mut acc = polys[n - 1];
        for i in (0..n - 1).rev() {
            let p = g.pow(v, sign * (exps[i + 1] - exps[i]));
            let m = g.mul2(p, acc);
            acc = g.add2(polys[i], m);
        }
        let p = g.pow(v, sign * exps[0]);
        parts.push(g.mul2(p, acc));
    }
    g.add(&parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_to_sum_and_horner_round_trip() {
        let mut g = Graph::new();
        let w = g.symbol("w");
        let u = g.symbol("u");
        let x = g.symbol("x");
        let wu = g.mul2(w, u);
        let s = g.sin(wu);
        let two = g.int(2);
        let wu2 = g.mul(&[two, w, u]);
        let c2 = g.cos(wu2);
        let xi = g.pow(x, -2);
        let e = g.mul(&[s, s, c2, xi]);
        let e = g.add2(e, x);
        let mut ex = Expander::new(u, w);
        let p = ex.expand(&mut g, e).unwrap();
        // sin² cos 2θ = (cos 2θ − cos² 2θ)/2 = cos2θ/2 − 1/4 − cos4θ/4
        assert_eq!(p.terms.len(), 4);
        // round trip through Horner with trig factors as atoms
        let mut terms = Vec::new();
        for ((t, m), c) in &p.terms {
            let atom = match t.kind {
                TrigKind::One => None,
                k => {
                    let kk = g.constant(Num::Exact(t.k));
                    let a = g.mul(&[kk, w, u]);
                    Some(if k == TrigKind::Cos {
                        g.cos(a)
                    } else {
                        g.sin(a)
                    })
                }
            };
            let m = match atom {
                Some(a) => mono_mul(m, &mono_var(a, 1)),
                None => m.clone(),
            };
            terms.push((m, *c));
        }
        let back = horner(&mut g, terms, &[w], true);
        let b = [(w, 1.3), (u, 0.7), (x, 0.4)];
        let v1 = g.eval(e, &b);
        let v2 = g.eval(back, &b);
        assert!((v1 - v2).abs() < 1e-14 * v1.abs());
    }
}

//! The expression DAG: an arena of hash-consed nodes with construction-time
//! simplification.
//!
//! Every node lives once in the arena: building a structurally equal node returns the
//! existing [`Id`]. Children are always created before their parents, so the arena
//! order is a topological order (the evaluator and the emitter rely on it).
//!
//! Canonical forms kept by the constructors:
//! - `Add` is flat (no `Add` child), has at most one constant (folded), combines like
//!   terms `c1·m + c2·m = (c1 + c2)·m`, drops zeros, and is sorted by child `Id`.
//! - `Mul` is flat, has at most one constant, placed first (folded; a zero product is
//!   0), combines powers of one base `x^a·x^b = x^(a+b)`, and sorts the other factors
//!   by `Id`. A term `c·m` of a sum is a `Mul` whose first child is the constant `c`.
//! - `Pow(b, e)` has an integer exponent `e ∉ {0, 1}` and a base that is not a
//!   constant (folded), not a `Pow` (exponents multiply) and not a `Mul` (the power is
//!   distributed over the factors).
//! - `sin(0) = 0`, `cos(0) = 1`, `sin(−x) = −sin x`, `cos(−x) = cos x`, where "−x"
//!   means a term with a negative constant coefficient; trig of a constant is folded
//!   to a float.

use crate::number::Num;
use std::collections::{BTreeMap, HashMap};
use std::ops::{Add, Mul, Neg};

/// Index of a node in the graph's arena.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub u32);

impl Id {
    /// Arena index.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// One node of the DAG (see the module docs for the canonical forms).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant.
    Const(Num),
    /// A symbol, by its index in the graph's symbol table.
    Sym(u32),
    /// Sum of two or more terms.
    Add(Box<[Id]>),
    /// Product of two or more factors.
    Mul(Box<[Id]>),
    /// Integer power.
    Pow(Id, i32),
    /// Sine.
    Sin(Id),
    /// Cosine.
    Cos(Id),
}

impl Node {
    /// Children, in order.
    pub fn children(&self) -> Vec<Id> {
        match self {
            Node::Const(_) | Node::Sym(_) => vec![],
            Node::Add(c) | Node::Mul(c) => c.to_vec(),
            Node::Pow(b, _) => vec![*b],
            Node::Sin(a) | Node::Cos(a) => vec![*a],
        }
    }
}

/// The expression graph.
#[derive(Debug, Default, Clone)]
pub struct Graph {
    nodes: Vec<Node>,
    index: HashMap<Node, Id>,
    symbols: Vec<String>,
    symbol_ids: HashMap<String, Id>,
    /// `partials[(s, v)]` = ∂s/∂v for a symbol `s` that depends on the symbol `v`
    /// (e.g. ∂W/∂d_i = d_i/W).
    pub(crate) partials: HashMap<(Id, Id), Id>,
    pub(crate) diff_memo: HashMap<(Id, Id), Id>,
}

impl Graph {
    /// An empty graph.
    pub fn new() -> Graph {
        Graph::default()
    }

    /// Number of nodes in the arena.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// Is the arena empty?
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The node behind an id.
    pub fn node(&self, id: Id) -> &Node {
        &self.nodes[id.index()]
    }

    /// Name of a symbol node (`None` if `id` is not a symbol).
    pub fn symbol_name(&self, id: Id) -> Option<&str> {
        match self.node(id) {
            Node::Sym(s) => Some(&self.symbols[*s as usize]),
            _ => None,
        }
    }

    fn intern(&mut self, n: Node) -> Id {
        if let Some(&id) = self.index.get(&n) {
            return id;
        }
        let id = Id(u32::try_from(self.nodes.len()).expect("graph larger than 2^32 nodes"));
        self.nodes.push(n.clone());
        self.index.insert(n, id);
        id
    }

    /// The symbol called `name` (created on first use).
    pub fn symbol(&mut self, name: &str) -> Id {
        if let Some(&id) = self.symbol_ids.get(name) {
            return id;
        }
        let s = self.symbols.len() as u32;
        self.symbols.push(name.to_string());
        let id = self.intern(Node::Sym(s));
        self.symbol_ids.insert(name.to_string(), id);
        id
    }

    /// Declare that symbol `s` depends on symbol `v` with ∂s/∂v = `partial`
    /// (used by [`Graph::diff`]).
    pub fn set_partial(&mut self, s: Id, v: Id, partial: Id) {
        self.partials.insert((s, v), partial);
        self.diff_memo.clear();
    }

    /// A constant.
    pub fn constant(&mut self, c: Num) -> Id {
        self.intern(Node::Const(c))
    }
    /// An integer constant.
    pub fn int(&mut self, n: i64) -> Id {
        self.constant(Num::int(n))
    }
    /// A float constant (exact if it is a small integer).
    pub fn float(&mut self, x: f64) -> Id {
        self.constant(Num::float(x))
    }
    /// The exact rational `n / d`.
    pub fn rational(&mut self, n: i64, d: i64) -> Id {
        self.constant(Num::ratio(n, d))
    }
    /// 0.
    pub fn zero(&mut self) -> Id {
        self.constant(Num::ZERO)
    }
    /// 1.
    pub fn one(&mut self) -> Id {
        self.constant(Num::ONE)
    }

    /// The constant value of a node, if it is a constant.
    pub fn as_const(&self, id: Id) -> Option<Num> {
        match self.node(id) {
            Node::Const(c) => Some(*c),
            _ => None,
        }
    }

    /// Split a term into (constant coefficient, rest): `c·m` → `(c, m)`, else `(1, t)`.
    pub fn split_coeff(&mut self, t: Id) -> (Num, Id) {
        if let Node::Mul(ch) = self.node(t) {
            if let Node::Const(c) = self.node(ch[0]) {
                let c = *c;
                let rest: Vec<Id> = ch[1..].to_vec();
                let rest = if rest.len() == 1 {
                    rest[0]
                } else {
                    self.intern(Node::Mul(rest.into()))
                };
                return (c, rest);
            }
        }
        (Num::ONE, t)
    }

    /// `c · rest` where `rest` carries no constant factor.
    fn scaled(&mut self, c: Num, rest: Id) -> Id {
        if c.is_zero() {
            return self.zero();
        }
        if c.is_one() {
            return rest;
        }
        let k = self.constant(c);
        let mut ch = vec![k];
        match self.node(rest) {
            Node::Mul(f) => ch.extend(f.iter()),
            Node::Const(r) => {
                let v = c.mul(*r);
                return self.constant(v);
            }
            _ => ch.push(rest),
        }
        self.intern(Node::Mul(ch.into()))
    }

    /// Sum of terms.
    pub fn add(&mut self, terms: &[Id]) -> Id {
        let mut constant = Num::ZERO;
        let mut like: BTreeMap<Id, Num> = BTreeMap::new();
        let mut stack: Vec<Id> = terms.iter().rev().copied().collect();
        while let Some(t) = stack.pop() {
            match self.node(t) {
                Node::Add(ch) => stack.extend(ch.iter().rev()),
                Node::Const(c) => constant = constant.add(*c),
                _ => {
                    let (c, m) = self.split_coeff(t);
                    let e = like.entry(m).or_insert(Num::ZERO);
                    *e = e.add(c);
                }
            }
        }
        let mut out = Vec::with_capacity(like.len() + 1);
        for (m, c) in like {
            if !c.is_zero() {
                out.push(self.scaled(c, m));
            }
        }
        if !constant.is_zero() {
            out.push(self.constant(constant));
        }
        out.sort();
        match out.len() {
            0 => self.zero(),
            1 => out[0],
            _ => self.intern(Node::Add(out.into())),
        }
    }

    /// `a + b`.
    pub fn add2(&mut self, a: Id, b: Id) -> Id {
        self.add(&[a, b])
    }
    /// `a − b`.
    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        let nb = self.neg(b);
        self.add(&[a, nb])
    }
    /// `−a`.
    pub fn neg(&mut self, a: Id) -> Id {
        let m = self.int(-1);
        self.mul(&[m, a])
    }

    /// Product of factors.
    pub fn mul(&mut self, factors: &[Id]) -> Id {
        let mut constant = Num::ONE;
        let mut powers: BTreeMap<Id, i32> = BTreeMap::new();
        let mut stack: Vec<Id> = factors.iter().rev().copied().collect();
        while let Some(f) = stack.pop() {
            match self.node(f) {
                Node::Mul(ch) => stack.extend(ch.iter().rev()),
                Node::Const(c) => constant = constant.mul(*c),
                Node::Pow(b, e) => *powers.entry(*b).or_insert(0) += *e,
                _ => *powers.entry(f).or_insert(0) += 1,
            }
        }
        if constant.is_zero() {
            return self.zero();
        }
        let mut out = Vec::with_capacity(powers.len() + 1);
        for (b, e) in powers {
            match e {
                0 => {}
                1 => out.push(b),
                _ => out.push(self.intern(Node::Pow(b, e))),
            }
        }
        out.sort();
        if out.is_empty() {
            return self.constant(constant);
        }
        if constant.is_one() {
            if out.len() == 1 {
                return out[0];
            }
        } else {
            out.insert(0, self.constant(constant));
        }
        self.intern(Node::Mul(out.into()))
    }

    /// `a · b`.
    pub fn mul2(&mut self, a: Id, b: Id) -> Id {
        self.mul(&[a, b])
    }
    /// `a / b`.
    pub fn div(&mut self, a: Id, b: Id) -> Id {
        let ib = self.pow(b, -1);
        self.mul(&[a, ib])
    }

    /// `b^e` for an integer `e`.
    pub fn pow(&mut self, b: Id, e: i32) -> Id {
        if e == 0 {
            return self.one();
        }
        if e == 1 {
            return b;
        }
        match self.node(b).clone() {
            Node::Const(c) => self.constant(c.powi(e)),
            Node::Pow(bb, ee) => self.pow(bb, ee * e),
            Node::Mul(ch) => {
                let f: Vec<Id> = ch.iter().map(|&c| self.pow(c, e)).collect();
                self.mul(&f)
            }
            _ => self.intern(Node::Pow(b, e)),
        }
    }

    /// `sin a`.
    pub fn sin(&mut self, a: Id) -> Id {
        if let Some(c) = self.as_const(a) {
            return if c.is_zero() {
                self.zero()
            } else {
                self.float(c.to_f64().sin())
            };
        }
        let (c, m) = self.split_coeff(a);
        if c.is_negative() {
            let pa = self.scaled(c.neg(), m);
            let s = self.sin(pa);
            return self.neg(s);
        }
        self.intern(Node::Sin(a))
    }

    /// `cos a`.
    pub fn cos(&mut self, a: Id) -> Id {
        if let Some(c) = self.as_const(a) {
            return if c.is_zero() {
                self.one()
            } else {
                self.float(c.to_f64().cos())
            };
        }
        let (c, m) = self.split_coeff(a);
        if c.is_negative() {
            let pa = self.scaled(c.neg(), m);
            return self.cos(pa);
        }
        self.intern(Node::Cos(a))
    }

    /// Does `id` depend on the symbol `s` (directly, or through a symbol declared to
    /// depend on it with [`Graph::set_partial`])?
    pub fn depends_on(&self, id: Id, s: Id, memo: &mut HashMap<Id, bool>) -> bool {
        if let Some(&b) = memo.get(&id) {
            return b;
        }
        let r = match self.node(id) {
            Node::Const(_) => false,
            Node::Sym(_) => id == s || self.partials.contains_key(&(id, s)),
            n => n
                .children()
                .into_iter()
                .any(|c| self.depends_on(c, s, memo)),
        };
        memo.insert(id, r);
        r
    }

    /// All nodes reachable from `roots`, as a mask over the arena.
    pub fn reachable(&self, roots: &[Id]) -> Vec<bool> {
        let mut mark = vec![false; self.nodes.len()];
        let mut stack: Vec<Id> = roots.to_vec();
        while let Some(id) = stack.pop() {
            if mark[id.index()] {
                continue;
            }
            mark[id.index()] = true;
            stack.extend(self.node(id).children());
        }
        mark
    }

    /// Evaluate several expressions at once. `bindings` gives a value to every symbol
    /// the expressions use (panics otherwise: this is a test and generator tool).
    pub fn eval_many(&self, roots: &[Id], bindings: &[(Id, f64)]) -> Vec<f64> {
        self.evaluator(roots).eval(self, bindings)
    }

    /// The node equal to `n`, if it exists in the arena.
    pub fn lookup(&self, n: &Node) -> Option<Id> {
        self.index.get(n).copied()
    }

    /// A reusable evaluator of `roots` (cheaper than [`Graph::eval_many`] when the same
    /// expressions are evaluated at many points).
    pub fn evaluator(&self, roots: &[Id]) -> Evaluator {
        let mark = self.reachable(roots);
        Evaluator {
            order: (0..self.nodes.len()).filter(|&i| mark[i]).collect(),
            roots: roots.to_vec(),
        }
    }

    /// Evaluate one expression (see [`Graph::eval_many`]).
    pub fn eval(&self, id: Id, bindings: &[(Id, f64)]) -> f64 {
        self.eval_many(&[id], bindings)[0]
    }
}

/// Compiled evaluation order of some expressions (see [`Graph::evaluator`]).
#[derive(Clone, Debug)]
pub struct Evaluator {
    order: Vec<usize>,
    roots: Vec<Id>,
}

impl Evaluator {
    /// Values of the roots; `bindings` as for [`Graph::eval_many`].
    pub fn eval(&self, g: &Graph, bindings: &[(Id, f64)]) -> Vec<f64> {
        let mut val = vec![0.0f64; g.len()];
        for &i in &self.order {
            val[i] = match &g.nodes[i] {
                Node::Const(c) => c.to_f64(),
                Node::Sym(s) => bindings
                    .iter()
                    .find(|(id, _)| id.index() == i)
                    .map(|b| b.1)
                    .unwrap_or_else(|| {
                        panic!("no value bound to symbol {}", g.symbols[*s as usize])
                    }),
                Node::Add(ch) => ch.iter().map(|c| val[c.index()]).sum(),
                Node::Mul(ch) => ch.iter().map(|c| val[c.index()]).product(),
                Node::Pow(b, e) => val[b.index()].powi(*e),
                Node::Sin(a) => val[a.index()].sin(),
                Node::Cos(a) => val[a.index()].cos(),
            };
        }
        self.roots.iter().map(|r| val[r.index()]).collect()
    }

    /// [`Evaluator::eval`] in `f32` arithmetic: every bound value and constant rounded
    /// to `f32`, every operation done in `f32` the way the f32 emitter writes it (sums and
    /// products left to right in the order of the node's children, integer powers by the
    /// emitter's repeated multiplications from `b` or `1 / b`, `sin`/`cos` of `f32`), the
    /// results widened to `f64`: what generated f32 code of the same expressions
    /// computes, operation for operation (the test `f32_evaluation_is_the_emitted_code`
    /// of superhelix-generated compares them bit for bit).
    pub fn eval_f32(&self, g: &Graph, bindings: &[(Id, f64)]) -> Vec<f64> {
        let mut val = vec![0.0f32; g.len()];
        for &i in &self.order {
            val[i] = match &g.nodes[i] {
                Node::Const(c) => c.to_f64() as f32,
                Node::Sym(s) => bindings
                    .iter()
                    .find(|(id, _)| id.index() == i)
                    .map(|b| b.1 as f32)
                    .unwrap_or_else(|| {
                        panic!("no value bound to symbol {}", g.symbols[*s as usize])
                    }),
                Node::Add(ch) => ch.iter().fold(0.0f32, |a, c| a + val[c.index()]),
                Node::Mul(ch) => ch.iter().fold(1.0f32, |a, c| a * val[c.index()]),
                Node::Pow(b, e) => power_f32(val[b.index()], *e),
                Node::Sin(a) => val[a.index()].sin(),
                Node::Cos(a) => val[a.index()].cos(),
            };
        }
        self.roots.iter().map(|r| val[r.index()] as f64).collect()
    }
}

/// `b^e` in f32 by the emitter's multiplications (`emit::Emitter::power`): `b`, `1 / b`
/// for `e = ±1`, the square of `b^(e/2)` for even `e`, `b^(e∓1) · b^(±1)` for odd.
fn power_f32(b: f32, e: i32) -> f32 {
    match e {
        0 => 1.0,
        1 => b,
        -1 => 1.0 / b,
        e if e % 2 == 0 => {
            let h = power_f32(b, e / 2);
            h * h
        }
        e => power_f32(b, e - e.signum()) * power_f32(b, e.signum()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_consing_gives_one_id_for_equal_expressions() {
        let mut g = Graph::new();
        let build = |g: &mut Graph| {
            let x = g.symbol("x");
            let y = g.symbol("y");
            let xy = g.mul(&[y, x]);
            let s = g.sin(xy);
            let two = g.int(2);
            let p = g.pow(x, 3);
            let t = g.mul(&[two, p, s]);
            g.add(&[t, y, x])
        };
        let a = build(&mut g);
        let n = g.len();
        let b = build(&mut g);
        assert_eq!(a, b);
        assert_eq!(g.len(), n, "no new node the second time");
        // commutativity and association
        let x = g.symbol("x");
        let y = g.symbol("y");
        let xy = g.mul2(x, y);
        let yx = g.mul2(y, x);
        assert_eq!(xy, yx);
        let s1 = g.add(&[x, y, xy]);
        let inner = g.add2(xy, x);
        let s2 = g.add2(y, inner);
        assert_eq!(s1, s2);
    }

    #[test]
    fn construction_time_simplification() {
        let mut g = Graph::new();
        let x = g.symbol("x");
        let y = g.symbol("y");
        let zero = g.zero();
        let one = g.one();
        // like terms
        let two = g.int(2);
        let tx = g.mul2(two, x);
        let s = g.add(&[x, tx]);
        let three = g.int(3);
        let e = g.mul2(three, x);
        assert_eq!(s, e);
        let d = g.sub(x, x);
        assert_eq!(d, zero);
        // powers
        let x2 = g.pow(x, 2);
        let xm3 = g.pow(x, -3);
        let p = g.mul(&[x2, xm3, x]);
        assert_eq!(p, one);
        let q = g.div(x, x);
        assert_eq!(q, one);
        // identities
        let m0 = g.mul2(zero, y);
        assert_eq!(m0, zero);
        let s0 = g.sin(zero);
        assert_eq!(s0, zero);
        let c0 = g.cos(zero);
        assert_eq!(c0, one);
        let nx = g.neg(x);
        let snx = g.sin(nx);
        let sx = g.sin(x);
        let msx = g.neg(sx);
        assert_eq!(snx, msx);
        let cnx = g.cos(nx);
        let cx = g.cos(x);
        assert_eq!(cnx, cx);
        // constant folding
        let h = g.rational(1, 2);
        let t = g.add(&[h, h, x]);
        let e = g.add2(one, x);
        assert_eq!(t, e);
        let xy = g.mul2(x, y);
        let p = g.pow(xy, 2);
        let x2y2 = {
            let y2 = g.pow(y, 2);
            g.mul2(x2, y2)
        };
        assert_eq!(p, x2y2);
    }

    #[test]
    fn f32_evaluation_rounds_every_operation_to_f32() {
        let mut g = Graph::new();
        let x = g.symbol("x");
        let third = g.rational(1, 3);
        let e = g.mul2(third, x);
        let one = g.one();
        let s = g.add2(e, one);
        let ev = g.evaluator(&[s]);
        let x0 = 0.1f64;
        let want = (1.0f32 / 3.0) * (x0 as f32) + 1.0;
        assert_eq!(ev.eval_f32(&g, &[(x, x0)]), vec![want as f64]);
        assert_ne!(ev.eval(&g, &[(x, x0)])[0], want as f64);
    }

    #[test]
    fn evaluator() {
        let mut g = Graph::new();
        let x = g.symbol("x");
        let y = g.symbol("y");
        let s = g.sin(x);
        let xy = g.mul2(x, y);
        let c = g.cos(xy);
        let r = g.div(s, c);
        let e = g.add2(r, y);
        let v = g.eval(e, &[(x, 0.3), (y, 2.0)]);
        assert!((v - (0.3f64.sin() / 0.6f64.cos() + 2.0)).abs() < 1e-15);
    }
}

//! Common-subexpression elimination and operation counts.
//!
//! Hash-consing already makes every repeated subexpression one node; CSE is then the
//! choice of which nodes get a `let` binding: every non-trivial node that is used more
//! than once among all the outputs of one generated function (constants and symbols
//! are never bound; powers go through a cache of repeated multiplications in the
//! emitter; sines and cosines are always bound so that `sin`/`cos` of one argument
//! become one `sin_cos` call).
//!
//! [`tree_ops`] counts the operations of the outputs as trees (every use of a shared
//! node counted again): the cost without CSE. The cost after CSE is counted by the
//! emitter, operation by operation as written.

use crate::graph::{Graph, Id, Node};
use std::fmt;
use std::ops::{Add, AddAssign};

/// Floating-point operation counts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OpCounts {
    /// Additions and subtractions.
    pub adds: u64,
    /// Multiplications.
    pub muls: u64,
    /// Divisions.
    pub divs: u64,
    /// Calls of `sin`, `cos` or `sin_cos` (one `sin_cos` counts once).
    pub trig: u64,
    /// Square roots.
    pub sqrts: u64,
}

impl OpCounts {
    /// Sum of all counts.
    pub fn total(&self) -> u64 {
        self.adds + self.muls + self.divs + self.trig + self.sqrts
    }
}

impl Add for OpCounts {
    type Output = OpCounts;
    fn add(self, o: OpCounts) -> OpCounts {
        OpCounts {
            adds: self.adds.saturating_add(o.adds),
            muls: self.muls.saturating_add(o.muls),
            divs: self.divs.saturating_add(o.divs),
            trig: self.trig.saturating_add(o.trig),
            sqrts: self.sqrts.saturating_add(o.sqrts),
        }
    }
}

impl AddAssign for OpCounts {
    fn add_assign(&mut self, o: OpCounts) {
        *self = *self + o;
    }
}

impl fmt::Display for OpCounts {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} adds, {} muls, {} divs, {} trig, {} sqrt ({} total)",
            self.adds,
            self.muls,
            self.divs,
            self.trig,
            self.sqrts,
            self.total()
        )
    }
}

/// Operations of one node itself (children not included), as written naively.
fn own_ops(g: &Graph, id: Id) -> OpCounts {
    let mut o = OpCounts::default();
    match g.node(id) {
        Node::Const(_) | Node::Sym(_) => {}
        Node::Add(ch) => o.adds = ch.len() as u64 - 1,
        Node::Mul(ch) => {
            // a leading −1 is a sign, not a multiplication
            let minus_one = g.as_const(ch[0]).is_some_and(|c| (-c).is_one());
            o.muls = ch.len() as u64 - 1 - u64::from(minus_one);
        }
        Node::Pow(_, e) => {
            o.muls = u64::from(e.unsigned_abs() - 1);
            o.divs = u64::from(*e < 0);
        }
        Node::Sin(_) | Node::Cos(_) => o.trig = 1,
    }
    o
}

/// Operation counts of the outputs written as trees (no sharing).
pub fn tree_ops(g: &Graph, roots: &[Id]) -> OpCounts {
    let mark = g.reachable(roots);
    let mut memo: Vec<OpCounts> = vec![OpCounts::default(); g.len()];
    for i in 0..g.len() {
        if !mark[i] {
            continue;
        }
        let id = Id(i as u32);
        let mut o = own_ops(g, id);
        for c in g.node(id).children() {
            o += memo[c.index()];
        }
        memo[i] = o;
    }
    roots
        .iter()
        .fold(OpCounts::default(), |a, r| a + memo[r.index()])
}

/// Operation counts with every node counted once (sharing, no power cache).
pub fn dag_ops(g: &Graph, roots: &[Id]) -> OpCounts {
    let mark = g.reachable(roots);
    (0..g.len())
        .filter(|&i| mark[i])
        .fold(OpCounts::default(), |a, i| a + own_ops(g, Id(i as u32)))
}

/// Number of uses of every node among the outputs (edges from reachable parents, plus
/// one per output).
pub(crate) fn use_counts(g: &Graph, roots: &[Id]) -> Vec<u32> {
    let mark = g.reachable(roots);
    let mut uses = vec![0u32; g.len()];
    for (i, &m) in mark.iter().enumerate() {
        if m {
            for c in g.node(Id(i as u32)).children() {
                uses[c.index()] += 1;
            }
        }
    }
    for r in roots {
        uses[r.index()] += 1;
    }
    uses
}

/// Deepest nesting of an inlined expression; deeper nodes get a binding too (keeps
/// statements readable and rustfmt fast).
const MAX_INLINE_DEPTH: u32 = 6;

/// Which nodes get a `let` binding (see the module docs).
pub(crate) fn bindings(g: &Graph, roots: &[Id]) -> Vec<bool> {
    let uses = use_counts(g, roots);
    let mut bind: Vec<bool> = (0..g.len())
        .map(|i| match g.node(Id(i as u32)) {
            Node::Const(_) | Node::Sym(_) | Node::Pow(..) => false,
            // a negation `−x` is written inline: it costs nothing
            Node::Mul(ch) if ch.len() == 2 && g.as_const(ch[0]).is_some_and(|c| (-c).is_one()) => {
                false
            }
            Node::Sin(_) | Node::Cos(_) => uses[i] > 0,
            _ => uses[i] > 1,
        })
        .collect();
    // inline depth, children first (arena order is topological)
    let mut depth = vec![0u32; g.len()];
    for i in 0..g.len() {
        if uses[i] == 0 {
            continue;
        }
        let d = g
            .node(Id(i as u32))
            .children()
            .iter()
            .map(|c| if bind[c.index()] { 0 } else { depth[c.index()] })
            .max()
            .map_or(0, |m| m + 1);
        if d > MAX_INLINE_DEPTH && !matches!(g.node(Id(i as u32)), Node::Pow(..)) {
            bind[i] = true;
            depth[i] = 0;
        } else {
            depth[i] = d;
        }
    }
    bind
}

//! Point values of one element: expressions evaluated at one abscissa `u` (not
//! integrated), in two branches on `x = W u`, with everything that cancels as `x → 0`
//! confined to a few *radial functions*.
//!
//! A function of `d` at a point is written as a polynomial in `d` and `u` whose
//! coefficients are radial functions `F(W, u)` (functions of `d` through `W = |d|`
//! only, even in W, e.g. the helix coefficients `sin(uW)/W`, `(1 − cos uW)/W²`,
//! `(uW − sin uW)/W³`). [`radial_family`] declares `F_0` and its derivatives
//! `F_{k+1} = (1/W) ∂F_k/∂W` as symbols with `∂F_k/∂d_i = F_{k+1} d_i`, so that
//! [`Graph::diff`] differentiates the polynomial part with respect to `d` exactly and
//! never divides by W: all the cancellation of the d-derivatives at `W → 0` lives in
//! the radial functions. [`generate_point`] then
//! 1. writes every radial function in two branches, from the same expression: the
//!    closed form `u^p Q(x)` (Horner in `1/x` with `sin x`, `cos x`; exact, but losing
//!    digits as `x → 0`) and the Taylor series `u^p Q(z)`, `z = x²` (the trig factors
//!    replaced by their series in `W u`, negative powers of W cancelled in exact
//!    rational arithmetic, truncated at a degree in `x` chosen per function);
//! 2. picks the switch `x*` and the Taylor degrees by measuring the *outputs* (not the
//!    radial functions) of both branches, relative to the largest entry of each output
//!    group at the same sample point (see [`PointOptions`]);
//! 3. emits the radial functions inside one `if z < x*²` (one `sqrt` and one
//!    `sin_cos` in the closed branch only), then the polynomial part once after it,
//!    common to both branches, with CSE across all outputs.

use crate::branch::{pick_f32, F32Candidate, Rng};
use crate::cse::{tree_ops, OpCounts};
use crate::emit::Emitter;
use crate::float::Float;
use crate::graph::{Evaluator, Graph, Id, Node};
use crate::helix::HelixSymbols;
use crate::number::Num;
use crate::poly::{horner, mono_mul, mono_take, mono_var, Expander, Mono, TPoly, Trig, TrigKind};
use crate::CodegenError;
use proc_macro2::{Ident, Span, TokenStream};
use quote::quote;
use std::collections::HashMap;

/// A radial function: a symbol of the graph standing for an expression of `W` and `u`
/// alone (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Radial {
    /// Name of the symbol, also its identifier in the generated code.
    pub name: String,
    /// The symbol.
    pub symbol: Id,
    /// Its value in `W` and `u`.
    pub expr: Id,
}

/// `F_0 = f0` and `F_k = (1/W) ∂F_{k−1}/∂W` for `k < levels`, as symbols `{name}{k}`
/// declared to depend on `d` by `∂F_k/∂d_i = F_{k+1} d_i` (chain rule through
/// `∂W/∂d_i = d_i/W`). The symbol `{name}{levels}` that the last derivative refers to has
/// no value: an output that needs it is rejected by [`generate_point`] as having a free
/// symbol.
pub fn radial_family(
    g: &mut Graph,
    h: &HelixSymbols,
    name: &str,
    f0: Id,
    levels: usize,
) -> Vec<Radial> {
    let mut exprs = vec![f0];
    for k in 1..levels {
        let dw = g.diff(exprs[k - 1], h.w);
        let iw = g.pow(h.w, -1);
        exprs.push(g.mul2(iw, dw));
    }
    let syms: Vec<Id> = (0..=levels)
        .map(|k| g.symbol(&format!("{name}{k}")))
        .collect();
    for k in 0..levels {
        for i in 0..3 {
            let p = g.mul2(syms[k + 1], h.d[i]);
            g.set_partial(syms[k], h.d[i], p);
        }
    }
    (0..levels.max(1))
        .map(|k| Radial {
            name: format!("{name}{k}"),
            symbol: syms[k],
            expr: exprs[k],
        })
        .collect()
}

/// `u^p`, the terms of Q and its trig atoms (see [`PointBuilder`]).
type Rescaled = (i32, Vec<(Mono, Num)>, Vec<Id>);

/// Writes expressions of `W` and `u` as closed forms `u^p Q(x)` and Taylor series
/// `u^p Q(z)`.
pub struct PointBuilder {
    h: HelixSymbols,
    /// `x = W u` (symbol `wu`).
    pub x: Id,
    /// `z = x²` (symbol `zu`).
    pub z: Id,
    ex: Expander,
}

impl PointBuilder {
    /// A builder over the element's symbols (creates the symbols `wu` and `zu`).
    pub fn new(g: &mut Graph, h: &HelixSymbols) -> PointBuilder {
        PointBuilder {
            h: *h,
            x: g.symbol("wu"),
            z: g.symbol("zu"),
            ex: Expander::new(h.u, h.w),
        }
    }

    /// Bindings of the symbols the branches use, for [`Graph::eval`]: `u`, `x = W u`,
    /// `z = x²`.
    pub fn bindings(&self, w: f64, u: f64) -> [(Id, f64); 3] {
        let x = w * u;
        [(self.h.u, u), (self.x, x), (self.z, x * x)]
    }

    /// `u^p` and the terms of Q: monomials in `x` (closed) or `z` (series) and trig
    /// atoms of `x`.
    fn rescale(&self, g: &mut Graph, p: &TPoly, series: bool) -> Result<Rescaled, CodegenError> {
        let (h, x) = (self.h, self.x);
        let mut degree = None;
        let mut atoms = Vec::new();
        let mut out = Vec::with_capacity(p.terms.len());
        for ((t, m), c) in &p.terms {
            let (ew, rest) = mono_take(m, h.w);
            let (eu, rest) = mono_take(&rest, h.u);
            if let Some(&(v, _)) = rest.first() {
                return Err(CodegenError::Unsupported(format!(
                    "a radial function depends on {} (only W and u are allowed)",
                    g.symbol_name(v).unwrap_or("a non-symbol")
                )));
            }
            let pu = eu - ew;
            if *degree.get_or_insert(pu) != pu {
                return Err(CodegenError::Unsupported(
                    "a radial function is not of the form u^p Q(W u)".into(),
                ));
            }
            let mut mm = if series {
                if t.kind != TrigKind::One || ew % 2 != 0 || ew < 0 {
                    return Err(CodegenError::NotRegular(format!(
                        "the Taylor branch keeps x^{ew} (odd or negative)"
                    )));
                }
                mono_var(self.z, ew / 2)
            } else {
                mono_var(x, ew)
            };
            if t.kind != TrigKind::One {
                let k = g.constant(Num::Exact(t.k));
                let arg = g.mul2(k, x);
                let a = if t.kind == TrigKind::Sin {
                    g.sin(arg)
                } else {
                    g.cos(arg)
                };
                if !atoms.contains(&a) {
                    atoms.push(a);
                }
                mm = mono_mul(&mm, &mono_var(a, 1));
            }
            out.push((mm, *c));
        }
        Ok((degree.unwrap_or(0), out, atoms))
    }

    fn build(&mut self, g: &mut Graph, p: &TPoly, series: bool) -> Result<Id, CodegenError> {
        let (pu, terms, mut order) = self.rescale(g, p, series)?;
        order.push(if series { self.z } else { self.x });
        let q = horner(g, terms, &order, true);
        let up = g.pow(self.h.u, pu);
        Ok(g.mul2(up, q))
    }

    /// Closed form of `e` (a function of `W` and `u`): `u^p Q(x)`.
    pub fn closed(&mut self, g: &mut Graph, e: Id) -> Result<Id, CodegenError> {
        let p = (*self.ex.expand(g, e)?).clone();
        self.build(g, &p, false)
    }

    /// Taylor series of `e` in `W u`, truncated at degree `order` in `x`: `u^p Q(z)`.
    /// Fails with [`CodegenError::NotRegular`] when a negative or odd power of `x`
    /// survives (`e` is not an analytic even function of W).
    pub fn series(&mut self, g: &mut Graph, e: Id, order: u32) -> Result<Id, CodegenError> {
        let p = (*self.ex.expand(g, e)?).clone();
        let (u, w) = (self.h.u, self.h.w);
        let order = order as i32;
        let mut out = TPoly::default();
        for ((t, m), c) in &p.terms {
            let (ew, _) = mono_take(m, w);
            // coefficient of (W u)^j in the series of the trig factor
            let (mut j, mut coef) = match t.kind {
                TrigKind::One | TrigKind::Cos => (0, Num::ONE),
                TrigKind::Sin => (1, Num::Exact(t.k)),
            };
            let k2 = Num::Exact(t.k) * Num::Exact(t.k);
            while ew + j <= order {
                let mm = mono_mul(m, &mono_mul(&mono_var(w, j), &mono_var(u, j)));
                out.add_term(Trig::ONE, mm, *c * coef);
                if t.kind == TrigKind::One {
                    break;
                }
                coef = -(coef * k2) / Num::int(((j + 1) * (j + 2)) as i64);
                j += 2;
            }
        }
        self.build(g, &out, true)
    }
}

/// What [`generate_point`] computes: radial functions, outputs (polynomials in `d`, `u`
/// and the radial symbols) and the groups the branches' agreement is measured on.
#[derive(Clone, Debug)]
pub struct PointSpec {
    /// The radial functions, in the order they are emitted.
    pub radial: Vec<Radial>,
    /// Distinct outputs: (identifier in the generated code, expression).
    pub outputs: Vec<(String, Id)>,
    /// Output groups (name, indices into `outputs`; an output may appear in several
    /// groups or several times): deviations are relative to the largest entry of the
    /// group at the same sample point.
    pub groups: Vec<(String, Vec<usize>)>,
}

/// Targets and search ranges of the switch selection of [`generate_point`].
///
/// Deviation of a set of outputs `a` from a reference `b` at one sample point: for each
/// group G, `max_{j∈G} |a_j − b_j| / max_{j∈G} |b_j|`; over a sample set, the largest
/// of these. Samples: unit directions (the three axes, a planar diagonal, then
/// pseudo-random, seeded), `W = x/u` with u cycling through 1, 0.01 and 3.
#[derive(Clone, Debug, PartialEq)]
pub struct PointOptions {
    /// Required agreement of the two branches at `x*`.
    pub agreement_target: f64,
    /// Required truncation error of the Taylor branch at `x*` (against the series of
    /// degree + 8).
    pub truncation_target: f64,
    /// A candidate is taken when its measured agreement is within `safety` times the
    /// target on `samples` points, and within the target on `check_samples` more.
    pub safety: f64,
    /// Candidates for `x*`, in increasing order (the first that qualifies is taken:
    /// the closed branch costs the same for every `x*`, the Taylor branch less for a
    /// smaller one).
    pub candidates: Vec<f64>,
    /// Number of sample points during the selection.
    pub samples: usize,
    /// Number of sample points (another seed) confirming a candidate.
    pub check_samples: usize,
    /// Smallest common Taylor degree tried (in x, even).
    pub min_order: u32,
    /// Largest Taylor degree tried.
    pub max_order: u32,
    /// Lower the degree of each radial function separately below the common one while
    /// the truncation target still holds.
    pub per_function_orders: bool,
    /// Seed of the sample directions.
    pub seed: u64,
    /// Type of the generated code. With [`Float::F32`] (see [`PointOptions::for_f32`])
    /// the sample points are rounded to f32, the outputs of each branch are computed in
    /// f32 arithmetic (the radial functions, then the polynomial part) and compared with
    /// the f64 outputs of the Taylor series of degree `N + 8` at the same inputs; the
    /// switch is taken by `pick_f32`'s rule (`branch.rs`) (the closed form also at the
    /// next candidate), and the degrees by the truncation target as for f64.
    pub float: Float,
}

impl PointOptions {
    /// These options for f32 code: [`Float::F32`] with the f32 targets of
    /// [`crate::SwitchOptions::for_f32`] (truncation 2^-24, error 2^-20).
    pub fn for_f32(mut self) -> PointOptions {
        let u = Float::F32.unit_roundoff();
        self.float = Float::F32;
        self.truncation_target = u;
        self.agreement_target = 16.0 * u;
        self
    }
}

impl Default for PointOptions {
    fn default() -> PointOptions {
        PointOptions {
            agreement_target: 1e-14,
            truncation_target: 1e-15,
            safety: 0.5,
            candidates: vec![
                0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0, 1.125,
                1.25, 1.375, 1.5, 1.75, 2.0, 2.25, 2.5, 3.0, 3.5, 4.0, 5.0, 6.0,
            ],
            samples: 16,
            check_samples: 256,
            min_order: 2,
            max_order: 60,
            per_function_orders: true,
            seed: 0x0e1e_9017,
            float: Float::F64,
        }
    }
}

/// Generated code of a point function and what was measured.
#[derive(Clone, Debug)]
pub struct PointCode {
    /// Radial function names, in order.
    pub radial_names: Vec<String>,
    /// Taylor degree (in x) of each radial function.
    pub series_orders: Vec<u32>,
    /// The switch `x*` on `W u`: the Taylor branch is used for `W u < x*`.
    pub switch: f64,
    /// Largest deviation of the closed branch from the Taylor branch at `x*` (see
    /// [`PointOptions`] for the measure), over all samples.
    pub agreement: f64,
    /// Largest deviation of the Taylor branch from the one of degree + 8 at `x*`.
    pub truncation: f64,
    /// Number of sample points the reported agreement is the worst over.
    pub agreement_samples: usize,
    /// Type of the generated code.
    pub float: Float,
    /// With [`Float::F32`]: the largest error of the outputs through the Taylor branch
    /// in f32 at the switch against the f64 reference (see [`PointOptions::float`]);
    /// NaN for f64.
    pub series_error: f64,
    /// The same through the closed branch.
    pub closed_error: f64,
    /// Whether the switch meets the agreement target (see
    /// [`crate::SwitchChoice::target_met`]).
    pub target_met: bool,
    /// `let z = u * u * (d0 * d0 + d1 * d1 + d2 * d2);`
    pub ops_prologue: OpCounts,
    /// The radial functions' Taylor branch as emitted.
    pub ops_series: OpCounts,
    /// The radial functions' closed branch as emitted (with its `sqrt`).
    pub ops_closed: OpCounts,
    /// The polynomial part as emitted (after CSE), common to both branches.
    pub ops_shared: OpCounts,
    /// Every output as a tree with the Taylor-branch radial functions substituted
    /// (no CSE), plus the prologue.
    pub ops_before_series: OpCounts,
    /// The same with the closed-branch radial functions.
    pub ops_before_closed: OpCounts,
    /// Statements computing every output from `d0, d1, d2, u` (bound by the caller)
    /// into `let` bindings named after the outputs: [`PointCode::radial_body`] then
    /// [`PointCode::shared_body`].
    pub body: TokenStream,
    /// Statements binding `z` and the radial functions (by their names) from `d0, d1,
    /// d2, u`: the switch and both branches.
    pub radial_body: TokenStream,
    /// Statements binding the outputs from `d0, d1, d2, u` and the radial functions:
    /// the polynomial part, the same for either branch (and written so that it
    /// type-checks with the radial functions as four lanes, `F4`).
    pub shared_body: TokenStream,
    /// Closed-form DAG of every radial function.
    pub closed: Vec<Id>,
    /// Taylor-branch DAG of every radial function.
    pub series: Vec<Id>,
}

impl PointCode {
    /// Total operations when the Taylor branch runs (prologue, radial functions,
    /// shared part).
    pub fn ops_series_path(&self) -> OpCounts {
        self.ops_prologue + self.ops_series + self.ops_shared
    }
    /// Total operations when the closed branch runs.
    pub fn ops_closed_path(&self) -> OpCounts {
        self.ops_prologue + self.ops_closed + self.ops_shared
    }
}

/// Sample points `(d, u)` with `|d| u = x`.
fn samples(x: f64, n: usize, seed: u64) -> Vec<([f64; 3], f64)> {
    let mut rng = Rng(seed);
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let fixed = [
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, h, h],
    ];
    (0..n)
        .map(|i| {
            let u = [1.0, 0.01, 3.0][i % 3];
            let e = if i < fixed.len() {
                fixed[i]
            } else {
                rng.direction()
            };
            ([e[0] * x / u, e[1] * x / u, e[2] * x / u], u)
        })
        .collect()
}

/// [`samples`] rounded to `float`.
fn samples_in(x: f64, n: usize, seed: u64, float: Float) -> Vec<([f64; 3], f64)> {
    let mut pts = samples(x, n, seed);
    for (d, u) in pts.iter_mut() {
        *d = d.map(|v| float.round(v));
        *u = float.round(*u);
    }
    pts
}

/// Evaluates the outputs from the radial functions' branches.
struct Measure<'a> {
    g: &'a Graph,
    h: HelixSymbols,
    pb: [Id; 3],
    radial: Vec<Id>,
    outputs: Evaluator,
    groups: &'a [(String, Vec<usize>)],
}

impl Measure<'_> {
    /// Outputs at every sample point with the radial functions given by `branch`.
    fn outputs(&self, branch: &[Id], pts: &[([f64; 3], f64)]) -> Vec<Vec<f64>> {
        let ev = self.g.evaluator(branch);
        pts.iter()
            .map(|(d, u)| {
                let w = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let x = w * u;
                let rb = [(self.pb[0], *u), (self.pb[1], x), (self.pb[2], x * x)];
                let r = ev.eval(self.g, &rb);
                let mut b: Vec<(Id, f64)> = vec![
                    (self.h.d[0], d[0]),
                    (self.h.d[1], d[1]),
                    (self.h.d[2], d[2]),
                    (self.h.u, *u),
                ];
                b.extend(self.radial.iter().copied().zip(r));
                self.outputs.eval(self.g, &b)
            })
            .collect()
    }

    /// [`Measure::outputs`] in f32 arithmetic, as generated f32 code computes them:
    /// `z = u u (d·d)` and `x = sqrt(z)` in f32, the radial functions' branch and then
    /// the outputs evaluated in f32 ([`Evaluator::eval_f32`]).
    fn outputs_f32(&self, branch: &[Id], pts: &[([f64; 3], f64)]) -> Vec<Vec<f64>> {
        let ev = self.g.evaluator(branch);
        pts.iter()
            .map(|(d, u)| {
                let (d, u) = (d.map(|v| v as f32), *u as f32);
                let z = u * u * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                let x = z.sqrt();
                let f = |v: f32| v as f64;
                let rb = [(self.pb[0], f(u)), (self.pb[1], f(x)), (self.pb[2], f(z))];
                let r = ev.eval_f32(self.g, &rb);
                let mut b: Vec<(Id, f64)> = vec![
                    (self.h.d[0], f(d[0])),
                    (self.h.d[1], f(d[1])),
                    (self.h.d[2], f(d[2])),
                    (self.h.u, f(u)),
                ];
                b.extend(self.radial.iter().copied().zip(r));
                self.outputs.eval_f32(self.g, &b)
            })
            .collect()
    }

    /// Largest deviation of `a` from `b` (see [`PointOptions`]).
    fn deviation(&self, a: &[Vec<f64>], b: &[Vec<f64>]) -> f64 {
        let mut worst = 0.0f64;
        for (va, vb) in a.iter().zip(b) {
            for (_, idx) in self.groups {
                let scale = idx.iter().map(|&j| vb[j].abs()).fold(0.0, f64::max);
                for &j in idx {
                    let e = (va[j] - vb[j]).abs();
                    if e > 0.0 {
                        worst = worst.max(if scale > 0.0 {
                            e / scale
                        } else {
                            f64::INFINITY
                        });
                    }
                }
            }
        }
        worst
    }
}

fn ident(s: &str) -> Ident {
    Ident::new(s, Span::call_site())
}

fn is_ident(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(f) if f.is_ascii_alphabetic() || f == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
        && s != "_"
}

/// Number of times the leaf `s` occurs in the outputs written as trees.
fn tree_occurrences(g: &Graph, roots: &[Id], s: Id) -> u64 {
    let mark = g.reachable(roots);
    let mut n = vec![0u64; g.len()];
    for i in 0..g.len() {
        if !mark[i] {
            continue;
        }
        n[i] = if Id(i as u32) == s {
            1
        } else {
            g.node(Id(i as u32))
                .children()
                .iter()
                .fold(0u64, |a, c| a.saturating_add(n[c.index()]))
        };
    }
    roots
        .iter()
        .fold(0u64, |a, r| a.saturating_add(n[r.index()]))
}

/// Generate the statements of a point function (see the module docs). `switch` names
/// the constant holding `x*` in the generated code (the caller defines it with the
/// returned [`PointCode::switch`]).
pub fn generate_point(
    g: &mut Graph,
    h: &HelixSymbols,
    spec: &PointSpec,
    switch: &Ident,
    opts: &PointOptions,
) -> Result<PointCode, CodegenError> {
    let reserved = ["d0", "d1", "d2", "u", "z", "x"];
    let mut seen = std::collections::HashSet::new();
    let names = spec
        .radial
        .iter()
        .map(|r| r.name.as_str())
        .chain(spec.outputs.iter().map(|o| o.0.as_str()));
    for n in names {
        if !is_ident(n) || reserved.contains(&n) || !seen.insert(n) {
            return Err(CodegenError::BadName(n.to_string()));
        }
        // the emitters' own bindings are s1, q1, t1, …
        let mut c = n.chars();
        if matches!(c.next(), Some('s' | 'q' | 't'))
            && c.clone().count() > 0
            && c.all(|c| c.is_ascii_digit())
        {
            return Err(CodegenError::BadName(n.to_string()));
        }
    }
    for (gname, idx) in &spec.groups {
        if idx.is_empty() || idx.iter().any(|&j| j >= spec.outputs.len()) {
            return Err(CodegenError::BadName(format!("group {gname}")));
        }
    }
    let mut pb = PointBuilder::new(g, h);
    let outputs: Vec<Id> = spec.outputs.iter().map(|o| o.1).collect();
    let radial_syms: Vec<Id> = spec.radial.iter().map(|r| r.symbol).collect();

    // free symbols: the outputs may use d, u and the radial symbols only
    let mut allowed: Vec<Id> = vec![h.d[0], h.d[1], h.d[2], h.u];
    allowed.extend(&radial_syms);
    let mark = g.reachable(&outputs);
    for (i, &m) in mark.iter().enumerate() {
        let id = Id(i as u32);
        if m && matches!(g.node(id), Node::Sym(_)) && !allowed.contains(&id) {
            return Err(CodegenError::Unsupported(format!(
                "free symbol {} in an output (a radial derivative beyond the declared levels?)",
                g.symbol_name(id).unwrap_or("?")
            )));
        }
    }

    let closed: Vec<Id> = spec
        .radial
        .iter()
        .map(|r| pb.closed(g, r.expr))
        .collect::<Result<_, _>>()?;
    let mut cache: HashMap<(usize, u32), Id> = HashMap::new();
    let mut series_at = |g: &mut Graph, pb: &mut PointBuilder, orders: &[u32]| {
        orders
            .iter()
            .enumerate()
            .map(|(k, &o)| {
                if let Some(&id) = cache.get(&(k, o)) {
                    return Ok(id);
                }
                let id = pb.series(g, spec.radial[k].expr, o)?;
                cache.insert((k, o), id);
                Ok(id)
            })
            .collect::<Result<Vec<Id>, CodegenError>>()
    };

    // switch and degrees, by measurement
    let nr = spec.radial.len();
    let mut order = opts.min_order;
    let mut best: Option<(f64, f64)> = None;
    let mut chosen = None;
    let float = opts.float;
    // f32: every candidate measured, then picked (x*, degrees, truncation, errors)
    let mut measured: Vec<(F32Candidate, Vec<u32>, f64)> = Vec::new();
    for &x in &opts.candidates {
        let pts = samples_in(x, opts.samples, opts.seed, float);
        // every series this candidate may need, built before measuring (the measure
        // borrows the graph)
        let (trunc, orders) = loop {
            let reference = series_at(g, &mut pb, &vec![order + 8; nr])?;
            let s = series_at(g, &mut pb, &vec![order; nr])?;
            let m = measure(g, h, &pb, &radial_syms, &outputs, &spec.groups);
            let rv = m.outputs(&reference, &pts);
            let t = m.deviation(&m.outputs(&s, &pts), &rv);
            if t <= opts.truncation_target || order + 2 > opts.max_order {
                break (t, vec![order; nr]);
            }
            order += 2;
        };
        if trunc > opts.truncation_target {
            break;
        }
        let mut orders = orders;
        let reference = series_at(g, &mut pb, &vec![order + 8; nr])?;
        if opts.per_function_orders {
            for k in 0..nr {
                while orders[k] >= 2 {
                    orders[k] -= 2;
                    let s = series_at(g, &mut pb, &orders)?;
                    let m = measure(g, h, &pb, &radial_syms, &outputs, &spec.groups);
                    let rv = m.outputs(&reference, &pts);
                    if m.deviation(&m.outputs(&s, &pts), &rv) > opts.truncation_target {
                        orders[k] += 2;
                        break;
                    }
                }
            }
        }
        let s = series_at(g, &mut pb, &orders)?;
        let m = measure(g, h, &pb, &radial_syms, &outputs, &spec.groups);
        let sv = m.outputs(&s, &pts);
        if float == Float::F32 {
            // each branch in f32 against the f64 outputs of the degree + 8 series
            let more = samples_in(x, opts.check_samples, opts.seed ^ 0xa5a5, float);
            let (rv, rm) = (m.outputs(&reference, &pts), m.outputs(&reference, &more));
            let trunc = m
                .deviation(&sv, &rv)
                .max(m.deviation(&m.outputs(&s, &more), &rm));
            let err = |branch: &[Id], p: &[([f64; 3], f64)], r: &[Vec<f64>]| {
                m.deviation(&m.outputs_f32(branch, p), r)
            };
            let (ss, cs) = (err(&s, &pts, &rv), err(&closed, &pts, &rv));
            let (sm, cm) = (err(&s, &more, &rm), err(&closed, &more, &rm));
            measured.push((
                F32Candidate {
                    x,
                    series_sel: ss,
                    closed_sel: cs,
                    series_all: ss.max(sm),
                    closed_all: cs.max(cm),
                },
                orders,
                trunc,
            ));
            continue;
        }
        let agreement = m.deviation(&m.outputs(&closed, &pts), &sv);
        // truncation of the degrees as chosen (per function)
        let trunc = m.deviation(&sv, &m.outputs(&reference, &pts));
        if best.is_none_or(|b| agreement < b.1) {
            best = Some((x, agreement));
        }
        if agreement <= opts.safety * opts.agreement_target {
            let more = samples(x, opts.check_samples, opts.seed ^ 0xa5a5);
            let sv = m.outputs(&s, &more);
            let check = m.deviation(&m.outputs(&closed, &more), &sv);
            if check <= opts.agreement_target {
                let rv = m.outputs(&reference, &more);
                let trunc = m.deviation(&sv, &rv).max(trunc);
                chosen = Some((x, orders, agreement.max(check), trunc));
                break;
            }
        }
    }
    let (mut series_error, mut closed_error, mut target_met) = (f64::NAN, f64::NAN, true);
    if float == Float::F32 {
        let cands: Vec<F32Candidate> = measured.iter().map(|m| m.0).collect();
        if let Some((i, error, met)) = pick_f32(&cands, opts.agreement_target, opts.safety, true) {
            let (c, orders, trunc) = measured.swap_remove(i);
            (series_error, closed_error, target_met) = (c.series_all, c.closed_all, met);
            chosen = Some((c.x, orders, error, trunc));
        }
    }
    let Some((x_star, orders, agreement, truncation)) = chosen else {
        return Err(CodegenError::NoSwitch(format!(
            "no candidate x* meets agreement {:e} with truncation {:e}; best (x*, agreement): {:?}",
            opts.agreement_target, opts.truncation_target, best
        )));
    };
    let series = series_at(g, &mut pb, &orders)?;

    // emission
    let (u_id, ident_u) = (h.u, ident("u"));
    let mut es = Emitter::new(
        g,
        &series,
        &[(u_id, ident_u.clone()), (pb.z, ident("z"))],
        "s",
    )
    .with_float(float);
    let series_exprs = es.run(&series);
    let mut ec = Emitter::new(
        g,
        &closed,
        &[(u_id, ident_u.clone()), (pb.x, ident("x"))],
        "q",
    )
    .with_float(float);
    let closed_exprs = ec.run(&closed);
    let mut symbols: Vec<(Id, Ident)> = vec![
        (h.d[0], ident("d0")),
        (h.d[1], ident("d1")),
        (h.d[2], ident("d2")),
        (u_id, ident_u),
    ];
    symbols.extend(spec.radial.iter().map(|r| (r.symbol, ident(&r.name))));
    let mut em = Emitter::new(g, &outputs, &symbols, "t").with_float(float);
    let output_exprs = em.run(&outputs);

    let radial_idents: Vec<Ident> = spec.radial.iter().map(|r| ident(&r.name)).collect();
    let output_idents: Vec<Ident> = spec.outputs.iter().map(|o| ident(&o.0)).collect();
    let (ss, cs, ts) = (&es.stmts, &ec.stmts, &em.stmts);
    let radial_body = quote! {
        let z = u * u * (d0 * d0 + d1 * d1 + d2 * d2);
        let (#(#radial_idents),*) = if z < #switch * #switch {
            #(#ss)*
            (#(#series_exprs),*)
        } else {
            let x = z.sqrt();
            #(#cs)*
            (#(#closed_exprs),*)
        };
    };
    let shared_body = quote! {
        #(#ts)*
        #(let #output_idents = #output_exprs;)*
    };
    let body = quote!(#radial_body #shared_body);

    let ops_prologue = OpCounts {
        adds: 2,
        muls: 5,
        ..OpCounts::default()
    };
    let sqrt = OpCounts {
        sqrts: 1,
        ..OpCounts::default()
    };
    // as trees: every occurrence of a radial symbol in an output tree costs its branch
    let shared_tree = tree_ops(g, &outputs);
    let mut before_series = ops_prologue + shared_tree;
    let mut before_closed = ops_prologue + shared_tree;
    for k in 0..nr {
        let n = tree_occurrences(g, &outputs, radial_syms[k]);
        let (ts, tc) = (
            tree_ops(g, &series[k..=k]),
            tree_ops(g, &closed[k..=k]) + sqrt,
        );
        for _ in 0..n {
            before_series += ts;
            before_closed += tc;
        }
    }
    Ok(PointCode {
        radial_names: spec.radial.iter().map(|r| r.name.clone()).collect(),
        series_orders: orders,
        switch: x_star,
        agreement,
        truncation,
        agreement_samples: opts.samples + opts.check_samples,
        float,
        series_error,
        closed_error,
        target_met,
        ops_prologue,
        ops_series: es.ops,
        ops_closed: ec.ops + sqrt,
        ops_shared: em.ops,
        ops_before_series: before_series,
        ops_before_closed: before_closed,
        body,
        radial_body,
        shared_body,
        closed,
        series,
    })
}

fn measure<'a>(
    g: &'a Graph,
    h: &HelixSymbols,
    pb: &PointBuilder,
    radial: &[Id],
    outputs: &[Id],
    groups: &'a [(String, Vec<usize>)],
) -> Measure<'a> {
    Measure {
        g,
        h: *h,
        pb: [h.u, pb.x, pb.z],
        radial: radial.to_vec(),
        outputs: g.evaluator(outputs),
        groups,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn family(g: &mut Graph, h: &HelixSymbols) -> Vec<Radial> {
        // B = (1 − cos uW)/W²
        let wu = g.mul2(h.w, h.u);
        let c = g.cos(wu);
        let one = g.one();
        let omc = g.sub(one, c);
        let iw2 = g.pow(h.w, -2);
        let b = g.mul2(omc, iw2);
        radial_family(g, h, "b", b, 3)
    }

    #[test]
    fn radial_branches_match_the_expression_and_its_w_derivatives() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let f = family(&mut g, &h);
        let mut pb = PointBuilder::new(&mut g, &h);
        for (k, r) in f.iter().enumerate() {
            let closed = pb.closed(&mut g, r.expr).unwrap();
            let series = pb.series(&mut g, r.expr, 30).unwrap();
            for (w, u) in [(3.0, 0.2), (40.0, 0.05), (25.0, 0.2), (0.7, 7.0)] {
                let mut b = h.bindings([w, 0.0, 0.0], 0.0, u);
                b.extend(pb.bindings(w, u));
                let exact = g.eval(r.expr, &b);
                let c = g.eval(closed, &b);
                let s = g.eval(series, &b);
                if w * u >= 2.0 {
                    // the expression as built and the closed branch (Horner in 1/x)
                    assert!(
                        (c - exact).abs() <= 1e-13 * exact.abs(),
                        "{k}: {c} vs {exact}"
                    );
                }
                if w * u <= 2.0 {
                    assert!(
                        (s - exact).abs() <= 1e-10 * exact.abs(),
                        "{k}: {s} vs {exact}"
                    );
                    assert!((s - c).abs() <= 1e-10 * s.abs(), "{k}: {s} vs {c}");
                }
            }
            // F_{k+1} = (1/W) ∂F_k/∂W by a central difference in W
            if k + 1 < f.len() {
                let (w, u, e) = (2.0, 0.3, 1e-4);
                let at = |g: &Graph, w: f64| {
                    let mut b = h.bindings([w, 0.0, 0.0], 0.0, u);
                    b.extend(pb.bindings(w, u));
                    g.eval(closed, &b)
                };
                let fd = (at(&g, w + e) - at(&g, w - e)) / (2.0 * e) / w;
                let mut b = h.bindings([w, 0.0, 0.0], 0.0, u);
                b.extend(pb.bindings(w, u));
                let next = g.eval(f[k + 1].expr, &b);
                assert!(
                    (fd - next).abs() <= 1e-7 * next.abs(),
                    "{k}: {fd} vs {next}"
                );
            }
        }
        // an odd function of W has no Taylor branch in z
        let wu = g.mul2(h.w, h.u);
        let s = g.sin(wu);
        let iw2 = g.pow(h.w, -2);
        let odd = g.mul2(s, iw2);
        assert!(matches!(
            pb.series(&mut g, odd, 10),
            Err(CodegenError::NotRegular(_))
        ));
    }

    #[test]
    fn point_function_of_a_radial_family() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let f = family(&mut g, &h);
        // B d0 and its d-derivatives: every output needs the chain rule through W
        let v = g.mul2(f[0].symbol, h.d[0]);
        let v1 = g.diff(v, h.d[1]);
        let v11 = g.diff(v1, h.d[1]);
        let spec = PointSpec {
            radial: f.clone(),
            outputs: vec![("v".into(), v), ("v1".into(), v1), ("v11".into(), v11)],
            groups: vec![("v".into(), vec![0]), ("dv".into(), vec![1, 2])],
        };
        let sw = ident("SWITCH");
        let code = generate_point(&mut g, &h, &spec, &sw, &PointOptions::default()).unwrap();
        assert!(code.agreement <= 1e-14 && code.truncation <= 1e-14);
        assert!(code.switch > 0.0 && code.series_orders.len() == 3);
        let text = code.body.to_string();
        assert!(text.contains("sin_cos") && text.contains("let v11 ="));
        assert!(code.ops_closed_path().trig == 1 && code.ops_series_path().trig == 0);
        assert!(code.ops_series_path().total() < code.ops_before_series.total());

        // a derivative beyond the declared levels is a free symbol
        let v111 = g.diff(v11, h.d[1]);
        let bad = PointSpec {
            radial: f,
            outputs: vec![("v111".into(), v111)],
            groups: vec![("v".into(), vec![0])],
        };
        assert!(matches!(
            generate_point(&mut g, &h, &bad, &sw, &PointOptions::default()),
            Err(CodegenError::Unsupported(_))
        ));
    }
}

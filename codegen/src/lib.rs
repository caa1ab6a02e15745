//! `superhelix-codegen`: a small symbolic engine that turns the closed-form helix
//! element (design page "Reconstruction") into fast, allocation-free Rust for the
//! per-element integrals of the fixed-N kernels ("Efficient assembly").
//!
//! Pipeline (generator and output kept apart, SymForce-style):
//! 1. build integrands in the hash-consed DAG ([`Graph`], [`helix`] builders,
//!    [`Graph::diff`]);
//! 2. integrate each over the element, `∫_0^l … du`, in two branches
//!    ([`Graph::integrate_element`]): exact closed form, and Taylor series in `W l`
//!    with no division by W;
//! 3. [`generate_function`] picks the switch `x*` on `W l` and the Taylor order by
//!    measuring both branches ([`branch`]), eliminates common subexpressions across all
//!    outputs ([`cse`]) and prints one Rust function ([`emit`]); [`format`] runs rustfmt.
//!
//! ```
//! use superhelix_codegen::{generate_function, helix, GenerateOptions, Graph, HelixSymbols};
//! let mut g = Graph::new();
//! let h = HelixSymbols::new(&mut g);
//! let p = helix::position(&mut g, &h, h.u);
//! let pp = g.mul2(p[1], p[2]);
//! let list = vec![("p1".to_string(), p[1]), ("p1p2".to_string(), pp)];
//! let out = generate_function(&mut g, &h, "element_moments", &list, &GenerateOptions::default()).unwrap();
//! assert!(out.code.contains("pub fn element_moments(d: &[f64; 3], l: f64, out: &mut [f64; 2])"));
//! assert!(out.agreement <= 1e-14);
//! ```
//!
//! # Generated code
//! `pub fn <name>(d: &[f64; 3], l: f64, out: &mut [f64; K])` writes output `i` (in the
//! order of the list) to `out[i]`; `pub const <NAME>_OUTPUTS: [&str; K]` holds the
//! names and `pub const <NAME>_SWITCH: f64` the switch. The body computes
//! `W = sqrt(d·d)` and branches once on `W l < x*`. It allocates nothing and cannot
//! panic (constant indices into a fixed-size array, float arithmetic only).

#![warn(missing_docs)]
// index loops over 0..3 read like the formulas they implement
#![allow(clippy::needless_range_loop)]

pub mod branch;
pub mod cse;
mod diff;
pub mod emit;
pub mod graph;
pub mod helix;
pub mod integrate;
pub mod number;
mod poly;

pub use branch::{SwitchChoice, SwitchOptions};
pub use cse::OpCounts;
pub use emit::format;
pub use graph::{Evaluator, Graph, Id, Node};
pub use helix::HelixSymbols;
pub use integrate::ElementIntegral;
pub use number::{Num, Rational};

use proc_macro2::{Ident, Span};
use quote::quote;
use std::fmt;

/// Version written into the `@generated` header.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// What can go wrong while generating.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CodegenError {
    /// An integrand outside the supported class (see [`integrate`]).
    Unsupported(String),
    /// The Taylor branch keeps a negative power of W (the integrand is not analytic at
    /// W = 0).
    NotRegular(String),
    /// A function or output name that is not a Rust identifier, or repeated.
    BadName(String),
    /// No switch meets the targets.
    NoSwitch(String),
}

impl fmt::Display for CodegenError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CodegenError::Unsupported(s) => write!(f, "unsupported integrand: {s}"),
            CodegenError::NotRegular(s) => write!(f, "integrand not regular at W = 0: {s}"),
            CodegenError::BadName(s) => write!(f, "bad name: {s}"),
            CodegenError::NoSwitch(s) => write!(f, "no switch found: {s}"),
        }
    }
}

impl std::error::Error for CodegenError {}

/// Options of [`generate_function`].
#[derive(Clone, Debug, PartialEq)]
pub struct GenerateOptions {
    /// Switch selection (targets, candidates, orders).
    pub switch: SwitchOptions,
    /// Directions sampled for the reported agreement of the emitted branches.
    pub check_samples: usize,
    /// Write `sin(nWl)`, `cos(nWl)` from `sin(Wl)`, `cos(Wl)` by the multiple-angle
    /// recurrences (one `sin_cos` call).
    pub multiple_angles: bool,
}

impl Default for GenerateOptions {
    fn default() -> GenerateOptions {
        GenerateOptions {
            switch: SwitchOptions::default(),
            check_samples: 64,
            multiple_angles: true,
        }
    }
}

/// A generated function and what is known about it.
#[derive(Clone, Debug)]
pub struct GeneratedCode {
    /// Function name.
    pub name: String,
    /// Output names, in `out` order.
    pub outputs: Vec<String>,
    /// Rust source (one line of tokens after the header; see [`format`]).
    pub code: String,
    /// Operations written as trees, both branches plus the prologue (no CSE).
    pub ops_before: OpCounts,
    /// Operations as emitted, both branches plus the prologue (after CSE).
    pub ops_after: OpCounts,
    /// Of `ops_after`: the Taylor branch alone.
    pub ops_series: OpCounts,
    /// Of `ops_after`: the closed-form branch alone.
    pub ops_closed: OpCounts,
    /// The switch `x*` on `W l`.
    pub switch: f64,
    /// Degree in W of the Taylor branch.
    pub series_order: u32,
    /// Largest relative difference of the emitted branches at `x*`, over
    /// `check_samples` directions (see [`branch`] for "relative").
    pub agreement: f64,
    /// Estimated largest relative truncation error of the Taylor branch at `x*`.
    pub truncation: f64,
    /// Closed-form DAG of every output.
    pub closed: Vec<Id>,
    /// Taylor-branch DAG of every output.
    pub series: Vec<Id>,
}

fn is_ident(s: &str) -> bool {
    let mut c = s.chars();
    matches!(c.next(), Some(f) if f.is_ascii_alphabetic() || f == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
        && s != "_"
}

/// Integrate every named integrand over the element and emit one Rust function that
/// computes all of them (see the crate docs for its signature).
pub fn generate_function(
    g: &mut Graph,
    h: &HelixSymbols,
    name: &str,
    integrands: &[(String, Id)],
    opts: &GenerateOptions,
) -> Result<GeneratedCode, CodegenError> {
    if !is_ident(name) {
        return Err(CodegenError::BadName(name.to_string()));
    }
    let mut seen = std::collections::HashSet::new();
    for (n, _) in integrands {
        if !is_ident(n) || !seen.insert(n.as_str()) {
            return Err(CodegenError::BadName(n.clone()));
        }
    }
    let mut it = integrate::Integrator::new(*h, opts.multiple_angles);
    let mut expanded = Vec::with_capacity(integrands.len());
    let mut closed = Vec::with_capacity(integrands.len());
    for (_, e) in integrands {
        let p = it.expand(g, *e)?;
        let c = it.closed(&p)?;
        closed.push(it.build_dag(g, &c));
        expanded.push(p);
    }
    let mut cache: std::collections::HashMap<u32, Vec<Id>> = std::collections::HashMap::new();
    let mut series_at = |g: &mut Graph, order: u32| -> Result<Vec<Id>, CodegenError> {
        if let Some(v) = cache.get(&order) {
            return Ok(v.clone());
        }
        let mut v = Vec::with_capacity(expanded.len());
        for p in &expanded {
            let s = it.series(p, order)?;
            v.push(it.build_dag(g, &s));
        }
        cache.insert(order, v.clone());
        Ok(v)
    };
    let choice = branch::choose(g, h, &closed, &mut series_at, &opts.switch)?;
    let series = series_at(g, choice.order)?;

    // the reported agreement: emitted DAGs, more directions, another seed
    let pts = branch::samples(choice.x_star, opts.check_samples, opts.switch.seed ^ 0xa5a5);
    let agreement = branch::max_relative(
        &branch::evaluate(g, h, &closed, &pts),
        &branch::evaluate(g, h, &series, &pts),
    );

    // symbols of the generated code
    let ident = |s: &str| Ident::new(s, Span::call_site());
    let symbols: Vec<(Id, Ident)> = vec![
        (h.d[0], ident("d0")),
        (h.d[1], ident("d1")),
        (h.d[2], ident("d2")),
        (h.w, ident("w")),
        (h.l, ident("l")),
    ];
    let mut all: Vec<Id> = series.clone();
    all.extend(&closed);
    let mark = g.reachable(&all);
    for (i, &m) in mark.iter().enumerate() {
        let id = Id(i as u32);
        if m && g.symbol_name(id).is_some() && !symbols.iter().any(|s| s.0 == id) {
            return Err(CodegenError::Unsupported(format!(
                "free symbol {} in an integral",
                g.symbol_name(id).unwrap_or("?")
            )));
        }
    }

    let mut es = emit::Emitter::new(g, &series, &symbols, "s");
    let series_exprs = es.run(&series);
    let mut ec = emit::Emitter::new(g, &closed, &symbols, "c");
    let closed_exprs = ec.run(&closed);
    let prologue = OpCounts {
        adds: 2,
        muls: 4,
        sqrts: 1,
        ..OpCounts::default()
    };
    let ops_after = prologue + es.ops + ec.ops;
    let ops_before = prologue + cse::tree_ops(g, &series) + cse::tree_ops(g, &closed);

    let k = integrands.len();
    let idx: Vec<proc_macro2::Literal> =
        (0..k).map(proc_macro2::Literal::usize_unsuffixed).collect();
    let fname = ident(name);
    let upper = name.to_uppercase();
    let outputs_const = ident(&format!("{upper}_OUTPUTS"));
    let switch_const = ident(&format!("{upper}_SWITCH"));
    let names: Vec<&str> = integrands.iter().map(|(n, _)| n.as_str()).collect();
    let xs = emit::literal(choice.x_star);
    let (ss, cs) = (&es.stmts, &ec.stmts);
    let k_lit = proc_macro2::Literal::usize_unsuffixed(k);
    let mut doc = format!(
        " Element integrals `∫_0^l … du` for Darboux vector `d` and length `l`.\n\n \
         Taylor branch (degree {} in W) for `W l < {}`, closed form above; the branches \
         agree to {:.1e} (relative) at the switch.\n\n Outputs:\n",
        choice.order, choice.x_star, agreement
    );
    for (i, n) in names.iter().enumerate() {
        doc.push_str(&format!(" - `out[{i}]`: `{n}`\n"));
    }
    let doc_outputs = format!(" Names of the outputs of [`{name}`], in order.");
    let doc_switch = format!(" Switch on `W l` of [`{name}`]: Taylor branch below.");
    let tokens = quote! {
        #[doc = #doc_outputs]
        pub const #outputs_const: [&str; #k_lit] = [#(#names),*];
        #[doc = #doc_switch]
        pub const #switch_const: f64 = #xs;
        #[doc = #doc]
        #[allow(
            unused_variables,
            clippy::all,
            clippy::pedantic,
            clippy::excessive_precision,
            clippy::unreadable_literal
        )]
        pub fn #fname(d: &[f64; 3], l: f64, out: &mut [f64; #k_lit]) {
            let d0 = d[0];
            let d1 = d[1];
            let d2 = d[2];
            let w = (d0 * d0 + d1 * d1 + d2 * d2).sqrt();
            if w * l < #switch_const {
                #(#ss)*
                #(out[#idx] = #series_exprs;)*
            } else {
                #(#cs)*
                #(out[#idx] = #closed_exprs;)*
            }
        }
    };
    let header = format!(
        "// @generated by superhelix-codegen {VERSION}\n\
         // {name}: {k} outputs; switch W*l = {} (Taylor degree {} below), branch agreement {:.2e}, \
         truncation {:.2e}\n\
         // ops before CSE (as trees): {ops_before}\n\
         // ops after CSE (as emitted): {ops_after}\n\
         //   Taylor branch: {}\n\
         //   closed branch: {}\n",
        choice.x_star, choice.order, agreement, choice.truncation, es.ops, ec.ops
    );
    Ok(GeneratedCode {
        name: name.to_string(),
        outputs: names.iter().map(|s| s.to_string()).collect(),
        code: format!("{header}{tokens}\n"),
        ops_before,
        ops_after,
        ops_series: es.ops,
        ops_closed: ec.ops,
        switch: choice.x_star,
        series_order: choice.order,
        agreement,
        truncation: choice.truncation,
        closed,
        series,
    })
}

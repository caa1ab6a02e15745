//! Printing DAG nodes as Rust statements with `quote`, and formatting with rustfmt.
//!
//! The emitter writes one `let` per node chosen by `cse::bindings`, in arena
//! order (a topological order), inlining everything used once. Integer powers are
//! written as repeated multiplications through a cache (`x²` once, `x⁴ = x²·x²`, …;
//! negative powers from one `1.0 / x`). `sin` and `cos` of one argument become one
//! `sin_cos` call. Every operation written is counted.

use crate::cse::{bindings, OpCounts};
use crate::float::Float;
use crate::graph::{Graph, Id, Node};
use crate::number::Num;
use proc_macro2::{Ident, Literal, Span, TokenStream};
use quote::quote;
use std::collections::HashMap;
use std::str::FromStr;

/// Context of an expression, for parentheses.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Prec {
    /// A whole right-hand side.
    Top,
    /// A factor of a product.
    Product,
    /// A method receiver.
    Receiver,
}

/// A non-negative float literal (shortest round-trip form).
pub(crate) fn literal(v: f64) -> TokenStream {
    literal_in(v, Float::F64)
}

/// A non-negative float literal of `v` rounded to `float`, in the shortest form that
/// reads back as that value of that type (unsuffixed: the type comes from the context).
/// Panics when a nonzero `v` rounds to zero or infinity in `float`.
pub(crate) fn literal_in(v: f64, float: Float) -> TokenStream {
    debug_assert!(v >= 0.0 && v.is_finite());
    // Display and LowerExp print the shortest digits that read back as the value
    let (plain, exp) = match float {
        Float::F64 => (format!("{v}"), format!("{v:e}")),
        Float::F32 => {
            let r = v as f32;
            assert!(
                r.is_finite() && (r == 0.0) == (v == 0.0),
                "constant {v:e} is not representable as f32"
            );
            (format!("{r}"), format!("{r:e}"))
        }
    };
    let v = float.round(v);
    let s = if v == 0.0 {
        "0.0".to_string()
    } else if (1e-5..1e16).contains(&v) {
        if plain.contains('.') {
            plain
        } else {
            format!("{plain}.0")
        }
    } else {
        exp
    };
    TokenStream::from(proc_macro2::TokenTree::Literal(
        Literal::from_str(&s).expect("float literal"),
    ))
}

/// Writes the statements of one branch.
pub(crate) struct Emitter<'a> {
    g: &'a Graph,
    bind: Vec<bool>,
    names: HashMap<Id, TokenStream>,
    powers: HashMap<(Id, i32), TokenStream>,
    /// Statements written so far.
    pub stmts: Vec<TokenStream>,
    /// Operations written so far.
    pub ops: OpCounts,
    next: usize,
    prefix: &'static str,
    float: Float,
}

impl<'a> Emitter<'a> {
    /// An emitter for the outputs `roots`, with the given identifiers for symbols, and
    /// `prefix` for the names of its bindings.
    pub fn new(
        g: &'a Graph,
        roots: &[Id],
        symbols: &[(Id, Ident)],
        prefix: &'static str,
    ) -> Emitter<'a> {
        Emitter {
            g,
            bind: bindings(g, roots),
            names: symbols.iter().map(|(id, n)| (*id, quote!(#n))).collect(),
            powers: HashMap::new(),
            stmts: Vec::new(),
            ops: OpCounts::default(),
            next: 0,
            prefix,
            float: Float::F64,
        }
    }

    /// The same emitter writing its constants as literals of `float` (f64 by default).
    pub fn with_float(mut self, float: Float) -> Emitter<'a> {
        self.float = float;
        self
    }

    fn fresh(&mut self) -> Ident {
        self.next += 1;
        Ident::new(&format!("{}{}", self.prefix, self.next), Span::call_site())
    }

    fn let_bind(&mut self, value: TokenStream) -> TokenStream {
        let n = self.fresh();
        self.stmts.push(quote!(let #n = #value;));
        quote!(#n)
    }

    /// Write the bindings, then return the expression of every root.
    pub fn run(&mut self, roots: &[Id]) -> Vec<TokenStream> {
        for i in 0..self.g.len() {
            let id = Id(i as u32);
            if !self.bind[i] || self.names.contains_key(&id) {
                continue;
            }
            self.bind_node(id);
        }
        roots.iter().map(|&r| self.expr(r, Prec::Top)).collect()
    }

    /// Write every root as the statement `store(k, expression)`, each preceded by the
    /// bindings it needs that are not written yet (depth first, children before
    /// parents), so a temporary lives from just before its first use: the same
    /// operations as [`Emitter::run`] on the same operands (bit-for-bit the same
    /// results), with shorter live ranges than writing every binding first. In
    /// straight-line code of thousands of operations that is what keeps the compiler's
    /// register allocation from spilling most temporaries to the stack.
    pub fn run_scheduled(
        &mut self,
        roots: &[Id],
        store: impl Fn(usize, TokenStream) -> TokenStream,
    ) {
        for (k, &r) in roots.iter().enumerate() {
            self.need(r);
            let e = self.expr(r, Prec::Top);
            self.stmts.push(store(k, e));
        }
    }

    /// Write the bindings `id`'s expression needs (and `id`'s own when it is bound),
    /// depth first without recursion.
    fn need(&mut self, id: Id) {
        // (node, children visited)
        let mut stack: Vec<(Id, bool)> = vec![(id, false)];
        let mut seen: std::collections::HashSet<Id> = std::collections::HashSet::new();
        while let Some((n, visited)) = stack.pop() {
            if self.names.contains_key(&n) {
                continue;
            }
            if visited {
                if self.bind[n.index()] {
                    self.bind_node(n);
                }
                continue;
            }
            if !seen.insert(n) {
                continue;
            }
            stack.push((n, true));
            for c in self.g.node(n).children().into_iter().rev() {
                if !self.names.contains_key(&c) {
                    stack.push((c, false));
                }
            }
        }
    }

    /// Write the binding of the bound node `id` (its bound children already written).
    fn bind_node(&mut self, id: Id) {
        match self.g.node(id) {
            Node::Sin(a) | Node::Cos(a) => {
                let a = *a;
                let (s, c) = (self.g.lookup(&Node::Sin(a)), self.g.lookup(&Node::Cos(a)));
                let arg = self.expr(a, Prec::Receiver);
                self.ops.trig += 1;
                match (s, c) {
                    (Some(s), Some(c)) if self.bind[s.index()] && self.bind[c.index()] => {
                        let (ns, nc) = (self.fresh(), self.fresh());
                        self.stmts.push(quote!(let (#ns, #nc) = #arg.sin_cos();));
                        self.names.insert(s, quote!(#ns));
                        self.names.insert(c, quote!(#nc));
                    }
                    _ => {
                        let v = if matches!(self.g.node(id), Node::Sin(_)) {
                            quote!(#arg.sin())
                        } else {
                            quote!(#arg.cos())
                        };
                        let n = self.let_bind(v);
                        self.names.insert(id, n);
                    }
                }
            }
            _ => {
                let v = self.expr(id, Prec::Top);
                let n = self.let_bind(v);
                self.names.insert(id, n);
            }
        }
    }

    /// `b` as a name (binding it first if it is compound and has none).
    fn atom(&mut self, b: Id) -> TokenStream {
        if let Some(n) = self.names.get(&b) {
            return n.clone();
        }
        let v = self.expr(b, Prec::Top);
        let n = self.let_bind(v);
        self.names.insert(b, n.clone());
        n
    }

    /// `b^e` by repeated multiplication, each power bound once.
    fn power(&mut self, b: Id, e: i32) -> TokenStream {
        if e == 1 {
            return self.atom(b);
        }
        if let Some(n) = self.powers.get(&(b, e)) {
            return n.clone();
        }
        let v = if e == -1 {
            let a = self.atom(b);
            self.ops.divs += 1;
            quote!(1.0 / #a)
        } else {
            let (x, y) = if e % 2 == 0 {
                (self.power(b, e / 2), self.power(b, e / 2))
            } else {
                let unit = e.signum();
                (self.power(b, e - unit), self.power(b, unit))
            };
            self.ops.muls += 1;
            quote!(#x * #y)
        };
        let n = self.let_bind(v);
        self.powers.insert((b, e), n.clone());
        n
    }

    /// `c · f1 · f2 ⋯` for `c ≥ 0` (c omitted when 1).
    fn product(&mut self, c: Num, factors: &[Id]) -> TokenStream {
        let mut parts: Vec<TokenStream> = Vec::new();
        if !c.is_one() || factors.is_empty() {
            parts.push(literal_in(c.to_f64(), self.float));
        }
        for &f in factors {
            let t = match self.g.node(f) {
                Node::Pow(b, e) if !self.names.contains_key(&f) => self.power(*b, *e),
                _ => self.expr(f, Prec::Product),
            };
            parts.push(t);
        }
        self.ops.muls += parts.len() as u64 - 1;
        let first = &parts[0];
        let rest = &parts[1..];
        quote!(#first #(* #rest)*)
    }

    /// Sign and magnitude of a term: `(negative, tokens of |term|)`.
    fn signed(&mut self, t: Id) -> (bool, TokenStream) {
        if let Some(n) = self.names.get(&t) {
            return (false, n.clone());
        }
        match self.g.node(t) {
            Node::Const(c) => (c.is_negative(), literal_in(c.abs().to_f64(), self.float)),
            Node::Mul(ch) => {
                let ch = ch.clone();
                let (c, f) = match self.g.as_const(ch[0]) {
                    Some(c) => (c, &ch[1..]),
                    None => (Num::ONE, &ch[..]),
                };
                (c.is_negative(), self.product(c.abs(), f))
            }
            _ => (false, self.expr(t, Prec::Product)),
        }
    }

    /// The expression of `id` in context `p`.
    fn expr(&mut self, id: Id, p: Prec) -> TokenStream {
        if let Some(n) = self.names.get(&id) {
            return n.clone();
        }
        let (tokens, compound) = match self.g.node(id).clone() {
            Node::Const(c) => {
                let l = literal_in(c.abs().to_f64(), self.float);
                if c.is_negative() {
                    (quote!(-#l), true)
                } else {
                    (l, false)
                }
            }
            Node::Sym(_) => unreachable!("symbols are named"),
            Node::Add(ch) => {
                let mut terms: Vec<(bool, TokenStream)> =
                    ch.iter().map(|&t| self.signed(t)).collect();
                // lead with a positive term when there is one; in f32, only when it is
                // the second (a + b = b + a): otherwise the terms stay in the graph's
                // order, the order `Evaluator::eval_f32` sums them in, so that the f32
                // selection measures the rounding of the code as written
                if let Some(k) = terms.iter().position(|t| !t.0) {
                    if self.float == Float::F64 || k == 1 {
                        terms.swap(0, k);
                    }
                }
                self.ops.adds += terms.len() as u64 - 1;
                let mut out = if terms[0].0 {
                    let t = &terms[0].1;
                    quote!(-#t)
                } else {
                    terms[0].1.clone()
                };
                for (neg, t) in &terms[1..] {
                    out = if *neg {
                        quote!(#out - #t)
                    } else {
                        quote!(#out + #t)
                    };
                }
                (out, true)
            }
            Node::Mul(_) => {
                let (neg, t) = self.signed(id);
                (if neg { quote!(-#t) } else { t }, true)
            }
            Node::Pow(b, e) => (self.power(b, e), false),
            Node::Sin(_) | Node::Cos(_) => {
                let n = self.atom(id);
                (n, false)
            }
        };
        // products never contain products (flattened), so any compound factor or
        // receiver is wrapped
        if compound && p != Prec::Top {
            quote!((#tokens))
        } else {
            tokens
        }
    }
}

/// Format Rust source with the toolchain's `rustfmt` (edition 2021); the input is
/// returned unchanged if rustfmt is missing, fails, or takes longer than a minute.
pub fn format(code: &str) -> String {
    format_with_timeout(code, std::time::Duration::from_secs(60))
}

/// [`format()`] with a time limit for rustfmt.
pub fn format_with_timeout(code: &str, limit: std::time::Duration) -> String {
    use std::io::{Read, Write};
    use std::process::{Command, Stdio};
    let child = Command::new("rustfmt")
        .args(["--edition", "2021", "--emit", "stdout", "--quiet"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn();
    let Ok(mut child) = child else {
        return code.to_string();
    };
    // read stdout on a thread, so that a full pipe never blocks rustfmt
    let reader = child.stdout.take().map(|mut out| {
        std::thread::spawn(move || {
            let mut buf = Vec::new();
            out.read_to_end(&mut buf).map(|_| buf)
        })
    });
    let written = child
        .stdin
        .take()
        .is_some_and(|mut stdin| stdin.write_all(code.as_bytes()).is_ok());
    let start = std::time::Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(st)) => break Some(st),
            Ok(None) if start.elapsed() < limit => {
                std::thread::sleep(std::time::Duration::from_millis(20))
            }
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                break None;
            }
        }
    };
    let output = reader.and_then(|r| r.join().ok()).and_then(Result::ok);
    match (written, status, output) {
        (true, Some(st), Some(out)) if st.success() && !out.is_empty() => {
            String::from_utf8(out).unwrap_or_else(|_| code.to_string())
        }
        _ => code.to_string(),
    }
}

/// The lints a generated function is exempt from: generated names are not snake case
/// everywhere, constants carry every digit.
pub(crate) fn generated_attrs() -> TokenStream {
    quote! {
        #[allow(
            unused_variables,
            clippy::all,
            clippy::pedantic,
            clippy::excessive_precision,
            clippy::unreadable_literal
        )]
    }
}

/// A generated function `pub fn name(params) { body }` (documented by `doc`) written
/// three times: the body as an `#[inline(always)]` function, a copy compiled with AVX2
/// enabled, and `name`, which calls the AVX2 copy when the CPU has it
/// (`is_x86_feature_detected!`, a cached flag) and the portable one otherwise. Straight-line code of thousands of operations
/// is where the three-operand VEX encoding counts most: SSE2's two-operand `mulsd`
/// needs a register copy before most operations. The two copies compute the same
/// IEEE-754 operations in the same order (Rust never contracts `a * b + c` into a fused
/// multiply-add on its own), so they agree bit for bit; `name_portable` is public for the
/// test that checks it.
pub(crate) fn multiversioned(
    name: &Ident,
    doc: &str,
    params: TokenStream,
    args: TokenStream,
    body: TokenStream,
) -> TokenStream {
    let portable = Ident::new(&format!("{name}_portable"), Span::call_site());
    let avx2 = Ident::new(&format!("{name}_avx2"), Span::call_site());
    let inner = Ident::new(&format!("{name}_body"), Span::call_site());
    let doc_portable = format!(
        " [`{name}`] compiled for the baseline target only (what [`{name}`] runs on a CPU \
         without AVX2); for the test that both agree bit for bit."
    );
    let attrs = generated_attrs();
    quote! {
        #[doc = #doc]
        #attrs
        pub fn #name(#params) {
            #[cfg(all(target_arch = "x86_64", feature = "std"))]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2, checked just above.
                    unsafe { #avx2(#args) };
                    return;
                }
            }
            #inner(#args);
        }

        #[doc = #doc_portable]
        #[doc(hidden)]
        pub fn #portable(#params) {
            #inner(#args);
        }

        #[cfg(all(target_arch = "x86_64", feature = "std"))]
        #[target_feature(enable = "avx2")]
        fn #avx2(#params) {
            #inner(#args);
        }

        #attrs
        #[inline(always)]
        fn #inner(#params) {
            #body
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two outputs sharing `s = sin(x)` and `c = cos(x)`, each with a binding of its own.
    fn two_outputs(g: &mut Graph) -> (Vec<Id>, Vec<(Id, Ident)>) {
        let x = g.symbol("x");
        let y = g.symbol("y");
        let (s, c) = (g.sin(x), g.cos(x));
        let sc = g.mul2(s, c);
        let a = g.add2(sc, y); // used twice by the first output: bound
        let first = g.mul2(a, a);
        let b = g.add2(sc, x); // used twice by the second output: bound
        let second = g.mul(&[b, b, y]);
        let symbols = vec![
            (x, Ident::new("x", Span::call_site())),
            (y, Ident::new("y", Span::call_site())),
        ];
        (vec![first, second], symbols)
    }

    #[test]
    fn f32_literals_are_the_shortest_that_read_back_as_the_f32_value() {
        let f = |v: f64| literal_in(v, Float::F32).to_string();
        assert_eq!(f(1.0 / 3.0), "0.33333334");
        assert_eq!(f(0.5), "0.5");
        assert_eq!(f(2.0), "2.0");
        assert_eq!(f(1.0 / 120.0 / 5040.0), "1.6534392e-6");
        assert_eq!(f(0.0), "0.0");
        for v in [1.0 / 3.0, 1e-30, 123456.789, 7.0 / 11.0] {
            let back: f32 = f(v).parse().unwrap();
            assert_eq!(back, v as f32, "{v}");
        }
        // the f64 form is unchanged
        assert_eq!(literal(1.0 / 3.0).to_string(), "0.3333333333333333");
    }

    #[test]
    fn scheduled_emission_writes_the_same_bindings_each_just_before_its_first_use() {
        let mut g = Graph::new();
        let (roots, symbols) = two_outputs(&mut g);
        let mut plain = Emitter::new(&g, &roots, &symbols, "c");
        let exprs = plain.run(&roots);
        let mut sched = Emitter::new(&g, &roots, &symbols, "c");
        sched.run_scheduled(&roots, |k, e| {
            let k = proc_macro2::Literal::usize_unsuffixed(k);
            quote!(out[#k] = #e;)
        });
        // the same operations, every binding once
        assert_eq!(plain.ops, sched.ops);
        assert_eq!(plain.stmts.len() + exprs.len(), sched.stmts.len());
        let text: Vec<String> = sched.stmts.iter().map(|s| s.to_string()).collect();
        let pos = |needle: &str| text.iter().position(|s| s.contains(needle));
        let store0 = pos("out [0]").expect("first output stored");
        let store1 = pos("out [1]").expect("second output stored");
        // the sin_cos pair comes first; the second output's own binding (x + s·c) after
        // the first output's store
        assert!(text[0].contains("sin_cos"), "{text:?}");
        let own_second = text
            .iter()
            .position(|s| s.starts_with("let") && (s.contains("+ x") || s.contains("x +")))
            .expect("binding of s·c + x");
        assert!(store0 < own_second && own_second < store1, "{text:?}");
    }
}

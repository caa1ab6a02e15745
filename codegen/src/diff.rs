//! Symbolic differentiation on the DAG.
//!
//! `∂/∂v` of a symbol `s ≠ v` is the partial registered with [`Graph::set_partial`]
//! (zero if none): this is how `W = |d|` is a symbol of its own with `∂W/∂d_i = d_i/W`,
//! so derivatives with respect to `d` of expressions in `W` are exact. Results are
//! memoized per (node, variable), so shared subexpressions are differentiated once.

use crate::graph::{Graph, Id, Node};

impl Graph {
    /// `∂e/∂v` for a symbol `v`.
    pub fn diff(&mut self, e: Id, v: Id) -> Id {
        if let Some(&d) = self.diff_memo.get(&(e, v)) {
            return d;
        }
        let out = match self.node(e).clone() {
            Node::Const(_) => self.zero(),
            Node::Sym(_) => {
                if e == v {
                    self.one()
                } else if let Some(&p) = self.partials.get(&(e, v)) {
                    p
                } else {
                    self.zero()
                }
            }
            Node::Add(ch) => {
                let d: Vec<Id> = ch.iter().map(|&c| self.diff(c, v)).collect();
                self.add(&d)
            }
            Node::Mul(ch) => {
                let mut terms = Vec::with_capacity(ch.len());
                for i in 0..ch.len() {
                    let di = self.diff(ch[i], v);
                    if self.as_const(di).is_some_and(|c| c.is_zero()) {
                        continue;
                    }
                    let mut f: Vec<Id> = ch.to_vec();
                    f[i] = di;
                    terms.push(self.mul(&f));
                }
                self.add(&terms)
            }
            Node::Pow(b, k) => {
                let db = self.diff(b, v);
                let kk = self.int(k as i64);
                let p = self.pow(b, k - 1);
                self.mul(&[kk, p, db])
            }
            Node::Sin(a) => {
                let da = self.diff(a, v);
                let c = self.cos(a);
                self.mul2(c, da)
            }
            Node::Cos(a) => {
                let da = self.diff(a, v);
                let s = self.sin(a);
                let ms = self.neg(s);
                self.mul2(ms, da)
            }
        };
        self.diff_memo.insert((e, v), out);
        out
    }
}

#[cfg(test)]
mod tests {
    use crate::graph::{Graph, Id};
    use crate::helix::HelixSymbols;

    /// Central difference of order 4 of `e` in `d_i`, with W recomputed as |d|.
    fn fd(g: &Graph, h: &HelixSymbols, e: Id, d: [f64; 3], u: f64, i: usize) -> f64 {
        let f = |dd: [f64; 3]| g.eval(e, &h.bindings(dd, 0.0, u));
        let s = 1e-3 * (d[0].abs() + d[1].abs() + d[2].abs());
        let at = |k: f64| {
            let mut dd = d;
            dd[i] += k * s;
            f(dd)
        };
        (-at(2.0) + 8.0 * at(1.0) - 8.0 * at(-1.0) + at(-2.0)) / (12.0 * s)
    }

    #[test]
    fn derivatives_of_the_helix_match_finite_differences() {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let p = crate::helix::position(&mut g, &h, h.u);
        let e = crate::helix::frame(&mut g, &h, h.u);
        let d = [3.0, -7.0, 11.0];
        let u = 0.2;
        let mut exprs: Vec<Id> = p.to_vec();
        exprs.extend(e.iter().flatten());
        // a product and a quotient, to exercise the product and power rules
        let q = g.div(p[1], p[0]);
        exprs.push(q);
        for &x in &exprs {
            for i in 0..3 {
                let dx = g.diff(x, h.d[i]);
                let exact = g.eval(dx, &h.bindings(d, 0.0, u));
                let approx = fd(&g, &h, x, d, u, i);
                // step s ≈ 0.02 relative: O(s^4) ≈ 2e-7 truncation on O(1) values
                assert!(
                    (exact - approx).abs() < 1e-7 * exact.abs().max(1e-2),
                    "{exact} vs {approx}"
                );
                // second derivatives against differences of the first
                for j in 0..3 {
                    let dxy = g.diff(dx, h.d[j]);
                    let exact2 = g.eval(dxy, &h.bindings(d, 0.0, u));
                    let approx2 = fd(&g, &h, dx, d, u, j);
                    assert!(
                        (exact2 - approx2).abs() < 1e-6 * exact2.abs().max(1e-2),
                        "{exact2} vs {approx2}"
                    );
                }
            }
        }
    }

    #[test]
    fn power_and_trig_rules() {
        let mut g = Graph::new();
        let x = g.symbol("x");
        let x3 = g.pow(x, -3);
        let s = g.sin(x3);
        let d = g.diff(s, x);
        let v = g.eval(d, &[(x, 0.7)]);
        let exact = (0.7f64).powi(-3).cos() * -3.0 * 0.7f64.powi(-4);
        assert!((v - exact).abs() < 1e-13 * exact.abs());
    }
}

//! The M-related element integrals, both branches, against Gauss–Legendre quadrature of
//! an independent evaluation of the integrand: p(u) and ∂p/∂d by forward-mode jets
//! through the stable series of b(z) = (1 − cos x)/x², c(z) = (x − sin x)/x³
//! (z = x², as in the runtime's `helix_functions`), not through the generator.

#![allow(clippy::needless_range_loop)] // index loops read like the formulas

use std::sync::OnceLock;
use superhelix_codegen::{
    generate_function, helix, GenerateOptions, GeneratedCode, Graph, HelixSymbols,
};

// ---------------------------------------------------------------- reference integrand

/// Value, gradient and Hessian in the three components of d.
#[derive(Clone, Copy, Default, Debug)]
struct Jet {
    v: f64,
    g: [f64; 3],
    h: [[f64; 3]; 3],
}

impl Jet {
    fn c(v: f64) -> Jet {
        Jet {
            v,
            ..Default::default()
        }
    }
    fn var(v: f64, i: usize) -> Jet {
        let mut j = Jet::c(v);
        j.g[i] = 1.0;
        j
    }
    fn add(self, o: Jet) -> Jet {
        let mut r = self;
        r.v += o.v;
        for i in 0..3 {
            r.g[i] += o.g[i];
            for k in 0..3 {
                r.h[i][k] += o.h[i][k];
            }
        }
        r
    }
    fn scale(self, s: f64) -> Jet {
        let mut r = self;
        r.v *= s;
        for i in 0..3 {
            r.g[i] *= s;
            for k in 0..3 {
                r.h[i][k] *= s;
            }
        }
        r
    }
    fn mul(self, o: Jet) -> Jet {
        let mut r = Jet::c(self.v * o.v);
        for i in 0..3 {
            r.g[i] = self.v * o.g[i] + self.g[i] * o.v;
            for k in 0..3 {
                r.h[i][k] = self.v * o.h[i][k]
                    + self.h[i][k] * o.v
                    + self.g[i] * o.g[k]
                    + self.g[k] * o.g[i];
            }
        }
        r
    }
    /// f(self) given f, f', f'' at self.v.
    fn compose(self, f: [f64; 3]) -> Jet {
        let mut r = Jet::c(f[0]);
        for i in 0..3 {
            r.g[i] = f[1] * self.g[i];
            for k in 0..3 {
                r.h[i][k] = f[2] * self.g[i] * self.g[k] + f[1] * self.h[i][k];
            }
        }
        r
    }
}

/// Σ (−z)^n / (2n + k)! and two z-derivatives (k = 2: b, k = 3: c), for z < 16.
fn series(z: f64, k: usize) -> [f64; 3] {
    let mut coef = 1.0;
    for m in 1..=k {
        coef /= m as f64;
    }
    let (mut f, mut d1, mut d2) = (0.0, 0.0, 0.0);
    let (mut zn, mut zn1, mut zn2) = (1.0, 0.0, 0.0);
    for n in 0..40 {
        let nf = n as f64;
        f += coef * zn;
        d1 += coef * nf * zn1;
        d2 += coef * nf * (nf - 1.0) * zn2;
        zn2 = zn1;
        zn1 = zn;
        zn *= z;
        let m = (2 * n + k) as f64;
        coef = -coef / ((m + 1.0) * (m + 2.0));
    }
    [f, d1, d2]
}

/// b and c with two z-derivatives (series below z = 16, closed forms above).
fn bc(z: f64) -> ([f64; 3], [f64; 3]) {
    if z < 16.0 {
        return (series(z, 2), series(z, 3));
    }
    let x = z.sqrt();
    let (s, co) = x.sin_cos();
    let a = s / x;
    let b = (1.0 - co) / z;
    let c = (x - s) / (z * x);
    let a1 = 0.5 * (c - b);
    let b1 = (a - 2.0 * b) / (2.0 * z);
    let c1 = (b - 3.0 * c) / (2.0 * z);
    let b2 = (a1 - 4.0 * b1) / (2.0 * z);
    let c2 = (b1 - 5.0 * c1) / (2.0 * z);
    ([b, b1, b2], [c, c1, c2])
}

/// p(u) = u e0 + u² b (d × e0) + u³ c (d (d·e0) − |d|² e0), each component a jet in d.
fn p_jet(d: [f64; 3], u: f64) -> [Jet; 3] {
    let dj = [Jet::var(d[0], 0), Jet::var(d[1], 1), Jet::var(d[2], 2)];
    let dd = dj[0].mul(dj[0]).add(dj[1].mul(dj[1])).add(dj[2].mul(dj[2]));
    let z = dd.scale(u * u);
    let (fb, fc) = bc(z.v);
    let b = z.compose(fb).scale(u * u);
    let c = z.compose(fc).scale(u * u * u);
    let dxe = [Jet::c(0.0), dj[2], dj[1].scale(-1.0)];
    let ddxe = [
        dj[0].mul(dj[0]).add(dd.scale(-1.0)),
        dj[1].mul(dj[0]),
        dj[2].mul(dj[0]),
    ];
    let mut out = [Jet::c(0.0); 3];
    for m in 0..3 {
        out[m] = b.mul(dxe[m]).add(c.mul(ddxe[m]));
    }
    out[0] = out[0].add(Jet::c(u));
    out
}

/// The integrands of `helix::m_related_integrands`, in its order, at abscissa u.
fn m_related_values(d: [f64; 3], u: f64) -> Vec<f64> {
    let p = p_jet(d, u);
    let dp = |i: usize, a: usize| p[a].g[i];
    let mut v = Vec::new();
    for pa in &p {
        v.push(pa.v);
    }
    for a in 0..3 {
        for b in a..3 {
            v.push(p[a].v * p[b].v);
        }
    }
    for i in 0..3 {
        for a in 0..3 {
            v.push(dp(i, a));
        }
    }
    for a in 0..3 {
        for i in 0..3 {
            for b in 0..3 {
                v.push(p[a].v * dp(i, b));
            }
        }
    }
    for i in 0..3 {
        for j in i..3 {
            v.push((0..3).map(|a| dp(i, a) * dp(j, a)).sum());
        }
    }
    v
}

// ---------------------------------------------------------------- quadrature

/// Gauss–Legendre nodes and weights on [−1, 1]: the runtime's rule (tested there).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let r = superhelix_runtime::model::quadrature::gauss_legendre(n);
    r.nodes()
        .iter()
        .copied()
        .zip(r.weights().iter().copied())
        .collect()
}

/// ∫_0^l f with `panels` panels of an n-point rule.
fn quadrature(f: impl Fn(f64) -> Vec<f64>, l: f64, n: usize, panels: usize) -> Vec<f64> {
    let rule = gauss_legendre(n);
    let hw = l / panels as f64;
    let mut acc: Vec<f64> = Vec::new();
    for p in 0..panels {
        let a = p as f64 * hw;
        for &(x, w) in &rule {
            let v = f(a + 0.5 * hw * (x + 1.0));
            if acc.is_empty() {
                acc = vec![0.0; v.len()];
            }
            for (s, vi) in acc.iter_mut().zip(v) {
                *s += 0.5 * hw * w * vi;
            }
        }
    }
    acc
}

// ---------------------------------------------------------------- generated once

struct Setup {
    g: Graph,
    h: HelixSymbols,
    code: GeneratedCode,
}

fn setup() -> &'static Setup {
    static S: OnceLock<Setup> = OnceLock::new();
    S.get_or_init(|| {
        let mut g = Graph::new();
        let h = HelixSymbols::new(&mut g);
        let list = helix::m_related_integrands(&mut g, &h);
        let code = generate_function(&mut g, &h, "m_related", &list, &GenerateOptions::default())
            .expect("generation of the M-related list");
        Setup { g, h, code }
    })
}

fn unit(seed: u64) -> [f64; 3] {
    // a fixed, well spread set of directions
    let t = 0.7 + 1.3 * seed as f64;
    let ph = 2.1 * seed as f64 + 0.4;
    [t.cos() * ph.sin(), t.sin() * ph.sin(), ph.cos()]
}

/// The size each output is measured against: the norm of the vector or matrix it is a
/// component of, through Cauchy–Schwarz (|∫f g| ≤ (∫f² ∫g²)^½). Off-diagonal entries
/// such as ∫∂_1p·∂_2p are O(x²) smaller than the diagonal ones at small x = W l, and
/// the reference integrand itself only has them to about ε/x relative (cancellation
/// in the dot product), so they are compared at the scale of their matrix.
fn natural_scales(names: &[String], v: &[f64]) -> Vec<f64> {
    let get = |n: String| v[names.iter().position(|x| *x == n).expect("name")];
    names
        .iter()
        .map(|n| {
            let ix: Vec<usize> = n
                .bytes()
                .filter(u8::is_ascii_digit)
                .map(|b| (b - b'0') as usize)
                .collect();
            if n.starts_with("p_") {
                (0..3)
                    .map(|a| get(format!("p_{a}")).powi(2))
                    .sum::<f64>()
                    .sqrt()
            } else if n.starts_with("ppt_") {
                let (a, b) = (ix[0], ix[1]);
                (get(format!("ppt_{a}{a}")) * get(format!("ppt_{b}{b}"))).sqrt()
            } else if n.starts_with("dp_") {
                (0..3)
                    .map(|a| get(format!("dp_{}_{a}", ix[0])).powi(2))
                    .sum::<f64>()
                    .sqrt()
            } else if n.starts_with("pdp_") {
                let (a, i) = (ix[0], ix[1]);
                (get(format!("ppt_{a}{a}")) * get(format!("dpdp_{i}{i}"))).sqrt()
            } else {
                let (i, j) = (ix[0], ix[1]);
                (get(format!("dpdp_{i}{i}")) * get(format!("dpdp_{j}{j}"))).sqrt()
            }
        })
        .collect()
}

#[test]
fn m_related_integrals_match_gauss_legendre() {
    let s = setup();
    let l = 0.7;
    let rule_n = 64;
    for &x in &[1e-12, 1e-8, 1e-4, 1e-2, 0.3, 1.0, 30.0, 100.0] {
        let ids = if x < s.code.switch {
            &s.code.series
        } else {
            &s.code.closed
        };
        let ev = s.g.evaluator(ids);
        let mut worst = 0.0f64;
        // oscillation frequency up to 2W: keep ≲ 1 period per panel
        let panels = if x > 10.0 {
            (x / 2.0).ceil() as usize
        } else {
            1
        };
        for k in 0..3 {
            let e = unit(k);
            let d = [e[0] * x / l, e[1] * x / l, e[2] * x / l];
            let exact = quadrature(|u| m_related_values(d, u), l, rule_n, panels);
            let got = ev.eval(&s.g, &s.h.bindings(d, l, 0.0));
            let scale = natural_scales(&s.code.outputs, &exact);
            for (j, (a, b)) in got.iter().zip(&exact).enumerate() {
                let rel = (a - b).abs() / scale[j];
                worst = worst.max(rel);
                assert!(
                    rel <= 1e-12,
                    "x = {x}, direction {k}, output {} = {a:e}, quadrature {b:e}, relative {rel:e}",
                    s.code.outputs[j]
                );
            }
        }
        eprintln!("W l = {x:e}: worst difference to quadrature {worst:.1e}");
    }
}

#[test]
fn branches_agree_at_the_switch() {
    let s = setup();
    assert!(
        s.code.agreement <= 1e-14,
        "agreement {:e}",
        s.code.agreement
    );
    assert!(
        s.code.truncation <= 1e-15,
        "truncation {:e}",
        s.code.truncation
    );
    // independently of the generator's own samples: other directions, other lengths
    let x = s.code.switch;
    let ec = s.g.evaluator(&s.code.closed);
    let es = s.g.evaluator(&s.code.series);
    let pts: Vec<([f64; 3], f64)> = (10..40)
        .map(|k| {
            let e = unit(k);
            let l = [0.003, 0.05, 1.0, 7.0][k as usize % 4];
            ([e[0] * x / l, e[1] * x / l, e[2] * x / l], l)
        })
        .collect();
    let c: Vec<Vec<f64>> = pts
        .iter()
        .map(|(d, l)| ec.eval(&s.g, &s.h.bindings(*d, *l, 0.0)))
        .collect();
    let t: Vec<Vec<f64>> = pts
        .iter()
        .map(|(d, l)| es.eval(&s.g, &s.h.bindings(*d, *l, 0.0)))
        .collect();
    for j in 0..s.code.outputs.len() {
        // relative to the size of output j at this W l (largest over the directions)
        let scale = t.iter().map(|v| v[j].abs()).fold(0.0, f64::max);
        for (cv, tv) in c.iter().zip(&t) {
            let rel = (cv[j] - tv[j]).abs() / scale;
            assert!(rel <= 1e-14, "output {}: {rel:e}", s.code.outputs[j]);
        }
    }
}

#[test]
fn cse_reduces_the_operation_count() {
    let s = setup();
    assert!(
        s.code.ops_after.total() * 10 < s.code.ops_before.total() * 6,
        "before {} after {}",
        s.code.ops_before,
        s.code.ops_after
    );
    assert!(s
        .code
        .code
        .starts_with("// @generated by superhelix-codegen"));
}

#[test]
fn emitted_code_parses_as_rust() {
    let s = setup();
    let file: syn::File = syn::parse_str(&s.code.code).expect("raw token output parses");
    let has_fn = file
        .items
        .iter()
        .any(|i| matches!(i, syn::Item::Fn(f) if f.sig.ident == "m_related"));
    assert!(has_fn);
    // the formatted copy (rustfmt, or the raw text without it) parses too
    let formatted = superhelix_codegen::format(&s.code.code);
    syn::parse_str::<syn::File>(&formatted).expect("formatted output parses");
}

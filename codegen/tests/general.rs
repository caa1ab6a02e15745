//! Integrands beyond the M-related list: the engine takes any list of products of the
//! element's closed forms and their d-derivatives. Checked against Gauss–Legendre
//! quadrature of the integrand DAG itself, at W l where that evaluation is accurate.

#![allow(clippy::needless_range_loop)] // index loops read like the formulas

use superhelix_codegen::{generate_function, helix, GenerateOptions, Graph, HelixSymbols, Id};

/// Gauss–Legendre nodes and weights on [−1, 1]: the runtime's rule (tested there).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let r = superhelix_runtime::model::quadrature::gauss_legendre(n);
    r.nodes()
        .iter()
        .copied()
        .zip(r.weights().iter().copied())
        .collect()
}

/// ∫ E D Eᵀ du (D = diag(1, 2, 3)), ∫ ∂²p/∂d_i∂d_j du, ∫ w_1 · w_2 du, ∫ p · ∂²p/∂d0² du.
fn list(g: &mut Graph, h: &HelixSymbols) -> Vec<(String, Id)> {
    let e = helix::frame(g, h, h.u);
    let p = helix::position(g, h, h.u);
    let mut out = Vec::new();
    for r in 0..3 {
        for c in r..3 {
            let t: Vec<Id> = (0..3)
                .map(|k| {
                    let dk = g.int(k as i64 + 1);
                    g.mul(&[e[r][k], dk, e[c][k]])
                })
                .collect();
            out.push((format!("ede_{r}{c}"), g.add(&t)));
        }
    }
    for i in 0..3 {
        for j in i..3 {
            for a in 0..3 {
                let d1 = g.diff(p[a], h.d[i]);
                out.push((format!("d2p_{i}{j}_{a}"), g.diff(d1, h.d[j])));
            }
        }
    }
    let w1 = helix::rotation_column(g, h, h.u, 1);
    let w2 = helix::rotation_column(g, h, h.u, 2);
    let t: Vec<Id> = (0..3).map(|a| g.mul2(w1[a], w2[a])).collect();
    out.push(("w1w2".into(), g.add(&t)));
    let t: Vec<Id> = (0..3)
        .map(|a| {
            let d1 = g.diff(p[a], h.d[0]);
            let d2 = g.diff(d1, h.d[0]);
            g.mul2(p[a], d2)
        })
        .collect();
    out.push(("p_d2p_00".into(), g.add(&t)));
    out
}

#[test]
fn frame_products_and_second_derivatives() {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let list = list(&mut g, &h);
    let code = generate_function(&mut g, &h, "general", &list, &GenerateOptions::default())
        .expect("generation");
    assert!(code.agreement <= 1e-14 && code.truncation <= 1e-15);
    let integrands: Vec<Id> = list.iter().map(|x| x.1).collect();
    let ei = g.evaluator(&integrands);
    eprintln!(
        "general: {} outputs, switch {}, degree {}, agreement {:.1e}, ops {} -> {}",
        list.len(),
        code.switch,
        code.series_order,
        code.agreement,
        code.ops_before.total(),
        code.ops_after.total()
    );
    let rule = gauss_legendre(80);
    let mut worst = 0.0f64;
    let l = 0.4;
    // the integrand DAG is the plain closed form: accurate to ~1e-13 for x ≳ 1
    for &x in &[1.0, 4.0, 20.0] {
        let ids = if x < code.switch {
            &code.series
        } else {
            &code.closed
        };
        let ev = g.evaluator(ids);
        for k in 0..3 {
            let t = 0.3 + 1.7 * k as f64;
            let e = [t.cos() * 0.6, t.sin() * 0.6, 0.8];
            let d = [e[0] * x / l, e[1] * x / l, e[2] * x / l];
            let panels = (x / 2.0).ceil() as usize;
            let hw = l / panels as f64;
            let mut exact = vec![0.0; integrands.len()];
            for pnl in 0..panels {
                for &(r, w) in &rule {
                    let u = (pnl as f64 + 0.5 * (r + 1.0)) * hw;
                    for (s, v) in exact.iter_mut().zip(ei.eval(&g, &h.bindings(d, l, u))) {
                        *s += 0.5 * hw * w * v;
                    }
                }
            }
            let got = ev.eval(&g, &h.bindings(d, l, 0.0));
            let scale = exact.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (j, (a, b)) in got.iter().zip(&exact).enumerate() {
                worst = worst.max((a - b).abs() / scale.max(b.abs()));
                // relative to the largest output: the reference integrand is the plain
                // closed form, which loses digits near u = 0 (measured: ~2e-15)
                assert!(
                    (a - b).abs() <= 1e-12 * scale.max(b.abs()),
                    "x = {x}, {}: {a:e} vs {b:e}",
                    list[j].0
                );
            }
        }
    }
    eprintln!("general: worst relative difference to quadrature {worst:.1e}");
}

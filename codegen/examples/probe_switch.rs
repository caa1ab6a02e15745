use superhelix_codegen::{helix, Graph, HelixSymbols};
fn main() {
    let mut g = Graph::new();
    let h = HelixSymbols::new(&mut g);
    let list = helix::m_related_integrands(&mut g, &h);
    let mut cl = vec![];
    let mut se = vec![];
    for (_, e) in &list {
        let r = g.integrate_element(&h, *e, 40).unwrap();
        cl.push(r.closed);
        se.push(r.series);
    }
    let ec = g.evaluator(&cl);
    let es = g.evaluator(&se);
    for &x in &[0.3, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0] {
        let mut worst = vec![0.0f64; list.len()];
        let mut scale = vec![0.0f64; list.len()];
        let mut vals = vec![];
        for k in 0..8 {
            let t = 0.7 + 1.3 * k as f64;
            let ph = 2.1 * k as f64 + 0.4;
            let e = [t.cos() * ph.sin(), t.sin() * ph.sin(), ph.cos()];
            let d = [e[0] * x, e[1] * x, e[2] * x];
            let c = ec.eval(&g, &h.bindings(d, 1.0, 0.0));
            let s = es.eval(&g, &h.bindings(d, 1.0, 0.0));
            for j in 0..list.len() {
                scale[j] = scale[j].max(s[j].abs());
            }
            vals.push((c, s));
        }
        for (c, s) in &vals {
            for j in 0..list.len() {
                worst[j] = worst[j].max((c[j] - s[j]).abs() / scale[j]);
            }
        }
        let mut idx: Vec<usize> = (0..list.len()).collect();
        idx.sort_by(|a, b| worst[*b].total_cmp(&worst[*a]));
        print!("x={x}: ");
        for &j in idx.iter().take(5) {
            print!("{}={:.1e} ", list[j].0, worst[j]);
        }
        println!();
    }
}

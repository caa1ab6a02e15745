//! Error and time of the FMM against the direct sum on a sample of targets (how the
//! table `ERROR_BY_ORDER` was measured: `-- 1000 P 0.5 64` for P = 1 … 20).
//! `cargo run --release -p superhelix-fmm --example accuracy -- FIBRES ORDER THETA LEAF`
#![allow(clippy::needless_range_loop)] // coordinates indexed by axis read as the formulas
use std::time::Instant;
use superhelix_fmm::samples::curly_fibres;
use superhelix_fmm::{direct_at, Fmm, FmmOptions, Softening};

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let fibres: usize = a
        .get(1)
        .map_or(2000, |v| v.parse().expect("FIBRES: an integer"));
    let order: usize = a
        .get(2)
        .map_or(10, |v| v.parse().expect("ORDER: an integer"));
    let theta: f64 = a
        .get(3)
        .map_or(0.5, |v| v.parse().expect("THETA: a number"));
    let leaf: usize = a
        .get(4)
        .map_or(64, |v| v.parse().expect("LEAF: an integer"));
    let (pts, q) = curly_fibres(fibres, 100, 7);
    let n = pts.len();
    let sample: Vec<usize> = (0..2000).map(|k| (k * 7919) % n).collect();
    let (phi0, e0) = direct_at(&pts, &q, &sample, Softening::NONE);
    let mut fmm = Fmm::new(FmmOptions {
        order,
        theta,
        leaf_size: leaf,
        softening: Softening::NONE,
    })
    .expect("options");
    let t = Instant::now();
    let (out, stats) = fmm.evaluate(&pts, &q).expect("evaluate");
    let secs = t.elapsed().as_secs_f64();
    let (mut num, mut den, mut worst, mut angle, mut pn, mut pd) =
        (0.0, 0.0, 0.0f64, 0.0, 0.0, 0.0);
    for (k, &i) in sample.iter().enumerate() {
        let e = out.field[i];
        let d = [e[0] - e0[k][0], e[1] - e0[k][1], e[2] - e0[k][2]];
        let dn = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let en = (e0[k][0].powi(2) + e0[k][1].powi(2) + e0[k][2].powi(2)).sqrt();
        num += dn * dn;
        den += en * en;
        worst = worst.max(dn / en);
        let dot = (e[0] * e0[k][0] + e[1] * e0[k][1] + e[2] * e0[k][2])
            / (en * (e[0].powi(2) + e[1].powi(2) + e[2].powi(2)).sqrt());
        angle += dot.clamp(-1.0, 1.0).acos();
        pn += (out.potential[i] - phi0[k]).powi(2);
        pd += phi0[k].powi(2);
    }
    println!(
        "n={n} p={order} theta={theta} leaf={leaf}: {secs:.3} s  field rel l2 {:.2e} worst {:.2e} mean angle {:.2e} rad  potential rel l2 {:.2e}",
        (num / den).sqrt(),
        worst,
        angle / sample.len() as f64,
        (pn / pd).sqrt()
    );
    println!("{stats:?}");
}

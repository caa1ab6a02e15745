//! Each translation operator alone against the direct sum it stands for.

#![allow(clippy::needless_range_loop)] // coordinates indexed by axis read as the formulas

use num_complex::Complex64 as C;
use superhelix_fmm::harmonics::tri_len;
use superhelix_fmm::operators::{l2l, l2p, m2l, m2m, m2p, p2m, Scratch};
use superhelix_fmm::samples::uniform_cube;

/// `n` charges in a ball of radius `r` around `c`.
fn cluster(c: [f64; 3], r: f64, n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let (pts, q) = uniform_cube(n, seed);
    let pts = pts
        .iter()
        .map(|p| {
            let d = [2.0 * p[0] - 1.0, 2.0 * p[1] - 1.0, 2.0 * p[2] - 1.0];
            let s = r / 3f64.sqrt();
            [c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2]]
        })
        .collect();
    (pts, q)
}

fn direct(x: [f64; 3], pts: &[[f64; 3]], q: &[f64]) -> (f64, [f64; 3]) {
    let mut phi = 0.0;
    let mut e = [0.0; 3];
    for (p, &qi) in pts.iter().zip(q) {
        let d = [x[0] - p[0], x[1] - p[1], x[2] - p[2]];
        let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        phi += qi / r;
        for a in 0..3 {
            e[a] += qi * d[a] / (r * r * r);
        }
    }
    (phi, e)
}

fn zeros(p: usize) -> Vec<C> {
    vec![C::new(0.0, 0.0); tri_len(p)]
}

/// P2M then M2P: the truncation error of eq. 3 is at most Q/(d − ρ) (ρ/d)^{p+1}
/// (ρ the cluster radius, d the distance, Q = Σ|q|).
#[test]
fn p2m_expansion_converges_at_its_bound() {
    let c = [0.3, -0.2, 0.1];
    let (pts, q) = cluster(c, 0.5, 50, 1);
    let qabs: f64 = q.iter().map(|v| v.abs()).sum();
    for p in [2, 5, 10, 16] {
        let mut s = Scratch::new(p);
        let mut m = zeros(p);
        p2m(c, &pts, &q, &mut m, &mut s);
        for x in [[3.0, 0.5, -0.4], [-1.0, 2.5, 1.0], [0.3, -0.2, 2.1]] {
            let d = ((x[0] - c[0]).powi(2) + (x[1] - c[1]).powi(2) + (x[2] - c[2]).powi(2)).sqrt();
            let bound = qabs / (d - 0.5) * (0.5 / d).powi(p as i32 + 1);
            let err = (m2p(c, &m, x, &mut s) - direct(x, &pts, &q).0).abs();
            assert!(
                err <= bound,
                "p = {p}: error {err:e} above the bound {bound:e}"
            );
        }
    }
    // And it does converge: p = 16 at d/ρ ≥ 4 is below 1e-9 of the potential.
    let p = 16;
    let mut s = Scratch::new(p);
    let mut m = zeros(p);
    p2m(c, &pts, &q, &mut m, &mut s);
    let x = [3.0, 0.5, -0.4];
    let exact = direct(x, &pts, &q).0;
    assert!((m2p(c, &m, x, &mut s) - exact).abs() <= 1e-9 * qabs / 3.0);
}

/// M2M is exact at a fixed order: moving the children's expansions to the parent gives
/// the parent's expansion of the same charges to round-off.
#[test]
fn m2m_equals_the_parents_own_expansion() {
    let p = 12;
    let mut s = Scratch::new(p);
    let parent_c = [0.0, 0.0, 0.0];
    let mut total = zeros(p);
    let mut own = zeros(p);
    let mut scale: f64 = 0.0;
    for (k, c) in [[0.2, 0.1, -0.15], [-0.25, 0.2, 0.1], [0.1, -0.3, 0.25]]
        .into_iter()
        .enumerate()
    {
        let (pts, q) = cluster(c, 0.15, 20, 10 + k as u64);
        let mut child = zeros(p);
        p2m(c, &pts, &q, &mut child, &mut s);
        m2m(c, parent_c, &child, &mut total, &mut s);
        p2m(parent_c, &pts, &q, &mut own, &mut s);
    }
    for v in &own {
        scale = scale.max(v.norm());
    }
    let worst = total
        .iter()
        .zip(&own)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        worst <= 1e-13 * scale,
        "M2M differs by {worst:e} (scale {scale:e})"
    );
}

/// M2L then L2P: potential and field at targets near the local centre against the
/// direct sum, within the bound (2ρ/d)^{p+1}-type of two spheres of radius ρ at d.
#[test]
fn m2l_and_l2p_match_the_direct_sum() {
    let cm = [0.0, 0.0, 0.0];
    let cl = [2.5, 1.5, -2.0];
    let (pts, q) = cluster(cm, 0.5, 60, 3);
    let (targets, _) = cluster(cl, 0.5, 10, 4);
    let qabs: f64 = q.iter().map(|v| v.abs()).sum();
    let d = (2.5f64 * 2.5 + 1.5 * 1.5 + 2.0 * 2.0).sqrt();
    let mut last = f64::INFINITY;
    for p in [3, 6, 10, 15] {
        let mut s = Scratch::new(p);
        let mut m = zeros(p);
        p2m(cm, &pts, &q, &mut m, &mut s);
        let mut l = zeros(p);
        m2l(cm, cl, &m, &mut l, &mut s);
        let mut worst: f64 = 0.0;
        for &x in &targets {
            let (phi, grad) = l2p(cl, &l, x, &mut s);
            let (phi0, e0) = direct(x, &pts, &q);
            worst = worst.max((phi - phi0).abs() / (qabs / d));
            for a in 0..3 {
                worst = worst.max((-grad[a] - e0[a]).abs() / (qabs / (d * d)));
            }
        }
        let ratio: f64 = 1.0 / (d - 1.0);
        let bound = 4.0 * (p as f64 + 2.0) * ratio.powi(p as i32 + 1);
        assert!(
            worst <= bound,
            "p = {p}: relative error {worst:e} above {bound:e}"
        );
        assert!(
            worst < last,
            "p = {p}: no improvement ({worst:e} after {last:e})"
        );
        last = worst;
    }
    assert!(last < 1e-8, "p = 15 reached only {last:e}");
}

/// L2L is exact at a fixed order (re-centring a polynomial), and L2P's gradient is the
/// derivative of its potential (central differences).
#[test]
fn l2l_is_exact_and_l2p_gradient_is_the_derivative() {
    let p = 10;
    let mut s = Scratch::new(p);
    let cm = [0.0, 0.0, 0.0];
    let cl = [3.0, -1.0, 2.0];
    let child = [3.2, -0.9, 1.85];
    let (pts, q) = cluster(cm, 0.4, 30, 5);
    let mut m = zeros(p);
    p2m(cm, &pts, &q, &mut m, &mut s);
    let mut l = zeros(p);
    m2l(cm, cl, &m, &mut l, &mut s);
    let mut lc = zeros(p);
    l2l(cl, child, &l, &mut lc, &mut s);
    for x in [[3.25, -0.85, 1.9], [3.1, -1.0, 1.8], [3.3, -0.8, 1.95]] {
        let (a, ga) = l2p(cl, &l, x, &mut s);
        let (b, gb) = l2p(child, &lc, x, &mut s);
        assert!(
            (a - b).abs() <= 1e-13 * a.abs().max(1.0),
            "L2L potential {a} vs {b}"
        );
        for k in 0..3 {
            assert!(
                (ga[k] - gb[k]).abs() <= 1e-12 * ga.iter().map(|v| v.abs()).fold(0.0, f64::max)
            );
        }
        let h = 1e-5;
        for k in 0..3 {
            let mut xp = x;
            let mut xm = x;
            xp[k] += h;
            xm[k] -= h;
            let fd = (l2p(cl, &l, xp, &mut s).0 - l2p(cl, &l, xm, &mut s).0) / (2.0 * h);
            assert!((fd - ga[k]).abs() <= 1e-7 * ga.iter().map(|v| v.abs()).fold(0.0, f64::max));
        }
    }
}

/// A batch of up to four M2Ls (four sources in the lanes of one register; a single M2L is
/// a batch of one, checked against the direct sum above) equals the sum of the sources'
/// M2Ls one by one: the lanes do not mix, idle lanes add nothing.
#[test]
fn batched_m2l_equals_single_m2l() {
    use superhelix_fmm::operators::{m2l_batch, BatchScratch};
    let p = 9;
    let mut s = Scratch::new(p);
    let mut bs = BatchScratch::new(p);
    let cl = [0.1, 0.2, -0.3];
    let centres = [
        [3.0, 0.5, 1.0],
        [-2.5, 2.0, 0.0],
        [0.4, -3.1, 1.2],
        [1.0, 1.0, -3.5],
    ];
    let mps: Vec<Vec<C>> = centres
        .iter()
        .enumerate()
        .map(|(k, &c)| {
            let (pts, q) = cluster(c, 0.5, 15, 20 + k as u64);
            let mut m = zeros(p);
            p2m(c, &pts, &q, &mut m, &mut s);
            m
        })
        .collect();
    for count in [1, 3, 4] {
        let mut single = zeros(p);
        for k in 0..count {
            m2l(centres[k], cl, &mps[k], &mut single, &mut s);
        }
        let batch: Vec<([f64; 3], &[C])> = (0..count).map(|k| (centres[k], &mps[k][..])).collect();
        let mut batched = zeros(p);
        m2l_batch(&batch, cl, &mut batched, &mut bs);
        let scale = single.iter().map(|v| v.norm()).fold(0.0, f64::max);
        for (a, b) in single.iter().zip(&batched) {
            assert!(
                (a - b).norm() <= 1e-13 * scale,
                "{count} sources: {a} vs {b}"
            );
        }
    }
}

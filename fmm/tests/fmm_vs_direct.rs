//! The multipole method against the direct sum, at several orders, on random and on
//! hair-like sets; the softened near field; input errors.

#![allow(clippy::needless_range_loop)] // coordinates indexed by axis read as the formulas

use superhelix_fmm::samples::{curly_fibres, uniform_cube};
use superhelix_fmm::{direct_at, direct_sum, expected_error, Fmm, FmmError, FmmOptions, Softening};

/// Relative l2 error of the field and of the potential at `sample`.
fn errors(points: &[[f64; 3]], q: &[f64], options: FmmOptions, sample: &[usize]) -> (f64, f64) {
    let (phi0, e0) = direct_at(points, q, sample, options.softening);
    let mut fmm = Fmm::new(options).expect("options");
    let (out, _) = fmm.evaluate(points, q).expect("evaluate");
    let (mut num, mut den, mut pn, mut pd) = (0.0, 0.0, 0.0, 0.0);
    for (k, &i) in sample.iter().enumerate() {
        for a in 0..3 {
            num += (out.field[i][a] - e0[k][a]).powi(2);
            den += e0[k][a].powi(2);
        }
        pn += (out.potential[i] - phi0[k]).powi(2);
        pd += phi0[k].powi(2);
    }
    ((num / den).sqrt(), (pn / pd).sqrt())
}

fn options(order: usize) -> FmmOptions {
    FmmOptions {
        order,
        theta: 0.5,
        leaf_size: 64,
        softening: Softening::NONE,
    }
}

/// Hair-like, 100,000 particles: every order within 3× the error table (the table was
/// measured on another sample of the same kind of set: seed 7 against seed 3 here), and
/// the error falls with p.
#[test]
fn hair_like_set_meets_the_error_table() {
    let (points, q) = curly_fibres(1000, 100, 3);
    let sample: Vec<usize> = (0..1000).map(|k| (k * 7919 + 13) % points.len()).collect();
    let mut last = f64::INFINITY;
    for p in [2, 5, 8, 12] {
        let (field, potential) = errors(&points, &q, options(p), &sample);
        assert!(
            field <= 3.0 * expected_error(p),
            "p = {p}: field error {field:e}, table {:e}",
            expected_error(p)
        );
        assert!(
            potential <= 3.0 * expected_error(p),
            "p = {p}: potential error {potential:e}"
        );
        assert!(field < last);
        last = field;
    }
}

/// Uniform random points in a cube (the easy case for an octree): the same table holds.
#[test]
fn random_set_meets_the_error_table() {
    let (points, q) = uniform_cube(20_000, 5);
    let (_, e0) = direct_sum(&points, &q, Softening::NONE);
    for p in [3, 6, 10] {
        let mut fmm = Fmm::new(options(p)).expect("options");
        let (out, stats) = fmm.evaluate(&points, &q).expect("evaluate");
        assert!(stats.m2l > 0, "the test must exercise M2L");
        let (mut num, mut den) = (0.0, 0.0);
        for (a, b) in out.field.iter().zip(&e0) {
            for k in 0..3 {
                num += (a[k] - b[k]).powi(2);
                den += b[k].powi(2);
            }
        }
        let err = (num / den).sqrt();
        assert!(
            err <= 3.0 * expected_error(p),
            "p = {p}: {err:e} against {:e}",
            expected_error(p)
        );
    }
}

/// `for_accuracy(eps)` gives a field within eps (in fact within eps/10 by construction,
/// allowed 3× for another set).
#[test]
fn requested_accuracy_is_met() {
    let (points, q) = curly_fibres(400, 100, 11);
    let sample: Vec<usize> = (0..800).map(|k| (k * 104_729 + 1) % points.len()).collect();
    for eps in [1e-2, 1e-4, 1e-6] {
        let o = FmmOptions::for_accuracy(eps).expect("eps");
        let (field, _) = errors(&points, &q, o, &sample);
        assert!(
            field <= 0.3 * eps,
            "eps = {eps:e} (p = {}): {field:e}",
            o.order
        );
    }
}

/// Two straight fibres crossing at a point, particles of both at the crossing: with the
/// softening every field is finite and at most Σ|q|/a² (the bound of the ball kernel),
/// and the multipole method agrees with the softened direct sum.
#[test]
fn crossing_fibres_give_bounded_forces() {
    let spacing = 1.0 / 330.0;
    let mut points = Vec::new();
    for k in -50..=50 {
        let s = k as f64 * spacing;
        points.push([s, 0.0, 0.0]);
        points.push([0.0, s, 1e-7]);
    }
    // A third fibre through the same point, exactly.
    for k in -50..=50 {
        points.push([0.0, 0.0, k as f64 * spacing]);
    }
    let q = vec![-7.8e-14; points.len()];
    let a = spacing;
    let softening = Softening { radius: a };
    let (phi, e) = direct_sum(&points, &q, softening);
    let bound: f64 = q.iter().map(|v| v.abs()).sum::<f64>() / (a * a);
    for (p, f) in phi.iter().zip(&e) {
        assert!(p.is_finite());
        let m = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt();
        assert!(m.is_finite() && m <= bound, "|E| = {m:e} above {bound:e}");
    }
    let mut o = options(10);
    o.softening = softening;
    o.leaf_size = 8;
    let mut fmm = Fmm::new(o).expect("options");
    let (out, stats) = fmm.evaluate(&points, &q).expect("evaluate");
    assert!(stats.m2l > 0);
    let scale = e
        .iter()
        .map(|f| f.iter().map(|v| v.abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    let worst = out
        .field
        .iter()
        .zip(&e)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f64::max);
    // p = 10: the table's 1.8e-6 (relative l2) for the worst component, 10× margin.
    assert!(
        worst <= 2e-5 * scale,
        "multipole against direct: {:e} of the largest field",
        worst / scale
    );
}

/// Without softening, particles at one point do not act on each other (no NaN), and a
/// single particle or none is handled.
#[test]
fn coincident_single_and_empty_sets() {
    let points = vec![[0.1, 0.2, 0.3]; 5];
    let q = vec![1.0; 5];
    let mut fmm = Fmm::new(options(4)).expect("options");
    let (out, _) = fmm.evaluate(&points, &q).expect("evaluate");
    assert!(out.field.iter().flatten().all(|v| *v == 0.0));
    assert!(out.potential.iter().all(|v| *v == 0.0));
    let (out, _) = fmm.evaluate(&[[1.0, 2.0, 3.0]], &[2.0]).expect("one");
    assert_eq!(out.potential, vec![0.0]);
    let (out, _) = fmm.evaluate(&[], &[]).expect("none");
    assert!(out.potential.is_empty());
}

/// Bad input is an error naming what is wrong.
#[test]
fn bad_input_is_refused() {
    let mut fmm = Fmm::new(options(4)).expect("options");
    assert_eq!(
        fmm.evaluate(&[[0.0; 3]], &[]).unwrap_err(),
        FmmError::Lengths {
            points: 1,
            charges: 0
        }
    );
    assert_eq!(
        fmm.evaluate(&[[0.0, f64::NAN, 0.0]], &[1.0]).unwrap_err(),
        FmmError::NonFinite {
            what: "points",
            index: 0
        }
    );
    assert!(matches!(
        Fmm::new(FmmOptions {
            theta: 1.5,
            ..options(4)
        }),
        Err(FmmError::Option { name: "theta", .. })
    ));
    assert!(matches!(
        FmmOptions::for_accuracy(0.0),
        Err(FmmError::Option { name: "eps", .. })
    ));
}

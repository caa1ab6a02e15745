//! The generated `element_point` against the runtime's reference `ElementPoint::by_jets`,
//! and the agreement of its two branches at the switch as compiled.
//! `cargo test -p superhelix-generated --release --test element_point -- --nocapture`
//! prints the worst deviations.

#![allow(clippy::needless_range_loop)] // index loops read like the formulas

use superhelix_generated::{element_point, element_point_into, ELEMENT_POINT_SWITCH};
mod common;

use common::{direction, Rng};
use superhelix_runtime::model::element::ElementPoint;
use superhelix_runtime::Vector3;

const FIELDS: [&str; 6] = ["frame", "p", "dp", "d2p", "w", "dw"];

/// The entries of each field of the struct, in the order of [`FIELDS`].
fn fields(e: &ElementPoint) -> [Vec<f64>; 6] {
    let flat3 = |v: &[Vector3<f64>]| v.iter().flat_map(|x| x.iter().copied()).collect();
    [
        e.frame.iter().copied().collect(),
        e.p.iter().copied().collect(),
        flat3(&e.dp),
        flat3(&e.d2p.concat()),
        flat3(&e.w),
        flat3(&e.dw.concat()),
    ]
}

/// Per field: largest |a − b| over the field, relative to the largest |b| of the field
/// (exact equality required when the field of `b` is zero).
fn deviations(a: &ElementPoint, b: &ElementPoint) -> [f64; 6] {
    let (fa, fb) = (fields(a), fields(b));
    std::array::from_fn(|k| {
        let scale = fb[k].iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let err = fa[k]
            .iter()
            .zip(&fb[k])
            .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        if err == 0.0 {
            0.0
        } else if scale > 0.0 {
            err / scale
        } else {
            f64::INFINITY
        }
    })
}

/// Direction kinds: random, planar (d0 = 0), pure κ1, pure κ2, pure twist.
const KINDS: [&str; 5] = ["random", "planar", "kappa1", "kappa2", "twist"];

#[test]
fn generated_element_point_matches_the_jets() {
    let xs = ELEMENT_POINT_SWITCH;
    let classes = [
        0.0,
        1e-12,
        1e-8,
        1e-4,
        1e-2,
        xs * (1.0 - 1e-9),
        xs * (1.0 + 1e-9),
        1.0,
        1.5,
        2.5,
        5.0,
        12.0,
        30.0,
        100.0,
        300.0,
    ];
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut worst = [0.0f64; 6];
    let mut worst_at = [(0.0, [0.0; 3], 0.0); 6];
    let mut count = 0;
    for &wl in &classes {
        let mut worst_class = 0.0f64;
        for kind in 0..KINDS.len() {
            for _ in 0..60 {
                // u over three decades; W = (W u)/u
                let u = 10f64.powf(-3.0 + 3.0 * (rng.next() + 1.0) / 2.0);
                let d = direction(&mut rng, kind) * (wl / u);
                let got = element_point(&d, u);
                let reference = ElementPoint::by_jets(&d, u);
                let dev = deviations(&got, &reference);
                for k in 0..6 {
                    if dev[k] > worst[k] {
                        worst[k] = dev[k];
                        worst_at[k] = (wl, [d[0], d[1], d[2]], u);
                    }
                    worst_class = worst_class.max(dev[k]);
                    assert!(
                        dev[k] <= 1e-13,
                        "W u = {wl}, {} direction, d = {d:?}, u = {u}: field {} deviates by {:e}",
                        KINDS[kind],
                        FIELDS[k],
                        dev[k]
                    );
                }
                count += 1;
            }
        }
        println!("W u = {wl:<22e} worst deviation {worst_class:.2e}");
    }
    for k in 0..6 {
        println!(
            "{:>5}: worst {:.2e} (W u = {:e}, d = {:?}, u = {:e})",
            FIELDS[k], worst[k], worst_at[k].0, worst_at[k].1, worst_at[k].2
        );
    }
    println!(
        "{count} points: worst relative deviation from ElementPoint::by_jets {:.2e}",
        worst.iter().fold(0.0f64, |m, x| m.max(*x))
    );
}

#[test]
fn values_are_accurate_where_the_reference_cancels() {
    // by_jets writes p = u e0 + C K² e0: for d ⊥ e0 a term of size u cancels to
    // |p| ~ u/(W u), so its own error grows like W u (it dominates the deviations above
    // at W u = 300). The generated values use P = A I + B K + C d dᵀ; compare them with
    // that form evaluated from the runtime's a, b, c.
    use superhelix_runtime::model::helix_functions::abc_values;
    let mut rng = Rng(0x5555_aaaa_1234_4321);
    let (mut worst, mut worst_jets) = (0.0f64, 0.0f64);
    for &wl in &[5.0, 30.0, 100.0, 300.0] {
        for i in 0..200 {
            let u = 10f64.powf(-3.0 + 3.0 * (rng.next() + 1.0) / 2.0);
            let d = direction(&mut rng, i % 2) * (wl / u);
            let (a, b, c) = abc_values(u * u * d.norm_squared());
            let (a, b, c) = (u * a, u * u * b, u * u * u * c);
            let w: [Vector3<f64>; 3] = std::array::from_fn(|i| {
                let e = Vector3::ith(i, 1.0);
                e * a + d.cross(&e) * b + d * (c * d[i])
            });
            let got = element_point(&d, u);
            let jets = ElementPoint::by_jets(&d, u);
            // each w_i against its own largest entry (w_0 = p is the field `p`)
            for i in 0..3 {
                let scale = w[i].amax();
                worst = worst.max((got.w[i] - w[i]).amax() / scale);
                worst_jets = worst_jets.max((jets.w[i] - w[i]).amax() / scale);
            }
        }
    }
    println!(
        "w_i = P e_i at W u in 5..300 against A I + B K + C d dᵀ, relative to max |w_i|: generated {worst:.2e}, by_jets {worst_jets:.2e}"
    );
    assert!(worst <= 1e-14, "{worst:e}");
}

#[test]
fn branches_agree_at_the_switch_as_compiled() {
    // the same direction and u on both sides of the switch, |d| a few ulps apart: the
    // difference is the branches' disagreement (the function itself moves by ~1e-16)
    let xs = ELEMENT_POINT_SWITCH;
    let mut rng = Rng(0x0123_4567_89ab_cdef);
    let mut worst = 0.0f64;
    for i in 0..2000 {
        let u = 10f64.powf(-3.0 + 3.0 * (rng.next() + 1.0) / 2.0);
        let e = direction(&mut rng, i % KINDS.len());
        // z as the generated code computes it
        let z = |s: f64| {
            let d = e * s;
            u * u * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        };
        let mut s = xs / u;
        while z(s) >= xs * xs {
            s = s.next_down();
        }
        while z(s) < xs * xs {
            s = s.next_up();
        }
        let (below, above) = (s.next_down(), s);
        assert!(z(below) < xs * xs && z(above) >= xs * xs);
        let a = element_point(&(e * below), u);
        let b = element_point(&(e * above), u);
        let dev = deviations(&a, &b);
        worst = dev.iter().fold(worst, |m, x| m.max(*x));
    }
    println!("branches at W u = {xs} as compiled: worst relative difference {worst:.2e}");
    assert!(worst <= 2e-14, "{worst:e}");
}

#[test]
fn into_overwrites_every_field_and_values_are_finite() {
    let mut out = ElementPoint::default();
    out.frame.fill(f64::NAN);
    out.p.fill(f64::NAN);
    out.dp = [Vector3::repeat(f64::NAN); 3];
    out.d2p = [[Vector3::repeat(f64::NAN); 3]; 3];
    out.w = [Vector3::repeat(f64::NAN); 3];
    out.dw = [[Vector3::repeat(f64::NAN); 3]; 3];
    let d = Vector3::new(3.0, -20.0, 7.0);
    element_point_into(&d, 0.04, &mut out);
    assert_eq!(out, element_point(&d, 0.04));
    for x in [0.0, 1e-300, 1e-3, 1.0, 1e3] {
        for u in [0.0, 1e-6, 0.05, 1.0] {
            let e = element_point(&Vector3::new(x, -0.5 * x, 2.0 * x), u);
            assert!(
                fields(&e).iter().flatten().all(|v| v.is_finite()),
                "{x} {u}"
            );
        }
    }
    // at u = 0 the frame is the identity and everything else vanishes
    let e = element_point(&d, 0.0);
    assert_eq!(e.frame, superhelix_runtime::Matrix3::identity());
    assert!(fields(&e)[1..].iter().flatten().all(|v| *v == 0.0));
}

//! The generated `element_rotary_point_into` (ElementPoint without `d2p`, what the
//! rotary-inertia quadrature reads) against `element_point_into`: frame, p, dp, w and dw
//! agree to 1e-15 of each field's largest entry, `d2p` is left untouched.
//! `cargo test -p superhelix-generated --release --test element_rotary_point -- --nocapture`
//! prints the worst deviation per field and how many points agree bit for bit.

use superhelix_generated::{
    element_point_into, element_rotary_point_into, ELEMENT_POINT_SWITCH,
    ELEMENT_ROTARY_POINT_SWITCH,
};
mod common;

use common::{direction, Rng};
use superhelix_runtime::model::element::ElementPoint;
use superhelix_runtime::Vector3;

const FIELDS: [&str; 5] = ["frame", "p", "dp", "w", "dw"];

/// The entries of the fields the rotary point fills, in the order of [`FIELDS`].
fn fields(e: &ElementPoint) -> [Vec<f64>; 5] {
    let flat3 = |v: &[Vector3<f64>]| v.iter().flat_map(|x| x.iter().copied()).collect();
    [
        e.frame.iter().copied().collect(),
        e.p.iter().copied().collect(),
        flat3(&e.dp),
        flat3(&e.w),
        flat3(&e.dw.concat()),
    ]
}

#[test]
fn rotary_point_matches_element_point_without_d2p() {
    // same branch at every (d, u)
    assert_eq!(ELEMENT_ROTARY_POINT_SWITCH, ELEMENT_POINT_SWITCH);
    let xs = ELEMENT_POINT_SWITCH;
    let mut wus = vec![
        0.0, 1e-12, 1e-8, 1e-4, 0.01, 0.1, 0.3, 0.5, 0.9, 2.0, 5.0, 10.0, 30.0, 100.0,
    ];
    // both sides of the switch, by a few ulps and by 1e-9
    for f in [
        1.0 - 1e-9,
        1.0 - 4.0 * f64::EPSILON,
        1.0,
        1.0 + 4.0 * f64::EPSILON,
        1.0 + 1e-9,
    ] {
        wus.push(xs * f);
    }
    let mut rng = Rng(0x0bad_cafe_f00d_1234);
    let mut worst = [0.0f64; 5];
    let (mut points, mut identical) = (0usize, 0usize);
    let sentinel = [[Vector3::new(f64::NAN, 7.0, -3.0); 3]; 3];
    for &wu in &wus {
        for kind in 0..5 {
            for k in 0..40 {
                // u over several decades, W = W u / u (random W u when k is odd above 0)
                let u = [1.0, 0.01, 3.0, 0.2][k % 4] * (1.0 + 0.5 * rng.next());
                let wu = if k % 2 == 1 && wu > 0.0 {
                    wu * (1.0 + 0.25 * rng.next())
                } else {
                    wu
                };
                let d = direction(&mut rng, kind) * (wu / u);
                let mut full = ElementPoint::default();
                element_point_into(&d, u, &mut full);
                let mut rot = ElementPoint {
                    d2p: sentinel,
                    ..Default::default()
                };
                element_rotary_point_into(&d, u, &mut rot);
                // d2p is not written
                for (a, b) in rot.d2p.iter().flatten().zip(sentinel.iter().flatten()) {
                    assert!(a.x.is_nan() && a.y == b.y && a.z == b.z, "d2p was written");
                }
                let (fa, fb) = (fields(&rot), fields(&full));
                let mut same = true;
                for f in 0..5 {
                    let scale = fb[f].iter().fold(0.0f64, |m, x| m.max(x.abs()));
                    let err = fa[f]
                        .iter()
                        .zip(&fb[f])
                        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
                    same &= fa[f]
                        .iter()
                        .zip(&fb[f])
                        .all(|(x, y)| x.to_bits() == y.to_bits());
                    let e = if err == 0.0 { 0.0 } else { err / scale };
                    worst[f] = worst[f].max(e);
                    assert!(
                        e <= 1e-15,
                        "{}: W u = {:e}, u = {u}, d = {d:?}: deviation {e:e}\n{:?}\n{:?}",
                        FIELDS[f],
                        d.norm() * u,
                        fa[f],
                        fb[f]
                    );
                }
                points += 1;
                identical += usize::from(same);
            }
        }
    }
    println!(
        "{points} points, {identical} bit-identical in every field; worst deviation per field:"
    );
    for (name, e) in FIELDS.iter().zip(worst) {
        println!("  {name:6} {e:.2e}");
    }
}

/// Lane k of `element_rotary_points_lanes` (one abscissa of each of W elements, element k
/// of W strands) is `element_rotary_point_into` at lane k's (d, u), bit for bit, with
/// lanes on both sides of the switch in the same call, at W = 1, 4, 8 and 16.
#[test]
fn rotary_points_in_lanes_are_one_point_each_bit_for_bit() {
    use superhelix_generated::element_rotary_point::element_rotary_points_lanes;
    use superhelix_generated::kernels::element::LaneRotaryPoints;
    use superhelix_generated::kernels::lane::Lanes;
    fn check<const W: usize>(rng: &mut Rng) -> usize {
        let xs = ELEMENT_ROTARY_POINT_SWITCH;
        let wus = [
            0.0,
            1e-6,
            0.3,
            xs * (1.0 - 1e-9),
            xs,
            xs * (1.0 + 1e-9),
            2.0,
            30.0,
        ];
        let mut checked = 0;
        for case in 0..40 {
            let mut d = [Lanes([0.0; W]); 3];
            let mut u = Lanes([0.0; W]);
            let mut inputs = Vec::new();
            for k in 0..W {
                let uk = [1.0, 0.01, 3.0, 0.2][(case + k) % 4] * (1.0 + 0.5 * rng.next());
                let wu = wus[(case + 3 * k) % wus.len()];
                let dk = direction(rng, (case + k) % 5) * (wu / uk);
                for i in 0..3 {
                    d[i].0[k] = dk[i];
                }
                u.0[k] = uk;
                inputs.push((dk, uk));
            }
            let mut out = LaneRotaryPoints::<W>::default();
            element_rotary_points_lanes(&d, u, &mut out);
            for (k, (dk, uk)) in inputs.iter().enumerate() {
                let mut one = ElementPoint::default();
                element_rotary_point_into(dk, *uk, &mut one);
                let same = |a: f64, b: f64| a.to_bits() == b.to_bits();
                for c in 0..3 {
                    for r in 0..3 {
                        assert!(
                            same(out.frame[c][r].0[k], one.frame[(r, c)]),
                            "W = {W}, case {case}, lane {k}: frame"
                        );
                    }
                }
                for i in 0..3 {
                    for m in 0..3 {
                        assert!(
                            same(out.w[i][m].0[k], one.w[i][m]),
                            "W = {W}, case {case}, lane {k}: w"
                        );
                        for j in 0..3 {
                            assert!(
                                same(out.dw[i][j][m].0[k], one.dw[i][j][m]),
                                "W = {W}, case {case}, lane {k}: dw"
                            );
                        }
                    }
                }
                checked += 1;
            }
        }
        checked
    }
    let mut rng = Rng(0x1a4e_9017);
    let checked =
        check::<1>(&mut rng) + check::<4>(&mut rng) + check::<8>(&mut rng) + check::<16>(&mut rng);
    assert_eq!(checked, 40 * (1 + 4 + 8 + 16));
}

//! Every generated kernel is compiled twice, for the baseline target and with AVX2, and
//! dispatches at run time (`superhelix_codegen::emit::multiversioned`). Both copies must
//! give the same bits: the same IEEE-754 operations in the same order, which holds as
//! long as nothing contracts `a * b + c` into a fused multiply-add. On a CPU without
//! AVX2 the dispatched function *is* the portable one and the test is trivially true;
//! the test says which case it ran.

mod common;

use common::{direction, Rng};
use superhelix_generated as g;
use superhelix_runtime::model::element::ElementPoint;
use superhelix_runtime::Vector3;

/// W·l (or W·u) across every branch of every kernel: the low and full Taylor branches,
/// either side of each switch, and the closed form up to a coil of 16 turns.
const WL: [f64; 14] = [
    0.0, 1e-12, 1e-8, 1e-4, 1e-2, 0.3, 0.74, 0.76, 1.0, 3.4, 3.6, 10.0, 30.0, 100.0,
];

type PointFn = fn(&Vector3<f64>, f64, &mut ElementPoint);

/// The generated element-point functions: name, dispatched, portable copy.
const POINT_FUNCTIONS: [(&str, PointFn, PointFn); 2] = [
    (
        "element_point_into",
        g::element_point_into,
        g::element_point::element_point_into_portable,
    ),
    (
        "element_rotary_point_into",
        g::element_rotary_point_into,
        g::element_rotary_point::element_rotary_point_into_portable,
    ),
];

fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

fn point_fields(p: &ElementPoint) -> Vec<f64> {
    let mut v: Vec<f64> = p.frame.iter().copied().collect();
    v.extend(p.p.iter());
    for i in 0..3 {
        v.extend(p.dp[i].iter());
        v.extend(p.w[i].iter());
        for j in 0..3 {
            v.extend(p.d2p[i][j].iter());
            v.extend(p.dw[i][j].iter());
        }
    }
    v
}

#[test]
fn dispatched_and_portable_kernels_agree_bit_for_bit() {
    #[cfg(target_arch = "x86_64")]
    eprintln!(
        "AVX2 on this CPU: {} (without it both calls run the portable copy)",
        std::arch::is_x86_feature_detected!("avx2")
    );
    let mut rng = Rng(0x5eed_0fa5);
    let mut checked = 0;
    for &wl in &WL {
        for kind in 0..5 {
            for _ in 0..20 {
                let l = 0.05 + 2.0 * (rng.next() + 1.0);
                let d = direction(&mut rng, kind) * (wl / l);
                let da = [d.x, d.y, d.z];
                let (mut a, mut b) = ([0.0; 135], [0.0; 135]);
                g::centreline_force(&da, l, &mut a);
                g::centreline_force::centreline_force_portable(&da, l, &mut b);
                assert!(same_bits(&a, &b), "centreline_force at d = {d:?}, l = {l}");
                let (mut a, mut b) = ([0.0; 51], [0.0; 51]);
                g::centreline_mass(&da, l, &mut a);
                g::centreline_mass::centreline_mass_portable(&da, l, &mut b);
                assert!(same_bits(&a, &b), "centreline_mass at d = {d:?}, l = {l}");
                let (mut a, mut b) = ([0.0; 63], [0.0; 63]);
                g::rotary_basis(&da, l, &mut a);
                g::rotary_basis::rotary_basis_portable(&da, l, &mut b);
                assert!(same_bits(&a, &b), "rotary_basis at d = {d:?}, l = {l}");
                let u = l * 0.5 * (rng.next() + 1.0);
                for (name, dispatched, portable) in POINT_FUNCTIONS {
                    let (mut a, mut b) = (ElementPoint::default(), ElementPoint::default());
                    dispatched(&d, u, &mut a);
                    portable(&d, u, &mut b);
                    assert!(
                        same_bits(&point_fields(&a), &point_fields(&b)),
                        "{name} at d = {d:?}, u = {u}"
                    );
                }
                checked += 1;
            }
        }
    }
    assert_eq!(checked, WL.len() * 5 * 20);
}

/// The four-lane closed forms (`*_closed_x4`): dispatched and portable copies agree bit
/// for bit, and lane k is the one-element function of lane k's inputs, at W·l in the
/// closed-form branch of all three functions.
#[test]
fn four_lane_closed_forms_agree_with_their_portable_copies_and_one_element() {
    use superhelix_runtime::model::lanes::F4;
    let mut rng = Rng(0x4a4e_5f0d);
    let mut checked = 0;
    for &wl in &[3.6, 10.0, 30.0, 100.0] {
        for kind in 0..5 {
            for _ in 0..10 {
                let mut d = [F4([0.0; 4]); 3];
                let mut l = F4([0.0; 4]);
                for k in 0..4 {
                    l.0[k] = 0.05 + 2.0 * (rng.next() + 1.0);
                    let dk = direction(&mut rng, kind) * (wl * (1.0 + 0.5 * k as f64) / l.0[k]);
                    for i in 0..3 {
                        d[i].0[k] = dk[i];
                    }
                }
                macro_rules! check {
                    ($k:literal, $x4:path, $portable:path, $one:path) => {{
                        let (mut a, mut b) = ([F4([0.0; 4]); $k], [F4([0.0; 4]); $k]);
                        $x4(&d, l, &mut a);
                        $portable(&d, l, &mut b);
                        for lane in 0..4 {
                            let la: Vec<f64> = a.iter().map(|x| x.0[lane]).collect();
                            let lb: Vec<f64> = b.iter().map(|x| x.0[lane]).collect();
                            let mut one = [0.0; $k];
                            $one(
                                &[d[0].0[lane], d[1].0[lane], d[2].0[lane]],
                                l.0[lane],
                                &mut one,
                            );
                            assert!(
                                same_bits(&la, &lb),
                                "{} portable, lane {lane}",
                                stringify!($x4)
                            );
                            assert!(
                                same_bits(&la, &one),
                                "{} vs one element, lane {lane}",
                                stringify!($x4)
                            );
                        }
                    }};
                }
                check!(
                    135,
                    g::centreline_force_closed_x4,
                    g::centreline_force::centreline_force_closed_x4_portable,
                    g::centreline_force
                );
                check!(
                    51,
                    g::centreline_mass_closed_x4,
                    g::centreline_mass::centreline_mass_closed_x4_portable,
                    g::centreline_mass
                );
                check!(
                    63,
                    g::rotary_basis_closed_x4,
                    g::rotary_basis::rotary_basis_closed_x4_portable,
                    g::rotary_basis
                );
                checked += 1;
            }
        }
    }
    assert_eq!(checked, 200);
}

/// The four-lane rotary point (`element_rotary_points_into`): lane k is the one-point
/// `element_rotary_point_into` at `u[k]`, bit for bit, for 1–4 abscissae whose lanes
/// fall on either side of the switch (W·u = 1) in the same call, and the dispatched and
/// portable copies agree bit for bit.
#[test]
fn four_lane_rotary_points_are_the_one_point_function_bit_for_bit() {
    use superhelix_runtime::model::element::RotaryPoints;
    let mut rng = Rng(0x0b1e_c7ed);
    let mut checked = 0;
    let mut lanes_by_branch = [0usize; 2];
    let mut mixed = 0;
    for &wl in &WL {
        for kind in 0..5 {
            for used in 1..=4 {
                let l = 0.05 + 2.0 * (rng.next() + 1.0);
                let d = direction(&mut rng, kind) * (wl / l);
                let u: Vec<f64> = (0..used).map(|_| l * 0.5 * (rng.next() + 1.0)).collect();
                let taylor = u
                    .iter()
                    .filter(|&&uk| d.norm() * uk < g::ELEMENT_ROTARY_POINT_SWITCH);
                if (1..used).contains(&taylor.count()) {
                    mixed += 1;
                }
                let (mut a, mut b) = (RotaryPoints::default(), RotaryPoints::default());
                g::element_rotary_points_into(&d, &u, &mut a);
                g::element_rotary_point::element_rotary_points_into_portable(&d, &u, &mut b);
                for (k, &uk) in u.iter().enumerate() {
                    let mut one = ElementPoint::default();
                    g::element_rotary_point_into(&d, uk, &mut one);
                    let mut expected = RotaryPoints::default();
                    expected.set_lane(k, &one);
                    let lane = |p: &RotaryPoints| {
                        let mut v: Vec<f64> = p.frame.iter().flatten().map(|x| x.0[k]).collect();
                        v.extend(p.w.iter().flatten().map(|x| x.0[k]));
                        v.extend(p.dw.iter().flatten().flatten().map(|x| x.0[k]));
                        v
                    };
                    assert!(
                        same_bits(&lane(&a), &lane(&expected)),
                        "lane {k} of {used} at d = {d:?}, u = {uk}"
                    );
                    assert!(
                        same_bits(&lane(&b), &lane(&expected)),
                        "portable, lane {k} of {used} at d = {d:?}, u = {uk}"
                    );
                    lanes_by_branch
                        [usize::from(d.norm() * uk >= g::ELEMENT_ROTARY_POINT_SWITCH)] += 1;
                }
                checked += 1;
            }
        }
    }
    assert_eq!(checked, WL.len() * 5 * 4);
    // both branches, and calls mixing them, are covered
    assert!(
        lanes_by_branch[0] > 100 && lanes_by_branch[1] > 100,
        "{lanes_by_branch:?}"
    );
    assert!(mixed >= 20, "{mixed} calls mix the branches");
}

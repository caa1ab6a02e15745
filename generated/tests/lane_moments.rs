//! The element moments of W elements in lanes (`lane_moments`): every lane gives, bit for
//! bit, the one-element closed forms of its element, whatever branch the other lanes
//! take, on every compiled path and width.

mod common;

use common::{direction, Rng};
use superhelix_generated::kernels::lane::Lanes;
use superhelix_generated::kernels::moments::ElementMoments;
use superhelix_generated::lane_moments::{
    element_moments_lanes_into, element_moments_lanes_into_portable, LaneMoments, LaneParts,
};

/// Every field of a moment set, flattened in a fixed order.
fn flat(m: &ElementMoments) -> Vec<f64> {
    let mut v = Vec::new();
    v.extend(m.first.iter());
    v.extend(m.second.iter());
    m.dfirst.iter().for_each(|x| v.extend(x.iter()));
    m.cross.iter().for_each(|x| v.extend(x.iter()));
    v.extend(m.gram.iter());
    v.extend(m.rot.iter());
    m.rot_w.iter().for_each(|x| v.extend(x.iter()));
    v.extend(m.rot_ww.iter());
    m.pdp.iter().for_each(|x| v.extend(x.iter()));
    m.d2first
        .as_flattened()
        .iter()
        .for_each(|x| v.extend(x.iter()));
    m.cross2
        .as_flattened()
        .iter()
        .for_each(|x| v.extend(x.iter()));
    m.pd2p
        .as_flattened()
        .iter()
        .for_each(|x| v.extend(x.iter()));
    m.dpdp
        .as_flattened()
        .iter()
        .for_each(|x| v.extend(x.iter()));
    v.extend(m.dpd2p.as_flattened().as_flattened());
    v
}

/// W l of the cases: every branch of every function (0, nearly straight, around each
/// switch, closed form up to 100).
fn wl_of(case: usize, lane: usize, rng: &mut Rng) -> f64 {
    let switches = [
        superhelix_generated::CENTRELINE_MASS_SWITCH,
        superhelix_generated::CENTRELINE_FORCE_SWITCH,
        superhelix_generated::ROTARY_BASIS_SWITCH,
    ];
    match (case + 3 * lane) % 6 {
        0 => 0.0,
        1 => switches[lane % 3] * (1.0 + 1e-3 * rng.next()),
        2 => 4.0 * (rng.next() + 1.0),
        3 => 50.0 * (rng.next() + 1.0),
        4 => 0.2 * (rng.next() + 1.0),
        // a lane of a batch where every lane is in the closed form
        _ => 3.0 + (rng.next() + 1.0),
    }
}

fn check_width<const W: usize>(cases: usize, seed: u64) -> (usize, usize) {
    let mut rng = Rng(seed);
    let (mut mixed, mut closed_only) = (0, 0);
    for case in 0..cases {
        let rotary = if case % 5 == 0 {
            [0.0; 3]
        } else {
            [2.0e-9, 0.8e-9, 1.2e-9]
        };
        let all_closed = case % 4 == 3;
        let mut d = [Lanes([0.0; W]); 3];
        let mut l = Lanes([0.0; W]);
        let mut elements = Vec::new();
        for k in 0..W {
            l.0[k] = 0.01 + 0.03 * (rng.next() + 1.0);
            let wl = if all_closed {
                3.0 + 40.0 * (rng.next() + 1.0)
            } else {
                wl_of(case, k, &mut rng)
            };
            let dk = direction(&mut rng, (case + k) % 5) * (wl / l.0[k]);
            for i in 0..3 {
                d[i].0[k] = dk[i];
            }
            elements.push((dk, l.0[k]));
        }
        if all_closed {
            closed_only += 1;
        } else {
            mixed += 1;
        }
        let parts = LaneParts {
            rotary: rotary != [0.0; 3],
            ..LaneParts::ALL
        };
        let mut dispatched = LaneMoments::<W>::default();
        let mut portable = LaneMoments::<W>::default();
        element_moments_lanes_into(&d, l, parts, &mut dispatched);
        element_moments_lanes_into_portable(&d, l, parts, &mut portable);
        for (k, (dk, lk)) in elements.iter().enumerate() {
            let one = superhelix_generated::element_moments(dk, *lk, &rotary);
            for (name, lanes) in [("dispatched", &dispatched), ("portable", &portable)] {
                let mut m = ElementMoments::default();
                lanes.lane_into(k, &rotary, &mut m);
                let (a, b) = (flat(&m), flat(&one));
                let first = a
                    .iter()
                    .zip(&b)
                    .position(|(x, y)| x.to_bits() != y.to_bits());
                assert!(
                    first.is_none(),
                    "W = {W}, case {case}, lane {k} ({name}), W l = {}: entry {first:?}",
                    dk.norm() * lk
                );
            }
        }
    }
    (mixed, closed_only)
}

/// Each lane is its element's one-element moments, bit for bit, at four lanes (the width
/// the lanes run at; every width is the same generated text, and each width compiled is
/// two more copies of ~50 kB of straight-line code, so the suite compiles one), on the
/// dispatched path (AVX2 where the CPU has it) and the portable one, with
/// lanes on every branch of every function in the same call and with all lanes closed.
#[test]
fn every_lane_is_its_element_bit_for_bit() {
    let (mixed, closed) = check_width::<4>(200, 0x1a4e_0004);
    assert!(mixed > 0 && closed > 0, "{mixed} mixed, {closed} closed");
}

/// The parts not asked for are left as they were.
#[test]
fn parts_not_asked_for_are_untouched() {
    let d = [Lanes([30.0; 4]), Lanes([-20.0; 4]), Lanes([5.0; 4])];
    let l = Lanes([0.04; 4]);
    let mut out = LaneMoments::<4>::default();
    out.force[7] = Lanes([1.5; 4]);
    out.rotary[3] = Lanes([2.5; 4]);
    let parts = LaneParts {
        mass: true,
        force: false,
        rotary: false,
    };
    element_moments_lanes_into(&d, l, parts, &mut out);
    assert_eq!(out.force[7], Lanes([1.5; 4]));
    assert_eq!(out.rotary[3], Lanes([2.5; 4]));
    assert_ne!(out.mass[0], Lanes([0.0; 4]));
}

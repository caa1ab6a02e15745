//! Where a strand's contacts are sampled along it: arc lengths and the weights (the arc
//! length each sample stands for) of a quadrature of the contact forces over the strand;
//! their poses at a state.

use crate::element::local_pose;
use crate::pose::{darboux, Pose};
use nalgebra::Vector3;

/// Sample arc lengths and weights: `per` points per element at the centres of equal
/// parts (the midpoint rule), except, where `free_ends` (root, tip) asks, on the outer
/// part at that end, which takes the two-point Gauss–Radau rule that includes the end:
/// the end itself with a quarter of the part's weight and a point two thirds of the part
/// in with three quarters (exact to degree 2 like the midpoint rule; a strand of one part
/// with both takes Simpson's rule). The end then touches a body or another part where it
/// is: at the midpoints alone, a rope landing end-first stood on its tip 1 mm inside the
/// floor, held by a sample half a part up.
///
/// A pinned or free root's joint (the leading elements no longer than `2 ·
/// joint_fraction` of the strand's length, which the runtime's rod ends add) takes no
/// sample: samples there would weigh nothing, and the root's own end sample is that of
/// the first element of the strand's own (on the joint, a free rod's root went 1.3 mm
/// into a floor that nothing held it out of). Each sample is handed to `out` as (arc
/// length, weight), in arc-length order.
pub fn sample_points(
    lengths: &[f64],
    per: usize,
    free_ends: [bool; 2],
    joint_fraction: f64,
    mut out: impl FnMut(f64, f64),
) {
    let mut start = 0.0;
    let last = lengths.len().saturating_sub(1);
    let sliver = 2.0 * joint_fraction * lengths.iter().sum::<f64>();
    // the first element of the strand's own (after a root joint)
    let own = lengths.iter().position(|&l| l > sliver).unwrap_or(0);
    for (e, &l) in lengths.iter().enumerate() {
        if e < own {
            start += l;
            continue;
        }
        let w = l / per as f64;
        for j in 0..per {
            let first = e == own && j == 0 && free_ends[0];
            let end = e == last && j + 1 == per && free_ends[1];
            let a = start + w * j as f64;
            match (first, end) {
                (true, true) => {
                    out(a, w / 6.0);
                    out(a + 0.5 * w, 4.0 * w / 6.0);
                    out(a + w, w / 6.0);
                }
                (true, false) => {
                    out(a, 0.25 * w);
                    out(a + 2.0 * w / 3.0, 0.75 * w);
                }
                (false, true) => {
                    out(a + w / 3.0, 0.75 * w);
                    out(a + w, 0.25 * w);
                }
                // (as written: a case of the stress matrix at its edge moves with the
                // last bit of a sample's arc length)
                _ => out(start + l * (j as f64 + 0.5) / per as f64, l / per as f64),
            }
        }
        start += l;
    }
}

/// The positions y(s) at the arc lengths `arcs` (increasing; each clamped to the
/// strand) of a strand rooted at `root` with element lengths `lengths` at q, head
/// coordinates, handed to `visit(s, y)` in one pass along the strand (an element's end
/// pose once, one local pose per point).
pub fn positions_along(
    root: &Pose,
    lengths: &[f64],
    q: &[f64],
    arcs: impl IntoIterator<Item = f64>,
    mut visit: impl FnMut(f64, Vector3<f64>),
) {
    let n = lengths.len();
    if n == 0 {
        return;
    }
    let mut start = *root;
    let (mut element, mut s0) = (0, 0.0);
    let mut d = darboux(q, 0);
    for s in arcs {
        while element + 1 < n && s > s0 + lengths[element] {
            let (e, p) = local_pose(&d, lengths[element]);
            start = Pose {
                position: start.position + start.frame * p,
                frame: start.frame * e,
            };
            s0 += lengths[element];
            element += 1;
            d = darboux(q, element);
        }
        let u = (s - s0).clamp(0.0, lengths[element]);
        let (_, p) = local_pose(&d, u);
        visit(s, start.position + start.frame * p);
    }
}

/// Positions y(s_k) and unit tangents of the samples at arc lengths `samples` (in
/// increasing order, first entries of the pairs) of a strand rooted at `root` with element
/// lengths `lengths` at q, head coordinates, into `poses` (as many as the samples): one
/// pass along the strand, an element's end pose once and one local pose per sample.
pub fn sample_poses(
    root: &Pose,
    lengths: &[f64],
    q: &[f64],
    samples: &[(f64, f64)],
    poses: &mut [(Vector3<f64>, Vector3<f64>)],
) {
    let mut start = *root;
    let mut k = 0;
    let mut s0 = 0.0;
    let n = samples.len().min(poses.len());
    for (e, &l) in lengths.iter().enumerate() {
        let d = darboux(q, e);
        while k < n && (samples[k].0 <= s0 + l || e + 1 == lengths.len()) {
            let (f, p) = local_pose(&d, samples[k].0 - s0);
            let frame = start.frame * f;
            poses[k] = (start.position + start.frame * p, frame.column(0).into());
            k += 1;
        }
        let (f, p) = local_pose(&d, l);
        start = Pose {
            position: start.position + start.frame * p,
            frame: start.frame * f,
        };
        s0 += l;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec::Vec;

    /// The rule integrates linear functions of the arc length exactly over the strand's
    /// own part (after a root joint), with every combination of free ends: Σ w = L_own and
    /// Σ w s = ∫ s ds; the samples stay in order within the own part, the ends on it when
    /// free.
    #[test]
    fn the_samples_integrate_linear_functions_over_the_strand_exactly() {
        let joint = 1e-3;
        for lengths in [
            &[0.05][..],
            &[0.04, 0.06, 0.05][..],
            &[2e-4, 0.03, 0.05, 0.02][..],
        ] {
            let total: f64 = lengths.iter().sum();
            let skipped: f64 = lengths
                .iter()
                .take_while(|&&l| l <= 2.0 * joint * total)
                .sum();
            for per in [1, 2, 3] {
                for free_ends in [[false, false], [true, false], [false, true], [true, true]] {
                    let mut samples = Vec::new();
                    sample_points(lengths, per, free_ends, joint, |s, w| samples.push((s, w)));
                    let weight: f64 = samples.iter().map(|x| x.1).sum();
                    let moment: f64 = samples.iter().map(|x| x.0 * x.1).sum();
                    let exact = 0.5 * (total * total - skipped * skipped);
                    assert!(
                        (weight - (total - skipped)).abs() < 1e-15,
                        "{lengths:?} {per}"
                    );
                    assert!(
                        (moment - exact).abs() < 1e-15,
                        "{lengths:?} {per} {free_ends:?}"
                    );
                    assert!(samples.windows(2).all(|p| p[0].0 < p[1].0));
                    assert!(samples.iter().all(|x| x.0 >= skipped && x.0 <= total));
                    if free_ends[0] {
                        assert_eq!(samples[0].0, skipped);
                    }
                    if free_ends[1] {
                        assert!((samples[samples.len() - 1].0 - total).abs() < 1e-15);
                    }
                }
            }
        }
    }
}

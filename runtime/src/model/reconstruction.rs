//! Closed-form reconstruction of a Super-Helix (paper section 3.2 and appendix A):
//! centreline and material frames at element ends and at any arc length, chained from
//! the clamped root, `F_{Q+1} = F_Q E_Q(l_Q)`, `r_{Q+1} = r_Q + F_Q P_Q(l_Q) e0`.

use crate::model::element::local_pose;
use crate::model::strand::StrandGeometry;
use nalgebra::Vector3;
pub use superhelix_kernels::pose::{darboux, Pose};

/// Poses at the N + 1 element ends (root first), in head coordinates.
/// `ends.len()` must be N + 1.
pub fn element_ends(geom: &StrandGeometry, q: &[f64], ends: &mut [Pose]) {
    ends[0] = geom.root_pose(q);
    for (k, &l) in geom.lengths.iter().enumerate() {
        let (e, p) = local_pose(&darboux(q, k), l);
        let start = ends[k];
        ends[k + 1] = Pose {
            position: start.position + start.frame * p,
            frame: start.frame * e,
        };
    }
}

/// Pose at arc length `s` (clamped to [0, L]).
pub fn pose_at(geom: &StrandGeometry, q: &[f64], s: f64) -> Pose {
    let (element, u) = geom.locate(s);
    let mut pose = geom.root_pose(q);
    for (k, &l) in geom.lengths.iter().enumerate().take(element + 1) {
        let (e, p) = local_pose(&darboux(q, k), if k == element { u } else { l });
        pose = Pose {
            position: pose.position + pose.frame * p,
            frame: pose.frame * e,
        };
    }
    pose
}

/// Positions y(s) at the arc lengths `arcs` (in increasing order; each clamped to
/// [0, L]), in head coordinates, into `out` (cleared first): one pass along the strand,
/// an element's pose once and one local pose per point, where [`pose_at`] per point
/// would chain the elements from the root for each.
pub fn positions_at_sorted(
    geom: &StrandGeometry,
    q: &[f64],
    arcs: impl IntoIterator<Item = f64>,
    out: &mut Vec<Vector3<f64>>,
) {
    out.clear();
    walk_sorted(geom, q, arcs, |start, _, p| {
        out.push(start.position + start.frame * p)
    });
}

/// Poses (position and material frame) at the arc lengths `arcs` (in increasing order;
/// each clamped to [0, L]), in head coordinates, into `out` (cleared first), in one pass
/// along the strand as [`positions_at_sorted`].
pub fn poses_at_sorted(
    geom: &StrandGeometry,
    q: &[f64],
    arcs: impl IntoIterator<Item = f64>,
    out: &mut Vec<Pose>,
) {
    out.clear();
    walk_sorted(geom, q, arcs, |start, e, p| {
        out.push(Pose {
            position: start.position + start.frame * p,
            frame: start.frame * e,
        })
    });
}

/// One pass along the strand: for each arc length of `arcs` (increasing), the pose of
/// its element's start and the local pose (E(u), P(u)) at it.
fn walk_sorted(
    geom: &StrandGeometry,
    q: &[f64],
    arcs: impl IntoIterator<Item = f64>,
    mut visit: impl FnMut(&Pose, &nalgebra::Matrix3<f64>, &Vector3<f64>),
) {
    let n = geom.lengths.len();
    let mut start = geom.root_pose(q);
    let (mut element, mut s0) = (0, 0.0);
    let mut d = darboux(q, 0);
    for s in arcs {
        while element + 1 < n && s > s0 + geom.lengths[element] {
            let (e, p) = local_pose(&d, geom.lengths[element]);
            start = Pose {
                position: start.position + start.frame * p,
                frame: start.frame * e,
            };
            s0 += geom.lengths[element];
            element += 1;
            d = darboux(q, element);
        }
        let u = (s - s0).clamp(0.0, geom.lengths[element]);
        let (e, p) = local_pose(&d, u);
        visit(&start, &e, &p);
    }
}

/// Centreline points: the root, then `per_element` equally spaced points in each
/// element (the last one at the element's end), in head coordinates.
pub fn sample_centreline(
    geom: &StrandGeometry,
    q: &[f64],
    per_element: usize,
    out: &mut Vec<Vector3<f64>>,
) {
    out.clear();
    out.push(geom.root_pose(q).position);
    let mut start = geom.root_pose(q);
    let per = per_element.max(1);
    for (k, &l) in geom.lengths.iter().enumerate() {
        let d = darboux(q, k);
        for j in 1..=per {
            let (_, p) = local_pose(&d, l * j as f64 / per as f64);
            out.push(start.position + start.frame * p);
        }
        let (e, p) = local_pose(&d, l);
        start = Pose {
            position: start.position + start.frame * p,
            frame: start.frame * e,
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::material::Material;
    use nalgebra::Rotation3;

    #[test]
    fn positions_in_one_pass_are_the_poses_chained_from_the_root() {
        let frame = *Rotation3::from_euler_angles(0.3, -0.2, 0.7).matrix();
        let geom = StrandGeometry::new(
            Vector3::new(0.01, -0.02, 0.1),
            frame,
            vec![0.03, 0.05, 0.02, 0.04],
            &Material {
                mass_per_length: 1e-7,
                stiffness: [1e-10, 1e-10, 1e-10],
                rotary_inertia: [1e-15, 1e-15, 1e-15],
            },
        );
        let q: Vec<f64> = (0..12).map(|i| 20.0 * ((i as f64) * 1.7).sin()).collect();
        // inside elements, at element ends (0.03, 0.08, 0.1) and beyond both ends
        let arcs = [
            -0.01, 0.0, 0.012, 0.03, 0.03, 0.05, 0.08, 0.0801, 0.1, 0.13, 0.14, 0.2,
        ];
        let mut out = Vec::new();
        positions_at_sorted(&geom, &q, arcs, &mut out);
        assert_eq!(out.len(), arcs.len());
        for (s, y) in arcs.iter().zip(&out) {
            let expected = pose_at(&geom, &q, *s).position;
            assert!(
                (y - expected).norm() < 1e-15,
                "s = {s}: {y:?} against {expected:?}"
            );
        }
    }
}

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
    ends[0] = Pose {
        position: geom.root_position,
        frame: geom.root_frame,
    };
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
    let mut pose = Pose {
        position: geom.root_position,
        frame: geom.root_frame,
    };
    for (k, &l) in geom.lengths.iter().enumerate().take(element + 1) {
        let (e, p) = local_pose(&darboux(q, k), if k == element { u } else { l });
        pose = Pose {
            position: pose.position + pose.frame * p,
            frame: pose.frame * e,
        };
    }
    pose
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
    out.push(geom.root_position);
    let mut start = Pose {
        position: geom.root_position,
        frame: geom.root_frame,
    };
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

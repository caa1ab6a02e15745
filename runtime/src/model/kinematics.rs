//! What a rod code reads off a strand besides its centreline: the whole material frame
//! (directors n0 = the tangent, n1, n2; section 3.1 of the Super-Helix paper) and the
//! velocity of the centreline, at any arc lengths.
//!
//! The velocity relative to the head is ẏ(s) = J(s) q̇, the derivative of the
//! reconstruction (equation (6) and appendix A) along q̇. It is taken here as the central
//! difference `(y(q + ε q̇) − y(q − ε q̇)) / 2ε` with ε q̇ turning an element by at most
//! 10⁻⁶ rad: its truncation error is ~10⁻¹² of the speed and its rounding error
//! ~10⁻¹⁰ (a test holds it to the closed form of a rigidly turning strand). In world
//! coordinates the head's motion is added: `ẋ = Ẋ + R (ω × y + ẏ)`.

use crate::model::reconstruction::{poses_at_sorted, positions_at_sorted, Pose};
use crate::model::strand::StrandGeometry;
use nalgebra::Vector3;
use superhelix_kernels::head::HeadState;

/// The largest rotation of an element the difference's step ε q̇ makes, rad.
const TURN: f64 = 1e-6;

/// The poses at `arcs` (increasing) in world coordinates with the head at `head`:
/// position and material frame (columns n0, n1, n2).
pub fn world_poses(geom: &StrandGeometry, q: &[f64], head: &HeadState, arcs: &[f64]) -> Vec<Pose> {
    let mut poses = Vec::with_capacity(arcs.len());
    poses_at_sorted(geom, q, arcs.iter().copied(), &mut poses);
    for p in &mut poses {
        p.position = head.position + head.rotation * p.position;
        p.frame = head.rotation * p.frame;
    }
    poses
}

/// ẏ(s) = J(s) q̇ at `arcs` (increasing), head coordinates, m/s (see the module page).
pub fn relative_velocities(
    geom: &StrandGeometry,
    q: &[f64],
    v: &[f64],
    arcs: &[f64],
) -> Vec<Vector3<f64>> {
    // ε such that ε |q̇_i| l_i ≤ TURN for every curvature or twist (a translation of a
    // free root moves by at most TURN · L)
    let chain = geom.chain_dofs();
    let length = geom.length();
    let largest = v
        .iter()
        .enumerate()
        .map(|(i, &vi)| {
            let scale = if i < chain {
                geom.lengths[i / 3]
            } else {
                1.0 / length
            };
            vi.abs() * scale
        })
        .fold(0.0_f64, f64::max);
    if largest == 0.0 {
        return vec![Vector3::zeros(); arcs.len()];
    }
    let eps = TURN / largest;
    let shifted = |sign: f64| -> Vec<Vector3<f64>> {
        let qs: Vec<f64> = q.iter().zip(v).map(|(a, b)| a + sign * eps * b).collect();
        let mut out = Vec::with_capacity(arcs.len());
        positions_at_sorted(geom, &qs, arcs.iter().copied(), &mut out);
        out
    };
    let (plus, minus) = (shifted(1.0), shifted(-1.0));
    plus.iter()
        .zip(&minus)
        .map(|(a, b)| (a - b) / (2.0 * eps))
        .collect()
}

/// The world velocity `Ẋ + R (ω × y + ẏ)` of the points `positions` (head coordinates)
/// whose velocities relative to the head are `relative`, with the head at `head`.
pub fn world_velocities(
    head: &HeadState,
    positions: &[Vector3<f64>],
    relative: &[Vector3<f64>],
) -> Vec<Vector3<f64>> {
    positions
        .iter()
        .zip(relative)
        .map(|(y, v)| head.velocity + head.rotation * (head.omega.cross(y) + v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::material::Material;
    use crate::model::reconstruction::pose_at;
    use nalgebra::Matrix3;

    fn geometry() -> StrandGeometry {
        StrandGeometry::new(
            Vector3::new(0.01, 0.0, 0.1),
            Matrix3::identity(),
            vec![0.05; 4],
            &Material {
                mass_per_length: 1e-7,
                stiffness: [1e-10, 1e-10, 1e-10],
                rotary_inertia: [1e-15, 1e-15, 1e-15],
            },
        )
    }

    #[test]
    fn the_velocity_is_the_derivative_of_the_reconstruction_along_qdot() {
        let geom = geometry();
        let q: Vec<f64> = (0..12).map(|i| 8.0 * ((i as f64) * 1.3).sin()).collect();
        let v: Vec<f64> = (0..12).map(|i| 30.0 * ((i as f64) * 0.7).cos()).collect();
        let arcs = [0.0, 0.03, 0.1, 0.17, 0.2];
        let got = relative_velocities(&geom, &q, &v, &arcs);
        // an independent estimate: Richardson-extrapolated differences in time of the
        // reconstruction at q + t q̇ (t = ±1e-4, ±2e-4 s)
        for (s, g) in arcs.iter().zip(&got) {
            let y = |t: f64| {
                let qt: Vec<f64> = q.iter().zip(&v).map(|(a, b)| a + t * b).collect();
                pose_at(&geom, &qt, *s).position
            };
            let d = |h: f64| (y(h) - y(-h)) / (2.0 * h);
            let expected = (4.0 * d(1e-4) - d(2e-4)) / 3.0;
            assert!(
                (g - expected).norm() <= 1e-7 * expected.norm().max(1e-3),
                "s = {s}: {g:?} against {expected:?}"
            );
        }
        assert_eq!(got[0], Vector3::zeros(), "a clamped root does not move");
    }

    #[test]
    fn a_head_turning_with_a_still_strand_moves_it_as_a_rigid_body() {
        let geom = geometry();
        let q = vec![0.0; 12];
        let head = HeadState {
            velocity: Vector3::new(0.0, 0.2, 0.0),
            omega: Vector3::new(0.0, 0.0, 3.0),
            ..HeadState::rest()
        };
        let arcs = [0.0, 0.2];
        let poses = world_poses(&geom, &q, &head, &arcs);
        let positions: Vec<_> = poses.iter().map(|p| p.position).collect();
        let relative = relative_velocities(&geom, &q, &q, &arcs);
        let v = world_velocities(&head, &positions, &relative);
        // the tip of the straight strand along x from (0.01, 0, 0.1): at x = 0.21
        let expected = Vector3::new(0.0, 0.2, 0.0)
            + Vector3::new(0.0, 0.0, 3.0).cross(&Vector3::new(0.21, 0.0, 0.1));
        assert!((v[1] - expected).norm() < 1e-15, "{:?}", v[1]);
    }
}

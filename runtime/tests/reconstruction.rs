//! Issue #2, point 1: the reconstruction is inextensible, its frames orthonormal, its
//! centreline C1 across elements, and uniform natural q gives the measured helix.

mod common;
use common::*;
use nalgebra::{Matrix3, Vector3};
use superhelix_runtime::model::material::{helix_curvature, HelixForm};
use superhelix_runtime::model::reconstruction::{pose_at, Pose};
use superhelix_runtime::model::strand::StrandGeometry;

const WL: [f64; 6] = [0.0, 1e-12, 1e-6, 1e-3, 1.0, 50.0];

/// Fourth-order central difference of the centreline position.
fn tangent_fd(g: &StrandGeometry, q: &[f64], s: f64, h: f64) -> Vector3<f64> {
    let p = |s: f64| pose_at(g, q, s).position;
    (-p(s + 2.0 * h) + p(s + h) * 8.0 - p(s - h) * 8.0 + p(s - 2.0 * h)) / (12.0 * h)
}

fn configurations() -> Vec<(StrandGeometry, Vec<f64>)> {
    let mut rng = Rng(0x5eed);
    let mut out = Vec::new();
    for n in [1, 2, 3, 6] {
        for rep in 0..4 {
            let g = geometry(n, 0.3, &mut rng);
            let mut q = q_with_wl(&g, &WL[rep..], &mut rng);
            if rep == 3 {
                // planar arcs: tau = 0
                for k in 0..n {
                    q[3 * k] = 0.0;
                }
            }
            out.push((g, q));
        }
    }
    out
}

#[test]
fn unit_speed_and_tangent_is_n0_everywhere() {
    for (g, q) in configurations() {
        let length = g.length();
        for j in 1..40 {
            let s = length * j as f64 / 40.0;
            let max_curv = (0..g.elements())
                .map(|k| Vector3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2]).norm())
                .fold(0.0, f64::max);
            // step small against the tightest curl so the difference formula is exact to ~1e-9
            let h = (1e-3 / (1.0 + max_curv)).min(1e-4);
            let (e, u) = g.locate(s);
            if u < 2.5 * h || u > g.lengths[e] - 2.5 * h {
                continue; // stay inside one element: the centreline is only C1 at joins
            }
            let t = tangent_fd(&g, &q, s, h);
            let pose = pose_at(&g, &q, s);
            assert!(
                (t.norm() - 1.0).abs() < 1e-8,
                "|r'| = {} at s = {s}",
                t.norm()
            );
            assert!((t - pose.frame.column(0)).norm() < 1e-8);
        }
    }
}

#[test]
fn frames_are_orthonormal_rotations() {
    for (g, q) in configurations() {
        for j in 0..=50 {
            let f = pose_at(&g, &q, g.length() * j as f64 / 50.0).frame;
            assert!((f.transpose() * f - Matrix3::identity()).norm() < 1e-13);
            assert!((f.determinant() - 1.0).abs() < 1e-13);
        }
    }
}

#[test]
fn centreline_and_frames_are_continuous_with_continuous_tangent_at_joins() {
    for (g, q) in configurations() {
        let mut s = 0.0;
        for k in 0..g.elements() - 1 {
            s += g.lengths[k];
            let eps = 1e-9;
            let a: Pose = pose_at(&g, &q, s - eps);
            let b: Pose = pose_at(&g, &q, s + eps);
            assert!((a.position - b.position).norm() < 3e-9);
            // the frame (hence the tangent) has no jump: it moves by O(eps |d|) only
            let dmax = Vector3::new(q[3 * k], q[3 * k + 1], q[3 * k + 2])
                .norm()
                .max(Vector3::new(q[3 * k + 3], q[3 * k + 4], q[3 * k + 5]).norm());
            assert!(
                (a.frame - b.frame).norm() < 4.0 * eps * (1.0 + dmax),
                "jump at join {k}"
            );
            // one-sided derivatives from both sides agree with the common tangent
            let h = 1e-6;
            let left = (a.position - pose_at(&g, &q, s - h).position) / (h - eps);
            let right = (pose_at(&g, &q, s + h).position - b.position) / (h - eps);
            let n0 = pose_at(&g, &q, s).frame.column(0).into_owned();
            assert!((left - n0).norm() < 1e-5 * (1.0 + dmax * 1e-3) + dmax * h);
            assert!((right - n0).norm() < 1e-5 * (1.0 + dmax * 1e-3) + dmax * h);
        }
    }
}

#[test]
fn uniform_natural_q_is_the_measured_helix() {
    // (helix radius, step): curly, wavy, fuzzy of appendix B
    for (radius, step) in [(0.006, 0.005), (0.01, 0.005), (0.001, 0.01)] {
        let turn = ((2.0 * std::f64::consts::PI * radius).powi(2) + step * step).sqrt();
        for n in [1, 3, 7] {
            let g = StrandGeometry {
                root_position: Vector3::zeros(),
                root_frame: rotation(Vector3::new(0.2, 0.4, -0.9)),
                lengths: vec![2.5 * turn / n as f64; n],
                mass_per_length: 1e-5,
                rotary_inertia: [0.0; 3],
                floating: false,
            };
            let d = helix_curvature(radius, step, HelixForm::Exact);
            let q: Vec<f64> = (0..n).flat_map(|_| d).collect();
            let x = |s: f64| pose_at(&g, &q, s).position;
            for s0 in [0.0, 0.3 * turn, 1.1 * turn] {
                let rise = x(s0 + turn) - x(s0);
                assert!(
                    (rise.norm() / step - 1.0).abs() < 1e-9,
                    "step {} vs {step}",
                    rise.norm()
                );
                let axis = rise.normalize();
                let half = x(s0 + 0.5 * turn) - x(s0);
                let across = half - axis * half.dot(&axis);
                assert!(
                    (0.5 * across.norm() / radius - 1.0).abs() < 1e-9,
                    "radius {}",
                    0.5 * across.norm()
                );
                // the distance from the axis is the radius everywhere in between
                let centre = x(s0) + across * 0.5;
                for j in 1..8 {
                    let r = x(s0 + turn * j as f64 / 8.0) - centre;
                    let radial = r - axis * r.dot(&axis);
                    assert!((radial.norm() / radius - 1.0).abs() < 1e-9);
                }
            }
        }
    }
}

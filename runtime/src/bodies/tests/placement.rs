//! Bodies on the head move with it; bodies in the world stay; bodies on their own motion
//! are where their motion is at the time asked.

use super::{build_one, mesh_setup, temp_dir, write_obj};
use crate::bodies::motion::{HeadMotion, Keyframe};
use crate::bodies::setup::Attachment;
use crate::bodies::{Bodies, BodySetup, Placement, ShapeSetup};
use nalgebra::{Matrix3, Rotation3, Vector3};
use superhelix_kernels::head::HeadState;

/// The head turned by `angle` about a tilted axis through a pivot, and shifted.
fn head_at(angle: f64, shift: f64) -> HeadState {
    let rotation = Rotation3::new(Vector3::new(1.0, 1.0, 0.0).normalize() * angle).into_inner();
    let pivot = Vector3::new(0.0, 0.02, -0.1);
    HeadState {
        position: pivot - rotation * pivot + Vector3::new(shift, 0.0, 0.0),
        rotation,
        ..HeadState::rest()
    }
}

fn sphere(attached: Attachment) -> BodySetup {
    BodySetup {
        name: "ball".into(),
        attached,
        shape: ShapeSetup::Sphere {
            center: Vector3::new(0.0, 0.0, 0.08),
            radius: 0.09,
        },
    }
}

#[test]
fn a_body_on_the_head_moves_with_it_and_a_body_in_the_world_does_not() {
    let bodies = match Bodies::build(&[sphere(Attachment::Head), sphere(Attachment::World)]) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    let x = Vector3::new(0.05, -0.12, 0.1);
    let rest = bodies.at(HeadState::rest(), 0.0).query(0, &x).distance;
    for (angle, shift) in [(0.2, 0.0), (0.0, 0.03), (-0.5, 0.01)] {
        let head = head_at(angle, shift);
        let placed = bodies.at(head, 0.0);
        let on_head = placed.query(0, &x);
        // the world point in head coordinates, against the sphere there
        let y = head.rotation.transpose() * (x - head.position);
        let want = (y - Vector3::new(0.0, 0.0, 0.08)).norm() - 0.09;
        assert!((on_head.distance - want).abs() < 1e-15, "{angle} {shift}");
        assert!((on_head.distance - rest).abs() > 1e-3, "the head moved");
        let centre = head.to_world(&Vector3::new(0.0, 0.0, 0.08));
        assert!((on_head.normal - (x - centre).normalize()).norm() < 1e-14);
        assert!(((on_head.closest - centre).norm() - 0.09).abs() < 1e-15);
        let fixed = placed.query(1, &x);
        assert_eq!(
            fixed.distance,
            (x - Vector3::new(0.0, 0.0, 0.08)).norm() - 0.09
        );
        // the nearest body is the one with the smaller signed distance
        let (i, p) = placed.nearest(&x).unwrap_or_else(|| panic!("two bodies"));
        assert_eq!(p.distance, on_head.distance.min(fixed.distance));
        assert_eq!(i, usize::from(fixed.distance < on_head.distance));
    }
}

/// A ball keyframed from x = 0 (t = 0) to x = 0.2 m turned 90° about z (t = 1): at every
/// time it is where its motion puts it, whatever the head does; its frame's velocity is
/// the motion's (zero when placed at rest); the head's state does not move it.
#[test]
fn a_body_on_its_own_motion_is_where_its_motion_is_at_the_time_asked() {
    let keys = vec![
        Keyframe {
            t: 0.0,
            position: Vector3::zeros(),
            rotation: Vector3::zeros(),
        },
        Keyframe {
            t: 1.0,
            position: Vector3::new(0.2, 0.0, 0.0),
            rotation: Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2),
        },
    ];
    let motion = HeadMotion::keyframes(keys).unwrap_or_else(|e| panic!("{e}"));
    let bodies = match Bodies::build(&[sphere(Attachment::Motion(motion.clone()))]) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    assert!(bodies.any_motion());
    let x = Vector3::new(0.1, 0.05, 0.1);
    for t in [0.0, 0.3, 0.5, 1.0, 2.0] {
        let state = motion.state(t);
        for head in [HeadState::rest(), head_at(0.4, 0.02)] {
            let placed = bodies.at(head, t);
            let got = placed.query(0, &x);
            let centre = state.position + state.rotation * Vector3::new(0.0, 0.0, 0.08);
            assert!(
                ((x - centre).norm() - 0.09 - got.distance).abs() < 1e-15,
                "t = {t}"
            );
            assert!((got.normal - (x - centre).normalize()).norm() < 1e-14);
            let frame = placed.frame(0).unwrap_or_else(|| panic!("a moving frame"));
            assert_eq!(frame.velocity, state.velocity);
            assert_eq!(frame.omega, state.omega);
        }
        let rest = bodies.as_slice()[0].frame(&Placement::at_rest(t));
        let rest = rest.unwrap_or_else(|| panic!("a moving frame"));
        assert_eq!(rest.position, state.position);
        assert_eq!(rest.velocity, Vector3::zeros());
        assert_eq!(rest.omega, Vector3::zeros());
    }
    // halfway the ball moves (the clamped spline's peak speed is 1.5 × 0.2 m / 1 s)
    let mid = bodies.at(HeadState::rest(), 0.5).frame(0);
    let v = mid.map_or(0.0, |f| f.velocity.x);
    assert!((v - 0.3).abs() < 1e-12, "{v}");
}

#[test]
fn a_mesh_on_the_head_answers_for_the_transformed_point() {
    let dir = temp_dir("placement");
    // a tetrahedron
    let vertices: Vec<Vector3<f64>> = [
        [0.0, 0.0, 0.0],
        [0.1, 0.0, 0.0],
        [0.0, 0.1, 0.0],
        [0.0, 0.0, 0.1],
    ]
    .iter()
    .map(|p| Vector3::new(p[0], p[1], p[2]))
    .collect();
    let triangles = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    let path = write_obj(&dir, "tetra.obj", &vertices, &triangles);
    let mut setup = mesh_setup(path, Some(0.004));
    setup.attached = Attachment::Head;
    let body = build_one(setup);
    let head = HeadState {
        position: Vector3::new(0.3, -0.2, 0.1),
        rotation: Rotation3::new(Vector3::new(0.4, 0.1, -0.7)).into_inner(),
        ..HeadState::rest()
    };
    let mut u = super::Uniform(12);
    for _ in 0..200 {
        let y = u.point(0.15);
        let x = head.to_world(&y);
        let moved = body.query(&Placement::new(head, 0.0), &x);
        let local = body.query(&Default::default(), &y);
        assert!((moved.distance - local.distance).abs() < 1e-12);
        assert!((moved.normal - head.rotation * local.normal).norm() < 1e-12);
        assert!((moved.closest - head.to_world(&local.closest)).norm() < 1e-12);
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn mesh_placement_scales_rotates_and_translates_the_file() {
    let dir = temp_dir("scaled");
    let vertices: Vec<Vector3<f64>> = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vector3::new(p[0], p[1], p[2]))
    .collect();
    let path = write_obj(
        &dir,
        "tetra.obj",
        &vertices,
        &[[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
    );
    let rotation: Matrix3<f64> =
        Rotation3::new(Vector3::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)).into_inner();
    let translation = Vector3::new(1.0, 2.0, 3.0);
    let mut setup = mesh_setup(path, Some(0.002));
    setup.shape = match setup.shape {
        ShapeSetup::Mesh { path, cell, .. } => ShapeSetup::Mesh {
            path,
            cell,
            scale: 0.1,
            rotation,
            translation,
        },
        other => other,
    };
    let body = build_one(setup);
    // the file's vertex (1, 0, 0) is at translation + R (0.1, 0, 0) = (1, 2.1, 3); just
    // beyond it along the same direction the distance is the gap
    let tip = translation + Vector3::new(0.0, 0.1, 0.0);
    let x = tip + Vector3::new(0.0, 0.01, 0.0);
    let d = body.query(&Default::default(), &x).distance;
    assert!((d - 0.01).abs() < 2e-3, "{d}");
    assert!(
        body.query(
            &Default::default(),
            &(translation + Vector3::new(-0.01, 0.01, 0.01))
        )
        .distance
            < 0.0
    );
    let _ = std::fs::remove_dir_all(dir);
}

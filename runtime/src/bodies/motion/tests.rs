use super::*;
use nalgebra::Matrix3;

const H: f64 = 1e-5;

fn key(t: f64, position: [f64; 3], rotation: [f64; 3]) -> Keyframe {
    Keyframe {
        t,
        position: Vector3::from(position),
        rotation: Vector3::from(rotation),
    }
}

fn keyframed() -> HeadMotion {
    let keys = vec![
        key(0.0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]),
        key(0.3, [0.01, -0.02, 0.0], [0.2, -0.1, 0.4]),
        key(0.7, [0.03, 0.0, 0.01], [-0.5, 0.8, 0.1]),
        key(1.0, [0.0, 0.01, 0.0], [0.0, 0.0, 0.0]),
        key(1.4, [0.0, 0.0, 0.02], [1.5, 1.0, -2.0]),
    ];
    HeadMotion::keyframes(keys).expect("valid keys")
}

/// Name, motion, times to test at, and the scale of its derivatives.
fn motions() -> Vec<(&'static str, HeadMotion, Vec<f64>, f64)> {
    let axis = Vector3::new(1.0, 2.0, -0.5).normalize();
    vec![
        (
            "oscillate",
            HeadMotion::Oscillate {
                axis,
                amplitude: 0.5,
                frequency_hz: 2.0,
                center: Vector3::new(0.02, -0.1, 0.05),
            },
            vec![0.0, 0.13, 0.41, 0.77],
            1.0,
        ),
        (
            "translate",
            HeadMotion::TranslateOscillate {
                direction: axis,
                amplitude: 0.03,
                frequency_hz: 1.5,
            },
            vec![0.0, 0.2, 0.55],
            1.0,
        ),
        (
            "keyframes",
            keyframed(),
            vec![0.05, 0.2, 0.31, 0.5, 0.85, 1.2, 1.39],
            1.0,
        ),
        (
            "sudden-stop",
            HeadMotion::SuddenStop {
                axis,
                angular_speed: 3.0,
                stop_time: 0.5,
                stop_duration: 0.2,
                center: Vector3::new(0.0, 0.1, 0.0),
            },
            vec![0.1, 0.55, 0.62, 0.69, 1.0],
            3.0,
        ),
        (
            "jolt",
            HeadMotion::Jolt {
                direction: axis,
                acceleration: 20.0,
                start: 0.1,
                duration: 0.05,
            },
            vec![0.0, 0.11, 0.125, 0.149, 0.3],
            20.0,
        ),
    ]
}

/// `|got − want| <= tol · max(|want|, scale)`.
fn close(got: &Vector3<f64>, want: &Vector3<f64>, scale: f64, what: &str) {
    let err = (got - want).norm();
    assert!(
        err <= 1e-6 * want.norm().max(scale),
        "{what}: got {got:?}, finite differences {want:?}"
    );
}

fn vee(m: &Matrix3<f64>) -> Vector3<f64> {
    0.5 * Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
}

#[test]
fn rotation_is_orthonormal() {
    for (name, motion, times, _) in motions() {
        for t in times {
            let r = motion.state(t).rotation;
            assert!(
                (r.transpose() * r - Matrix3::identity()).norm() < 1e-13,
                "{name} at {t}"
            );
            assert!((r.determinant() - 1.0).abs() < 1e-13, "{name} at {t}");
        }
    }
}

#[test]
fn derivatives_match_central_differences() {
    for (name, motion, times, scale) in motions() {
        for t in times {
            let (s, prev, next) = (motion.state(t), motion.state(t - H), motion.state(t + H));
            let d = |a: Vector3<f64>, b: Vector3<f64>| (b - a) / (2.0 * H);
            let r_dot = (next.rotation - prev.rotation) / (2.0 * H);
            let omega_fd = vee(&(s.rotation.transpose() * r_dot));
            close(&s.omega, &omega_fd, scale, &format!("{name} omega at {t}"));
            close(
                &s.alpha,
                &d(prev.omega, next.omega),
                scale,
                &format!("{name} alpha at {t}"),
            );
            close(
                &s.velocity,
                &d(prev.position, next.position),
                scale,
                &format!("{name} velocity at {t}"),
            );
            close(
                &s.acceleration,
                &d(prev.velocity, next.velocity),
                scale,
                &format!("{name} acceleration at {t}"),
            );
        }
    }
}

#[test]
fn keyframes_pass_through_the_keys_and_hold_outside() {
    let motion = keyframed();
    let HeadMotion::Keyframes(track) = &motion else {
        unreachable!()
    };
    for k in track.keys() {
        let s = motion.state(k.t);
        assert!((s.position - k.position).norm() < 1e-14);
        assert!((s.rotation - so3::exp(&k.rotation)).norm() < 1e-14);
    }
    for t in [-1.0, 1.4, 3.0] {
        let s = motion.state(t);
        assert_eq!(s.omega, Vector3::zeros());
        assert_eq!(s.velocity, Vector3::zeros());
    }
    assert_eq!(motion.state(-1.0).rotation, Matrix3::identity());
}

#[test]
fn keyframes_through_zero_rotation_have_no_nan() {
    let keys = vec![key(0.0, [0.0; 3], [0.0; 3]), key(1.0, [0.0; 3], [0.0; 3])];
    let motion = HeadMotion::keyframes(keys).expect("valid keys");
    let s = motion.state(0.5);
    assert_eq!(s.omega, Vector3::zeros());
    assert_eq!(s.alpha, Vector3::zeros());
    // A pure rotation about one axis passing through φ = 0 mid-interval.
    let keys = vec![
        key(0.0, [0.0; 3], [-0.3, 0.0, 0.0]),
        key(1.0, [0.0; 3], [0.3, 0.0, 0.0]),
    ];
    let motion = HeadMotion::keyframes(keys).expect("valid keys");
    let s = motion.state(0.5);
    assert!(s.alpha.iter().chain(s.omega.iter()).all(|v| v.is_finite()));
    assert!((s.omega.x - 0.9).abs() < 1e-12, "{:?}", s.omega); // φ̇ = 1.5·0.6 at mid-time
}

#[test]
fn keyframes_reject_unordered_times() {
    let keys = vec![key(0.0, [0.0; 3], [0.0; 3]), key(0.0, [0.0; 3], [0.0; 3])];
    let err = HeadMotion::keyframes(keys).unwrap_err();
    assert_eq!(err.field, "keys[1].t");
    assert!(HeadMotion::keyframes(vec![]).is_err());
}

#[test]
fn sudden_stop_ends_at_rest_and_jolt_ends_at_constant_speed() {
    let axis = Vector3::z();
    let stop = HeadMotion::SuddenStop {
        axis,
        angular_speed: 2.0,
        stop_time: 1.0,
        stop_duration: 0.5,
        center: Vector3::zeros(),
    };
    assert_eq!(stop.state(0.5).omega, Vector3::new(0.0, 0.0, 2.0));
    assert_eq!(stop.state(2.0).omega, Vector3::zeros());
    let jolt = HeadMotion::Jolt {
        direction: axis,
        acceleration: 10.0,
        start: 0.0,
        duration: 0.1,
    };
    assert!((jolt.state(0.05).acceleration.z - 10.0).abs() < 1e-12);
    assert!((jolt.state(1.0).velocity.z - 0.5).abs() < 1e-12);
    assert_eq!(jolt.state(1.0).acceleration, Vector3::zeros());
}

#[test]
fn oscillation_keeps_the_pivot_fixed() {
    let center = Vector3::new(0.0, 0.0, 0.1);
    let motion = HeadMotion::Oscillate {
        axis: Vector3::x(),
        amplitude: 0.5,
        frequency_hz: 2.0,
        center,
    };
    let s = motion.state(0.1);
    assert!((s.to_world(&center) - center).norm() < 1e-15);
}

#[test]
fn uniform_over_is_true_exactly_where_the_head_frame_is_inertial() {
    // every motion: where `uniform_over` says so, ω, α and Ẍ vanish and Ẋ is constant at
    // every sampled time of the interval; where it does not, some sample moves non-uniformly
    let mut all = motions();
    all.push(("still", HeadMotion::Still, vec![], 1.0));
    for (name, motion, _, _) in all {
        let mut uniform_seen = false;
        for i in 0..40 {
            let (t0, t1) = (0.05 * i as f64, 0.05 * (i + 1) as f64);
            let samples: Vec<HeadState> = (0..=50)
                .map(|k| motion.state(t0 + (t1 - t0) * k as f64 / 50.0))
                .collect();
            let inertial = samples.iter().all(|s| {
                s.omega == Vector3::zeros()
                    && s.alpha == Vector3::zeros()
                    && s.acceleration == Vector3::zeros()
                    && s.velocity == samples[0].velocity
            });
            assert_eq!(
                motion.uniform_over(t0, t1),
                inertial,
                "{name} over [{t0}, {t1}]"
            );
            uniform_seen |= inertial;
        }
        let moving_throughout = matches!(
            motion,
            HeadMotion::Oscillate { .. } | HeadMotion::TranslateOscillate { .. }
        );
        assert_eq!(uniform_seen, !moving_throughout, "{name}");
    }
    // a jolt within one interval, and degenerate motions
    let jolt = HeadMotion::Jolt {
        direction: Vector3::x(),
        acceleration: 5.0,
        start: 0.1,
        duration: 0.01,
    };
    assert!(!jolt.uniform_over(0.0, 1.0));
    assert!(jolt.uniform_over(0.0, 0.1) && jolt.uniform_over(0.11, 1.0));
    let resting = HeadMotion::Oscillate {
        axis: Vector3::z(),
        amplitude: 0.0,
        frequency_hz: 3.0,
        center: Vector3::zeros(),
    };
    assert!(resting.uniform_over(0.0, 1.0));
}

#[test]
fn phase_changes_are_where_uniform_over_changes() {
    // every motion: on a fine grid, `uniform_over` of the cells on either side of a time
    // differs exactly where `phase_change` puts a change, and a change is reported for
    // an interval exactly when one lies strictly inside it
    let mut all = motions();
    all.push(("still", HeadMotion::Still, vec![], 1.0));
    let jolt = HeadMotion::Jolt {
        direction: Vector3::x(),
        acceleration: 5.0,
        start: 0.1,
        duration: 0.01,
    };
    all.push(("short jolt", jolt.clone(), vec![], 1.0));
    let cell = 1e-3;
    for (name, motion, _, _) in all {
        let mut changes = Vec::new();
        let mut t = 0.0;
        while t < 2.0 {
            if let Some(b) = motion.phase_change(t, t + 0.25) {
                assert!(
                    b > t && b < t + 0.25,
                    "{name}: {b} outside ({t}, {})",
                    t + 0.25
                );
                // nothing earlier inside
                assert_eq!(motion.phase_change(t, b), None, "{name}");
                changes.push(b);
                t = b;
            } else {
                t += 0.25;
            }
        }
        for &b in &changes {
            let before = motion.uniform_over(b - cell, b);
            let after = motion.uniform_over(b, b + cell);
            assert_ne!(before, after, "{name}: no change of phase at {b}");
        }
        // between the changes the phase holds
        let mut edges = vec![0.0];
        edges.extend(&changes);
        edges.push(2.0);
        for w in edges.windows(2) {
            let (a, b) = (w[0], w[1]);
            let phase = motion.uniform_over(a, a + cell);
            let mut t = a;
            while t + cell < b {
                assert_eq!(motion.uniform_over(t, t + cell), phase, "{name} at {t}");
                t += cell;
            }
        }
        let expected = match &motion {
            HeadMotion::Jolt { .. } => 2,
            HeadMotion::SuddenStop { .. } => 1,
            HeadMotion::Keyframes(track) => {
                let keys = track.keys();
                usize::from(keys.first().is_some_and(|k| k.t > 0.0)) + usize::from(!keys.is_empty())
            }
            _ => 0,
        };
        assert_eq!(changes.len(), expected, "{name}: {changes:?}");
    }
    assert_eq!(jolt.phase_change(0.0, 1.0), Some(0.1));
    assert_eq!(jolt.phase_change(0.1, 1.0), Some(0.11));
    assert_eq!(jolt.phase_change(0.11, 1.0), None);
}

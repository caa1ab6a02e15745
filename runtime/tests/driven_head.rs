//! A head driven by the caller between steps (`Simulation::set_head`): given the state
//! of a motion the scene can also describe, the steps are the scene's; a pose that
//! jumps carries the strands with it; a saved simulation keeps the driven head.

use superhelix_runtime::{parse_scene, HeadState, Matrix3, Simulation, Vector3};

/// Two strands of different N on a head given by `head` (a `[head]` table's motion),
/// gravity, the presets' drag and friction.
fn scene(engine: &str, head: &str) -> String {
    format!(
        r#"
[simulation]
dt = 0.005
engine = "{engine}"

[environment]
gravity = [0.0, 0.0, -9.81]

[head]
motion = {head}

[[strands]]
name = "curly"
root = [0.09, 0.0, 0.0]
direction = [1.0, 0.0, -1.0]
length = 0.2
elements = 5
preset = "curly"

[[strands]]
name = "wavy"
root = [0.0, 0.09, 0.0]
direction = [0.0, 1.0, -1.0]
length = 0.25
elements = 8
preset = "wavy"
"#
    )
}

const SPIN: f64 = std::f64::consts::FRAC_PI_2; // rad/s, about z

fn simulation(text: &str) -> Simulation {
    Simulation::new(parse_scene(text).expect("scene"), None).expect("simulation")
}

/// The head turning about z through the origin at SPIN, at time t: the scene's
/// `sudden-stop` before its stop.
fn turning(t: f64) -> HeadState {
    let (s, c) = (SPIN * t).sin_cos();
    HeadState {
        position: Vector3::zeros(),
        rotation: Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
        velocity: Vector3::zeros(),
        acceleration: Vector3::zeros(),
        omega: Vector3::new(0.0, 0.0, SPIN),
        alpha: Vector3::zeros(),
    }
}

/// The largest |Δq| between the two strands of two simulations, relative to the larger
/// of 1 and the strand's largest |q| in `a`.
fn q_apart(a: &Simulation, b: &Simulation) -> f64 {
    (0..2)
        .map(|i| {
            let scale = a.q(i).iter().fold(1.0f64, |m, x| m.max(x.abs()));
            a.q(i)
                .iter()
                .zip(b.q(i))
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs() / scale))
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_head_driven_by_the_caller_steps_as_the_scenes_own_motion() {
    // the scene's head turning at 90°/s (a sudden stop long after the run) against a still
    // scene whose head the caller drives with the same motion: once at t = 0 (the
    // extrapolation of a constant ω is that turn), or before every step with its state
    // then. The steps differ only by the rounding of the two ways of forming R(t).
    let turn = "{ kind = \"sudden-stop\", axis = [0.0, 0.0, 1.0], angular_speed_deg = 90.0, stop_time = 100.0, stop_duration = 1.0 }";
    for engine in ["runtime", "embedded"] {
        let mut scene_driven = simulation(&scene(engine, turn));
        let mut once = simulation(&scene(engine, "{ kind = \"still\" }"));
        let mut each = simulation(&scene(engine, "{ kind = \"still\" }"));
        once.set_head(turning(0.0), Some(0.0)).expect("head");
        for _ in 0..100 {
            each.set_head(turning(each.time()), None).expect("head");
            scene_driven.step().expect("step");
            once.step().expect("step");
            each.step().expect("step");
        }
        // the strands moved with the head: the comparison is not of strands at rest
        assert!(
            scene_driven.max_speed() > 1e-2,
            "{engine}: {}",
            scene_driven.max_speed()
        );
        for (name, driven) in [("once", &once), ("each step", &each)] {
            let apart = q_apart(&scene_driven, driven);
            assert!(apart < 1e-12, "{engine}, {name}: {apart:e}");
            let (a, b) = (scene_driven.head_state(), driven.head_state());
            assert!(
                (a.rotation - b.rotation).abs().max() < 1e-12,
                "{engine}, {name}"
            );
        }
        // a still head is not the turning one: the comparison can fail
        let mut still = simulation(&scene(engine, "{ kind = \"still\" }"));
        for _ in 0..100 {
            still.step().expect("step");
        }
        assert!(q_apart(&scene_driven, &still) > 1e-4, "{engine}");
    }
}

#[test]
fn a_head_pose_that_jumps_carries_the_strands_with_it() {
    // the head moved 1 m along x and turned a quarter about z between two steps: the
    // strands' coordinates are the head's, so their world nodes move rigidly with it
    let mut sim = simulation(&scene("runtime", "{ kind = \"still\" }"));
    for _ in 0..10 {
        sim.step().expect("step");
    }
    let before = sim.poses_world(0, &[0.0, 0.1, 0.2]);
    let mut moved = turning(1.0); // R: a quarter turn about z
    moved.position = Vector3::new(1.0, 0.0, 0.0);
    moved.omega = Vector3::zeros();
    sim.set_head(moved, None).expect("head");
    let after = sim.poses_world(0, &[0.0, 0.1, 0.2]);
    for (b, a) in before.iter().zip(&after) {
        let expected = moved.position + moved.rotation * b.position;
        assert!(
            (a.position - expected).norm() < 1e-14,
            "{a:?} against {expected}"
        );
    }
    sim.step().expect("a step after the jump");
}

#[test]
fn a_driven_head_is_refused_out_of_range_and_kept_by_a_save() {
    let mut sim = simulation(&scene("embedded", "{ kind = \"still\" }"));
    let mut bad = turning(0.0);
    bad.rotation[(0, 0)] = 2.0;
    let e = sim
        .set_head(bad, None)
        .expect_err("not a rotation")
        .to_string();
    assert!(e.contains("rotation"), "{e}");
    let mut bad = turning(0.0);
    bad.velocity[1] = f64::NAN;
    let e = sim.set_head(bad, None).expect_err("NaN").to_string();
    assert!(e.contains("velocity"), "{e}");
    let e = sim
        .set_head(turning(0.0), Some(f64::INFINITY))
        .expect_err("time")
        .to_string();
    assert!(e.contains("time"), "{e}");
    // a save and a restore go on as the driven simulation does
    sim.set_head(turning(0.0), None).expect("head");
    for _ in 0..5 {
        sim.step().expect("step");
    }
    let saved = sim.state();
    let mut back = simulation(&scene("embedded", "{ kind = \"still\" }"));
    back.restore(saved).expect("restore");
    for _ in 0..5 {
        sim.step().expect("step");
        back.step().expect("step");
    }
    assert_eq!(q_apart(&sim, &back), 0.0);
    assert_eq!(sim.head_state().rotation, back.head_state().rotation);
}

//! The `[head]` table: the rigid motion of every root; and the same motion table read for
//! a body on its own motion (`[bodies.motion]`).

use super::reader::{Bound, Node, Range};
use crate::forces::head_motion::{HeadMotion, Keyframe};
use nalgebra::Vector3;

/// Motion kinds as written in scenes.
const KINDS: [&str; 6] = [
    "still",
    "oscillate",
    "translate-oscillate",
    "keyframes",
    "sudden-stop",
    "jolt",
];

/// Angles of oscillation, degrees.
const ANGLE_DEG: Range = Range::new(Bound::Incl(0.0), Bound::Incl(180.0));
/// Head frequencies, Hz: beyond 50 Hz a head motion is meaningless for hair.
const FREQUENCY_HZ: Range = Range::new(Bound::Incl(0.0), Bound::Incl(50.0));
/// Peak accelerations, m/s²: up to 1000 g.
const ACCELERATION: Range = Range::new(Bound::Incl(0.0), Bound::Incl(1e4));
/// Angular speeds, degrees per second: up to 100 turns a second.
const ANGULAR_SPEED_DEG: Range = Range::new(Bound::Incl(0.0), Bound::Incl(36000.0));
/// Keyframe rotations (axis times angle), degrees per component: a hundred turns.
const ROTATION_DEG: Range = Range::new(Bound::Incl(-36000.0), Bound::Incl(36000.0));

/// The head motion of a `[head]` table (`Still` when absent or invalid; problems are
/// recorded).
pub(super) fn read_head(head: Option<Node<'_>>) -> HeadMotion {
    let Some(mut head) = head else {
        return HeadMotion::Still;
    };
    let motion = head
        .table("motion")
        .and_then(read_motion)
        .unwrap_or_default();
    head.finish();
    motion
}

/// The rigid motion of a motion table (`[head.motion]`, `[bodies.motion]`): `kind` and
/// the fields of that kind. `None` when invalid (problems are recorded).
pub(super) fn read_motion(mut m: Node<'_>) -> Option<HeadMotion> {
    let what = format!("one of {}", KINDS.join(", "));
    let kind = m.required("kind", &what, |m, k| {
        m.choice(k, &KINDS, |name| KINDS.iter().position(|&n| n == name))
    });
    let motion = match kind {
        Some(0) => Some(HeadMotion::Still),
        Some(1) => oscillate(&mut m),
        Some(2) => translate_oscillate(&mut m),
        Some(3) => keyframes(&mut m),
        Some(4) => sudden_stop(&mut m),
        Some(5) => jolt(&mut m),
        _ => None,
    };
    // With an unknown kind the other fields cannot be checked: do not call them unknown.
    if kind.is_some() {
        m.finish();
    }
    motion
}

fn center(m: &mut Node<'_>) -> Option<Vector3<f64>> {
    m.optional("center", Vector3::zeros(), Node::position)
}

fn frequency(m: &mut Node<'_>) -> Option<f64> {
    m.required_f64("frequency_hz", "frequency in Hz", FREQUENCY_HZ)
}

fn unit_vector(m: &mut Node<'_>, key: &'static str) -> Option<Vector3<f64>> {
    m.required(key, "a non-zero 3-vector", Node::unit)
}

fn oscillate(m: &mut Node<'_>) -> Option<HeadMotion> {
    let axis = unit_vector(m, "axis");
    let angle = m.required_f64("angle_deg", "amplitude in degrees", ANGLE_DEG);
    let frequency_hz = frequency(m);
    let center = center(m);
    Some(HeadMotion::Oscillate {
        axis: axis?,
        amplitude: angle?.to_radians(),
        frequency_hz: frequency_hz?,
        center: center?,
    })
}

fn translate_oscillate(m: &mut Node<'_>) -> Option<HeadMotion> {
    let direction = unit_vector(m, "direction");
    let amplitude = m.required_f64("amplitude", "amplitude in metres", Range::LENGTH);
    let frequency_hz = frequency(m);
    Some(HeadMotion::TranslateOscillate {
        direction: direction?,
        amplitude: amplitude?,
        frequency_hz: frequency_hz?,
    })
}

fn sudden_stop(m: &mut Node<'_>) -> Option<HeadMotion> {
    let axis = unit_vector(m, "axis");
    let speed = m.required_f64(
        "angular_speed_deg",
        "angular speed in degrees per second",
        ANGULAR_SPEED_DEG,
    );
    let stop_time = m.required_f64("stop_time", "time in s", Range::TIME_FROM_START);
    let stop_duration = m.required_f64("stop_duration", "duration in s", Range::DURATION);
    let center = center(m);
    Some(HeadMotion::SuddenStop {
        axis: axis?,
        angular_speed: speed?.to_radians(),
        stop_time: stop_time?,
        stop_duration: stop_duration?,
        center: center?,
    })
}

fn jolt(m: &mut Node<'_>) -> Option<HeadMotion> {
    let direction = unit_vector(m, "direction");
    let acceleration = m.required_f64("acceleration", "peak acceleration in m/s^2", ACCELERATION);
    let start = m.required_f64("start", "time in s", Range::TIME_FROM_START);
    let duration = m.required_f64("duration", "duration in s", Range::DURATION);
    Some(HeadMotion::Jolt {
        direction: direction?,
        acceleration: acceleration?,
        start: start?,
        duration: duration?,
    })
}

fn keyframes(m: &mut Node<'_>) -> Option<HeadMotion> {
    if !m.has("keys") {
        return m.missing("keys", "a list of { t, position, rotation_axis_angle_deg }");
    }
    let nodes = m.tables("keys");
    let keys: Vec<Option<Keyframe>> = nodes.into_iter().map(read_key).collect();
    let keys: Vec<Keyframe> = keys.into_iter().collect::<Option<_>>()?;
    match HeadMotion::keyframes(keys) {
        Ok(motion) => Some(motion),
        Err(e) => {
            m.error(&e.field, e.message);
            None
        }
    }
}

fn read_key(mut k: Node<'_>) -> Option<Keyframe> {
    let t = k.required_f64("t", "time in s", Range::TIME);
    let position = k.optional("position", Vector3::zeros(), Node::position);
    let rotation = k.optional("rotation_axis_angle_deg", Vector3::zeros(), |k, key| {
        k.vec3_in(key, ROTATION_DEG)
    });
    k.finish();
    Some(Keyframe {
        t: t?,
        position: position?,
        rotation: rotation? * 1f64.to_radians(),
    })
}

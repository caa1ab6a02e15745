//! Rigid motion of the head, i.e. of every strand root, and of a body on its own motion
//! ([`super::Attachment::Motion`]); `crate::forces::head_motion` names the same module.
//!
//! A point with head (or body) coordinates `y` is at `x = X(t) + R(t) y` in the world. The head's
//! state at time t ([`HeadState`]) carries X, R and the derivatives the equations of
//! motion need: `Ẋ`, `Ẍ` in world coordinates, and the angular velocity ω and angular
//! acceleration α = dω/dt in head coordinates (`Ṙ = R [ω]×`).

pub(crate) mod so3;
mod spline;

use crate::error::FieldError;
use nalgebra::{Vector3, Vector6};
use spline::ClampedSpline;
use std::f64::consts::PI;

pub use superhelix_kernels::head::HeadState;

/// One key of a keyframed head motion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    /// Time, seconds.
    pub t: f64,
    /// X at that time, metres.
    pub position: Vector3<f64>,
    /// Orientation as a rotation vector φ (axis times angle, radians): `R = exp([φ]×)`.
    pub rotation: Vector3<f64>,
}

/// A keyframed head motion: position and rotation vector are each interpolated by a C2
/// clamped cubic spline in time (zero velocity at the first and last key), and held
/// constant before the first key and after the last.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyframeTrack {
    keys: Vec<Keyframe>,
    spline: ClampedSpline<6>,
}

impl KeyframeTrack {
    /// The track through `keys`. Errors (with a field path relative to the key list,
    /// e.g. `keys[2].t`) when there is no key, a value is not finite, or the times are not
    /// strictly increasing.
    pub fn new(keys: Vec<Keyframe>) -> Result<Self, FieldError> {
        if keys.is_empty() {
            return Err(FieldError::new("keys", "needs at least one key"));
        }
        for (i, k) in keys.iter().enumerate() {
            let finite = k.t.is_finite()
                && k.position.iter().all(|v| v.is_finite())
                && k.rotation.iter().all(|v| v.is_finite());
            if !finite {
                return Err(FieldError::new(
                    format!("keys[{i}]"),
                    "values must be finite",
                ));
            }
            if i > 0 && k.t <= keys[i - 1].t {
                let msg = format!(
                    "key times must be strictly increasing, got {} after {}",
                    k.t,
                    keys[i - 1].t
                );
                return Err(FieldError::new(format!("keys[{i}].t"), msg));
            }
        }
        let times = keys.iter().map(|k| k.t).collect();
        let values = keys
            .iter()
            .map(|k| {
                Vector6::new(
                    k.position.x,
                    k.position.y,
                    k.position.z,
                    k.rotation.x,
                    k.rotation.y,
                    k.rotation.z,
                )
            })
            .collect();
        Ok(Self {
            spline: ClampedSpline::new(times, values),
            keys,
        })
    }

    /// The keys.
    pub fn keys(&self) -> &[Keyframe] {
        &self.keys
    }

    /// The head state at time t: `R = exp([φ]×)`, `ω = J_r(φ) φ̇`,
    /// `α = J̇_r(φ, φ̇) φ̇ + J_r(φ) φ̈`.
    pub fn state(&self, t: f64) -> HeadState {
        let jet = self.spline.eval(t);
        let part = |v: &Vector6<f64>, from: usize| Vector3::new(v[from], v[from + 1], v[from + 2]);
        let (phi, phi_dot, phi_ddot) =
            (part(&jet.value, 3), part(&jet.rate, 3), part(&jet.accel, 3));
        let jr = so3::right_jacobian(&phi);
        HeadState {
            position: part(&jet.value, 0),
            rotation: so3::exp(&phi),
            velocity: part(&jet.rate, 0),
            acceleration: part(&jet.accel, 0),
            omega: jr * phi_dot,
            alpha: so3::right_jacobian_rate(&phi, &phi_dot) * phi_dot + jr * phi_ddot,
        }
    }
}

/// Prescribed rigid motion of the head. Axes and directions must be unit vectors (the
/// scene reader normalises them).
#[derive(Debug, Clone, PartialEq, Default)]
pub enum HeadMotion {
    /// The head does not move: X = 0, R = I.
    #[default]
    Still,
    /// Shaking or nodding: rotation by θ(t) = A sin(2πft) about `axis` through the pivot
    /// `center`, so `R = exp(θ [axis]×)` and `X = center − R center`.
    Oscillate {
        /// Unit rotation axis (head coordinates; the same in world coordinates).
        axis: Vector3<f64>,
        /// Angular amplitude A, radians.
        amplitude: f64,
        /// Frequency f, Hz.
        frequency_hz: f64,
        /// Pivot in head coordinates, metres.
        center: Vector3<f64>,
    },
    /// Translation back and forth: `X = direction · A sin(2πft)`, R = I.
    TranslateOscillate {
        /// Unit direction.
        direction: Vector3<f64>,
        /// Amplitude A, metres.
        amplitude: f64,
        /// Frequency f, Hz.
        frequency_hz: f64,
    },
    /// Keyframed position and orientation.
    Keyframes(KeyframeTrack),
    /// Rotation about `axis` through `center` at constant angular speed Ω until
    /// `stop_time`, then a smooth stop: ω(t) = Ω (1 − S(u)), `u = (t − stop_time) /
    /// stop_duration`, with the smoothstep S(u) = 3u² − 2u³, so ω is C1 and the head is at
    /// rest from `stop_time + stop_duration` on. The head is already turning at t = 0
    /// (θ(t) = Ω t before the stop).
    SuddenStop {
        /// Unit rotation axis.
        axis: Vector3<f64>,
        /// Ω, rad/s.
        angular_speed: f64,
        /// Time the deceleration starts, seconds.
        stop_time: f64,
        /// Duration of the deceleration, seconds (> 0; 0 is treated as an instant stop,
        /// whose impulse is lost).
        stop_duration: f64,
        /// Pivot in head coordinates, metres.
        center: Vector3<f64>,
    },
    /// A jolt: a translation along `direction` whose acceleration is the smooth pulse
    /// `a(t) = A sin²(π (t − start) / duration)` on `[start, start + duration]`, zero
    /// elsewhere. The head is at rest before and moves at the constant speed
    /// `A duration / 2` after.
    Jolt {
        /// Unit direction.
        direction: Vector3<f64>,
        /// Peak acceleration A, m/s².
        acceleration: f64,
        /// Start of the pulse, seconds.
        start: f64,
        /// Duration of the pulse, seconds (> 0; 0 means no motion).
        duration: f64,
    },
    /// Driven by a caller between steps ([`crate::Simulation::set_head`]): the head's
    /// state at `t0` (pose and rates), moved on from it with constant acceleration and
    /// angular acceleration, `X(t) = X0 + Ẋ0 τ + ½ Ẍ0 τ²`,
    /// `R(t) = R0 exp([ω0 τ + ½ α0 τ²]×)` (τ = t − t0), as the embedded batch's head
    /// ([`superhelix_kernels::fixed::ExtrapolatedHead`]).
    Driven {
        /// The time of `state`, seconds.
        t0: f64,
        /// The head at t0 (boxed: the other motions are a few numbers).
        state: Box<HeadState>,
    },
}

/// A scalar coordinate of a motion and its first two time derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Profile {
    value: f64,
    rate: f64,
    accel: f64,
}

impl HeadMotion {
    /// A keyframed motion; see [`KeyframeTrack::new`] for the errors.
    pub fn keyframes(keys: Vec<Keyframe>) -> Result<Self, FieldError> {
        KeyframeTrack::new(keys).map(HeadMotion::Keyframes)
    }

    /// The head state at time `t` (seconds).
    pub fn state(&self, t: f64) -> HeadState {
        match self {
            HeadMotion::Still => HeadState::rest(),
            HeadMotion::Oscillate {
                axis,
                amplitude,
                frequency_hz,
                center,
            } => about_axis(axis, center, sine(*amplitude, *frequency_hz, t)),
            HeadMotion::TranslateOscillate {
                direction,
                amplitude,
                frequency_hz,
            } => along(direction, sine(*amplitude, *frequency_hz, t)),
            HeadMotion::Keyframes(track) => track.state(t),
            HeadMotion::SuddenStop {
                axis,
                angular_speed,
                stop_time,
                stop_duration,
                center,
            } => about_axis(
                axis,
                center,
                sudden_stop(*angular_speed, *stop_time, *stop_duration, t),
            ),
            HeadMotion::Jolt {
                direction,
                acceleration,
                start,
                duration,
            } => along(direction, jolt(*acceleration, *start, *duration, t)),
            HeadMotion::Driven { t0, state } => {
                use superhelix_kernels::fixed::HeadTrajectory;
                superhelix_kernels::fixed::ExtrapolatedHead {
                    t0: *t0,
                    state: **state,
                }
                .state(t)
            }
        }
    }
}

impl HeadMotion {
    /// Whether over the whole interval [t0, t1] the head does not rotate and translates
    /// at a constant velocity (ω = α = 0, Ẍ = 0): its frame is then inertial, and a
    /// strand's energy in it can only decrease. Exact for every motion (not sampled): a
    /// jolt is uniform before its start and after its end, a sudden stop from the end of
    /// the deceleration on, keyframes before the first and after the last key.
    pub fn uniform_over(&self, t0: f64, t1: f64) -> bool {
        match self {
            HeadMotion::Still => true,
            HeadMotion::Oscillate {
                amplitude,
                frequency_hz,
                ..
            }
            | HeadMotion::TranslateOscillate {
                amplitude,
                frequency_hz,
                ..
            } => *amplitude == 0.0 || *frequency_hz == 0.0,
            HeadMotion::Keyframes(track) => {
                let keys = track.keys();
                match (keys.first(), keys.last()) {
                    (Some(first), Some(last)) => t1 <= first.t || t0 >= last.t,
                    _ => true,
                }
            }
            HeadMotion::SuddenStop {
                angular_speed,
                stop_time,
                stop_duration,
                ..
            } => *angular_speed == 0.0 || t0 >= stop_time + stop_duration.max(0.0),
            HeadMotion::Jolt {
                acceleration,
                start,
                duration,
                ..
            } => *acceleration == 0.0 || *duration <= 0.0 || t1 <= *start || t0 >= start + duration,
            HeadMotion::Driven { state, .. } => {
                state.omega == Vector3::zeros()
                    && state.alpha == Vector3::zeros()
                    && state.acceleration == Vector3::zeros()
            }
        }
    }

    /// The earliest time in the open interval (t0, t1) at which the head starts or stops
    /// moving uniformly ([`HeadMotion::uniform_over`] changes there): a jolt's start and
    /// end, the end of a sudden stop's deceleration, the first and the last key of a
    /// keyframed track. The steps land on it, so that the energy ceiling of an inertial
    /// phase is the energy at its exact start (`superhelix_kernels::fixed::phase_cut`).
    pub fn phase_change(&self, t0: f64, t1: f64) -> Option<f64> {
        let changes: [Option<f64>; 2] = match self {
            HeadMotion::Still
            | HeadMotion::Oscillate { .. }
            | HeadMotion::TranslateOscillate { .. }
            | HeadMotion::Driven { .. } => [None, None],
            HeadMotion::Keyframes(track) => {
                let keys = track.keys();
                [keys.first().map(|k| k.t), keys.last().map(|k| k.t)]
            }
            HeadMotion::SuddenStop {
                angular_speed,
                stop_time,
                stop_duration,
                ..
            } => [
                (*angular_speed != 0.0).then(|| stop_time + stop_duration.max(0.0)),
                None,
            ],
            HeadMotion::Jolt {
                acceleration,
                start,
                duration,
                ..
            } => {
                let jolts = *acceleration != 0.0 && *duration > 0.0;
                [jolts.then_some(*start), jolts.then(|| start + duration)]
            }
        };
        changes
            .into_iter()
            .flatten()
            .filter(|&b| b > t0 && b < t1)
            .fold(None, |first: Option<f64>, b| {
                Some(first.map_or(b, |f| f.min(b)))
            })
    }
}

/// `A sin(2πft)` and its derivatives.
fn sine(amplitude: f64, frequency_hz: f64, t: f64) -> Profile {
    let w = 2.0 * PI * frequency_hz;
    let (s, c) = (w * t).sin_cos();
    Profile {
        value: amplitude * s,
        rate: amplitude * w * c,
        accel: -amplitude * w * w * s,
    }
}

/// Angle of the sudden-stop motion (see [`HeadMotion::SuddenStop`]).
fn sudden_stop(omega: f64, stop_time: f64, stop_duration: f64, t: f64) -> Profile {
    if t <= stop_time {
        return Profile {
            value: omega * t,
            rate: omega,
            accel: 0.0,
        };
    }
    if stop_duration <= 0.0 || t >= stop_time + stop_duration {
        let value = omega * (stop_time + 0.5 * stop_duration.max(0.0));
        return Profile {
            value,
            rate: 0.0,
            accel: 0.0,
        };
    }
    let u = (t - stop_time) / stop_duration;
    Profile {
        value: omega * (stop_time + stop_duration * (u - u.powi(3) + 0.5 * u.powi(4))),
        rate: omega * (1.0 - 3.0 * u * u + 2.0 * u.powi(3)),
        accel: -omega * 6.0 * u * (1.0 - u) / stop_duration,
    }
}

/// Displacement of the jolt (see [`HeadMotion::Jolt`]).
fn jolt(peak: f64, start: f64, duration: f64, t: f64) -> Profile {
    let tau = t - start;
    if tau <= 0.0 || duration <= 0.0 {
        return Profile {
            value: 0.0,
            rate: 0.0,
            accel: 0.0,
        };
    }
    if tau >= duration {
        let speed = 0.5 * peak * duration;
        return Profile {
            value: 0.5 * speed * duration + speed * (tau - duration),
            rate: speed,
            accel: 0.0,
        };
    }
    let phase = 2.0 * PI * tau / duration;
    Profile {
        value: peak
            * (0.25 * tau * tau + duration * duration / (8.0 * PI * PI) * (phase.cos() - 1.0)),
        rate: peak * (0.5 * tau - duration / (4.0 * PI) * phase.sin()),
        accel: peak * (PI * tau / duration).sin().powi(2),
    }
}

/// Rotation by the angle `angle.value` about the unit `axis` through the pivot `center`:
/// `X = c − R c`, `Ẋ = −R (ω × c)`, `Ẍ = −R (α × c + ω × (ω × c))`.
fn about_axis(axis: &Vector3<f64>, center: &Vector3<f64>, angle: Profile) -> HeadState {
    let rotation = so3::exp(&(axis * angle.value));
    let omega = axis * angle.rate;
    let alpha = axis * angle.accel;
    HeadState {
        position: center - rotation * center,
        rotation,
        velocity: -(rotation * omega.cross(center)),
        acceleration: -(rotation * (alpha.cross(center) + omega.cross(&omega.cross(center)))),
        omega,
        alpha,
    }
}

/// Translation by `offset.value` along the unit `direction`, no rotation.
fn along(direction: &Vector3<f64>, offset: Profile) -> HeadState {
    HeadState {
        position: direction * offset.value,
        velocity: direction * offset.rate,
        acceleration: direction * offset.accel,
        ..HeadState::rest()
    }
}

#[cfg(test)]
mod tests;

impl superhelix_kernels::fixed::HeadTrajectory for HeadMotion {
    fn state(&self, t: f64) -> HeadState {
        HeadMotion::state(self, t)
    }
    fn uniform_over(&self, t0: f64, t1: f64) -> bool {
        HeadMotion::uniform_over(self, t0, t1)
    }
    fn phase_change(&self, t0: f64, t1: f64) -> Option<f64> {
        HeadMotion::phase_change(self, t0, t1)
    }
}

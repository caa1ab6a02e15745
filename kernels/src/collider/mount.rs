//! Where a collider's own coordinates are: fixed in the head's frame, fixed in the world,
//! or in a frame on its own rigid motion; and what that makes of a point, a normal and the
//! collider's velocity in the head's coordinates, which a strand's step works in.
//!
//! With the head in state (X, R, Ẋ, ω) (ω in head coordinates, `Ṙ = R [ω]×`) and a point
//! `y` in head coordinates, the world point is `x = X + R y`; a collider on its own motion
//! in state (X_b, R_b, Ẋ_b, ω_b) holds it at `z = R_bᵀ(x − X_b)`. The velocity, in head
//! coordinates, of the collider's material point at y is
//!
//! ```text
//! head:    0
//! world:   u = −(Rᵀ Ẋ + ω × y)
//! motion:  u = Rᵀ(Ẋ_b + R_b (ω_b × z) − Ẋ) − ω × y
//! ```

use crate::head::HeadState;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Where a collider's coordinates are.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mount {
    /// Fixed in the head's frame: its coordinates are the head's.
    Head,
    /// Fixed in the world: its coordinates are the world's.
    World,
    /// A frame on its own rigid motion, in this state at the time of the query.
    Frame(HeadState),
}

impl Mount {
    /// The head-frame point `y` in the collider's coordinates, the head in `head`.
    #[inline]
    pub fn local(&self, head: &HeadState, y: &V3) -> V3 {
        match self {
            Mount::Head => *y,
            Mount::World => head.position + head.rotation * y,
            Mount::Frame(f) => {
                f.rotation.transpose() * (head.position + head.rotation * y - f.position)
            }
        }
    }

    /// A direction `n` of the collider's coordinates (an outward normal) in head
    /// coordinates.
    #[inline]
    pub fn direction_to_head(&self, head: &HeadState, n: &V3) -> V3 {
        match self {
            Mount::Head => *n,
            Mount::World => head.rotation.transpose() * n,
            Mount::Frame(f) => head.rotation.transpose() * (f.rotation * n),
        }
    }

    /// A point `p` of the collider's coordinates in head coordinates.
    #[inline]
    pub fn point_to_head(&self, head: &HeadState, p: &V3) -> V3 {
        match self {
            Mount::Head => *p,
            Mount::World => head.rotation.transpose() * (p - head.position),
            Mount::Frame(f) => {
                head.rotation.transpose() * (f.position + f.rotation * p - head.position)
            }
        }
    }

    /// The velocity, head coordinates, of the collider's material point at head-frame
    /// `y` (module documentation).
    #[inline]
    pub fn velocity(&self, head: &HeadState, y: &V3) -> V3 {
        match self {
            Mount::Head => V3::zeros(),
            Mount::World => -(head.rotation.transpose() * head.velocity + head.omega.cross(y)),
            Mount::Frame(f) => {
                let z = f.rotation.transpose() * (head.position + head.rotation * y - f.position);
                let world = f.velocity + f.rotation * f.omega.cross(&z);
                head.rotation.transpose() * (world - head.velocity) - head.omega.cross(y)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    fn moving(position: V3, axis: V3, angle: f64, velocity: V3, omega: V3) -> HeadState {
        HeadState {
            position,
            rotation: Rotation3::from_scaled_axis(axis * angle).into_inner(),
            velocity,
            omega,
            ..HeadState::rest()
        }
    }

    /// The state `dt` later: X + Ẋ dt, R exp(dt [ω]×), rates unchanged.
    fn advanced(s: &HeadState, dt: f64) -> HeadState {
        HeadState {
            position: s.position + s.velocity * dt,
            rotation: s.rotation * Rotation3::from_scaled_axis(s.omega * dt).into_inner(),
            ..*s
        }
    }

    /// The velocity of a collider's material point, against the central difference of
    /// that point's head coordinates as the head and the collider move (1e-6 s apart):
    /// to 1e-8 m/s for velocities of order 1.
    #[test]
    fn the_velocity_is_the_rate_of_the_collider_point_in_head_coordinates() {
        let head = moving(
            V3::new(0.1, -0.2, 0.3),
            V3::new(0.3, 1.0, -0.5).normalize(),
            0.7,
            V3::new(0.4, -0.3, 0.2),
            V3::new(1.1, -0.6, 0.9),
        );
        let frame = moving(
            V3::new(-0.2, 0.05, 0.1),
            V3::new(-0.8, 0.1, 0.6).normalize(),
            1.3,
            V3::new(-0.5, 0.6, 0.1),
            V3::new(-0.4, 1.7, 0.3),
        );
        let y = V3::new(0.05, 0.12, -0.08);
        let dt = 1e-6;
        for mount in [Mount::Head, Mount::World, Mount::Frame(frame)] {
            // the collider point now at y, in the collider's coordinates
            let p = mount.local(&head, &y);
            let at = |t: f64| {
                let h = advanced(&head, t);
                let m = match mount {
                    Mount::Frame(f) => Mount::Frame(advanced(&f, t)),
                    other => other,
                };
                m.point_to_head(&h, &p)
            };
            let rate = (at(dt) - at(-dt)) / (2.0 * dt);
            let u = mount.velocity(&head, &y);
            assert!((u - rate).norm() < 1e-8, "{mount:?}: {u} against {rate}");
            // local and point_to_head are inverse, and directions turn as points do
            assert!((mount.point_to_head(&head, &p) - y).norm() < 1e-15);
            let n = V3::new(0.3, -0.4, 0.5).normalize();
            let turned = mount.direction_to_head(&head, &n);
            let through_points =
                mount.point_to_head(&head, &(p + n)) - mount.point_to_head(&head, &p);
            assert!((turned - through_points).norm() < 1e-14, "{mount:?}");
        }
    }
}

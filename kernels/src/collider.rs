//! What a strand's contacts collide with, in the strand's own crate (no `std`, no
//! allocation): the exact signed distances of the analytic shapes — [`Sphere`],
//! [`Ellipsoid`], [`Capsule`], [`Cylinder`] and [`Plane`] — each answering a
//! [`Proximity`] (signed distance, unit outward normal, closest surface point) for a
//! point in the shape's own coordinates — and a signed distance sampled on a grid the
//! caller owns ([`SdfGrid`] on a [`GridView`]: trilinear, extended beyond its box).
//!
//! [`Mount`] says where a collider's coordinates are (the head's frame, the world, a
//! frame on its own motion) and turns points, normals and the collider's velocity into
//! the head coordinates a strand's step works in; [`Collider`] is what anything that
//! answers a signed distance implements (a closure `Fn(&Vector3<f64>) -> Proximity`
//! among them, the form a callback takes); [`PoseOverStep`] gives a frame's state within
//! a step from its poses at the step's two ends, as an engine hands them
//! (`crate::fixed::PosedColliders` places colliders so over a step).
//!
//! The runtime places them in a scene (attached to the head, fixed in the world or on
//! their own motion) and adds the sampled signed distance of a triangle mesh beside them
//! (`superhelix_runtime::bodies`).

pub mod grid;
pub mod mount;
pub mod pose_over_step;
pub mod proximity;
pub mod shape_capsule;
pub mod shape_cylinder;
pub mod shape_ellipsoid;
pub mod shape_plane;
pub mod shape_sphere;

pub use grid::{GridView, SdfGrid};
pub use mount::Mount;
pub use pose_over_step::PoseOverStep;
pub use proximity::Proximity;
pub use shape_capsule::Capsule;
pub use shape_cylinder::Cylinder;
pub use shape_ellipsoid::Ellipsoid;
pub use shape_plane::Plane;
pub use shape_sphere::Sphere;

/// Anything that answers a signed distance in its own coordinates: the analytic shapes,
/// a signed-distance grid, the runtime's meshes.
pub trait Collider {
    /// Signed distance (negative inside), unit outward normal and closest surface point
    /// of the point `y` of the collider's coordinates.
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity;

    /// Whether `y` is certainly farther than `r` outside the surface (a cheap test that
    /// may answer false for some such points, never true for a nearer one). By default
    /// false: every point is queried.
    fn farther_than(&self, y: &nalgebra::Vector3<f64>, r: f64) -> bool {
        let _ = (y, r);
        false
    }

    /// The velocity of the surface's material point at `y` relative to the collider's
    /// coordinates (a deforming body, a conveyor belt; added to its mount's motion): by
    /// default zero, a rigid collider.
    fn surface_velocity(&self, y: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
        let _ = y;
        nalgebra::Vector3::zeros()
    }

    /// Whether the surface moves within the collider's coordinates
    /// ([`Self::surface_velocity`] may be nonzero): the work of its motion then enters a
    /// strand's energy balance as a collider's on its own motion. By default false.
    fn surface_moves(&self) -> bool {
        false
    }
}

impl Collider for Sphere {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
}

impl Collider for Ellipsoid {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
    fn farther_than(&self, y: &nalgebra::Vector3<f64>, r: f64) -> bool {
        Ellipsoid::farther_than(self, y, r)
    }
}

impl Collider for Capsule {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
}

impl Collider for Cylinder {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
}

impl Collider for Plane {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
}

impl Collider for SdfGrid<'_> {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self.query(y)
    }
}

/// A collider of any kind behind a reference: colliders of different kinds side by side
/// (a slice of `(&dyn Collider, Mount)` pairs is a `contact::body::ColliderSet`).
impl Collider for &dyn Collider {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        (**self).proximity(y)
    }
    fn farther_than(&self, y: &nalgebra::Vector3<f64>, r: f64) -> bool {
        (**self).farther_than(y, r)
    }
    fn surface_velocity(&self, y: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
        (**self).surface_velocity(y)
    }
    fn surface_moves(&self) -> bool {
        (**self).surface_moves()
    }
}

/// A callback as a collider: `f(y)` answers for the point y of its coordinates.
impl<F: Fn(&nalgebra::Vector3<f64>) -> Proximity> Collider for F {
    fn proximity(&self, y: &nalgebra::Vector3<f64>) -> Proximity {
        self(y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// Anything answering a signed distance is queried alike through the trait: a ball,
    /// and a callback answering for the same ball.
    #[test]
    fn shapes_and_callbacks_answer_through_one_trait() {
        let ball = Sphere {
            center: Vector3::new(0.0, 0.0, 0.1),
            radius: 0.08,
        };
        let callback = |y: &Vector3<f64>| ball.query(y);
        let colliders: [&dyn Collider; 2] = [&ball, &callback];
        let y = Vector3::new(0.03, -0.02, 0.2);
        let answers = colliders.map(|c| c.proximity(&y));
        assert_eq!(answers[0], answers[1]);
        assert!((answers[0].distance - ((y - ball.center).norm() - ball.radius)).abs() < 1e-16);
        assert!(
            !colliders[1].farther_than(&y, 1.0),
            "a callback is always queried"
        );
        // side by side with their mounts, they are a step's collider set
        use crate::contact::body::ColliderSet;
        let set = [(colliders[0], Mount::Head), (colliders[1], Mount::World)];
        assert_eq!(set[..].count(), 2);
        assert_eq!(set[..].proximity(1, &y), answers[0]);
        assert_eq!(set[..].mount(1), Mount::World);
    }
}

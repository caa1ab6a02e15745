//! The geometry of a body, built: the analytic shapes and the sampled mesh field, each
//! answering [`Proximity`] queries in the body's own coordinates.

use super::grid_sdf::GridSdf;
use super::mesh_sdf::MeshSdf;
use super::proximity::Proximity;
use super::shape_capsule::Capsule;
use super::shape_cylinder::Cylinder;
use super::shape_ellipsoid::Ellipsoid;
use super::shape_plane::Plane;
use super::shape_sphere::Sphere;
use nalgebra::Vector3;
use std::sync::Arc;

/// A body's geometry, in its own coordinates (head coordinates for a body attached to the
/// head).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A ball (exact).
    Sphere(Sphere),
    /// An ellipsoid (exact).
    Ellipsoid(Ellipsoid),
    /// A capsule (exact).
    Capsule(Capsule),
    /// A cylinder with flat caps (exact).
    Cylinder(Cylinder),
    /// A half-space (exact).
    Plane(Plane),
    /// A closed mesh's signed distance on a grid (trilinear), shared between copies.
    Mesh(Arc<MeshSdf>),
    /// A signed distance given on a grid (trilinear), shared between copies.
    Grid(Arc<GridSdf>),
}

impl Shape {
    /// Whether `y` is certainly farther than `r` outside the surface (a cheap test that
    /// may answer false for some such points, never true for a nearer one).
    pub fn farther_than(&self, y: &Vector3<f64>, r: f64) -> bool {
        match self {
            Shape::Ellipsoid(e) => e.farther_than(y, r),
            _ => self
                .bounding_ball()
                .is_some_and(|(c, radius)| (y - c).norm_squared() > (radius + r) * (radius + r)),
        }
    }

    /// A ball that holds the body's surface (centre, radius), in the body's coordinates;
    /// `None` for a plane. A point farther than `radius + r` from the centre is farther
    /// than r from the surface.
    pub fn bounding_ball(&self) -> Option<(Vector3<f64>, f64)> {
        match self {
            Shape::Sphere(s) => Some((s.center, s.radius)),
            Shape::Ellipsoid(e) => Some((e.center, e.radii.max())),
            Shape::Capsule(c) => Some((
                0.5 * (c.start + c.end),
                0.5 * (c.end - c.start).norm() + c.radius,
            )),
            Shape::Cylinder(c) => Some((
                0.5 * (c.start + c.end),
                (0.25 * (c.end - c.start).norm_squared() + c.radius * c.radius).sqrt(),
            )),
            Shape::Plane(_) => None,
            Shape::Mesh(m) => {
                let (lo, hi) = (m.grid().origin(), m.grid().corner());
                Some((0.5 * (lo + hi), 0.5 * (hi - lo).norm()))
            }
            Shape::Grid(g) => Some(g.bounding_ball()),
        }
    }

    /// Signed distance, outward normal and closest surface point of `y`.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        match self {
            Shape::Sphere(s) => s.query(y),
            Shape::Ellipsoid(s) => s.query(y),
            Shape::Capsule(s) => s.query(y),
            Shape::Cylinder(s) => s.query(y),
            Shape::Plane(s) => s.query(y),
            Shape::Mesh(s) => s.query(y),
            Shape::Grid(s) => s.query(y),
        }
    }
}

impl superhelix_kernels::collider::Collider for Shape {
    fn proximity(&self, y: &Vector3<f64>) -> Proximity {
        self.query(y)
    }
    fn farther_than(&self, y: &Vector3<f64>, r: f64) -> bool {
        Shape::farther_than(self, y, r)
    }
}

//! The geometry of a body, built: the analytic shapes and the sampled mesh field, each
//! answering [`Proximity`] queries in the body's own coordinates.

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
}

impl Shape {
    /// Signed distance, outward normal and closest surface point of `y`.
    pub fn query(&self, y: &Vector3<f64>) -> Proximity {
        match self {
            Shape::Sphere(s) => s.query(y),
            Shape::Ellipsoid(s) => s.query(y),
            Shape::Capsule(s) => s.query(y),
            Shape::Cylinder(s) => s.query(y),
            Shape::Plane(s) => s.query(y),
            Shape::Mesh(s) => s.query(y),
        }
    }
}

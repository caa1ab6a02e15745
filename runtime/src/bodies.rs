//! The bodies of a scene — the head and any obstacle — as signed distance fields: for a
//! world point at a given head state, the signed distance (negative inside), the unit
//! outward normal and the closest surface point: what the charged scalp of static
//! electricity (Sobottka & Weber 2006, section 2.4, eq. 7–8: the distance field Φ_S and
//! its normalised gradient) and contacts need. The bodies themselves exert no force.
//!
//! A body is attached to the head (its geometry in head coordinates, moving rigidly
//! with the head), fixed in the world, or moves on its own rigid motion ([`motion`]: the
//! same kinds of motion as the head's, keyframes among them). Spheres, ellipsoids, capsules, cylinders and
//! planes are exact ([`shape_sphere`], [`shape_ellipsoid`], [`shape_capsule`],
//! [`shape_cylinder`], [`shape_plane`]); a
//! closed triangle mesh read from OBJ ([`obj`], checked by [`triangle_mesh`]) is
//! sampled exactly ([`mesh_distance`]: closest points through a [`bvh`], signs by the
//! angle-weighted pseudonormal) on a regular [`grid`] and evaluated by trilinear
//! interpolation ([`mesh_sdf`]); a signed distance given on a grid (a `.npy` file) is
//! evaluated the same way ([`grid_sdf`]).
//!
//! [`Bodies::build`] turns the scene's [`BodySetup`]s into [`Bodies`];
//! [`Bodies::at`] places them at a time and head state for queries ([`PlacedBodies`]).

pub mod body;
pub mod bvh;
pub mod collection;
pub mod grid;
pub mod grid_sdf;
pub mod mesh_distance;
pub mod mesh_sdf;
pub mod motion;
pub mod obj;
pub mod setup;
pub mod shape;
pub mod triangle;
pub mod triangle_mesh;

// the analytic shapes and the answer of a query live with the strand's step, in the
// kernels crate (no std), and keep their paths here
pub use superhelix_kernels::collider::{
    proximity, shape_capsule, shape_cylinder, shape_ellipsoid, shape_plane, shape_sphere,
};

pub use body::{Body, Placement};
pub use collection::{Bodies, PlacedBodies};
pub use proximity::Proximity;
pub use setup::{Attachment, BodySetup, ShapeSetup};
pub use shape::Shape;

#[cfg(test)]
mod tests;

//! The bodies of a scene, built from their setups, and the same bodies placed at one time
//! and head state for queries in world coordinates.

use super::body::{Body, Placement};
use super::grid_sdf::GridSdf;
use super::mesh_sdf::MeshSdf;
use super::obj::read_obj;
use super::proximity::Proximity;
use super::setup::{BodySetup, ShapeSetup, MAX_GRID_NODES};
use super::shape::Shape;
use super::shape_capsule::Capsule;
use super::shape_cylinder::Cylinder;
use super::shape_ellipsoid::Ellipsoid;
use super::shape_plane::Plane;
use super::shape_sphere::Sphere;
use super::triangle_mesh::ClosedMesh;
use crate::error::{Error, FieldError, Result};
use nalgebra::Vector3;
use std::sync::Arc;
use superhelix_kernels::head::HeadState;

/// The bodies of a scene (none when the scene has no `[[bodies]]`).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Bodies {
    bodies: Vec<Body>,
}

impl Bodies {
    /// Build every body of `setups`: check each ([`BodySetup::check`]), read and check the
    /// mesh files, sample the mesh fields. Every problem is listed in [`Error::Invalid`]
    /// with its field (`bodies[2].path`, `bodies[0].cell`, …).
    pub fn build(setups: &[BodySetup]) -> Result<Self> {
        let mut errors = Vec::new();
        let mut bodies = Vec::with_capacity(setups.len());
        for (index, setup) in setups.iter().enumerate() {
            let problems = setup.check(index);
            if !problems.is_empty() {
                errors.extend(problems);
                continue;
            }
            match build_shape(&setup.shape) {
                Ok(shape) => bodies.push(Body {
                    name: setup.name.clone(),
                    attached: setup.attached.clone(),
                    shape,
                }),
                Err(e) => errors.push(FieldError::new(
                    format!("bodies[{index}].{}", e.field),
                    e.message,
                )),
            }
        }
        if errors.is_empty() {
            Ok(Self { bodies })
        } else {
            Err(Error::Invalid(errors))
        }
    }

    /// The bodies, in scene order.
    pub fn as_slice(&self) -> &[Body] {
        &self.bodies
    }

    /// Number of bodies.
    pub fn len(&self) -> usize {
        self.bodies.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.bodies.is_empty()
    }

    /// Whether a body moves on its own motion ([`crate::bodies::Attachment::Motion`]).
    pub fn any_motion(&self) -> bool {
        self.bodies.iter().any(|b| b.attached.is_motion())
    }

    /// The bodies at time `t` with the head in state `head`: queries in world coordinates.
    pub fn at(&self, head: HeadState, t: f64) -> PlacedBodies<'_> {
        self.placed(Placement::new(head, t))
    }

    /// The bodies at `at`: queries in world coordinates. Each body on its own motion is
    /// placed once, here.
    pub fn placed(&self, at: Placement) -> PlacedBodies<'_> {
        let frames = if self.any_motion() {
            self.bodies.iter().map(|b| b.frame(&at)).collect()
        } else {
            Vec::new()
        };
        PlacedBodies {
            bodies: &self.bodies,
            at,
            frames,
        }
    }
}

/// The bodies at one time and head state.
#[derive(Debug, Clone)]
pub struct PlacedBodies<'a> {
    bodies: &'a [Body],
    at: Placement,
    /// The frame of every body when one moves on its own motion (else empty: the head's).
    frames: Vec<Option<HeadState>>,
}

impl<'a> PlacedBodies<'a> {
    /// The bodies, in scene order.
    pub fn bodies(&self) -> &'a [Body] {
        self.bodies
    }

    /// The head state they are placed at.
    pub fn head(&self) -> &HeadState {
        &self.at.head
    }

    /// The time and head state they are placed at.
    pub fn placement(&self) -> &Placement {
        &self.at
    }

    /// The state of body `i`'s frame ([`Body::frame`]): `None` for a body fixed in the
    /// world.
    pub fn frame(&self, i: usize) -> Option<HeadState> {
        match self.frames.get(i) {
            Some(f) => *f,
            None => self.bodies[i].frame(&self.at),
        }
    }

    /// Signed distance, normal and closest point of the world point `x` to body `i`.
    pub fn query(&self, i: usize, x: &Vector3<f64>) -> Proximity {
        match self.frames.get(i) {
            Some(f) => self.bodies[i].query_in(f.as_ref(), x),
            None => self.bodies[i].query(&self.at, x),
        }
    }

    /// The body `x` is deepest in or nearest to (smallest signed distance) and its answer;
    /// `None` without bodies.
    pub fn nearest(&self, x: &Vector3<f64>) -> Option<(usize, Proximity)> {
        (0..self.bodies.len())
            .map(|i| self.query(i, x))
            .enumerate()
            .min_by(|a, b| a.1.distance.total_cmp(&b.1.distance))
    }
}

/// The shape of a checked setup; an error names the field relative to the body.
fn build_shape(setup: &ShapeSetup) -> std::result::Result<Shape, FieldError> {
    Ok(match setup {
        ShapeSetup::Sphere { center, radius } => Shape::Sphere(Sphere {
            center: *center,
            radius: *radius,
        }),
        ShapeSetup::Ellipsoid {
            center,
            radii,
            rotation,
        } => Shape::Ellipsoid(Ellipsoid {
            center: *center,
            radii: *radii,
            rotation: *rotation,
        }),
        ShapeSetup::Capsule { start, end, radius } => Shape::Capsule(Capsule {
            start: *start,
            end: *end,
            radius: *radius,
        }),
        ShapeSetup::Cylinder { start, end, radius } => Shape::Cylinder(Cylinder {
            start: *start,
            end: *end,
            radius: *radius,
        }),
        ShapeSetup::Plane { point, normal } => Shape::Plane(Plane {
            point: *point,
            normal: *normal,
        }),
        ShapeSetup::Mesh {
            path,
            cell,
            scale,
            rotation,
            translation,
        } => {
            let (vertices, triangles) =
                read_obj(path).map_err(|message| FieldError::new("path", message))?;
            let placed: Vec<Vector3<f64>> = vertices
                .iter()
                .map(|v| rotation * (v * *scale) + translation)
                .collect();
            let mesh = ClosedMesh::new(&placed, &triangles).map_err(|message| {
                FieldError::new("path", format!("'{}': {message}", path.display()))
            })?;
            let sdf = MeshSdf::build(mesh, *cell).map_err(|e| {
                FieldError::new(
                    "cell",
                    format!(
                        "the grid over the mesh would have {:.3e} nodes, more than the cap of \
                         {MAX_GRID_NODES}; use cell >= {:.3e} m",
                        e.nodes, e.smallest_cell
                    ),
                )
            })?;
            Shape::Mesh(Arc::new(sdf))
        }
        ShapeSetup::Grid { path, origin, cell } => {
            Shape::Grid(Arc::new(GridSdf::read(path, *origin, *cell)?))
        }
    })
}

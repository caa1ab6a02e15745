//! What a scene says about its bodies (plain data, as `[[bodies]]` reads it) and the
//! checks of that data for users of the API who build it by hand.

use super::motion::HeadMotion;
use crate::error::FieldError;
use nalgebra::{Matrix3, Vector3};
use std::path::PathBuf;

/// Largest radius, half-axis or capsule radius of a body, metres.
pub const MAX_BODY_SIZE: f64 = 1000.0;
/// Largest `scale` of a mesh.
pub const MAX_MESH_SCALE: f64 = 1e6;
/// Most nodes of the grid of a mesh or grid body (256³, 134 MB of f64).
pub const MAX_GRID_NODES: usize = 1 << 24;
/// The default grid cell of a mesh is the longest side of the mesh's box over this.
pub const DEFAULT_CELLS_PER_SIDE: f64 = 64.0;

/// What a body moves with.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum Attachment {
    /// Rigidly with the head: the body's geometry is in head coordinates, a point y of it
    /// is at `X(t) + R(t) y` in the world.
    #[default]
    Head,
    /// Fixed in the world: the body's geometry is in world coordinates.
    World,
    /// On its own rigid motion, of the same kinds as the head's: the body's geometry is in
    /// its own coordinates, a point y of it is at `X_b(t) + R_b(t) y` in the world, with
    /// `X_b`, `R_b` (and their rates) the motion's state at time t.
    Motion(HeadMotion),
}

impl Attachment {
    /// Name as written in scenes (`attached = "…"`).
    pub fn name(&self) -> &'static str {
        match self {
            Attachment::Head => "head",
            Attachment::World => "world",
            Attachment::Motion(_) => "motion",
        }
    }
    /// Parse a scene name of an attachment without motion data (`head`, `world`).
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Head, Self::World]
            .into_iter()
            .find(|a| a.name() == name)
    }
    /// Whether the body moves on its own motion.
    pub fn is_motion(&self) -> bool {
        matches!(self, Attachment::Motion(_))
    }
}

/// The geometry of a body, in the coordinates of its [`Attachment`].
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeSetup {
    /// A ball.
    Sphere {
        /// Centre, m.
        center: Vector3<f64>,
        /// Radius, m, in (0, [`MAX_BODY_SIZE`]].
        radius: f64,
    },
    /// A solid ellipsoid `|(Rᵀ(y − c))ᵢ / aᵢ|² ≤ 1`.
    Ellipsoid {
        /// Centre c, m.
        center: Vector3<f64>,
        /// Half-axes a, m, each in (0, [`MAX_BODY_SIZE`]].
        radii: Vector3<f64>,
        /// R: the ellipsoid's axes (its columns) in the body's coordinates.
        rotation: Matrix3<f64>,
    },
    /// The points within `radius` of the segment from `start` to `end` (a ball when they
    /// coincide).
    Capsule {
        /// One end of the axis, m.
        start: Vector3<f64>,
        /// The other end, m.
        end: Vector3<f64>,
        /// Radius, m, in (0, [`MAX_BODY_SIZE`]].
        radius: f64,
    },
    /// A solid cylinder with flat caps: the points within `radius` of the axis from
    /// `start` to `end`, between the caps through the two ends.
    Cylinder {
        /// Centre of one cap, m.
        start: Vector3<f64>,
        /// Centre of the other cap, m (different from `start`).
        end: Vector3<f64>,
        /// Radius, m, in (0, [`MAX_BODY_SIZE`]].
        radius: f64,
    },
    /// The half-space behind a plane: `(y − point) · normal ≤ 0`.
    Plane {
        /// A point of the plane, m.
        point: Vector3<f64>,
        /// Unit outward normal.
        normal: Vector3<f64>,
    },
    /// The solid bounded by a closed triangle mesh read from an OBJ file; a vertex v of
    /// the file is at `rotation · (scale v) + translation`.
    Mesh {
        /// The OBJ file (a scene resolves it against the scene file's folder).
        path: PathBuf,
        /// Grid cell, m; `None`: the longest side of the mesh's box / [`DEFAULT_CELLS_PER_SIDE`].
        cell: Option<f64>,
        /// Uniform scale of the file's coordinates, in (0, [`MAX_MESH_SCALE`]].
        scale: f64,
        /// Rotation applied after the scale.
        rotation: Matrix3<f64>,
        /// Translation applied last, m.
        translation: Vector3<f64>,
    },
    /// A signed distance sampled on a regular grid (negative inside), read from a `.npy`
    /// file of float64 values in C order of shape `(nz, ny, nx)`: node (i, j, k) at
    /// `origin + cell · (i, j, k)` holds `values[k, j, i]`; evaluated by trilinear
    /// interpolation inside the grid's box and `f(p) + |x − p|` beyond it (the form a
    /// game engine builds for hair, and what the C ABI's `SH_COLLIDER_GRID` reads).
    Grid {
        /// The `.npy` file (a scene resolves it against the scene file's folder).
        path: PathBuf,
        /// Position of node (0, 0, 0), m.
        origin: Vector3<f64>,
        /// Distance between neighbouring nodes, m, in (0, [`MAX_BODY_SIZE`]].
        cell: f64,
    },
}

impl ShapeSetup {
    /// Name of the shape as written in scenes.
    pub fn name(&self) -> &'static str {
        match self {
            ShapeSetup::Sphere { .. } => "sphere",
            ShapeSetup::Ellipsoid { .. } => "ellipsoid",
            ShapeSetup::Capsule { .. } => "capsule",
            ShapeSetup::Cylinder { .. } => "cylinder",
            ShapeSetup::Plane { .. } => "plane",
            ShapeSetup::Mesh { .. } => "mesh",
            ShapeSetup::Grid { .. } => "grid",
        }
    }
}

/// One body of a scene.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySetup {
    /// Name, unique among the bodies.
    pub name: String,
    /// What the body moves with.
    pub attached: Attachment,
    /// Its geometry.
    pub shape: ShapeSetup,
}

impl BodySetup {
    /// The problems of body `index` (field paths `bodies[index].…`): values that are not
    /// finite or out of range. The mesh file itself is read by [`crate::bodies::Bodies::build`].
    pub fn check(&self, index: usize) -> Vec<FieldError> {
        let mut errors = Vec::new();
        let at = |f: &str| format!("bodies[{index}].{f}");
        let size = |errors: &mut Vec<FieldError>, field: &str, x: f64| {
            if !(x > 0.0 && x <= MAX_BODY_SIZE) {
                errors.push(FieldError::new(
                    at(field),
                    format!("must be in (0, {MAX_BODY_SIZE}] m, got {x}"),
                ));
            }
        };
        let finite = |errors: &mut Vec<FieldError>, field: &str, v: &[f64]| {
            if v.iter().any(|x| !x.is_finite()) {
                errors.push(FieldError::new(at(field), "values must be finite"));
            }
        };
        match &self.shape {
            ShapeSetup::Sphere { center, radius } => {
                finite(&mut errors, "center", center.as_slice());
                size(&mut errors, "radius", *radius);
            }
            ShapeSetup::Ellipsoid {
                center,
                radii,
                rotation,
            } => {
                finite(&mut errors, "center", center.as_slice());
                for (k, r) in radii.iter().enumerate() {
                    size(&mut errors, &format!("radii[{k}]"), *r);
                }
                check_rotation(&mut errors, &at("rotation_axis_angle_deg"), rotation);
            }
            ShapeSetup::Capsule { start, end, radius } => {
                finite(&mut errors, "start", start.as_slice());
                finite(&mut errors, "end", end.as_slice());
                size(&mut errors, "radius", *radius);
            }
            ShapeSetup::Cylinder { start, end, radius } => {
                finite(&mut errors, "start", start.as_slice());
                finite(&mut errors, "end", end.as_slice());
                size(&mut errors, "radius", *radius);
                if start == end {
                    errors.push(FieldError::new(
                        at("end"),
                        "must differ from start: a cylinder needs an axis",
                    ));
                }
            }
            ShapeSetup::Plane { point, normal } => {
                finite(&mut errors, "point", point.as_slice());
                let off = (normal.norm() - 1.0).abs();
                if !(off.is_finite() && off < 1e-9) {
                    errors.push(FieldError::new(
                        at("normal"),
                        format!("must be a unit vector, got length {}", normal.norm()),
                    ));
                }
            }
            ShapeSetup::Mesh {
                path,
                cell,
                scale,
                rotation,
                translation,
            } => {
                if path.as_os_str().is_empty() {
                    errors.push(FieldError::new(at("path"), "must name an OBJ file"));
                }
                if let Some(h) = cell {
                    size(&mut errors, "cell", *h);
                }
                if !(*scale > 0.0 && *scale <= MAX_MESH_SCALE) {
                    errors.push(FieldError::new(
                        at("scale"),
                        format!("must be in (0, {MAX_MESH_SCALE:e}], got {scale}"),
                    ));
                }
                check_rotation(&mut errors, &at("rotation_axis_angle_deg"), rotation);
                finite(&mut errors, "translation", translation.as_slice());
            }
            ShapeSetup::Grid { path, origin, cell } => {
                if path.as_os_str().is_empty() {
                    errors.push(FieldError::new(at("path"), "must name a .npy file"));
                }
                finite(&mut errors, "origin", origin.as_slice());
                size(&mut errors, "cell", *cell);
            }
        }
        errors
    }
}

/// A rotation matrix: finite, orthonormal, determinant 1 (to 1e-9).
fn check_rotation(errors: &mut Vec<FieldError>, field: &str, r: &Matrix3<f64>) {
    let orthonormal = (r.transpose() * r - Matrix3::identity()).norm() < 1e-9;
    if !(orthonormal && (r.determinant() - 1.0).abs() < 1e-9) {
        errors.push(FieldError::new(field, "must be a rotation"));
    }
}

//! What the post-run files show besides the strands: the head's motion, the bodies as the
//! pictures draw them, and the render strands asked for by `[render]`.
//!
//! Bodies are drawn from their exact silhouettes where that is cheap: a sphere or an
//! ellipsoid projects to an ellipse, a capsule to a stadium, a mesh to the union of its
//! projected triangles (the OBJ file is read again for it). A plane (a half-space) is drawn
//! only in the panels that see it edge on (its normal across the view direction), as the
//! grey region behind its line; in the other panels it would cover everything and is left
//! out. Planes do not count in the pictures' bounds.

use crate::bodies::obj::read_obj;
use crate::bodies::{Attachment, Bodies, Body, BodySetup, ShapeSetup};
use crate::config::SimulationSetup;
use crate::error::{Error, Result};
use crate::forces::head_motion::HeadMotion;
use crate::render::RenderSettings;
use nalgebra::{Matrix3, Vector3};
use std::sync::Arc;
use superhelix_kernels::head::HeadState;

/// The shape of a body as the pictures draw it, in the coordinates of its attachment.
#[derive(Debug, Clone, PartialEq)]
pub enum PreviewShape {
    /// An ellipsoid: `centre + axes · diag(radii) · s`, |s| ≤ 1.
    Ellipsoid {
        /// Centre, m.
        centre: Vector3<f64>,
        /// The ellipsoid's axes (columns), orthonormal.
        axes: Matrix3<f64>,
        /// Semi-axes, m (equal for a sphere).
        radii: Vector3<f64>,
    },
    /// The points within `radius` of the segment from `start` to `end`.
    Capsule {
        /// One end of the axis, m.
        start: Vector3<f64>,
        /// The other end, m.
        end: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// The finite cylinder of `radius` about the segment from `start` to `end`, flat at
    /// both ends.
    Cylinder {
        /// The centre of one end, m.
        start: Vector3<f64>,
        /// The centre of the other end, m.
        end: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// The half-space behind a plane.
    HalfSpace {
        /// A point of the plane, m.
        point: Vector3<f64>,
        /// Unit outward normal.
        normal: Vector3<f64>,
    },
    /// A closed triangle mesh.
    Mesh {
        /// Vertex positions, m.
        vertices: Arc<Vec<Vector3<f64>>>,
        /// Triangles, indices into the vertices.
        triangles: Arc<Vec<[usize; 3]>>,
    },
}

/// A body drawn under the strands, moving with the head, fixed in the world or on its own
/// motion.
#[derive(Debug, Clone, PartialEq)]
pub struct PreviewBody {
    /// What it moves with.
    pub attached: Attachment,
    /// Its shape.
    pub shape: PreviewShape,
}

impl PreviewBody {
    /// A ball of `radius` at `centre`, fixed in the world.
    pub fn sphere(centre: [f64; 3], radius: f64) -> Self {
        Self {
            attached: Attachment::World,
            shape: PreviewShape::Ellipsoid {
                centre: Vector3::from(centre),
                axes: Matrix3::identity(),
                radii: Vector3::repeat(radius),
            },
        }
    }

    /// The body as drawn, from its setup (a mesh file is read again).
    pub fn from_setup(setup: &BodySetup) -> std::result::Result<Self, String> {
        let shape = match &setup.shape {
            ShapeSetup::Sphere { center, radius } => PreviewShape::Ellipsoid {
                centre: *center,
                axes: Matrix3::identity(),
                radii: Vector3::repeat(*radius),
            },
            ShapeSetup::Ellipsoid {
                center,
                radii,
                rotation,
            } => PreviewShape::Ellipsoid {
                centre: *center,
                axes: *rotation,
                radii: *radii,
            },
            ShapeSetup::Capsule { start, end, radius } => PreviewShape::Capsule {
                start: *start,
                end: *end,
                radius: *radius,
            },
            ShapeSetup::Cylinder { start, end, radius } => PreviewShape::Cylinder {
                start: *start,
                end: *end,
                radius: *radius,
            },
            ShapeSetup::Plane { point, normal } => PreviewShape::HalfSpace {
                point: *point,
                normal: *normal,
            },
            ShapeSetup::Mesh {
                path,
                scale,
                rotation,
                translation,
                ..
            } => {
                let (vertices, triangles) = read_obj(path)?;
                let vertices = vertices
                    .iter()
                    .map(|v| rotation * (v * *scale) + translation)
                    .collect();
                PreviewShape::Mesh {
                    vertices: Arc::new(vertices),
                    triangles: Arc::new(triangles),
                }
            }
            // a grid is drawn as the box of its nodes inside the body
            ShapeSetup::Grid { path, origin, cell } => {
                let sdf = crate::bodies::grid_sdf::GridSdf::read(path, *origin, *cell)
                    .map_err(|e| e.message)?;
                let (lo, hi) = sdf.inside_box().unwrap_or((*origin, *origin));
                box_mesh(&lo, &hi)
            }
        };
        Ok(Self {
            attached: setup.attached.clone(),
            shape,
        })
    }

    /// The shape in world coordinates at simulated time `t` with the head in state `head`
    /// (a body on its own motion at its pose of t, or of 0 for a time that is not finite).
    pub fn placed(&self, head: &HeadState, t: f64) -> PreviewShape {
        let (x, r) = match &self.attached {
            Attachment::World => return self.shape.clone(),
            Attachment::Head => (head.position, head.rotation),
            Attachment::Motion(motion) => {
                let state = motion.state(if t.is_finite() { t } else { 0.0 });
                (state.position, state.rotation)
            }
        };
        let at = |p: &Vector3<f64>| x + r * p;
        match &self.shape {
            PreviewShape::Ellipsoid {
                centre,
                axes,
                radii,
            } => PreviewShape::Ellipsoid {
                centre: at(centre),
                axes: r * axes,
                radii: *radii,
            },
            PreviewShape::Capsule { start, end, radius } => PreviewShape::Capsule {
                start: at(start),
                end: at(end),
                radius: *radius,
            },
            PreviewShape::Cylinder { start, end, radius } => PreviewShape::Cylinder {
                start: at(start),
                end: at(end),
                radius: *radius,
            },
            PreviewShape::HalfSpace { point, normal } => PreviewShape::HalfSpace {
                point: at(point),
                normal: r * normal,
            },
            PreviewShape::Mesh {
                vertices,
                triangles,
            } => PreviewShape::Mesh {
                vertices: Arc::new(vertices.iter().map(at).collect()),
                triangles: Arc::clone(triangles),
            },
        }
    }
}

impl PreviewShape {
    /// Smallest and largest world x, y, z of the shape (`None` for a half-space).
    pub fn extent(&self) -> Option<([f64; 3], [f64; 3])> {
        let (lo, hi) = match self {
            PreviewShape::Ellipsoid {
                centre,
                axes,
                radii,
            } => {
                // half-width along world axis c: sqrt(Σ_k (axes[c][k] radii[k])²)
                let half = Vector3::from_fn(|c, _| {
                    (0..3)
                        .map(|k| (axes[(c, k)] * radii[k]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                });
                (centre - half, centre + half)
            }
            PreviewShape::Capsule { start, end, radius } => {
                let r = Vector3::repeat(*radius);
                (start.inf(end) - r, start.sup(end) + r)
            }
            PreviewShape::Cylinder { start, end, radius } => {
                // an end disc reaches r sqrt(1 − a_c²) along world axis c (a the unit axis)
                let a = (end - start).try_normalize(0.0).unwrap_or_else(Vector3::z);
                let half = Vector3::from_fn(|c, _| radius * (1.0 - a[c] * a[c]).max(0.0).sqrt());
                (start.inf(end) - half, start.sup(end) + half)
            }
            PreviewShape::HalfSpace { .. } => return None,
            PreviewShape::Mesh { vertices, .. } => {
                let mut lo = Vector3::repeat(f64::INFINITY);
                let mut hi = Vector3::repeat(f64::NEG_INFINITY);
                for v in vertices.iter() {
                    lo = lo.inf(v);
                    hi = hi.sup(v);
                }
                (lo, hi)
            }
        };
        let ok = lo.iter().chain(hi.iter()).all(|v| v.is_finite());
        ok.then(|| ([lo.x, lo.y, lo.z], [hi.x, hi.y, hi.z]))
    }
}

/// The render strands asked for, the body their roots are projected onto and the bodies
/// they keep out of.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderSource {
    /// The scene's `[render]` table.
    pub settings: RenderSettings,
    /// The scalp (a body attached to the head), built.
    pub scalp: Option<Body>,
    /// Every body of the scene, built: the render strands keep out of them by the
    /// clearance (none: the strands are the blend alone).
    pub bodies: Vec<Body>,
}

/// What the post-run files show besides the strands.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scenery {
    /// The head's motion: the pose of the bodies on the head and of the render strands'
    /// offsets at each frame (evaluated at the frame's simulated time).
    pub head: HeadMotion,
    /// Bodies drawn under the strands.
    pub bodies: Vec<PreviewBody>,
    /// Render strands (`None`: none).
    pub render: Option<RenderSource>,
}

impl Scenery {
    /// The scenery of a scene: its head motion, its bodies and its `[render]` table (with
    /// it every body is built for the render strands, a mesh's field sampled). Errors name
    /// the body's field.
    pub fn from_setup(setup: &SimulationSetup) -> Result<Self> {
        let mut bodies = Vec::with_capacity(setup.bodies.len());
        for (i, b) in setup.bodies.iter().enumerate() {
            bodies.push(
                PreviewBody::from_setup(b)
                    .map_err(|m| Error::invalid(format!("bodies[{i}].path"), m))?,
            );
        }
        let render = match setup.output.render {
            None => None,
            Some(settings) => {
                // built once: the strands keep out of them, the scalp is one of them
                let bodies = Bodies::build(&setup.bodies)?.as_slice().to_vec();
                let scalp = match settings.scalp_body {
                    None => None,
                    Some(i) => Some(bodies.get(i).cloned().ok_or_else(|| {
                        Error::invalid(
                            "render.scalp_body",
                            format!("body {i} does not exist ({} bodies)", bodies.len()),
                        )
                    })?),
                };
                Some(RenderSource {
                    settings,
                    scalp,
                    bodies,
                })
            }
        };
        Ok(Self {
            head: setup.head.clone(),
            bodies,
            render,
        })
    }

    /// The head state at simulated time `t` (at rest for a time that is not finite).
    pub fn head_at(&self, t: f64) -> HeadState {
        if t.is_finite() {
            self.head.state(t)
        } else {
            HeadState::rest()
        }
    }
}

/// The box `[lo, hi]` as a closed mesh of 12 triangles, each turned outwards.
fn box_mesh(lo: &Vector3<f64>, hi: &Vector3<f64>) -> PreviewShape {
    let corner = |i: usize| {
        Vector3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        )
    };
    let vertices = (0..8).map(corner).collect();
    // each face as two triangles, counter-clockwise seen from outside
    let faces: [[usize; 4]; 6] = [
        [0, 2, 3, 1], // z = lo
        [4, 5, 7, 6], // z = hi
        [0, 1, 5, 4], // y = lo
        [2, 6, 7, 3], // y = hi
        [0, 4, 6, 2], // x = lo
        [1, 3, 7, 5], // x = hi
    ];
    let triangles = faces
        .iter()
        .flat_map(|f| [[f[0], f[1], f[2]], [f[0], f[2], f[3]]])
        .collect();
    PreviewShape::Mesh {
        vertices: Arc::new(vertices),
        triangles: Arc::new(triangles),
    }
}

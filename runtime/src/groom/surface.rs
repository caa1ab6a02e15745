//! Points spread uniformly by area over the surface of a body, with the surface's outward
//! unit normal there: the candidates the roots of a groom are chosen from
//! ([`super::poisson`]). Spheres and capsules are sampled exactly; an ellipsoid by
//! rejection from the sphere with the exact area ratio; a mesh by choosing a triangle in
//! proportion to its area and a uniform point in it, its normal interpolated from the
//! corners' angle-weighted pseudonormals (smooth across edges).

use crate::bodies::obj::read_obj;
use crate::bodies::triangle_mesh::ClosedMesh;
use crate::bodies::ShapeSetup;
use nalgebra::{Matrix3, Vector3};
use rand::RngExt;
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// A point of a surface and the outward unit normal there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position, in the coordinates of the body's setup (head coordinates for a body on
    /// the head), m.
    pub position: Vector3<f64>,
    /// Unit outward normal.
    pub normal: Vector3<f64>,
}

/// The surface of a body, ready to be sampled uniformly by area.
#[derive(Debug, Clone)]
pub enum Surface {
    /// A sphere.
    Sphere {
        /// Centre, m.
        center: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// An ellipsoid `|(Rᵀ(y − c))ᵢ / aᵢ| = 1`.
    Ellipsoid {
        /// Centre c, m.
        center: Vector3<f64>,
        /// Half-axes a, m.
        radii: Vector3<f64>,
        /// R: the ellipsoid's axes in the body's coordinates.
        rotation: Matrix3<f64>,
    },
    /// A capsule: a cylinder of radius r around the segment and two half-spheres.
    Capsule {
        /// One end of the axis, m.
        start: Vector3<f64>,
        /// The other end, m.
        end: Vector3<f64>,
        /// Radius, m.
        radius: f64,
    },
    /// A closed triangle mesh.
    Mesh {
        /// The triangles, counter-clockwise seen from outside.
        triangles: Vec<[Vector3<f64>; 3]>,
        /// The unit normal at each corner (the normalised angle-weighted pseudonormal).
        corner_normals: Vec<[Vector3<f64>; 3]>,
        /// Running sum of the triangles' areas (the last is the total area).
        cumulative_area: Vec<f64>,
    },
}

/// Uniform in [0, 1).
fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    rng.random::<f64>()
}

/// A direction uniform on the unit sphere.
fn unit_direction(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let z = 2.0 * uniform(rng) - 1.0;
    let phi = 2.0 * PI * uniform(rng);
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vector3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Two unit vectors completing the unit vector `a` to an orthonormal basis.
fn basis(a: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let k = a.iamin();
    let e = Vector3::ith(k, 1.0);
    let u = (e - a * a.dot(&e)).normalize();
    (u, a.cross(&u))
}

impl Surface {
    /// The surface of a body's shape. A plane has no finite area and is refused; a mesh
    /// file is read and checked (closed, consistently oriented) here. The error says why.
    pub fn from_shape(shape: &ShapeSetup) -> Result<Self, String> {
        Ok(match shape {
            ShapeSetup::Sphere { center, radius } => Surface::Sphere {
                center: *center,
                radius: *radius,
            },
            ShapeSetup::Ellipsoid {
                center,
                radii,
                rotation,
            } => Surface::Ellipsoid {
                center: *center,
                radii: *radii,
                rotation: *rotation,
            },
            ShapeSetup::Capsule { start, end, radius } => Surface::Capsule {
                start: *start,
                end: *end,
                radius: *radius,
            },
            ShapeSetup::Cylinder { .. } => {
                return Err(
                    "hair is not rooted on cylinders; use a sphere, an ellipsoid, a capsule \
                     or a mesh"
                        .into(),
                )
            }
            ShapeSetup::Plane { .. } => {
                return Err(
                    "a plane has no bounded surface to root hair on; use a sphere, \
                            an ellipsoid, a capsule or a mesh"
                        .into(),
                )
            }
            ShapeSetup::Grid { .. } => {
                return Err(
                    "hair is not rooted on grid bodies (their surface is not a mesh); use a \
                     sphere, an ellipsoid, a capsule or a mesh"
                        .into(),
                )
            }
            ShapeSetup::Mesh {
                path,
                scale,
                rotation,
                translation,
                ..
            } => {
                let (vertices, triangles) = read_obj(path)?;
                let placed: Vec<Vector3<f64>> = vertices
                    .iter()
                    .map(|v| rotation * (v * *scale) + translation)
                    .collect();
                let mesh = ClosedMesh::new(&placed, &triangles)
                    .map_err(|m| format!("'{}': {m}", path.display()))?;
                Self::from_mesh(&mesh)
            }
        })
    }

    /// The surface of a checked closed mesh.
    pub fn from_mesh(mesh: &ClosedMesh) -> Self {
        let mut total = 0.0;
        let cumulative_area = mesh
            .triangles
            .iter()
            .map(|t| {
                total += 0.5 * (t[1] - t[0]).cross(&(t[2] - t[0])).norm();
                total
            })
            .collect();
        let corner_normals = mesh
            .vertex_normals
            .iter()
            .zip(&mesh.face_normals)
            .map(|(corners, face)| {
                corners.map(|n| {
                    let norm = n.norm();
                    if norm > 0.0 && norm.is_finite() {
                        n / norm
                    } else {
                        *face
                    }
                })
            })
            .collect();
        Surface::Mesh {
            triangles: mesh.triangles.clone(),
            corner_normals,
            cumulative_area,
        }
    }

    /// The centre a region's cap is measured from by default: the centre of a sphere or
    /// an ellipsoid, the middle of a capsule's axis, the centre of a mesh's box.
    pub fn center(&self) -> Vector3<f64> {
        match self {
            Surface::Sphere { center, .. } | Surface::Ellipsoid { center, .. } => *center,
            Surface::Capsule { start, end, .. } => 0.5 * (start + end),
            Surface::Mesh { triangles, .. } => {
                let mut lo = Vector3::repeat(f64::INFINITY);
                let mut hi = Vector3::repeat(f64::NEG_INFINITY);
                for p in triangles.iter().flatten() {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                0.5 * (lo + hi)
            }
        }
    }

    /// Total area, m². The ellipsoid's is `abc ∫ |u ⊘ a| dΩ` over the unit sphere,
    /// evaluated by the midpoint rule on a 400 × 800 grid in (z, φ), where dΩ = dz dφ
    /// (relative error below 10⁻⁵).
    pub fn area(&self) -> f64 {
        match self {
            Surface::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Surface::Ellipsoid { radii, .. } => {
                let (nz, nphi) = (400, 800);
                let mut sum = 0.0;
                for i in 0..nz {
                    let z = -1.0 + (i as f64 + 0.5) * 2.0 / nz as f64;
                    let r = (1.0 - z * z).sqrt();
                    for j in 0..nphi {
                        let phi = (j as f64 + 0.5) * 2.0 * PI / nphi as f64;
                        let u = Vector3::new(r * phi.cos(), r * phi.sin(), z);
                        sum += u.component_div(radii).norm();
                    }
                }
                let cell = (2.0 / nz as f64) * (2.0 * PI / nphi as f64);
                radii.x * radii.y * radii.z * sum * cell
            }
            Surface::Capsule { start, end, radius } => {
                2.0 * PI * radius * (end - start).norm() + 4.0 * PI * radius * radius
            }
            Surface::Mesh {
                cumulative_area, ..
            } => cumulative_area.last().copied().unwrap_or(0.0),
        }
    }

    /// A point uniformly distributed by area over the surface, and its normal.
    pub fn sample(&self, rng: &mut ChaCha8Rng) -> SurfacePoint {
        match self {
            Surface::Sphere { center, radius } => {
                let d = unit_direction(rng);
                SurfacePoint {
                    position: center + d * *radius,
                    normal: d,
                }
            }
            Surface::Ellipsoid {
                center,
                radii,
                rotation,
            } => {
                // u uniform on the sphere maps to y = c + R (a ∘ u); the area element
                // grows by abc |u ⊘ a|, at most abc / min(a): accept with probability
                // |u ⊘ a| · min(a).
                let min = radii.min();
                loop {
                    let u = unit_direction(rng);
                    let stretch = u.component_div(radii);
                    if uniform(rng) < stretch.norm() * min {
                        return SurfacePoint {
                            position: center + rotation * radii.component_mul(&u),
                            normal: (rotation * stretch).normalize(),
                        };
                    }
                }
            }
            Surface::Capsule { start, end, radius } => {
                let axis = end - start;
                let h = axis.norm();
                let side = 2.0 * PI * radius * h;
                let total = side + 4.0 * PI * radius * radius;
                if h > 0.0 && uniform(rng) * total < side {
                    let a = axis / h;
                    let (u, v) = basis(&a);
                    let phi = 2.0 * PI * uniform(rng);
                    let normal = u * phi.cos() + v * phi.sin();
                    let t = uniform(rng);
                    SurfacePoint {
                        position: start + axis * t + normal * *radius,
                        normal,
                    }
                } else {
                    let d = unit_direction(rng);
                    let cap = if d.dot(&axis) > 0.0 { end } else { start };
                    SurfacePoint {
                        position: cap + d * *radius,
                        normal: d,
                    }
                }
            }
            Surface::Mesh {
                triangles,
                corner_normals,
                cumulative_area,
            } => {
                let total = cumulative_area.last().copied().unwrap_or(0.0);
                let target = uniform(rng) * total;
                let k = cumulative_area
                    .partition_point(|&a| a <= target)
                    .min(triangles.len().saturating_sub(1));
                let (t, n) = (&triangles[k], &corner_normals[k]);
                let (r1, r2) = (uniform(rng).sqrt(), uniform(rng));
                let w = [1.0 - r1, r1 * (1.0 - r2), r1 * r2];
                let position = t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
                let blend = n[0] * w[0] + n[1] * w[1] + n[2] * w[2];
                let normal = if blend.norm() > 1e-12 {
                    blend.normalize()
                } else {
                    (t[1] - t[0]).cross(&(t[2] - t[0])).normalize()
                };
                SurfacePoint { position, normal }
            }
        }
    }
}

//! The exact signed distance to a closed triangle mesh: the closest point by the
//! [`Bvh`], the sign by the angle-weighted pseudonormal of the feature (face, edge or
//! vertex) the closest point lies on (Bærentzen & Aanæs 2005).
//!
//! Why the pseudonormal and not the generalised winding number: on a closed, manifold,
//! consistently oriented mesh — which [`ClosedMesh`] guarantees — `(x − c) · n_ψ > 0`
//! exactly when x is outside (c the closest point, n_ψ the angle-weighted pseudonormal
//! of its feature), and the test costs nothing beyond the closest-point query the
//! distance needs anyway. The winding number is robust on open or self-intersecting
//! meshes, but costs a sum over all triangles per point (or a hierarchical
//! approximation), and those meshes are refused here.

use super::bvh::{Bvh, Hit};
use super::triangle::Feature;
use super::triangle_mesh::ClosedMesh;
use nalgebra::Vector3;

/// The signed distance of a point to a closed mesh, with its closest point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshPoint {
    /// Signed distance, negative inside.
    pub distance: f64,
    /// The closest point of the mesh.
    pub closest: Vector3<f64>,
}

/// A closed mesh and its hierarchy: exact signed distances.
#[derive(Debug, Clone)]
pub struct MeshDistance {
    mesh: ClosedMesh,
    bvh: Bvh,
}

impl MeshDistance {
    /// The distance function of `mesh`.
    pub fn new(mesh: ClosedMesh) -> Self {
        let bvh = Bvh::new(&mesh.triangles);
        Self { mesh, bvh }
    }

    /// The mesh.
    pub fn mesh(&self) -> &ClosedMesh {
        &self.mesh
    }

    /// The signed distance of `p` and its closest point.
    pub fn at(&self, p: &Vector3<f64>) -> MeshPoint {
        self.within(p, f64::INFINITY)
    }

    /// [`MeshDistance::at`], told that the mesh is within distance `bound` of `p` (a
    /// bound too small only costs a second, unbounded search).
    pub fn within(&self, p: &Vector3<f64>, bound: f64) -> MeshPoint {
        let hit = self
            .bvh
            .closest(p, &self.mesh.triangles, bound * bound)
            .or_else(|| self.bvh.closest(p, &self.mesh.triangles, f64::INFINITY));
        let Some(hit) = hit else {
            // unreachable: a closed mesh has triangles and an unbounded search finds one
            return MeshPoint {
                distance: f64::INFINITY,
                closest: *p,
            };
        };
        let distance = hit.distance2.sqrt();
        let outside = (p - hit.point).dot(&self.pseudonormal(&hit)) >= 0.0;
        MeshPoint {
            distance: if outside { distance } else { -distance },
            closest: hit.point,
        }
    }

    /// The angle-weighted pseudonormal of the feature of `hit`.
    fn pseudonormal(&self, hit: &Hit) -> Vector3<f64> {
        let t = hit.triangle;
        match hit.feature {
            Feature::Face => self.mesh.face_normals[t],
            Feature::Edge(k) => self.mesh.edge_normals[t][k as usize],
            Feature::Vertex(k) => self.mesh.vertex_normals[t][k as usize],
        }
    }
}

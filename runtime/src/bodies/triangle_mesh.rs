//! A closed triangle mesh, checked: vertices at the same position welded, every edge
//! shared by exactly two consistently oriented triangles, no triangle without area, each
//! connected piece turned outward (positive enclosed volume); with the angle-weighted
//! pseudonormals of its faces, edges and vertices (Bærentzen & Aanæs, "Signed distance
//! computation using the angle weighted pseudonormal", IEEE TVCG 2005).

use super::triangle::angle_at;
use nalgebra::Vector3;
use std::collections::HashMap;

/// A closed, consistently oriented, outward triangle mesh and its pseudonormals.
#[derive(Debug, Clone)]
pub struct ClosedMesh {
    /// The corners of each triangle, counter-clockwise seen from outside.
    pub triangles: Vec<[Vector3<f64>; 3]>,
    /// Unit normal of each face.
    pub face_normals: Vec<Vector3<f64>>,
    /// Per triangle, the pseudonormal of each edge (0 = ab, 1 = bc, 2 = ca): the sum of
    /// the unit normals of the two faces that share it.
    pub edge_normals: Vec<[Vector3<f64>; 3]>,
    /// Per triangle, the pseudonormal of each corner: the sum over the faces around the
    /// vertex of the face normal times the face's angle there.
    pub vertex_normals: Vec<[Vector3<f64>; 3]>,
    /// Smallest corner of the box around the vertices.
    pub min: Vector3<f64>,
    /// Largest corner of the box around the vertices.
    pub max: Vector3<f64>,
}

/// A point for messages.
fn at(p: &Vector3<f64>) -> String {
    format!("({:.6}, {:.6}, {:.6})", p.x, p.y, p.z)
}

/// Union-find root of `i`, with path halving.
fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

impl ClosedMesh {
    /// Check the mesh of `vertices` and `triangles` (indices into `vertices`) and build its
    /// pseudonormals. The error says what is wrong and where (a position in the mesh's
    /// coordinates).
    pub fn new(vertices: &[Vector3<f64>], triangles: &[[usize; 3]]) -> Result<Self, String> {
        if triangles.is_empty() {
            return Err("the mesh has no triangles (a body mesh must enclose a volume)".into());
        }
        if let Some(v) = vertices.iter().find(|v| !v.iter().all(|x| x.is_finite())) {
            return Err(format!("a vertex is not finite: {v:?}"));
        }
        if let Some((t, _)) = triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i >= vertices.len()))
        {
            return Err(format!(
                "triangle {t} names a vertex beyond the {} vertices",
                vertices.len()
            ));
        }
        // weld vertices at the same position (-0.0 and 0.0 alike)
        let mut welded: HashMap<[u64; 3], usize> = HashMap::new();
        let mut positions = Vec::new();
        let index: Vec<usize> = vertices
            .iter()
            .map(|v| {
                let key = [v.x, v.y, v.z].map(|x| (x + 0.0).to_bits());
                *welded.entry(key).or_insert_with(|| {
                    positions.push(*v);
                    positions.len() - 1
                })
            })
            .collect();
        let mut tris: Vec<[usize; 3]> = triangles.iter().map(|t| t.map(|i| index[i])).collect();

        let (mut min, mut max) = (positions[tris[0][0]], positions[tris[0][0]]);
        for &i in tris.iter().flatten() {
            min = min.inf(&positions[i]);
            max = max.sup(&positions[i]);
        }
        let scale = (max - min).norm();
        for (t, tri) in tris.iter().enumerate() {
            let [a, b, c] = tri.map(|i| positions[i]);
            let area2 = (b - a).cross(&(c - a)).norm();
            if !(area2.is_finite() && area2 > 1e-14 * scale * scale) {
                return Err(format!(
                    "triangle {t} (in file order, after triangulation) near {} has no area; \
                     remove degenerate faces",
                    at(&a)
                ));
            }
        }
        check_edges(&positions, &tris)?;

        // each connected piece outward: flip a piece of negative volume
        let mut parent: Vec<usize> = (0..positions.len()).collect();
        for t in &tris {
            for k in 1..3 {
                let (r0, r1) = (find(&mut parent, t[0]), find(&mut parent, t[k]));
                parent[r1] = r0;
            }
        }
        let mut volume: HashMap<usize, f64> = HashMap::new();
        for t in &tris {
            let [a, b, c] = t.map(|i| positions[i] - min);
            *volume.entry(find(&mut parent, t[0])).or_default() += a.dot(&b.cross(&c)) / 6.0;
        }
        for (&piece, &v) in &volume {
            if !(v.is_finite() && v.abs() > 1e-12 * scale.powi(3)) {
                return Err(format!(
                    "a closed piece of the mesh (around vertex {}) encloses no volume",
                    at(&positions[piece])
                ));
            }
        }
        for t in &mut tris {
            if volume[&find(&mut parent, t[0])] < 0.0 {
                t.swap(1, 2);
            }
        }
        Ok(Self::with_pseudonormals(&positions, &tris, min, max))
    }

    fn with_pseudonormals(
        positions: &[Vector3<f64>],
        tris: &[[usize; 3]],
        min: Vector3<f64>,
        max: Vector3<f64>,
    ) -> Self {
        let triangles: Vec<[Vector3<f64>; 3]> =
            tris.iter().map(|t| t.map(|i| positions[i])).collect();
        let face_normals: Vec<Vector3<f64>> = triangles
            .iter()
            .map(|[a, b, c]| (b - a).cross(&(c - a)).normalize())
            .collect();
        let mut at_vertex = vec![Vector3::zeros(); positions.len()];
        let mut at_edge: HashMap<(usize, usize), Vector3<f64>> = HashMap::new();
        for (t, tri) in tris.iter().enumerate() {
            for k in 0..3 {
                at_vertex[tri[k]] += face_normals[t] * angle_at(&triangles[t], k);
                let (i, j) = (tri[k], tri[(k + 1) % 3]);
                *at_edge.entry((i.min(j), i.max(j))).or_default() += face_normals[t];
            }
        }
        let edge_normals = tris
            .iter()
            .map(|tri| {
                std::array::from_fn(|k| {
                    let (i, j) = (tri[k], tri[(k + 1) % 3]);
                    at_edge[&(i.min(j), i.max(j))]
                })
            })
            .collect();
        let vertex_normals = tris.iter().map(|tri| tri.map(|i| at_vertex[i])).collect();
        Self {
            triangles,
            face_normals,
            edge_normals,
            vertex_normals,
            min,
            max,
        }
    }
}

/// Every edge shared by exactly two triangles that run along it in opposite directions.
fn check_edges(positions: &[Vector3<f64>], tris: &[[usize; 3]]) -> Result<(), String> {
    // per undirected edge: (uses, uses from the smaller vertex to the larger)
    let mut edges: HashMap<(usize, usize), (usize, usize)> = HashMap::new();
    for t in tris {
        for k in 0..3 {
            let (i, j) = (t[k], t[(k + 1) % 3]);
            let e = edges.entry((i.min(j), i.max(j))).or_default();
            e.0 += 1;
            e.1 += usize::from(i < j);
        }
    }
    let mut sorted: Vec<_> = edges.into_iter().collect();
    sorted.sort_unstable();
    let describe = |(i, j): (usize, usize)| {
        format!(
            "the edge from {} to {}",
            at(&positions[i]),
            at(&positions[j])
        )
    };
    let crowded: Vec<_> = sorted.iter().filter(|(_, (n, _))| *n > 2).collect();
    if let Some((e, (n, _))) = crowded.first() {
        return Err(format!(
            "the mesh is not manifold: {} edge(s) are shared by more than two triangles \
             ({} by {n}); every edge must be shared by exactly two",
            crowded.len(),
            describe(*e)
        ));
    }
    let open: Vec<_> = sorted.iter().filter(|(_, (n, _))| *n == 1).collect();
    if let Some((e, _)) = open.first() {
        return Err(format!(
            "the mesh is open: {} edge(s) belong to one triangle only ({} is one); a body \
             mesh must be closed, every edge shared by exactly two triangles",
            open.len(),
            describe(*e)
        ));
    }
    if let Some((e, _)) = sorted.iter().find(|(_, (_, forward))| *forward != 1) {
        return Err(format!(
            "the triangles are not consistently oriented: the two triangles of {} run \
             along it in the same direction",
            describe(*e)
        ));
    }
    Ok(())
}

//! A bounding volume hierarchy over triangles for closest-point queries: axis-aligned
//! boxes, split at the median centroid along the longest side of the centroids' box,
//! leaves of at most `LEAF_SIZE` (4) triangles. A query visits the nearer child first and
//! skips every box farther than the best distance found so far (or than a bound the
//! caller knows), so it touches O(log n) nodes for a point near a mesh of n triangles.

use super::triangle::{closest_point, Feature};
use nalgebra::Vector3;

/// Most triangles of a leaf.
const LEAF_SIZE: usize = 4;
/// Depth of the traversal stack: a median split halves the triangles at each level, so
/// depth ≤ log2(n) + 1 < 64 for any n.
const STACK: usize = 64;

#[derive(Debug, Clone)]
struct Node {
    min: Vector3<f64>,
    max: Vector3<f64>,
    /// A leaf: the start of its triangles in `order`; an inner node: its first child
    /// (the second follows it).
    first: u32,
    /// Triangles of a leaf; 0 for an inner node.
    count: u32,
}

impl Node {
    /// Squared distance from `p` to the box (0 inside).
    fn distance2(&self, p: &Vector3<f64>) -> f64 {
        let d = (self.min - p).sup(&(p - self.max)).sup(&Vector3::zeros());
        d.norm_squared()
    }
}

/// The closest point of a mesh to a query point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Index of the triangle.
    pub triangle: usize,
    /// The closest point.
    pub point: Vector3<f64>,
    /// Where on the triangle it lies.
    pub feature: Feature,
    /// Squared distance to it.
    pub distance2: f64,
}

/// The hierarchy over a list of triangles (kept by the caller).
#[derive(Debug, Clone)]
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

impl Bvh {
    /// The hierarchy of `triangles` (fewer than 2³² of them; none: every query finds
    /// nothing).
    pub fn new(triangles: &[[Vector3<f64>; 3]]) -> Self {
        if triangles.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                order: Vec::new(),
            };
        }
        let centroids: Vec<Vector3<f64>> = triangles
            .iter()
            .map(|[a, b, c]| (a + b + c) / 3.0)
            .collect();
        let mut bvh = Bvh {
            nodes: Vec::with_capacity(2 * triangles.len() / LEAF_SIZE + 1),
            order: (0..triangles.len() as u32).collect(),
        };
        bvh.nodes.push(Node {
            min: Vector3::zeros(),
            max: Vector3::zeros(),
            first: 0,
            count: 0,
        });
        bvh.build(0, 0, triangles.len(), triangles, &centroids);
        bvh
    }

    /// Fill node `node` with the triangles `order[start..end]`.
    fn build(
        &mut self,
        node: usize,
        start: usize,
        end: usize,
        triangles: &[[Vector3<f64>; 3]],
        centroids: &[Vector3<f64>],
    ) {
        let ids = &mut self.order[start..end];
        let first = &triangles[ids[0] as usize][0];
        let (mut min, mut max) = (*first, *first);
        let (mut cmin, mut cmax) = (centroids[ids[0] as usize], centroids[ids[0] as usize]);
        for &t in ids.iter() {
            for v in &triangles[t as usize] {
                min = min.inf(v);
                max = max.sup(v);
            }
            cmin = cmin.inf(&centroids[t as usize]);
            cmax = cmax.sup(&centroids[t as usize]);
        }
        self.nodes[node].min = min;
        self.nodes[node].max = max;
        if end - start <= LEAF_SIZE {
            self.nodes[node].first = start as u32;
            self.nodes[node].count = (end - start) as u32;
            return;
        }
        let axis = (cmax - cmin).imax();
        let mid = start + (end - start) / 2;
        ids.select_nth_unstable_by(mid - start, |&a, &b| {
            centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
        });
        let left = self.nodes.len();
        for _ in 0..2 {
            self.nodes.push(Node {
                min: Vector3::zeros(),
                max: Vector3::zeros(),
                first: 0,
                count: 0,
            });
        }
        self.nodes[node].first = left as u32;
        self.build(left, start, mid, triangles, centroids);
        self.build(left + 1, mid, end, triangles, centroids);
    }

    /// The closest point of `triangles` (those the hierarchy was built on) to `p`, among
    /// those at squared distance below `bound2` (`f64::INFINITY`: no bound); `None` when
    /// no triangle is that close.
    pub fn closest(
        &self,
        p: &Vector3<f64>,
        triangles: &[[Vector3<f64>; 3]],
        bound2: f64,
    ) -> Option<Hit> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<Hit> = None;
        let mut best2 = bound2;
        let mut stack = [0u32; STACK];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let node = &self.nodes[stack[depth] as usize];
            if node.distance2(p) >= best2 {
                continue;
            }
            if node.count > 0 {
                let start = node.first as usize;
                for &t in &self.order[start..start + node.count as usize] {
                    let t = t as usize;
                    let (point, feature) = closest_point(p, &triangles[t]);
                    let d2 = (p - point).norm_squared();
                    if d2 < best2 {
                        best2 = d2;
                        best = Some(Hit {
                            triangle: t,
                            point,
                            feature,
                            distance2: d2,
                        });
                    }
                }
                continue;
            }
            let (a, b) = (node.first, node.first + 1);
            let (da, db) = (
                self.nodes[a as usize].distance2(p),
                self.nodes[b as usize].distance2(p),
            );
            // the nearer child goes on top of the stack; the stack holds at most one entry
            // per level plus one, so it never fills (the guard keeps indexing in bounds)
            let (near, far) = if da <= db { (a, b) } else { (b, a) };
            debug_assert!(depth + 2 <= STACK);
            if depth + 2 <= STACK {
                stack[depth] = far;
                stack[depth + 1] = near;
                depth += 2;
            }
        }
        best
    }
}

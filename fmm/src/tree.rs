//! The adaptive octree: particles sorted along a Morton curve, boxes split while they
//! hold more than a leaf's worth, empty children left out (hair is strongly
//! non-uniform: particles lie on curves, most of space is empty).

use rayon::prelude::*;

/// Bits per axis of the Morton keys (the deepest level a box can have).
pub const MAX_LEVEL: u32 = 21;

/// One box of the octree.
#[derive(Debug, Clone, Copy)]
pub struct Node {
    /// Centre of the expansions: the centre of the bounding box of the node's particles.
    pub centre: [f64; 3],
    /// Largest distance of a particle of the node from `centre`.
    pub radius: f64,
    /// First particle (in the tree's order).
    pub start: u32,
    /// One past the last particle.
    pub end: u32,
    /// First child (children are consecutive); 0 for a leaf.
    pub first_child: u32,
    /// Number of children (0: a leaf).
    pub children: u8,
    /// Depth (root 0).
    pub level: u8,
    /// Parent (the root is its own parent).
    pub parent: u32,
}

impl Node {
    /// Whether the node has no children.
    pub fn is_leaf(&self) -> bool {
        self.children == 0
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        (self.end - self.start) as usize
    }

    /// Whether it holds no particle (only an empty root can).
    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }

    /// The range of its particles.
    pub fn range(&self) -> core::ops::Range<usize> {
        self.start as usize..self.end as usize
    }

    /// The range of its children.
    pub fn child_range(&self) -> core::ops::Range<usize> {
        self.first_child as usize..self.first_child as usize + self.children as usize
    }
}

/// The octree over a point set.
#[derive(Debug, Clone, Default)]
pub struct Octree {
    /// Nodes in breadth-first order (root first; every level contiguous).
    pub nodes: Vec<Node>,
    /// Node ranges of each level.
    pub levels: Vec<core::ops::Range<usize>>,
    /// `order[k]`: the input index of the k-th particle in tree order.
    pub order: Vec<u32>,
    /// Positions in tree order.
    pub points: Vec<[f64; 3]>,
    /// Indices of the leaves.
    pub leaves: Vec<u32>,
    keys: Vec<u64>,
}

fn spread(v: u64) -> u64 {
    // Spread the low 21 bits of v to every third bit.
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    x = (x | x << 2) & 0x1249249249249249;
    x
}

impl Octree {
    /// Build the tree of `points` with at most `leaf_size` particles per leaf (more
    /// only at [`MAX_LEVEL`], for points closer than `2^−21` of the cube's side). Reuses
    /// this tree's buffers.
    pub fn build(&mut self, points: &[[f64; 3]], leaf_size: usize) {
        let n = points.len();
        let leaf_size = leaf_size.max(1);
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in points {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        let side = (0..3).map(|a| hi[a] - lo[a]).fold(0.0, f64::max);
        let side = if side > 0.0 { side * (1.0 + 1e-9) } else { 1.0 };
        let scale = (1u64 << MAX_LEVEL) as f64 / side;
        let cell = |v: f64, a: usize| (((v - lo[a]) * scale) as u64).min((1 << MAX_LEVEL) - 1);
        let mut pairs: Vec<(u64, u32)> = points
            .par_iter()
            .enumerate()
            .map(|(i, p)| {
                let k =
                    spread(cell(p[0], 0)) | spread(cell(p[1], 1)) << 1 | spread(cell(p[2], 2)) << 2;
                (k, i as u32)
            })
            .collect();
        pairs.par_sort_unstable();
        self.keys.clear();
        self.keys.extend(pairs.iter().map(|p| p.0));
        self.order.clear();
        self.order.extend(pairs.iter().map(|p| p.1));
        self.points.clear();
        self.points
            .extend(self.order.iter().map(|&i| points[i as usize]));
        self.nodes.clear();
        self.levels.clear();
        self.leaves.clear();
        self.nodes.push(Node {
            centre: [0.0; 3],
            radius: 0.0,
            start: 0,
            end: n as u32,
            first_child: 0,
            children: 0,
            level: 0,
            parent: 0,
        });
        let mut level_start = 0;
        for level in 0..=MAX_LEVEL {
            let level_end = self.nodes.len();
            self.levels.push(level_start..level_end);
            if level == MAX_LEVEL {
                break;
            }
            let shift = 3 * (MAX_LEVEL - 1 - level);
            for i in level_start..level_end {
                let node = self.nodes[i];
                if node.len() <= leaf_size {
                    continue;
                }
                let first = self.nodes.len() as u32;
                let keys = &self.keys[node.range()];
                let mut s = 0;
                let mut count = 0u8;
                while s < keys.len() {
                    let octant = (keys[s] >> shift) & 7;
                    let e = s + keys[s..].partition_point(|k| (k >> shift) & 7 == octant);
                    self.nodes.push(Node {
                        centre: [0.0; 3],
                        radius: 0.0,
                        start: node.start + s as u32,
                        end: node.start + e as u32,
                        first_child: 0,
                        children: 0,
                        level: (level + 1) as u8,
                        parent: i as u32,
                    });
                    count += 1;
                    s = e;
                }
                self.nodes[i].first_child = first;
                self.nodes[i].children = count;
            }
            level_start = level_end;
            if self.nodes.len() == level_end {
                break;
            }
        }
        let pts = &self.points;
        self.nodes.par_iter_mut().for_each(|node| {
            let mut lo = [f64::INFINITY; 3];
            let mut hi = [f64::NEG_INFINITY; 3];
            for p in &pts[node.range()] {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
            if node.is_empty() {
                return;
            }
            let c = [
                (lo[0] + hi[0]) / 2.0,
                (lo[1] + hi[1]) / 2.0,
                (lo[2] + hi[2]) / 2.0,
            ];
            let mut r2: f64 = 0.0;
            for p in &pts[node.range()] {
                let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
                r2 = r2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            }
            node.centre = c;
            node.radius = r2.sqrt();
        });
        self.leaves.extend(
            self.nodes
                .iter()
                .enumerate()
                .filter(|(_, n)| n.is_leaf())
                .map(|(i, _)| i as u32),
        );
    }
}

//! The nearest guide roots of each guide root: a uniform grid of cells (a hash of cell
//! coordinates), searched shell by shell.

use nalgebra::Vector3;
use std::collections::HashMap;

/// Points in a grid of cells for nearest-neighbour queries.
pub struct PointGrid<'a> {
    points: &'a [Vector3<f64>],
    origin: Vector3<f64>,
    cell: f64,
    cells: HashMap<[i64; 3], Vec<u32>>,
    /// Largest shell a search may need: the box's diagonal in cells.
    max_shell: i64,
}

impl<'a> PointGrid<'a> {
    /// The grid of `points` (finite), with about one point per cell for points spread over
    /// a surface.
    pub fn new(points: &'a [Vector3<f64>]) -> Self {
        let mut lo = Vector3::repeat(f64::INFINITY);
        let mut hi = Vector3::repeat(f64::NEG_INFINITY);
        for p in points {
            lo = lo.inf(p);
            hi = hi.sup(p);
        }
        if points.is_empty() {
            lo = Vector3::zeros();
            hi = Vector3::zeros();
        }
        let diagonal = (hi - lo).norm();
        let n = points.len().max(1) as f64;
        let cell = if diagonal > 0.0 {
            (diagonal / n.sqrt()).max(diagonal * 1e-6)
        } else {
            1.0
        };
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in points.iter().enumerate() {
            cells
                .entry(cell_of(&lo, cell, p))
                .or_default()
                .push(i as u32);
        }
        Self {
            points,
            origin: lo,
            cell,
            cells,
            max_shell: (diagonal / cell).ceil() as i64 + 1,
        }
    }

    /// Up to `k` points nearest to point `i` (other than `i`) within `radius`, nearest
    /// first, with their distances.
    pub fn nearest(&self, i: usize, k: usize, radius: f64) -> Vec<(u32, f64)> {
        let p = self.points[i];
        let centre = cell_of(&self.origin, self.cell, &p);
        let mut found: Vec<(u32, f64)> = Vec::new();
        let shells = if radius.is_finite() {
            ((radius / self.cell).ceil() as i64 + 1).min(self.max_shell)
        } else {
            self.max_shell
        };
        for s in 0..=shells {
            // every point of a later shell is farther than (s − 1) cells
            if found.len() >= k && (s - 1) as f64 * self.cell > found[k - 1].1 {
                break;
            }
            for_shell(centre, s, |c| {
                if let Some(list) = self.cells.get(&c) {
                    for &j in list {
                        if j as usize == i {
                            continue;
                        }
                        let d = (self.points[j as usize] - p).norm();
                        if d <= radius {
                            found.push((j, d));
                        }
                    }
                }
            });
            found.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            found.truncate(k);
        }
        found
    }
}

fn cell_of(origin: &Vector3<f64>, cell: f64, p: &Vector3<f64>) -> [i64; 3] {
    [0, 1, 2].map(|c| ((p[c] - origin[c]) / cell).floor() as i64)
}

/// Call `f` on every cell at Chebyshev distance exactly `s` from `c`.
fn for_shell(c: [i64; 3], s: i64, mut f: impl FnMut([i64; 3])) {
    for dx in -s..=s {
        for dy in -s..=s {
            let on_side = dx.abs() == s || dy.abs() == s;
            if on_side {
                for dz in -s..=s {
                    f([c[0] + dx, c[1] + dy, c[2] + dz]);
                }
            } else {
                f([c[0] + dx, c[1] + dy, c[2] - s]);
                if s > 0 {
                    f([c[0] + dx, c[1] + dy, c[2] + s]);
                }
            }
        }
    }
}

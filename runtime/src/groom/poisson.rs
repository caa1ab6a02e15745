//! Poisson-disk subsets of a point set by weighted sample elimination (Yuksel, *Sample
//! Elimination for Generating Poisson Disk Sample Sets*, Eurographics 2015): from M
//! candidates spread uniformly over a surface, the candidate with the largest weight —
//! the one most crowded by its neighbours — is removed until `count` remain. The result
//! has exactly `count` points, spread as a Poisson-disk set (no two close together), and
//! depends only on the candidates (deterministic).
//!
//! Weights (Yuksel's eq. 1–2 with weight limiting): for points i, j at distance d_ij,
//! `w_ij = (1 − d̂_ij / (2 r_max))^α` with α = 8 and `d̂_ij = max(d_ij, 2 r_min)` for
//! `d_ij < 2 r_max`, 0 beyond. `r_max = sqrt(A / (2√3 N))` is the largest Poisson-disk
//! radius of N points on an area A (hexagonal packing), `r_min = r_max β (1 − (N/M)^γ)`
//! with β = 0.65, γ = 1.5. Distances are straight-line (3D), which on a surface is the
//! geodesic distance to second order in r / (radius of curvature).

use nalgebra::Vector3;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

/// Exponent α of the weight function.
const ALPHA: f64 = 8.0;
/// β of the weight limiting.
const BETA: f64 = 0.65;
/// γ of the weight limiting.
const GAMMA: f64 = 1.5;

/// The largest Poisson-disk radius of `count` points on area `area` (hexagonal packing):
/// `sqrt(A / (2√3 N))`; the spacing of the packing's neighbours is twice it.
pub fn max_radius(area: f64, count: usize) -> f64 {
    (area / (2.0 * 3f64.sqrt() * count.max(1) as f64)).sqrt()
}

/// A heap entry: weight and point, ordered by weight (ties by index, for determinism).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    weight: f64,
    index: usize,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.weight
            .total_cmp(&other.weight)
            .then(other.index.cmp(&self.index))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// The indices (ascending) of `count` of the `points`, chosen by weighted sample
/// elimination over a surface of area `area` (m²). All indices when `count ≥` the number
/// of points.
pub fn eliminate(points: &[Vector3<f64>], count: usize, area: f64) -> Vec<usize> {
    let m = points.len();
    if count >= m {
        return (0..m).collect();
    }
    let r_max = max_radius(area, count);
    let r_min = r_max * BETA * (1.0 - (count as f64 / m as f64).powf(GAMMA));
    let reach = 2.0 * r_max;
    let weight = |d: f64| {
        let d = d.max(2.0 * r_min);
        (1.0 - d / reach).max(0.0).powf(ALPHA)
    };
    let neighbours = neighbour_lists(points, reach);
    let mut weights: Vec<f64> = neighbours
        .iter()
        .map(|list| list.iter().map(|&(_, d)| weight(d)).sum())
        .collect();
    let mut heap: BinaryHeap<Entry> = weights
        .iter()
        .enumerate()
        .map(|(index, &weight)| Entry { weight, index })
        .collect();
    let mut alive = vec![true; m];
    let mut remaining = m;
    while remaining > count {
        let Some(top) = heap.pop() else { break };
        // an entry is stale when the point is gone or its weight has fallen since
        if !alive[top.index] || top.weight != weights[top.index] {
            continue;
        }
        alive[top.index] = false;
        remaining -= 1;
        for &(j, d) in &neighbours[top.index] {
            if alive[j] {
                weights[j] -= weight(d);
                heap.push(Entry {
                    weight: weights[j],
                    index: j,
                });
            }
        }
    }
    (0..m).filter(|&i| alive[i]).collect()
}

/// For every point, the other points closer than `reach` and their distances (a uniform
/// grid of cell `reach`).
fn neighbour_lists(points: &[Vector3<f64>], reach: f64) -> Vec<Vec<(usize, f64)>> {
    let cell = |p: &Vector3<f64>| p.map(|x| (x / reach).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        let c = cell(p);
        grid.entry([c.x, c.y, c.z]).or_default().push(i);
    }
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let c = cell(p);
            let mut list = Vec::new();
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let Some(members) = grid.get(&[c.x + dx, c.y + dy, c.z + dz]) else {
                            continue;
                        };
                        for &j in members {
                            let d = (points[j] - p).norm();
                            if j != i && d < reach {
                                list.push((j, d));
                            }
                        }
                    }
                }
            }
            list.sort_by_key(|&(j, _)| j);
            list
        })
        .collect()
}

/// The smallest distance between two of the `points` (a uniform grid of cell `cell`,
/// which should be about the expected spacing); infinity for fewer than two points.
pub fn min_distance(points: &[Vector3<f64>], cell: f64) -> f64 {
    let mut best = f64::INFINITY;
    if points.len() < 2 || cell.is_nan() || cell <= 0.0 {
        return best;
    }
    let key = |p: &Vector3<f64>| p.map(|x| (x / cell).floor() as i64);
    let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        let c = key(p);
        grid.entry([c.x, c.y, c.z]).or_default().push(i);
    }
    for (i, p) in points.iter().enumerate() {
        let c = key(p);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(members) = grid.get(&[c.x + dx, c.y + dy, c.z + dz]) {
                        for &j in members.iter().filter(|&&j| j > i) {
                            best = best.min((points[j] - p).norm());
                        }
                    }
                }
            }
        }
    }
    if best > cell && points.len() <= 5_000 {
        // no pair within a cell of each other: fall back on every pair (a larger set
        // keeps the bound: the smallest distance is then at least the cell)
        for (i, p) in points.iter().enumerate() {
            for q in &points[i + 1..] {
                best = best.min((q - p).norm());
            }
        }
    }
    best
}

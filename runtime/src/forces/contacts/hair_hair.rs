//! Hair–hair interaction between the simulated strands (paper section 4.1): "detection is
//! efficiently processed by exploiting temporal coherence, as in [Raghupathi et al.
//! 2003]: we avoid the quadratic cost of computing proximity of guide strands by keeping
//! track of pairs of closest points over time. As in [Choe et al. 2005], contacts between
//! hair volumes are handled by dissipative penalty forces."
//!
//! Each strand is a chain of contact samples ([`super::StrandContacts::samples`]). A
//! *pair* joins a sample of one strand to a sample of another where the two centrelines
//! are locally closest. Before every step:
//!
//! 1. the pairs of the last step are tracked: each side walks along its chain to the
//!    sample closest to the other side (a local descent, a few samples at most when the
//!    motion is coherent), and a pair whose points drifted apart beyond the search
//!    distance is dropped;
//! 2. every `search_every` steps a broad phase finds new pairs: the samples of every
//!    strand are hashed on a grid of cells of the search distance (the reach plus twice
//!    the largest motion of a sample over the last step, or the distance a point at rest
//!    falls in two steps when that is more; between 2 and 1 + [`SEARCH_MARGIN`] reaches),
//!    and
//!    the sample pairs of different strands within it that are local minima of the
//!    distance along both chains become pairs;
//! 3. each pair is refined to the closest points of the two polylines near its samples
//!    (segment against segment), and gives each of its two strands a
//!    [`super::PartnerPoint`]: its own arc length there, and the other side's point and
//!    velocity (from the last two positions), which the strand's step treats as a moving
//!    ball of radius reach (a penalty along the line of centres and a damping of the
//!    relative velocity, both implicit on the strand's own side).
//!
//! A pair found already overlapping (at the first update, or after the two strands met
//! between two searches) is allowed its overlap ([`HairHair::with_depenetration_speed`]):
//! its reach is reduced by the allowance, which shrinks at the depenetration speed, so the
//! two strands are let apart rather than kicked apart by the whole penalty at once.
//!
//! The cost per step is linear in the number of samples (the grid) plus the pairs.

use super::strand_contacts::PartnerPoint;
use nalgebra::Vector3;
use std::collections::HashMap;

/// Most margin the search adds to the reach, in reaches: two strands approaching each
/// other faster than this per step may pass without meeting (the cost of a wider search
/// grows with the cube of its radius).
pub const SEARCH_MARGIN: f64 = 4.0;

/// A pair of samples of two strands: (strand, sample) each, the first strand lower.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Pair {
    /// (strand, sample) of the first side.
    pub a: (usize, usize),
    /// (strand, sample) of the second side.
    pub b: (usize, usize),
}

/// The tracked pairs and the broad phase.
#[derive(Debug, Clone, Default)]
pub struct HairHair {
    pairs: Vec<Pair>,
    previous: Vec<Vec<Vector3<f64>>>,
    grid: HashMap<[i64; 3], Vec<(u32, u32)>>,
    steps: usize,
    search_every: usize,
    tracked_last: usize,
    found_last: usize,
    /// Overlap allowed to a pair of strands found already overlapping (strand indices,
    /// lower first), m; it shrinks at `depenetration_speed`.
    allowance: HashMap<(usize, usize), f64>,
    depenetration_speed: f64,
}

/// What the last update did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PairCounts {
    /// Pairs after the update.
    pub pairs: usize,
    /// Pairs carried over from the step before by tracking.
    pub tracked: usize,
    /// Pairs the broad phase added.
    pub found: usize,
}

fn dist2(p: &[Vec<Vector3<f64>>], a: (usize, usize), b: (usize, usize)) -> f64 {
    (p[a.0][a.1] - p[b.0][b.1]).norm_squared()
}

/// Walk the side `which` (0: a, 1: b) of `pair` to the sample of its chain closest to the
/// other side's point.
fn descend(p: &[Vec<Vector3<f64>>], pair: &mut Pair, which: usize) {
    loop {
        let (own, other) = if which == 0 {
            (pair.a, pair.b)
        } else {
            (pair.b, pair.a)
        };
        let here = dist2(p, own, other);
        let len = p[own.0].len();
        let mut best = (here, own.1);
        for k in [own.1.wrapping_sub(1), own.1 + 1] {
            if k < len {
                let d = dist2(p, (own.0, k), other);
                if d < best.0 {
                    best = (d, k);
                }
            }
        }
        if best.1 == own.1 {
            return;
        }
        if which == 0 {
            pair.a.1 = best.1;
        } else {
            pair.b.1 = best.1;
        }
    }
}

impl HairHair {
    /// An empty set of pairs; the broad phase runs every `search_every` steps.
    pub fn new(search_every: usize) -> Self {
        HairHair {
            search_every: search_every.max(1),
            ..Default::default()
        }
    }

    /// Let two strands that are found already overlapping (at the first update, or on
    /// first meeting between two searches) apart at `speed` (m/s) rather than kick them
    /// apart: their overlap when found is allowed (no force), and the allowance shrinks by
    /// `speed` per second and to their present overlap (0, the default: no allowance, any
    /// overlap is pushed out at once).
    pub fn with_depenetration_speed(mut self, speed: f64) -> Self {
        self.depenetration_speed = speed;
        self
    }

    /// The current pairs.
    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    /// What the last update did.
    pub fn counts(&self) -> PairCounts {
        PairCounts {
            pairs: self.pairs.len(),
            tracked: self.tracked_last,
            found: self.found_last,
        }
    }

    /// Update the pairs for the sample positions `points` (world, per strand per sample;
    /// `arcs` their arc lengths and weights) with interaction distance `reach`, and give each strand its partner points (the
    /// velocities from the positions of the last update, `h` seconds ago; zero at the
    /// first). `fall` is how far a point starting at rest may move in the coming step
    /// (|g| h²: twice the free fall), the least margin of the search.
    pub fn update(
        &mut self,
        points: &[Vec<Vector3<f64>>],
        arcs: &[&[(f64, f64)]],
        reach: f64,
        h: f64,
        fall: f64,
    ) -> Vec<Vec<PartnerPoint>> {
        // the search reaches as far as the samples moved over the last step, twice (a pair
        // must exist before the two points meet: the step that brings them together is
        // split by the strand's contact check until it resolves the approach)
        let moved = self
            .previous
            .iter()
            .zip(points)
            .filter(|(a, b)| a.len() == b.len())
            .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).norm()))
            .fold(0.0, f64::max);
        let reach_search = reach + (2.0 * moved).max(fall).clamp(reach, SEARCH_MARGIN * reach);
        // 1. track
        let mut tracked: Vec<Pair> = self
            .pairs
            .iter()
            .filter(|p| p.a.0 < points.len() && p.b.0 < points.len())
            .map(|p| {
                let mut p = *p;
                for _ in 0..4 {
                    let before = p;
                    descend(points, &mut p, 0);
                    descend(points, &mut p, 1);
                    if p == before {
                        break;
                    }
                }
                p
            })
            .filter(|p| dist2(points, p.a, p.b) < reach_search * reach_search)
            .collect();
        tracked.sort_unstable();
        tracked.dedup();
        self.tracked_last = tracked.len();
        // the pairs of strands already in contact: a pair the search finds between them
        // again is no new meeting and takes no allowance
        let known: std::collections::HashSet<(usize, usize)> = if self.depenetration_speed > 0.0 {
            tracked.iter().map(|p| (p.a.0, p.b.0)).collect()
        } else {
            Default::default()
        };
        // 2. broad phase
        let mut found = 0;
        let mut new_pairs = Vec::new();
        if self.steps % self.search_every == 0 {
            self.grid.values_mut().for_each(Vec::clear);
            let cell = reach_search;
            let key = |x: &Vector3<f64>| {
                [
                    (x.x / cell).floor() as i64,
                    (x.y / cell).floor() as i64,
                    (x.z / cell).floor() as i64,
                ]
            };
            for (i, chain) in points.iter().enumerate() {
                for (k, x) in chain.iter().enumerate() {
                    if x.iter().all(|c| c.is_finite()) {
                        self.grid
                            .entry(key(x))
                            .or_default()
                            .push((i as u32, k as u32));
                    }
                }
            }
            self.grid.retain(|_, v| !v.is_empty());
            let r2 = reach_search * reach_search;
            let mut candidates = Vec::new();
            for (c, list) in &self.grid {
                for dx in -1..=1 {
                    for dy in -1..=1 {
                        for dz in -1..=1 {
                            let Some(other) = self.grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                            else {
                                continue;
                            };
                            for &(i, k) in list {
                                for &(j, l) in other {
                                    if i >= j {
                                        continue;
                                    }
                                    let a = (i as usize, k as usize);
                                    let b = (j as usize, l as usize);
                                    if dist2(points, a, b) < r2 {
                                        candidates.push(Pair { a, b });
                                    }
                                }
                            }
                        }
                    }
                }
            }
            // keep the local minima of the distance along both chains
            for mut p in candidates {
                descend(points, &mut p, 0);
                descend(points, &mut p, 1);
                if dist2(points, p.a, p.b) < r2 && tracked.binary_search(&p).is_err() {
                    new_pairs.push(p);
                }
            }
            new_pairs.sort_unstable();
            new_pairs.dedup();
            found = new_pairs.len();
            // appended and sorted once (inserting each new pair in place would move the
            // list once per pair)
            tracked.extend_from_slice(&new_pairs);
            tracked.sort_unstable();
        }
        self.found_last = found;
        self.steps += 1;
        // 3. partners
        let velocity = |s: usize, k: usize| match self.previous.get(s).and_then(|c| c.get(k)) {
            Some(x0) if h > 0.0 && self.previous[s].len() == points[s].len() => {
                (points[s][k] - x0) / h
            }
            _ => Vector3::zeros(),
        };
        let mut partners: Vec<Vec<PartnerPoint>> = vec![Vec::new(); points.len()];
        let closest: Vec<(f64, f64)> = tracked
            .iter()
            .map(|p| closest_on_chains(points, p.a, p.b))
            .collect();
        // the allowances: a pair that is found already overlapping (at the first update,
        // or after the two strands met between two searches) is allowed its overlap, so
        // that it is let apart at the depenetration speed rather than pushed apart by its
        // whole penalty at once; an allowance shrinks by that speed and to the pair's
        // present overlap
        if self.depenetration_speed > 0.0 {
            let mut overlap: HashMap<(usize, usize), f64> = HashMap::new();
            let mut fresh: HashMap<(usize, usize), f64> = HashMap::new();
            for (p, &(ta, tb)) in tracked.iter().zip(&closest) {
                let depth = reach - (point_at(points, p.a, ta) - point_at(points, p.b, tb)).norm();
                if depth <= 0.0 {
                    continue;
                }
                let key = (p.a.0, p.b.0);
                let o = overlap.entry(key).or_insert(0.0);
                *o = o.max(depth);
                if new_pairs.binary_search(p).is_ok() && !known.contains(&key) {
                    let f = fresh.entry(key).or_insert(0.0);
                    *f = f.max(depth);
                }
            }
            let shrink = self.depenetration_speed * h;
            self.allowance.retain(|k, a| {
                *a = a.min(overlap.get(k).copied().unwrap_or(0.0)) - shrink;
                *a > 0.0
            });
            for (k, f) in fresh {
                let a = self.allowance.entry(k).or_insert(0.0);
                *a = a.max(f);
            }
        }
        for (p, &(ta, tb)) in tracked.iter().zip(&closest) {
            let reach = reach - self.allowance.get(&(p.a.0, p.b.0)).copied().unwrap_or(0.0);
            let at = |side: (usize, usize), t: f64| -> (f64, f64, Vector3<f64>, Vector3<f64>) {
                // the point at parameter t ∈ [−1, 1] around sample side.1: its arc
                // length, weight, position and velocity (linear between samples)
                let (s, k) = side;
                let j = if t < 0.0 { k - 1 } else { k + 1 };
                let f = t.abs();
                let (arc, wt) = arcs[s][k];
                let (arc2, _) = arcs[s].get(j).copied().unwrap_or((arc, wt));
                let x = points[s][k]
                    + (points[s].get(j).copied().unwrap_or(points[s][k]) - points[s][k]) * f;
                let v0 = velocity(s, k);
                let v = if j < points[s].len() {
                    v0 + (velocity(s, j) - v0) * f
                } else {
                    v0
                };
                (arc + (arc2 - arc) * f, wt, x, v)
            };
            let (sa, wa, xa, va) = at(p.a, ta);
            let (sb, wb, xb, vb) = at(p.b, tb);
            let weight = wa.min(wb);
            partners[p.a.0].push(PartnerPoint {
                s: sa,
                weight,
                point: xb,
                velocity: vb,
                reach,
            });
            partners[p.b.0].push(PartnerPoint {
                s: sb,
                weight,
                point: xa,
                velocity: va,
                reach,
            });
        }
        self.pairs = tracked;
        self.previous.resize(points.len(), Vec::new());
        for (prev, now) in self.previous.iter_mut().zip(points) {
            prev.clear();
            prev.extend_from_slice(now);
        }
        partners
    }
}

/// Closest points of the two segments `p0 + t (p1 − p0)` and `q0 + u (q1 − q0)`,
/// t, u ∈ [0, 1]: (t, u, squared distance).
fn segment_closest(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64, f64) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let (mut t, mut u);
    if a <= f64::EPSILON && e <= f64::EPSILON {
        (t, u) = (0.0, 0.0);
    } else if a <= f64::EPSILON {
        t = 0.0;
        u = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(&r);
        if e <= f64::EPSILON {
            u = 0.0;
            t = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            t = if denom > 0.0 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            u = (b * t + f) / e;
            if u < 0.0 {
                u = 0.0;
                t = (-c / a).clamp(0.0, 1.0);
            } else if u > 1.0 {
                u = 1.0;
                t = ((b - c) / a).clamp(0.0, 1.0);
            }
        }
    }
    let d = (p0 + d1 * t) - (q0 + d2 * u);
    (t, u, d.norm_squared())
}

/// The closest points of the two chains around samples `a` and `b`, among the segments
/// to each side's neighbours: parameters in [−1, 1] (−1: the previous sample, 1: the
/// next, 0: the sample itself).
fn closest_on_chains(p: &[Vec<Vector3<f64>>], a: (usize, usize), b: (usize, usize)) -> (f64, f64) {
    let sides = |(s, k): (usize, usize)| {
        let chain = &p[s];
        let mut out = [None, None];
        if k > 0 {
            out[0] = Some((k - 1, -1.0));
        }
        if k + 1 < chain.len() {
            out[1] = Some((k + 1, 1.0));
        }
        out
    };
    let mut best = (0.0, 0.0, (p[a.0][a.1] - p[b.0][b.1]).norm_squared());
    for (ja, sa) in sides(a).into_iter().flatten() {
        for (jb, sb) in sides(b).into_iter().flatten() {
            let (t, u, d) = segment_closest(&p[a.0][a.1], &p[a.0][ja], &p[b.0][b.1], &p[b.0][jb]);
            if d < best.2 {
                best = (sa * t, sb * u, d);
            }
        }
    }
    (best.0, best.1)
}

/// The point at parameter t ∈ [−1, 1] around sample `side` of its chain (linear between
/// samples; as [`closest_on_chains`] returns).
fn point_at(p: &[Vec<Vector3<f64>>], (s, k): (usize, usize), t: f64) -> Vector3<f64> {
    let j = if t < 0.0 { k.wrapping_sub(1) } else { k + 1 };
    match p[s].get(j) {
        Some(x) => p[s][k] + (x - p[s][k]) * t.abs(),
        None => p[s][k],
    }
}

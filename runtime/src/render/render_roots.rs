//! Where the render strands grow and which guides each one blends (paper section 4.1,
//! "Generating the rendered hair geometry"): the roots are placed once, seeded, among the
//! guide roots, in head coordinates.
//!
//! The guide roots are triangulated locally: each root's 8 nearest roots within
//! `max_spacing` are its candidate neighbours; a triangle of three roots that are
//! pairwise within `max_spacing` is kept when it is not a sliver (area at least 5 % of
//! its longest edge squared) and no other candidate root lies strictly inside its
//! diametral sphere (the sphere through its corners centred in its plane): on a flat or
//! gently curved scalp, the Delaunay triangles. Co-circular roots (a square grid) keep
//! both diagonals of each square: every point of the square is then in exactly two
//! triangles, and the density of roots stays even. A guide in no triangle (alone, or on
//! a line of guides) gets a disc of radius half its nearest spacing across its root
//! direction (the scalp normal with a scalp), whose render strands follow it alone.
//!
//! Render root i picks a triangle or disc with probability proportional to its area,
//! then a uniform point in it, from three 64-bit draws of ChaCha8 seeded by `seed`
//! (stream 0) at word 6i, so that any subset of the roots can be placed alone, the same
//! as in the whole set ([`RenderRoots::place_subset`]): in a triangle its
//! blend weights are its barycentric coordinates, in a disc the guide's weight is 1. With
//! a scalp, the point is moved to the closest point of the scalp's surface. Its dominant
//! guide is the one of largest weight.

use super::neighbours::PointGrid;
use super::settings::{RenderSettings, DEFAULT_LOCK_RADIUS, DEFAULT_SPACING_FACTOR};
use crate::bodies::{Body, Placement};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashSet;
use superhelix_kernels::head::HeadState;

/// Candidate neighbours of a root.
const NEIGHBOURS: usize = 8;
/// A triangle's area must be at least this times its longest edge squared.
const MIN_SHAPE: f64 = 0.05;

/// One render strand's root and guides.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderRoot {
    /// Root, head coordinates, m.
    pub position: Vector3<f64>,
    /// The guides blended (indices into the guides); unused slots repeat the first with
    /// weight 0.
    pub guides: [u32; 3],
    /// Blend weights at the root, ≥ 0, summing to 1.
    pub weights: [f64; 3],
    /// Slot (0..3) of the dominant guide: the largest weight.
    pub dominant: u8,
}

impl RenderRoot {
    /// The root at `position` blending `guides` with `weights` (normalised to sum 1;
    /// negative weights count as 0); the dominant slot is the largest weight.
    pub fn new(position: Vector3<f64>, guides: [u32; 3], weights: [f64; 3]) -> Self {
        let w = weights.map(|w| if w > 0.0 { w } else { 0.0 });
        let sum: f64 = w.iter().sum();
        let weights = if sum > 0.0 {
            w.map(|w| w / sum)
        } else {
            [1.0, 0.0, 0.0]
        };
        let mut dominant = 0;
        for k in 1..3 {
            if weights[k] > weights[dominant] {
                dominant = k;
            }
        }
        Self {
            position,
            guides,
            weights,
            dominant: dominant as u8,
        }
    }

    /// Index of the dominant guide.
    pub fn dominant_guide(&self) -> usize {
        self.guides[self.dominant as usize] as usize
    }
}

/// The triangles and discs render roots are drawn from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct RootSites {
    /// Triangles of guide indices.
    pub triangles: Vec<[u32; 3]>,
    /// Guides in no triangle, with their disc radius, m.
    pub discs: Vec<(u32, f64)>,
    /// The longest edge interpolated across, m (`max_spacing`, or its default).
    pub max_spacing: f64,
}

impl RootSites {
    /// The triangles and discs of the guide roots `roots` (head coordinates, finite).
    pub fn new(roots: &[Vector3<f64>], max_spacing: Option<f64>) -> Self {
        let grid = PointGrid::new(roots);
        let nearest: Vec<f64> = (0..roots.len())
            .map(|i| {
                grid.nearest(i, 1, f64::INFINITY)
                    .first()
                    .map_or(f64::INFINITY, |n| n.1)
            })
            .collect();
        let mut finite: Vec<f64> = nearest
            .iter()
            .copied()
            .filter(|d| d.is_finite() && *d > 0.0)
            .collect();
        finite.sort_by(f64::total_cmp);
        let median = finite.get(finite.len() / 2).copied();
        let spacing = max_spacing
            .or(median.map(|m| DEFAULT_SPACING_FACTOR * m))
            .unwrap_or(2.0 * DEFAULT_LOCK_RADIUS);
        let neighbours: Vec<Vec<(u32, f64)>> = (0..roots.len())
            .map(|i| grid.nearest(i, NEIGHBOURS, spacing))
            .collect();
        let mut seen = HashSet::new();
        let mut triangles = Vec::new();
        for (g, list) in neighbours.iter().enumerate() {
            for (x, &(a, _)) in list.iter().enumerate() {
                for &(b, _) in &list[x + 1..] {
                    let mut t = [g as u32, a, b];
                    t.sort_unstable();
                    if !seen.insert(t) {
                        continue;
                    }
                    if keep_triangle(roots, &neighbours, t, spacing) {
                        triangles.push(t);
                    }
                }
            }
        }
        let mut covered = vec![false; roots.len()];
        for t in &triangles {
            for &g in t {
                covered[g as usize] = true;
            }
        }
        let discs = (0..roots.len())
            .filter(|&g| !covered[g])
            .map(|g| {
                let near = nearest[g].min(spacing);
                let radius = if near.is_finite() && near > 0.0 {
                    0.5 * near
                } else {
                    DEFAULT_LOCK_RADIUS
                };
                (g as u32, radius)
            })
            .collect();
        Self {
            triangles,
            discs,
            max_spacing: spacing,
        }
    }
}

/// Whether triangle `t` is short-edged, not a sliver, and has an empty diametral sphere.
fn keep_triangle(
    roots: &[Vector3<f64>],
    neighbours: &[Vec<(u32, f64)>],
    t: [u32; 3],
    spacing: f64,
) -> bool {
    let [a, b, c] = t.map(|i| roots[i as usize]);
    let (ab, ac, bc) = (b - a, c - a, c - b);
    let longest = ab.norm().max(ac.norm()).max(bc.norm());
    if longest > spacing {
        return false;
    }
    let normal = ab.cross(&ac);
    let area2 = normal.norm();
    if area2.is_nan() || area2 <= 2.0 * MIN_SHAPE * longest * longest {
        return false;
    }
    // circumcentre of the triangle in its plane
    let centre = a
        + (normal.cross(&ab) * ac.norm_squared() + ac.cross(&normal) * ab.norm_squared())
            / (2.0 * normal.norm_squared());
    let radius = (a - centre).norm();
    let inside =
        |j: u32| !t.contains(&j) && (roots[j as usize] - centre).norm() < radius * (1.0 - 1e-9);
    !t.iter()
        .any(|&v| neighbours[v as usize].iter().any(|&(j, _)| inside(j)))
}

/// The render roots: placed once, deterministic for a seed.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderRoots {
    /// One per render strand.
    pub roots: Vec<RenderRoot>,
    /// The sites they were drawn from.
    pub sites: RootSites,
}

impl RenderRoots {
    /// Place `settings.strands` render roots among the guide roots `roots` (head
    /// coordinates) whose root tangents are `directions` (unit), projected onto `scalp`
    /// (a body in head coordinates) when given. Empty without guides.
    pub fn place(
        roots: &[Vector3<f64>],
        directions: &[Vector3<f64>],
        settings: &RenderSettings,
        scalp: Option<&Body>,
    ) -> Self {
        Self::place_subset(roots, directions, settings, scalp, 0..settings.strands)
    }

    /// The render roots of indices `indices` (each below `settings.strands`) of
    /// [`RenderRoots::place`], in that order, without placing the others.
    pub fn place_subset(
        roots: &[Vector3<f64>],
        directions: &[Vector3<f64>],
        settings: &RenderSettings,
        scalp: Option<&Body>,
        indices: impl Iterator<Item = usize>,
    ) -> Self {
        let sites = RootSites::new(roots, settings.max_spacing);
        if roots.is_empty() {
            return Self {
                roots: Vec::new(),
                sites,
            };
        }
        let rest = Placement::new(HeadState::rest(), 0.0);
        // cumulative areas of the triangles, then of the discs
        let mut cumulative = Vec::with_capacity(sites.triangles.len() + sites.discs.len());
        let mut total = 0.0;
        for t in &sites.triangles {
            let [a, b, c] = t.map(|i| roots[i as usize]);
            total += 0.5 * (b - a).cross(&(c - a)).norm();
            cumulative.push(total);
        }
        for &(_, r) in &sites.discs {
            total += std::f64::consts::PI * r * r;
            cumulative.push(total);
        }
        let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
        rng.set_stream(0);
        // a uniform f64 in [0, 1) from the top 53 bits of one 64-bit draw
        let uniform =
            |rng: &mut ChaCha8Rng| (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
        let mut out = Vec::with_capacity(indices.size_hint().0);
        for i in indices {
            rng.set_word_pos(6 * i as u128);
            let pick = uniform(&mut rng) * total;
            let site = cumulative
                .partition_point(|&c| c <= pick)
                .min(cumulative.len() - 1);
            let (r1, r2) = (uniform(&mut rng), uniform(&mut rng));
            let root = if site < sites.triangles.len() {
                let t = sites.triangles[site];
                let s = r1.sqrt();
                let w = [1.0 - s, s * (1.0 - r2), s * r2];
                let p = (0..3).map(|k| roots[t[k] as usize] * w[k]).sum();
                RenderRoot::new(p, t, w)
            } else {
                let (g, radius) = sites.discs[site - sites.triangles.len()];
                let centre = roots[g as usize];
                let axis = scalp
                    .map(|b| b.query(&rest, &centre).normal)
                    .or_else(|| directions.get(g as usize).copied())
                    .unwrap_or_else(Vector3::z);
                let (e1, e2) = across(&axis);
                let (rho, phi) = (radius * r1.sqrt(), std::f64::consts::TAU * r2);
                let p = centre + (e1 * phi.cos() + e2 * phi.sin()) * rho;
                RenderRoot::new(p, [g; 3], [1.0, 0.0, 0.0])
            };
            out.push(root);
        }
        if let Some(body) = scalp {
            for r in &mut out {
                let closest = body.query(&rest, &r.position).closest;
                if closest.iter().all(|v| v.is_finite()) {
                    r.position = closest;
                }
            }
        }
        Self { roots: out, sites }
    }
}

impl RenderRoots {
    /// Render roots at given `positions` (head coordinates) among the guide roots
    /// `roots` triangulated as `sites`: the blend of a position is its barycentric
    /// coordinates in the triangle it projects into (the nearest such triangle to its
    /// plane), else weight 1 on the nearest guide. Cost O(positions × triangles).
    pub fn at_positions(
        roots: &[Vector3<f64>],
        sites: RootSites,
        positions: &[Vector3<f64>],
    ) -> Self {
        let placed = positions
            .iter()
            .map(|p| {
                let mut best: Option<(f64, RenderRoot)> = None;
                for t in &sites.triangles {
                    let Some((w, off_plane)) = barycentric(t.map(|i| roots[i as usize]), p) else {
                        continue;
                    };
                    if w.iter().all(|&x| x >= -1e-12)
                        && best.as_ref().is_none_or(|b| off_plane < b.0)
                    {
                        best = Some((off_plane, RenderRoot::new(*p, *t, w)));
                    }
                }
                best.map(|b| b.1).unwrap_or_else(|| {
                    let g = (0..roots.len())
                        .min_by(|&i, &j| (roots[i] - p).norm().total_cmp(&(roots[j] - p).norm()))
                        .unwrap_or(0) as u32;
                    RenderRoot::new(*p, [g; 3], [1.0, 0.0, 0.0])
                })
            })
            .collect();
        Self {
            roots: placed,
            sites,
        }
    }
}

/// Barycentric coordinates of the projection of `p` onto the plane of triangle `t`, and
/// the distance of `p` to that plane; `None` for a degenerate triangle.
fn barycentric(t: [Vector3<f64>; 3], p: &Vector3<f64>) -> Option<([f64; 3], f64)> {
    let (v0, v1, v2) = (t[1] - t[0], t[2] - t[0], p - t[0]);
    let (d00, d01, d11) = (v0.dot(&v0), v0.dot(&v1), v1.dot(&v1));
    let (d20, d21) = (v2.dot(&v0), v2.dot(&v1));
    let denom = d00 * d11 - d01 * d01;
    if denom.is_nan() || denom <= 0.0 {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / denom;
    let w = (d00 * d21 - d01 * d20) / denom;
    let normal = v0.cross(&v1).normalize();
    Some(([1.0 - v - w, v, w], v2.dot(&normal).abs()))
}

/// Two unit vectors spanning the plane across `axis` (any plane when it is zero).
fn across(axis: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let n = axis.try_normalize(1e-300).unwrap_or_else(Vector3::z);
    let least = (0..3)
        .min_by(|&i, &j| n[i].abs().total_cmp(&n[j].abs()))
        .unwrap_or(0);
    let mut e = Vector3::zeros();
    e[least] = 1.0;
    let e1 = (e - n * n.dot(&e)).normalize();
    (e1, n.cross(&e1))
}

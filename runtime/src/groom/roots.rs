//! The roots of a groom on a scalp region: Poisson-disk positions on a body's surface
//! and the root frame of each (paper section 3.1: a strand is clamped to the head by
//! the position and material frame (n0, n1, n2) of its root).
//!
//! Candidates are drawn uniformly by area over the whole surface ([`Surface::sample`],
//! ChaCha8 seeded by the groom's seed on streams of their own) and kept inside the [`Region`] until there are five per root
//! (Yuksel's ratio); weighted sample elimination ([`super::poisson`]) then keeps exactly
//! the number of roots asked for, or `round(density · area)` of them, the region's area
//! being the surface's times the share of candidates inside it.
//!
//! **Root frame.** n0, the strand's tangent at the root, is the surface normal n turned
//! by the tilt angle t towards the combing direction: with c the comb direction
//! projected on the tangent plane and normalised, `n0 = cos t n + sin t c`,
//! `n1 = −sin t n + cos t c` (the comb direction, across n0), `n2 = n0 × n1`. Where the
//! comb is along the normal, c is the world axis least aligned with n, projected.

use super::poisson::{eliminate, max_radius, min_distance};
use super::region::Region;
use super::surface::{Surface, SurfacePoint};
use nalgebra::{Matrix3, Vector3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Candidates drawn per root before the elimination.
pub const CANDIDATES_PER_ROOT: usize = 5;
/// Candidates drawn to measure the region's area when roots are given by density.
pub const AREA_SAMPLES: usize = 100_000;
/// Most candidates drawn from the whole surface.
pub const MAX_DRAWS: usize = 50_000_000;

/// How many roots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RootCount {
    /// Exactly this many.
    Exact(usize),
    /// This many per m² of the region, rounded.
    Density(f64),
}

/// What the roots of a groom are made from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RootSettings {
    /// The part of the surface that grows hair.
    pub region: Region,
    /// How many roots.
    pub count: RootCount,
    /// Combing direction (unit; projected on the tangent plane at each root).
    pub comb: Vector3<f64>,
    /// Tilt of n0 from the normal towards the comb, rad, in [0, π/2).
    pub tilt: f64,
    /// Seed of the candidates.
    pub seed: u64,
    /// Most roots allowed (a density that asks for more is an error).
    pub max_count: usize,
}

/// One root: position and frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Root {
    /// Position on the surface, m.
    pub position: Vector3<f64>,
    /// Outward surface normal there.
    pub normal: Vector3<f64>,
    /// Root frame (n0, n1, n2) as columns.
    pub frame: Matrix3<f64>,
}

/// The roots of a groom and what their spread measures.
#[derive(Debug, Clone, PartialEq)]
pub struct Roots {
    /// The roots.
    pub roots: Vec<Root>,
    /// Area of the region, m² (estimated by the share of candidates inside it).
    pub area: f64,
    /// Smallest distance between two roots, m.
    pub min_spacing: f64,
    /// The spacing of the hexagonal packing of as many points on the same area (the
    /// largest possible smallest distance), m.
    pub packing_spacing: f64,
}

/// Why no roots could be made; `field` is the groom field to blame.
#[derive(Debug, Clone, PartialEq)]
pub struct RootsError {
    /// `count`, `density`, `max_angle_deg`, …
    pub field: &'static str,
    /// What is wrong.
    pub message: String,
}

/// The root frame at a surface point (module doc).
pub fn root_frame(normal: &Vector3<f64>, comb: &Vector3<f64>, tilt: f64) -> Matrix3<f64> {
    let along = comb - normal * normal.dot(comb);
    let c = if along.norm() > 1e-6 {
        along.normalize()
    } else {
        let e = Vector3::ith(normal.iamin(), 1.0);
        (e - normal * normal.dot(&e)).normalize()
    };
    let (s, co) = tilt.sin_cos();
    let n0 = normal * co + c * s;
    let n1 = -normal * s + c * co;
    Matrix3::from_columns(&[n0, n1, n0.cross(&n1)])
}

/// Stream of the candidates that measure the region's area.
const AREA_STREAM: u64 = u64::MAX;
/// Stream of the candidates the roots are chosen from (the strands of a groom use
/// streams 1 + k).
const ROOT_STREAM: u64 = u64::MAX - 1;

/// The seeded generator of a groom's candidates on `stream`.
fn rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut r = ChaCha8Rng::seed_from_u64(seed);
    r.set_stream(stream);
    r
}

/// The share of `draws` candidates of `surface` inside `region`.
fn region_share(surface: &Surface, region: &Region, seed: u64, draws: usize) -> f64 {
    let mut r = rng(seed, AREA_STREAM);
    let inside = (0..draws)
        .filter(|_| region.contains(&surface.sample(&mut r).position))
        .count();
    inside as f64 / draws as f64
}

/// The roots of a groom on `surface` (module doc).
pub fn sample_roots(surface: &Surface, settings: &RootSettings) -> Result<Roots, RootsError> {
    let total_area = surface.area();
    let region = &settings.region;
    let empty = || RootsError {
        field: "max_angle_deg",
        message: "the region (cap and cut) contains no part of the body's surface".into(),
    };
    let count = match settings.count {
        RootCount::Exact(n) => n,
        RootCount::Density(density) => {
            let share = region_share(surface, region, settings.seed, AREA_SAMPLES);
            if share == 0.0 {
                return Err(empty());
            }
            let n = (density * share * total_area).round();
            if n < 1.0 {
                return Err(RootsError {
                    field: "density",
                    message: format!(
                        "gives no root on the region's {:.3e} m^2: raise it",
                        share * total_area
                    ),
                });
            }
            if n > settings.max_count as f64 {
                return Err(RootsError {
                    field: "density",
                    message: format!(
                        "gives {n:.0} roots on the region's {:.3e} m^2, more than the cap of {}",
                        share * total_area,
                        settings.max_count
                    ),
                });
            }
            n as usize
        }
    };
    let wanted = CANDIDATES_PER_ROOT * count;
    let mut r = rng(settings.seed, ROOT_STREAM);
    let mut candidates: Vec<SurfacePoint> = Vec::with_capacity(wanted);
    let mut draws = 0usize;
    while candidates.len() < wanted {
        if draws >= MAX_DRAWS {
            let message = if candidates.is_empty() {
                empty().message
            } else {
                format!(
                    "the region covers about {:.2e} of the body's surface: too little to \
                     draw {wanted} candidates in {MAX_DRAWS} tries; widen it",
                    candidates.len() as f64 / draws as f64
                )
            };
            return Err(RootsError {
                field: "max_angle_deg",
                message,
            });
        }
        draws += 1;
        let point = surface.sample(&mut r);
        if region.contains(&point.position) {
            candidates.push(point);
        }
    }
    let area = total_area * candidates.len() as f64 / draws as f64;
    let positions: Vec<Vector3<f64>> = candidates.iter().map(|c| c.position).collect();
    let kept = eliminate(&positions, count, area);
    let roots: Vec<Root> = kept
        .iter()
        .map(|&i| {
            let c = &candidates[i];
            Root {
                position: c.position,
                normal: c.normal,
                frame: root_frame(&c.normal, &settings.comb, settings.tilt),
            }
        })
        .collect();
    let spacing = 2.0 * max_radius(area, count);
    let kept_positions: Vec<Vector3<f64>> = roots.iter().map(|r| r.position).collect();
    Ok(Roots {
        min_spacing: min_distance(&kept_positions, spacing),
        packing_spacing: spacing,
        roots,
        area,
    })
}

//! Render strands kept out of the scene's bodies. The guides do not enter the bodies
//! (contacts), but a render strand blended between two guides that wrap around a head
//! follows their chord and cuts through it. After the blend, every render point but the
//! root whose signed distance to a body is below the clearance is moved out along that
//! body's normal to the clearance, and the strand around it is lifted with it.
//!
//! **Why a ramp.** Moving only the points inside would lay the strand on the surface and
//! break it at both ends of that stretch, by the angle at which the interpolated strand
//! enters and leaves the body. Carrying the whole push to the tip (every following point
//! moved by at least the same amount) would keep the shape but move the strand out of
//! its clump for good: its tip would leave its guides. So the push is carried along the
//! strand and ramped down linearly with arc length, at [`RAMP_SLOPE`] per metre of
//! strand on each side: after the body the strand returns to its interpolated path
//! within |push| / [`RAMP_SLOPE`] of strand (4 × the depth it was pushed by), and before
//! the body it starts rising by as much, so that it leaves and meets its own path at an
//! angle of at most atan([`RAMP_SLOPE`]) ≈ 14° whatever the depth. The tip stays on its
//! interpolated path unless the body is near it. The root never moves: a root on the
//! scalp stays there.
//!
//! **Cost.** Only a scene with bodies and render strands pays it. The points are tested
//! in blocks of [`BLOCK`]: the ball around a block's box, plus the clearance, is tested
//! against each body's cheap bound ([`crate::bodies::Shape::farther_than`]); a block far from every
//! body is left as blended. Only the points of near blocks (and of a strand already
//! lifted) are queried, each against the bodies its own bound does not rule out. An
//! ellipsoid is queried by Newton's method on the closest-point equation from a lower
//! bound of its root, which converges from below in a few steps near the surface
//! ([`ellipsoid_proximity`]), instead of the bisection of the exact query that the
//! simulation's contacts use (same answer to rounding; the exact query is kept for deep
//! points).

use crate::bodies::proximity::Proximity;
use crate::bodies::shape_ellipsoid::Ellipsoid;
use crate::bodies::{Body, Placement, Shape};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Vector3};

/// How fast the lift of a render strand around a body fades along the strand: the
/// offset's length changes by at most this per unit arc length (m/m), on both sides of
/// the points pushed out.
pub const RAMP_SLOPE: f64 = 0.25;
/// Render points tested together against the bodies' bounds.
pub const BLOCK: usize = 8;
/// Most pushes of one point (out of one body into another's clearance, out again).
const MAX_PUSHES: usize = 4;
/// Most Newton steps of [`ellipsoid_proximity`] before it falls back to the exact query.
pub const MAX_NEWTON: usize = 40;

/// The bodies the render strands keep out of, and by how much.
#[derive(Debug, Clone, PartialEq)]
pub struct KeepOut {
    bodies: Vec<Body>,
    clearance: f64,
}

impl KeepOut {
    /// Keep the render strands `clearance` (m, ≥ 0) away from `bodies`. An error when the
    /// clearance is negative or not finite.
    pub fn new(bodies: Vec<Body>, clearance: f64) -> Result<Self> {
        if !(clearance.is_finite() && clearance >= 0.0) {
            return Err(Error::invalid(
                "render.clearance",
                format!("must be a finite distance >= 0, got {clearance}"),
            ));
        }
        Ok(Self { bodies, clearance })
    }

    /// The bodies.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// The clearance, m.
    pub fn clearance(&self) -> f64 {
        self.clearance
    }

    /// The bodies placed at `at` (bodies on the head at its state, bodies on their own
    /// motion at their pose of `at.time`), for [`Placed::apply`].
    pub(super) fn at<'a>(&'a self, at: &Placement) -> Placed<'a> {
        Placed {
            keep: self,
            frames: self
                .bodies
                .iter()
                .map(|b| {
                    b.frame(at).map(|f| BodyFrame {
                        rotation: f.rotation,
                        to_local: f.rotation.transpose(),
                        position: f.position,
                    })
                })
                .collect(),
        }
    }
}

/// Where a body's coordinates are at one time: `x = position + rotation y`.
#[derive(Debug, Clone, Copy)]
struct BodyFrame {
    rotation: Matrix3<f64>,
    to_local: Matrix3<f64>,
    position: Vector3<f64>,
}

/// [`KeepOut`] at one time: each body's frame (`None`: fixed in the world).
#[derive(Debug, Clone)]
pub(super) struct Placed<'a> {
    keep: &'a KeepOut,
    frames: Vec<Option<BodyFrame>>,
}

impl Placed<'_> {
    /// `x` (world) in the coordinates of body `i`.
    #[inline]
    fn local(&self, i: usize, x: &Vector3<f64>) -> Vector3<f64> {
        match &self.frames[i] {
            None => *x,
            Some(f) => f.to_local * (x - f.position),
        }
    }

    /// Whether every point within `radius` of `x` (world) is farther than the clearance
    /// from every body, by the bodies' cheap bounds.
    #[inline]
    fn far(&self, x: &Vector3<f64>, radius: f64) -> bool {
        let r = radius + self.keep.clearance;
        self.keep
            .bodies
            .iter()
            .enumerate()
            .all(|(i, b)| b.shape.farther_than(&self.local(i, x), r))
    }

    /// The deepest body within the clearance of `x` (world), but body `skip`: its index,
    /// signed distance and world normal; `None` when every body is at least the
    /// clearance away.
    fn deepest(&self, x: &Vector3<f64>, skip: Option<usize>) -> Option<(usize, f64, Vector3<f64>)> {
        let c = self.keep.clearance;
        let mut best: Option<(usize, Proximity)> = None;
        for (i, b) in self.keep.bodies.iter().enumerate() {
            if skip == Some(i) {
                continue;
            }
            let y = self.local(i, x);
            if b.shape.farther_than(&y, c) {
                continue;
            }
            let p = match &b.shape {
                Shape::Ellipsoid(e) => ellipsoid_proximity(e, &y),
                shape => shape.query(&y),
            };
            if p.distance < c && best.is_none_or(|(_, q)| p.distance < q.distance) {
                best = Some((i, p));
            }
        }
        best.map(|(i, p)| match &self.frames[i] {
            None => (i, p.distance, p.normal),
            Some(f) => (i, p.distance, f.rotation * p.normal),
        })
    }

    /// `x` moved out of every body to the clearance (a few pushes at most). A body with
    /// an exact distance is not asked again right after it pushed the point out.
    fn push_out(&self, mut x: Vector3<f64>) -> Vector3<f64> {
        let mut skip = None;
        for _ in 0..MAX_PUSHES {
            match self.deepest(&x, skip) {
                Some((i, d, n)) if (self.keep.clearance - d).is_finite() => {
                    x += (self.keep.clearance - d) * n;
                    skip = (!matches!(self.keep.bodies[i].shape, Shape::Mesh(_))).then_some(i);
                }
                _ => break,
            }
        }
        x
    }

    /// Keep one render strand (`line`, root first, world) out of the bodies; `offsets`
    /// (as long as `line`) is scratch.
    pub(super) fn apply(&self, line: &mut [[f32; 3]], offsets: &mut [[f32; 3]]) {
        if self.keep.bodies.is_empty() || line.len() < 2 {
            return;
        }
        let m = line.len();
        // forward: push out, carry the offset on and ramp it down
        let mut lifted = false;
        let mut carry = Vector3::<f64>::zeros();
        let mut j = 1;
        while j < m {
            let end = (j + BLOCK).min(m);
            if carry == Vector3::zeros() && self.block_far(&line[j..end]) {
                offsets[j..end].fill([0.0; 3]);
                j = end;
                continue;
            }
            for k in j..end {
                let p = vector(line[k]);
                let q = self.push_out(p + carry);
                let delta = q - p;
                offsets[k] = to_f32(delta);
                if delta != Vector3::zeros() {
                    lifted = true;
                    line[k] = to_f32(q);
                }
                carry = match line.get(k + 1) {
                    Some(&next) if delta != Vector3::zeros() => {
                        ramp(&delta, (vector(next) - p).norm())
                    }
                    _ => Vector3::zeros(),
                };
            }
            j = end;
        }
        if !lifted {
            return;
        }
        // backward: lift the points before each push by the ramp too
        for k in (1..m - 1).rev() {
            if offsets[k + 1] == [0.0; 3] {
                continue;
            }
            let next = vector(offsets[k + 1]);
            let here = vector(offsets[k]);
            let original = vector(line[k]) - here;
            let next_original = vector(line[k + 1]) - next;
            let wanted = ramp(&next, (next_original - original).norm());
            let (have, want) = (here.norm(), wanted.norm());
            if want > have {
                let raised = here + wanted * ((want - have) / want);
                let q = self.push_out(original + raised);
                offsets[k] = to_f32(q - original);
                line[k] = to_f32(q);
            }
        }
    }

    /// Whether a block of points is far from every body (the ball around its box).
    #[inline]
    fn block_far(&self, points: &[[f32; 3]]) -> bool {
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in &points[1..] {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let (lo, hi) = (vector(lo), vector(hi));
        let radius = 0.5 * (hi - lo).norm();
        // NaN points: not far, and the queries leave them as they are
        radius.is_finite() && self.far(&(0.5 * (lo + hi)), radius)
    }
}

/// `delta` shortened by [`RAMP_SLOPE`] × `length` (zero once used up).
#[inline]
fn ramp(delta: &Vector3<f64>, length: f64) -> Vector3<f64> {
    let norm = delta.norm();
    let left = norm - RAMP_SLOPE * length;
    if norm > 0.0 && left > 0.0 {
        delta * (left / norm)
    } else {
        Vector3::zeros()
    }
}

#[inline]
fn vector(p: [f32; 3]) -> Vector3<f64> {
    Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

#[inline]
fn to_f32(v: Vector3<f64>) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Signed distance, outward normal and closest point of `y` (body coordinates) to the
/// ellipsoid `e`: the closest point is `xᵢ = aᵢ² uᵢ / (t + aᵢ²)` (u = `y` in the axes)
/// with t the root of `F(t) = Σ (aᵢ uᵢ / (t + aᵢ²))² − 1`, convex and decreasing for
/// t > −min aᵢ². Newton's method starts at the first-order estimate of the root
/// (t = d / |D⁻²x| for a point at distance d along the normal at x, with d from the
/// gradient of |D⁻¹u|), kept above the lower bound `t₀ = maxᵢ (aᵢ|uᵢ| − aᵢ²)` (where one
/// term alone is 1, so F(t₀) ≥ 0; t₀ ≥ 0 outside, where F(0) > 0); a step from above the
/// root lands below it (F is convex), and from below the steps climb to it without
/// overshooting; a step is never taken below t₀. Points on a symmetry plane of the axes or deep inside (t₀ within
/// a hundredth of min aᵢ² of the pole, where the closest point may leave the plane or the
/// steps crawl) take the exact query ([`Ellipsoid::query`]), as does a search that has not
/// converged after [`MAX_NEWTON`] steps.
pub fn ellipsoid_proximity(e: &Ellipsoid, y: &Vector3<f64>) -> Proximity {
    let u = e.rotation.transpose() * (y - e.center);
    let a = e.radii;
    let a2 = a.component_mul(&a);
    let rho2 = (0..3).map(|i| (u[i] / a[i]).powi(2)).sum::<f64>();
    let pole = -a2.min();
    let low = (0..3)
        .map(|i| a[i] * u[i].abs() - a2[i])
        .fold(f64::NEG_INFINITY, f64::max);
    let low = if rho2 > 1.0 { low.max(0.0) } else { low };
    let room = low - pole;
    if u.iter().any(|&v| v == 0.0) || room.is_nan() || room <= 0.01 * a2.min() {
        return e.query(y);
    }
    // first-order start: u = x + d n with n ∥ D⁻²x gives t = d / |D⁻²x| ≈ (ρ − 1) ρ / |D⁻²u|²
    let rho = rho2.sqrt();
    let guess = (rho - 1.0) * rho / u.component_div(&a2).norm_squared();
    let mut t = if guess.is_finite() {
        guess.max(low)
    } else {
        low
    };
    let mut converged = false;
    for _ in 0..MAX_NEWTON {
        let (mut f, mut df) = (-1.0, 0.0);
        for i in 0..3 {
            let q = a[i] * u[i] / (t + a2[i]);
            f += q * q;
            df -= 2.0 * q * q / (t + a2[i]);
        }
        let step = f / df;
        if !step.is_finite() {
            break;
        }
        // from above the root a step lands below it; never below the bound
        t = (t - step).max(low);
        if step.abs() <= 1e-15 * (t.abs() + a2.max()) {
            converged = true;
            break;
        }
    }
    if !converged {
        return e.query(y);
    }
    let x = Vector3::from_fn(|i, _| a2[i] * u[i] / (t + a2[i]));
    let gap = (u - x).norm();
    let normal = e.rotation * x.component_div(&a2).normalize();
    Proximity {
        distance: if rho2 < 1.0 { -gap } else { gap },
        normal,
        closest: e.center + e.rotation * x,
    }
}

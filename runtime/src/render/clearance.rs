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
//! **Cost.** Only a scene with bodies and render strands pays it. At each frame every
//! body is placed once: an ellipsoid gets one map from the world to its own axes (its
//! frame's rotation and its own turned into one), every other body its frame and a world
//! ball around its surface. The points are then tested in blocks of [`BLOCK`]: from the
//! centre of the ball around a block's box, a lower bound of the distance to each body
//! (for an ellipsoid (ρ − 1) min aᵢ with ρ = |D⁻¹u|, [`Ellipsoid::farther_than`]; for the
//! others their ball) rules the block out when it is farther than the ball's radius plus
//! the clearance from every body (the block is left as blended), and leaves a mask of the
//! bodies the block may come near with the ball grown by a slack of 1 cm; a point within
//! that grown ball (pushed or lifted by less) asks only the bodies of its block's mask,
//! a point outside it asks them all. Each asked ellipsoid first compares ρ² with the
//! bound's reach; only a point it does not rule out is queried, by Newton's method on
//! the closest-point equation from a first-order start ([`ellipsoid_proximity`], one or
//! two steps near the surface, one division a step), instead of the bisection of the
//! exact query that the simulation's contacts use (same answer to 1e-12 m; the exact
//! query is kept for deep points). The point then goes to the closest surface point
//! plus the clearance along the normal there, which on a convex body is the clearance
//! away from it whatever the surface point.

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
        let frames = self
            .bodies
            .iter()
            .map(|b| {
                b.frame(at).map(|f| BodyFrame {
                    rotation: f.rotation,
                    to_local: f.rotation.transpose(),
                    position: f.position,
                })
            })
            .collect();
        Placed::new(self, frames)
    }
}

/// Where a body's coordinates are at one time: `x = position + rotation y`.
#[derive(Debug, Clone, Copy)]
struct BodyFrame {
    rotation: Matrix3<f64>,
    to_local: Matrix3<f64>,
    position: Vector3<f64>,
}

/// An ellipsoid at one time in its own axes: `u = to_axes (x − origin)` for a world
/// point x, half-axes `a` along u.
#[derive(Debug, Clone, Copy)]
struct Axes {
    to_axes: Matrix3<f64>,
    from_axes: Matrix3<f64>,
    origin: Vector3<f64>,
    a: Vector3<f64>,
    a2: Vector3<f64>,
    inv_a2: Vector3<f64>,
    /// ρ² = Σ uᵢ²/aᵢ² above which a point is farther than the clearance (the bound of
    /// [`Ellipsoid::farther_than`]: the distance is at least (ρ − 1) min aᵢ).
    reach2: f64,
}

/// How one body is asked about a point at one time.
#[derive(Debug, Clone, Copy)]
enum Placing<'a> {
    /// An ellipsoid, in its axes (world to axes in one step).
    Ellipsoid(Axes),
    /// Any other shape, through its frame (`None`: fixed in the world).
    Other(&'a Shape, Option<BodyFrame>),
}

/// One body at one time: how it is asked, and a world ball that holds its surface
/// (`None`: a plane, never ruled out).
#[derive(Debug, Clone, Copy)]
struct Near<'a> {
    placing: Placing<'a>,
    ball: Option<(Vector3<f64>, f64)>,
}

/// Bodies of index 64 and above are always asked (they have no bit in a block's mask).
const MASKED: usize = 64;
/// Every body asked.
const ALL: u64 = u64::MAX;
/// Distance (m) a point may move from its block's ball and still be ruled out of the
/// bodies the block is: each block's bodies are ruled out for its ball grown by this.
const SLACK: f64 = 0.01;

/// The bodies a block of points may come near: the bit of body i (i < [`MASKED`]) is set
/// unless every point within `radius` of `centre` is farther than the clearance from it.
#[derive(Debug, Clone, Copy)]
struct Block {
    centre: Vector3<f64>,
    radius2: f64,
    mask: u64,
}

impl Block {
    /// No ball: every body asked wherever the point is.
    const EVERY: Block = Block {
        centre: Vector3::new(0.0, 0.0, 0.0),
        radius2: f64::INFINITY,
        mask: ALL,
    };

    /// The bodies to ask about `x`: the block's when `x` is in its ball, else all.
    #[inline]
    fn mask(&self, x: &Vector3<f64>) -> u64 {
        if (x - self.centre).norm_squared() <= self.radius2 {
            self.mask
        } else {
            ALL
        }
    }
}

/// [`KeepOut`] at one time: each body placed.
#[derive(Debug, Clone)]
pub(super) struct Placed<'a> {
    keep: &'a KeepOut,
    near: Vec<Near<'a>>,
}

impl<'a> Placed<'a> {
    /// The bodies of `keep` in the frames `frames` (`None`: fixed in the world).
    fn new(keep: &'a KeepOut, frames: Vec<Option<BodyFrame>>) -> Self {
        let c = keep.clearance;
        let near = keep
            .bodies
            .iter()
            .zip(frames)
            .map(|(b, f)| {
                let to_world = |y: Vector3<f64>| match &f {
                    None => y,
                    Some(f) => f.position + f.rotation * y,
                };
                let ball = b.shape.bounding_ball().map(|(c, r)| (to_world(c), r));
                let placing = match &b.shape {
                    Shape::Ellipsoid(e) => {
                        let rotation = match &f {
                            None => e.rotation,
                            Some(f) => f.rotation * e.rotation,
                        };
                        let a = e.radii;
                        let a2 = a.component_mul(&a);
                        let reach = 1.0 + c / a.min();
                        Placing::Ellipsoid(Axes {
                            to_axes: rotation.transpose(),
                            from_axes: rotation,
                            origin: to_world(e.center),
                            a,
                            a2,
                            inv_a2: a2.map(|v| 1.0 / v),
                            // a hair above the bound's reach: rounding never rules out
                            // a point that is within the clearance
                            reach2: reach * reach * (1.0 + 1e-12),
                        })
                    }
                    shape => Placing::Other(shape, f),
                };
                Near { placing, ball }
            })
            .collect();
        Self { keep, near }
    }

    /// The bodies a block of points may come within the clearance of, for points that
    /// stay within [`SLACK`] of the ball around the block's box, and whether the block
    /// itself (that ball) is farther than the clearance from every body.
    #[inline]
    fn block(&self, points: &[[f32; 3]]) -> (Block, bool) {
        let (mut lo, mut hi) = (points[0], points[0]);
        for p in &points[1..] {
            for c in 0..3 {
                lo[c] = lo[c].min(p[c]);
                hi[c] = hi[c].max(p[c]);
            }
        }
        let (lo, hi) = (vector(lo), vector(hi));
        let radius = 0.5 * (hi - lo).norm();
        if !radius.is_finite() {
            // NaN points: every body asked, and the queries leave them as they are
            return (Block::EVERY, false);
        }
        let centre = 0.5 * (lo + hi);
        let (r, grown) = (
            radius + self.keep.clearance,
            radius + SLACK + self.keep.clearance,
        );
        let mut mask = 0;
        let mut far = self.near.len() <= MASKED;
        for (i, n) in self.near.iter().enumerate().take(MASKED) {
            // a lower bound of the distance from the centre to the body
            let bound = match (&n.placing, &n.ball) {
                (Placing::Ellipsoid(e), _) => {
                    let u = e.to_axes * (centre - e.origin);
                    (u.component_div(&e.a).norm() - 1.0) * e.a.min()
                }
                (_, Some((c, b))) => (centre - c).norm() - b,
                (_, None) => f64::NEG_INFINITY,
            };
            far &= bound > r;
            if bound.is_nan() || bound <= grown {
                mask |= 1 << i;
            }
        }
        let block = Block {
            centre,
            radius2: (radius + SLACK) * (radius + SLACK),
            mask,
        };
        (block, far)
    }

    /// Body `i`'s answer about `x` (world) when `x` is nearer it than the clearance: the
    /// signed distance and `x` moved out to the clearance along the body's normal.
    #[inline]
    fn reach(&self, i: usize, x: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
        let c = self.keep.clearance;
        let n = &self.near[i];
        match &n.placing {
            Placing::Ellipsoid(e) => {
                let u = e.to_axes * (x - e.origin);
                let rho2 = u.component_mul(&u).dot(&e.inv_a2);
                // NaN: not near, left as it is
                if rho2.is_nan() || rho2 > e.reach2 {
                    return None;
                }
                let (distance, closest, normal) = match closest_in_axes(&e.a, &e.a2, &u, rho2) {
                    Some(x) => {
                        let gap = (u - x).norm();
                        let normal = x.component_mul(&e.inv_a2).normalize();
                        (if rho2 < 1.0 { -gap } else { gap }, x, normal)
                    }
                    None => {
                        let p = Ellipsoid {
                            center: Vector3::zeros(),
                            radii: e.a,
                            rotation: Matrix3::identity(),
                        }
                        .query(&u);
                        (p.distance, p.closest, p.normal)
                    }
                };
                // on the convex body's surface, out along its normal: exactly the
                // clearance away whichever surface point it is
                (distance < c && normal.iter().all(|v| v.is_finite()))
                    .then(|| (distance, e.origin + e.from_axes * (closest + c * normal)))
            }
            Placing::Other(shape, frame) => {
                if let Some((centre, r)) = n.ball {
                    if (x - centre).norm_squared() > (r + c) * (r + c) {
                        return None;
                    }
                }
                let (p, normal) = match frame {
                    None => {
                        let p = shape.query(x);
                        (p, p.normal)
                    }
                    Some(f) => {
                        let p = shape.query(&(f.to_local * (x - f.position)));
                        (p, f.rotation * p.normal)
                    }
                };
                let push = c - p.distance;
                (p.distance < c && push.is_finite()).then(|| (p.distance, x + push * normal))
            }
        }
    }

    /// Whether `x` (world) is farther than the clearance from every body of `mask` (and
    /// `mask` holds every body of index [`MASKED`] and above), by their cheap bounds.
    #[inline]
    fn clear(&self, x: &Vector3<f64>, mask: u64) -> bool {
        let c = self.keep.clearance;
        self.near.len() <= MASKED
            && self.near.iter().enumerate().all(|(i, n)| {
                mask & (1 << i) == 0
                    || match (&n.placing, &n.ball) {
                        (Placing::Ellipsoid(e), _) => {
                            let u = e.to_axes * (x - e.origin);
                            u.component_mul(&u).dot(&e.inv_a2) > e.reach2
                        }
                        (_, Some((centre, r))) => (x - centre).norm_squared() > (r + c) * (r + c),
                        (_, None) => false,
                    }
            })
    }

    /// `x` moved out of every body to the clearance (a few pushes at most): each time out
    /// of the deepest body within the clearance, asking only the bodies of `block`'s mask
    /// while `x` is in its ball. A body with an exact distance is not asked again right
    /// after it pushed the point out.
    #[inline]
    fn push_out(&self, mut x: Vector3<f64>, block: &Block) -> Vector3<f64> {
        let mut skip = usize::MAX;
        for _ in 0..MAX_PUSHES {
            let mask = block.mask(&x);
            let mut best: Option<(usize, f64, Vector3<f64>)> = None;
            for i in 0..self.near.len() {
                if i == skip || (i < MASKED && mask & (1 << i) == 0) {
                    continue;
                }
                if let Some((d, q)) = self.reach(i, &x) {
                    if best.is_none_or(|(_, e, _)| d < e) {
                        best = Some((i, d, q));
                    }
                }
            }
            match best {
                Some((i, _, q)) => {
                    x = q;
                    skip = if matches!(self.keep.bodies[i].shape, Shape::Mesh(_)) {
                        usize::MAX
                    } else {
                        i
                    };
                }
                None => break,
            }
        }
        x
    }

    /// Keep one render strand (`line`, root first, world) out of the bodies; `offsets`
    /// (as long as `line`) is scratch.
    pub(super) fn apply(&self, line: &mut [[f32; 3]], offsets: &mut [[f32; 3]]) {
        if self.near.is_empty() || line.len() < 2 {
            return;
        }
        let m = line.len();
        // forward: push out, carry the offset on and ramp it down
        let mut lifted = false;
        let mut carry = Vector3::<f64>::zeros();
        let mut j = 1;
        while j < m {
            let end = (j + BLOCK).min(m);
            let (block, far) = self.block(&line[j..end]);
            if far && carry == Vector3::zeros() {
                offsets[j..end].fill([0.0; 3]);
                j = end;
                continue;
            }
            for k in j..end {
                let p = vector(line[k]);
                if carry == Vector3::zeros() && self.clear(&p, block.mask) {
                    offsets[k] = [0.0; 3];
                    continue;
                }
                let q = self.push_out(p + carry, &block);
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
                let q = self.push_out(original + raised, &Block::EVERY);
                offsets[k] = to_f32(q - original);
                line[k] = to_f32(q);
            }
        }
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
/// converged after [`MAX_NEWTON`] steps. The search stops after a step below 1e-6 of
/// t + min aᵢ² (the error left is then about the square of that, convergence being
/// quadratic). Each step takes one division: with sᵢ = t + aᵢ² and wᵢ the product of the
/// other two, 1/sᵢ = wᵢ / Π sⱼ.
pub fn ellipsoid_proximity(e: &Ellipsoid, y: &Vector3<f64>) -> Proximity {
    let u = e.rotation.transpose() * (y - e.center);
    let a = e.radii;
    let a2 = a.component_mul(&a);
    let rho2 = (0..3).map(|i| (u[i] / a[i]).powi(2)).sum::<f64>();
    let Some(x) = closest_in_axes(&a, &a2, &u, rho2) else {
        return e.query(y);
    };
    let gap = (u - x).norm();
    let normal = e.rotation * x.component_div(&a2).normalize();
    Proximity {
        distance: if rho2 < 1.0 { -gap } else { gap },
        normal,
        closest: e.center + e.rotation * x,
    }
}

/// The closest point of the ellipsoid of half-axes `a` (`a2` their squares, centred,
/// axis-aligned) to `u` (ρ² = `rho2`), by the Newton search of [`ellipsoid_proximity`];
/// `None` where that search is not used or has not converged (then the exact query).
#[inline]
fn closest_in_axes(
    a: &Vector3<f64>,
    a2: &Vector3<f64>,
    u: &Vector3<f64>,
    rho2: f64,
) -> Option<Vector3<f64>> {
    let a2min = a2.x.min(a2.y).min(a2.z);
    let low = (a.x * u.x.abs() - a2.x)
        .max(a.y * u.y.abs() - a2.y)
        .max(a.z * u.z.abs() - a2.z);
    let low = if rho2 > 1.0 { low.max(0.0) } else { low };
    let room = low + a2min;
    if u.x == 0.0 || u.y == 0.0 || u.z == 0.0 || room.is_nan() || room <= 0.01 * a2min {
        return None;
    }
    // first-order start: u = x + d n with n ∥ D⁻²x gives t = d / |D⁻²x| ≈ (ρ − 1) ρ / |D⁻²u|²
    let rho = rho2.sqrt();
    let guess = (rho - 1.0) * rho / u.component_div(a2).norm_squared();
    let mut t = if guess.is_finite() {
        guess.max(low)
    } else {
        low
    };
    // with sᵢ = t + aᵢ², wᵢ = Π_{j≠i} sⱼ and p = Π sᵢ (so 1/sᵢ = wᵢ/p), F = Σ Aᵢwᵢ²/p² − 1
    // and F' = −2 Σ Aᵢwᵢ³/p³ (Aᵢ = aᵢ²uᵢ²): one division per step
    let au = a.component_mul(u);
    let big_a = au.component_mul(&au);
    let terms = |t: f64| {
        let s = a2.add_scalar(t);
        let w = Vector3::new(s.y * s.z, s.x * s.z, s.x * s.y);
        (w, s.x * w.x)
    };
    for _ in 0..MAX_NEWTON {
        let (w, p) = terms(t);
        let aw2 = big_a.component_mul(&w).component_mul(&w);
        let step = (aw2.x + aw2.y + aw2.z - p * p) * p / (-2.0 * aw2.dot(&w));
        if !step.is_finite() {
            return None;
        }
        // from above the root a step lands below it; never below the bound
        t = (t - step).max(low);
        // quadratic convergence: the error after this step is about the square of its
        // relative size (to t + min aᵢ², the scale of the steps and of the closest
        // point's change with t), below 1e-12 of it
        if step.abs() <= 1e-6 * (t + a2min) {
            let (w, p) = terms(t);
            return Some(a2.component_mul(u).component_mul(&w) / p);
        }
    }
    None
}

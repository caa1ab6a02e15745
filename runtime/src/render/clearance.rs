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
//! lifted) are queried, each against the bodies its own bound does not rule out.

use crate::bodies::{Attachment, Body};
use crate::error::{Error, Result};
use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::head::HeadState;

/// How fast the lift of a render strand around a body fades along the strand: the
/// offset's length changes by at most this per unit arc length (m/m), on both sides of
/// the points pushed out.
pub const RAMP_SLOPE: f64 = 0.25;
/// Render points tested together against the bodies' bounds.
pub const BLOCK: usize = 8;
/// Most pushes of one point (out of one body into another's clearance, out again).
const MAX_PUSHES: usize = 4;

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

    /// The bodies placed at head state `head`, for [`Placed::apply`].
    pub(super) fn at<'a>(&'a self, head: &HeadState) -> Placed<'a> {
        Placed {
            keep: self,
            rotation: head.rotation,
            to_head: head.rotation.transpose(),
            position: head.position,
        }
    }
}

/// [`KeepOut`] at one head state.
#[derive(Debug, Clone, Copy)]
pub(super) struct Placed<'a> {
    keep: &'a KeepOut,
    rotation: Matrix3<f64>,
    to_head: Matrix3<f64>,
    position: Vector3<f64>,
}

impl Placed<'_> {
    /// `x` (world) in the coordinates of `body`.
    #[inline]
    fn local(&self, body: &Body, x: &Vector3<f64>) -> Vector3<f64> {
        match body.attached {
            Attachment::World => *x,
            Attachment::Head => self.to_head * (x - self.position),
        }
    }

    /// Whether every point within `radius` of `x` (world) is farther than the clearance
    /// from every body, by the bodies' cheap bounds.
    #[inline]
    fn far(&self, x: &Vector3<f64>, radius: f64) -> bool {
        let r = radius + self.keep.clearance;
        let mut head = None;
        self.keep.bodies.iter().all(|b| {
            let y = match b.attached {
                Attachment::World => *x,
                Attachment::Head => *head.get_or_insert_with(|| self.local(b, x)),
            };
            b.shape.farther_than(&y, r)
        })
    }

    /// The deepest body within the clearance of `x` (world): its signed distance and
    /// world normal; `None` when every body is at least the clearance away.
    fn deepest(&self, x: &Vector3<f64>) -> Option<(f64, Vector3<f64>)> {
        let c = self.keep.clearance;
        let mut best: Option<(f64, Vector3<f64>, Attachment)> = None;
        for b in &self.keep.bodies {
            let y = self.local(b, x);
            if b.shape.farther_than(&y, c) {
                continue;
            }
            let p = b.shape.query(&y);
            if p.distance < c && best.is_none_or(|(d, _, _)| p.distance < d) {
                best = Some((p.distance, p.normal, b.attached));
            }
        }
        best.map(|(d, n, attached)| match attached {
            Attachment::World => (d, n),
            Attachment::Head => (d, self.rotation * n),
        })
    }

    /// `x` moved out of every body to the clearance (a few pushes at most).
    fn push_out(&self, mut x: Vector3<f64>) -> Vector3<f64> {
        for _ in 0..MAX_PUSHES {
            match self.deepest(&x) {
                Some((d, n)) if (self.keep.clearance - d).is_finite() => {
                    x += (self.keep.clearance - d) * n;
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
                    Some(&next) => ramp(&delta, (vector(next) - p).norm()),
                    None => Vector3::zeros(),
                };
            }
            j = end;
        }
        if !lifted {
            return;
        }
        // backward: lift the points before each push by the ramp too
        for k in (1..m - 1).rev() {
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

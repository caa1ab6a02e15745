//! Render strands kept out of the scene's bodies. The guides do not enter the bodies
//! (contacts), but a render strand blended between two guides that wrap around a head
//! follows their chord and cuts through it. After the blend, every render point but the
//! root that comes within the clearance of a body is pushed out of it to the clearance
//! ([`super::clearance_bodies`]: along the normal for spheres, capsules and planes, along
//! the gradient of the scaled radius for an ellipsoid), and the strand around it is lifted
//! with it.
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
//! body is placed once (its frame and its own rotation turned into one map, in f32). The
//! strands are then kept out [`LANES`] at a time: their points are copied into rows (one
//! point of each of the eight strands, by coordinate) and walked together, forward and
//! back. At each row every body answers for the eight points at once in closed form
//! (SIMD, `render/lanes.rs`: no branch and no iteration but an early end when no point is
//! near), and only a body without a closed form (a cylinder, a mesh) is asked point by
//! point. A row with nothing near and nothing carried costs the bodies' first tests.
//! The code is generic over the lanes: `wide::f32x8` on the portable path, one AVX
//! register each on a CPU with AVX2 ([`super::semi_interpolation`] chooses at run time).

use super::clearance_bodies::{Placed, P};
use super::lanes::Lanes;
use crate::bodies::{Body, Placement};
use crate::error::{Error, Result};

/// One point (or offset) of each strand of a group, by coordinate.
pub(super) type Row = [[f32; LANES]; 3];

/// How fast the lift of a render strand around a body fades along the strand: the
/// offset's length changes by at most this per unit arc length (m/m), on both sides of
/// the points pushed out.
pub const RAMP_SLOPE: f32 = 0.25;
/// Render strands kept out together, their points walked in step.
pub const LANES: usize = 8;
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

    /// The bodies placed at `at` (bodies on the head at its state, bodies on their own
    /// motion at their pose of `at.time`), for [`Frame::apply`].
    pub(super) fn at<'a, L: Lanes>(&'a self, at: &Placement) -> Frame<'a, L> {
        let bodies: Vec<Placed<'a, L>> = self
            .bodies
            .iter()
            .map(|b| Placed::new(b, b.frame(at).as_ref(), self.clearance))
            .collect();
        Frame { bodies }
    }

    /// Scratch a group of [`LANES`] strands of `points` points needs in [`Frame::apply`]:
    /// per point, a row of offsets and a row of positions.
    pub(super) fn scratch_len(points: usize) -> usize {
        2 * points
    }
}

/// [`KeepOut`] at one frame: each body placed.
#[derive(Debug, Clone)]
pub(super) struct Frame<'a, L> {
    bodies: Vec<Placed<'a, L>>,
}

impl<L: Lanes> Frame<'_, L> {
    /// `x` (eight points, one per lane) pushed out of every body to the clearance (a few
    /// pushes at most): each time out of the deepest body within the clearance; a body
    /// with a closed form is not asked again right after it pushed the point out.
    #[inline(always)]
    fn push(&self, x: &mut P<L>) -> bool {
        let none = L::splat(-1.0);
        let mut skip = none;
        let mut active = L::splat(0.0).eq(L::splat(0.0));
        let mut pushed = false;
        for _ in 0..MAX_PUSHES {
            let mut best = L::splat(f32::INFINITY);
            let mut from = none;
            let mut q = *x;
            for (i, b) in self.bodies.iter().enumerate() {
                let index = L::splat(i as f32);
                let asked = active & skip.ne(index);
                if asked.none() {
                    continue;
                }
                let Some((d, p)) = b.push(*x, asked) else {
                    continue;
                };
                let take = d.lt(best);
                best = take.select(d, best);
                from = take.select(index, from);
                q = [
                    take.select(p[0], q[0]),
                    take.select(p[1], q[1]),
                    take.select(p[2], q[2]),
                ];
            }
            active = from.ne(none);
            if active.none() {
                return pushed;
            }
            pushed = true;
            *x = q;
            skip = from;
            for (i, b) in self.bodies.iter().enumerate() {
                if b.asked_again() {
                    skip = from.eq(L::splat(i as f32)).select(none, skip);
                }
            }
        }
        pushed
    }

    /// Keep `count` (1 to [`LANES`]) render strands of `m` points each (`lines`, strand
    /// after strand, root first, world) out of the bodies; `scratch` holds
    /// [`KeepOut::scratch_len`]`(m)` rows.
    #[inline(always)]
    pub(super) fn apply(
        &self,
        lines: &mut [[f32; 3]],
        count: usize,
        m: usize,
        scratch: &mut [Row],
    ) {
        if self.bodies.is_empty() || m < 2 || count == 0 {
            return;
        }
        // the points by row, each coordinate of the eight strands together (lanes past
        // `count` walk the last strand again and are not written back), and their offsets
        let (scratch, rows) = scratch.split_at_mut(m);
        let starts: [usize; LANES] = std::array::from_fn(|l| l.min(count - 1) * m);
        for (k, row) in rows.iter_mut().enumerate().skip(1) {
            for l in 0..LANES {
                let s = lines[starts[l] + k];
                row[0][l] = s[0];
                row[1][l] = s[1];
                row[2][l] = s[2];
            }
        }
        let zero = L::splat(0.0);
        // forward: push out, carry the offset on and ramp it down
        let mut lifted = 0u32;
        // the first and last rows where a strand moved
        let (mut first, mut last) = (m, 0);
        let mut carry = [zero; 3];
        let mut carrying = false;
        let mut p = offsets(&rows[1]);
        for k in 1..m {
            let mut q = [p[0] + carry[0], p[1] + carry[1], p[2] + carry[2]];
            if !self.push(&mut q) && !carrying {
                // nothing near and nothing carried: the points stay as blended
                scratch[k] = [[0.0; LANES]; 3];
                if k + 1 < m {
                    p = offsets(&rows[k + 1]);
                }
                continue;
            }
            let delta = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            scratch[k] = [
                delta[0].to_array(),
                delta[1].to_array(),
                delta[2].to_array(),
            ];
            let moved = nonzero(delta).bitmask() & ((1 << count) - 1);
            if moved != 0 {
                lifted |= moved;
                (first, last) = (first.min(k), k);
                let q = [q[0].to_array(), q[1].to_array(), q[2].to_array()];
                for l in (0..count).filter(|l| moved >> l & 1 == 1) {
                    lines[starts[l] + k] = [q[0][l], q[1][l], q[2][l]];
                }
                rows[k] = q;
            }
            if k + 1 < m {
                let next = offsets(&rows[k + 1]);
                let step = [next[0] - p[0], next[1] - p[1], next[2] - p[2]];
                carry = ramp8(delta, dot8(step, step));
                carrying = nonzero(carry).any();
                p = next;
            }
        }
        if lifted == 0 {
            return;
        }
        // backward from the last row that moved: lift the points before each push by the
        // ramp too, down to where nothing is lifted before the first row that moved
        let mut next: P<L> = offsets(&scratch[last]);
        let mut next_point = offsets(&rows[last]);
        for k in (1..last).rev() {
            let here = offsets(&scratch[k]);
            let point = offsets(&rows[k]);
            if nonzero(next).none() {
                if k < first {
                    break;
                }
                (next, next_point) = (here, point);
                continue;
            }
            let original = [point[0] - here[0], point[1] - here[1], point[2] - here[2]];
            let next_original = [
                next_point[0] - next[0],
                next_point[1] - next[1],
                next_point[2] - next[2],
            ];
            let step = [
                next_original[0] - original[0],
                next_original[1] - original[1],
                next_original[2] - original[2],
            ];
            let wanted = ramp8(next, dot8(step, step));
            let (have2, want2) = (dot8(here, here), dot8(wanted, wanted));
            let raise = want2.gt(have2);
            let lanes = raise.bitmask() & ((1 << count) - 1);
            if lanes == 0 {
                (next, next_point) = (here, point);
                continue;
            }
            // raised by the part of the wanted offset the point lacks: want − have
            let f = L::splat(1.0) - (have2 / want2).sqrt();
            let mut q = [
                point[0] + wanted[0] * f,
                point[1] + wanted[1] * f,
                point[2] + wanted[2] * f,
            ];
            self.push(&mut q);
            let q = [
                raise.select(q[0], point[0]),
                raise.select(q[1], point[1]),
                raise.select(q[2], point[2]),
            ];
            let lifted_here = [q[0] - original[0], q[1] - original[1], q[2] - original[2]];
            scratch[k] = [
                lifted_here[0].to_array(),
                lifted_here[1].to_array(),
                lifted_here[2].to_array(),
            ];
            let written = [q[0].to_array(), q[1].to_array(), q[2].to_array()];
            for l in (0..count).filter(|l| lanes >> l & 1 == 1) {
                lines[l * m + k] = [written[0][l], written[1][l], written[2][l]];
            }
            (next, next_point) = (lifted_here, q);
        }
    }
}

/// A row in lanes.
#[inline(always)]
fn offsets<L: Lanes>(row: &Row) -> P<L> {
    [
        L::from_array(row[0]),
        L::from_array(row[1]),
        L::from_array(row[2]),
    ]
}

/// The lanes where `v` is not zero.
#[inline(always)]
fn nonzero<L: Lanes>(v: P<L>) -> L {
    let zero = L::splat(0.0);
    v[0].ne(zero) | v[1].ne(zero) | v[2].ne(zero)
}

/// Eight offsets `delta` each shortened by [`RAMP_SLOPE`] × the length whose square is
/// `length2` (zero once used up, and for a NaN): scaled by 1 − [`RAMP_SLOPE`] √(length2 /
/// |delta|²), one division and one root.
#[inline(always)]
fn ramp8<L: Lanes>(delta: P<L>, length2: L) -> P<L> {
    let f = L::splat(1.0) - L::splat(RAMP_SLOPE) * (length2 / dot8(delta, delta)).sqrt();
    // f > 0 fails for a zero offset (√∞ or NaN) and a NaN
    let f = f.gt(L::splat(0.0)).select(f, L::splat(0.0));
    [delta[0] * f, delta[1] * f, delta[2] * f]
}

#[inline(always)]
fn dot8<L: Lanes>(a: P<L>, b: P<L>) -> L {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

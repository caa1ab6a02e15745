//! The body contacts of one strand on storage the caller owns: which collider each
//! sample touches, the forces, stiffnesses and damping the samples add to a step's terms,
//! the energy they store, and the Coulomb anchors' update after a step. The runtime's
//! contacts and the fixed-N step both call these (the same law, the same order of
//! operations, so the same results bit for bit).
//!
//! A strand's samples sit at arc lengths `s_k` with weights `w_k`
//! ([`super::sample_points`]); their positions and unit tangents at q in head
//! coordinates are `poses` ([`super::samples::sample_poses`]). A sample touches the
//! collider it is nearest to within the contact radius r, except the collider its strand
//! grows from for the samples of the root zone; the penalty acts on the depth less the
//! sample's allowance (a depth it started with, let out over time). No `std`, no
//! allocation.

use super::law::{anchor_after_step, body_damping, body_elastic, body_potential};
use super::samples::positions_along;
use super::{ContactParams, Friction};
use crate::collider::{Mount, Proximity};
use crate::head::HeadState;
use crate::pose::Pose;
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;
type M3 = Matrix3<f64>;

/// Arc-length spacing of the dense sweep of [`BodyContacts::deepest_inside`], m.
pub const SWEEP_SPACING: f64 = 5e-4;

/// The colliders a strand may touch, by index: each answers a signed distance in its
/// own coordinates and says where those are ([`Mount`]).
pub trait ColliderSet {
    /// Number of colliders.
    fn count(&self) -> usize;
    /// Signed distance, outward normal and closest point of collider `b` at the point
    /// `local` of its coordinates.
    fn proximity(&self, b: usize, local: &V3) -> Proximity;
    /// Whether `local` is certainly farther than `r` outside collider `b` (a cheap test
    /// that may answer false for such points, never true for a nearer one).
    fn farther_than(&self, b: usize, local: &V3, r: f64) -> bool;
    /// Where collider `b`'s coordinates are, at the time the set was placed.
    fn mount(&self, b: usize) -> Mount;
    /// Whether collider `b` moves on its own motion (not with the head, not fixed in the
    /// world).
    fn on_own_motion(&self, b: usize) -> bool {
        matches!(self.mount(b), Mount::Frame(_))
    }
    /// The velocity, head coordinates, of collider `b`'s material point at the head-frame
    /// point `y`, the head in `head`: by default its mount's ([`Mount::velocity`]); a
    /// collider whose surface moves within its own coordinates (a deforming body, a
    /// callback that reports a velocity) adds that motion.
    fn velocity(&self, b: usize, head: &HeadState, y: &V3) -> V3 {
        self.mount(b).velocity(head, y)
    }
}

/// One sample's contact with a collider.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyHit {
    /// The collider's index in its [`ColliderSet`].
    pub body: usize,
    /// Signed distance of the sample's centreline point to the surface, m.
    pub distance: f64,
    /// Unit outward normal, head coordinates.
    pub normal: V3,
}

/// Where a sticking contact point is held (Coulomb friction): a point of a collider, in
/// that collider's coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anchor {
    /// The collider's index.
    pub body: usize,
    /// The anchor point, the collider's coordinates.
    pub point: V3,
    /// The point slid over the last step: the spring holds the kinetic force and has no
    /// stiffness along the sliding direction.
    pub sliding: bool,
}

/// What an evaluation of the body contacts found.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BodySummary {
    /// Samples touching a collider.
    pub contacts: usize,
    /// Deepest sample inside a collider (the centreline below the surface), m (0: none).
    pub max_penetration: f64,
    /// Sum of the normal forces (elastic part), N.
    pub normal_force: f64,
}

/// Which of a step's terms the contacts add.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TermsAsked {
    /// The generalized force `Jᵀ f`.
    pub force: bool,
    /// The stiffness `Jᵀ (∂f/∂y) J`.
    pub stiffness: bool,
    /// With the stiffness, the strand's curvature under the force: `f · ∂²y/∂q²`.
    pub curvature: bool,
    /// The damping `Jᵀ (∂f/∂ẏ) J`.
    pub damping: bool,
}

/// Where the contacts' terms go: the strand's point at an arc length with its Jacobian,
/// and the step's force, stiffness and damping.
pub trait ContactSink {
    /// y(s) at the state being evaluated, J(s) into `jac` (one column per coordinate of
    /// q); with `curvature = Some(f)`, `f · ∂²y(s)/∂q²` added to the stiffness.
    fn point(&mut self, s: f64, jac: &mut [V3], curvature: Option<V3>) -> V3;
    /// `force += Jᵀ f`.
    fn add_force(&mut self, jac: &[V3], f: &V3);
    /// `stiffness += Jᵀ A J` (A symmetric).
    fn add_stiffness(&mut self, jac: &[V3], a: &M3);
    /// `damping += Jᵀ A J` (A symmetric).
    fn add_damping(&mut self, jac: &[V3], a: &M3);
}

/// ẏ = J q̇.
pub fn point_velocity(jac: &[V3], v: &[f64]) -> V3 {
    jac.iter().zip(v).map(|(c, &x)| c * x).sum()
}

/// `force += Jᵀ f`.
pub fn add_generalized_force(jac: &[V3], f: &V3, force: &mut [f64]) {
    for (i, c) in jac.iter().enumerate() {
        force[i] += c.dot(f);
    }
}

/// `m += Jᵀ A J` (A symmetric) through `add(i, j, value)`, `aj` scratch of as many
/// columns as J. J(s) has no columns beyond the element holding s (they are zero), and
/// the product is symmetric: only the lower triangle of the nonzero block is computed,
/// and handed to both (i, j) and (j, i).
pub fn add_projected(jac: &[V3], a: &M3, aj: &mut [V3], mut add: impl FnMut(usize, usize, f64)) {
    let n = jac
        .iter()
        .rposition(|c| *c != V3::zeros())
        .map_or(0, |i| i + 1);
    for (o, c) in aj[..n].iter_mut().zip(&jac[..n]) {
        *o = a * c;
    }
    for j in 0..n {
        for i in j..n {
            let x = jac[i].dot(&aj[j]);
            add(i, j, x);
            if i != j {
                add(j, i, x);
            }
        }
    }
}

/// The body contacts of one strand, borrowed: its colliders (placed at the time of the
/// state evaluated), the law's parameters, the samples (arc length, weight), each
/// sample's anchor and allowance, and the root zone (`(collider, count)`: the first
/// `count` samples do not touch that collider).
pub struct BodyContacts<'a, C: ColliderSet> {
    /// The colliders (a borrowed set, `&S`, is one too).
    pub colliders: C,
    /// The contact law's parameters.
    pub params: &'a ContactParams,
    /// Arc length and weight of each sample.
    pub samples: &'a [(f64, f64)],
    /// Each sample's Coulomb anchor.
    pub anchors: &'a [Option<Anchor>],
    /// Each sample's allowance: a depth it may have without force, m.
    pub allowance: &'a [f64],
    /// The root zone: `(collider, count)`.
    pub root_zone: (usize, usize),
}

impl<C: ColliderSet> BodyContacts<'_, C> {
    /// Signed distance and outward normal (head coordinates) of collider `b` at the
    /// head-frame point `y`, the head in `head`.
    pub fn query(&self, head: &HeadState, b: usize, y: &V3) -> BodyHit {
        let mount = self.colliders.mount(b);
        let p = self.colliders.proximity(b, &mount.local(head, y));
        BodyHit {
            body: b,
            distance: p.distance,
            normal: mount.direction_to_head(head, &p.normal),
        }
    }

    /// The collider the head-frame point `y` is nearest to among those nearer than
    /// `reach` (≥ 0), other than `skip`; with `only`, among the colliders on their own
    /// motion (`Some(true)`) or the others (`Some(false)`).
    pub fn nearest_within(
        &self,
        head: &HeadState,
        y: &V3,
        skip: Option<usize>,
        only: Option<bool>,
        reach: f64,
    ) -> Option<BodyHit> {
        let mut best: Option<BodyHit> = None;
        for b in 0..self.colliders.count() {
            if skip == Some(b) || only.is_some_and(|m| m != self.colliders.on_own_motion(b)) {
                continue;
            }
            let local = self.colliders.mount(b).local(head, y);
            if self.colliders.farther_than(b, &local, reach) {
                continue;
            }
            let hit = self.query(head, b, y);
            if hit.distance < reach && best.is_none_or(|h| hit.distance < h.distance) {
                best = Some(hit);
            }
        }
        best
    }

    /// The collider `y` touches most deeply within the contact radius, other than `skip`
    /// (see [`Self::nearest_within`] for `only`).
    pub fn nearest(
        &self,
        head: &HeadState,
        y: &V3,
        skip: Option<usize>,
        only: Option<bool>,
    ) -> Option<BodyHit> {
        self.nearest_within(head, y, skip, only, self.params.radius)
    }

    /// The collider sample `k` at `y` touches most deeply within the contact radius (a
    /// sample of the root zone does not touch its strand's root collider); with `only`,
    /// among the colliders on their own motion or the others.
    pub fn sample_hit_among(
        &self,
        head: &HeadState,
        k: usize,
        y: &V3,
        only: Option<bool>,
    ) -> Option<BodyHit> {
        let (root_body, zone) = self.root_zone;
        self.nearest(head, y, (k < zone).then_some(root_body), only)
    }

    /// [`Self::sample_hit_among`] among all colliders.
    pub fn sample_hit(&self, head: &HeadState, k: usize, y: &V3) -> Option<BodyHit> {
        self.sample_hit_among(head, k, y, None)
    }

    /// The depth of sample `k` in `hit` the penalty acts on: the depth less the sample's
    /// allowance, m (≤ 0: no force).
    pub fn effective_depth(&self, k: usize, hit: &BodyHit) -> f64 {
        self.params.radius - hit.distance - self.allowance[k]
    }

    /// The collider sample `k` at `y` presses into (its effective depth > 0), if any.
    pub fn touching(&self, head: &HeadState, k: usize, y: &V3) -> Option<BodyHit> {
        self.sample_hit(head, k, y)
            .filter(|h| self.effective_depth(k, h) > 0.0)
    }

    /// The anchor of sample `k` in head coordinates when it is held to collider `b`, and
    /// whether it slid over the last step.
    pub fn anchor_at(&self, head: &HeadState, k: usize, b: usize) -> Option<(V3, bool)> {
        let a = self.anchors[k].filter(|a| a.body == b)?;
        let point = self.colliders.mount(b).point_to_head(head, &a.point);
        Some((point, a.sliding))
    }

    /// The elastic forces (normal penalty, Coulomb spring) of sample `k` touching `hit`
    /// at `y` with tangent `t`, and their stiffnesses ([`body_elastic`]).
    pub fn elastic(
        &self,
        head: &HeadState,
        k: usize,
        hit: &BodyHit,
        y: &V3,
        t: &V3,
    ) -> (V3, V3, f64, M3) {
        let w = self.samples[k].1;
        let depth = self.effective_depth(k, hit);
        let anchor = self.anchor_at(head, k, hit.body);
        body_elastic(self.params, w, depth, &hit.normal, t, y, anchor)
    }

    /// The contact terms of the samples at `poses` (positions and unit tangents at the
    /// state evaluated, head coordinates; the head in `head`) and velocities `v` into
    /// `sink`, as `asked`: for each touching sample the force (penalty, friction,
    /// damping of the velocity relative to the collider) through J, its stiffness
    /// `−k w n nᵀ − K_t` and its damping. `jac` and `aj` are scratch of one column per
    /// coordinate. Returns what was found and whether a sample added stiffness.
    #[allow(clippy::too_many_arguments)]
    pub fn add_terms<S: ContactSink>(
        &self,
        head: &HeadState,
        poses: &[(V3, V3)],
        v: &[f64],
        asked: TermsAsked,
        jac: &mut [V3],
        sink: &mut S,
    ) -> (BodySummary, bool) {
        let mut summary = BodySummary::default();
        let mut stiffened = false;
        for (k, &(y, t)) in poses.iter().enumerate().take(self.samples.len()) {
            let Some(hit) = self.touching(head, k, &y) else {
                continue;
            };
            let (s, w) = self.samples[k];
            summary.contacts += 1;
            summary.max_penetration = summary.max_penetration.max(-hit.distance);
            let (normal, spring, kn, kt) = self.elastic(head, k, &hit, &y, &t);
            summary.normal_force += normal.norm();
            let elastic = normal + spring;
            let curvature = (asked.stiffness && asked.curvature).then_some(elastic);
            sink.point(s, jac, curvature);
            let n = hit.normal;
            let vel = point_velocity(jac, v) - self.colliders.velocity(hit.body, head, &y);
            let (force, damping) =
                body_damping(self.params, w, &n, &t, normal.norm(), &vel, elastic);
            if asked.force {
                sink.add_force(jac, &force);
            }
            if asked.stiffness {
                let a = -kn * n * n.transpose() - kt;
                sink.add_stiffness(jac, &a);
                stiffened = true;
            }
            if asked.damping {
                sink.add_damping(jac, &damping);
            }
        }
        (summary, stiffened)
    }

    /// The energy the samples at `poses` store (normal penalty and Coulomb springs), and
    /// its rate at fixed q through the motion of the colliders they touch (a collider
    /// fixed in the world while the head moves, one on its own motion).
    pub fn energy(&self, head: &HeadState, poses: &[(V3, V3)]) -> (f64, f64) {
        let (mut potential, mut rate) = (0.0, 0.0);
        for (k, &(y, t)) in poses.iter().enumerate().take(self.samples.len()) {
            let Some(hit) = self.touching(head, k, &y) else {
                continue;
            };
            let w = self.samples[k].1;
            let depth = self.effective_depth(k, &hit);
            let (normal, spring, _, _) = self.elastic(head, k, &hit, &y, &t);
            let (penalty, held) = body_potential(self.params, w, depth, &spring);
            potential += penalty;
            potential += held;
            let u = self.colliders.velocity(hit.body, head, &y);
            rate += (normal + spring).dot(&u);
        }
        (potential, rate)
    }

    /// The power at q̇ that the damping and viscous friction of the colliders on their
    /// own motion put into the strand through their velocity u: both act on the velocity
    /// relative to the collider, and their part through u does the work `c u · ẏ`. The
    /// samples at `poses`; `jacobian(s, jac)` puts J(s) into `jac`.
    pub fn drag_power(
        &self,
        head: &HeadState,
        poses: &[(V3, V3)],
        v: &[f64],
        jac: &mut [V3],
        mut jacobian: impl FnMut(f64, &mut [V3]),
    ) -> f64 {
        let mut power = 0.0;
        for (k, &(y, t)) in poses.iter().enumerate().take(self.samples.len()) {
            let Some(hit) = self.touching(head, k, &y) else {
                continue;
            };
            if !self.colliders.on_own_motion(hit.body) {
                continue;
            }
            let u = self.colliders.velocity(hit.body, head, &y);
            if u == V3::zeros() {
                continue;
            }
            let (s, w) = self.samples[k];
            jacobian(s, jac);
            let ydot = point_velocity(jac, v);
            let n = hit.normal;
            let mut f = self.params.damping * w * n.dot(&u) * n;
            if let Friction::Viscous {
                coefficient,
                slip_speed,
            } = self.params.friction
            {
                let p = M3::identity() - n * n.transpose();
                let slide = p * (ydot - u);
                let norm = slide.norm();
                let cos = if norm > 0.0 {
                    t.dot(&slide) / norm
                } else {
                    0.0
                };
                let depth = self.effective_depth(k, &hit);
                let normal = self.params.stiffness * w * depth.clamp(0.0, self.params.max_depth);
                let ct = coefficient * (1.0 + self.params.anisotropy * cos) * normal / slip_speed;
                f += ct * (p * u);
            }
            power += f.dot(&ydot);
        }
        power
    }

    /// Sample `k`'s anchor after an accepted step, the sample at `y` with tangent `t`
    /// (Coulomb friction; `None` under another model or when it touches nothing): held
    /// while within the static limit, dragged to the kinetic stretch beyond it, set where
    /// it is for a new contact ([`anchor_after_step`]), in the collider's coordinates.
    pub fn anchor_after(&self, head: &HeadState, k: usize, y: &V3, t: &V3) -> Option<Anchor> {
        let hit = self.touching(head, k, y)?;
        let w = self.samples[k].1;
        let depth = self.effective_depth(k, &hit);
        let previous = self.anchor_at(head, k, hit.body);
        let (anchor, sliding) =
            anchor_after_step(self.params, w, depth, &hit.normal, t, y, previous)?;
        Some(Anchor {
            body: hit.body,
            point: self.colliders.mount(hit.body).local(head, &anchor),
            sliding,
        })
    }

    /// Sample `k`'s allowance after `h` seconds more, the sample at `y`: no more than its
    /// depth now, less the depenetration speed times h, never negative.
    pub fn allowance_after(&self, head: &HeadState, k: usize, y: &V3, h: f64) -> f64 {
        let a = self.allowance[k];
        if a <= 0.0 {
            return a;
        }
        let depth = self
            .sample_hit(head, k, y)
            .map_or(0.0, |hit| (self.params.radius - hit.distance).max(0.0));
        (a.min(depth) - self.params.depenetration_speed * h).max(0.0)
    }

    /// The deepest point of the centreline inside a collider at q, m (0: none), checked
    /// on a dense sweep: points every [`SWEEP_SPACING`] of arc length from the root to
    /// the tip, not only the samples, of a strand rooted at `root` with element lengths
    /// `lengths`. The root zone's points (up to its last sample's half weight beyond it,
    /// [`Self::zone_end`]) do not count against its collider.
    ///
    /// Between two points of the sweep the depth differs from theirs by at most half the
    /// spacing (the distance to a collider is 1-Lipschitz along a unit-speed curve); at
    /// the deepest point of a centreline that crosses a smooth surface the depth is
    /// stationary along the curve, so there the sweep's error is of second order in the
    /// spacing.
    pub fn deepest_inside(&self, head: &HeadState, root: &Pose, lengths: &[f64], q: &[f64]) -> f64 {
        let length: f64 = lengths.iter().sum();
        let count = crate::math::ceil(length / SWEEP_SPACING).max(1.0) as usize;
        let arcs = (0..=count).map(|i| length * i as f64 / count as f64);
        let root_body = self.root_zone.0;
        let zone_end = self.zone_end();
        let mut deepest = 0.0f64;
        positions_along(root, lengths, q, arcs, |s, y| {
            let skip = (s <= zone_end).then_some(root_body);
            if let Some(hit) = self.nearest_within(head, &y, skip, None, 0.0) {
                deepest = deepest.max(-hit.distance);
            }
        });
        deepest
    }

    /// The root zone of a strand rooted at `root` (None: a free root, which no collider
    /// holds) whose samples are at `poses`, of length `length`: the collider the root
    /// lies within the contact radius of, and its samples from the root on that lie
    /// within the contact radius of that collider (nearest to it), up to the first that
    /// does not and at most a quarter of the length. They stand for the hair leaving its
    /// follicle: pushed out, they could not leave (the root is clamped) and would bend
    /// the strand by a penalty of up to 10⁴ times its weight.
    pub fn root_zone_at(
        &self,
        head: &HeadState,
        root: Option<&V3>,
        poses: &[(V3, V3)],
        length: f64,
    ) -> (usize, usize) {
        let Some(root) = root.and_then(|r| self.nearest(head, r, None, None)) else {
            return (0, 0);
        };
        let quarter = 0.25 * length;
        let zone = (0..self.samples.len().min(poses.len()))
            .take_while(|&k| {
                self.samples[k].0 <= quarter
                    && self
                        .nearest(head, &poses[k].0, None, None)
                        .is_some_and(|h| h.body == root.body)
            })
            .count();
        (root.body, zone)
    }

    /// Sample `k`'s allowance at the start, the sample at `y`: a depth whose penalty is
    /// within `harmless` (m) is left to the penalty (a strand laid on a collider at rest),
    /// the rest allowed, to be let out at the depenetration speed rather than kicked out.
    pub fn start_allowance(&self, head: &HeadState, k: usize, y: &V3, harmless: f64) -> f64 {
        self.sample_hit(head, k, y).map_or(0.0, |h| {
            (self.params.radius - h.distance - harmless).max(0.0)
        })
    }

    /// Sample `k`'s effective depth (≥ 0) at `y` among the colliders on their own motion
    /// or the others (`only`; all with `None`): what a step's acceptance measures from.
    pub fn depth_among(&self, head: &HeadState, k: usize, y: &V3, only: Option<bool>) -> f64 {
        self.sample_hit_among(head, k, y, only)
            .map_or(0.0, |h| self.effective_depth(k, &h).max(0.0))
    }

    /// Whether a sample at `poses` (the step's end, the colliders placed there) went
    /// deeper than [`ContactParams::split_depth`] beyond its depth at the start,
    /// `start_depth` ([`Self::depth_among`]): a fast approach is resolved by substeps
    /// rather than met by a deep penalty.
    pub fn too_deep(&self, head: &HeadState, poses: &[(V3, V3)], start_depth: &[f64]) -> bool {
        let split = self.params.split_depth;
        (0..self.samples.len().min(poses.len())).any(|k| {
            self.sample_hit(head, k, &poses[k].0)
                .is_some_and(|h| self.effective_depth(k, &h) - start_depth[k] > split)
        })
    }

    /// The arc length up to which the root zone's points do not count against its
    /// collider: its last sample's arc length and half its weight (−1: no zone).
    pub fn zone_end(&self) -> f64 {
        match self
            .root_zone
            .1
            .checked_sub(1)
            .and_then(|k| self.samples.get(k))
        {
            Some((s, w)) => s + 0.5 * w,
            None => -1.0,
        }
    }
}

/// A borrowed set is a set.
impl<S: ColliderSet + ?Sized> ColliderSet for &S {
    fn count(&self) -> usize {
        (**self).count()
    }
    fn proximity(&self, b: usize, local: &V3) -> Proximity {
        (**self).proximity(b, local)
    }
    fn farther_than(&self, b: usize, local: &V3, r: f64) -> bool {
        (**self).farther_than(b, local, r)
    }
    fn mount(&self, b: usize) -> Mount {
        (**self).mount(b)
    }
    fn on_own_motion(&self, b: usize) -> bool {
        (**self).on_own_motion(b)
    }
    fn velocity(&self, b: usize, head: &HeadState, y: &V3) -> V3 {
        (**self).velocity(b, head, y)
    }
}

/// Colliders placed with their mounts: a slice of (collider, mount) pairs is a
/// [`ColliderSet`] (what an engine hands the step: its shapes, grids and callbacks,
/// each on the head, in the world or on its own motion).
impl<T: crate::collider::Collider> ColliderSet for [(T, Mount)] {
    fn count(&self) -> usize {
        self.len()
    }
    fn proximity(&self, b: usize, local: &V3) -> Proximity {
        self[b].0.proximity(local)
    }
    fn farther_than(&self, b: usize, local: &V3, r: f64) -> bool {
        self[b].0.farther_than(local, r)
    }
    fn mount(&self, b: usize) -> Mount {
        self[b].1
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider::{Plane, Sphere};
    use crate::contact::{sample_points, sample_poses};
    use crate::moments::EndDerivatives;
    use crate::strand_point::{strand_point, tests::Jets};
    use std::vec;
    use std::vec::Vec;

    const LENGTHS: [f64; 4] = [0.03, 0.025, 0.02, 0.025];
    const DOFS: usize = 12;

    fn root() -> Pose {
        Pose {
            position: Vector3::new(0.0, 0.0, 0.004),
            frame: Matrix3::identity(),
        }
    }

    /// A strand along +x from 4 mm above z = 0, bent down (the second curvature) so that
    /// its outer half dips below the plane z = 0.
    fn bent() -> Vec<f64> {
        (0..DOFS)
            .map(|i| match i % 3 {
                0 => 0.4 + 0.1 * i as f64,
                1 => 4.0 + 0.3 * i as f64,
                _ => -0.5,
            })
            .collect()
    }

    fn params(friction: Friction) -> ContactParams {
        ContactParams {
            radius: 1e-3,
            stiffness: 2e3,
            damping: 0.4,
            max_depth: 0.05,
            split_depth: 1e-3,
            depenetration_speed: 0.01,
            friction,
            anisotropy: 0.3,
        }
    }

    /// The contact terms into dense arrays: J by `strand_point` at q, the Hessian
    /// contracted with the force into the stiffness.
    struct Dense<'a> {
        q: &'a [f64],
        force: Vec<f64>,
        stiffness: Vec<f64>,
        damping: Vec<f64>,
        aj: Vec<V3>,
    }

    impl<'a> Dense<'a> {
        fn new(q: &'a [f64]) -> Self {
            Dense {
                q,
                force: vec![0.0; DOFS],
                stiffness: vec![0.0; DOFS * DOFS],
                damping: vec![0.0; DOFS * DOFS],
                aj: vec![V3::zeros(); DOFS],
            }
        }
    }

    impl ContactSink for Dense<'_> {
        fn point(&mut self, s: f64, jac: &mut [V3], curvature: Option<V3>) -> V3 {
            let mut ends = [Pose::default(); 5];
            let mut derivs = [EndDerivatives::default(); 4];
            let st = &mut self.stiffness;
            let mut add = |k: usize, l: usize, v: f64| st[k + l * DOFS] += v;
            let hessian = curvature.map(|c| (c, &mut add));
            strand_point(
                &Jets,
                &root(),
                &LENGTHS,
                &mut ends,
                &mut derivs,
                None,
                self.q,
                s,
                jac,
                hessian,
            )
        }
        fn add_force(&mut self, jac: &[V3], f: &V3) {
            add_generalized_force(jac, f, &mut self.force);
        }
        fn add_stiffness(&mut self, jac: &[V3], a: &M3) {
            let m = &mut self.stiffness;
            add_projected(jac, a, &mut self.aj, |i, j, x| m[i + j * DOFS] += x);
        }
        fn add_damping(&mut self, jac: &[V3], a: &M3) {
            let m = &mut self.damping;
            add_projected(jac, a, &mut self.aj, |i, j, x| m[i + j * DOFS] += x);
        }
    }

    fn samples() -> Vec<(f64, f64)> {
        let mut out = Vec::new();
        sample_points(&LENGTHS, 3, [false, true], 0.0, |s, w| out.push((s, w)));
        out
    }

    fn poses(q: &[f64], samples: &[(f64, f64)]) -> Vec<(V3, V3)> {
        let mut p = vec![(V3::zeros(), V3::zeros()); samples.len()];
        sample_poses(&root(), &LENGTHS, q, samples, &mut p);
        p
    }

    /// The terms (force, stiffness with the curvature) and the energy at q, q̇ = 0.
    fn terms<C: ColliderSet>(
        contacts: &BodyContacts<'_, C>,
        q: &[f64],
    ) -> (Vec<f64>, Vec<f64>, f64, BodySummary) {
        let head = HeadState::rest();
        let p = poses(q, contacts.samples);
        let mut sink = Dense::new(q);
        let mut jac = [V3::zeros(); DOFS];
        let asked = TermsAsked {
            force: true,
            stiffness: true,
            curvature: true,
            damping: true,
        };
        let (summary, _) = contacts.add_terms(&head, &p, &[0.0; DOFS], asked, &mut jac, &mut sink);
        let energy = contacts.energy(&head, &p).0;
        (sink.force, sink.stiffness, energy, summary)
    }

    /// The poses are the points `strand_point` gives and their unit tangents dy/ds
    /// (central differences in s).
    #[test]
    fn the_sample_poses_are_the_strands_points_and_tangents() {
        let q = bent();
        let samples = samples();
        let poses = poses(&q, &samples);
        let mut sink = Dense::new(&q);
        let mut jac = [V3::zeros(); DOFS];
        for (&(s, _), (y, t)) in samples.iter().zip(&poses) {
            let mut at = |s: f64, jac: &mut [V3]| sink.point(s, jac, None);
            let exact = at(s, &mut jac);
            assert!((exact - y).norm() < 1e-15, "s = {s}");
            let h = 1e-6;
            let length: f64 = LENGTHS.iter().sum();
            let slope = if s + h <= length {
                (at(s + h, &mut jac) - at(s - h, &mut jac)) / (2.0 * h)
            } else {
                // the tip: the second-order one-sided difference
                (3.0 * exact - 4.0 * at(s - h, &mut jac) + at(s - 2.0 * h, &mut jac)) / (2.0 * h)
            };
            assert!(
                (slope - t).norm() < 1e-7,
                "s = {s}: tangent {t} against {slope}"
            );
            assert!((t.norm() - 1.0).abs() < 1e-14);
        }
    }

    /// Against a ball (penalty alone) and the floor with Coulomb anchors held in place
    /// (the springs within the static limit): the generalized force the samples add is
    /// −∂U/∂q of the energy they store (central differences, 1e-7 in q), and on the
    /// floor, whose normal is constant, the stiffness with the curvature is ∂F/∂q.
    #[test]
    fn the_force_is_the_energys_gradient_and_the_stiffness_its_derivative() {
        let q = bent();
        let samples = samples();
        let allowance = vec![0.0; samples.len()];
        let ball = [(
            Sphere {
                center: Vector3::new(0.07, 0.0, -0.05),
                radius: 0.05,
            },
            Mount::Head,
        )];
        let floor = [(
            Plane {
                point: V3::zeros(),
                normal: V3::z(),
            },
            Mount::Head,
        )];
        let coulomb = params(Friction::Coulomb {
            static_coefficient: 10.0,
            kinetic_coefficient: 5.0,
            stiffness_ratio: 0.5,
        });
        // the floor's anchors: each touching sample held 0.1 mm behind where it is
        let p = poses(&q, &samples);
        let anchors: Vec<Option<Anchor>> = p
            .iter()
            .map(|(y, _)| {
                (y.z < coulomb.radius).then(|| Anchor {
                    body: 0,
                    point: y - Vector3::new(1e-4, 3e-5, 0.0),
                    sliding: false,
                })
            })
            .collect();
        let plain = params(Friction::None);
        let none = vec![None; samples.len()];
        let on_ball = BodyContacts {
            colliders: &ball[..],
            params: &plain,
            samples: &samples,
            anchors: &none,
            allowance: &allowance,
            root_zone: (0, 0),
        };
        let on_floor = BodyContacts {
            colliders: &floor[..],
            params: &coulomb,
            samples: &samples,
            anchors: &anchors,
            allowance: &allowance,
            root_zone: (0, 0),
        };
        for (name, touching, stiffness_exact) in [("ball", 4, false), ("floor", 6, true)] {
            let (force, stiffness, energy, summary) = if stiffness_exact {
                terms(&on_floor, &q)
            } else {
                terms(&on_ball, &q)
            };
            let at = |q: &[f64]| {
                if stiffness_exact {
                    terms(&on_floor, q)
                } else {
                    terms(&on_ball, q)
                }
            };
            assert!(
                summary.contacts >= touching && energy > 0.0,
                "{name}: {} samples touch",
                summary.contacts
            );
            let fscale = force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let kscale = stiffness.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let h = 1e-7;
            for i in 0..DOFS {
                let (mut up, mut down) = (q.clone(), q.clone());
                up[i] += h;
                down[i] -= h;
                let (fu, _, eu, _) = at(&up);
                let (fd, _, ed, _) = at(&down);
                let gradient = (eu - ed) / (2.0 * h);
                assert!(
                    (force[i] + gradient).abs() <= 1e-5 * fscale,
                    "{name}: F[{i}] = {} against −∂U/∂q = {}",
                    force[i],
                    -gradient
                );
                if stiffness_exact {
                    for j in 0..DOFS {
                        let numeric = (fu[j] - fd[j]) / (2.0 * h);
                        assert!(
                            (numeric - stiffness[j + i * DOFS]).abs() <= 1e-5 * kscale,
                            "{name}: K({j}, {i}) = {} against ∂F/∂q = {numeric}",
                            stiffness[j + i * DOFS]
                        );
                    }
                }
            }
        }
    }

    /// The sweep's deepest point of a straight strand sloping through the floor is its
    /// tip's depth (exact: the tip is a point of the sweep), and the root zone's points
    /// do not count against the root's collider: with the whole strand in the zone,
    /// nothing is inside.
    #[test]
    fn the_sweep_finds_the_tips_depth_and_leaves_out_the_root_zone() {
        let slope = 0.1f64;
        let root = Pose {
            position: Vector3::new(0.0, 0.0, 0.002),
            frame: nalgebra::Rotation3::from_euler_angles(0.0, slope, 0.0).into_inner(),
        };
        let q = [0.0; DOFS];
        let length: f64 = LENGTHS.iter().sum();
        let tip_depth = length * libm::sin(slope) - 0.002;
        let samples = samples();
        let none = vec![None; samples.len()];
        let allowance = vec![0.0; samples.len()];
        let floor = [(
            Plane {
                point: V3::zeros(),
                normal: V3::z(),
            },
            Mount::World,
        )];
        let p = params(Friction::None);
        let mut contacts = BodyContacts {
            colliders: &floor[..],
            params: &p,
            samples: &samples,
            anchors: &none,
            allowance: &allowance,
            root_zone: (0, 0),
        };
        let head = HeadState::rest();
        let deepest = contacts.deepest_inside(&head, &root, &LENGTHS, &q);
        assert!(
            (deepest - tip_depth).abs() < 1e-15,
            "{deepest} against {tip_depth}"
        );
        contacts.root_zone = (0, samples.len());
        assert_eq!(contacts.deepest_inside(&head, &root, &LENGTHS, &q), 0.0);
    }
}

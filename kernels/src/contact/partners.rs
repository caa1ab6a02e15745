//! Hair–hair contact of one strand with the points of other strands it was paired with
//! for a step (its *partners*): each partner acts on the strand as a ball of radius
//! `reach` moving with the other strand's point (the staggered `"ball"` coupling: each
//! strand steps against where its partners are), with a penalty, damping and, between
//! rods, Coulomb friction held at an anchor (the paper's section 4.2 extended to fibres;
//! the runtime's docs/contacts.md). The broad phase that pairs the strands is the
//! caller's; here is what one strand's step does with its partners, on borrowed values.
//! No `std`, no allocation.
//!
//! For a partner of weight w (the arc length the pair stands for) at distance d < reach
//! of the strand's point y(s), n the unit line of centres from the partner's point p:
//!
//! ```text
//! f_n = k w (reach − d) n                       penalty (elastic)
//! f_d = −c w (ẏ − v_p)  (along n only with friction)   damping
//! f_t: a spring to the anchor, |f_t| ≤ μ |f_n|  Coulomb friction between rods
//! ```

use super::body::{point_velocity, ContactSink, TermsAsked};
use super::law::{rod_friction, rod_spring_energy, RodFriction};
use crate::head::HeadState;
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;
type M3 = Matrix3<f64>;

/// Hair–hair penalty parameters of one strand.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HairHairParams {
    /// Radius of the hair volume, m.
    pub radius: f64,
    /// Penalty stiffness, N/m².
    pub stiffness: f64,
    /// Damping per metre, N·s/m².
    pub damping: f64,
    /// Penalty stiffness (N/m²) and damping per metre (N·s/m²) between two parts of this
    /// strand (self-contact).
    pub self_stiffness: f64,
    /// See [`Self::self_stiffness`].
    pub self_damping: f64,
    /// Depth of a new contact beyond which a step is split, m (`None`: the contacts').
    pub split_depth: Option<f64>,
    /// Coulomb friction between rods (`None`: none).
    pub friction: Option<RodFriction>,
    /// The normal force of a pair of two strands is solved for both after their steps
    /// (the runtime's `coupling = "pair"`): a strand's own step leaves it out.
    pub coupled: bool,
}

impl HairHairParams {
    /// These parameters as they act between two parts of the strand (self-contact).
    pub fn for_self(&self) -> Self {
        HairHairParams {
            stiffness: self.self_stiffness,
            damping: self.self_damping,
            ..*self
        }
    }
}

/// A point of another strand that one of this strand's samples was paired with for the
/// coming step (hair–hair): it acts as a moving ball of radius `reach` around `point`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartnerPoint {
    /// This strand's arc length at the pair's closest point, m.
    pub s: f64,
    /// The arc length the pair stands for, m.
    pub weight: f64,
    /// The other strand's point, world coordinates, m.
    pub point: V3,
    /// Its velocity, world coordinates, m/s.
    pub velocity: V3,
    /// Distance below which the two interact (the sum of the two volumes' radii), m.
    pub reach: f64,
    /// The pair's friction anchor, when it sticks or slides (Coulomb friction between
    /// rods).
    pub anchor: Option<PartnerAnchor>,
    /// For a pair of two parts of this strand (self-contact): the other part's arc
    /// length, m. The pair is then stepped implicitly on both parts (its force, stiffness
    /// and damping act through `J(s) − J(partner_s)`), not against a ball where the
    /// other part was at the step's start; `point` and `velocity` are only where it was.
    pub partner_s: Option<f64>,
    /// The pair's index among the pairs of this step (both sides of a pair carry it).
    pub pair: usize,
    /// The line of centres at the step's start, from the other strand's point to this
    /// one's, world coordinates (unit; zero when the two coincide).
    pub normal: V3,
}

/// Where one of this strand's samples is held by friction against another strand: the
/// other strand's sample, offset by the pair's anchor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartnerAnchor {
    /// This strand's sample (index among its contact samples).
    pub sample: usize,
    /// The point it is held to, world coordinates, m.
    pub point: V3,
    /// Its velocity, world coordinates, m/s.
    pub velocity: V3,
    /// Whether the pair slid over the last step (the spring then holds the kinetic
    /// force).
    pub sliding: bool,
    /// For a pair of two parts of this strand: the other part's sample (the spring then
    /// joins the two samples, held `offset` apart across the line of centres).
    pub partner_sample: Option<usize>,
    /// Δ*, head coordinates, m: where this sample is held relative to the partner's
    /// sample (for a pair of two parts of this strand; `point` holds it otherwise).
    pub offset: V3,
    /// The coming step's length, s: a sliding pair's force points against its slip
    /// predicted at the step's end (the slip now plus the relative velocity times the
    /// step), not against the slip now, which is shorter than one step's motion.
    pub step: f64,
}

/// One strand's partners (in arc-length order) with its hair–hair parameters and its
/// contact samples, borrowed.
pub struct PartnerContacts<'a> {
    /// The parameters.
    pub params: &'a HairHairParams,
    /// The partners of the coming step, in arc-length order.
    pub partners: &'a [PartnerPoint],
    /// Arc length and weight of each contact sample.
    pub samples: &'a [(f64, f64)],
}

/// The partners of other strands (in arc-length order) the samples' poses (head
/// coordinates, the head in `head`) do not rule out, each index passed to `near` in
/// arc-length order: a partner is ruled out when the centreline at its arc length s is
/// certainly farther than its reach from its point, judged from the two samples around s
/// (within |s − s_k| of sample k, the centreline is within that arc length of it). The
/// pairs of two parts of this strand are left out (stepped on both parts by the caller).
pub fn near(
    partners: &[PartnerPoint],
    samples: &[(f64, f64)],
    head: &HeadState,
    poses: &[(V3, V3)],
    mut near: impl FnMut(usize),
) {
    let Some(last) = samples.len().checked_sub(1) else {
        for (i, p) in partners.iter().enumerate() {
            if p.partner_s.is_none() {
                near(i);
            }
        }
        return;
    };
    let rt = head.rotation.transpose();
    // the partners are in arc-length order: the first sample at or beyond s only moves on
    let mut k = 0;
    for (i, p) in partners.iter().enumerate() {
        if p.partner_s.is_some() {
            continue;
        }
        while k < last && samples[k].0 < p.s {
            k += 1;
        }
        let pt = rt * (p.point - head.position);
        let bound = |k: usize| (poses[k].0 - pt).norm() - (samples[k].0 - p.s).abs();
        let lower = if k > 0 {
            bound(k).max(bound(k - 1))
        } else {
            bound(k)
        };
        if lower <= p.reach {
            near(i);
        }
    }
}

/// The friction spring of an anchored pair in contact: the plane across its line of
/// centres, its slip and relative velocity there, its stiffness and the pair's normal
/// force (the limit of its force).
struct RodSpring {
    plane: M3,
    slip: V3,
    rel: V3,
    stiff: f64,
    normal: f64,
}

impl RodSpring {
    /// Its force, stiffness and the damping of its turning ([`rod_friction`]) through
    /// `jac` into `sink`, as `asked`.
    fn add(
        &self,
        f: &RodFriction,
        anchor: &PartnerAnchor,
        asked: TermsAsked,
        jac: &[V3],
        sink: &mut impl ContactSink,
    ) {
        let (spring, kt, turning) = rod_friction(
            f,
            anchor.sliding,
            anchor.step,
            &self.plane,
            &self.slip,
            &self.rel,
            self.stiff,
            self.normal,
        );
        if asked.force {
            sink.add_force(jac, &spring);
        }
        if asked.stiffness {
            sink.add_stiffness(jac, &-kt);
        }
        if asked.damping && turning != M3::zeros() {
            sink.add_damping(jac, &-turning);
        }
    }
}

/// A partner's point and velocity in head coordinates (the head in `head`).
fn in_head(head: &HeadState, point: &V3, velocity: &V3) -> (V3, V3) {
    let rt = head.rotation.transpose();
    let p = rt * (point - head.position);
    let v = rt * (velocity - head.velocity) - head.omega.cross(&p);
    (p, v)
}

impl PartnerContacts<'_> {
    /// [`near`] for these partners and samples.
    pub fn near(&self, head: &HeadState, poses: &[(V3, V3)], visit: impl FnMut(usize)) {
        near(self.partners, self.samples, head, poses, visit);
    }

    /// The partners whose approach over a step the samples do not settle, each index
    /// passed to `unsettled` (the pairs of two parts of this strand and a coupled pair's,
    /// whose normal force is not the step's, left out): with the samples at `start`
    /// (head coordinates, the step's start) and `end` (poses, the step's end), along the
    /// line of centres the point at s moved by at least
    ///
    /// ```text
    /// |y0(s_k) − p| − |y1(s_k) − y0(s_k)| − 3 |s − s_k|
    /// ```
    ///
    /// for any sample k (|y0(s) − y0(s_k)| ≤ |s − s_k| and the displacement changes by
    /// at most 2 |s − s_k| between them: unit tangents); when that is at least
    /// `reach − split` for one of the two samples around s the step passes it.
    pub fn unsettled(
        &self,
        head: &HeadState,
        start: &[V3],
        end: &[(V3, V3)],
        split: f64,
        mut unsettled: impl FnMut(usize),
    ) {
        let rt = head.rotation.transpose();
        let coupled = self.params.coupled;
        for (i, p) in self.partners.iter().enumerate() {
            if p.partner_s.is_some() || coupled {
                continue;
            }
            let pt = rt * (p.point - head.position);
            let k = self
                .samples
                .partition_point(|(arc, _)| *arc < p.s)
                .min(self.samples.len().saturating_sub(1));
            let bound = |k: usize| {
                (start[k] - pt).norm()
                    - (end[k].0 - start[k]).norm()
                    - 3.0 * (self.samples[k].0 - p.s).abs()
            };
            let lower = if k > 0 {
                bound(k).max(bound(k - 1))
            } else {
                bound(k)
            };
            if lower < p.reach - split {
                unsettled(i);
            }
        }
    }

    /// Whether a step passes the partners `near` (their points on the strand at the
    /// step's start `y0` and end `y1`, head coordinates): a partner apart at the start
    /// may not end closer than `reach − split` along the line of centres at the start.
    pub fn approach_acceptable(
        &self,
        head: &HeadState,
        near: &[usize],
        y0: &[V3],
        y1: &[V3],
        split: f64,
    ) -> bool {
        let rt = head.rotation.transpose();
        near.iter().zip(y0).zip(y1).all(|((&i, y0), y1)| {
            let p = &self.partners[i];
            let pt = rt * (p.point - head.position);
            let d0 = y0 - pt;
            let norm = d0.norm();
            if norm == 0.0 {
                return true;
            }
            let along = (y1 - pt).dot(&(d0 / norm));
            norm < p.reach || p.reach - along <= split
        })
    }

    /// Add the terms of the partners `near` (indices, their points on the strand at q in
    /// `near_y`, head coordinates) at (q, q̇ = `v`) to `sink`, as `asked` (the curvature
    /// never: a partner's force acts along the strand's Jacobian only); the anchored
    /// samples' friction springs through `sink.point` at their arc lengths. `jac` is 3N
    /// columns of scratch. Returns the number of partners within reach and whether one
    /// added stiffness.
    #[allow(clippy::too_many_arguments)]
    pub fn add_terms(
        &self,
        head: &HeadState,
        near: &[usize],
        near_y: &[V3],
        v: &[f64],
        asked: TermsAsked,
        jac: &mut [V3],
        sink: &mut impl ContactSink,
    ) -> (usize, bool) {
        let hh = self.params;
        let rt = head.rotation.transpose();
        let (mut touching, mut stiffened) = (0, false);
        for (&i, &y) in near.iter().zip(near_y) {
            let partner = self.partners[i];
            let (s, w) = (partner.s, partner.weight);
            let p = rt * (partner.point - head.position);
            if (y - p).norm() >= partner.reach {
                continue;
            }
            if hh.coupled && hh.friction.is_none() {
                // all of a coupled pair's force is the pair solve's, after the step
                touching += 1;
                continue;
            }
            let y = sink.point(s, jac, None);
            let d = (y - p).norm();
            if d >= partner.reach || d == 0.0 {
                continue;
            }
            touching += 1;
            let n = (y - p) / d;
            let normal = hh.stiffness * w * (partner.reach - d);
            // with friction the damping acts along the line of centres only (the
            // tangential force is Coulomb's); without, on the whole relative velocity. A
            // coupled pair's penalty and damping are the pair solve's, after the step:
            // only its friction is the step's
            if !hh.coupled {
                // the partner's velocity as seen in the head frame
                let vp = head.rotation.transpose() * (partner.velocity - head.velocity)
                    - head.omega.cross(&p);
                let vel = point_velocity(jac, v) - vp;
                let damping = if hh.friction.is_some() {
                    hh.damping * w * n * n.transpose()
                } else {
                    hh.damping * w * M3::identity()
                };
                if asked.force {
                    sink.add_force(jac, &(normal * n - damping * vel));
                }
                if asked.stiffness {
                    let a = -hh.stiffness * w * n * n.transpose();
                    sink.add_stiffness(jac, &a);
                    stiffened = true;
                }
                if asked.damping {
                    sink.add_damping(jac, &-damping);
                }
            }
            // Coulomb friction: the anchored sample held to the partner's anchor point
            let (Some(f), Some(anchor)) = (hh.friction, partner.anchor) else {
                continue;
            };
            let Some(&(s_anchor, _)) = self.samples.get(anchor.sample) else {
                continue;
            };
            let ya = sink.point(s_anchor, jac, None);
            let target = rt * (anchor.point - head.position);
            let plane = M3::identity() - n * n.transpose();
            let slip = plane * (ya - target);
            let stiff = f.stiffness_ratio * hh.stiffness * w;
            let va = rt * (anchor.velocity - head.velocity) - head.omega.cross(&target);
            let rel = point_velocity(jac, v) - va;
            let spring = RodSpring {
                plane,
                slip,
                rel,
                stiff,
                normal,
            };
            spring.add(&f, &anchor, asked, jac, sink);
        }
        (touching, stiffened)
    }

    /// The energy the partners `near` (their points on the strand at q in `near_y`)
    /// store — the penalty and the friction springs of the anchored samples (their
    /// positions in `poses`) — and its rate at fixed q through the partners' and the
    /// anchors' motion, (J, W), added term by term to `sums` (the caller's other
    /// contacts' energy and rate, so that the order of the sum is the caller's).
    pub fn energy(
        &self,
        head: &HeadState,
        near: &[usize],
        near_y: &[V3],
        poses: &[(V3, V3)],
        sums: (f64, f64),
    ) -> (f64, f64) {
        let hh = self.params;
        let rt = head.rotation.transpose();
        let (mut potential, mut rate) = sums;
        for (&i, &y) in near.iter().zip(near_y) {
            let partner = &self.partners[i];
            let w = partner.weight;
            let pt = rt * (partner.point - head.position);
            let d = (y - pt).norm();
            if d >= partner.reach || d == 0.0 {
                continue;
            }
            let overlap = partner.reach - d;
            let n = (y - pt) / d;
            if !hh.coupled {
                // (a coupled pair's penalty is the pair solve's, not the step's)
                potential += 0.5 * hh.stiffness * w * overlap * overlap;
                let vp = head.rotation.transpose() * (partner.velocity - head.velocity)
                    - head.omega.cross(&pt);
                rate += hh.stiffness * w * overlap * n.dot(&vp);
            }
            // the friction spring: its energy, and its rate through the anchor point's
            // motion
            let (Some(f), Some(anchor)) = (hh.friction, partner.anchor) else {
                continue;
            };
            let Some(&(ya, _)) = poses.get(anchor.sample) else {
                continue;
            };
            let target = rt * (anchor.point - head.position);
            let plane = M3::identity() - n * n.transpose();
            let slip = plane * (ya - target);
            let stiff = f.stiffness_ratio * hh.stiffness * w;
            let normal = hh.stiffness * w * overlap;
            let (held, spring) =
                rod_spring_energy(&f, anchor.sliding, &plane, &slip, stiff, normal);
            potential += held;
            let va = rt * (anchor.velocity - head.velocity) - head.omega.cross(&target);
            rate += spring.dot(&(plane * va));
        }
        (potential, rate)
    }

    /// Add the terms of the pairs of two parts of this strand (self-contact, the partners
    /// with [`PartnerPoint::partner_s`]) within reach at (q, q̇ = `v`) to `sink`, as
    /// `asked` (never the curvature), each stepped implicitly on both parts: with
    /// `D = J(s) − J(s')`, the penalty `Dᵀ k w δ n`, its stiffness `−Dᵀ k w n nᵀ D`, the
    /// damping of the relative velocity `−Dᵀ c w D` (along n only with friction), and the
    /// friction spring between the two anchored samples; the self parameters
    /// ([`HairHairParams::for_self`]). `jac`, `other` and `diff` are 3N columns of
    /// scratch each. Returns the pairs within reach and whether one added stiffness.
    #[allow(clippy::too_many_arguments)]
    pub fn add_self_terms(
        &self,
        v: &[f64],
        asked: TermsAsked,
        jac: &mut [V3],
        other: &mut [V3],
        diff: &mut [V3],
        sink: &mut impl ContactSink,
    ) -> (usize, bool) {
        let hh = self.params.for_self();
        let (mut touching, mut stiffened) = (0, false);
        for partner in self.partners {
            let Some(s_other) = partner.partner_s else {
                continue;
            };
            let w = partner.weight;
            let y = sink.point(partner.s, jac, None);
            let yo = sink.point(s_other, other, None);
            let d = (y - yo).norm();
            if d >= partner.reach || d == 0.0 {
                continue;
            }
            touching += 1;
            for ((c, a), b) in diff.iter_mut().zip(jac.iter()).zip(other.iter()) {
                *c = a - b;
            }
            let n = (y - yo) / d;
            let normal = hh.stiffness * w * (partner.reach - d);
            let damping = if hh.friction.is_some() {
                hh.damping * w * n * n.transpose()
            } else {
                hh.damping * w * M3::identity()
            };
            let force = normal * n - damping * point_velocity(diff, v);
            if asked.force {
                sink.add_force(diff, &force);
            }
            if asked.stiffness {
                let a = -hh.stiffness * w * n * n.transpose();
                sink.add_stiffness(diff, &a);
                stiffened = true;
            }
            if asked.damping {
                sink.add_damping(diff, &-damping);
            }
            let (Some(f), Some(anchor)) = (hh.friction, partner.anchor) else {
                continue;
            };
            let (Some(&(sa, _)), Some(&(sb, _))) = (
                self.samples.get(anchor.sample),
                anchor.partner_sample.and_then(|k| self.samples.get(k)),
            ) else {
                continue;
            };
            let ya = sink.point(sa, jac, None);
            let yb = sink.point(sb, other, None);
            for ((c, a), b) in diff.iter_mut().zip(jac.iter()).zip(other.iter()) {
                *c = a - b;
            }
            let plane = M3::identity() - n * n.transpose();
            let slip = plane * (ya - yb - anchor.offset);
            let stiff = f.stiffness_ratio * hh.stiffness * w;
            let rel = point_velocity(diff, v);
            let spring = RodSpring {
                plane,
                slip,
                rel,
                stiff,
                normal,
            };
            spring.add(&f, &anchor, asked, diff, sink);
        }
        (touching, stiffened)
    }

    /// The energy of the pairs of two parts of this strand at q (penalty and friction
    /// springs; internal: no work through motion): `points(lo, hi)` gives the strand's
    /// points at the arc lengths lo ≤ hi of a pair, `poses` the samples' positions (for
    /// the anchored ones).
    pub fn self_energy(
        &self,
        poses: &[(V3, V3)],
        mut points: impl FnMut(f64, f64) -> Option<(V3, V3)>,
    ) -> f64 {
        let hh = self.params.for_self();
        let mut potential = 0.0;
        for partner in self.partners {
            let Some(s_other) = partner.partner_s else {
                continue;
            };
            let (lo, hi) = if partner.s <= s_other {
                (partner.s, s_other)
            } else {
                (s_other, partner.s)
            };
            let Some((a, b)) = points(lo, hi) else {
                continue;
            };
            let d = (a - b).norm();
            if d >= partner.reach || d == 0.0 {
                continue;
            }
            let w = partner.weight;
            let overlap = partner.reach - d;
            potential += 0.5 * hh.stiffness * w * overlap * overlap;
            let (Some(f), Some(anchor)) = (hh.friction, partner.anchor) else {
                continue;
            };
            let (Some(&(ya, _)), Some(&(yb, _))) = (
                poses.get(anchor.sample),
                anchor.partner_sample.and_then(|k| poses.get(k)),
            ) else {
                continue;
            };
            // n from this point to the other, oriented as in the step
            let (y, yo) = if partner.s <= s_other { (a, b) } else { (b, a) };
            let n = (y - yo) / d;
            let plane = M3::identity() - n * n.transpose();
            let slip = plane * (ya - yb - anchor.offset);
            let stiff = f.stiffness_ratio * hh.stiffness * w;
            let normal = hh.stiffness * w * overlap;
            potential += rod_spring_energy(&f, anchor.sliding, &plane, &slip, stiff, normal).0;
        }
        potential
    }

    /// Whether a step passes the pairs of two parts of this strand: a pair apart at the
    /// start may not end closer than its reach less `split` along the line of centres at
    /// the start (both parts move within the step). `points(end, lo, hi)` gives the
    /// strand's points at the arc lengths lo ≤ hi of a pair at the step's start
    /// (`end = false`) or end.
    pub fn self_approach_acceptable(
        &self,
        split: f64,
        mut points: impl FnMut(bool, f64, f64) -> (V3, V3),
    ) -> bool {
        for partner in self.partners {
            let Some(s_other) = partner.partner_s else {
                continue;
            };
            let (lo, hi) = (partner.s.min(s_other), partner.s.max(s_other));
            let (a0, b0) = points(false, lo, hi);
            let d0 = a0 - b0;
            let (a1, b1) = points(true, lo, hi);
            let d1 = a1 - b1;
            let norm = d0.norm();
            if norm == 0.0 || norm < partner.reach {
                continue;
            }
            if partner.reach - d1.dot(&(d0 / norm)) > split {
                return false;
            }
        }
        true
    }

    /// The power `c w v_p · ẏ` (along n only with friction) of the damping of the
    /// partners `near` within reach through their velocities v_p (head frame) at
    /// (q, q̇ = `v`): the work the energy balance allows a step besides the energy's
    /// rate. `point(s, jac)` is the strand's point at s with its Jacobian; 0 for a
    /// coupled pair (its damping is not the step's).
    pub fn drag_power(
        &self,
        head: &HeadState,
        near: &[usize],
        near_y: &[V3],
        v: &[f64],
        jac: &mut [V3],
        mut point: impl FnMut(f64, &mut [V3]) -> V3,
    ) -> f64 {
        let hh = self.params;
        if self.partners.is_empty() || hh.coupled {
            return 0.0;
        }
        let mut power = 0.0;
        for (&i, &y) in near.iter().zip(near_y) {
            let partner = self.partners[i];
            let (p, vp) = in_head(head, &partner.point, &partner.velocity);
            if (y - p).norm() >= partner.reach {
                continue;
            }
            let y = point(partner.s, jac);
            let d = (y - p).norm();
            if d >= partner.reach || d == 0.0 {
                continue;
            }
            let ydot = point_velocity(jac, v);
            power += hh.damping
                * partner.weight
                * if hh.friction.is_some() {
                    let n = (y - p) / d;
                    n.dot(&vp) * n.dot(&ydot)
                } else {
                    vp.dot(&ydot)
                };
        }
        power
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::body::add_projected;

    /// A "strand" that is one free point y (q = y, J = I): the sink of the partner terms.
    struct Point {
        y: V3,
        force: [f64; 3],
        stiffness: [[f64; 3]; 3],
        damping: [[f64; 3]; 3],
        aj: [V3; 3],
    }

    impl Point {
        fn at(y: V3) -> Self {
            Point {
                y,
                force: [0.0; 3],
                stiffness: [[0.0; 3]; 3],
                damping: [[0.0; 3]; 3],
                aj: [V3::zeros(); 3],
            }
        }
    }

    impl ContactSink for Point {
        fn point(&mut self, _s: f64, jac: &mut [V3], _curvature: Option<V3>) -> V3 {
            jac.copy_from_slice(&[V3::x(), V3::y(), V3::z()]);
            self.y
        }
        fn add_force(&mut self, jac: &[V3], f: &V3) {
            for (i, c) in jac.iter().enumerate() {
                self.force[i] += c.dot(f);
            }
        }
        fn add_stiffness(&mut self, jac: &[V3], a: &M3) {
            let st = &mut self.stiffness;
            add_projected(jac, a, &mut self.aj, |i, j, x| st[i][j] += x);
        }
        fn add_damping(&mut self, jac: &[V3], a: &M3) {
            let d = &mut self.damping;
            add_projected(jac, a, &mut self.aj, |i, j, x| d[i][j] += x);
        }
    }

    fn params(friction: Option<RodFriction>) -> HairHairParams {
        HairHairParams {
            radius: 1e-3,
            stiffness: 200.0,
            damping: 0.05,
            self_stiffness: 200.0,
            self_damping: 0.05,
            split_depth: None,
            friction,
            coupled: false,
        }
    }

    fn partner(anchor: Option<PartnerAnchor>) -> PartnerPoint {
        PartnerPoint {
            s: 0.0,
            weight: 0.01,
            point: V3::new(0.0, 0.0, 0.0),
            velocity: V3::new(0.02, -0.01, 0.03),
            reach: 2e-3,
            anchor,
            partner_s: None,
            pair: 0,
            normal: V3::z(),
        }
    }

    /// Force, stiffness and damping of a partner at y with velocity ẏ (head at rest).
    fn terms(c: &PartnerContacts<'_>, y: V3, ydot: V3) -> Point {
        let mut sink = Point::at(y);
        let mut jac = [V3::zeros(); 3];
        let asked = TermsAsked {
            force: true,
            stiffness: true,
            curvature: false,
            damping: true,
        };
        let v = [ydot.x, ydot.y, ydot.z];
        c.add_terms(
            &HeadState::rest(),
            &[0],
            &[y],
            &v,
            asked,
            &mut jac,
            &mut sink,
        );
        sink
    }

    /// A partner point 0.6 mm into its 2 mm reach, without and with a sticking Coulomb
    /// anchor 0.1 mm off in the tangent plane of the line of centres: the elastic force (at ẏ equal to the
    /// partner's velocity: no damping) is minus the gradient of the stored energy (central
    /// differences, 1e-6 relative); without friction the step's stiffness is the normal
    /// part of ∂F/∂y, −k w n nᵀ, the rest being the ball's curvature k w (reach − d)/d
    /// (I − n nᵀ), which stays explicit (checked: the two add up to the central
    /// differences of F); the damping is −c w n nᵀ with friction and −c w I without, and
    /// the drag power is c w v_p · ẏ (along n with friction); beyond reach nothing acts.
    #[test]
    fn forces_are_minus_the_gradient_of_the_partner_energy() {
        let head = HeadState::rest();
        let y0 = V3::new(3e-4, -2e-4, 1.4e-3 - 1e-12);
        let friction = RodFriction {
            static_coefficient: 0.5,
            kinetic_coefficient: 0.4,
            stiffness_ratio: 1.0,
        };
        let anchor = PartnerAnchor {
            sample: 0,
            // in the tangent plane: the spring's force is then the gradient of its energy
            // (the plane turns with y, which moves a slip along n only)
            point: y0 + 1e-4 * (V3::x() - y0.normalize() * y0.normalize().x).normalize(),
            velocity: V3::new(0.02, -0.01, 0.03),
            sliding: false,
            partner_sample: None,
            offset: V3::zeros(),
            step: 1.0 / 30.0,
        };
        let samples = [(0.0, 0.01)];
        for (f, a) in [(None, None), (Some(friction), Some(anchor))] {
            let hh = params(f);
            let partners = [partner(a)];
            let c = PartnerContacts {
                params: &hh,
                partners: &partners,
                samples: &samples,
            };
            let vp = partners[0].velocity;
            let energy = |y: V3| c.energy(&head, &[0], &[y], &[(y, V3::x())], (0.0, 0.0)).0;
            let at = terms(&c, y0, vp);
            let h = 1e-8;
            let scale = at.force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(scale > 0.0);
            for i in 0..3 {
                let e = V3::ith(i, h);
                let grad = (energy(y0 + e) - energy(y0 - e)) / (2.0 * h);
                assert!(
                    (at.force[i] + grad).abs() <= 1e-6 * scale,
                    "friction {}: F[{i}] = {:e}, −∂U = {:e}",
                    f.is_some(),
                    at.force[i],
                    -grad
                );
                if f.is_some() {
                    continue;
                }
                let (fp, fm) = (terms(&c, y0 + e, vp), terms(&c, y0 - e, vp));
                let (n, d) = (y0.normalize(), y0.norm());
                let curvature =
                    hh.stiffness * 0.01 * (2e-3 - d) / d * (M3::identity() - n * n.transpose());
                for r in 0..3 {
                    let k = (fp.force[r] - fm.force[r]) / (2.0 * h);
                    let normal = -hh.stiffness * 0.01 * n[r] * n[i];
                    assert!((at.stiffness[i][r] - normal).abs() <= 1e-12, "K[{r}][{i}]");
                    assert!(
                        (at.stiffness[i][r] + curvature[(r, i)] - k).abs() <= 1e-6 * 200.0 * 0.01,
                        "K[{r}][{i}] = {:e} + {:e}, ∂F = {k:e}",
                        at.stiffness[i][r],
                        curvature[(r, i)]
                    );
                }
            }
            // damping and the drag power
            let n = y0.normalize();
            let expected = if f.is_some() {
                -hh.damping * 0.01 * n * n.transpose()
            } else {
                -hh.damping * 0.01 * M3::identity()
            };
            for i in 0..3 {
                for r in 0..3 {
                    assert!((at.damping[i][r] - expected[(r, i)]).abs() <= 1e-15);
                }
            }
            let ydot = V3::new(-0.1, 0.2, 0.05);
            let mut jac = [V3::zeros(); 3];
            let power = c.drag_power(
                &head,
                &[0],
                &[y0],
                &[ydot.x, ydot.y, ydot.z],
                &mut jac,
                |_, jac| {
                    jac.copy_from_slice(&[V3::x(), V3::y(), V3::z()]);
                    y0
                },
            );
            let expected = hh.damping
                * 0.01
                * if f.is_some() {
                    n.dot(&vp) * n.dot(&ydot)
                } else {
                    vp.dot(&ydot)
                };
            assert!((power - expected).abs() <= 1e-15, "{power:e} {expected:e}");
            // beyond reach
            let far = terms(&c, V3::new(0.0, 0.0, 2.1e-3), vp);
            assert_eq!(far.force, [0.0; 3]);
        }
    }

    /// `near` rules out only partners beyond reach: of partners along a straight strand
    /// on the x axis (samples every 10 mm) at distances 1, 2, 5, 8 and 10 mm (reach
    /// 3 mm), the two within reach are kept, the pair of two parts of the strand is left
    /// out, and those the samples' bound puts beyond reach (8 and 10 mm) are ruled out.
    #[test]
    fn near_keeps_the_partners_within_reach() {
        let samples: [(f64, f64); 5] = core::array::from_fn(|k| (0.01 * k as f64, 0.01));
        let poses: [(V3, V3); 5] =
            core::array::from_fn(|k| (V3::new(samples[k].0, 0.0, 0.0), V3::x()));
        let mut partners = [partner(None); 6];
        for (i, (p, z)) in partners
            .iter_mut()
            .zip([1e-3, 0.0, 2e-3, 5e-3, 8e-3, 1e-2])
            .enumerate()
        {
            p.s = 0.007 * i as f64;
            p.point = V3::new(p.s, 0.0, z);
            p.reach = 3e-3;
        }
        partners[1].partner_s = Some(0.03);
        let mut kept = [false; 6];
        near(&partners, &samples, &HeadState::rest(), &poses, |i| {
            kept[i] = true
        });
        assert!(kept[0] && kept[2], "{kept:?}");
        assert!(!kept[1] && !kept[4] && !kept[5], "{kept:?}");
    }

    /// A straight strand on the x axis (samples every 10 mm) moving up towards partners
    /// 3 mm above it (reach 2 mm, split 0.5 mm): moved 2 mm, the partner at a sample's arc
    /// length is unsettled by the samples' bound (3 − 2 < 2 − 0.5) and the step fails it
    /// (it ends 1 mm inside the reach, beyond the split); moved 0.4 mm, the bound settles
    /// it (2.6 ≥ 1.5) and checked directly it passes; a partner 30 mm above is always
    /// settled. The verdict over every partner equals the one over the unsettled ones.
    #[test]
    fn the_approach_check_fails_a_partner_approached_beyond_the_split() {
        let samples: [(f64, f64); 5] = core::array::from_fn(|k| (0.01 * k as f64, 0.01));
        let start: [V3; 5] = core::array::from_fn(|k| V3::new(samples[k].0, 0.0, 0.0));
        let lift = |dz: f64| -> [(V3, V3); 5] {
            core::array::from_fn(|k| (start[k] + V3::new(0.0, 0.0, dz), V3::x()))
        };
        let hh = params(None);
        for (dz, close, passes) in [(2e-3, true, false), (0.4e-3, false, true)] {
            let end = lift(dz);
            let mut partners = [partner(None); 2];
            partners[0].s = 0.02;
            partners[0].point = V3::new(0.02, 0.0, 3e-3);
            partners[1].s = 0.03;
            partners[1].point = V3::new(0.03, 0.0, 3e-2);
            let c = PartnerContacts {
                params: &hh,
                partners: &partners,
                samples: &samples,
            };
            let mut unsettled = [false; 2];
            c.unsettled(&HeadState::rest(), &start, &end, 5e-4, |i| {
                unsettled[i] = true
            });
            assert_eq!(unsettled, [close, false], "dz {dz}");
            let y0 = [start[2], start[3]];
            let y1 = [end[2].0, end[3].0];
            let head = HeadState::rest();
            let all = c.approach_acceptable(&head, &[0, 1], &y0, &y1, 5e-4);
            let near: &[usize] = if close { &[0] } else { &[] };
            let some = c.approach_acceptable(&head, near, &y0, &y1, 5e-4);
            assert_eq!((all, some), (passes, passes), "dz {dz}");
        }
    }
}

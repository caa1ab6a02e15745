//! The samples that may reach a collider within a step (the contacts that start within a
//! step, whose one-sided penalty the step resolves on its own factors: the complementarity
//! problem of [`super::complementarity`]): which samples are candidates, at the step's
//! predicted end and at its actual end, and what each carries. No `std`, no allocation.

use super::body::{BodyContacts, BodyHit, ColliderSet};
use crate::head::HeadState;
use nalgebra::Vector3;

/// One sample that may reach a body within the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Index of the sample (beyond the samples: the tip).
    pub sample: usize,
    /// Its arc length, m.
    pub s: f64,
    /// Its penalty stiffness k w, N/m.
    pub stiffness: f64,
    /// The body.
    pub body: usize,
    /// The body's outward normal at the linearisation point, head coordinates.
    pub normal: Vector3<f64>,
    /// The distance to the body at which its penalty starts, m: the contact radius (less
    /// the sample's allowance) for a sample that touched nothing at the start; 0 (less
    /// the allowance) for one whose stiffness is in the step's matrix and whose
    /// centreline ended inside the body (the linearisation's error: it then adds to
    /// the matrix's penalty what keeps the centreline out).
    pub onset: f64,
    /// The gap φ = d − onset at the linearisation point, plus the correction of the
    /// linearisation found by checking the step's end (the runtime's
    /// `PredictedContacts`), m.
    pub gap: f64,
    /// The gap measured at the end of the step's last solve (`None`: not measured).
    pub end_gap: Option<f64>,
}

impl<C: ColliderSet> BodyContacts<'_, C> {
    /// Sample `k` as a candidate against collider `b` (penalty from distance `onset`),
    /// linearised where it is at the linearisation point, `lin_y`, with the gap measured
    /// at the step's end when known.
    pub fn candidate(
        &self,
        head: &HeadState,
        k: usize,
        b: usize,
        onset: f64,
        lin_y: &Vector3<f64>,
        end_gap: Option<f64>,
    ) -> Candidate {
        let start = self.query(head, b, lin_y);
        Candidate {
            sample: k,
            s: self.samples[k].0,
            stiffness: self.params.stiffness * self.samples[k].1,
            body: b,
            normal: start.normal,
            onset,
            gap: start.distance - onset,
            end_gap,
        }
    }

    /// For sample `k`, which touched nothing at the linearisation point, at `end` (the
    /// step's predicted end): the collider it comes within one and a half contact radii
    /// of (its penalty's onset, the radius less its allowance, plus half a radius), and
    /// that onset.
    pub fn predicted_hit(
        &self,
        head: &HeadState,
        k: usize,
        end: &Vector3<f64>,
    ) -> Option<(BodyHit, f64)> {
        let r = self.params.radius;
        let onset = r - self.allowance[k];
        let (root_body, zone) = self.root_zone;
        let skip = (k < zone).then_some(root_body);
        self.nearest_within(head, end, skip, None, onset + 0.5 * r)
            .map(|hit| (hit, onset))
    }

    /// For sample `k` at `y` (the step's actual end) that was not a candidate: the
    /// collider it ends within its onset of — the contact radius for a sample that
    /// touched nothing at the linearisation point, the surface for one that touched
    /// (`touching`: its stiffness was in the step's matrix), less its allowance — and that
    /// onset.
    pub fn end_hit(
        &self,
        head: &HeadState,
        k: usize,
        y: &Vector3<f64>,
        touching: bool,
    ) -> Option<(BodyHit, f64)> {
        let hit = self.sample_hit(head, k, y)?;
        let onset = if touching { 0.0 } else { self.params.radius } - self.allowance[k];
        (hit.distance < onset).then_some((hit, onset))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider::{Mount, Plane};
    use crate::contact::{ContactParams, Friction};

    /// Against the floor z = 0 with r = 1 mm: a sample is a candidate at its predicted
    /// end within 1.5 r of it (its onset r less its allowance), its gap at the
    /// linearisation point measured from that onset along the floor's normal; at the
    /// actual end a sample that touched nothing counts within r, one that touched only
    /// inside the floor (less its allowance); the root zone's samples never against the
    /// root's collider.
    #[test]
    fn candidates_are_found_within_their_onsets() {
        let floor = [(
            Plane {
                point: Vector3::zeros(),
                normal: Vector3::z(),
            },
            Mount::Head,
        )];
        let params = ContactParams {
            radius: 1e-3,
            stiffness: 1e3,
            damping: 0.1,
            max_depth: 1e-3,
            split_depth: 1e-3,
            depenetration_speed: 0.05,
            friction: Friction::None,
            anisotropy: 0.0,
        };
        let samples = [(0.01, 0.02), (0.03, 0.02)];
        let anchors = [None, None];
        let allowance = [0.0, 2e-4];
        let mut contacts = BodyContacts {
            colliders: &floor[..],
            params: &params,
            samples: &samples,
            anchors: &anchors,
            allowance: &allowance,
            root_zone: (0, 0),
        };
        let head = HeadState::rest();
        let at = |z: f64| Vector3::new(0.0, 0.0, z);
        // sample 0: onset 1 mm, reach 1.5 mm; sample 1: onset 0.8 mm, reach 1.3 mm
        assert!(contacts.predicted_hit(&head, 0, &at(1.49e-3)).is_some());
        assert!(contacts.predicted_hit(&head, 0, &at(1.51e-3)).is_none());
        let (hit, onset) = contacts
            .predicted_hit(&head, 1, &at(1.29e-3))
            .expect("within");
        assert_eq!((hit.body, onset), (0, 8e-4));
        assert!(contacts.predicted_hit(&head, 1, &at(1.31e-3)).is_none());
        let c = contacts.candidate(&head, 1, 0, onset, &at(5e-3), None);
        assert_eq!((c.sample, c.s, c.stiffness), (1, 0.03, 1e3 * 0.02));
        assert!((c.gap - (5e-3 - 8e-4)).abs() < 1e-18 && c.normal == Vector3::z());
        // the actual end
        assert!(contacts.end_hit(&head, 0, &at(0.9e-3), false).is_some());
        assert!(contacts.end_hit(&head, 0, &at(0.9e-3), true).is_none());
        let (_, onset) = contacts
            .end_hit(&head, 1, &at(-3e-4), true)
            .expect("inside");
        assert_eq!(onset, -2e-4);
        assert!(contacts.end_hit(&head, 1, &at(-1e-4), true).is_none());
        // the root zone
        contacts.root_zone = (0, 1);
        assert!(contacts.predicted_hit(&head, 0, &at(1e-4)).is_none());
        assert!(contacts.end_hit(&head, 0, &at(-1e-4), true).is_none());
    }
}

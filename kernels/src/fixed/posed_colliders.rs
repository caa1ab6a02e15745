//! Colliders as an engine hands them to a step: each carried by the head, fixed in the
//! world, or on a pose of its own given at the step's two ends ([`Carrier::Pose`], a
//! [`PoseOverStep`]); placed at each time the step asks ([`PosedColliders`], a
//! [`StepColliders`] on the caller's frames: no allocation). The C library's batch
//! steps its colliders through it.

use super::contacts::StepColliders;
use crate::collider::{Collider, Mount, PoseOverStep, Proximity};
use crate::contact::ColliderSet;
use crate::head::HeadState;
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// What carries a collider's coordinates over a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Carrier {
    /// The head's frame (the collider moves with the head).
    Head,
    /// The world.
    World,
    /// A frame of its own, at these poses at the step's two ends.
    Pose(PoseOverStep),
}

/// Colliders with their carriers, placed over the step from `t0` by `h`: one on a pose
/// of its own is at `PoseOverStep::state((t − t0)/h, h)` at time t (its frame kept in
/// the caller's `frames`, one per collider); a collider whose surface moves within its
/// coordinates ([`Collider::surface_moves`]) adds that velocity to its carrier's.
pub struct PosedColliders<'a, T: Collider> {
    colliders: &'a [(T, Carrier)],
    frames: &'a mut [HeadState],
    t0: f64,
    h: f64,
    placed: Option<f64>,
}

impl<'a, T: Collider> PosedColliders<'a, T> {
    /// The colliders over the step from `t0` by `h` (> 0), their frames in `frames`;
    /// `None` when `frames` is shorter than the colliders.
    pub fn new(
        colliders: &'a [(T, Carrier)],
        frames: &'a mut [HeadState],
        t0: f64,
        h: f64,
    ) -> Option<Self> {
        (frames.len() >= colliders.len()).then_some(PosedColliders {
            colliders,
            frames,
            t0,
            h,
            placed: None,
        })
    }

    /// The colliders where the last step, which ended at `t`, left them (those on a pose
    /// of their own at their end poses): for the deepest-point sweep after a step.
    pub fn at_end(
        colliders: &'a [(T, Carrier)],
        frames: &'a mut [HeadState],
        t: f64,
    ) -> Option<Self> {
        Self::new(colliders, frames, t - 1.0, 1.0)
    }
}

impl<T: Collider> ColliderSet for PosedColliders<'_, T> {
    fn count(&self) -> usize {
        self.colliders.len()
    }
    fn proximity(&self, b: usize, local: &V3) -> Proximity {
        self.colliders[b].0.proximity(local)
    }
    fn farther_than(&self, b: usize, local: &V3, r: f64) -> bool {
        self.colliders[b].0.farther_than(local, r)
    }
    fn mount(&self, b: usize) -> Mount {
        match self.colliders[b].1 {
            Carrier::Head => Mount::Head,
            Carrier::World => Mount::World,
            Carrier::Pose(_) => Mount::Frame(self.frames[b]),
        }
    }
    fn on_own_motion(&self, b: usize) -> bool {
        let (c, carrier) = &self.colliders[b];
        matches!(carrier, Carrier::Pose(_)) || c.surface_moves()
    }
    fn velocity(&self, b: usize, head: &HeadState, y: &V3) -> V3 {
        let mount = self.mount(b);
        let carried = mount.velocity(head, y);
        let c = &self.colliders[b].0;
        if c.surface_moves() {
            carried + mount.direction_to_head(head, &c.surface_velocity(&mount.local(head, y)))
        } else {
            carried
        }
    }
}

impl<T: Collider> StepColliders for PosedColliders<'_, T> {
    fn place(&mut self, t: f64, _head: &HeadState) {
        if self.placed == Some(t) {
            return;
        }
        let s = (t - self.t0) / self.h;
        for (f, (_, carrier)) in self.frames.iter_mut().zip(self.colliders) {
            if let Carrier::Pose(p) = carrier {
                *f = p.state(s, self.h);
            }
        }
        self.placed = Some(t);
    }
    fn moves_relative(&self, _t0: f64, _t1: f64, head0: &HeadState, head1: &HeadState) -> bool {
        let moves = |h: &HeadState| h.velocity != V3::zeros() || h.omega != V3::zeros();
        let head_moves = moves(head0) || moves(head1);
        self.colliders.iter().any(|(c, carrier)| {
            c.surface_moves()
                || match carrier {
                    Carrier::Head => false,
                    Carrier::World => head_moves,
                    Carrier::Pose(p) => {
                        head_moves
                            || p.start_position != p.end_position
                            || p.start_rotation != p.end_rotation
                    }
                }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collider::Sphere;
    use nalgebra::Matrix3;

    /// A ball on a pose of its own moving 3 cm along x over a step of 1/60 s: placed at
    /// the step's middle it is halfway, its surface moves at 1.8 m/s (the velocity the
    /// contacts' damping and friction see), it moves relative to a still head; the same
    /// ball at rest does not; a ball on the head never does.
    #[test]
    fn a_posed_ball_is_placed_along_its_poses() {
        let ball = Sphere {
            center: V3::zeros(),
            radius: 0.05,
        };
        let h = 1.0 / 60.0;
        let moving = PoseOverStep {
            start_position: V3::zeros(),
            start_rotation: Matrix3::identity(),
            end_position: V3::new(0.03, 0.0, 0.0),
            end_rotation: Matrix3::identity(),
        };
        let set = [(ball, Carrier::Pose(moving)), (ball, Carrier::Head)];
        let mut frames = [HeadState::rest(); 2];
        let mut posed = PosedColliders::new(&set, &mut frames, 2.0, h).expect("room");
        let head = HeadState::rest();
        posed.place(2.0 + 0.5 * h, &head);
        let y = V3::new(0.07, 0.0, 0.0);
        // halfway (x = 0.015): 0.07 − 0.015 − 0.05 from the surface
        let local = posed.mount(0).local(&head, &y);
        let d = posed.proximity(0, &local).distance;
        assert!((d - 0.005).abs() < 1e-15, "{d}");
        assert!((posed.velocity(0, &head, &y) - V3::new(1.8, 0.0, 0.0)).norm() < 1e-12);
        assert!(posed.on_own_motion(0) && !posed.on_own_motion(1));
        assert!(posed.moves_relative(2.0, 2.0 + h, &head, &head));
        let still = [(
            ball,
            Carrier::Pose(PoseOverStep::still(V3::zeros(), Matrix3::identity())),
        )];
        let mut frames = [HeadState::rest()];
        let posed = PosedColliders::new(&still, &mut frames, 0.0, h).expect("room");
        assert!(!posed.moves_relative(0.0, h, &head, &head));
        let mut none: [HeadState; 0] = [];
        assert!(PosedColliders::new(&still, &mut none, 0.0, h).is_none());
    }
}

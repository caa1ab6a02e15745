//! One body: a shape placed in the world, rigidly with the head or fixed.

use super::proximity::Proximity;
use super::setup::Attachment;
use super::shape::Shape;
use nalgebra::Vector3;
use superhelix_kernels::head::HeadState;

/// A body of the scene: a shape in the coordinates of what it is attached to.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Name, unique among the bodies.
    pub name: String,
    /// What the body moves with.
    pub attached: Attachment,
    /// Its geometry.
    pub shape: Shape,
}

impl Body {
    /// Signed distance, unit outward normal and closest surface point of the world point
    /// `x` with the head in state `head` (ignored by a body fixed in the world). A body on
    /// the head answers for `y = Rᵀ(x − X)` and turns the answer back into the world:
    /// the distance is unchanged, the normal is `R n`, the closest point `X + R c`.
    pub fn query(&self, head: &HeadState, x: &Vector3<f64>) -> Proximity {
        match self.attached {
            Attachment::World => self.shape.query(x),
            Attachment::Head => {
                let y = head.rotation.transpose() * (x - head.position);
                let local = self.shape.query(&y);
                Proximity {
                    distance: local.distance,
                    normal: head.rotation * local.normal,
                    closest: head.to_world(&local.closest),
                }
            }
        }
    }

    /// Signed distance of the world point `x` with the head in state `head`.
    pub fn distance(&self, head: &HeadState, x: &Vector3<f64>) -> f64 {
        self.query(head, x).distance
    }
}

//! One body: a shape placed in the world, rigidly with the head, fixed, or on its own
//! rigid motion; and [`Placement`], the time and head state at which bodies are placed.

use super::proximity::Proximity;
use super::setup::Attachment;
use super::shape::Shape;
use nalgebra::Vector3;
use superhelix_kernels::head::HeadState;

/// Where the moving parts of a scene are at one time: the head's state, and the time at
/// which a body on its own motion ([`Attachment::Motion`]) is placed. The default: the
/// head at rest, t = 0.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Placement {
    /// The head's state.
    pub head: HeadState,
    /// Time t, s.
    pub time: f64,
    /// Whether a body on its own motion is taken at rest, at its pose of `time` with no
    /// velocity: the view of a static solve, which takes the head at rest too.
    pub at_rest: bool,
}

impl Placement {
    /// The bodies at time `t` with the head in state `head`.
    pub fn new(head: HeadState, t: f64) -> Self {
        Placement {
            head,
            time: t,
            at_rest: false,
        }
    }

    /// The static view: the head at rest ([`HeadState::rest`]) and a body on its own
    /// motion at its pose of time `t`, at rest.
    pub fn at_rest(t: f64) -> Self {
        Placement {
            head: HeadState::rest(),
            time: t,
            at_rest: true,
        }
    }
}

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
    /// The state of the frame the body's geometry is given in, at `at`: the head's state
    /// for a body on the head, the motion's state at `at.time` for a body on its own
    /// motion (without its rates when `at.at_rest`), `None` for a body fixed in the world.
    pub fn frame(&self, at: &Placement) -> Option<HeadState> {
        match &self.attached {
            Attachment::World => None,
            Attachment::Head => Some(at.head),
            Attachment::Motion(motion) => {
                let state = motion.state(at.time);
                Some(if at.at_rest {
                    HeadState {
                        position: state.position,
                        rotation: state.rotation,
                        ..HeadState::rest()
                    }
                } else {
                    state
                })
            }
        }
    }

    /// Signed distance, unit outward normal and closest surface point of the world point
    /// `x` with the body's frame in state `frame` (`None`: the world, see [`Body::frame`]).
    /// A body in a moving frame answers for `y = Rᵀ(x − X)` and turns the answer back
    /// into the world: the distance is unchanged, the normal is `R n`, the closest point
    /// `X + R c`.
    pub fn query_in(&self, frame: Option<&HeadState>, x: &Vector3<f64>) -> Proximity {
        match frame {
            None => self.shape.query(x),
            Some(f) => {
                let y = f.rotation.transpose() * (x - f.position);
                let local = self.shape.query(&y);
                Proximity {
                    distance: local.distance,
                    normal: f.rotation * local.normal,
                    closest: f.to_world(&local.closest),
                }
            }
        }
    }

    /// Signed distance, unit outward normal and closest surface point of the world point
    /// `x`, the body placed at `at`.
    pub fn query(&self, at: &Placement, x: &Vector3<f64>) -> Proximity {
        match self.attached {
            Attachment::World => self.shape.query(x),
            Attachment::Head => self.query_in(Some(&at.head), x),
            Attachment::Motion(_) => self.query_in(self.frame(at).as_ref(), x),
        }
    }

    /// Signed distance of the world point `x`, the body placed at `at`.
    pub fn distance(&self, at: &Placement, x: &Vector3<f64>) -> f64 {
        self.query(at, x).distance
    }
}

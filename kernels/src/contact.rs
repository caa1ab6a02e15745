//! The contact law of a strand's sample points (the paper's section 4.2: "a normal
//! elastic response together with a tangential viscous friction force", anisotropic by
//! "a cosine function \[of\] the orientation of hair fibers with respect to their
//! sliding motion"), with Coulomb friction and sticking anchors beside the paper's
//! viscous law: per sample, in head coordinates, the force and its stiffness and damping
//! matrices, which the step projects with the sample's Jacobian. No `std`, no allocation.
//!
//! For a sample of weight w (the arc length it stands for) at depth δ = r − d (d the
//! signed distance to the surface, n the outward normal, [`crate::collider`]):
//!
//! ```text
//! f_n = k w min(δ, δ_max) n                         normal penalty (elastic)
//! f_d = −c w (n · v) n,  c = 2 ζ √(k ρS)            normal damping (dissipative)
//! f_t = −μ(θ) |f_n| P v / v_s                       viscous friction, P = I − n nᵀ
//!     or −k_t w P (y − a), |f_t| ≤ μ_s(θ) |f_n|     Coulomb: spring to an anchor a
//! μ(θ) = μ (1 + α cos θ),  cos θ = t̂ · (sliding direction)
//! ```
//!
//! v is the point's velocity relative to the collider ([`crate::collider::Mount`]).
//! Where the samples are along the strand, and what each weighs: [`samples`]; a strand's
//! samples against its colliders, on the caller's storage: [`body`].

pub mod body;
pub mod candidates;
pub mod complementarity;
pub mod law;
pub mod partners;
pub mod predicted;
pub mod samples;

pub use body::{Anchor, BodyContacts, BodyHit, BodySummary, ColliderSet, ContactSink, TermsAsked};
pub use law::{
    anchor_after_step, body_damping, body_elastic, body_potential, body_sample, coulomb_spring,
    rod_friction, rod_spring_energy, ContactParams, Friction, RodFriction, SampleLaw,
};
pub use samples::{sample_points, sample_poses};

//! Forces and effects: the environment (gravity), the rigid motion of the head and the
//! fictitious forces it causes, composed with air drag into one body field per strand and
//! step ([`effects`]), and the point loads applied through J(s)ᵀ ([`point_loads`]).
//! Static electricity ([`electrostatics`]): charged tracer particles and their Coulomb
//! forces. Contacts with bodies and between strands ([`contacts`]). What a strand carries
//! inside and what its holders apply ([`internal_loads`]).

pub mod contacts;
pub mod effects;
pub mod electrostatics;
pub mod environment;
pub mod internal_loads;
/// The rigid motion of the head (the module [`crate::bodies::motion`], shared with the
/// bodies that move on their own).
pub use crate::bodies::motion as head_motion;
pub mod point_loads;

//! Contacts (paper section 4.1–4.2): hair–body contacts with penalty normal response and
//! anisotropic friction, and hair–hair interaction between the simulated strands.
//!
//! Built only when a scene has a `[contacts]` table: without it no strand has contact
//! samples and no pair is searched.
//!
//! - [`config`]: what the scene asks for (`[contacts]`, `[contacts.hair_hair]`).
//! - [`strand_contacts`]: one strand's contact samples, their forces and matrices, the
//!   energy the step's balance needs, the Coulomb anchors.
//! - [`hair_hair`]: the pairs of closest points between strands, tracked over time.

pub mod config;
pub mod hair_hair;
pub mod predicted;
pub mod strand_contacts;

pub use config::{ContactConfig, Coupling, Friction, HairHairConfig, RodFriction};
pub use hair_hair::{HairHair, Pair, PairCounts, SearchInterval};
pub use strand_contacts::{
    ContactParams, ContactSummary, HairHairParams, PartnerAnchor, PartnerPoint, StrandContacts,
};

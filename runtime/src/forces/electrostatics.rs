//! Static electricity on hair (Sobottka & Weber 2006): charged tracer particles on the
//! fibres (section 2.2), their Coulomb forces (eqs. 1–6) by the fast multipole method of
//! `superhelix-fmm` (section 2.3.1), applied to each strand as `Σ J(s_i)ᵀ F_i`.
//!
//! Built only when a scene has an `[electrostatics]` table: a scene without charge has
//! no particles, no tree and no extra loads.
//!
//! - [`tracers`]: where the particles sit (arc lengths) and what they carry.
//! - [`force_coulomb`]: the field at every particle and the force `F_i = q_i E_i`, in SI.
//!
//! Units: positions in m, charges in C, fields in V/m, forces in N, with Coulomb's
//! constant `k = 1/(4πε₀)`. The paper's charge density "−7.7·10⁻⁴ C/cm" is read as
//! statcoulomb per centimetre (its `c₀ = 1` is the Gaussian system), i.e.
//! −7.7·10⁻⁴ × 3.33564·10⁻¹⁰ C per 10⁻² m = [`PAPER_CHARGE_PER_LENGTH`] C/m; the
//! experiments check it against the paper's mean field strength of 13 kV/m.

pub mod force_coulomb;
pub mod tracers;

pub use force_coulomb::{
    scalp_field, CoulombMethod, Electrostatics, FieldSummary, COULOMB_CONSTANT,
};
pub use tracers::Tracers;

/// One statcoulomb in coulombs (10⁻¹ / c, c in m/s).
pub const STATCOULOMB: f64 = 3.335_640_951_981_52e-10;

/// The paper's charge per length, −7.7·10⁻⁴ statC/cm, in C/m.
pub const PAPER_CHARGE_PER_LENGTH: f64 = -7.7e-4 * STATCOULOMB / 1e-2;

/// The paper's tracer particle density, particles per metre.
pub const PAPER_PARTICLE_DENSITY: f64 = 330.0;

/// What a scene's `[electrostatics]` asks for.
#[derive(Debug, Clone, PartialEq)]
pub struct ElectrostaticsConfig {
    /// Tracer particles per metre of fibre, ρ_P.
    pub particle_density: f64,
    /// Charge per length of each strand, C/m (in the order of the strands).
    pub charge_per_length: Vec<f64>,
    /// Requested relative accuracy of the field (multipole method).
    pub accuracy: f64,
    /// Radius of the ball each particle's charge is spread over in the near field, m.
    pub softening: f64,
    /// The forces are recomputed every this many steps (dynamics).
    pub update_every: usize,
    /// Multipole method, direct sum, or the cheaper of the two for the particle count.
    pub method: CoulombMethod,
    /// Statics: the charge is brought up in this many steps (1: all at once; more: the
    /// fraction `ln(1 + k) / ln(1 + n)` at step k, the paper's logarithmic charging).
    pub charging_steps: usize,
    /// Statics: the outer iteration ends when every strand's generalized force with the
    /// refreshed Coulomb forces is at most this, relative to its force scale.
    pub tolerance: f64,
    /// Statics: most outer iterations per charging step.
    pub max_iterations: usize,
    /// The charged scalp (paper section 2.4, eq. 8): a body of the scene and its charge.
    pub scalp: Option<ScalpCharge>,
}

/// A charged body (the scalp) repelling the particles (paper eq. 8): the field of a charge
/// `charge` at the body's closest surface point, `E = k Q_S / r² n` along the outward
/// normal n, r the distance to the surface, bounded by `r ≥ a` (the softening); a
/// particle found inside the body gets the surface's largest field `k Q_S / a²` outward
/// (the paper's fallback for a particle inside: a force that does not decay), which
/// pushes it out over the next steps without a kick.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalpCharge {
    /// The body's name (`[[bodies]]`).
    pub body: String,
    /// Q_S, C (same sign as the fibres' charge: repulsion).
    pub charge: f64,
}

impl ElectrostaticsConfig {
    /// The paper's settings (ρ_P = 330/m, −7.7·10⁻⁴ statC/cm) for `strands` strands.
    pub fn paper(strands: usize) -> Self {
        ElectrostaticsConfig {
            particle_density: PAPER_PARTICLE_DENSITY,
            charge_per_length: vec![PAPER_CHARGE_PER_LENGTH; strands],
            accuracy: 1e-6,
            softening: 1.0 / PAPER_PARTICLE_DENSITY,
            update_every: 1,
            method: CoulombMethod::Auto,
            charging_steps: 1,
            tolerance: 1e-6,
            max_iterations: 30,
            scalp: None,
        }
    }
}

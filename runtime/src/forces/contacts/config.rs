//! What a scene's `[contacts]` table asks for: which bodies the strands touch, how thick
//! a strand is for contacts, the penalty of the normal response, the friction model, and
//! optionally hair–hair interaction (`[contacts.hair_hair]`).

use crate::error::FieldError;

/// Standard gravity used to scale the default penalty stiffness, m/s² (independent of the
/// scene's gravity, so that the default does not vanish without gravity).
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// Default penalty stiffness relative to a strand's weight per length and contact radius:
/// `k = DEFAULT_STIFFNESS_FACTOR · ρS g₀ / r`, so that a strand resting on a body under
/// its own weight sinks by `r / DEFAULT_STIFFNESS_FACTOR`.
pub const DEFAULT_STIFFNESS_FACTOR: f64 = 1e4;

/// Default hair–hair penalty stiffness relative to a strand's weight per length and the
/// volume radius: `k = DEFAULT_HAIR_STIFFNESS_FACTOR · ρS g₀ / r`, so that a strand
/// resting on another sinks into its hair volume by 1 % of the radius. Hair volumes are
/// soft (Choe et al. 2005 model them as compressible, with dissipative penalties), unlike
/// a body. The body's factor (10⁴ times the weight per millimetre-scale depth) made the
/// staggered coupling of the strands (each steps against where its partners were) feed
/// energy from strand to strand: 150 long strands falling onto a head and each other
/// whipped up to q̇ ≈ 10⁵ rad/(m s) within 0.6 s, where with this factor they settle as
/// they do without hair–hair interaction.
pub const DEFAULT_HAIR_STIFFNESS_FACTOR: f64 = 100.0;

/// Default penalty stiffness between two strands whose pairs are solved together
/// (`coupling = "pair"`, [`Coupling::Pair`]), relative to a strand's weight per length and
/// the volume radius, as for a body: `k = DEFAULT_PAIR_STIFFNESS_FACTOR · ρS g₀ / r`. Two
/// rods crossing carry a load on a contact a few samples long, not along the strand: at
/// [`DEFAULT_HAIR_STIFFNESS_FACTOR`] two ropes crossing under their own weight and a point
/// load of 5 mN sank 65 % of their reach into each other. The pair solve keeps each
/// pair's momentum, so the stiff penalty feeds no energy from strand to strand as the
/// staggered `"ball"` coupling did.
pub const DEFAULT_PAIR_STIFFNESS_FACTOR: f64 = 1e4;

/// Default penalty stiffness between two parts of one strand (`self_contact = true`),
/// relative to the strand's weight per length and the volume radius, as for a body: `k =
/// DEFAULT_SELF_STIFFNESS_FACTOR · ρS g₀ / r`. Both parts move in the strand's own step,
/// so the pair is stepped implicitly on both and a stiff penalty feeds no energy; at the
/// hair default [`DEFAULT_HAIR_STIFFNESS_FACTOR`] a rope of 1 m fed onto a floor
/// (`scenes/rope-pile.toml`) came to 0.06 of 2R of itself within 0.65 s: a pile presses
/// the coils below with the weight of all the rope above them.
pub const DEFAULT_SELF_STIFFNESS_FACTOR: f64 = 1e4;

pub use superhelix_kernels::contact::{ContactParams, Friction, RodFriction};

/// Hair–hair interaction between the simulated strands (Choe et al. 2005: dissipative
/// penalty forces between hair volumes; pairs tracked over time after Raghupathi et al.
/// 2003).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HairHairConfig {
    /// Radius of the hair volume a strand stands for, m: two strands interact when their
    /// centrelines come closer than twice this.
    pub radius: f64,
    /// Penalty stiffness, N/m² (force per metre of strand per metre of overlap); `None`:
    /// [`DEFAULT_HAIR_STIFFNESS_FACTOR`] `ρS g₀ / radius` for each strand
    /// ([`DEFAULT_PAIR_STIFFNESS_FACTOR`] with `coupling = "pair"`, and
    /// [`DEFAULT_SELF_STIFFNESS_FACTOR`] between two parts of one strand).
    pub stiffness: Option<f64>,
    /// Damping ratio of the relative velocity of the two points (normal and tangential),
    /// in [0, 10]: the dissipative part of the penalty.
    pub damping_ratio: f64,
    /// Steps between two searches of the broad phase (a spatial grid over every sample);
    /// between them the pairs found are tracked by their closest points.
    pub search_every: usize,
    /// Self-contact: distant parts of one strand touch too (a rope piling up, a coil),
    /// excluding the parts within `self_exclusion` of each other along the strand.
    pub self_contact: bool,
    /// Arc length within which two points of one strand do not touch, m; `None`:
    /// [`SELF_EXCLUSION_RADII`] radii.
    pub self_exclusion: Option<f64>,
    /// Depth of a new hair–hair contact beyond which a step is split, m; `None`: the
    /// contacts' `split_depth` (a strand's step sees its partners where they were at its
    /// start, so a pair that meets within the step overlaps by up to one step's approach
    /// before its penalty acts: a smaller depth resolves the meeting by substeps).
    pub split_depth: Option<f64>,
    /// Coulomb friction between the strands in contact (and the parts of a strand, with
    /// self-contact); `None`: none, the damping acts on the whole relative velocity.
    pub friction: Option<RodFriction>,
    /// The most pairs a sample keeps: a pair is kept while it is among the
    /// `max_pairs_per_sample` nearest of either of its samples, so that the pairs (and
    /// the memory and time of a step) grow linearly with the samples however dense the
    /// hair ([`DEFAULT_MAX_PAIRS_PER_SAMPLE`]).
    pub max_pairs_per_sample: usize,
    /// How the two strands of a pair are stepped together ([`Coupling`]).
    pub coupling: Coupling,
}

/// How the force of a pair of two strands in contact enters their steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Coupling {
    /// The pair's force is solved once for both strands after their steps (each
    /// strand's compliance at the pair's point from its step matrix), and applied to
    /// both, equal and opposite: the two strands' momentum is kept and neither sees the
    /// other as immovable ([`crate::solver::pair_coupling`]).
    Pair,
    /// Each strand's step sees the other's point as a ball where it was at the step's
    /// start, moving at its velocity, with the penalty implicit on its own side only: the
    /// two forces of a pair are not equal and opposite while the strands move. Cheaper
    /// on dense hair (each strand's pairs in its own step, in parallel).
    #[default]
    Ball,
}

/// The default cap on the pairs of a sample: more than the strands a sample of a dense
/// bundle touches at once (hair volumes of radius R packed 1 R apart: a disc of radius
/// 2 R holds about 4π ≈ 12.6 strands), so that in contact it drops only pairs beyond
/// the nearest 16, which have not met yet.
pub const DEFAULT_MAX_PAIRS_PER_SAMPLE: usize = 16;

/// The default arc length excluded from self-contact, in radii of the hair volume: more
/// than the π R of the tightest U-turn a strand of radius R can make, so that two points
/// of one strand that touch are not neighbours bent round.
pub const SELF_EXCLUSION_RADII: f64 = 4.0;

impl HairHairConfig {
    /// The hair–hair parameters of a strand of mass per length `rho_s` (kg/m) under this
    /// configuration.
    pub fn params(&self, rho_s: f64) -> superhelix_kernels::contact::partners::HairHairParams {
        let factor = if self.coupling == Coupling::Pair {
            DEFAULT_PAIR_STIFFNESS_FACTOR
        } else {
            DEFAULT_HAIR_STIFFNESS_FACTOR
        };
        let weight = rho_s * STANDARD_GRAVITY / self.radius;
        let k = self.stiffness.unwrap_or(factor * weight);
        let k_self = self
            .stiffness
            .unwrap_or(DEFAULT_SELF_STIFFNESS_FACTOR * weight);
        superhelix_kernels::contact::partners::HairHairParams {
            radius: self.radius,
            stiffness: k,
            damping: 2.0 * self.damping_ratio * (k * rho_s).sqrt(),
            self_stiffness: k_self,
            self_damping: 2.0 * self.damping_ratio * (k_self * rho_s).sqrt(),
            split_depth: self.split_depth,
            friction: self.friction,
            coupled: self.coupling == Coupling::Pair,
        }
    }

    /// The arc length within which two points of one strand do not touch, m.
    pub fn self_exclusion(&self) -> f64 {
        self.self_exclusion
            .unwrap_or(SELF_EXCLUSION_RADII * self.radius)
    }
}

impl Default for HairHairConfig {
    fn default() -> Self {
        HairHairConfig {
            radius: 2e-3,
            stiffness: None,
            damping_ratio: 1.0,
            search_every: 1,
            self_contact: false,
            self_exclusion: None,
            split_depth: None,
            friction: None,
            max_pairs_per_sample: DEFAULT_MAX_PAIRS_PER_SAMPLE,
            coupling: Coupling::default(),
        }
    }
}

/// The scene's `[contacts]`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactConfig {
    /// Names of the bodies the strands touch; `None`: every body of the scene.
    pub bodies: Option<Vec<String>>,
    /// Contact radius of a strand, m: a centreline point touches a body when it comes
    /// closer to the surface than this. A guide strand stands for a clump: its radius is
    /// the clump's, not a fibre's.
    pub radius: f64,
    /// Normal penalty stiffness, N/m² (force per metre of strand per metre of depth);
    /// `None`: [`DEFAULT_STIFFNESS_FACTOR`] `ρS g₀ / radius` for each strand.
    pub stiffness: Option<f64>,
    /// Damping ratio of the normal response, in [0, 10]: `c = 2 ζ √(k ρS)` per metre.
    pub damping_ratio: f64,
    /// Depth, m, beyond which the normal force stops growing (a strand that starts inside
    /// a body is pushed out over several steps, never kicked out); `None`: the radius.
    pub max_depth: Option<f64>,
    /// Speed at which a strand that starts inside a body (within the contact radius) is
    /// let out, m/s: each such point is allowed its starting depth without force, and the
    /// allowance shrinks at this speed (no depenetration kick).
    pub depenetration_speed: f64,
    /// The friction model.
    pub friction: Friction,
    /// Anisotropy α of the friction coefficient, in [0, 1): `μ(θ) = μ (1 + α cos θ)`,
    /// θ the angle between the fibre's root-to-tip tangent and its sliding direction
    /// (sliding towards the tip rubs against the cuticle scales: more friction).
    pub anisotropy: f64,
    /// Contact points per helical element, 1 to 64.
    pub samples_per_element: usize,
    /// A sample at each free end (a hair's tip, a free root): the outer part there takes
    /// the two-point Gauss–Radau rule that includes the end instead of its midpoint, so
    /// the end touches bodies and, with self-contact, the strand's other parts where it
    /// is. Off: an end is half a part beyond its last sample, and can pass into a body
    /// unseen (the tip of a 25 cm, N = 10 strand whipped by a shaking head went 1.7 mm into
    /// a bar, its last sample 3.1 mm back clear of the contact radius). `None`: on, but
    /// off with `coupling = "pair"` between strands (the pair solve's tip pairs whip dense
    /// hair at one solve per step: |q̇| = 5.6e3 rad/(m s) on the shaken head, 476 without);
    /// [`Self::free_ends`] resolves it.
    pub end_samples: Option<bool>,
    /// A step that takes a contact point deeper than this (m) beyond its depth at the
    /// start of the step is split; `None`: the radius.
    pub split_depth: Option<f64>,
    /// Hair–hair interaction; `None`: none, nothing built for it.
    pub hair_hair: Option<HairHairConfig>,
    /// Whether the contacts that start within a step are predicted from the step's own
    /// solution and resolved in it (`superhelix_runtime::forces::contacts::predicted`);
    /// off, such a contact is caught by the step's depth check alone (a step taking a
    /// sample deeper than [`Self::split_depth`] is split), as the embedded engine does.
    pub predict: bool,
}

impl ContactConfig {
    /// Which ends of a strand take a sample where they are ([`Self::end_samples`]):
    /// (root, tip), given whether its root is free and its tip is not held.
    pub fn free_ends(&self, root_free: bool, tip_free: bool) -> [bool; 2] {
        let pair = self
            .hair_hair
            .as_ref()
            .is_some_and(|h| h.coupling == Coupling::Pair);
        let on = self.end_samples.unwrap_or(!pair);
        [on && root_free, on && tip_free]
    }
}

impl Default for ContactConfig {
    fn default() -> Self {
        ContactConfig {
            bodies: None,
            radius: 1e-3,
            stiffness: None,
            damping_ratio: 0.5,
            max_depth: None,
            depenetration_speed: 0.05,
            friction: Friction::Viscous {
                coefficient: 0.3,
                slip_speed: 0.05,
            },
            anisotropy: 0.3,
            samples_per_element: 4,
            end_samples: None,
            split_depth: None,
            hair_hair: None,
            predict: true,
        }
    }
}

fn range(
    errors: &mut Vec<FieldError>,
    field: &str,
    x: f64,
    lo: f64,
    hi: f64,
    lo_open: bool,
    text: &str,
) {
    let ok = x.is_finite() && (if lo_open { x > lo } else { x >= lo }) && x <= hi;
    if !ok {
        errors.push(FieldError::new(field, format!("{x}: must be in {text}")));
    }
}

impl ContactConfig {
    /// The problems of the configuration (field paths `contacts.…`).
    pub fn check(&self) -> Vec<FieldError> {
        let mut e = Vec::new();
        range(
            &mut e,
            "contacts.radius",
            self.radius,
            0.0,
            0.1,
            true,
            "(0, 0.1] m",
        );
        if let Some(k) = self.stiffness {
            range(
                &mut e,
                "contacts.stiffness",
                k,
                0.0,
                1e9,
                true,
                "(0, 1e9] N/m²",
            );
        }
        range(
            &mut e,
            "contacts.damping_ratio",
            self.damping_ratio,
            0.0,
            10.0,
            false,
            "[0, 10]",
        );
        if let Some(d) = self.max_depth {
            range(&mut e, "contacts.max_depth", d, 0.0, 1.0, true, "(0, 1] m");
        }
        if let Some(d) = self.split_depth {
            range(
                &mut e,
                "contacts.split_depth",
                d,
                0.0,
                1.0,
                true,
                "(0, 1] m",
            );
        }
        range(
            &mut e,
            "contacts.depenetration_speed",
            self.depenetration_speed,
            0.0,
            100.0,
            true,
            "(0, 100] m/s",
        );
        range(
            &mut e,
            "contacts.anisotropy",
            self.anisotropy,
            0.0,
            0.99,
            false,
            "[0, 0.99]",
        );
        if !(1..=64).contains(&self.samples_per_element) {
            e.push(FieldError::new(
                "contacts.samples_per_element",
                format!("{}: must be in 1..=64", self.samples_per_element),
            ));
        }
        match self.friction {
            Friction::None => {}
            Friction::Viscous {
                coefficient,
                slip_speed,
            } => {
                range(
                    &mut e,
                    "contacts.friction_coefficient",
                    coefficient,
                    0.0,
                    10.0,
                    false,
                    "[0, 10]",
                );
                range(
                    &mut e,
                    "contacts.slip_speed",
                    slip_speed,
                    0.0,
                    100.0,
                    true,
                    "(0, 100] m/s",
                );
            }
            Friction::Coulomb {
                static_coefficient,
                kinetic_coefficient,
                stiffness_ratio,
            } => {
                range(
                    &mut e,
                    "contacts.friction_coefficient",
                    static_coefficient,
                    0.0,
                    10.0,
                    false,
                    "[0, 10]",
                );
                if !(kinetic_coefficient.is_finite()
                    && kinetic_coefficient >= 0.0
                    && kinetic_coefficient <= static_coefficient)
                {
                    e.push(FieldError::new(
                        "contacts.kinetic_friction_coefficient",
                        format!("{kinetic_coefficient}: must be in [0, friction_coefficient]"),
                    ));
                }
                range(
                    &mut e,
                    "contacts.tangential_stiffness_ratio",
                    stiffness_ratio,
                    0.0,
                    100.0,
                    true,
                    "(0, 100]",
                );
            }
        }
        if let Some(h) = &self.hair_hair {
            range(
                &mut e,
                "contacts.hair_hair.radius",
                h.radius,
                0.0,
                0.1,
                true,
                "(0, 0.1] m",
            );
            if let Some(k) = h.stiffness {
                range(
                    &mut e,
                    "contacts.hair_hair.stiffness",
                    k,
                    0.0,
                    1e9,
                    true,
                    "(0, 1e9] N/m²",
                );
            }
            range(
                &mut e,
                "contacts.hair_hair.damping_ratio",
                h.damping_ratio,
                0.0,
                10.0,
                false,
                "[0, 10]",
            );
            if !(1..=1000).contains(&h.search_every) {
                e.push(FieldError::new(
                    "contacts.hair_hair.search_every",
                    format!("{}: must be in 1..=1000", h.search_every),
                ));
            }
            if let Some(x) = h.split_depth {
                range(
                    &mut e,
                    "contacts.hair_hair.split_depth",
                    x,
                    0.0,
                    1.0,
                    true,
                    "(0, 1]",
                );
            }
            if let Some(x) = h.self_exclusion {
                if !(x.is_finite() && x >= 2.0 * h.radius && x <= 10.0) {
                    e.push(FieldError::new(
                        "contacts.hair_hair.self_exclusion",
                        format!(
                            "{x}: must be in [2 radius, 10] m = [{}, 10] (within 2 radii of arc length, neighbouring points of a straight strand touch)",
                            2.0 * h.radius
                        ),
                    ));
                }
            }
            if let Some(f) = h.friction {
                range(
                    &mut e,
                    "contacts.hair_hair.friction_coefficient",
                    f.static_coefficient,
                    0.0,
                    10.0,
                    false,
                    "[0, 10]",
                );
                if !(f.kinetic_coefficient.is_finite()
                    && f.kinetic_coefficient >= 0.0
                    && f.kinetic_coefficient <= f.static_coefficient)
                {
                    e.push(FieldError::new(
                        "contacts.hair_hair.kinetic_friction_coefficient",
                        format!(
                            "{}: must be in [0, friction_coefficient]",
                            f.kinetic_coefficient
                        ),
                    ));
                }
                range(
                    &mut e,
                    "contacts.hair_hair.tangential_stiffness_ratio",
                    f.stiffness_ratio,
                    0.0,
                    100.0,
                    true,
                    "(0, 100]",
                );
            }
        }
        e
    }

    /// The depth beyond which the normal force stops growing, m.
    pub fn max_depth(&self) -> f64 {
        self.max_depth.unwrap_or(self.radius)
    }

    /// Whether strands touch the body named `name` (every body when `bodies` is `None`).
    pub fn touches(&self, name: &str) -> bool {
        self.bodies
            .as_ref()
            .is_none_or(|names| names.iter().any(|n| n == name))
    }

    /// The depth increase in one step beyond which the step is split, m.
    pub fn split_depth(&self) -> f64 {
        self.split_depth.unwrap_or(self.radius)
    }

    /// The normal penalty stiffness for a strand of mass per length `rho_s`, N/m².
    pub fn stiffness_for(&self, rho_s: f64) -> f64 {
        self.stiffness
            .unwrap_or(DEFAULT_STIFFNESS_FACTOR * rho_s * STANDARD_GRAVITY / self.radius)
    }

    /// The resolved parameters of these contacts for a strand of mass per length `rho_s`:
    /// the damping `c = 2 ζ √(k ρS)` of the penalty's stiffness k.
    pub fn params(&self, rho_s: f64) -> ContactParams {
        let k = self.stiffness_for(rho_s);
        ContactParams {
            radius: self.radius,
            stiffness: k,
            damping: 2.0 * self.damping_ratio * (k * rho_s).sqrt(),
            max_depth: self.max_depth(),
            split_depth: self.split_depth(),
            depenetration_speed: self.depenetration_speed,
            friction: self.friction,
            anisotropy: self.anisotropy,
        }
    }
}

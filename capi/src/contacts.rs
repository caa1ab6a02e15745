//! A batch's contacts with its colliders: the C description of the contact law
//! ([`ShContactParams`], checked into [`ContactSettings`]), what each strand keeps from
//! step to step ([`StrandContacts`]: its samples, Coulomb anchors, allowances and clock)
//! and what a worker reuses from strand to strand ([`ContactScratch`]), from which the
//! fixed-N step's contacts (`superhelix_kernels::fixed::FixedContacts`) are made for
//! each strand's step, as the runtime's embedded engine makes them.

use crate::colliders::{Colliders, StepSet};
use core::ffi::c_int;
use nalgebra::Vector3;
use superhelix_generated::ClosedForm;
use superhelix_kernels::contact::predicted::{
    Candidate, PoolSizes, PredictedArrays, PredictedScalars,
};
use superhelix_kernels::contact::{sample_points, Anchor, ContactParams, Friction};
use superhelix_kernels::fixed::{
    ContactScalars, ContactStore, FixedContacts, FixedParams, STANDARD_GRAVITY,
};
use superhelix_kernels::head::HeadState;
use superhelix_kernels::moments::EndDerivatives;
use superhelix_kernels::pose::Pose;

type V3 = Vector3<f64>;

/// [`ShContactParams::friction`]: no friction.
pub const SH_FRICTION_NONE: c_int = 0;
/// [`ShContactParams::friction`]: the paper's viscous friction (section 4.2), scaled by
/// the normal force: `f_t = −μ(θ) f_n v_t / v_s`.
pub const SH_FRICTION_VISCOUS: c_int = 1;
/// [`ShContactParams::friction`]: Coulomb friction with sticking: each contact point is
/// held to an anchor on the collider by a tangential spring while `|f_t| ≤ μ_s(θ) f_n`,
/// and slides with `|f_t| = μ_k(θ) f_n` beyond.
pub const SH_FRICTION_COULOMB: c_int = 2;

/// Default penalty stiffness over a strand's weight per length and the contact radius
/// (`k = 1e4 ρS g₀ / r` when [`ShContactParams::stiffness`] is 0), as a scene's
/// `[contacts]`.
pub const SH_DEFAULT_STIFFNESS_FACTOR: f64 = 1e4;

/// The contacts of a batch's strands with its colliders: a scene's `[contacts]` table
/// (docs/scene-format.md), field for field. `sh_contact_params_default` fills the
/// scene's defaults.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShContactParams {
    /// Contact radius r of a strand, m, in (0, 0.1]: a centreline point touches a
    /// collider closer than this to its surface.
    pub radius: f64,
    /// Normal penalty stiffness k, N/m² (force per metre of strand per metre of depth),
    /// in (0, 1e9]; 0: `SH_DEFAULT_STIFFNESS_FACTOR · ρS g₀ / r` for each strand (ρS its
    /// mass per length, g₀ = 9.80665 m/s²).
    pub stiffness: f64,
    /// Damping ratio ζ of the normal response, in [0, 10]: `c = 2 ζ √(k ρS)` per metre.
    pub damping_ratio: f64,
    /// `SH_FRICTION_NONE`, `SH_FRICTION_VISCOUS` or `SH_FRICTION_COULOMB`.
    pub friction: c_int,
    /// μ (viscous) or μ_s (Coulomb), in [0, 10].
    pub friction_coefficient: f64,
    /// Coulomb: μ_k, in [0, friction_coefficient].
    pub kinetic_friction_coefficient: f64,
    /// Viscous: the slip speed v_s at which the force is Coulomb's, m/s, in (0, 100].
    pub slip_speed: f64,
    /// Coulomb: the tangential spring's stiffness over k, in (0, 100].
    pub tangential_stiffness_ratio: f64,
    /// Anisotropy α of the friction, in [0, 0.99]: `μ(θ) = μ (1 + α cos θ)`, θ between
    /// the fibre's root-to-tip tangent and its sliding direction.
    pub anisotropy: f64,
    /// Contact points per element, 1 to 64.
    pub samples_per_element: usize,
    /// Nonzero: a contact point at the tip (the last part takes the two-point rule that
    /// includes the tip instead of its midpoint), as a scene's default.
    pub tip_sample: c_int,
    /// Nonzero: the contacts that start within a step are predicted from the step's own
    /// solution and resolved in it (a scene's `predict = true`); zero: caught by the
    /// step's depth check alone (a step taking a point deeper than `split_depth` is
    /// split).
    pub predict: c_int,
    /// Depth beyond which the normal force stops growing, m, in (0, 1]; 0: the radius.
    pub max_depth: f64,
    /// A step taking a contact point deeper than this beyond its depth at the step's
    /// start is split, m, in (0, 1]; 0: the radius.
    pub split_depth: f64,
    /// Speed at which a point that starts inside a collider is let out, m/s, in
    /// (0, 100].
    pub depenetration_speed: f64,
}

/// The scene's `[contacts]` defaults (docs/scene-format.md).
pub(crate) const DEFAULT_PARAMS: ShContactParams = ShContactParams {
    radius: 1e-3,
    stiffness: 0.0,
    damping_ratio: 0.5,
    friction: SH_FRICTION_VISCOUS,
    friction_coefficient: 0.3,
    kinetic_friction_coefficient: 0.3,
    slip_speed: 0.05,
    tangential_stiffness_ratio: 1.0,
    anisotropy: 0.3,
    samples_per_element: 4,
    tip_sample: 1,
    predict: 1,
    max_depth: 0.0,
    split_depth: 0.0,
    depenetration_speed: 0.05,
};

/// The contact settings of a batch, checked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ContactSettings {
    pub radius: f64,
    pub stiffness: Option<f64>,
    pub damping_ratio: f64,
    pub max_depth: f64,
    pub split_depth: f64,
    pub depenetration_speed: f64,
    pub friction: Friction,
    pub anisotropy: f64,
    pub samples_per_element: usize,
    pub tip_sample: bool,
    pub predict: bool,
}

fn within(x: f64, lo: f64, hi: f64, lo_open: bool, field: &str, text: &str) -> Result<f64, String> {
    let ok = x.is_finite() && (if lo_open { x > lo } else { x >= lo }) && x <= hi;
    if ok {
        Ok(x)
    } else {
        Err(format!("contacts.{field}: {x} must be in {text}"))
    }
}

impl ContactSettings {
    /// The settings of `p`, checked: a message naming the first field out of range.
    pub fn new(p: &ShContactParams) -> Result<Self, String> {
        let radius = within(p.radius, 0.0, 0.1, true, "radius", "(0, 0.1] m")?;
        let stiffness = match p.stiffness {
            0.0 => None,
            k => Some(within(
                k,
                0.0,
                1e9,
                true,
                "stiffness",
                "(0, 1e9] N/m² (or 0: the default)",
            )?),
        };
        let damping_ratio = within(
            p.damping_ratio,
            0.0,
            10.0,
            false,
            "damping_ratio",
            "[0, 10]",
        )?;
        let depth = |x: f64, field: &str| match x {
            0.0 => Ok(radius),
            x => within(x, 0.0, 1.0, true, field, "(0, 1] m (or 0: the radius)"),
        };
        let max_depth = depth(p.max_depth, "max_depth")?;
        let split_depth = depth(p.split_depth, "split_depth")?;
        let depenetration_speed = within(
            p.depenetration_speed,
            0.0,
            100.0,
            true,
            "depenetration_speed",
            "(0, 100] m/s",
        )?;
        let anisotropy = within(p.anisotropy, 0.0, 0.99, false, "anisotropy", "[0, 0.99]")?;
        let mu = |p: &ShContactParams| {
            within(
                p.friction_coefficient,
                0.0,
                10.0,
                false,
                "friction_coefficient",
                "[0, 10]",
            )
        };
        let friction = match p.friction {
            SH_FRICTION_NONE => Friction::None,
            SH_FRICTION_VISCOUS => Friction::Viscous {
                coefficient: mu(p)?,
                slip_speed: within(p.slip_speed, 0.0, 100.0, true, "slip_speed", "(0, 100] m/s")?,
            },
            SH_FRICTION_COULOMB => {
                let static_coefficient = mu(p)?;
                let kinetic = p.kinetic_friction_coefficient;
                if !(kinetic.is_finite() && kinetic >= 0.0 && kinetic <= static_coefficient) {
                    return Err(format!(
                        "contacts.kinetic_friction_coefficient: {kinetic} must be in [0, friction_coefficient] = [0, {static_coefficient}]"
                    ));
                }
                Friction::Coulomb {
                    static_coefficient,
                    kinetic_coefficient: kinetic,
                    stiffness_ratio: within(
                        p.tangential_stiffness_ratio,
                        0.0,
                        100.0,
                        true,
                        "tangential_stiffness_ratio",
                        "(0, 100]",
                    )?,
                }
            }
            f => {
                return Err(format!(
                    "contacts.friction: {f} is not one of SH_FRICTION_NONE (0), SH_FRICTION_VISCOUS (1), SH_FRICTION_COULOMB (2)"
                ))
            }
        };
        if !(1..=64).contains(&p.samples_per_element) {
            return Err(format!(
                "contacts.samples_per_element: {} must be in 1..=64",
                p.samples_per_element
            ));
        }
        Ok(ContactSettings {
            radius,
            stiffness,
            damping_ratio,
            max_depth,
            split_depth,
            depenetration_speed,
            friction,
            anisotropy,
            samples_per_element: p.samples_per_element,
            tip_sample: p.tip_sample != 0,
            predict: p.predict != 0,
        })
    }

    /// The law's parameters for a strand of mass per length `rho_s` (kg/m): the
    /// runtime's `ContactConfig::params`.
    pub fn params(&self, rho_s: f64) -> ContactParams {
        let k = self
            .stiffness
            .unwrap_or(SH_DEFAULT_STIFFNESS_FACTOR * rho_s * STANDARD_GRAVITY / self.radius);
        ContactParams {
            radius: self.radius,
            stiffness: k,
            damping: 2.0 * self.damping_ratio * (k * rho_s).sqrt(),
            max_depth: self.max_depth,
            split_depth: self.split_depth,
            depenetration_speed: self.depenetration_speed,
            friction: self.friction,
            anisotropy: self.anisotropy,
        }
    }
}

/// What one strand's contacts keep from step to step: the law, the samples (arc length,
/// weight), per sample its Coulomb anchor and allowance, the scalars, and the strand's
/// clock (the time its contacts' bookkeeping runs on, s).
#[derive(Debug, Clone)]
pub(crate) struct StrandContacts {
    pub params: ContactParams,
    pub samples: Vec<(f64, f64)>,
    pub anchors: Vec<Option<Anchor>>,
    pub allowance: Vec<f64>,
    pub scalars: ContactScalars,
    pub predict: bool,
    pub time: f64,
}

impl StrandContacts {
    /// The contacts of a strand of element `lengths` and mass per length `rho_s` under
    /// `settings`, not started (the first step starts them: root zone, allowances,
    /// anchors), at time 0.
    pub fn new(settings: &ContactSettings, lengths: &[f64], rho_s: f64) -> Self {
        let mut samples = Vec::with_capacity(lengths.len() * settings.samples_per_element + 2);
        sample_points(
            lengths,
            settings.samples_per_element,
            [false, settings.tip_sample],
            0.0,
            |s, w| samples.push((s, w)),
        );
        let n = samples.len();
        StrandContacts {
            params: settings.params(rho_s),
            samples,
            anchors: vec![None; n],
            allowance: vec![0.0; n],
            scalars: ContactScalars::default(),
            predict: settings.predict,
            time: 0.0,
        }
    }

    /// Forget the anchors, allowances and root zone: the next step starts the contacts
    /// afresh from the strand's state then (after a state set from outside).
    pub fn restart(&mut self) {
        self.anchors.iter_mut().for_each(|a| *a = None);
        self.allowance.iter_mut().for_each(|a| *a = 0.0);
        self.scalars = ContactScalars::default();
    }

    /// The fixed-N step's contacts of the strand of `params` over the colliders `set`,
    /// on these buffers and a worker's `scratch` (sized by [`ContactScratch::fit`]).
    pub fn hooks<'a, const N: usize, const D: usize>(
        &'a mut self,
        params: &FixedParams<N, D>,
        lengths: &'a [f64],
        set: &'a mut StepSet<'a>,
        scratch: &'a mut ContactScratchParts,
    ) -> FixedContacts<'a, StepSet<'a>, ClosedForm> {
        let m = self.samples.len();
        *scratch.chain_valid = 0;
        // the poses in the scratch were another strand's
        *scratch.poses_valid = false;
        let store = ContactStore {
            anchors: &mut self.anchors,
            allowance: &mut self.allowance,
            start_depth: &mut scratch.start_depth[..m],
            poses: &mut scratch.poses[..m],
            poses_q: &mut scratch.poses_q[..D],
            poses_valid: scratch.poses_valid,
            jac: &mut scratch.jac[..D],
            aj: &mut scratch.aj[..D],
            ends: &mut scratch.ends[..N + 1],
            end_derivs: &mut scratch.end_derivs[..N],
            chain_q: &mut scratch.chain_q[..D],
            chain_valid: scratch.chain_valid,
            scalars: &mut self.scalars,
        };
        let contacts = FixedContacts::new(
            params,
            lengths,
            set,
            &ClosedForm,
            &self.params,
            &self.samples,
            store,
        );
        if !self.predict {
            return contacts;
        }
        match PredictedArrays::carve(
            m,
            D,
            scratch.predicted,
            scratch.floats,
            scratch.flags,
            scratch.indices,
            scratch.candidates,
            scratch.points,
        ) {
            Some(arrays) => contacts.with_prediction(arrays),
            // (the scratch is fitted before: never reached)
            None => contacts,
        }
    }
}

/// The scratch of the contacts of the strands a worker steps, kept from step to step
/// (grown, never shrunk, to the most samples and colliders met): what the runtime's
/// embedded engine keeps per worker.
#[derive(Debug, Default)]
pub(crate) struct ContactScratch {
    start_depth: Vec<f64>,
    poses: Vec<(V3, V3)>,
    /// The q of `poses` and whether they are current (cleared for each strand).
    poses_q: Vec<f64>,
    poses_valid: bool,
    jac: Vec<V3>,
    aj: Vec<V3>,
    ends: Vec<Pose>,
    end_derivs: Vec<EndDerivatives>,
    chain_q: Vec<f64>,
    chain_valid: usize,
    predicted: PredictedScalars,
    floats: Vec<f64>,
    flags: Vec<bool>,
    indices: Vec<usize>,
    candidates: Vec<Candidate>,
    points: Vec<V3>,
    /// The colliders' frames placed in time, one per collider.
    pub frames: Vec<HeadState>,
    /// A strand's anchors, allowances and scalars before its step (a failed step puts
    /// them back).
    pub kept_anchors: Vec<Option<Anchor>>,
    pub kept_allowance: Vec<f64>,
}

/// A [`ContactScratch`] borrowed apart from its colliders' frames.
pub(crate) struct ContactScratchParts<'a> {
    start_depth: &'a mut [f64],
    poses: &'a mut [(V3, V3)],
    poses_q: &'a mut [f64],
    poses_valid: &'a mut bool,
    jac: &'a mut [V3],
    aj: &'a mut [V3],
    ends: &'a mut [Pose],
    end_derivs: &'a mut [EndDerivatives],
    chain_q: &'a mut [f64],
    chain_valid: &'a mut usize,
    predicted: &'a mut PredictedScalars,
    floats: &'a mut [f64],
    flags: &'a mut [bool],
    indices: &'a mut [usize],
    candidates: &'a mut [Candidate],
    points: &'a mut [V3],
}

fn grow<T: Clone>(v: &mut Vec<T>, n: usize, x: T) {
    if v.len() < n {
        v.resize(n, x);
    }
}

impl ContactScratch {
    /// Room for strands of `elements` elements with `samples` samples, and `colliders`
    /// colliders (allocates only when more is needed than before).
    pub fn fit(&mut self, elements: usize, samples: usize, colliders: usize) {
        let dofs = 3 * elements;
        let zero = V3::zeros();
        grow(&mut self.start_depth, samples, 0.0);
        grow(&mut self.poses, samples, (zero, zero));
        grow(&mut self.poses_q, dofs, 0.0);
        grow(&mut self.jac, dofs, zero);
        grow(&mut self.aj, dofs, zero);
        grow(&mut self.ends, elements + 1, Pose::default());
        grow(&mut self.end_derivs, elements, EndDerivatives::default());
        grow(&mut self.chain_q, dofs, f64::NAN);
        let pools = PoolSizes::of(samples, dofs);
        grow(&mut self.floats, pools.floats, 0.0);
        grow(&mut self.flags, pools.flags, false);
        grow(&mut self.indices, pools.indices, 0);
        grow(&mut self.candidates, pools.candidates, Candidate::NONE);
        grow(&mut self.points, pools.points, zero);
        grow(&mut self.frames, colliders, HeadState::rest());
        grow(&mut self.kept_anchors, samples, None);
        grow(&mut self.kept_allowance, samples, 0.0);
    }

    /// The frames of the colliders and the rest, borrowed apart.
    pub fn parts(&mut self) -> (&mut [HeadState], ContactScratchParts<'_>) {
        (
            &mut self.frames,
            ContactScratchParts {
                start_depth: &mut self.start_depth,
                poses: &mut self.poses,
                poses_q: &mut self.poses_q,
                poses_valid: &mut self.poses_valid,
                jac: &mut self.jac,
                aj: &mut self.aj,
                ends: &mut self.ends,
                end_derivs: &mut self.end_derivs,
                chain_q: &mut self.chain_q,
                chain_valid: &mut self.chain_valid,
                predicted: &mut self.predicted,
                floats: &mut self.floats,
                flags: &mut self.flags,
                indices: &mut self.indices,
                candidates: &mut self.candidates,
                points: &mut self.points,
            },
        )
    }

    /// Bytes this scratch holds.
    pub fn bytes(&self) -> usize {
        use core::mem::size_of;
        self.start_depth.capacity() * size_of::<f64>()
            + (self.poses.capacity()) * size_of::<(V3, V3)>()
            + (self.jac.capacity() + self.aj.capacity() + self.points.capacity()) * size_of::<V3>()
            + self.ends.capacity() * size_of::<Pose>()
            + self.end_derivs.capacity() * size_of::<EndDerivatives>()
            + (self.chain_q.capacity()
                + self.poses_q.capacity()
                + self.floats.capacity()
                + self.kept_allowance.capacity())
                * size_of::<f64>()
            + self.flags.capacity()
            + self.indices.capacity() * size_of::<usize>()
            + self.candidates.capacity() * size_of::<Candidate>()
            + self.frames.capacity() * size_of::<HeadState>()
            + self.kept_anchors.capacity() * size_of::<Option<Anchor>>()
    }
}

/// The colliders of the batch at the end of a strand's last step, for the
/// deepest-point sweep after it.
pub(crate) fn deepest<const N: usize, const D: usize, const B: usize>(
    strand: &superhelix_kernels::fixed::FixedStrand<N, D, B>,
    contacts: &mut StrandContacts,
    colliders: &Colliders,
    head: &HeadState,
    scratch: &mut ContactScratch,
) -> f64 {
    use superhelix_kernels::fixed::ContactHooks;
    scratch.fit(N, contacts.samples.len(), colliders.items.len());
    let (frames, mut parts) = scratch.parts();
    let t = contacts.time;
    let Some(mut set) = StepSet::at_end(&colliders.items, frames, t) else {
        // (the scratch is fitted to the colliders above: never reached)
        return 0.0;
    };
    let lengths = strand.params.lengths;
    let mut hooks = contacts.hooks(&strand.params, &lengths, &mut set, &mut parts);
    ContactHooks::<f64>::deepest(&mut hooks, &strand.q, t, head)
}

//! The a-posteriori energy-balance test of implicit steps (issue #4, README "Hard cases
//! (stress)", "What the integrator checks after a step").
//!
//! Written in the head frame, the strand's energy `E = T + U + V` (T kinetic relative to
//! the head, U elastic, V the potential of the uniform part c0 of the body field and of
//! the point loads at the head state of the time) changes under the exact dynamics as
//!
//! ```text
//! dE/dt = q̇ᵀ ∫ Jᵀ C1 y ds − ċ0 · ∫ y ds − Σ ḟ_l · y_l − q̇ᵀ Γ q̇ − ν ∫ |ẏ|² ds
//! ```
//!
//! (the Coriolis force is normal to ẏ and does no work; ḟ_l = −ω × f_l is the rate of a
//! point load in head coordinates, f_l = Rᵀ f_world). When the head moves uniformly over a step (no
//! rotation, constant velocity: [`HeadMotion::uniform_over`]) C1 = 0 and c0, f_l are
//! constant, so **E cannot increase**: friction and drag only dissipate. Otherwise the
//! first three terms are the work W the head's motion does on the strand, estimated by the
//! trapezoidal rule over the step.

use crate::effects::{body_field, GlobalEffects};
use crate::head_motion::{HeadMotion, HeadState};
use crate::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use crate::strand::Strand;
use nalgebra::Vector3;

/// The energy of one state (q, q̇) at one time, with what the balance of a step needs.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StateEnergy {
    /// Time of the state, s.
    pub time: f64,
    /// T = ½ q̇ᵀ M(q) q̇, J.
    pub kinetic: f64,
    /// U = ½ Σ K (q − q_n)², J.
    pub elastic: f64,
    /// V = −c0 · ∫ y ds − Σ f_l · y_l (head coordinates, at the head state of `time`), J.
    pub potential: f64,
    /// ∫ y ds, m².
    pub moment: Vector3<f64>,
    /// c0 (N/m) of the head state at `time`.
    pub uniform: Vector3<f64>,
    /// Power of the fictitious forces linear in y: q̇ᵀ ∫ Jᵀ C1 y ds, W.
    pub power: f64,
    /// Σ f_l · y_l of the point loads, J (the part of −V they make).
    pub load_moment: f64,
    /// −Σ ḟ_l · y_l = Σ (ω × f_l) · y_l: the rate of V through the point loads' rotation
    /// at fixed q, W.
    pub load_rate: f64,
    /// Scale of the energy that can change hands: T + U + |c0| L², J.
    pub scale: f64,
}

impl StateEnergy {
    /// E = T + U + V, J.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.potential
    }

    /// A bound on the round-off of [`StateEnergy::total`]: its parts' magnitudes times
    /// [`ROUNDOFF`].
    pub fn roundoff(&self) -> f64 {
        ROUNDOFF
            * (self.kinetic.abs()
                + self.elastic.abs()
                + self.potential.abs()
                + self.load_moment.abs()
                + self.scale)
    }
}

/// Relative round-off allowed in an energy: E is a sum of O(3N²) products, each good to
/// 1e-16, and is evaluated to ~1e-14 of its parts (`stress`, energy of a still head two
/// ways); 1e-12 leaves a margin of 100.
pub const ROUNDOFF: f64 = 1e-12;

/// Measure the energy of (q, q̇) at time `t` with the head in state `head`: one kernel
/// evaluation of M (and ∫ρS y ds with it); when the head rotates, also of the force, with
/// the body field reduced to its part C1 linear in y, so that `force + b` is the
/// generalized force of C1 and q̇ᵀ(force + b) its power.
#[allow(clippy::too_many_arguments)]
pub fn measure(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    terms: &mut StrandTerms,
    jac: &mut [Vector3<f64>],
    stiffness: &[f64],
    effects: &GlobalEffects,
    head: &HeadState,
    t: f64,
    q: &[f64],
    v: &[f64],
) -> StateEnergy {
    let rho_s = strand.material.mass_per_length;
    let full = body_field(effects, head, rho_s, strand.air_drag);
    let field = BodyField {
        uniform: Vector3::zeros(),
        linear: full.linear,
        velocity: nalgebra::Matrix3::zeros(),
    };
    kernel.evaluate(
        &EvalInput {
            q,
            v,
            field,
            // M and ∫ρS y ds; the force only for the power of C1 (a rotating head)
            terms: Terms {
                mass: true,
                force: field.has_linear(),
                ..Default::default()
            },
        },
        terms,
    );
    let n = q.len();
    let m = &terms.mass;
    let mut kinetic = 0.0;
    for j in 0..n {
        let mut mv = 0.0;
        for i in 0..n {
            mv += m[(i, j)] * v[i];
        }
        kinetic += 0.5 * mv * v[j];
    }
    let elastic: f64 = (0..n)
        .map(|i| 0.5 * stiffness[i] * (q[i] - strand.natural[i]).powi(2))
        .sum();
    let power = if field.has_linear() {
        (0..n)
            .map(|i| v[i] * (terms.force[i] + terms.velocity_term[i]))
            .sum()
    } else {
        0.0
    };
    let moment = terms.first_moment / rho_s;
    let mut load_moment = 0.0;
    let mut load_rate = 0.0;
    if !strand.point_loads.is_empty() {
        let rt = head.rotation.transpose();
        // d(Rᵀ f)/dt = −ω × Rᵀ f (Ṙ = R[ω]×)
        let w = head.omega;
        for load in &strand.point_loads {
            let f = rt * load.force;
            let y = kernel.point(q, load.s, jac, None);
            load_moment += f.dot(&y);
            load_rate += w.cross(&f).dot(&y);
        }
    }
    let length = strand.geometry.length();
    StateEnergy {
        time: t,
        kinetic,
        elastic,
        potential: -full.uniform.dot(&moment) - load_moment,
        moment,
        uniform: full.uniform,
        power,
        load_moment,
        load_rate,
        scale: kinetic + elastic + full.uniform.norm() * length * length,
    }
}

/// The energy balance of one step from `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    /// E(end) − E(start), J.
    pub change: f64,
    /// The head's work over the step (trapezoidal estimate; 0 when the head moves
    /// uniformly), J.
    pub work: f64,
    /// What the change may exceed `work` by: round-off when the head moves uniformly,
    /// plus the allowance for the error of the work estimate otherwise, J.
    pub allowance: f64,
    /// The head moved uniformly over the step: the balance is exact.
    pub inertial: bool,
}

impl Balance {
    /// Energy created beyond what the head put in and the allowance, J (≤ 0: none).
    pub fn excess(&self) -> f64 {
        self.change - self.work - self.allowance
    }
}

/// Relative allowance for the error of the trapezoidal estimate of the head's work over a
/// step (of the magnitudes of its terms): the estimate is exact for work linear in time
/// and off by O(h³) otherwise, which at the paper's step and a 5 Hz shake (the head turns
/// ~1 rad per step) is a sizeable fraction of it. The test is meant to catch steps that
/// create energy out of all proportion to the head's work (an unstable step multiplies
/// the kinetic energy), not to measure the work.
pub const WORK_ALLOWANCE: f64 = 1.0;

/// The balance of a step; `inertial` when the head moves uniformly over it.
pub fn balance(start: &StateEnergy, end: &StateEnergy, inertial: bool) -> Balance {
    let change = end.total() - start.total();
    let roundoff = start.roundoff() + end.roundoff();
    if inertial {
        return Balance {
            change,
            work: 0.0,
            allowance: roundoff,
            inertial,
        };
    }
    let h = end.time - start.time;
    let powers = [
        0.5 * h * start.power,
        0.5 * h * end.power,
        0.5 * h * start.load_rate,
        0.5 * h * end.load_rate,
        // −ċ0 · ∫y ds by the trapezoidal rule: −Δc0 · (mean ∫y ds)
        -(end.uniform - start.uniform).dot(&(0.5 * (start.moment + end.moment))),
    ];
    let work: f64 = powers.iter().sum();
    let magnitude: f64 = powers.iter().map(|p| p.abs()).sum();
    Balance {
        change,
        work,
        allowance: roundoff + WORK_ALLOWANCE * magnitude,
        inertial,
    }
}

/// Whether the head moves uniformly (constant velocity, no rotation) over [t0, t1].
pub fn head_uniform(head: &HeadMotion, t0: f64, t1: f64) -> bool {
    head.uniform_over(t0, t1)
}

//! The a-posteriori energy-balance test of implicit steps (issue #4; README "Time
//! stepping" and "Hard cases (stress)").
//!
//! Written in the head frame, the strand's energy `E = T + U + V` (T kinetic relative to
//! the head, U elastic, V the potential of the uniform part c0 of the body field and of
//! the point loads f_l, at the head state of the time) changes under the exact dynamics
//! as
//!
//! ```text
//! dE/dt = q̇ᵀ ∫ Jᵀ C1 y ds − ċ0 · ∫ y ds − Σ ḟ_l · y_l − D,
//! D = q̇ᵀ Γ q̇ + ν ∫ |ẏ|² ds ≥ 0
//! ```
//!
//! (the Coriolis force is normal to ẏ and does no work; ḟ_l = −ω × f_l is the rate of a
//! point load in head coordinates, f_l = Rᵀ f_world). The first three terms are the work
//! W the head's motion does on the strand, D what internal friction and air drag
//! dissipate.
//!
//! - When the head moves uniformly over a step (no rotation, constant velocity:
//!   [`crate::HeadMotion::uniform_over`]), C1 = 0 and c0, f_l are constant: W = 0, and
//!   from the start of such a phase E can only decrease, by at least ∫ D. The bound of a
//!   step's end is then its *ceiling*: the energy at the start of the phase less the
//!   dissipation estimated since (trapezoidal rule on D), or the energy at the start of
//!   the step when that is higher. Without friction and drag the ceiling is the energy at
//!   the start of the phase: a step may give back energy that earlier steps dissipated
//!   numerically, never more; the step-to-step bound alone would ratchet the energy down
//!   (an implicit Euler step in a fast, large motion errs by O(h²) in E with either
//!   sign, and only the positive errors would be removed).
//! - Otherwise the bound is E(start) + W, W by the trapezoidal rule over the step, with an
//!   allowance for the error of that estimate ([`WORK_ALLOWANCE`]).

use super::system::StrandSystem;
use crate::forces::effects::body_field;
use crate::forces::head_motion::HeadState;
use crate::kernels::kernel::{BodyField, EvalInput, Terms};
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
    /// A bound on the dissipation rate D: q̇ᵀ Γ q̇ + (2ν/ρS) T (ν ∫|ẏ|² with the rotary
    /// part of T counted too), W.
    pub dissipation: f64,
    /// The most energy the state may have, unless it is below E (see the module
    /// documentation), J; E itself after a step with a moving head.
    pub ceiling: f64,
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

    /// Scale the velocities by λ (T by λ², the power and the dissipation with them).
    pub fn scale_velocities(&mut self, lambda: f64) {
        let kinetic = lambda * lambda * self.kinetic;
        self.scale += kinetic - self.kinetic;
        self.kinetic = kinetic;
        self.power *= lambda;
        self.dissipation *= lambda * lambda;
    }
}

/// Relative round-off allowed in an energy: E is a sum of O(3N²) products, each good to
/// 1e-16, and is evaluated to ~1e-14 of its parts (`stress`, the energy of a still head two
/// ways); 1e-12 leaves a margin of 100.
pub const ROUNDOFF: f64 = 1e-12;

/// Measure the energy of (q, q̇) at time `t` with the head in state `head`: one kernel
/// evaluation of M (and ∫ρS y ds with it); when the head rotates, also of the force, with
/// the body field reduced to its part C1 linear in y, so that `force + b` is the
/// generalized force of C1 and q̇ᵀ(force + b) its power. The ceiling is E.
pub fn measure(
    system: &mut StrandSystem,
    head: &HeadState,
    t: f64,
    q: &[f64],
    v: &[f64],
) -> StateEnergy {
    let StrandSystem {
        strand,
        kernel,
        workspace,
        context,
    } = system;
    let kernel = kernel.as_mut();
    let (terms, jac) = (&mut workspace.terms, &mut workspace.jac);
    let (stiffness, friction) = (&workspace.stiffness, &workspace.friction);
    let effects = &context.effects;
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
    let dissipation = (0..n).map(|i| friction[i] * v[i] * v[i]).sum::<f64>()
        + 2.0 * strand.air_drag / rho_s * kinetic;
    let length = strand.geometry.length();
    let potential = -full.uniform.dot(&moment) - load_moment;
    StateEnergy {
        time: t,
        kinetic,
        elastic,
        potential,
        moment,
        uniform: full.uniform,
        power,
        load_moment,
        load_rate,
        dissipation,
        ceiling: kinetic + elastic + potential,
        scale: kinetic + elastic + full.uniform.norm() * length * length,
    }
}

/// The energy balance of one step from `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Balance {
    /// The most energy the end state may have before the allowance, J: with the head
    /// moving uniformly, the larger of E(start) and the start's ceiling less the estimated
    /// dissipation over the step (which is also the end's ceiling); otherwise E(start)
    /// plus the head's work (trapezoidal estimate).
    pub bound: f64,
    /// What E(end) may exceed `bound` by: round-off, plus the allowance for the error of
    /// the work estimate when the head does not move uniformly, J.
    pub allowance: f64,
    /// The head moved uniformly over the step.
    pub inertial: bool,
    /// E(end) − bound − allowance, J (≤ 0: the step is balanced).
    pub excess: f64,
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
    let roundoff = start.roundoff() + end.roundoff();
    let h = end.time - start.time;
    let (bound, allowance) = if inertial {
        let dissipated = 0.5 * h * (start.dissipation + end.dissipation);
        ((start.ceiling - dissipated).max(start.total()), roundoff)
    } else {
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
        (start.total() + work, roundoff + WORK_ALLOWANCE * magnitude)
    };
    Balance {
        bound,
        allowance,
        inertial,
        excess: end.total() - bound - allowance,
    }
}

/// The ceiling of a step's end state, once accepted (its velocities limited if needed):
/// with the head moving uniformly, the start's ceiling less the estimated dissipation over
/// the step (not raised to the end's energy when that is higher, within round-off or by
/// the fallback to E(start): the next step's bound takes the larger of the two anyway, and
/// a ceiling raised by round-off step after step would creep); its energy otherwise.
pub fn end_ceiling(start: &StateEnergy, end: &StateEnergy, inertial: bool) -> f64 {
    if inertial {
        let h = end.time - start.time;
        start.ceiling - 0.5 * h * (start.dissipation + end.dissipation)
    } else {
        end.total()
    }
}

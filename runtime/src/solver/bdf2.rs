//! The variable-step two-step BDF (BDF2), linearised once per step on the linearly
//! implicit Euler step's matrix.

use super::predicted_contacts::resolve;
use super::stats::StepStats;
use super::system::{HeadInterval, StrandState, StrandSystem, StrandWorkspace};
use crate::config::IntegratorKind;
use crate::kernels::kernel::Terms;

/// Largest ratio of a BDF2 step to the step before it; beyond it (after substeps of a
/// quarter of the step or less) the history is not used and a linearly implicit Euler
/// step restarts the scheme. Variable-step BDF2 is zero-stable only for ratios below
/// 1 + √2 (Grigorieff 1983; Hairer, Nørsett & Wanner, *Solving ODEs I*, III.5); a step
/// split once and then resumed has ratio 2.
pub const BDF2_MAX_RATIO: f64 = 2.0;

/// One step of the variable-step two-step BDF (BDF2; Hairer, Nørsett & Wanner, *Solving
/// ODEs I*, section III.5) on the equations of motion (paper eq. 6), `q̇ = v`,
/// `M(q) v̇ = F(q, v)` (F the full force of [`assemble`](super::system::StrandSystem::assemble), including −b), linearised once
/// per step like [`linearly_implicit_euler`](super::linearly_implicit::linearly_implicit_euler) (design page "Time stepping": "implicit
/// midpoint / BDF2 ... are the accuracy/cost variants"). With h the step, h₋ the previous
/// one, ω = h/h₋ and y = (q, v):
///
/// ```text
/// y⁺ − a₁ y + a₂ y₋ = β h f(t + h, y⁺),   a₁ = (1+ω)²/(1+2ω), a₂ = ω²/(1+2ω), β = (1+ω)/(1+2ω)
/// ```
///
/// (4/3, 1/3, 2/3 at a constant step), i.e. with ŷ = a₁ y − a₂ y₋:
/// `q⁺ = q̂ + βh v⁺` and `M(q⁺)(v⁺ − v̂) = βh F(q⁺, v⁺)`. Everything at the new state is
/// linearised about the extrapolation ỹ = y + ω (y − y₋), which is y⁺ + O(h²):
/// M(q⁺) ≈ M̃, F(q⁺, v⁺) ≈ F̃ + b̃ + D_q (q⁺ − q̃) + D_v (v⁺ − ṽ) − ½ B̃ v⁺ (b ≈ ½ B v⁺
/// as in the linearly implicit Euler step), which gives one linear solve with that
/// step's matrix at the step βh, all at (t + h, ỹ):
///
/// ```text
/// (M̃ − βh D_v + (βh/2) B̃ − β²h² D_q) v⁺ = M̃ v̂ + βh (F̃ + b̃ − D_v ṽ + D_q (q̂ − q̃))
/// q⁺ = q̂ + βh v⁺
/// ```
///
/// D_q = H⁻ − K, D_v and B as in [`linearly_implicit_euler`](super::linearly_implicit::linearly_implicit_euler) (the destabilising part of
/// the field stiffness stays explicit). Every term left out of the linearisation (H's
/// positive part and skew part, ∂M/∂q, ∂b/∂q and the q-derivative of the Coriolis and drag
/// forces, the rest of b) is multiplied by y⁺ − ỹ = O(h²), so the step stays second order
/// whatever the Jacobian's error; an equilibrium is a fixed point, as for implicit Euler.
/// What is left out is in effect extrapolated, as by the two-step Adams–Bashforth
/// formula, which tolerates less of it than implicit Euler: on q̈ = −(k − p) q with −k in
/// the matrix the step is stable for −0.33 k < p < k at every h²k/m (implicit Euler:
/// −k < p < k). BDF2 is L-stable: the stiff twist and high bending modes are damped as by
/// implicit Euler, while a resolved oscillation loses |ζ|² ≈ 1 − (ωh)⁴/2 of its energy
/// per step (implicit Euler: 1/(1 + (ωh)²)); its frequency is (1 − (ωh)²/3) times the
/// exact one, as for implicit Euler.
///
/// The mass matrix enters only where the matrix is built (at q̃), never inverted at
/// another state. A one-step Rosenbrock-W scheme (ROS2) on the same matrix does not
/// work here: its second stage must evaluate M⁻¹F at a stage point, and the twist block
/// of M⁻¹ (the inverse of the rotary inertia of nearly straight elements, ~1e6 times
/// the bending block's) makes that stage unstable: exactly (a falling 5 cm fibre
/// blew up at dt = 1/50 s) or to first order (the 20 cm swing at N = 20 blew up at
/// dt = 1/4800 s, its step map having spectral radius 2.0–2.3 at every dt from 1/240 to
/// 1/4800 s where implicit Euler's is 1.003–1.16).
///
/// The cost of a step is that of a linearly implicit Euler step (one full assembly, one
/// projection of the field stiffness, one LU factorisation and solve). The history
/// (y₋, h₋) is kept in the workspace from the last accepted (sub)step; without one (the
/// first step, after `Simulation::set_state` or a static solve) or after a step-size jump
/// beyond [`BDF2_MAX_RATIO`], [`super::step`] takes a linearly implicit Euler step
/// instead (as at a restart of any multistep method), whose local error O(h²) does not
/// change the global order. A step that rotates an element by more than
/// [`TRUSTED_ELEMENT_ROTATION`](super::adaptive::TRUSTED_ELEMENT_ROTATION) (BDF2 steps are
/// not split by their numerical loss, and may not rotate further) is redone as linearly
/// implicit Euler substeps: there the
/// linearisation no longer holds, and extrapolating what it leaves out is what fails
/// first. With BDF2 substeps the stress matrix (`superhelix stress --integrator bdf2`) had
/// 81 failures, 8 of them blow-ups or runaway kinetic energy of frictionless strands on a
/// moving head; with implicit Euler substeps 56, none of those.
pub fn bdf2(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
    stats: &mut StepStats,
) -> Result<(), String> {
    let h = interval.h;
    let (q, v) = (&mut state.q[..], &mut state.v[..]);
    let n = q.len();
    let ws = &mut system.workspace;
    let w = h / ws.prev_h;
    let beta = (1.0 + w) / (1.0 + 2.0 * w);
    let a1 = (1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w);
    let a2 = w * w / (1.0 + 2.0 * w);
    let bh = beta * h;
    let mut s = std::mem::take(&mut ws.scratch);
    let result = (|| {
        let [qt, vt, qh, vh, dq, _] = &mut s;
        let ws = &system.workspace;
        for i in 0..n {
            qt[i] = q[i] + w * (q[i] - ws.prev_q[i]);
            vt[i] = v[i] + w * (v[i] - ws.prev_v[i]);
            qh[i] = a1 * q[i] - a2 * ws.prev_q[i];
            vh[i] = a1 * v[i] - a2 * ws.prev_v[i];
        }
        let assembled = system.assemble(&interval.at_end(), qt, vt, Terms::all());
        let ws = &mut system.workspace;
        let field_stiffness = ws.step_matrix(assembled, bh, stats);
        // D_q (q̂ − q̃)
        for i in 0..n {
            qh[i] -= qt[i];
        }
        ws.apply_dq(field_stiffness, qh, dq);
        let t = &ws.terms;
        // summed over j in order, column by column
        let rhs = &mut ws.solver.rhs_mut()[..n];
        for (i, r) in rhs.iter_mut().enumerate() {
            *r = bh * (t.force[i] + t.velocity_term[i] + dq[i]);
        }
        for j in 0..n {
            let mass = &t.mass.col_as_slice(j)[..n];
            let damping = &t.damping.col_as_slice(j)[..n];
            for i in 0..n {
                rhs[i] += mass[i] * vh[j] - bh * damping[i] * vt[j];
            }
        }
        if !ws.solver.solve_general() {
            return Err("BDF2: singular step matrix".into());
        }
        v.copy_from_slice(ws.solver.solution());
        for i in 0..n {
            // q̂ = (q̂ − q̃) + q̃
            q[i] = qh[i] + qt[i] + bh * v[i];
        }
        // the contacts that start within the step, predicted along the solution
        let at = interval.at_end();
        if let Some(c) = system.contacts.as_mut() {
            c.predict(&at, &system.strand.geometry, qt, q);
        }
        resolve(system, &at, (bh, bh), q, v, stats)
    })();
    system.workspace.scratch = s;
    result
}

/// After an accepted implicit step of length `h` from the workspace's saved start state:
/// keep that start state as BDF2's history.
pub fn record_history(kind: IntegratorKind, ws: &mut StrandWorkspace, h: f64) {
    if kind == IntegratorKind::Bdf2 {
        ws.prev_q.copy_from_slice(&ws.saved_q);
        ws.prev_v.copy_from_slice(&ws.saved_v);
        ws.prev_h = h;
    }
}

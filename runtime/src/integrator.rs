//! Time integration of one strand (paper section 3.4, design page "Time stepping"):
//! linearly implicit Euler (default), Newton-iterated implicit Euler, linearised BDF2
//! (second order, on the same step matrix), explicit RK4.
//!
//! Each strand owns a [`StrandWorkspace`] sized once: a step allocates nothing.

use crate::dense_solve::DenseSolver;
use crate::effects::{body_field, GlobalEffects};
use crate::energy_balance::{self, StateEnergy};
use crate::head_motion::{HeadMotion, HeadState};
use crate::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::simulation::IntegratorKind;
use crate::strand::Strand;
use nalgebra::Vector3;

/// Counters of what the solvers had to do.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Steps where the eigendecomposition of the field stiffness failed and it was
    /// left explicit.
    pub stiffness_dropped: usize,
    /// Newton iterations performed (Newton implicit Euler).
    pub newton_iterations: usize,
    /// Newton solves that did not converge (or met a singular Jacobian) at the deepest
    /// substep and were replaced by the linearly implicit step there.
    pub newton_unconverged: usize,
    /// Implicit steps split in two: they rotated an element too much, did not converge,
    /// or failed the energy balance.
    pub substeps: usize,
    /// Of the splits, those for the energy balance ([`crate::energy_balance`]).
    pub energy_rejected: usize,
    /// Steps whose velocities were scaled down so that the energy does not exceed the
    /// start's plus the head's work (see `implicit_adaptive`).
    pub energy_limited: usize,
    /// Steps accepted at the deepest substep although their energy exceeds the balance
    /// (the potential energy alone above the bound, so that no velocity scaling can help).
    pub energy_unbalanced: usize,
}

impl StepStats {
    /// Add another's counts.
    pub fn add(&mut self, o: &StepStats) {
        self.stiffness_dropped += o.stiffness_dropped;
        self.newton_iterations += o.newton_iterations;
        self.newton_unconverged += o.newton_unconverged;
        self.substeps += o.substeps;
        self.energy_rejected += o.energy_rejected;
        self.energy_limited += o.energy_limited;
        self.energy_unbalanced += o.energy_unbalanced;
    }
}

/// Per-strand buffers of the integrators.
pub struct StrandWorkspace {
    /// Kernel outputs plus the strand's own forces.
    pub terms: StrandTerms,
    /// Linear solver.
    pub solver: DenseSolver,
    pub(crate) jac: Vec<Vector3<f64>>,
    /// Diagonal of K.
    pub stiffness: Vec<f64>,
    /// Diagonal of the internal friction matrix γ l_Q.
    pub friction: Vec<f64>,
    scratch: [Vec<f64>; 6],
    saved_q: Vec<f64>,
    saved_v: Vec<f64>,
    /// BDF2 history: the state one step back and that step's length (0: none).
    prev_q: Vec<f64>,
    prev_v: Vec<f64>,
    prev_h: f64,
    /// The energy of the state the last implicit step ended in, and that state.
    last_energy: Option<StateEnergy>,
    last_q: Vec<f64>,
    last_v: Vec<f64>,
}

impl StrandWorkspace {
    /// Buffers for this strand.
    pub fn new(strand: &Strand) -> Self {
        let n = strand.geometry.dofs();
        let friction = strand
            .geometry
            .lengths
            .iter()
            .flat_map(|l| [l * strand.internal_friction; 3])
            .collect();
        StrandWorkspace {
            terms: StrandTerms::new(n),
            solver: DenseSolver::new(n),
            jac: vec![Vector3::zeros(); n],
            stiffness: strand.stiffness_diagonal(),
            friction,
            scratch: std::array::from_fn(|_| vec![0.0; n]),
            saved_q: vec![0.0; n],
            saved_v: vec![0.0; n],
            prev_q: vec![0.0; n],
            prev_v: vec![0.0; n],
            prev_h: 0.0,
            last_energy: None,
            last_q: vec![0.0; n],
            last_v: vec![0.0; n],
        }
    }

    /// Forget the state history of the two-step integrator (BDF2): its next step starts
    /// afresh, with a linearly implicit Euler step. Call it whenever the state is set
    /// from outside the integrator.
    pub fn forget_history(&mut self) {
        self.prev_h = 0.0;
    }
}

/// Everything about the world a strand's step needs.
#[derive(Debug, Clone, Copy)]
pub struct StepContext {
    /// Global effects.
    pub effects: GlobalEffects,
}

/// What an assembly contained beyond elasticity and friction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Assembled {
    /// The stiffness holds field or point-load terms (not only −K).
    pub field_stiffness: bool,
    /// The damping holds a skew (gyroscopic, Coriolis) part.
    pub gyroscopic: bool,
}

/// Evaluate the strand's full force F(q, q̇) (kernel terms, elasticity −K(q − q_n),
/// internal friction −γ l q̇, point loads Jᵀ f) and the requested Jacobians into
/// `ws.terms`: `stiffness` = ∂F/∂q (less ∂b/∂q), `damping` = ∂F/∂q̇ (less ∂b/∂q̇,
/// which is in `velocity_term_jacobian`).
pub fn assemble(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    q: &[f64],
    v: &[f64],
    terms: Terms,
) -> Assembled {
    let field = body_field(
        &ctx.effects,
        head,
        strand.material.mass_per_length,
        strand.air_drag,
    );
    // the kernel computes only what the scene's effects make non-zero
    let position_field = field.uniform != Vector3::zeros() || field.has_linear();
    let velocity_field = field.velocity != nalgebra::Matrix3::zeros();
    let kernel_terms = Terms {
        stiffness: terms.stiffness && position_field,
        damping: terms.damping && velocity_field,
        ..terms
    };
    kernel.evaluate(
        &EvalInput {
            q,
            v,
            field,
            terms: kernel_terms,
        },
        &mut ws.terms,
    );
    let t = &mut ws.terms;
    let n = q.len();
    if terms.stiffness && !kernel_terms.stiffness {
        t.stiffness.fill(0.0);
    }
    if terms.damping && !kernel_terms.damping {
        t.damping.fill(0.0);
    }
    if terms.force {
        for i in 0..n {
            t.force[i] -= ws.stiffness[i] * (q[i] - strand.natural[i]) + ws.friction[i] * v[i];
        }
    }
    if terms.stiffness {
        for i in 0..n {
            t.stiffness[(i, i)] -= ws.stiffness[i];
        }
    }
    if terms.damping {
        for i in 0..n {
            t.damping[(i, i)] -= ws.friction[i];
        }
    }
    if (terms.force || terms.stiffness) && !strand.point_loads.is_empty() {
        let rt = head.rotation.transpose();
        for load in &strand.point_loads {
            let f = rt * load.force;
            let hess = terms.stiffness.then_some((f, &mut t.stiffness));
            kernel.point(q, load.s, &mut ws.jac, hess);
            if terms.force {
                for (i, col) in ws.jac.iter().enumerate() {
                    t.force[i] += col.dot(&f);
                }
            }
        }
    }
    Assembled {
        field_stiffness: position_field || !strand.point_loads.is_empty(),
        gyroscopic: ctx.effects.head_moves && head.omega != Vector3::zeros() && terms.damping,
    }
}

/// Kinetic energy ½ q̇ᵀ M(q) q̇ (relative to the head).
pub fn kinetic_energy(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    q: &[f64],
    v: &[f64],
) -> f64 {
    energy_parts(strand, kernel, ws, ctx, q, v).0
}

/// Total energy T + U + V (gravity and point loads; with a still head), for tests and
/// diagnostics.
pub fn energy(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    q: &[f64],
    v: &[f64],
) -> f64 {
    let (kinetic, potential) = energy_parts(strand, kernel, ws, ctx, q, v);
    kinetic + potential
}

/// (T, U + V) of [`energy`].
fn energy_parts(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    q: &[f64],
    v: &[f64],
) -> (f64, f64) {
    let terms = Terms {
        mass: true,
        force: true,
        ..Default::default()
    };
    let field = body_field(
        &ctx.effects,
        &HeadState::rest(),
        strand.material.mass_per_length,
        0.0,
    );
    kernel.evaluate(&EvalInput { q, v, field, terms }, &mut ws.terms);
    let m = &ws.terms.mass;
    let n = q.len();
    let mut kinetic = 0.0;
    for j in 0..n {
        for i in 0..n {
            kinetic += 0.5 * v[i] * m[(i, j)] * v[j];
        }
    }
    let elastic: f64 = (0..n)
        .map(|i| 0.5 * ws.stiffness[i] * (q[i] - strand.natural[i]).powi(2))
        .sum();
    let gravity = ctx
        .effects
        .gravity
        .map_or(0.0, |g| -ws.terms.first_moment.dot(&g));
    let loads: f64 = strand
        .point_loads
        .iter()
        .map(|l| -kernel.point(q, l.s, &mut ws.jac, None).dot(&l.force))
        .sum();
    (kinetic, elastic + gravity + loads)
}

/// Largest rotation an implicit step may put into one element, radians: the change of
/// `l_Q |d_Q|` over the step. Beyond it the step's linearisation of M(q), b and the
/// forces no longer holds and energy can be created, so the step is split in two.
pub const MAX_ELEMENT_ROTATION: f64 = 0.2;
/// How many times a step may be halved (down to h / 2^depth).
pub const MAX_SUBSTEP_DEPTH: usize = 8;
/// With the head moving uniformly (inertial head frame), a step that creates more energy
/// than this fraction of the energy scale S = T + U + |c0| L² (beyond round-off) is split
/// in two; a smaller excess is removed from the velocities instead (see
/// `implicit_adaptive`). A step of a first-order scheme that resolves the motion errs by
/// O(h²) in E; one that creates 0.1 % of S at once does not resolve it (the straight
/// strands after a stop created 1.6e-4 to 1.1 S per step, the kinked ones far more), and
/// its halves are more accurate. Below it, halving again mostly costs: a strand whose
/// fastest motion is far beyond any substep (the 3 rad kinks) errs in E at every depth.
pub const ENERGY_SPLIT_FRACTION: f64 = 1e-3;
/// The same as [`ENERGY_SPLIT_FRACTION`] for a head that rotates or accelerates, where
/// the head's work over the step is a trapezoidal estimate: ordinary steps of the demo
/// scene (2 Hz, ±30° at 1/30 s) exceed estimate plus allowance by up to 1e-2 S, so a
/// lower threshold only splits steps that are fine; the instabilities it is for create
/// more than S per step.
pub const WORK_SPLIT_FRACTION: f64 = 1e-2;

/// Advance one strand from t by h with the chosen integrator (head motion read at the
/// times each scheme needs). Implicit steps are checked after the fact: split into
/// halves, recursively, when they fail, rotate an element by more than
/// [`MAX_ELEMENT_ROTATION`] or create energy ([`crate::energy_balance`]), with the excess
/// energy of the deepest (or a nearly right) step removed from its velocities; Newton
/// solves that do not converge are replaced by the linearly implicit step (see
/// `implicit_adaptive`; the counts are in [`StepStats`]). On failure, returns the cause.
#[allow(clippy::too_many_arguments)]
pub fn step_strand(
    kind: IntegratorKind,
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadMotion,
    t: f64,
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    match kind {
        IntegratorKind::Rk4 => {
            let heads = [head.state(t), head.state(t + 0.5 * h), head.state(t + h)];
            rk4(
                strand,
                kernel,
                ws,
                ctx,
                [&heads[0], &heads[1], &heads[2]],
                h,
                q,
                v,
            )
        }
        _ => {
            let start = start_energy(strand, kernel, ws, ctx, head, t, q, v);
            let end = implicit_adaptive(
                kind, strand, kernel, ws, ctx, head, t, h, q, v, stats, 0, &start,
            )?;
            ws.last_energy = Some(end);
            ws.last_q.copy_from_slice(q);
            ws.last_v.copy_from_slice(v);
            Ok(())
        }
    }?;
    if let Some(i) = q.iter().chain(v.iter()).position(|x| !x.is_finite()) {
        let what = if i < q.len() { "q" } else { "q̇" };
        return Err(format!("non-finite {what}[{}] after the step", i % q.len()));
    }
    Ok(())
}

/// The energy of (q, q̇) at t: the end of the previous step when it is that state (the
/// usual case), measured otherwise.
#[allow(clippy::too_many_arguments)]
fn start_energy(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadMotion,
    t: f64,
    q: &[f64],
    v: &[f64],
) -> StateEnergy {
    if let Some(e) = ws.last_energy {
        if (e.time - t).abs() <= 1e-12 * t.abs().max(1.0) && ws.last_q == q && ws.last_v == v {
            return e;
        }
    }
    measure_energy(strand, kernel, ws, ctx, &head.state(t), t, q, v)
}

#[allow(clippy::too_many_arguments)]
fn measure_energy(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    t: f64,
    q: &[f64],
    v: &[f64],
) -> StateEnergy {
    energy_balance::measure(
        strand,
        kernel,
        &mut ws.terms,
        &mut ws.jac,
        &ws.stiffness,
        &ws.friction,
        &ctx.effects,
        head,
        t,
        q,
        v,
    )
}

/// After an accepted implicit step of length `h` from `ws.saved_q`, `ws.saved_v`: keep
/// that start state as BDF2's history.
fn record_bdf2_history(kind: IntegratorKind, ws: &mut StrandWorkspace, h: f64) {
    if kind == IntegratorKind::Bdf2 {
        ws.prev_q.copy_from_slice(&ws.saved_q);
        ws.prev_v.copy_from_slice(&ws.saved_v);
        ws.prev_h = h;
    }
}

/// Largest l_Q |Δd_Q| between two states.
fn max_element_rotation(lengths: &[f64], q: &[f64], q0: &[f64]) -> f64 {
    lengths
        .iter()
        .enumerate()
        .map(|(k, l)| {
            let d: f64 = (0..3).map(|i| (q[3 * k + i] - q0[3 * k + i]).powi(2)).sum();
            l * d.sqrt()
        })
        .fold(0.0, f64::max)
}

/// One implicit step from (q, q̇) at t, whose energy is `start`, to t + h, checked after
/// the fact and split into two halves (recursively, at most [`MAX_SUBSTEP_DEPTH`] deep)
/// when it is not acceptable. Returns the energy of the end state.
///
/// - A Newton solve that does not converge (or meets a singular Jacobian) is never
///   accepted: the linearly implicit step of the same h replaces it, under the same checks
///   (counted in [`StepStats::newton_unconverged`]).
/// - A step that fails (a singular matrix, non-finite values) or rotates an element by
///   more than [`MAX_ELEMENT_ROTATION`] is split; at the deepest substep a failure is an
///   error and a large rotation is accepted.
/// - The energy balance ([`energy_balance::balance`]): E(end) must not exceed its bound
///   plus an allowance. With the head moving uniformly the bound is the ceiling (the
///   energy at the start of that phase less the estimated dissipation since, or E(start)
///   when higher) and the allowance round-off; otherwise E(start) plus the head's work W
///   (trapezoidal estimate) and the allowance covers the estimate's error. A step whose
///   excess is above [`ENERGY_SPLIT_FRACTION`] S (uniform head) or
///   [`WORK_SPLIT_FRACTION`] S (moving head) is split. A smaller excess, or any at the
///   deepest substep, is removed by scaling the velocities by the λ < 1 that brings E
///   down to bound plus allowance ([`StepStats::energy_limited`]): the exact dynamics
///   cannot gain more (friction and drag only dissipate), the excess of a first-order step
///   is its local error, so the correction is of the order of the error the step makes
///   anyway (it moves q̇ by excess / (2T) relative), and it is what keeps a step that
///   cannot resolve the motion from feeding energy in. When the potential energy alone
///   exceeds the bound, the step is split, or, at the deepest substep, accepted as it is
///   and counted ([`StepStats::energy_unbalanced`]), for the caller's own checks.
#[allow(clippy::too_many_arguments)]
fn implicit_adaptive(
    kind: IntegratorKind,
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadMotion,
    t: f64,
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
    depth: usize,
    start: &StateEnergy,
) -> Result<StateEnergy, String> {
    ws.saved_q.copy_from_slice(q);
    ws.saved_v.copy_from_slice(v);
    let head_next = head.state(t + h);
    let deepest = depth == MAX_SUBSTEP_DEPTH;
    let unconverged_before = stats.newton_unconverged;
    let mut outcome = match kind {
        IntegratorKind::NewtonImplicitEuler => {
            newton_implicit_euler(strand, kernel, ws, ctx, &head_next, h, q, v, stats)
        }
        // BDF2 takes whole steps; a step split for rotating too much is taken as linearly
        // implicit Euler substeps
        IntegratorKind::Bdf2
            if depth == 0 && ws.prev_h > 0.0 && h <= BDF2_MAX_RATIO * ws.prev_h =>
        {
            bdf2(strand, kernel, ws, ctx, &head_next, h, q, v, stats)
        }
        _ => linearly_implicit_euler(strand, kernel, ws, ctx, &head_next, h, q, v, stats),
    };
    if kind == IntegratorKind::NewtonImplicitEuler
        && (outcome.is_err() || stats.newton_unconverged > unconverged_before)
    {
        // never accept an unconverged (or failed) Newton solve: take the linearly implicit
        // step instead, under the same checks
        stats.newton_unconverged = unconverged_before + 1;
        q.copy_from_slice(&ws.saved_q);
        v.copy_from_slice(&ws.saved_v);
        outcome = linearly_implicit_euler(strand, kernel, ws, ctx, &head_next, h, q, v, stats);
    }
    let finite = q.iter().chain(v.iter()).all(|x| x.is_finite());
    let acceptable = outcome.is_ok()
        && finite
        && max_element_rotation(&strand.geometry.lengths, q, &ws.saved_q) <= MAX_ELEMENT_ROTATION;
    if acceptable || deepest {
        outcome?;
        if !finite {
            return Err(format!(
                "non-finite state after a substep of {h:.3e} s (at the deepest split)"
            ));
        }
        let mut end = measure_energy(strand, kernel, ws, ctx, &head_next, t + h, q, v);
        let inertial = head.uniform_over(t, t + h);
        let balance = energy_balance::balance(start, &end, inertial);
        let excess = balance.excess;
        // an accepted step: its end bounds the next, and it is BDF2's history
        let accept = |ws: &mut StrandWorkspace, mut end: StateEnergy| {
            end.ceiling = energy_balance::end_ceiling(start, &end, inertial);
            record_bdf2_history(kind, ws, h);
            Ok(end)
        };
        if excess <= 0.0 {
            return accept(ws, end);
        }
        let fraction = if inertial {
            ENERGY_SPLIT_FRACTION
        } else {
            WORK_SPLIT_FRACTION
        };
        let split = !deepest && excess > fraction * start.scale;
        if !split {
            // the kinetic energy that brings E down to the bound plus the allowance
            let kinetic = end.kinetic - excess;
            if kinetic >= 0.0 && end.kinetic > 0.0 {
                let lambda = (kinetic / end.kinetic).sqrt();
                for x in v.iter_mut() {
                    *x *= lambda;
                }
                end.scale_velocities(lambda);
                stats.energy_limited += 1;
                return accept(ws, end);
            }
            if deepest {
                stats.energy_unbalanced += 1;
                return accept(ws, end);
            }
        }
        stats.energy_rejected += 1;
    }
    stats.substeps += 1;
    q.copy_from_slice(&ws.saved_q);
    v.copy_from_slice(&ws.saved_v);
    let half = 0.5 * h;
    let middle = implicit_adaptive(
        kind,
        strand,
        kernel,
        ws,
        ctx,
        head,
        t,
        half,
        q,
        v,
        stats,
        depth + 1,
        start,
    )?;
    implicit_adaptive(
        kind,
        strand,
        kernel,
        ws,
        ctx,
        head,
        t + half,
        half,
        q,
        v,
        stats,
        depth + 1,
        &middle,
    )
}

/// One Newton step of backward Euler (design page "Time stepping"), with the velocity
/// term taken semi-implicitly:
///
/// ```text
/// (M − h D_v + (h/2) B − h² D_q) v⁺ = M v + h (F + b) − h D_v v,   q⁺ = q + h v⁺
/// ```
///
/// - D_q = H⁻ − K, where H is the symmetric part of the field and point-load stiffness
///   and H⁻ its negative semidefinite part (eigenvalues clamped at 0; H itself when a
///   Cholesky factorisation of −H succeeds): a destabilising stiffness (gravity on a
///   strand pointing up, centrifugal force) stays explicit, because in the matrix it
///   amplifies by 1/(1 − h²λ), which explodes as h²λ → 1. This is a convex–concave
///   splitting (Eyre): the convex part of the potential implicit, the concave part
///   explicit. Taking H whole whenever K − H is positive definite (one Cholesky instead
///   of an eigendecomposition, tried and reverted) is cheaper but lets the step create energy: a
///   frictionless fuzzy strand falling at N = 10–20 gained up to 0.11 of its energy scale
///   within 0.2 s (`superhelix stress`, conservative group; regression test in
///   `tests/stability.rs`).
/// - D_v = ∂F/∂q̇ less ∂b/∂q̇: friction and drag and, when the head turns, the Coriolis
///   term (skew).
/// - b(q, q̇) is quadratic in q̇ with ∂b/∂q̇ = B and B q̇ = 2b, so `b ≈ ½ B(q, q̇) q̇⁺`
///   is exact at q̇⁺ = q̇ and linear in q̇⁺ (the semi-implicit Coriolis treatment of
///   multibody codes). Left explicit, as in the paper, a whipping strand (q̇ l h of
///   order 1: a fine strand on a 3 Hz, ±40° shake) grows as v_{k+1} ~ h v_k² and
///   overflows within ten steps; `tests/stability.rs` is that case.
///
/// The matrix is not symmetric (B, Coriolis): partial-pivoting LU.
#[allow(clippy::too_many_arguments)]
fn linearly_implicit_euler(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    let terms = Terms::all();
    let assembled = assemble(strand, kernel, ws, ctx, head, q, v, terms);
    let n = q.len();
    step_matrix(ws, assembled, h, stats);
    let t = &ws.terms;
    // r_i = h (F + b)_i + Σ_j (M − h D_v)_ij v_j, summed over j in order, column by column
    let rhs = &mut ws.solver.rhs_mut()[..n];
    for (i, r) in rhs.iter_mut().enumerate() {
        *r = h * (t.force[i] + t.velocity_term[i]);
    }
    for (j, &vj) in v.iter().enumerate() {
        let mass = &t.mass.col_as_slice(j)[..n];
        let damping = &t.damping.col_as_slice(j)[..n];
        for i in 0..n {
            rhs[i] += (mass[i] - h * damping[i]) * vj;
        }
    }
    if !ws.solver.solve_general() {
        return Err("linearly implicit Euler: singular step matrix".into());
    }
    v.copy_from_slice(ws.solver.solution());
    for i in 0..n {
        q[i] += h * v[i];
    }
    Ok(())
}

/// The matrix of the linearly implicit step, `M − h D_v + (h/2) B − h² D_q` (see
/// [`linearly_implicit_euler`]), into `ws.solver.matrix`, from a full assembly in
/// `ws.terms`. Leaves H⁻ (the negative semidefinite part of the symmetrised field
/// stiffness) in `ws.terms.stiffness`; returns whether D_q holds it (false: no field
/// stiffness, or its eigendecomposition failed and it stays explicit, counted in
/// [`StepStats::stiffness_dropped`]), for [`apply_dq`].
fn step_matrix(
    ws: &mut StrandWorkspace,
    assembled: Assembled,
    h: f64,
    stats: &mut StepStats,
) -> bool {
    let n = ws.stiffness.len();
    let field_stiffness = assembled.field_stiffness && {
        // H = sym(stiffness) + K, projected
        let st = &mut ws.terms.stiffness;
        for j in 0..n {
            for i in 0..j {
                let m = 0.5 * (st[(i, j)] + st[(j, i)]);
                st[(i, j)] = m;
                st[(j, i)] = m;
            }
            st[(j, j)] += ws.stiffness[j];
        }
        let ok = ws
            .solver
            .project_negative_semidefinite(&mut ws.terms.stiffness);
        if !ok {
            stats.stiffness_dropped += 1;
        }
        ok
    };
    let t = &ws.terms;
    // column by column on slices (the same arithmetic as entry by entry)
    for j in 0..n {
        let mass = &t.mass.col_as_slice(j)[..n];
        let damping = &t.damping.col_as_slice(j)[..n];
        let jacobian = &t.velocity_term_jacobian.col_as_slice(j)[..n];
        let stiffness = &t.stiffness.col_as_slice(j)[..n];
        let out = &mut ws.solver.matrix.col_as_slice_mut(j)[..n];
        for i in 0..n {
            let mut dq = if field_stiffness { stiffness[i] } else { 0.0 };
            if i == j {
                dq -= ws.stiffness[i];
            }
            out[i] = mass[i] - h * damping[i] + 0.5 * h * jacobian[i] - h * h * dq;
        }
    }
    field_stiffness
}

/// `out = (H⁻ − K) x` with H⁻ as left by [`step_matrix`] (in `ws.terms.stiffness` when
/// `field_stiffness`).
fn apply_dq(ws: &StrandWorkspace, field_stiffness: bool, x: &[f64], out: &mut [f64]) {
    let n = x.len();
    for i in 0..n {
        out[i] = -ws.stiffness[i] * x[i];
    }
    if field_stiffness {
        let h = &ws.terms.stiffness;
        for j in 0..n {
            let xj = x[j];
            for i in 0..n {
                out[i] += h[(i, j)] * xj;
            }
        }
    }
}

/// Largest ratio of a BDF2 step to the step before it; beyond it (after substeps of a
/// quarter of the step or less) the history is not used and a linearly implicit Euler
/// step restarts the scheme. Variable-step BDF2 is zero-stable only for ratios below
/// 1 + √2 (Grigorieff 1983; Hairer, Nørsett & Wanner, *Solving ODEs I*, III.5); a step
/// split once and then resumed has ratio 2.
pub const BDF2_MAX_RATIO: f64 = 2.0;

/// One step of the variable-step two-step BDF (BDF2; Hairer, Nørsett & Wanner, *Solving
/// ODEs I*, section III.5) on the equations of motion (paper eq. 6), `q̇ = v`,
/// `M(q) v̇ = F(q, v)` (F the full force of [`assemble`], including −b), linearised once
/// per step like [`linearly_implicit_euler`] (design page "Time stepping": "implicit
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
/// D_q = H⁻ − K, D_v and B as in [`linearly_implicit_euler`] (the destabilising part of
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
/// another state: a one-step Rosenbrock-W scheme (ROS2) on the same matrix was tried and
/// dropped because its second stage must evaluate M⁻¹F at a stage point, and the twist
/// block of M⁻¹ (the inverse of the rotary inertia of nearly straight elements, ~1e6
/// times the bending block's) made that stage unstable: exactly (a falling 5 cm fibre
/// blew up at dt = 1/50 s) or to first order (the 20 cm swing at N = 20 blew up at
/// dt = 1/4800 s, its step map having spectral radius 2.0–2.3 at every dt from 1/240 to
/// 1/4800 s where implicit Euler's is 1.003–1.16).
///
/// The cost of a step is that of a linearly implicit Euler step (one full assembly, one
/// projection of the field stiffness, one LU factorisation and solve). The history
/// (y₋, h₋) is kept in the workspace from the last accepted (sub)step; without one (the
/// first step, after `Simulation::set_state` or a static solve) or after a step-size jump
/// beyond [`BDF2_MAX_RATIO`], [`step_strand`] takes a linearly implicit Euler step
/// instead (as at a restart of any multistep method), whose local error O(h²) does not
/// change the global order. A step that rotates an element by more than
/// [`MAX_ELEMENT_ROTATION`] is redone as linearly implicit Euler substeps: there the
/// linearisation no longer holds, and extrapolating what it leaves out is what fails
/// first. With BDF2 substeps the stress matrix (`superhelix stress --integrator bdf2`) had
/// 81 failures, 8 of them blow-ups or runaway kinetic energy of frictionless strands on a
/// moving head; with implicit Euler substeps 56, none of those.
#[allow(clippy::too_many_arguments)]
fn bdf2(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    let n = q.len();
    let w = h / ws.prev_h;
    let beta = (1.0 + w) / (1.0 + 2.0 * w);
    let a1 = (1.0 + w) * (1.0 + w) / (1.0 + 2.0 * w);
    let a2 = w * w / (1.0 + 2.0 * w);
    let bh = beta * h;
    let mut s = std::mem::take(&mut ws.scratch);
    let result = (|| {
        let [qt, vt, qh, vh, dq, _] = &mut s;
        for i in 0..n {
            qt[i] = q[i] + w * (q[i] - ws.prev_q[i]);
            vt[i] = v[i] + w * (v[i] - ws.prev_v[i]);
            qh[i] = a1 * q[i] - a2 * ws.prev_q[i];
            vh[i] = a1 * v[i] - a2 * ws.prev_v[i];
        }
        let assembled = assemble(strand, kernel, ws, ctx, head, qt, vt, Terms::all());
        let field_stiffness = step_matrix(ws, assembled, bh, stats);
        // D_q (q̂ − q̃)
        for i in 0..n {
            qh[i] -= qt[i];
        }
        apply_dq(ws, field_stiffness, qh, dq);
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
        Ok(())
    })();
    ws.scratch = s;
    result
}

/// Backward Euler `M(q⁺)(v⁺ − v) = h F(q⁺, v⁺)`, `q⁺ = q + h v⁺`, solved by Newton
/// iterations on v⁺ with the Jacobian `M − h(D_v − ∂b/∂q̇) − h² D_q` (∂M/∂q and ∂b/∂q
/// are left out: they enter at relative order h and only slow convergence), to a
/// residual of 1e-10 of the step's force scale (the largest of M Δv, h K(q − q_n) and the
/// other forces times h), at most [`NEWTON_MAX_ITERATIONS`] iterations.
///
/// Without ∂M/∂q and ∂b/∂q the iterations converge linearly, at a rate that degrades as
/// h grows (in fast large rotations: 0.03 per iteration at a substep of 0.13 ms, 0.12 at
/// 0.26 ms, none at 1 ms). From the third residual on, the solve stops as unconverged as
/// soon as the residual no longer decreases or its rate of decrease cannot reach the
/// tolerance within the remaining iterations: the caller splits the step, and iterating on
/// would only cost.
#[allow(clippy::too_many_arguments)]
fn newton_implicit_euler(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    const TOLERANCE: f64 = 1e-10;
    let n = q.len();
    let mut s = std::mem::take(&mut ws.scratch);
    let [v_new, q_new, residual, ..] = &mut s;
    v_new.copy_from_slice(v);
    let mut converged = false;
    let mut outcome = Ok(());
    let mut previous = f64::INFINITY;
    for iteration in 0..NEWTON_MAX_ITERATIONS {
        for i in 0..n {
            q_new[i] = q[i] + h * v_new[i];
        }
        assemble(strand, kernel, ws, ctx, head, q_new, v_new, Terms::all());
        stats.newton_iterations += 1;
        let t = &ws.terms;
        let mut scale: f64 = 1e-300;
        let mut worst: f64 = 0.0;
        for i in 0..n {
            let mut mdv = 0.0;
            for j in 0..n {
                mdv += t.mass[(i, j)] * (v_new[j] - v[j]);
            }
            residual[i] = mdv - h * t.force[i];
            // the scale of the terms that cancel in the residual: at rest the net force is
            // zero while elasticity and gravity are not
            let elastic = ws.stiffness[i] * (q_new[i] - strand.natural[i]);
            let others = t.force[i] + elastic;
            scale = scale
                .max(mdv.abs())
                .max(h * elastic.abs())
                .max(h * others.abs());
            worst = worst.max(residual[i].abs());
        }
        let relative = worst / scale;
        if relative <= TOLERANCE {
            converged = true;
            break;
        }
        if iteration >= 2 {
            let rate = relative / previous;
            let left = (NEWTON_MAX_ITERATIONS - 1 - iteration) as f64;
            // a NaN rate (a NaN residual) is no progress either
            let progressing = rate < 1.0;
            if !progressing || (TOLERANCE / relative).ln() / rate.ln() > left {
                break;
            }
        }
        previous = relative;
        for j in 0..n {
            for i in 0..n {
                let dv = t.damping[(i, j)] - t.velocity_term_jacobian[(i, j)];
                ws.solver.matrix[(i, j)] = t.mass[(i, j)] - h * dv - h * h * t.stiffness[(i, j)];
            }
        }
        for i in 0..n {
            ws.solver.rhs_mut()[i] = -residual[i];
        }
        if !ws.solver.solve_general() {
            outcome = Err("Newton implicit Euler: singular Jacobian".to_string());
            break;
        }
        let dv = ws.solver.solution();
        for i in 0..n {
            v_new[i] += dv[i];
        }
    }
    if outcome.is_ok() {
        if !converged {
            stats.newton_unconverged += 1;
        }
        v.copy_from_slice(v_new);
        for i in 0..n {
            q[i] += h * v[i];
        }
    }
    ws.scratch = s;
    outcome
}

/// Most Newton iterations of one implicit Euler solve.
pub const NEWTON_MAX_ITERATIONS: usize = 20;

/// q̈ = M⁻¹ F(q, q̇) into `acc`.
#[allow(clippy::too_many_arguments)]
fn acceleration(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    head: &HeadState,
    q: &[f64],
    v: &[f64],
    acc: &mut [f64],
) -> Result<(), String> {
    let terms = Terms {
        mass: true,
        force: true,
        ..Default::default()
    };
    assemble(strand, kernel, ws, ctx, head, q, v, terms);
    ws.solver.matrix.copy_from(&ws.terms.mass);
    ws.solver.rhs_mut().copy_from_slice(&ws.terms.force);
    if !ws.solver.solve_spd() {
        let finite = q.iter().chain(v).all(|x| x.is_finite());
        let largest = q.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        return Err(if finite {
            format!(
                "RK4: the mass matrix at a stage state is not positive definite (largest |q| = {largest:.3e} rad/m): \
                 the explicit steps have grown unstable (dt beyond the stability limit of the stiffest mode, \
                 which changes along the motion); use a smaller dt or an implicit integrator"
            )
        } else {
            "RK4: a stage state is not finite: the explicit steps diverged (dt beyond the stability limit \
             of the stiffest mode); use a smaller dt or an implicit integrator"
                .to_string()
        });
    }
    acc.copy_from_slice(ws.solver.solution());
    Ok(())
}

/// Classical RK4 on (q, q̇); a reference for tests (explicit: needs small steps).
#[allow(clippy::too_many_arguments)]
fn rk4(
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    heads: [&HeadState; 3],
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
) -> Result<(), String> {
    let n = q.len();
    let mut s = std::mem::take(&mut ws.scratch);
    let result = (|| {
        let [qs, vs, acc, dq, dv, _] = &mut s;
        dq.fill(0.0);
        dv.fill(0.0);
        acc.fill(0.0);
        vs.copy_from_slice(v);
        // (c, weight, head at t + c h): stage state (q + c h k_q, v + c h k_v) of the previous stage
        for (c, weight, head) in [(0.0, 1.0, 0), (0.5, 2.0, 1), (0.5, 2.0, 1), (1.0, 1.0, 2)] {
            for i in 0..n {
                qs[i] = q[i] + c * h * vs[i];
                vs[i] = v[i] + c * h * acc[i];
            }
            acceleration(strand, kernel, ws, ctx, heads[head], qs, vs, acc)?;
            for i in 0..n {
                dq[i] += weight * vs[i];
                dv[i] += weight * acc[i];
            }
        }
        for i in 0..n {
            q[i] += h / 6.0 * dq[i];
            v[i] += h / 6.0 * dv[i];
        }
        Ok(())
    })();
    ws.scratch = s;
    result
}

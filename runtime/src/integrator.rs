//! Time integration of one strand (paper section 3.4, design page "Time stepping"):
//! linearly implicit Euler (default), Newton-iterated implicit Euler, explicit RK4.
//!
//! Each strand owns a [`StrandWorkspace`] sized once: a step allocates nothing.

use crate::dense_solve::DenseSolver;
use crate::effects::{body_field, GlobalEffects};
use crate::head_motion::HeadState;
use crate::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::simulation::IntegratorKind;
use crate::strand::Strand;
use faer::Mat;
use nalgebra::Vector3;

/// Counters of what the solvers had to do.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StepStats {
    /// Steps whose system was not positive definite and went to LU.
    pub lu_fallbacks: usize,
    /// Steps where LU failed too and the field stiffness was dropped.
    pub stiffness_dropped: usize,
    /// Newton iterations performed (Newton implicit Euler).
    pub newton_iterations: usize,
    /// Newton solves that reached the iteration cap without meeting the tolerance.
    pub newton_unconverged: usize,
}

impl StepStats {
    /// Add another's counts.
    pub fn add(&mut self, o: &StepStats) {
        self.lu_fallbacks += o.lu_fallbacks;
        self.stiffness_dropped += o.stiffness_dropped;
        self.newton_iterations += o.newton_iterations;
        self.newton_unconverged += o.newton_unconverged;
    }
}

/// Per-strand buffers of the integrators.
pub struct StrandWorkspace {
    /// Kernel outputs plus the strand's own forces.
    pub terms: StrandTerms,
    /// Linear solver.
    pub solver: DenseSolver,
    jac: Vec<Vector3<f64>>,
    /// Diagonal of K.
    pub stiffness: Vec<f64>,
    /// Diagonal of the internal friction matrix γ l_Q.
    pub friction: Vec<f64>,
    scratch: [Vec<f64>; 6],
}

impl StrandWorkspace {
    /// Buffers for this strand.
    pub fn new(strand: &Strand) -> Self {
        let n = strand.geometry.dofs();
        let friction = strand.geometry.lengths.iter().flat_map(|l| [l * strand.internal_friction; 3]).collect();
        StrandWorkspace {
            terms: StrandTerms::new(n),
            solver: DenseSolver::new(n),
            jac: vec![Vector3::zeros(); n],
            stiffness: strand.stiffness_diagonal(),
            friction,
            scratch: std::array::from_fn(|_| vec![0.0; n]),
        }
    }
}

/// Everything about the world a strand's step needs.
#[derive(Debug, Clone, Copy)]
pub struct StepContext {
    /// Global effects.
    pub effects: GlobalEffects,
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
) {
    let field = body_field(&ctx.effects, head, strand.material.mass_per_length, strand.air_drag);
    kernel.evaluate(&EvalInput { q, v, field, terms }, &mut ws.terms);
    let t = &mut ws.terms;
    let n = q.len();
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
    let terms = Terms { mass: true, force: true, ..Default::default() };
    let field = body_field(&ctx.effects, &HeadState::rest(), strand.material.mass_per_length, 0.0);
    kernel.evaluate(&EvalInput { q, v, field, terms }, &mut ws.terms);
    let m = &ws.terms.mass;
    let n = q.len();
    let mut kinetic = 0.0;
    for j in 0..n {
        for i in 0..n {
            kinetic += 0.5 * v[i] * m[(i, j)] * v[j];
        }
    }
    let elastic: f64 = (0..n).map(|i| 0.5 * ws.stiffness[i] * (q[i] - strand.natural[i]).powi(2)).sum();
    let gravity = ctx.effects.gravity.map_or(0.0, |g| -ws.terms.first_moment.dot(&g));
    let loads: f64 = strand
        .point_loads
        .iter()
        .map(|l| -kernel.point(q, l.s, &mut ws.jac, None).dot(&l.force))
        .sum();
    (kinetic, elastic + gravity + loads)
}

fn symmetric_part(m: &Mat<f64>, i: usize, j: usize) -> f64 {
    0.5 * (m[(i, j)] + m[(j, i)])
}

/// Advance one strand by h with the chosen integrator. `head_now` is the head at t,
/// `head_mid` at t + h/2, `head_next` at t + h. On failure, returns the cause.
#[allow(clippy::too_many_arguments)]
pub fn step_strand(
    kind: IntegratorKind,
    strand: &Strand,
    kernel: &mut dyn StrandKernel,
    ws: &mut StrandWorkspace,
    ctx: &StepContext,
    heads: [&HeadState; 3],
    h: f64,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    match kind {
        IntegratorKind::LinearlyImplicitEuler => linearly_implicit_euler(strand, kernel, ws, ctx, heads[2], h, q, v, stats),
        IntegratorKind::NewtonImplicitEuler => newton_implicit_euler(strand, kernel, ws, ctx, heads[2], h, q, v, stats),
        IntegratorKind::Rk4 => rk4(strand, kernel, ws, ctx, heads, h, q, v),
    }?;
    if let Some(i) = q.iter().chain(v.iter()).position(|x| !x.is_finite()) {
        let what = if i < q.len() { "q" } else { "q̇" };
        return Err(format!("non-finite {what}[{}] after the step", i % q.len()));
    }
    Ok(())
}

/// One Newton step of backward Euler (design page "Time stepping"):
/// `(M − h D_v − h² D_q) v⁺ = M v + h F − h D_v v`, `q⁺ = q + h v⁺`, with the symmetric
/// parts of D_q = ∂F/∂q (−K plus the field and point-load stiffness) and D_v = ∂F/∂q̇
/// (−γL − drag); the gyroscopic (skew) parts stay explicit. Cholesky; LU when the
/// field stiffness makes the matrix indefinite; the field stiffness dropped (K only,
/// always SPD) if even LU fails.
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
    let terms = Terms { mass: true, force: true, stiffness: true, damping: true, velocity_term_jacobian: false };
    assemble(strand, kernel, ws, ctx, head, q, v, terms);
    let n = q.len();
    let fill = |ws: &mut StrandWorkspace, with_field_stiffness: bool| {
        let t = &ws.terms;
        for j in 0..n {
            for i in 0..n {
                let dq = if with_field_stiffness {
                    symmetric_part(&t.stiffness, i, j)
                } else if i == j {
                    -ws.stiffness[i]
                } else {
                    0.0
                };
                ws.solver.matrix[(i, j)] = t.mass[(i, j)] - h * symmetric_part(&t.damping, i, j) - h * h * dq;
            }
        }
        let rhs = ws.solver.rhs.col_as_slice_mut(0);
        for i in 0..n {
            let mut r = h * t.force[i];
            for j in 0..n {
                r += (t.mass[(i, j)] - h * symmetric_part(&t.damping, i, j)) * v[j];
            }
            rhs[i] = r;
        }
    };
    fill(ws, true);
    let mut solved = ws.solver.solve_spd();
    if !solved {
        stats.lu_fallbacks += 1;
        fill(ws, true);
        solved = ws.solver.solve_general();
    }
    if !solved {
        stats.stiffness_dropped += 1;
        fill(ws, false);
        solved = ws.solver.solve_spd();
    }
    if !solved {
        return Err("linearly implicit Euler: the step matrix M + h C + h² K is singular".into());
    }
    v.copy_from_slice(ws.solver.solution());
    for i in 0..n {
        q[i] += h * v[i];
    }
    Ok(())
}

/// Backward Euler `M(q⁺)(v⁺ − v) = h F(q⁺, v⁺)`, `q⁺ = q + h v⁺`, solved by Newton
/// iterations on v⁺ with the Jacobian `M − h(D_v − ∂b/∂q̇) − h² D_q` (∂M/∂q and ∂b/∂q
/// are left out: they enter at relative order h and only slow convergence), to a
/// residual of 1e-10 of the step's force scale, at most 12 iterations.
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
    const MAX_ITERATIONS: usize = 12;
    const TOLERANCE: f64 = 1e-10;
    let n = q.len();
    let mut s = std::mem::take(&mut ws.scratch);
    let [v_new, q_new, residual, ..] = &mut s;
    v_new.copy_from_slice(v);
    let mut converged = false;
    let mut outcome = Ok(());
    for _ in 0..MAX_ITERATIONS {
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
            scale = scale.max(mdv.abs()).max((h * t.force[i]).abs());
            worst = worst.max(residual[i].abs());
        }
        if worst <= TOLERANCE * scale {
            converged = true;
            break;
        }
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
    let terms = Terms { mass: true, force: true, ..Default::default() };
    assemble(strand, kernel, ws, ctx, head, q, v, terms);
    ws.solver.matrix.copy_from(&ws.terms.mass);
    ws.solver.rhs_mut().copy_from_slice(&ws.terms.force);
    if !ws.solver.solve_spd() {
        return Err("RK4: the mass matrix is not positive definite".into());
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

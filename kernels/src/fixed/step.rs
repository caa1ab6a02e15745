//! The fixed-N step: the terms of the equation of motion, the linearly implicit Euler
//! step, and the centreline.

use super::contacts::ContactHooks;
use super::dense::{lu_solve_factored, lu_solve_sized, negative_semidefinite_part, Projection};
use super::end_hooks::{EndHooks, HeldError};
use super::free_root;
use super::workspace::FixedWorkspace;
use super::FixedStrand;
use crate::body_field::BodyField;
use crate::field_split::{dissipative_split, FieldRule, SplitOutcome};
use crate::float::Float;
use crate::head::{body_field, HeadState};
use crate::point_load;
use crate::pose::Pose;
use crate::projection::{
    cholesky, ProjectionBasis, ProjectionOutcome, ProjectionScratch, SpectralProjection,
};
use crate::storage::{ParamsView, ProjectionView, Square, StrandView, WorkView};
use crate::strand_terms::{
    element_ends, MomentSource, PointsOf, StepTerms, TermMatrix, TermVectors, Terms,
};
use nalgebra::Vector3;

/// What one step of a strand needs besides the strand: the head at the end of the step
/// and the world's effects.
#[derive(Debug, Clone, Copy)]
pub struct StepInput {
    /// The head's state at the end of the step (position, rotation and their first two
    /// derivatives).
    pub head: HeadState,
    /// Gravity in world coordinates, m/s² (`None`: no gravity).
    pub gravity: Option<Vector3<f64>>,
    /// Whether the head moves: the fictitious forces of its motion are built only then.
    pub head_moves: bool,
}

/// What a successful step reports (in `f64` whatever the step's float type).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StepReport {
    /// Largest rotation the step put into one element, radians: `l_Q |Δd_Q|`. Beyond
    /// ~0.2 the step's linearisation no longer holds: take smaller steps.
    pub max_element_rotation: f64,
    /// How the stabilising part of the field stiffness was found (`None`: the field has
    /// no stiffness, e.g. no gravity and a still head).
    pub projection: Option<Projection>,
    /// Contacts that started within the step and pushed
    /// ([`crate::contact::predicted`]; 0 without predicted contacts).
    pub contacts_predicted: usize,
    /// Whether a contact or a point load added stiffness to the step's matrix (the
    /// dissipative split's rule then keeps the spectral projection,
    /// [`crate::field_split`]).
    pub loaded: bool,
}

/// The first non-finite entry of (q, q̇) as a [`StepError::NonFinite`], if any.
pub(crate) fn non_finite<T: Float>(q: &[T], v: &[T]) -> Option<StepError> {
    let n = q.len();
    q.iter()
        .chain(v.iter())
        .position(|x| !x.is_finite())
        .map(|i| StepError::NonFinite {
            index: i % n,
            velocity: i >= n,
        })
}

/// Why a step failed; the strand keeps the state it had before the step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepError {
    /// The step matrix is singular (a zero pivot or a non-finite solution).
    SingularMatrix,
    /// The step produced a value that is not finite: q or q̇ (`velocity`) at `index`.
    NonFinite {
        /// Index into q.
        index: usize,
        /// Whether it was q̇ (else q).
        velocity: bool,
    },
    /// The time step is not finite and > 0.
    TimeStep,
    /// The tolerance of the error-controlled step is outside its range
    /// ([`super::min_tolerance`] to [`super::MAX_TOLERANCE`]).
    Tolerance,
    /// A strand and a workspace of different sizes handed to [`super::step_views`].
    Sizes,
    /// The shortest piece a checked step splits into (`dt / 2^MAX_SUBSTEP_DEPTH`) still
    /// turns an element by `rotation` rad, beyond the
    /// [`crate::energy::MAX_ELEMENT_ROTATION`] a step can follow, under point loads:
    /// they accelerate the strand faster than the steps resolve, and limiting the step
    /// would take momentum away.
    UnresolvedMotion {
        /// The largest l_Q |Δd_Q| of the piece, rad.
        rotation: f64,
        /// The piece's length, s.
        h: f64,
        /// Its start, s.
        t: f64,
    },
    /// The strand's held tip could not be kept ([`super::EndHooks`]).
    Held(HeldError),
    /// The error-controlled step's estimate stayed above its tolerance down to the
    /// shortest step ([`super::error_control::MIN_STEP`]) for
    /// [`super::error_control::MAX_FORCED_STEPS`] steps in a row: an error that does not
    /// shrink with the step is not one the step can control.
    ToleranceUnmet {
        /// The last estimate, relative to the strand's length.
        error: f64,
        /// The tolerance.
        tolerance: f64,
        /// Where the strand stopped (the end of the last of those steps), s.
        t: f64,
    },
}

impl core::fmt::Display for StepError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            StepError::SingularMatrix => write!(f, "singular step matrix"),
            StepError::Held(e) => write!(f, "{e}"),
            StepError::NonFinite { index, velocity } => write!(
                f,
                "non-finite {}[{index}] after the step",
                if *velocity { "q̇" } else { "q" }
            ),
            StepError::TimeStep => write!(f, "dt: must be finite and > 0"),
            StepError::Sizes => write!(f, "a strand and a step workspace of different sizes"),
            StepError::UnresolvedMotion { rotation, h, t } => write!(
                f,
                "an element turns by {rotation:.2} rad within {h:.3e} s (from t = {t:.6} s), the shortest piece a step splits into ([simulation] dt / 2^{}), beyond the {} rad a step can follow: the loads or the head accelerate the strand faster than the steps resolve, and limiting the step would take momentum away (the strand would no longer follow F = ma); lower [simulation] dt, or the loads",
                crate::energy::MAX_SUBSTEP_DEPTH,
                crate::energy::MAX_ELEMENT_ROTATION
            ),
            StepError::ToleranceUnmet { error, tolerance, t } => write!(
                f,
                "the error-controlled step could not meet its tolerance {tolerance:e}: its estimate stayed at {error:.2e} of the strand's length down to its shortest step ({:e} s) for {} steps in a row, up to t = {t:.9} s, where the strand stopped",
                super::error_control::MIN_STEP,
                super::error_control::MAX_FORCED_STEPS
            ),
            StepError::Tolerance => write!(
                f,
                "tolerance: must lie in [{:e}, {}] ({:e} in f32)",
                super::error_control::MIN_TOLERANCE,
                super::error_control::MAX_TOLERANCE,
                super::error_control::min_tolerance::<f32>()
            ),
        }
    }
}

/// The kernel terms `terms` at (q, q̇) in `field` into `ws` (M in the assembly's
/// buffers, the force ∫JᵀF − b, b and ∫ρS y, and the requested matrices), reusing
/// the element moments when q is the one `ws` was prepared for.
pub(crate) fn evaluate_at<S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    params: &ParamsView<'_, T>,
    q: &[T],
    v: &[T],
    field: &BodyField<T>,
    terms: Terms,
    ws: &mut WorkView<'_, T, NC>,
) {
    let WorkView {
        assembly,
        stiffness,
        damping,
        velocity_jacobian,
        force,
        velocity_term,
        first_moment,
        ..
    } = ws;
    let mut vectors = TermVectors {
        force,
        velocity_term,
        first_moment,
    };
    let mut sink = |which: TermMatrix, m: &[T]| {
        let target = match which {
            TermMatrix::Mass => return,
            TermMatrix::Stiffness => &mut *stiffness,
            TermMatrix::Damping => &mut *damping,
            TermMatrix::VelocityTermJacobian => &mut *velocity_jacobian,
        };
        target.as_mut_slice().copy_from_slice(m);
    };
    source.evaluate(
        &params.shape(),
        assembly,
        q,
        v,
        field,
        terms,
        &mut vectors,
        &mut sink,
    );
}

/// Fill the terms of the step at the strand's state with the head in `input.head` into
/// `ws`: M, F = ∫JᵀF − b − K(q − q_n) − γ l q̇, b, and (when the field has them) ∂F/∂q
/// and ∂F/∂q̇ less ∂b/∂q, and ∂b/∂q̇. Returns whether the stiffness holds field terms.
pub fn evaluate<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &FixedStrand<N, D, B, T>,
    input: &StepInput,
    ws: &mut FixedWorkspace<N, D, E, T>,
) -> bool {
    let mut ws = ws.view();
    ws.forget();
    let params = strand.params.view();
    let mut source = source;
    assemble(
        &mut source,
        &params,
        &strand.q,
        &strand.v,
        input,
        &mut ws,
        None,
        None,
    )
    .0
}

/// [`evaluate`] at (q, q̇) without forgetting what `ws` was prepared for, with the
/// strand's point loads and its contacts (their terms at time t). Returns whether the
/// stiffness holds terms beyond −K (in the matrix, projected) and whether the strand
/// touches or carries point loads (the dissipative split's rule then keeps the
/// projection, [`crate::field_split`]).
pub(crate) fn assemble<'c, 'e, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    p: &ParamsView<'_, T>,
    q: &[T],
    v: &[T],
    input: &StepInput,
    ws: &mut WorkView<'_, T, NC>,
    contacts: Option<(&mut (dyn ContactHooks<T> + 'c), f64)>,
    end: Option<&mut (dyn EndHooks<T> + 'e)>,
) -> (bool, bool) {
    assemble_terms(source, p, q, v, input, ws, contacts, end, false)
}

/// [`assemble`], with the whole stiffness and damping as Newton's Jacobian needs them
/// when `full` (the field stiffness unsymmetrised, the damping in its general form;
/// the linearly implicit step keeps sym(stiffness) only and its damping split).
#[allow(clippy::too_many_arguments)]
pub(crate) fn assemble_terms<'c, 'e, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    p: &ParamsView<'_, T>,
    q: &[T],
    v: &[T],
    input: &StepInput,
    ws: &mut WorkView<'_, T, NC>,
    contacts: Option<(&mut (dyn ContactHooks<T> + 'c), f64)>,
    end: Option<&mut (dyn EndHooks<T> + 'e)>,
    full: bool,
) -> (bool, bool) {
    let n = crate::storage::sized::<NC>(p.dofs());
    let field = body_field(
        input.gravity,
        input.head_moves,
        &input.head,
        p.mass_per_length,
        p.air_drag,
    );
    let position_field = field.uniform != Vector3::zeros() || field.has_linear();
    let velocity_field = field.velocity != nalgebra::Matrix3::zeros();
    let explicit = *ws.field_rule == FieldRule::Explicit;
    let terms = Terms {
        mass: true,
        force: true,
        stiffness: position_field && !explicit,
        damping: velocity_field,
        velocity_term_jacobian: true,
        field_force: false,
        // the step keeps sym(stiffness) only (`step_matrix`); Newton's Jacobian the whole
        symmetric_stiffness: !full,
        split_damping: !full,
    };
    evaluate_at(source, p, q, v, &field, terms, ws);
    if !terms.stiffness {
        ws.stiffness.fill(T::zero());
    }
    if !velocity_field {
        ws.damping.fill(T::zero());
    }
    for i in 0..n {
        ws.force[i] -= p.stiffness[i] * (q[i] - p.natural[i]) + p.friction[i] * v[i];
        ws.stiffness[i][i] -= p.stiffness[i];
        ws.damping[i][i] -= p.friction[i];
    }
    // the point loads' force and (unless the field stiffness is explicit) stiffness
    let loaded = !p.loads.is_empty();
    if loaded {
        let shape = p.shape();
        let WorkView {
            force,
            stiffness,
            points,
            ..
        } = &mut *ws;
        point_load::add_terms(
            p.loads,
            source,
            &shape,
            &input.head.rotation,
            q,
            points,
            force,
            (!explicit).then_some(stiffness),
        );
    }
    // a held tip: the holder's reaction of the last step pulls on the tip as a point
    // load at s = L would (its stiffness f · ∂²y(L)/∂q²), and a clamped tip's torque
    // through the turning of its frame; its force is the multipliers'
    let held = end.is_some();
    let mut held_stiffness = false;
    if let (Some(end), false) = (end, explicit) {
        let shape = p.shape();
        let f = end.tip_force(&input.head);
        if f != Vector3::zeros() {
            source.point(
                &shape,
                q,
                p.length(),
                &mut ws.points,
                Some((f, &mut ws.stiffness)),
            );
            held_stiffness = true;
        }
        let mut points = PointsOf {
            source: &mut *source,
            shape,
            scratch: &mut ws.points,
        };
        held_stiffness |= end.add_stiffness(&mut points, q, &mut ws.stiffness);
    }
    // the contacts' force, stiffness and damping at the step's end (time t)
    let touching = match contacts {
        Some((c, t)) => c.add_terms(
            &mut PointsOf {
                source: &mut *source,
                shape: p.shape(),
                scratch: &mut ws.points,
            },
            q,
            v,
            t,
            &input.head,
            !explicit,
            ws.force,
            &mut ws.stiffness,
            &mut ws.damping,
        ),
        None => false,
    };
    // with the field stiffness explicit, only the contacts' stiffness is in the matrix
    let field_stiffness = if explicit {
        touching
    } else {
        position_field || touching || loaded || held_stiffness
    };
    (field_stiffness, touching || loaded || held)
}

/// Advance `strand` by `h` seconds: one linearly implicit Euler step (paper section
/// 3.4) with the runtime's treatment of its terms,
///
/// ```text
/// (M − h D_v + (h/2) B − h² D_q) q̇⁺ = M q̇ + h (F + b) − h D_v q̇,   q⁺ = q + h q̇⁺
/// ```
///
/// D_q = H⁻ − K with H⁻ the negative semidefinite part of the symmetrised field
/// stiffness (a destabilising stiffness stays explicit), D_v = ∂F/∂q̇ less ∂b/∂q̇
/// (friction, drag, Coriolis), and b ≈ ½ B q̇⁺ taken semi-implicitly (B = ∂b/∂q̇).
/// This is the step without checks after the fact: [`super::adaptive::step`] adds the
/// runtime's (energy balance, splitting a step that rotates an element too far), which
/// a strand on a moving head needs at game time steps. Without them, keep
/// `max_element_rotation` of the report below ~0.2 by the choice of h. Allocates
/// nothing; on failure the strand keeps its state.
pub fn linearly_implicit<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    input: &StepInput,
    h: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
) -> Result<StepReport, StepError> {
    linearly_implicit_with(source, strand, input, h, ws, None)
}

/// [`linearly_implicit`] with contacts: their terms at the step's start state with the
/// colliders placed at the step's end, time `t` (`contacts = Some((hooks, t))`).
pub fn linearly_implicit_with<
    'c,
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &mut FixedStrand<N, D, B, T>,
    input: &StepInput,
    h: f64,
    ws: &mut FixedWorkspace<N, D, E, T>,
    contacts: Option<(&mut (dyn ContactHooks<T> + 'c), f64)>,
) -> Result<StepReport, StepError> {
    let mut ws = ws.view();
    let stack = ws.take_stack();
    let t_end = contacts.as_ref().map_or(0.0, |(_, t)| *t);
    solve_step(
        &mut &*source,
        &mut strand.view(),
        input,
        (h, t_end),
        &mut ws,
        stack,
        contacts,
    )
}

/// The linearly implicit Euler step of [`linearly_implicit_with`] on any storage (`stack`:
/// at least two vectors of n), of `h` seconds ending at `t_end` (where a held tip's
/// holder is, [`StrandView::end`]).
pub(crate) fn solve_step<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    input: &StepInput,
    (h, t_end): (f64, f64),
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
    contacts: Option<(&mut (dyn ContactHooks<T> + 'c), f64)>,
) -> Result<StepReport, StepError> {
    if !(h.is_finite() && h > 0.0) {
        return Err(StepError::TimeStep);
    }
    let n = crate::storage::sized::<NC>(strand.dofs());
    let h_f64 = h;
    let h = T::of(h);
    let mut contacts = contacts;
    let (field_stiffness, loaded) = assemble(
        source,
        &strand.params,
        strand.q,
        strand.v,
        input,
        ws,
        contacts.as_mut().map(|(c, t)| (&mut **c, *t)),
        strand.end.as_deref_mut(),
    );
    let (q_new, stack) = stack.split_at_mut(n);
    let (projection, _) = step_matrix(strand, field_stiffness, loaded, h, ws, stack);
    let p = &strand.params;
    let (q, v) = (&mut *strand.q, &mut *strand.v);
    for i in 0..n {
        ws.rhs[i] = h * (ws.force[i] + ws.velocity_term[i]);
    }
    let mass = &*ws.assembly.mass;
    for j in 0..n {
        let vj = v[j];
        let (mass_j, damping_j) = (&mass[j * n..j * n + n], &ws.damping[j]);
        for i in 0..n {
            ws.rhs[i] += (mass_j[i] - h * damping_j[i]) * vj;
        }
    }
    let factored = scaled_lu_solve::<T, NC>(&mut ws.matrix_a, ws.rhs, ws.pivots, p.scale);
    *ws.factors_piece = if factored { h_f64 } else { 0.0 };
    if !factored {
        return Err(StepError::SingularMatrix);
    }
    if let Some(end) = strand.end.as_deref_mut() {
        // the held tip's multipliers on the same factors
        let mut points = PointsOf {
            source: &mut *source,
            shape: p.shape(),
            scratch: &mut ws.points,
        };
        let (a, pivots) = (&ws.matrix_a, &*ws.pivots);
        let mut solve = |x: &mut [f64]| solve_factored_f64(a, pivots, p.scale, x, stack);
        end.constrain(&mut points, &mut solve, q, ws.rhs, t_end, h_f64)
            .map_err(StepError::Held)?;
    }
    q_new.copy_from_slice(q);
    for i in 0..n {
        q_new[i] += h * ws.rhs[i];
    }
    let mut contacts_predicted = 0;
    if let Some((c, t)) = contacts {
        // the contacts that start within the step, predicted along the solution and
        // resolved on the step's factors
        c.predict(q, q_new, t, &input.head);
        let (a, pivots, v_new) = (&ws.matrix_a, &*ws.pivots, &mut *ws.rhs);
        let mut solve = |x: &mut [f64]| solve_factored_f64(a, pivots, p.scale, x, stack);
        let map = Some((h_f64, h_f64));
        let mut points = PointsOf {
            source: &mut *source,
            shape: p.shape(),
            scratch: &mut ws.points,
        };
        contacts_predicted = c
            .resolve(&mut points, q_new, v_new, map, t, &input.head, &mut solve)
            .map_err(|_| StepError::SingularMatrix)?;
    }
    if p.free_root() && strand.end.is_none() {
        // a free root's momentum changes by the step's impulse, the contacts that start
        // within the step included
        let target = free_root::momentum_target(&*ws, &*ws.rhs, h);
        let v_new = &mut stack[..n];
        v_new.copy_from_slice(ws.rhs);
        free_root::correct_momentum(source, p, q_new, v_new, target, ws);
        ws.rhs.copy_from_slice(v_new);
    }
    if let Some(end) = strand.end.as_deref_mut() {
        // the drift the linearised constraint leaves, projected out
        let mut points = PointsOf {
            source: &mut *source,
            shape: p.shape(),
            scratch: &mut ws.points,
        };
        end.project(&mut points, q_new, t_end)
            .map_err(StepError::Held)?;
    }
    if let Some(i) = q_new.iter().position(|x| !x.is_finite()) {
        return Err(StepError::NonFinite {
            index: i,
            velocity: false,
        });
    }
    let rotation = max_element_rotation(p.lengths, q_new, q);
    q.copy_from_slice(q_new);
    v.copy_from_slice(ws.rhs);
    Ok(StepReport {
        max_element_rotation: rotation.as_f64(),
        projection,
        contacts_predicted,
        loaded,
    })
}

/// The matrix of a linearly implicit Euler step of `h` seconds from the strand's state
/// (its terms with the head in `input.head`, the contacts' at `t_end`), factored in
/// `ws` as a linearly implicit piece's (`WorkView::factors_piece` = h, what
/// `HeapWorkspace::last_factors` lends): what a caller that solves on the step's matrix
/// after a step whose own solve left other factors (BDF2's, Newton's Jacobian) needs —
/// the pair solve of hair–hair contacts. The strand's q and q̇ are not changed (its
/// projection basis may be). False when the matrix is singular.
pub fn factor_step_views<'c, S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    strand: &mut StrandView<'_, T>,
    input: &StepInput,
    (h, t_end): (f64, f64),
    mut ws: WorkView<'_, T, NC>,
    contacts: Option<&mut (dyn ContactHooks<T> + 'c)>,
) -> bool {
    *ws.factors_piece = 0.0;
    if !(h.is_finite() && h > 0.0) {
        return false;
    }
    let n = crate::storage::sized::<NC>(strand.dofs());
    let stack = ws.take_stack();
    let (field_stiffness, loaded) = assemble(
        source,
        &strand.params,
        strand.q,
        strand.v,
        input,
        &mut ws,
        contacts.map(|c| (c, t_end)),
        strand.end.as_deref_mut(),
    );
    step_matrix(strand, field_stiffness, loaded, T::of(h), &mut ws, stack);
    ws.rhs[..n].fill(T::zero());
    let factored =
        scaled_lu_solve::<T, NC>(&mut ws.matrix_a, ws.rhs, ws.pivots, strand.params.scale);
    if factored {
        *ws.factors_piece = h;
    }
    factored
}

/// Largest l_Q |Δd_Q| between two states.
pub(crate) fn max_element_rotation<T: Float>(lengths: &[T], q: &[T], q0: &[T]) -> T {
    lengths
        .iter()
        .enumerate()
        .map(|(k, &l)| {
            let d: T = (0..3)
                .map(|i| (q[3 * k + i] - q0[3 * k + i]) * (q[3 * k + i] - q0[3 * k + i]))
                .sum();
            l * d.sqrt()
        })
        .fold(T::zero(), T::max)
}

/// `A x = b` in place for an f64 `b` (n long) with the step's factors in `T` (the
/// columns of the contacts that start within a step, a held tip's multipliers), the
/// factors those of `S A S` for a coordinate scale S (`scale`, empty: none, see
/// [`ParamsView::scale`]); `scratch` at least n long.
pub(crate) fn solve_factored_f64<T: Float>(
    a: &Square<'_, T>,
    pivots: &[usize],
    scale: &[T],
    x: &mut [f64],
    scratch: &mut [T],
) -> bool {
    let b = &mut scratch[..x.len()];
    for (bi, xi) in b.iter_mut().zip(x.iter()) {
        *bi = T::of(*xi);
    }
    let ok = scaled_solve_factored(a, pivots, scale, b);
    for (xi, bi) in x.iter_mut().zip(b.iter()) {
        *xi = bi.as_f64();
    }
    ok
}

/// `A x = b` in place with the LU factors of `S A S` (`scale` S, empty: none): `b ← S b`,
/// the solve, `x ← S y`.
fn scaled_solve_factored<T: Float>(
    a: &Square<'_, T>,
    pivots: &[usize],
    scale: &[T],
    b: &mut [T],
) -> bool {
    scale_vector(b, scale);
    let ok = lu_solve_factored(a, pivots, b);
    scale_vector(b, scale);
    ok && b.iter().all(|x| x.is_finite())
}

/// `b ← S b` (nothing for an empty `scale`).
fn scale_vector<T: Float>(b: &mut [T], scale: &[T]) {
    for (x, s) in b.iter_mut().zip(scale) {
        *x *= *s;
    }
}

/// Factor the step matrix `S A S` that [`step_matrix`] left in `a` (`scale` S, empty:
/// none) and solve `A x = b` in place: `b ← S b`, the LU solve, `x ← S y`. False when the
/// matrix is singular or the solution not finite.
pub(crate) fn scaled_lu_solve<T: Float, const NC: usize>(
    a: &mut Square<'_, T>,
    b: &mut [T],
    pivots: &mut [usize],
    scale: &[T],
) -> bool {
    if scale.is_empty() {
        return lu_solve_sized::<T, NC>(a, b, pivots);
    }
    scale_vector(b, scale);
    let ok = lu_solve_sized::<T, NC>(a, b, pivots);
    scale_vector(b, scale);
    ok && b.iter().all(|x| x.is_finite())
}

/// The step matrix `M − h D_v + (h/2) B − h² D_q` of the terms `assemble` left in `ws`
/// into `ws.matrix_a` (D_q = H⁻ − K, H⁻ the negative semidefinite part of the
/// symmetrised field stiffness when `field_stiffness`, by the dissipative split of
/// [`crate::field_split`] or the spectral projection, `ws.field_rule`; `ws.stiffness`
/// then holds that part; `stack` at least one vector of n).
/// Returns how H⁻ was found and whether it is in the matrix (not when the projection
/// failed).
pub(crate) fn step_matrix<T: Float, const NC: usize>(
    strand: &mut StrandView<'_, T>,
    field_stiffness: bool,
    loaded: bool,
    h: T,
    ws: &mut WorkView<'_, T, NC>,
    stack: &mut [T],
) -> (Option<Projection>, bool) {
    let n = crate::storage::sized::<NC>(strand.dofs());
    let half = T::of(0.5);
    let p = &strand.params;
    let projection = if field_stiffness {
        // H = sym(stiffness) + K, projected onto its negative semidefinite part
        let st = &mut ws.stiffness;
        for j in 0..n {
            for i in 0..j {
                let m = half * (st[i][j] + st[j][i]);
                st[i][j] = m;
                st[j][i] = m;
            }
            st[j][j] += p.stiffness[j];
        }
        let explicit = *ws.field_rule == FieldRule::Explicit;
        // a strand without internal friction or drag keeps the projection, and so does one
        // that touches or carries point loads (see crate::field_split)
        let split = if ws.field_rule.splits(p.dissipative()) && !loaded {
            // the metric of the step matrix's diagonal, M_jj/h² + K_j
            let inv_h2 = T::one() / (h * h);
            let metric = &mut stack[..n];
            for j in 0..n {
                metric[j] = ws.assembly.mass[j * n + j] * inv_h2 + p.stiffness[j];
            }
            dissipative_split(
                n,
                ws.stiffness.as_mut_slice(),
                metric,
                ws.split_work.as_mut_slice(),
                ws.split_scale,
                ws.split_order,
            )
        } else {
            SplitOutcome::Beyond
        };
        Some(match split {
            // the contacts' stiffness along their Jacobians alone: negative semidefinite
            // as it is
            _ if explicit => Projection::Unprojected,
            SplitOutcome::Whole => Projection::Whole,
            SplitOutcome::Shifted => Projection::Shifted,
            SplitOutcome::Beyond => {
                // projected in the coordinates' scale: S H S
                scale_square(&mut ws.stiffness, p.scale, false);
                let outcome = project::<T, NC>(
                    &mut ws.stiffness,
                    strand.basis,
                    strand.basis_k,
                    strand.basis_negative,
                    &mut ws.projection,
                );
                scale_square(&mut ws.stiffness, p.scale, true);
                outcome
            }
        })
    } else {
        None
    };
    let use_h = matches!(projection, Some(p) if p != Projection::Failed);
    let mass = &*ws.assembly.mass;
    for j in 0..n {
        let (a, st, d, b) = (
            &mut ws.matrix_a[j],
            &ws.stiffness[j],
            &ws.damping[j],
            &ws.velocity_jacobian[j],
        );
        let m = &mass[j * n..j * n + n];
        for i in 0..n {
            let mut dq = if use_h { st[i] } else { T::zero() };
            if i == j {
                dq -= p.stiffness[i];
            }
            a[i] = m[i] - h * d[i] + half * h * b[i] - h * h * dq;
        }
    }
    // solved in the coordinates' scale: S A S ([`scaled_lu_solve`])
    scale_square(&mut ws.matrix_a, p.scale, false);
    (projection, use_h)
}

/// `m_ij ← m_ij · s_i s_j`, or `/` with `inverse` (nothing for an empty `scale`).
fn scale_square<T: Float>(m: &mut Square<'_, T>, scale: &[T], inverse: bool) {
    for (j, &sj) in scale.iter().enumerate() {
        for (x, &si) in m[j].iter_mut().zip(scale) {
            let f = si * sj;
            *x = if inverse { *x / f } else { *x * f };
        }
    }
}

/// The centreline at the N + 1 element ends, root first, in head coordinates (metres),
/// from the element points of `source`.
pub fn centreline<
    S: MomentSource<T>,
    const N: usize,
    const D: usize,
    const E: usize,
    const B: usize,
    T: Float,
>(
    source: &S,
    strand: &FixedStrand<N, D, B, T>,
    ends: &mut [Pose<T>; E],
) {
    element_ends(source, &strand.params.shape(), &strand.q, ends);
}

/// Replace the symmetric `h` by its negative semidefinite part as the runtime's step does:
/// the same input as the last call of this step gives the last result; −H positive
/// definite leaves H; otherwise the shared partial eigendecomposition
/// ([`crate::projection`]), reusing the strand's kept basis while it splits H, and the
/// full Jacobi decomposition when that fails its checks.
fn project<T: Float, const NC: usize>(
    h: &mut Square<'_, T>,
    basis: &mut [T],
    basis_k: &mut usize,
    basis_negative: &mut bool,
    p: &mut ProjectionView<'_, T>,
) -> Projection {
    let n = h.n();
    let repeated = *p.last_valid
        && (0..n).all(|j| {
            h[j][j..]
                .iter()
                .zip(&p.last_input[j][j..])
                .all(|(a, b)| a.same_bits(*b))
        });
    if repeated {
        h.copy_from(&p.last_output);
        return Projection::Repeated;
    }
    for j in 0..n {
        p.last_input[j][j..].copy_from_slice(&h[j][j..]);
    }
    let outcome = project_uncached::<T, NC>(h, basis, basis_k, basis_negative, p);
    *p.last_valid = outcome != Projection::Failed;
    if *p.last_valid {
        p.last_output.copy_from(h);
    }
    outcome
}

/// [`project`] without the repeat check.
fn project_uncached<T: Float, const NC: usize>(
    h: &mut Square<'_, T>,
    basis: &mut [T],
    basis_k: &mut usize,
    basis_negative: &mut bool,
    p: &mut ProjectionView<'_, T>,
) -> Projection {
    let n = h.n();
    for j in 0..n {
        for i in j..n {
            p.dense[j][i] = -h[j][i];
        }
    }
    if cholesky(p.dense.as_mut_slice(), n) {
        return Projection::Definite;
    }
    for j in 0..n {
        for i in j..n {
            p.dense[j][i] = h[j][i];
            p.dense[i][j] = h[j][i];
        }
    }
    let spectral = SpectralProjection::<T, NC>::new(
        n,
        ProjectionBasis {
            vectors: basis,
            k: basis_k,
            negative: basis_negative,
        },
        ProjectionScratch::on(
            n,
            p.a.as_mut_slice(),
            p.vectors,
            p.pivot,
            (p.hu.as_mut_slice(), p.coupling.as_mut_slice(), p.rotated),
        ),
    );
    if let Some(mut spectral) = spectral {
        match spectral.negative_part(p.dense.as_mut_slice()) {
            ProjectionOutcome::Failed => spectral.forget_basis(),
            outcome => {
                h.copy_from(&p.dense);
                return if outcome == ProjectionOutcome::Reused {
                    Projection::Reused
                } else {
                    Projection::Decomposed
                };
            }
        }
    }
    negative_semidefinite_part(h, &mut p.eigen, p.eigenvalues)
}

//! What the step of one strand works on: the [`StrandSystem`] (strand, kernel, buffers,
//! step context), its [`StrandState`] (q, q̇), the [`HeadInterval`] of the step (the
//! head's state at its two ends, computed once), and the shared assembly of the full
//! force F(q, q̇) and of the linearly implicit step matrix that every integrator and the
//! static solve build on.
//!
//! Each strand owns a [`StrandWorkspace`] sized once: a step allocates nothing.

use super::dense_solve::DenseSolver;
use crate::bodies::Placement;
use crate::config::IntegratorKind;
use crate::forces::contacts::StrandContacts;
use crate::forces::effects::{body_field, GlobalEffects};
use crate::forces::head_motion::{HeadMotion, HeadState};
use crate::forces::point_loads::{add_point_loads, point_load_potential};
use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::kernels::step_terms::KernelPoints;
use crate::model::strand::Strand;
use nalgebra::Vector3;
use superhelix_kernels::energy::StateEnergy;

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
    pub(super) scratch: [Vec<f64>; 6],
    /// BDF2 history: the state one step back and that step's length (0: none).
    pub(super) prev_q: Vec<f64>,
    pub(super) prev_v: Vec<f64>,
    pub(super) prev_h: f64,
    /// The energy of the state the last implicit step ended in, and that state.
    pub(super) last_energy: Option<StateEnergy>,
    /// The contact part of the last energy measured: the contact potential and its rate
    /// (with the drag power of bodies on their own motion) as
    /// the one step's energy measure counted them (`superhelix_kernels::fixed`'s
    /// contact hooks, [`super::contact_hook`]).
    pub(super) last_contact: (f64, f64),
    pub(super) last_q: Vec<f64>,
    pub(super) last_v: Vec<f64>,
    /// How many times the next step is halved before it is first tried
    /// ([`superhelix_kernels::energy::predicted_split_levels`] of the last step; used
    /// only when the next step continues from its end, `last_energy`).
    pub(super) split_hint: usize,
    /// The error-controlled step's state ([`super::error_control`]).
    pub(super) error_control: super::error_control::ErrorControl,
    /// The one step's factors of its last linearly implicit piece, kept for the pair solve
    /// of a strand in pairs of `coupling = "pair"` ([`super::one_step`]).
    pub(super) one_step_factors: OneStepFactors,
    /// Scratch of the one step's terms ([`crate::kernels::step_terms::KernelTerms`]).
    pub(super) flat: Vec<f64>,
}

/// The LU factors of the step matrix `S A S` of a strand's last linearly implicit piece
/// on the one step (`HeapWorkspace::last_factors`), with the piece's length and the
/// coordinates' scale S (empty: none), copied out of the thread's workspace after the
/// step for the pair solve ([`super::pair_coupling`]).
#[derive(Debug, Clone, Default)]
pub(super) struct OneStepFactors {
    /// The piece's length, s (0: no factors kept).
    pub piece: f64,
    /// The factors are those of the step's own last solve (not the linearly implicit
    /// matrix at its end, factored after a BDF2 or Newton solve).
    pub own: bool,
    lu: Vec<f64>,
    pivots: Vec<usize>,
    scale: Vec<f64>,
}

impl OneStepFactors {
    /// Keep `factors` (`HeapWorkspace::last_factors`; none: forget) with `scale`.
    pub fn keep(&mut self, factors: Option<(f64, &[f64], &[usize])>, scale: &[f64], own: bool) {
        match factors {
            Some((piece, lu, pivots)) => {
                self.piece = piece;
                self.own = own;
                self.lu.clear();
                self.lu.extend_from_slice(lu);
                self.pivots.clear();
                self.pivots.extend_from_slice(pivots);
                self.scale.clear();
                self.scale.extend_from_slice(scale);
            }
            None => self.piece = 0.0,
        }
    }

    /// `A x = b` in place (`b` becomes x) with the factors of `S A S`: `b ← S b`, the
    /// two triangular solves, `x ← S y`. False when none are kept or x is not finite.
    pub fn solve(&mut self, b: &mut [f64]) -> bool {
        let n = self.pivots.len();
        if self.piece <= 0.0 || b.len() != n {
            return false;
        }
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        let Some(a) = superhelix_kernels::storage::Square::new(&mut self.lu, n) else {
            return false;
        };
        let ok = superhelix_kernels::fixed::lu_solve_factored(&a, &self.pivots, b);
        for (x, s) in b.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        ok && b.iter().all(|x| x.is_finite())
    }
}

impl StrandWorkspace {
    /// Buffers for this strand.
    pub fn new(strand: &Strand) -> Self {
        let n = strand.geometry.dofs();
        let friction = strand.friction_diagonal();
        StrandWorkspace {
            terms: StrandTerms::new(n),
            solver: DenseSolver::new(n).with_scale(strand.solver_scale()),
            jac: vec![Vector3::zeros(); n],
            stiffness: strand.stiffness_diagonal(),
            friction,
            scratch: std::array::from_fn(|_| vec![0.0; n]),
            prev_q: vec![0.0; n],
            prev_v: vec![0.0; n],
            prev_h: 0.0,
            last_energy: None,
            last_contact: (0.0, 0.0),
            last_q: vec![0.0; n],
            last_v: vec![0.0; n],
            split_hint: 0,
            error_control: super::error_control::ErrorControl::default(),
            one_step_factors: OneStepFactors::default(),
            flat: Vec::new(),
        }
    }

    /// The error-controlled step's state and statistics.
    pub fn error_control(&self) -> &super::error_control::ErrorControl {
        &self.error_control
    }

    /// The error-controlled step's state, to take its window of steps.
    pub fn error_control_mut(&mut self) -> &mut super::error_control::ErrorControl {
        &mut self.error_control
    }

    /// The strand's loads' Σ f_l · y_l at its state grew by `change` (J) without it moving
    /// (the Coulomb forces updated): the energy its last step ended with and that
    /// energy's ceiling as the new loads count them ([`shift_load_energy`]).
    pub fn shift_load_energy(&mut self, change: f64) {
        if let Some(e) = &mut self.last_energy {
            shift_load_energy(e, change);
        }
    }

    /// Forget the state history of the two-step integrator (BDF2): its next step starts
    /// afresh, with a linearly implicit Euler step. Call it whenever the state is set
    /// from outside the integrator.
    pub fn forget_history(&mut self) {
        self.prev_h = 0.0;
    }

    /// Forget the energy the last step ended with: the next step measures it afresh
    /// (a load changed between two steps, which is no work the strand did).
    pub fn forget_energy(&mut self) {
        self.last_energy = None;
    }

    /// What the next step needs of these buffers (see [`WorkspaceState`]).
    pub fn state(&self) -> WorkspaceState {
        let (basis, basis_negative) = self.solver.projection_basis();
        WorkspaceState {
            prev_q: self.prev_q.clone(),
            prev_v: self.prev_v.clone(),
            prev_h: self.prev_h,
            last_energy: self.last_energy.as_ref().map(energy_words),
            last_contact: self.last_contact,
            last_q: self.last_q.clone(),
            last_v: self.last_v.clone(),
            split_hint: self.split_hint,
            error_control: self.error_control.state(),
            basis,
            basis_negative,
        }
    }

    /// Continue from `state`; an error when its sizes are not this strand's.
    pub fn restore(&mut self, state: WorkspaceState) -> Result<(), String> {
        let n = self.prev_q.len();
        let sizes = [
            state.prev_q.len(),
            state.prev_v.len(),
            state.last_q.len(),
            state.last_v.len(),
        ];
        if sizes.iter().any(|&len| len != n) {
            return Err(format!(
                "step buffers of {} coordinates in the checkpoint, {n} in the scene",
                state.prev_q.len()
            ));
        }
        if !self
            .solver
            .set_projection_basis(&state.basis, state.basis_negative)
        {
            return Err(format!(
                "a projection basis of {} values for {n} coordinates",
                state.basis.len()
            ));
        }
        self.prev_q = state.prev_q;
        self.prev_v = state.prev_v;
        self.prev_h = state.prev_h;
        self.last_energy = state.last_energy.as_ref().map(energy_from_words);
        self.last_contact = state.last_contact;
        self.last_q = state.last_q;
        self.last_v = state.last_v;
        self.split_hint = state.split_hint;
        self.error_control.restore(state.error_control);
        Ok(())
    }
}

/// What a strand's step buffers carry from one step to the next (a checkpoint's part):
/// the two-step integrator's previous state and step, the last step's end (its energy,
/// contact energy, state), the split hint, the error-controlled
/// step's sizes and the stiffness projection's kept basis. The other buffers are
/// overwritten before they are read within each step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WorkspaceState {
    prev_q: Vec<f64>,
    prev_v: Vec<f64>,
    prev_h: f64,
    last_energy: Option<[f64; ENERGY_WORDS]>,
    last_contact: (f64, f64),
    last_q: Vec<f64>,
    last_v: Vec<f64>,
    split_hint: usize,
    error_control: super::error_control::ErrorControlState,
    basis: Vec<f64>,
    basis_negative: bool,
}

/// `e` as loads whose Σ f_l · y_l at its state is `change` (J) higher count it: V and the
/// ceiling lower by `change` (V = −c0 · ∫ y ds − Σ f_l · y_l), so that the energy
/// balance's bound of the next step moves with the loads (their change is not work).
pub fn shift_load_energy(e: &mut StateEnergy, change: f64) {
    e.potential -= change;
    e.load_moment += change;
    e.ceiling -= change;
}

/// Number of values of a [`StateEnergy`] as [`energy_words`] writes it.
pub const ENERGY_WORDS: usize = 16;

/// A [`StateEnergy`] as plain values (what a checkpoint writes), in the order of its fields.
pub fn energy_words(e: &StateEnergy) -> [f64; ENERGY_WORDS] {
    [
        e.time,
        e.kinetic,
        e.elastic,
        e.potential,
        e.moment.x,
        e.moment.y,
        e.moment.z,
        e.uniform.x,
        e.uniform.y,
        e.uniform.z,
        e.power,
        e.load_moment,
        e.load_rate,
        e.dissipation,
        e.ceiling,
        e.scale,
    ]
}

/// The [`StateEnergy`] of [`energy_words`]'s values.
pub fn energy_from_words(w: &[f64; ENERGY_WORDS]) -> StateEnergy {
    StateEnergy {
        time: w[0],
        kinetic: w[1],
        elastic: w[2],
        potential: w[3],
        moment: Vector3::new(w[4], w[5], w[6]),
        uniform: Vector3::new(w[7], w[8], w[9]),
        power: w[10],
        load_moment: w[11],
        load_rate: w[12],
        dissipation: w[13],
        ceiling: w[14],
        scale: w[15],
    }
}

/// What every strand's step shares: the world's effects and the integrator.
#[derive(Debug, Clone, Copy)]
pub struct StepContext {
    /// Global effects.
    pub effects: GlobalEffects,
    /// The time integrator.
    pub integrator: IntegratorKind,
    /// The deepest split of an implicit step, 0 to
    /// [`MAX_SUBSTEP_DEPTH`](superhelix_kernels::energy::MAX_SUBSTEP_DEPTH).
    pub max_split_depth: usize,
    /// Whether the step's matrix holds only the contacts' stiffness along the Jacobian
    /// ([`crate::config::FieldStiffness::Explicit`]), unprojected.
    pub explicit_field_stiffness: bool,
    /// Whether the field stiffness goes into the step's matrix by the dissipative split
    /// ([`superhelix_kernels::field_split`], the spectral projection its fallback) or by
    /// the projection alone ([`crate::config::FieldStiffness`]).
    pub field_split: bool,
    /// Whether implicit steps are checked against the energy balance
    /// ([`crate::config::SimulationConfig::energy_balance`]).
    pub energy_balance: bool,
    /// The error-controlled step's tolerance
    /// ([`crate::config::SimulationConfig::tolerance`]; `None`: fixed steps).
    pub tolerance: Option<f64>,
}

/// The state of one strand: generalized coordinates q and velocities q̇ (3N each).
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct StrandState {
    /// q, rad/m.
    pub q: Vec<f64>,
    /// q̇, rad/(m·s).
    pub v: Vec<f64>,
}

/// One strand's system: what travels together through its steps (the strand, its
/// kernel, its buffers, the step context).
pub struct StrandSystem {
    /// The strand.
    pub strand: Strand,
    /// Its kernel.
    pub kernel: Box<dyn StrandKernel>,
    /// Its buffers.
    pub workspace: StrandWorkspace,
    /// The effects and integrator of its steps.
    pub context: StepContext,
    /// Its contacts with bodies and other strands (`None`: the scene has no `[contacts]`).
    pub contacts: Option<StrandContacts>,
    /// Its held tip (`None`: a free tip).
    pub held: Option<super::held_end::HeldTip>,
}

impl StrandSystem {
    /// The system of `strand` on `kernel`, its buffers sized once.
    pub fn new(strand: Strand, kernel: Box<dyn StrandKernel>, context: StepContext) -> Self {
        StrandSystem {
            workspace: StrandWorkspace::new(&strand),
            strand,
            kernel,
            context,
            contacts: None,
            held: None,
        }
    }

    /// Evaluate the strand's full force F(q, q̇) (kernel terms, elasticity −K(q − q_n),
    /// internal friction −γ l q̇, point loads Jᵀ f, contacts) with the head and the bodies
    /// placed at `at`, and the requested Jacobians, into `workspace.terms`: `stiffness` =
    /// ∂F/∂q (less ∂b/∂q), `damping` = ∂F/∂q̇ (less ∂b/∂q̇, which is in
    /// `velocity_term_jacobian`).
    pub fn assemble(&mut self, at: &Placement, q: &[f64], v: &[f64], terms: Terms) {
        let head = &at.head;
        let StrandSystem {
            strand,
            kernel,
            workspace: ws,
            context: ctx,
            contacts,
            held,
        } = self;
        let kernel = kernel.as_mut();
        let field = body_field(
            &ctx.effects,
            head,
            strand.material.mass_per_length,
            strand.air_drag,
        );
        // the kernel computes only what the scene's effects make non-zero
        let position_field = field.uniform != Vector3::zeros() || field.has_linear();
        let velocity_field = field.velocity != nalgebra::Matrix3::zeros();
        let explicit = ctx.explicit_field_stiffness;
        let kernel_terms = Terms {
            stiffness: terms.stiffness && position_field && !explicit,
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
        add_point_loads(
            &strand.point_loads,
            &head.rotation,
            &strand.geometry,
            kernel,
            q,
            &mut ws.jac,
            Terms {
                stiffness: terms.stiffness && !explicit,
                ..terms
            },
            t,
        );
        if let (Some(held), true) = (held.as_mut(), terms.stiffness && !explicit) {
            // the holder's reaction (of the last step or static iteration) pulls on the
            // tip as a point load would: its stiffness f · ∂²y(L)/∂q² (the tension's
            // geometric stiffness) goes into the matrix; its force is the multipliers'
            let f = head.rotation.transpose() * held.reaction_force();
            if f != Vector3::zeros() {
                kernel.point(
                    q,
                    strand.geometry.length(),
                    &mut ws.jac,
                    Some((f, &mut t.stiffness)),
                );
            }
            // and a clamped tip's torque, through the turning of the tip's frame (the head
            // is still under a held tip: head and world coordinates agree)
            if held.end.kind.holds_frame() && held.reaction.fixed_rows::<3>(3).norm() > 0.0 {
                held.add_torque_stiffness(
                    &mut KernelPoints(kernel),
                    &strand.geometry,
                    q,
                    &mut |i, j, x| t.stiffness[(i, j)] += x,
                );
            }
        }
        if let Some(c) = contacts {
            c.add_to_terms(
                at,
                kernel,
                &strand.geometry,
                q,
                v,
                terms,
                !explicit,
                &mut ws.jac,
                t,
            );
        }
    }

    /// Kinetic energy ½ q̇ᵀ M(q) q̇ (relative to the head).
    pub fn kinetic_energy(&mut self, q: &[f64], v: &[f64]) -> f64 {
        self.energy_parts(q, v).0
    }

    /// Total energy T + U + V (gravity and point loads; with a still head), for tests and
    /// diagnostics.
    pub fn energy(&mut self, q: &[f64], v: &[f64]) -> f64 {
        let (kinetic, potential) = self.energy_parts(q, v);
        kinetic + potential
    }

    /// (T, U + V) of [`StrandSystem::energy`].
    fn energy_parts(&mut self, q: &[f64], v: &[f64]) -> (f64, f64) {
        let StrandSystem {
            strand,
            kernel,
            workspace: ws,
            context: ctx,
            contacts,
            ..
        } = self;
        let kernel = kernel.as_mut();
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
        let loads = point_load_potential(&strand.point_loads, kernel, q, &mut ws.jac);
        let touching = contacts.as_mut().map_or(0.0, |c| {
            c.energy(&Placement::at_rest(0.0), &strand.geometry, q).0
        });
        (kinetic, elastic + gravity + loads + touching)
    }
}

/// One (sub)step's time interval [t, t + h] and the head's state at its two ends, each
/// computed once; halved by [`HeadInterval::first_half`] and
/// [`HeadInterval::second_half`] when the step is split.
#[derive(Debug, Clone, Copy)]
pub struct HeadInterval<'a> {
    /// The head's motion, for the states inside the interval.
    pub motion: &'a HeadMotion,
    /// Start time, s.
    pub t: f64,
    /// Length, s.
    pub h: f64,
    /// The head at t.
    pub start: HeadState,
    /// The head at t + h.
    pub end: HeadState,
    /// Whether the head moves uniformly over the interval
    /// ([`HeadMotion::uniform_over`]).
    pub uniform: bool,
    /// How many times the time step was halved to reach this interval.
    pub depth: usize,
}

impl<'a> HeadInterval<'a> {
    /// The interval [t, t + h] of a whole time step.
    pub fn new(motion: &'a HeadMotion, t: f64, h: f64) -> Self {
        HeadInterval {
            motion,
            t,
            h,
            start: motion.state(t),
            end: motion.state(t + h),
            uniform: motion.uniform_over(t, t + h),
            depth: 0,
        }
    }

    /// The head's state at t + c h.
    pub fn state_at(&self, c: f64) -> HeadState {
        self.motion.state(self.t + c * self.h)
    }

    /// The head and the bodies at t.
    pub fn at_start(&self) -> Placement {
        Placement::new(self.start, self.t)
    }

    /// The head and the bodies at t + h.
    pub fn at_end(&self) -> Placement {
        Placement::new(self.end, self.t + self.h)
    }

    /// The first half [t, t + h/2].
    pub fn first_half(&self) -> Self {
        let h = 0.5 * self.h;
        HeadInterval {
            h,
            end: self.motion.state(self.t + h),
            uniform: self.motion.uniform_over(self.t, self.t + h),
            depth: self.depth + 1,
            ..*self
        }
    }

    /// The second half, following `first` (this interval's [`HeadInterval::first_half`]):
    /// [t + h/2, t + h/2 + h/2], its end state this interval's when the end time is the
    /// same number.
    pub fn second_half(&self, first: &HeadInterval<'a>) -> Self {
        let t = first.t + first.h;
        let h = first.h;
        let end_time = t + h;
        HeadInterval {
            motion: self.motion,
            t,
            h,
            start: first.end,
            end: if end_time == self.t + self.h {
                self.end
            } else {
                self.motion.state(end_time)
            },
            uniform: self.motion.uniform_over(t, end_time),
            depth: first.depth,
        }
    }
}

//! Counters of what the solvers had to do, per strand and summed over a simulation.

/// Counters of what the solvers had to do.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    /// Implicit (sub)steps attempted, accepted or not: the linear solves of the step
    /// (a Newton step's iterations count once).
    pub attempts: usize,
    /// Of the splits, those for the energy balance ([`superhelix_kernels::energy`]):
    /// energy created, or, with the head moving uniformly, too much lost numerically
    /// ([`superhelix_kernels::energy::loss_ratio`]).
    pub energy_rejected: usize,
    /// Steps whose velocities were scaled down so that the energy does not exceed the
    /// start's plus the head's work (see [`superhelix_kernels::fixed::step_views`]).
    pub energy_limited: usize,
    /// Steps accepted at the deepest substep although their energy exceeds the balance
    /// (the potential energy alone above the bound, so that no velocity scaling can help).
    pub energy_unbalanced: usize,
    /// Steps taken at the deepest split allowed (`[simulation] max_split_depth`) that
    /// would have rotated an element by more than
    /// [`TRUSTED_ELEMENT_ROTATION`](superhelix_kernels::energy::TRUSTED_ELEMENT_ROTATION): their
    /// change of q and their velocities were scaled down to that rotation.
    pub rotation_limited: usize,
    /// Steps taken at the deepest split allowed whose end had more potential energy than
    /// the energy balance allows: their change of q was pulled back towards the start
    /// (no solve; [`superhelix_kernels::fixed::step_views`]).
    #[serde(default)]
    pub energy_pulled_back: usize,
    /// Contacts that started within a step and pushed in it (a sample that touched
    /// nothing at the step's start, found by the predicted test or at the solve's end,
    /// or one whose centreline ended inside a body: [`crate::forces::contacts::predicted`]),
    /// counted at each solve's first resolution.
    pub contacts_predicted: usize,
    /// Steps accepted by the error-controlled step (`[simulation] tolerance`:
    /// [`crate::solver::error_control`]).
    pub error_steps: usize,
    /// Steps the error-controlled step rejected and retried shorter.
    pub error_rejected: usize,
    /// Of those, steps rejected by the contacts' depth check (a sample deeper than
    /// `[contacts] split_depth` beyond its start's depth, whatever the error estimate).
    #[serde(default)]
    pub error_rejected_deep: usize,
    /// Sides of hair–hair pairs left without force in a step because their strand's
    /// step matrix made its compliance at one of its pairs indefinite (a whipping
    /// strand's gyroscopic terms outweighing its mass there;
    /// [`crate::solver::pair_coupling`]).
    #[serde(default)]
    pub pairs_indefinite: usize,
    /// Sides of hair–hair pairs left without force in a step because the pairs' solve
    /// did not converge ([`crate::solver::pair_coupling`]).
    #[serde(default)]
    pub pairs_unresolved: usize,
    /// Solves whose field stiffness went into the step's matrix by the dissipative split
    /// ([`superhelix_kernels::field_split`]: one L D Lᵀ factorisation), whole or less a
    /// low-rank part.
    #[serde(default)]
    pub field_split: usize,
    /// Solves whose field stiffness was projected by the spectral projection (the
    /// split's fallback, or `field_stiffness = "projected"`).
    #[serde(default)]
    pub field_projected: usize,
    /// Solves the rule `field_stiffness = "split"` keeps on the spectral projection: a
    /// strand without internal friction or air drag, or one that touches, is held or
    /// carries point loads ([`superhelix_kernels::field_split`]).
    #[serde(default)]
    pub field_undamped: usize,
}

impl StepStats {
    /// Add another's counts.
    pub fn add(&mut self, o: &StepStats) {
        self.stiffness_dropped += o.stiffness_dropped;
        self.newton_iterations += o.newton_iterations;
        self.newton_unconverged += o.newton_unconverged;
        self.substeps += o.substeps;
        self.attempts += o.attempts;
        self.energy_rejected += o.energy_rejected;
        self.energy_limited += o.energy_limited;
        self.energy_unbalanced += o.energy_unbalanced;
        self.rotation_limited += o.rotation_limited;
        self.energy_pulled_back += o.energy_pulled_back;
        self.contacts_predicted += o.contacts_predicted;
        self.error_steps += o.error_steps;
        self.error_rejected += o.error_rejected;
        self.error_rejected_deep += o.error_rejected_deep;
        self.pairs_indefinite += o.pairs_indefinite;
        self.pairs_unresolved += o.pairs_unresolved;
        self.field_split += o.field_split;
        self.field_projected += o.field_projected;
        self.field_undamped += o.field_undamped;
    }
}

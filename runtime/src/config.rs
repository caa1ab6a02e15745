//! The settings of a run and what a simulation is built from: plain data (the scene's
//! `[simulation]` table, the strands and their initial states, the head motion, the
//! bodies and the environment), and the step and frame counts that follow from it.

pub mod formats;

pub use formats::{Formats, OutputSettings};

use crate::bodies::BodySetup;
use crate::forces::environment::Environment;
use crate::forces::head_motion::HeadMotion;
use crate::kernels::generic::QuadratureRule;
use crate::model::strand::Strand;
use superhelix_kernels::energy::MAX_SUBSTEP_DEPTH;

/// Dynamic time stepping or static equilibrium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Time stepping.
    #[default]
    Dynamic,
    /// Equilibrium: ∇(U + V) = external forces, solved by Newton with a line search.
    Static,
}

/// What of the stiffness of the external forces the implicit step's matrix holds
/// (`[simulation] field_stiffness`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FieldStiffness {
    /// The stiffness of gravity and the head's fictitious forces by the dissipative split
    /// of `superhelix_kernels::field_split`: all of it when it is negative
    /// semidefinite, else H less a low-rank E ⪰ 0 along its positive directions (one
    /// L D Lᵀ factorisation of −H, no eigendecomposition). Where the factorisation
    /// breaks down, for strands without internal friction or drag, and for a strand that
    /// touches, is held or carries point loads, the projection of
    /// [`FieldStiffness::Projected`].
    Split,
    /// The same stiffness (and that of the point loads, the held ends and the contacts,
    /// with the curvature of the strand under their forces) projected on its negative
    /// semidefinite part by an eigendecomposition at every solve; default.
    #[default]
    Projected,
    /// Only the contacts' normal, friction and hair–hair stiffness along the strand's
    /// Jacobian (symmetric negative semidefinite as they are: no eigendecomposition);
    /// gravity, the fictitious forces, the point loads and the curvature terms act at the
    /// start of the step, as the paper's scheme takes gravity (section 3.4).
    Explicit,
}

impl FieldStiffness {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            FieldStiffness::Split => "split",
            FieldStiffness::Projected => "projected",
            FieldStiffness::Explicit => "explicit",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Split, Self::Projected, Self::Explicit]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// Time integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum IntegratorKind {
    /// One Newton step of backward Euler per time step (paper section 3.4); default.
    #[default]
    LinearlyImplicitEuler,
    /// Backward Euler solved by Newton iterations to a residual tolerance.
    NewtonImplicitEuler,
    /// Variable-step BDF2 linearised once per step about the extrapolated state: second
    /// order, L-stable, on the linearly implicit Euler step's matrix (one factorisation
    /// per step); its first step (and any restart) is a linearly implicit Euler step.
    Bdf2,
    /// Classical explicit Runge–Kutta 4: a reference for tests, needs small steps.
    Rk4,
}

impl IntegratorKind {
    /// Every integrator, in the order scenes and messages list them.
    pub const ALL: [IntegratorKind; 4] = [
        Self::LinearlyImplicitEuler,
        Self::NewtonImplicitEuler,
        Self::Bdf2,
        Self::Rk4,
    ];
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::LinearlyImplicitEuler => "linearly-implicit-euler",
            IntegratorKind::NewtonImplicitEuler => "newton-implicit-euler",
            IntegratorKind::Bdf2 => "bdf2",
            IntegratorKind::Rk4 => "rk4",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }
}

/// Which strand kernels to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelChoice {
    /// The generated fixed-N kernel where this build has one for a strand's N, the
    /// moment assembly on the generated closed forms (any N) otherwise.
    #[default]
    Auto,
    /// Always the generic runtime-N path (Gauss–Legendre quadrature).
    Generic,
    /// The generated fixed-N kernels; an error when a strand's N has none in this build
    /// (`SUPERHELIX_N` generates others at build time).
    Generated,
    /// The moment assembly on the generated closed forms for every N (what `auto` uses
    /// for an N without fixed-N code): the yardstick of the fixed-N kernels.
    Moment,
}

impl KernelChoice {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            KernelChoice::Auto => "auto",
            KernelChoice::Generic => "generic",
            KernelChoice::Generated => "generated",
            KernelChoice::Moment => "moment",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Auto, Self::Generic, Self::Generated, Self::Moment]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// Which engine steps the strands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Engine {
    /// The embedded engine wherever it can run the scene (every strand's N has fixed-N
    /// code in this build, linearly implicit Euler, no contacts, point loads,
    /// electrostatics, static mode or step budget, kernels `auto` or `generated`), the
    /// runtime engine otherwise: the same steps (to 1e-12) for a fraction of the memory.
    #[default]
    Auto,
    /// The runtime's step: any integrator and kernel, checked after the fact (energy
    /// balance, a step split when it rotates an element too far), buffers per strand.
    Runtime,
    /// The fixed-N step an engine embeds (`superhelix-kernels`): linearly implicit Euler
    /// on the generated fixed-N code with the runtime's checks after the fact, one
    /// workspace per worker thread and 1.8 kB per strand at N = 5: for full heads.
    Embedded,
}

impl Engine {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            Engine::Auto => "auto",
            Engine::Runtime => "runtime",
            Engine::Embedded => "embedded",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Auto, Self::Runtime, Self::Embedded]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// Settings of a run (the scene's `[simulation]` table).
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationConfig {
    /// Dynamic or static.
    pub mode: Mode,
    /// Time step, seconds (> 0).
    pub dt: f64,
    /// Simulated duration, seconds (≥ 0).
    pub duration: f64,
    /// Frames written per simulated second (> 0).
    pub output_fps: f64,
    /// Integrator.
    pub integrator: IntegratorKind,
    /// Kernel choice.
    pub kernels: KernelChoice,
    /// Quadrature of the generic kernels.
    pub quadrature: QuadratureRule,
    /// The engine that steps the strands.
    pub engine: Engine,
    /// How many times an implicit step may be halved, 0 to [`MAX_SUBSTEP_DEPTH`]
    /// (`[simulation] max_split_depth`): at most 2^depth solves per step and strand
    /// (plus the rejected tries). Below the default the cost per step is bounded and a
    /// step that would still rotate an element too far is limited instead of split (see
    /// [`StepStats::rotation_limited`](crate::solver::StepStats)); accuracy is traded
    /// for a fixed budget.
    pub max_split_depth: usize,
    /// What of the external forces' stiffness the step's matrix holds.
    pub field_stiffness: FieldStiffness,
    /// Whether every implicit step is checked against the energy balance
    /// (`[simulation] energy_balance`, default true): split, or its velocities scaled,
    /// when it creates energy (see [`superhelix_kernels::energy`]). Off, no energy is
    /// measured and only the rotation check (and the contacts' approach check) splits or
    /// limits a step.
    pub energy_balance: bool,
    /// The local error each strand's step may make, relative to the strand's length
    /// (`[simulation] tolerance`, in [`MIN_TOLERANCE`, `MAX_TOLERANCE`]; `None`: fixed
    /// steps): each strand then chooses its own steps within every `dt` to keep it
    /// ([`crate::solver::error_control`]).
    pub tolerance: Option<f64>,
    /// The times of the frames (`[output] times`, strictly increasing, in [0, duration];
    /// `None`: every 1/output_fps): a step that would pass one is split there, so that each
    /// frame records the state at exactly its time (to round-off).
    pub output_times: Option<Vec<f64>>,
}

/// Smallest `[simulation] tolerance`.
pub const MIN_TOLERANCE: f64 = 1e-8;
/// Largest `[simulation] tolerance`.
pub const MAX_TOLERANCE: f64 = 0.5;

impl Default for SimulationConfig {
    fn default() -> Self {
        Self {
            mode: Mode::Dynamic,
            dt: 1.0 / 30.0,
            duration: 2.0,
            output_fps: 30.0,
            integrator: IntegratorKind::LinearlyImplicitEuler,
            kernels: KernelChoice::Auto,
            quadrature: QuadratureRule::default(),
            engine: Engine::Auto,
            max_split_depth: MAX_SUBSTEP_DEPTH,
            field_stiffness: FieldStiffness::Projected,
            energy_balance: true,
            tolerance: None,
            output_times: None,
        }
    }
}

/// A held tip: where it is held, in world coordinates, and how that place moves.
#[derive(Debug, Clone, PartialEq)]
pub struct HeldEnd {
    /// What is held.
    pub kind: crate::model::ends::HeldKind,
    /// The held point p (for `Sliding`, a point of the axis) in the motion's frame,
    /// metres: at time t it is at `X_m(t) + R_m(t) p` in the world.
    pub position: nalgebra::Vector3<f64>,
    /// The held frame F* (columns n0, n1, n2) in the motion's frame (`Clamped`).
    pub frame: nalgebra::Matrix3<f64>,
    /// The unit axis a tip slides along, in the motion's frame (`Sliding`).
    pub axis: nalgebra::Vector3<f64>,
    /// The motion of the holder (`Still`: fixed in the world; keyframes: driven).
    pub motion: crate::forces::head_motion::HeadMotion,
}

/// One strand and its initial state.
#[derive(Debug, Clone, PartialEq)]
pub struct StrandSetup {
    /// The strand.
    pub strand: Strand,
    /// Initial generalized coordinates (3N).
    pub q0: Vec<f64>,
    /// Output group (one USD prim and one preview colour per group): the patch name for
    /// the strands of a patch, by default the strand's own name.
    pub group: String,
    /// The strand's own charge per length, C/m (`strands[i].charge_per_length`); `None`:
    /// the scene's `electrostatics.charge_per_length`.
    pub charge_per_length: Option<f64>,
    /// Its held tip (`[strands.ends.tip]`; `None`: free). A pinned root is in the
    /// strand ([`crate::model::ends`]).
    pub tip: Option<HeldEnd>,
}

/// Everything needed to build a [`Simulation`](crate::Simulation); what a scene file becomes.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationSetup {
    /// Run settings.
    pub config: SimulationConfig,
    /// Gravity.
    pub environment: Environment,
    /// Rigid motion of the head (of every root).
    pub head: HeadMotion,
    /// The strands.
    pub strands: Vec<StrandSetup>,
    /// The bodies (head, obstacles); empty when the scene has none.
    pub bodies: Vec<BodySetup>,
    /// Centreline points written per element (plus the root) in outputs.
    pub samples_per_element: usize,
    /// The scene's `[output]` formats and size limit.
    pub output: OutputSettings,
    /// Static electricity (`[electrostatics]`); `None`: no charge, nothing built for it.
    pub electrostatics: Option<crate::forces::electrostatics::ElectrostaticsConfig>,
    /// Contacts with bodies and between strands (`[contacts]`); `None`: none, nothing
    /// built for them.
    pub contacts: Option<crate::forces::contacts::ContactConfig>,
}

/// Number of time steps of a dynamic run: `ceil(duration / dt)` (up to rounding of the
/// ratio), so that the last state is at or after `duration`. 0 in static mode.
pub fn total_steps(config: &SimulationConfig) -> usize {
    let ratio = config.duration / config.dt;
    if config.mode == Mode::Static || !ratio.is_finite() || ratio <= 0.0 {
        return 0;
    }
    (ratio - 1e-9 * ratio.max(1.0)).ceil().max(0.0) as usize
}

/// Nominal frame times: `[output] times` when the scene gives them, else `k / output_fps`
/// for `k = 0..=floor(duration · output_fps)`; `[0]` in static mode.
pub fn frame_times(config: &SimulationConfig) -> Vec<f64> {
    let product = config.duration * config.output_fps;
    if config.mode == Mode::Static {
        return vec![0.0];
    }
    if let Some(times) = &config.output_times {
        return times.clone();
    }
    if !product.is_finite() || product <= 0.0 {
        return vec![0.0];
    }
    let last = (product + 1e-9 * product.max(1.0)).floor().max(0.0) as usize;
    (0..=last).map(|k| k as f64 / config.output_fps).collect()
}

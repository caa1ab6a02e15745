//! A simulation: strands, environment, head motion, integrator; an explicit `step`.

use crate::environment::Environment;
use crate::error::Result;
use crate::head_motion::HeadMotion;
use crate::kernel::KernelFactory;
use crate::kernel_generic::QuadratureRule;
use crate::strand::Strand;

/// Dynamic time stepping or static equilibrium.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// Time stepping.
    #[default]
    Dynamic,
    /// Equilibrium: ∇(U + V) = external forces, solved by Newton with a line search.
    Static,
}

/// Time integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum IntegratorKind {
    /// One Newton step of backward Euler per time step (paper section 3.4); default.
    #[default]
    LinearlyImplicitEuler,
    /// Backward Euler solved by Newton iterations to a residual tolerance.
    NewtonImplicitEuler,
    /// Classical explicit Runge–Kutta 4: a reference for tests, needs small steps.
    Rk4,
}

impl IntegratorKind {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            IntegratorKind::LinearlyImplicitEuler => "linearly-implicit-euler",
            IntegratorKind::NewtonImplicitEuler => "newton-implicit-euler",
            IntegratorKind::Rk4 => "rk4",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::LinearlyImplicitEuler, Self::NewtonImplicitEuler, Self::Rk4]
            .into_iter()
            .find(|k| k.name() == name)
    }
}

/// Which strand kernels to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KernelChoice {
    /// Generated kernels where they exist for a strand's N, generic otherwise.
    #[default]
    Auto,
    /// Always the generic runtime-N path.
    Generic,
    /// Generated kernels; an error when a strand's N has none.
    Generated,
}

impl KernelChoice {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            KernelChoice::Auto => "auto",
            KernelChoice::Generic => "generic",
            KernelChoice::Generated => "generated",
        }
    }
    /// Parse a scene name.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Auto, Self::Generic, Self::Generated].into_iter().find(|k| k.name() == name)
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
}

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
        }
    }
}

/// One strand and its initial state.
#[derive(Debug, Clone, PartialEq)]
pub struct StrandSetup {
    /// The strand.
    pub strand: Strand,
    /// Initial generalized coordinates (3N).
    pub q0: Vec<f64>,
}

/// Everything needed to build a [`Simulation`]; what a scene file becomes.
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
    /// Centreline points written per element (plus the root) in outputs.
    pub samples_per_element: usize,
}

/// A running simulation. Built from a [`SimulationSetup`]; advanced by [`Simulation::step`].
pub struct Simulation {
    _private: (),
}

impl Simulation {
    /// Build the simulation: one kernel per strand (generated where `generated` has one
    /// and the configuration allows it), workspaces sized once.
    pub fn new(_setup: SimulationSetup, _generated: Option<&dyn KernelFactory>) -> Result<Self> {
        todo!()
    }
}

//! A simulation: strands, environment, head motion, integrator; an explicit `step`.

use crate::effects::GlobalEffects;
use crate::environment::Environment;
use crate::error::{Error, FieldError, Result};
use crate::head_motion::HeadMotion;
use crate::initial_state::check_initial_state;
use crate::integrator::{
    energy, kinetic_energy, step_strand, StepContext, StepStats, StrandWorkspace,
};
use crate::kernel::{KernelFactory, StrandKernel};
use crate::kernel_generic::{GenericKernel, QuadratureRule};
use crate::reconstruction::{pose_at, sample_centreline};
use crate::statics::{solve_static, StaticReport};
use crate::strand::{Strand, StrandGeometry};
use rayon::prelude::*;

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
        [Self::Auto, Self::Generic, Self::Generated]
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

/// One strand of a running simulation: its model, kernel, state and buffers.
struct StrandSim {
    strand: Strand,
    kernel: Box<dyn StrandKernel>,
    workspace: StrandWorkspace,
    q: Vec<f64>,
    v: Vec<f64>,
    stats: StepStats,
}

/// A running simulation. Built from a [`SimulationSetup`]; advanced by [`Simulation::step`].
pub struct Simulation {
    config: SimulationConfig,
    head: HeadMotion,
    context: StepContext,
    samples_per_element: usize,
    strands: Vec<StrandSim>,
    time: f64,
    steps: usize,
}

/// Check the parts of a setup the scene reader may not have (for users of the API).
fn check_setup(setup: &SimulationSetup) -> Result<()> {
    let mut errors = Vec::new();
    let c = &setup.config;
    if !(c.dt.is_finite() && c.dt > 0.0) {
        errors.push(FieldError::new(
            "simulation.dt",
            format!("must be finite and > 0, got {}", c.dt),
        ));
    }
    if !(c.duration.is_finite() && c.duration >= 0.0) {
        errors.push(FieldError::new(
            "simulation.duration",
            format!("must be finite and >= 0, got {}", c.duration),
        ));
    }
    if setup.strands.is_empty() {
        errors.push(FieldError::new(
            "strands",
            "at least one strand is required",
        ));
    }
    for (i, s) in setup.strands.iter().enumerate() {
        let g = &s.strand.geometry;
        let at = |f: &str| format!("strands[{i}].{f}");
        if g.lengths.is_empty() {
            errors.push(FieldError::new(at("elements"), "must be >= 1"));
        }
        if g.lengths.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
            errors.push(FieldError::new(
                at("element_lengths"),
                "every element length must be finite and > 0",
            ));
        }
        let n = g.dofs();
        if s.q0.len() != n || s.strand.natural.len() != n {
            errors.push(FieldError::new(
                at("q0"),
                format!("must have 3N = {n} values"),
            ));
        }
        if s.q0.iter().chain(&s.strand.natural).any(|x| !x.is_finite()) {
            errors.push(FieldError::new(at("q0"), "values must be finite"));
        }
        let m = &s.strand.material;
        if !(m.mass_per_length > 0.0 && m.stiffness.iter().all(|k| *k > 0.0 && k.is_finite())) {
            errors.push(FieldError::new(
                at("material"),
                "mass per length and stiffnesses must be finite and > 0",
            ));
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(Error::Invalid(errors))
    }
}

fn make_kernel(
    choice: KernelChoice,
    rule: QuadratureRule,
    geometry: &StrandGeometry,
    generated: Option<&dyn KernelFactory>,
    index: usize,
    name: &str,
) -> std::result::Result<Box<dyn StrandKernel>, FieldError> {
    let from_generated = || generated.and_then(|f| f.create(geometry));
    let generic = || Box::new(GenericKernel::new(geometry.clone(), rule)) as Box<dyn StrandKernel>;
    match choice {
        KernelChoice::Generic => Ok(generic()),
        KernelChoice::Auto => Ok(from_generated().unwrap_or_else(generic)),
        KernelChoice::Generated => from_generated().ok_or_else(|| {
            let available = generated.map(|f| f.available()).unwrap_or_default();
            FieldError::new(
                "simulation.kernels",
                format!(
                    "strand '{name}' (strands[{index}]) has N = {n} elements and there is no generated kernel for it \
                     (generated kernels exist for N in {available:?}; build with SUPERHELIX_N={n} to add it, \
                     or use kernels = \"auto\" or \"generic\")",
                    n = geometry.elements(),
                ),
            )
        }),
    }
}

impl Simulation {
    /// Build the simulation: one kernel per strand (generated where `generated` has one
    /// and the configuration allows it), workspaces sized once. The initial state is
    /// checked as the first step would meet it ([`crate::initial_state`]): a missing
    /// generated kernel, a non-finite centreline, force or mass matrix, and under RK4 a
    /// dt beyond its stability limit are [`Error::Invalid`], every problem listed.
    pub fn new(setup: SimulationSetup, generated: Option<&dyn KernelFactory>) -> Result<Self> {
        check_setup(&setup)?;
        let head_moves = setup.head != HeadMotion::Still;
        let context = StepContext {
            effects: GlobalEffects {
                gravity: setup.environment.gravity,
                head_moves,
            },
        };
        let head0 = setup.head.state(0.0);
        let rk4_dt = (setup.config.integrator == IntegratorKind::Rk4
            && setup.config.mode == Mode::Dynamic)
            .then_some(setup.config.dt);
        let mut errors = Vec::new();
        let mut strands = Vec::with_capacity(setup.strands.len());
        for (index, s) in setup.strands.into_iter().enumerate() {
            let mut kernel = match make_kernel(
                setup.config.kernels,
                setup.config.quadrature,
                &s.strand.geometry,
                generated,
                index,
                &s.strand.name,
            ) {
                Ok(kernel) => kernel,
                Err(e) => {
                    errors.push(e);
                    continue;
                }
            };
            let mut workspace = StrandWorkspace::new(&s.strand);
            errors.extend(check_initial_state(
                index,
                &s.strand,
                kernel.as_mut(),
                &mut workspace,
                &context,
                &head0,
                &s.q0,
                rk4_dt,
            ));
            let n = s.q0.len();
            strands.push(StrandSim {
                workspace,
                kernel,
                q: s.q0,
                v: vec![0.0; n],
                strand: s.strand,
                stats: StepStats::default(),
            });
        }
        if !errors.is_empty() {
            return Err(Error::Invalid(errors));
        }
        Ok(Simulation {
            config: setup.config,
            head: setup.head,
            context,
            samples_per_element: setup.samples_per_element,
            strands,
            time: 0.0,
            steps: 0,
        })
    }

    /// Advance every strand by one time step `dt` (in parallel over strands). On failure
    /// the error names the strand, the time and the cause, and the state is left at the
    /// last good step for the other strands.
    pub fn step(&mut self) -> Result<()> {
        let h = self.config.dt;
        let t = self.time;
        let head = &self.head;
        let kind = self.config.integrator;
        let ctx = self.context;
        let failure = self
            .strands
            .par_iter_mut()
            .enumerate()
            .map(|(i, s)| {
                let (mut q, mut v) = (std::mem::take(&mut s.q), std::mem::take(&mut s.v));
                let result = step_strand(
                    kind,
                    &s.strand,
                    s.kernel.as_mut(),
                    &mut s.workspace,
                    &ctx,
                    head,
                    t,
                    h,
                    &mut q,
                    &mut v,
                    &mut s.stats,
                );
                s.q = q;
                s.v = v;
                result.err().map(|cause| (i, cause))
            })
            .flatten()
            .min_by_key(|(i, _)| *i);
        if let Some((index, cause)) = failure {
            return Err(Error::Diverged {
                strand: self.strands[index].strand.name.clone(),
                index,
                time: t + h,
                cause,
            });
        }
        self.time = t + h;
        self.steps += 1;
        Ok(())
    }

    /// Solve every strand's static equilibrium in place (gravity and point loads, head at
    /// rest).
    pub fn solve_static(&mut self) -> Result<Vec<StaticReport>> {
        let ctx = self.context;
        let reports: Vec<std::result::Result<StaticReport, (usize, String)>> = self
            .strands
            .par_iter_mut()
            .enumerate()
            .map(|(i, s)| {
                let mut q = std::mem::take(&mut s.q);
                s.workspace.forget_history();
                let r = solve_static(&s.strand, s.kernel.as_mut(), &mut s.workspace, &ctx, &mut q);
                let finite = q.iter().all(|x| x.is_finite());
                s.q = q;
                match r {
                    Ok(rep) if finite => Ok(rep),
                    Ok(_) => Err((i, "static solve produced non-finite q".to_string())),
                    Err(e) => Err((i, e)),
                }
            })
            .collect();
        reports
            .into_iter()
            .map(|r| {
                r.map_err(|(index, cause)| Error::Diverged {
                    strand: self.strands[index].strand.name.clone(),
                    index,
                    time: self.time,
                    cause,
                })
            })
            .collect()
    }

    /// Simulated time, seconds.
    pub fn time(&self) -> f64 {
        self.time
    }
    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.steps
    }
    /// The run settings.
    pub fn config(&self) -> &SimulationConfig {
        &self.config
    }
    /// Centreline points per element in outputs.
    pub fn samples_per_element(&self) -> usize {
        self.samples_per_element
    }
    /// Number of strands.
    pub fn strand_count(&self) -> usize {
        self.strands.len()
    }
    /// Strand i.
    pub fn strand(&self, i: usize) -> &Strand {
        &self.strands[i].strand
    }
    /// Generalized coordinates of strand i.
    pub fn q(&self, i: usize) -> &[f64] {
        &self.strands[i].q
    }
    /// Generalized velocities of strand i.
    pub fn v(&self, i: usize) -> &[f64] {
        &self.strands[i].v
    }
    /// Set the state of strand i (lengths must be 3N).
    pub fn set_state(&mut self, i: usize, q: &[f64], v: &[f64]) {
        self.strands[i].q.copy_from_slice(q);
        self.strands[i].v.copy_from_slice(v);
        self.strands[i].workspace.forget_history();
    }
    /// Description of strand i's kernel.
    pub fn kernel_description(&self, i: usize) -> String {
        self.strands[i].kernel.description()
    }
    /// Whether strand i runs on a generated kernel.
    pub fn uses_generated_kernel(&self, i: usize) -> bool {
        self.strands[i].kernel.is_generated()
    }
    /// Solver counters summed over strands.
    pub fn stats(&self) -> StepStats {
        let mut total = StepStats::default();
        for s in &self.strands {
            total.add(&s.stats);
        }
        total
    }
    /// Largest |q̇| entry over all strands, rad/(m·s).
    pub fn max_speed(&self) -> f64 {
        self.strands
            .iter()
            .flat_map(|s| s.v.iter())
            .fold(0.0, |m, v| m.max(v.abs()))
    }
    /// Total energy T + U + V_gravity + V_loads of strand i (meaningful with a still head).
    pub fn energy(&mut self, i: usize) -> f64 {
        let ctx = self.context;
        let s = &mut self.strands[i];
        energy(
            &s.strand,
            s.kernel.as_mut(),
            &mut s.workspace,
            &ctx,
            &s.q,
            &s.v,
        )
    }
    /// Kinetic energy ½ q̇ᵀ M q̇ of strand i relative to the head, joules.
    pub fn kinetic_energy(&mut self, i: usize) -> f64 {
        let ctx = self.context;
        let s = &mut self.strands[i];
        kinetic_energy(
            &s.strand,
            s.kernel.as_mut(),
            &mut s.workspace,
            &ctx,
            &s.q,
            &s.v,
        )
    }
    /// Centreline of strand i in world coordinates: the root, then `per_element` points
    /// per element.
    pub fn centreline_world(&mut self, i: usize, per_element: usize) -> Vec<[f64; 3]> {
        let head = self.head.state(self.time);
        let s = &self.strands[i];
        let mut points = Vec::new();
        sample_centreline(&s.strand.geometry, &s.q, per_element, &mut points);
        points
            .iter()
            .map(|y| {
                let x = head.position + head.rotation * y;
                [x[0], x[1], x[2]]
            })
            .collect()
    }
    /// Position of strand i at arc length s, head coordinates.
    pub fn position_at(&self, i: usize, s: f64) -> nalgebra::Vector3<f64> {
        let st = &self.strands[i];
        pose_at(&st.strand.geometry, &st.q, s).position
    }
}

impl crate::output::FrameSource for Simulation {
    fn time(&self) -> f64 {
        self.time
    }
    fn strand_count(&self) -> usize {
        self.strands.len()
    }
    fn strand_name(&self, i: usize) -> &str {
        &self.strands[i].strand.name
    }
    fn q(&self, i: usize) -> &[f64] {
        &self.strands[i].q
    }
    fn v(&self, i: usize) -> &[f64] {
        &self.strands[i].v
    }
    fn centreline_world(&mut self, i: usize, samples_per_element: usize) -> Vec<[f64; 3]> {
        Simulation::centreline_world(self, i, samples_per_element)
    }
    fn step(&mut self) -> Result<()> {
        Simulation::step(self)
    }
    fn solve_static(&mut self) -> Result<()> {
        Simulation::solve_static(self).map(|_| ())
    }
}

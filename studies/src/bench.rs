//! `superhelix bench`: strand-steps per second for S independent strands of N elements,
//! with the effects asked for and nothing else.

use std::time::Instant;
use superhelix_runtime::config::{
    Engine, FieldStiffness, IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup,
    StrandSetup,
};
use superhelix_runtime::model::material::{helix_curvature, HelixForm, Preset};
use superhelix_runtime::model::strand::{PointLoad, Strand, StrandGeometry};
use superhelix_runtime::{
    Environment, Error, HeadMotion, Matrix3, QuadratureRule, Result, Simulation, Vector3,
};

/// The effects a benchmark (or a scene) can switch on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EffectSet {
    /// Gravity.
    pub gravity: bool,
    /// Air drag (the preset's ν).
    pub drag: bool,
    /// Internal friction (the preset's γ).
    pub friction: bool,
    /// Head motion: oscillation about the vertical, 2 Hz, ±30°.
    pub head: bool,
    /// A point load at each strand's tip.
    pub point_loads: bool,
}

impl EffectSet {
    /// The names accepted by `--effects`.
    pub const NAMES: [&'static str; 5] = ["gravity", "drag", "friction", "head", "point-loads"];

    /// Gravity, drag and internal friction: the bench's default.
    pub fn default_bench() -> Self {
        EffectSet {
            gravity: true,
            drag: true,
            friction: true,
            ..Default::default()
        }
    }

    /// The names of the effects in the set (`none` for none).
    pub fn names(&self) -> Vec<&'static str> {
        let on = [
            self.gravity,
            self.drag,
            self.friction,
            self.head,
            self.point_loads,
        ];
        let names: Vec<&'static str> = Self::NAMES
            .iter()
            .zip(on)
            .filter_map(|(n, o)| o.then_some(*n))
            .collect();
        if names.is_empty() {
            vec!["none"]
        } else {
            names
        }
    }

    /// Parse a comma list (`gravity,drag`), or `none`.
    pub fn parse(list: &str) -> Result<Self> {
        let mut set = EffectSet::default();
        for name in list
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty() && *s != "none")
        {
            match name {
                "gravity" => set.gravity = true,
                "drag" => set.drag = true,
                "friction" => set.friction = true,
                "head" => set.head = true,
                "point-loads" => set.point_loads = true,
                other => {
                    return Err(Error::invalid(
                        "--effects",
                        format!(
                            "unknown effect '{other}'; allowed: {} or none",
                            EffectSet::NAMES.join(", ")
                        ),
                    ))
                }
            }
        }
        Ok(set)
    }
}

/// What to benchmark.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchOptions {
    /// Elements per strand N.
    pub elements: usize,
    /// Number of strands S.
    pub strands: usize,
    /// Time steps T.
    pub steps: usize,
    /// Kernel choice.
    pub kernels: KernelChoice,
    /// Effects.
    pub effects: EffectSet,
    /// Hair type.
    pub preset: Preset,
    /// Integrator.
    pub integrator: IntegratorKind,
    /// Quadrature of the generic kernels.
    pub quadrature: QuadratureRule,
    /// Time step, s.
    pub dt: f64,
    /// Strand length, m.
    pub length: f64,
    /// The engine stepping the strands.
    pub engine: Engine,
    /// The deepest split of a step (`[simulation] max_split_depth`).
    pub max_split_depth: usize,
    /// What of the external forces' stiffness the step's matrix holds.
    pub field_stiffness: FieldStiffness,
    /// Whether implicit steps are checked against the energy balance.
    pub energy_balance: bool,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            elements: 5,
            strands: 100,
            steps: 30,
            kernels: KernelChoice::Auto,
            effects: EffectSet::default_bench(),
            preset: Preset::Wavy,
            integrator: IntegratorKind::LinearlyImplicitEuler,
            quadrature: QuadratureRule::Adaptive,
            dt: 1.0 / 30.0,
            length: 0.2,
            engine: Engine::Auto,
            max_split_depth: SimulationConfig::default().max_split_depth,
            field_stiffness: FieldStiffness::default(),
            energy_balance: true,
        }
    }
}

/// Measured figures.
#[derive(Debug, Clone, PartialEq)]
pub struct BenchReport {
    /// Wall time of the steps, s.
    pub seconds: f64,
    /// Steps per second of wall time (frames per second at one step per frame).
    pub frames_per_second: f64,
    /// The deepest point of any centreline inside a body after any step, m, on the dense
    /// sweep of every centreline after each step (not timed; `None`: no `[contacts]`).
    pub deepest: Option<f64>,
    /// Hair–hair pairs per step, averaged over the steps (`None`: no hair–hair).
    pub hair_pairs: Option<f64>,
    /// Of [`Self::seconds`], the wall time of the hair–hair pairs' tracking and search
    /// (`None`: no hair–hair).
    pub hair_pair_seconds: Option<f64>,
    /// S·T / seconds.
    pub strand_steps_per_second: f64,
    /// S·T.
    pub strand_steps: usize,
    /// On-CPU time of the process during the steps (all threads), s, where the
    /// platform has it: robust to other load on the machine.
    pub cpu_seconds: Option<f64>,
    /// Implicit steps that were split (see `StepStats::substeps`).
    pub substeps: usize,
    /// Of the splits, those for the energy balance (the rest split because a step
    /// rotated an element too far or failed).
    pub energy_rejected: usize,
    /// Steps whose excess kinetic energy was removed from the velocities.
    pub energy_limited: usize,
    /// Steps at the deepest split allowed whose rotation was limited
    /// (`StepStats::rotation_limited`).
    pub rotation_limited: usize,
    /// Implicit (sub)steps solved, accepted or not.
    pub attempts: usize,
    /// Solves whose field stiffness went into the matrix by the dissipative split
    /// (`StepStats::field_split`).
    pub field_split: usize,
    /// Solves whose field stiffness was found by the spectral projection
    /// (`StepStats::field_projected`).
    pub field_projected: usize,
    /// Solves of strands without internal friction or drag, which the split's rule keeps
    /// on the projection (`StepStats::field_undamped`).
    pub field_undamped: usize,
    /// Description of the kernel of strand 0.
    pub kernel: String,
    /// The engine that stepped the strands (`embedded` or `runtime`: what `auto`
    /// chose).
    pub engine: &'static str,
    /// Worker threads the strands were spread over.
    pub threads: usize,
}

fn check(o: &BenchOptions) -> Result<()> {
    let mut problems = Vec::new();
    if !(1..=200).contains(&o.elements) {
        problems.push(superhelix_runtime::FieldError::new(
            "--elements",
            "must be in 1..=200",
        ));
    }
    if !(1..=1_000_000).contains(&o.strands) {
        problems.push(superhelix_runtime::FieldError::new(
            "--strands",
            "must be in 1..=1000000",
        ));
    }
    if !(1..=10_000_000).contains(&o.steps) {
        problems.push(superhelix_runtime::FieldError::new(
            "--steps",
            "must be in 1..=10000000",
        ));
    }
    if !(o.length.is_finite() && o.length > 0.0 && o.length <= 10.0) {
        problems.push(superhelix_runtime::FieldError::new(
            "--length",
            "must be finite, > 0 and <= 10 m",
        ));
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Error::Invalid(problems))
    }
}

/// The strands of a benchmark: strands (20 cm unless `length` says otherwise) of the preset leaving a 10 cm head
/// sideways, roots spread around it.
fn strands(o: &BenchOptions) -> Vec<StrandSetup> {
    let p = o.preset.params();
    let material = p.cross_section.material();
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    let length = o.length;
    (0..o.strands)
        .map(|i| {
            let angle = i as f64 * 2.399963; // golden angle: roots spread evenly
            let n0 = Vector3::new(angle.cos(), angle.sin(), 0.0);
            let n2 = Vector3::z();
            let frame = Matrix3::from_columns(&[n0, n2.cross(&n0), n2]);
            let strand = Strand {
                name: format!("s{i}"),
                geometry: StrandGeometry::new(
                    n0 * 0.1,
                    frame,
                    vec![length / o.elements as f64; o.elements],
                    &material,
                ),
                material,
                natural: (0..o.elements).flat_map(|_| natural).collect(),
                internal_friction: if o.effects.friction {
                    p.internal_friction
                } else {
                    0.0
                },
                air_drag: if o.effects.drag { p.air_drag } else { 0.0 },
                point_loads: if o.effects.point_loads {
                    vec![PointLoad {
                        s: length,
                        force: Vector3::new(0.0, 0.0, -1e-6),
                        follows: false,
                        torque: nalgebra::Vector3::zeros(),
                    }]
                } else {
                    Vec::new()
                },
                ends: Default::default(),
            };
            StrandSetup {
                charge_per_length: None,
                tip: None,
                q0: strand.natural.clone(),
                group: strand.name.clone(),
                strand,
            }
        })
        .collect()
}

/// The simulation a benchmark runs: S strands of the preset, the effects asked for,
/// `steps · dt` of simulated time (also used by `superhelix quadrature-table`).
pub fn setup(o: &BenchOptions) -> Result<SimulationSetup> {
    check(o)?;
    Ok(SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            dt: o.dt,
            duration: o.dt * o.steps as f64,
            integrator: o.integrator,
            kernels: o.kernels,
            quadrature: o.quadrature,
            engine: o.engine,
            max_split_depth: o.max_split_depth,
            field_stiffness: o.field_stiffness,
            energy_balance: o.energy_balance,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: o.effects.gravity.then(|| Vector3::new(0.0, 0.0, -9.81)),
        },
        head: if o.effects.head {
            HeadMotion::Oscillate {
                axis: Vector3::z(),
                amplitude: 30f64.to_radians(),
                frequency_hz: 2.0,
                center: Vector3::zeros(),
            }
        } else {
            HeadMotion::Still
        },
        strands: strands(o),
        bodies: Vec::new(),
        samples_per_element: 1,
        output: Default::default(),
    })
}

/// The effects a (parsed) scene has.
pub fn scene_effects(setup: &SimulationSetup) -> EffectSet {
    EffectSet {
        gravity: setup.environment.gravity.is_some(),
        drag: setup.strands.iter().any(|s| s.strand.air_drag != 0.0),
        friction: setup
            .strands
            .iter()
            .any(|s| s.strand.internal_friction != 0.0),
        head: !matches!(setup.head, HeadMotion::Still),
        point_loads: setup
            .strands
            .iter()
            .any(|s| !s.strand.point_loads.is_empty()),
    }
}

/// Keep only the effects of `keep` in a scene (`superhelix bench --scene F --effects L`);
/// asking for an effect the scene does not have is an error naming it.
pub fn restrict_effects(setup: &mut SimulationSetup, keep: EffectSet) -> Result<()> {
    let has = scene_effects(setup);
    let missing: Vec<&str> = [
        (keep.gravity && !has.gravity, "gravity"),
        (keep.drag && !has.drag, "drag"),
        (keep.friction && !has.friction, "friction"),
        (keep.head && !has.head, "head"),
        (keep.point_loads && !has.point_loads, "point-loads"),
    ]
    .iter()
    .filter_map(|&(m, name)| m.then_some(name))
    .collect();
    if !missing.is_empty() {
        return Err(Error::invalid(
            "--effects",
            format!(
                "the scene has no {}; it has: {}",
                missing.join(", "),
                has.names().join(", ")
            ),
        ));
    }
    if !keep.gravity {
        setup.environment.gravity = None;
    }
    if !keep.head {
        setup.head = HeadMotion::Still;
    }
    for s in &mut setup.strands {
        if !keep.drag {
            s.strand.air_drag = 0.0;
        }
        if !keep.friction {
            s.strand.internal_friction = 0.0;
        }
        if !keep.point_loads {
            s.strand.point_loads.clear();
        }
    }
    Ok(())
}

/// Run the benchmark.
pub fn bench(o: &BenchOptions) -> Result<BenchReport> {
    bench_setup(setup(o)?, o.steps)
}

/// Time `steps` steps of any simulation setup (a scene's, for `bench --scene`).
pub fn bench_setup(setup: SimulationSetup, steps: usize) -> Result<BenchReport> {
    let strand_count = setup.strands.len();
    let mut sim = Simulation::new(setup, crate::kernel_factory())?;
    // only the steps are timed: the deepest point's sweep after each step and the pairs'
    // count are not
    let (mut seconds, mut cpu_seconds) = (0.0, Some(0.0));
    let (mut deepest, mut pairs) = (None::<f64>, 0);
    for _ in 0..steps {
        let start = Instant::now();
        let cpu_start = crate::cpu_time::process_seconds();
        sim.step()?;
        seconds += start.elapsed().as_secs_f64();
        let cpu = cpu_start
            .zip(crate::cpu_time::process_seconds())
            .map(|(a, b)| b - a);
        cpu_seconds = cpu_seconds.zip(cpu).map(|(a, b)| a + b);
        if let Some(d) = sim.max_penetration() {
            deepest = Some(deepest.map_or(d, |e| e.max(d)));
        }
        pairs += sim.hair_pairs().map_or(0, |c| c.pairs);
    }
    Ok(BenchReport {
        seconds,
        frames_per_second: steps as f64 / seconds.max(1e-12),
        deepest,
        hair_pairs: sim.hair_pairs().map(|_| pairs as f64 / steps.max(1) as f64),
        hair_pair_seconds: sim.hair_pair_seconds(),
        strand_steps_per_second: (strand_count * steps) as f64 / seconds.max(1e-12),
        strand_steps: strand_count * steps,
        cpu_seconds,
        substeps: sim.stats().substeps,
        energy_rejected: sim.stats().energy_rejected,
        energy_limited: sim.stats().energy_limited,
        rotation_limited: sim.stats().rotation_limited,
        attempts: sim.stats().attempts,
        field_split: sim.stats().field_split,
        field_projected: sim.stats().field_projected,
        field_undamped: sim.stats().field_undamped,
        kernel: sim.kernel_description(0),
        engine: sim.engine().name(),
        threads: rayon::current_num_threads(),
    })
}

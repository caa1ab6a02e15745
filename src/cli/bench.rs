//! `superhelix bench`: time S independent strands of N elements, or a scene's strands.

use super::common::{integrator, kernels, preset, with_threads};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use superhelix_studies::bench::{
    bench, bench_setup, restrict_effects, scene_effects, BenchOptions, BenchReport, EffectSet,
};
use superhelix_studies::runtime::QuadratureRule;
use superhelix_studies::Error;

/// Arguments of `bench`.
#[derive(Args)]
pub struct BenchArgs {
    /// Elements per strand N.
    #[arg(long, default_value_t = 5)]
    elements: usize,
    /// Number of strands S.
    #[arg(long, default_value_t = 100)]
    strands: usize,
    /// Time steps T (dt = 1/30 s).
    #[arg(long, default_value_t = 30)]
    steps: usize,
    /// Kernels: generated, generic or auto (default auto, or the scene's).
    #[arg(long)]
    kernels: Option<String>,
    /// Effects, a comma list of gravity, drag, friction, head, point-loads (or none);
    /// default gravity,drag,friction, or with --scene the scene's own.
    #[arg(long)]
    effects: Option<String>,
    /// Bench this scene's strands (and effects, head motion, dt) instead of S
    /// generated strands of N elements; --elements, --strands and --preset are then
    /// ignored.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Hair type: smooth, wavy, curly, fuzzy.
    #[arg(long, default_value = "wavy")]
    preset: String,
    /// Integrator: linearly-implicit-euler, newton-implicit-euler, bdf2, rk4 (default
    /// linearly-implicit-euler, or with --scene the scene's own).
    #[arg(long)]
    integrator: Option<String>,
    /// Gauss-Legendre points per element of the generic kernels (default: adaptive).
    #[arg(long)]
    quadrature: Option<usize>,
    /// Engine: auto (the embedded engine wherever it can run the strands, else the
    /// runtime's), runtime (the runtime's step, buffers per strand) or embedded (the
    /// fixed-N step an engine embeds, one workspace per thread); default auto, or with
    /// --scene the scene's own.
    #[arg(long)]
    engine: Option<String>,
    /// Strand length, metres (ignored with --scene).
    #[arg(long, default_value_t = 0.2)]
    length: f64,
    /// Worker threads the strands are spread over (default: one per core). With 1,
    /// the CPU time per strand-step is the step's own cost, free of the scheduling
    /// and shared-core effects of parallel runs.
    #[arg(long)]
    threads: Option<usize>,
    /// The deepest split of a step, 0 to 8 (default 8, or the scene's
    /// `[simulation] max_split_depth`): at most 2^depth solves per strand-step; 0 is a
    /// fixed cost of one solve per strand-step.
    #[arg(long)]
    max_split_depth: Option<usize>,
    /// With --scene: run the error-controlled step at this tolerance (`[simulation]
    /// tolerance`, 1e-8 to 0.5), replacing the scene's.
    #[arg(long, value_name = "TOL", allow_negative_numbers = true)]
    tolerance: Option<f64>,
    /// What of the external forces' stiffness the implicit step's matrix holds:
    /// projected (default, or the scene's `[simulation] field_stiffness`), split or
    /// explicit.
    #[arg(long)]
    field_stiffness: Option<String>,
    /// Check every implicit step against the energy balance: true (default, or the
    /// scene's `[simulation] energy_balance`) or false.
    #[arg(long)]
    energy_balance: Option<bool>,
}

/// Run `bench`.
pub fn run(args: BenchArgs) -> Result<ExitCode, Error> {
    let threads = args.threads;
    with_threads(threads, || match &args.scene {
        Some(path) => bench_scene(path, &args),
        None => bench_generated(&args),
    })
}

fn bench_generated(args: &BenchArgs) -> Result<ExitCode, Error> {
    if args.tolerance.is_some() {
        return Err(Error::invalid(
            "--tolerance",
            "needs --scene (the generated strands take fixed steps)",
        ));
    }
    let kernel_name = args.kernels.as_deref().unwrap_or("auto");
    let effects = args.effects.as_deref().unwrap_or("gravity,drag,friction");
    let integrator_name = args
        .integrator
        .as_deref()
        .unwrap_or("linearly-implicit-euler");
    let options = BenchOptions {
        elements: args.elements,
        strands: args.strands,
        steps: args.steps,
        kernels: kernels(kernel_name)?,
        effects: EffectSet::parse(effects)?,
        preset: preset(&args.preset)?,
        integrator: integrator(integrator_name)?,
        quadrature: match args.quadrature {
            Some(0) => return Err(Error::invalid("--quadrature", "must be >= 1")),
            Some(n) => QuadratureRule::Fixed(n),
            None => QuadratureRule::Adaptive,
        },
        length: args.length,
        engine: engine(args.engine.as_deref().unwrap_or("auto"))?,
        energy_balance: args
            .energy_balance
            .unwrap_or(BenchOptions::default().energy_balance),
        field_stiffness: match &args.field_stiffness {
            Some(name) => field_stiffness(name)?,
            None => BenchOptions::default().field_stiffness,
        },
        max_split_depth: match args.max_split_depth {
            Some(d) => super::common::split_depth(d)?,
            None => BenchOptions::default().max_split_depth,
        },
        ..BenchOptions::default()
    };
    let report = bench(&options)?;
    println!(
        "N={} strands={} steps={} length={} m engine={} ({}) kernels={kernel_name} ({}) effects={effects} integrator={integrator_name}",
        args.elements,
        args.strands,
        args.steps,
        args.length,
        options.engine.name(),
        report.engine,
        report.kernel
    );
    print_report(&report);
    Ok(ExitCode::SUCCESS)
}

/// `bench --scene`: time the scene's own strands, optionally restricted to some effects.
fn bench_scene(path: &Path, args: &BenchArgs) -> Result<ExitCode, Error> {
    let text = superhelix_studies::runtime::input::read_text_bounded(
        path,
        superhelix_studies::runtime::input::TEXT_FILE_LIMIT,
        "scene file",
    )
    .map_err(|e| Error::invalid("--scene", e))?;
    let mut setup =
        superhelix_studies::runtime::parse_scene_at(&text, super::common::scene_dir(path))?;
    if let Some(list) = &args.effects {
        restrict_effects(&mut setup, EffectSet::parse(list)?)?;
    }
    if let Some(k) = &args.kernels {
        setup.config.kernels = kernels(k)?;
    }
    if let Some(name) = &args.integrator {
        setup.config.integrator = integrator(name)?;
    }
    if let Some(name) = &args.engine {
        setup.config.engine = engine(name)?;
    }
    if let Some(d) = args.max_split_depth {
        setup.config.max_split_depth = super::common::split_depth(d)?;
    }
    if let Some(name) = &args.field_stiffness {
        setup.config.field_stiffness = field_stiffness(name)?;
    }
    if let Some(on) = args.energy_balance {
        setup.config.energy_balance = on;
    }
    superhelix_studies::apply_tolerance(&mut setup, args.tolerance)?;
    let names = scene_effects(&setup).names().join(",");
    let integrator = setup.config.integrator.name();
    let budget = format!(
        "max_split_depth={} field_stiffness={} energy_balance={} tolerance={}",
        setup.config.max_split_depth,
        setup.config.field_stiffness.name(),
        setup.config.energy_balance,
        setup
            .config
            .tolerance
            .map_or("none".into(), |t| format!("{t:e}"))
    );
    let steps = args.steps;
    let report = bench_setup(setup, steps)?;
    println!(
        "scene={} strands={} steps={steps} engine={} kernels ({}) effects={names} integrator={integrator}",
        path.display(),
        report.strand_steps / steps.max(1),
        report.engine,
        report.kernel
    );
    println!("{budget}");
    print_report(&report);
    Ok(ExitCode::SUCCESS)
}

/// `--field-stiffness`, parsed.
fn field_stiffness(
    name: &str,
) -> Result<superhelix_studies::runtime::config::FieldStiffness, Error> {
    superhelix_studies::runtime::config::FieldStiffness::from_name(name)
        .ok_or_else(|| Error::invalid("--field-stiffness", "must be projected, split or explicit"))
}

/// The engine named by `--engine`.
fn engine(name: &str) -> Result<superhelix_studies::runtime::config::Engine, Error> {
    superhelix_studies::runtime::config::Engine::from_name(name)
        .ok_or_else(|| Error::invalid("--engine", "must be auto, runtime or embedded"))
}

fn print_report(report: &BenchReport) {
    let solves = report.attempts;
    println!(
        "wall {:.3} s, {:.2} us per strand-step, {} substeps ({} for the energy balance, {} for a rotation, a contact or a failure), {} energy-limited, {} rotation-limited, {} threads",
        report.seconds,
        1e6 / report.strand_steps_per_second,
        report.substeps,
        report.energy_rejected,
        report.substeps - report.energy_rejected.min(report.substeps),
        report.energy_limited,
        report.rotation_limited,
        report.threads,
    );
    if let Some(cpu) = report.cpu_seconds {
        println!(
            "cpu {:.3} s: {:.2} us of CPU per strand-step, {:.2} us per implicit solve ({} solves)",
            cpu,
            1e6 * cpu / report.strand_steps.max(1) as f64,
            1e6 * cpu / solves.max(1) as f64,
            solves
        );
    }
    println!(
        "{}",
        superhelix_studies::stress::field_stiffness_line(
            report.field_split,
            report.field_projected,
            report.field_undamped
        )
    );
    if let Some(pairs) = report.hair_pairs {
        println!(
            "hair-hair pairs: {pairs:.0} per step on average, tracked and searched in {:.3} s of the wall time",
            report.hair_pair_seconds.unwrap_or(0.0)
        );
    }
    if let Some(d) = report.deepest {
        println!(
            "deepest centreline point inside a body after any step: {:.3} mm (dense sweep, not timed)",
            1e3 * d
        );
    }
    println!("frames_per_second={:.1}", report.frames_per_second);
    println!(
        "strand_steps_per_second={:.1}",
        report.strand_steps_per_second
    );
    println!(
        "solves_per_strand_step={:.3}",
        solves as f64 / report.strand_steps.max(1) as f64
    );
}

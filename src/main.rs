//! The `superhelix` command: `run` a scene to `frames.json`, `validate` a scene, `bench`,
//! `compare-kernels`, `quadrature-table`, `study` and `stress`.

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use superhelix::{Error, FieldError};

/// Super-Helix hair dynamics (Bertails et al. 2006).
#[derive(Parser)]
#[command(name = "superhelix", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene and write DIR/frames.json (the built-in demo scene without SCENE).
    Run {
        /// Scene file (TOML); without it, the built-in demo scene.
        scene: Option<PathBuf>,
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "out")]
        out: PathBuf,
    },
    /// Check a scene file and list every problem.
    Validate {
        /// Scene file (TOML).
        scene: PathBuf,
    },
    /// Time S independent strands of N elements; last line `strand_steps_per_second=<v>`.
    Bench {
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
        /// Worker threads the strands are spread over (default: one per core). With 1,
        /// the CPU time per strand-step is the step's own cost, free of the scheduling
        /// and shared-core effects of parallel runs.
        #[arg(long)]
        threads: Option<usize>,
    },
    /// Compare a strand kernel (default: the generated one for N) with a high-order
    /// quadrature reference on K random configurations; last line
    /// `max_relative_deviation=<v>`.
    CompareKernels {
        /// Elements per strand N.
        #[arg(long)]
        elements: usize,
        /// Number of random configurations K.
        #[arg(long, default_value_t = 1000)]
        samples: usize,
        /// Seed of the random configurations.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Kernel compared: generated, or (for development) generic-adaptive or
        /// generic-<n> (n Gauss-Legendre points per element).
        #[arg(long, default_value = "generated")]
        candidate: String,
    },
    /// Markdown table of the generic kernel's error and time per strand-step against its
    /// Gauss-Legendre order, against the closed-form kernel (or a 256-point stand-in).
    QuadratureTable {
        /// Elements per strand N.
        #[arg(long, default_value_t = 5)]
        elements: usize,
        /// Hair type: smooth, wavy, curly, fuzzy.
        #[arg(long, default_value = "fuzzy")]
        preset: String,
        /// Time steps T of the simulation that is timed and whose states are compared.
        #[arg(long, default_value_t = 30)]
        steps: usize,
        /// Strands S of that simulation.
        #[arg(long, default_value_t = 4)]
        strands: usize,
        /// Timed runs per order (the fastest counts).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
    },
    /// Run the hard cases (every preset, N, dt and head motion, and the extremes); one
    /// line per failed case, a table per group, last line `cases=<n> failed=<m>`; exit
    /// code 1 when a case fails.
    Stress {
        /// Only the quick subset (the one `cargo test` runs).
        #[arg(long)]
        quick: bool,
        /// Only the cases whose name contains SUBSTR.
        #[arg(long, value_name = "SUBSTR")]
        filter: Option<String>,
        /// Also print one line per case with what was measured.
        #[arg(long)]
        verbose: bool,
        /// Run every case with this integrator (linearly-implicit-euler, newton-implicit-euler,
        /// bdf2, rk4): cases are then named `<case>@<integrator>`, the conservative group keeps
        /// its cases of that integrator, and the known failures (of linearly implicit Euler)
        /// do not apply.
        #[arg(long)]
        integrator: Option<String>,
    },
    /// What accuracy costs: error against cost of N, dt, integrator and kernels on
    /// reference problems; writes DIR/report.md and one plot per problem.
    Study {
        /// Only a reduced grid of each problem (the one `cargo test` runs).
        #[arg(long)]
        quick: bool,
        /// Output directory.
        #[arg(long, value_name = "DIR", default_value = "study")]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run { scene, out } => run(scene.as_deref(), &out),
        Command::Validate { scene } => validate(&scene),
        Command::Bench {
            elements,
            strands,
            steps,
            kernels,
            effects,
            preset,
            integrator,
            quadrature,
            scene,
            threads,
        } => with_threads(threads, || match scene {
            Some(path) => bench_scene(
                &path,
                steps,
                kernels.as_deref(),
                effects.as_deref(),
                integrator.as_deref(),
            ),
            None => bench(
                elements,
                strands,
                steps,
                kernels.as_deref().unwrap_or("auto"),
                effects.as_deref().unwrap_or("gravity,drag,friction"),
                &preset,
                integrator.as_deref().unwrap_or("linearly-implicit-euler"),
                quadrature,
            ),
        }),
        Command::CompareKernels {
            elements,
            samples,
            seed,
            candidate,
        } => compare_kernels(elements, samples, seed, &candidate),
        Command::QuadratureTable {
            elements,
            preset,
            steps,
            strands,
            repeats,
        } => quadrature_table(elements, &preset, steps, strands, repeats),
        Command::Stress {
            quick,
            filter,
            verbose,
            integrator,
        } => stress(quick, filter.as_deref(), verbose, integrator.as_deref()),
        Command::Study { quick, out } => study(quick, &out),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            report(&e);
            ExitCode::FAILURE
        }
    }
}

fn read_scene(path: &Path) -> Result<String, Error> {
    std::fs::read_to_string(path).map_err(|source| Error::Io {
        path: path.display().to_string(),
        source,
    })
}

fn run(scene: Option<&Path>, out: &Path) -> Result<ExitCode, Error> {
    let text = match scene {
        Some(path) => read_scene(path)?,
        None => superhelix::DEFAULT_SCENE.to_string(),
    };
    let bar = progress_bar();
    let (summary, path) = superhelix::run_scene(&text, out, |step, total| {
        if let Some(bar) = &bar {
            bar.set_length(total as u64);
            bar.set_position(step as u64);
        }
    })?;
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    println!("{}: {summary}", path.display());
    Ok(ExitCode::SUCCESS)
}

/// A progress bar on stderr, only when stderr is a terminal.
fn progress_bar() -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps {elapsed} (eta {eta})")
    {
        bar.set_style(style);
    }
    Some(bar)
}

fn validate(path: &Path) -> Result<ExitCode, Error> {
    let text = read_scene(path)?;
    match superhelix::check_scene(&text) {
        Ok((strands, steps)) => {
            println!("ok: {strands} strands, {steps} steps");
            Ok(ExitCode::SUCCESS)
        }
        Err(problems) => {
            print_problems(&problems);
            eprintln!("{}: {} problem(s)", path.display(), problems.len());
            Ok(ExitCode::FAILURE)
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn bench(
    elements: usize,
    strands: usize,
    steps: usize,
    kernels: &str,
    effects: &str,
    preset: &str,
    integrator: &str,
    quadrature: Option<usize>,
) -> Result<ExitCode, Error> {
    use superhelix::bench::{bench, BenchOptions, EffectSet};
    use superhelix::runtime::material::Preset;
    use superhelix::runtime::simulation::{IntegratorKind, KernelChoice};
    let options = BenchOptions {
        elements,
        strands,
        steps,
        kernels: KernelChoice::from_name(kernels)
            .ok_or_else(|| Error::invalid("--kernels", "must be generated, generic or auto"))?,
        effects: EffectSet::parse(effects)?,
        preset: Preset::from_name(preset)
            .ok_or_else(|| Error::invalid("--preset", "must be smooth, wavy, curly or fuzzy"))?,
        integrator: IntegratorKind::from_name(integrator).ok_or_else(|| {
            Error::invalid(
                "--integrator",
                "must be linearly-implicit-euler, newton-implicit-euler, bdf2 or rk4",
            )
        })?,
        quadrature: match quadrature {
            Some(0) => return Err(Error::invalid("--quadrature", "must be >= 1")),
            Some(n) => superhelix::runtime::QuadratureRule::Fixed(n),
            None => superhelix::runtime::QuadratureRule::Adaptive,
        },
        ..BenchOptions::default()
    };
    let report = bench(&options)?;
    println!(
        "N={elements} strands={strands} steps={steps} kernels={kernels} ({}) effects={effects} integrator={integrator}",
        report.kernel
    );
    print_bench_report(&report);
    Ok(ExitCode::SUCCESS)
}

/// Run `f` on a pool of `threads` workers (`bench --threads`), or on the global pool.
fn with_threads(
    threads: Option<usize>,
    f: impl FnOnce() -> Result<ExitCode, Error> + Send,
) -> Result<ExitCode, Error> {
    match threads {
        None => f(),
        Some(0) => Err(Error::invalid("--threads", "must be >= 1")),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::invalid("--threads", format!("cannot start {t} threads: {e}")))?
            .install(f),
    }
}

/// `bench --scene`: time the scene's own strands, optionally restricted to some effects.
fn bench_scene(
    path: &std::path::Path,
    steps: usize,
    kernels: Option<&str>,
    effects: Option<&str>,
    integrator: Option<&str>,
) -> Result<ExitCode, Error> {
    use superhelix::bench::{bench_setup, restrict_effects, scene_effects, EffectSet};
    use superhelix::runtime::simulation::{IntegratorKind, KernelChoice};
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::invalid("--scene", format!("cannot read {}: {e}", path.display())))?;
    let mut setup = superhelix::parse_scene(&text)?;
    if let Some(list) = effects {
        restrict_effects(&mut setup, EffectSet::parse(list)?)?;
    }
    if let Some(k) = kernels {
        setup.config.kernels = KernelChoice::from_name(k)
            .ok_or_else(|| Error::invalid("--kernels", "must be generated, generic or auto"))?;
    }
    if let Some(name) = integrator {
        setup.config.integrator = IntegratorKind::from_name(name).ok_or_else(|| {
            Error::invalid(
                "--integrator",
                "must be linearly-implicit-euler, newton-implicit-euler, bdf2 or rk4",
            )
        })?;
    }
    let names = scene_effects(&setup).names().join(",");
    let integrator = setup.config.integrator.name();
    let report = bench_setup(setup, steps)?;
    println!(
        "scene={} steps={steps} kernels ({}) effects={names} integrator={integrator}",
        path.display(),
        report.kernel
    );
    print_bench_report(&report);
    Ok(ExitCode::SUCCESS)
}

fn print_bench_report(report: &superhelix::bench::BenchReport) {
    let threads = report.threads;
    // every split discards its attempt and solves two halves
    let solves = report.strand_steps + 2 * report.substeps;
    println!(
        "wall {:.3} s, {:.2} us per strand-step, {} substeps, {} threads",
        report.seconds,
        1e6 / report.strand_steps_per_second,
        report.substeps,
        threads,
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
        "strand_steps_per_second={:.1}",
        report.strand_steps_per_second
    );
}

fn compare_kernels(
    elements: usize,
    samples: usize,
    seed: u64,
    candidate: &str,
) -> Result<ExitCode, Error> {
    use superhelix::compare::{compare_kernels, Candidate, CompareOptions};
    let options = CompareOptions {
        elements,
        samples,
        seed,
        candidate: Candidate::from_name(candidate).ok_or_else(|| {
            Error::invalid(
                "--candidate",
                "must be generated, generic-adaptive or generic-<n> with n in 1..=256",
            )
        })?,
    };
    let report = compare_kernels(&options, superhelix::kernel_factory())?;
    print!("{}", report.render());
    Ok(ExitCode::SUCCESS)
}

fn quadrature_table(
    elements: usize,
    preset: &str,
    steps: usize,
    strands: usize,
    repeats: usize,
) -> Result<ExitCode, Error> {
    use superhelix::quadrature_table::{quadrature_table, TableOptions};
    use superhelix::runtime::material::Preset;
    let options = TableOptions {
        elements,
        preset: Preset::from_name(preset)
            .ok_or_else(|| Error::invalid("--preset", "must be smooth, wavy, curly or fuzzy"))?,
        steps,
        strands,
        repeats,
    };
    let table = quadrature_table(&options, superhelix::kernel_factory())?;
    print!("{}", table.render());
    Ok(ExitCode::SUCCESS)
}

fn stress(
    quick: bool,
    filter: Option<&str>,
    verbose: bool,
    integrator: Option<&str>,
) -> Result<ExitCode, Error> {
    use superhelix::runtime::simulation::IntegratorKind;
    use superhelix::stress;
    let mut cases: Vec<stress::Case> = if quick {
        stress::quick_cases()
    } else {
        stress::all_cases()
    };
    if let Some(name) = integrator {
        let kind = IntegratorKind::from_name(name).ok_or_else(|| {
            Error::invalid(
                "--integrator",
                "must be linearly-implicit-euler, newton-implicit-euler, bdf2 or rk4",
            )
        })?;
        cases = stress::with_integrator(cases, kind);
    }
    let cases: Vec<stress::Case> = cases
        .into_iter()
        .filter(|c| filter.is_none_or(|f| c.name.contains(f)))
        .collect();
    let start = std::time::Instant::now();
    let results = stress::run_cases(&cases);
    if verbose {
        for r in &results {
            println!("{}", stress::detail_line(r));
        }
    }
    print!(
        "{}",
        stress::render(&results, start.elapsed().as_secs_f64())
    );
    Ok(if results.iter().all(|r| r.passed()) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn study(quick: bool, out: &Path) -> Result<ExitCode, Error> {
    use superhelix::study::{run_study, write_report, StudyOptions};
    let options = StudyOptions {
        quick,
        command: format!(
            "superhelix study{} --out {}",
            if quick { " --quick" } else { "" },
            out.display()
        ),
    };
    let study = run_study(&options, superhelix::kernel_factory())?;
    let files = write_report(&study, out)?;
    for problem in &study.problems {
        let best = problem
            .budgets()
            .iter()
            .rev()
            .find_map(|&b| problem.best_within(b));
        if let Some(p) = best {
            if let Ok(m) = &p.outcome {
                println!(
                    "{}: {} points, most accurate within the largest budget: {} (error {:.2e})",
                    problem.key,
                    problem.points.len(),
                    p.setting.label(),
                    m.error
                );
            }
        }
    }
    for f in &files {
        println!("wrote {}", f.display());
    }
    println!("study_seconds={:.1}", study.wall_seconds);
    Ok(ExitCode::SUCCESS)
}

fn print_problems(problems: &[FieldError]) {
    for p in problems {
        println!("{p}");
    }
}

fn report(e: &Error) {
    match e {
        Error::Invalid(problems) => {
            eprintln!("error: invalid scene:");
            for p in problems {
                eprintln!("  {p}");
            }
        }
        other => eprintln!("error: {other}"),
    }
}

//! The `superhelix` command. Each command is one file in `src/cli/`: `run` a scene (or a
//! part of it), `validate` a scene, `merge` the parts of a split run, `render` written
//! frames, and the measurements `bench`, `compare-kernels`, `quadrature-table`, `study`
//! and `stress`.

mod cli;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// Super-Helix hair dynamics (Bertails et al. 2006).
#[derive(Parser)]
#[command(name = "superhelix", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scene and write its frames and previews into DIR (the built-in demo
    /// scene without SCENE). Ctrl-C stops the run and keeps every frame written.
    Run(cli::run::RunArgs),
    /// Check a scene file and list every problem.
    Validate(cli::validate::ValidateArgs),
    /// Join the outputs of the parts of a split run (run --part K/P) into those of the
    /// whole scene: frames.npy, frames.json, hair.usda and the pictures.
    Merge(cli::merge::MergeArgs),
    /// Re-render the preview pictures (preview.png, preview_first.png, preview.gif) from
    /// frames a run wrote, with other camera settings.
    Render(cli::render::RenderArgs),
    /// Time S independent strands of N elements; last line `strand_steps_per_second=<v>`.
    Bench(cli::bench::BenchArgs),
    /// Compare a strand kernel (default: the generated one for N) with a high-order
    /// quadrature reference on K random configurations; last line
    /// `max_relative_deviation=<v>`.
    CompareKernels(cli::compare_kernels::CompareKernelsArgs),
    /// Coulomb potential and field of a point set (.npy in and out) by the fast multipole method.
    Coulomb(cli::coulomb::CoulombArgs),
    /// Cost of the multipole method against particles (10^4 ... 4*10^6) and the direct sum's rate.
    CoulombScaling(cli::coulomb_scaling::CoulombScalingArgs),
    /// The paper's static-electricity experiments on a curly tress (report, pictures, plot).
    Electrostatics(cli::electrostatics::ElectrostaticsArgs),
    /// Markdown table of the generic kernel's error and time per strand-step against its
    /// Gauss-Legendre order, against the closed-form kernel (or a 256-point stand-in).
    QuadratureTable(cli::quadrature_table::QuadratureTableArgs),
    /// Run the hard cases (every preset, N, dt and head motion, and the extremes); one
    /// line per failed case, a table per group, last line `cases=<n> failed=<m>`; exit
    /// code 1 when a case fails.
    Stress(cli::stress::StressArgs),
    /// What accuracy costs: error against cost of N, dt, integrator and kernels on
    /// reference problems; writes DIR/report.md and one plot per problem.
    Study(cli::study::StudyArgs),
}

fn main() -> ExitCode {
    // a closed standard output (`superhelix validate scene.toml | head -1`) ends the
    // command quietly, as it ends any Unix tool, instead of a panic of `println!`
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal before any thread starts
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let result = match Cli::parse().command {
        Command::Run(args) => cli::run::run(args),
        Command::Validate(args) => cli::validate::run(args),
        Command::Merge(args) => cli::merge::run(args),
        Command::Render(args) => cli::render::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::CompareKernels(args) => cli::compare_kernels::run(args),
        Command::Coulomb(args) => cli::coulomb::run(args),
        Command::CoulombScaling(args) => cli::coulomb_scaling::run(args),
        Command::Electrostatics(args) => cli::electrostatics::run(args),
        Command::QuadratureTable(args) => cli::quadrature_table::run(args),
        Command::Stress(args) => cli::stress::run(args),
        Command::Study(args) => cli::study::run(args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            cli::common::report(&e);
            ExitCode::FAILURE
        }
    }
}

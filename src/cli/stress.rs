//! `superhelix stress`: the hard cases.

use clap::Args;
use std::process::ExitCode;
use superhelix_studies::stress;
use superhelix_studies::Error;

/// Arguments of `stress`.
#[derive(Args)]
pub struct StressArgs {
    /// Only the quick subset (the one `cargo test` runs).
    #[arg(long)]
    quick: bool,
    /// Only the cases whose name contains SUBSTR.
    #[arg(long, value_name = "SUBSTR")]
    filter: Option<String>,
    /// Also print one line per case with what was measured, as soon as the case has run
    /// (in the order the cases finish).
    #[arg(long)]
    verbose: bool,
    /// Run every case with this integrator (linearly-implicit-euler, newton-implicit-euler,
    /// bdf2, rk4): cases are then named `<case>@<integrator>`, the conservative group keeps
    /// its cases of that integrator, and the known failures (of linearly implicit Euler)
    /// do not apply.
    #[arg(long)]
    integrator: Option<String>,
    /// Run every case with this field stiffness in the implicit step's matrix
    /// (projected, the default, split or explicit): cases are then named `<case>@split`
    /// or `<case>@explicit`.
    #[arg(long)]
    field_stiffness: Option<String>,
    /// Run every case on this engine: auto (the default: the embedded fixed-N step
    /// wherever it can run the case, else the runtime's), runtime or embedded (a case it
    /// cannot run is then an error; on embedded, the cases it cannot run are left out:
    /// RK4, and an N without fixed-N code).
    #[arg(long)]
    engine: Option<String>,
    /// Run every case with this deepest split of a step, 0 to 8 (`[simulation]
    /// max_split_depth`; 0: one solve per strand-step, the step budget): cases are then
    /// named `<case>@depth<D>`.
    #[arg(long, value_name = "D")]
    max_split_depth: Option<usize>,
    /// Run every linearly implicit Euler case by the error-controlled step at this
    /// tolerance (`[simulation] tolerance`, 1e-8 to 0.5): cases are then named
    /// `<case>@tol<tolerance>`.
    #[arg(long, value_name = "TOL", allow_negative_numbers = true)]
    tolerance: Option<f64>,
}

/// Run `stress`.
pub fn run(args: StressArgs) -> Result<ExitCode, Error> {
    let cases = stress::select_cases(&stress::StressOptions {
        quick: args.quick,
        filter: args.filter,
        integrator: args.integrator,
        field_stiffness: args.field_stiffness,
        engine: args.engine,
        max_split_depth: args.max_split_depth,
        tolerance: args.tolerance,
    })?;
    let start = std::time::Instant::now();
    let results = if args.verbose {
        stress::run_cases_with(&cases, |r| println!("{}", stress::detail_line(r)))
    } else {
        stress::run_cases(&cases)
    };
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

//! `superhelix quadrature-table`: the generic kernel's error and cost against its
//! Gauss–Legendre order.

use super::common::preset;
use clap::Args;
use std::process::ExitCode;
use superhelix_studies::quadrature_table::{quadrature_table, TableOptions};
use superhelix_studies::Error;

/// Arguments of `quadrature-table`.
#[derive(Args)]
pub struct QuadratureTableArgs {
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
}

/// Run `quadrature-table`.
pub fn run(args: QuadratureTableArgs) -> Result<ExitCode, Error> {
    let options = TableOptions {
        elements: args.elements,
        preset: preset(&args.preset)?,
        steps: args.steps,
        strands: args.strands,
        repeats: args.repeats,
    };
    let table = quadrature_table(&options, superhelix_studies::kernel_factory())?;
    print!("{}", table.render());
    Ok(ExitCode::SUCCESS)
}

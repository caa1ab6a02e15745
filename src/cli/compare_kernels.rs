//! `superhelix compare-kernels`: a strand kernel against a high-order quadrature reference.

use clap::Args;
use std::process::ExitCode;
use superhelix_studies::compare::{compare_kernels, Candidate, CompareOptions};
use superhelix_studies::Error;

/// Arguments of `compare-kernels`.
#[derive(Args)]
pub struct CompareKernelsArgs {
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
}

/// Run `compare-kernels`.
pub fn run(args: CompareKernelsArgs) -> Result<ExitCode, Error> {
    let options = CompareOptions {
        elements: args.elements,
        samples: args.samples,
        seed: args.seed,
        candidate: Candidate::from_name(&args.candidate).ok_or_else(|| {
            Error::invalid(
                "--candidate",
                "must be generated, generic-adaptive or generic-<n> with n in 1..=256",
            )
        })?,
    };
    let report = compare_kernels(&options, superhelix_studies::kernel_factory())?;
    print!("{}", report.render());
    Ok(ExitCode::SUCCESS)
}

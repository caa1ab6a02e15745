//! `superhelix electrostatics`: the paper's experiments on a charged tress.

use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_studies::electrostatics_study::{run_experiments, write_report, ExperimentOptions};
use superhelix_studies::Error;

/// Arguments of `electrostatics`.
#[derive(Args)]
pub struct ElectrostaticsArgs {
    /// Folder of the report, its plot and each case's files.
    #[arg(long, default_value = "electrostatics")]
    out: PathBuf,
    /// Fibres of the tress.
    #[arg(long, default_value_t = 300)]
    fibres: usize,
    /// Elements per fibre (the report's "which N" table says why 30).
    #[arg(long, default_value_t = 30)]
    elements: usize,
    /// Highest multipole order of experiment 2.
    #[arg(long, default_value_t = 14)]
    max_order: usize,
    /// Run experiment 3 instead: the charged half scalp (--fibres defaults to 65,000 and
    /// --elements to 5 there).
    #[arg(long)]
    half_scalp: bool,
    /// Requested field accuracy of experiment 3.
    #[arg(long, default_value_t = 1e-3)]
    accuracy: f64,
}

/// Run `electrostatics`.
pub fn run(args: ElectrostaticsArgs) -> Result<ExitCode, Error> {
    if args.fibres == 0 {
        return Err(Error::invalid("--fibres", "must be >= 1"));
    }
    if !(1..=superhelix_fmm::MAX_ORDER).contains(&args.max_order) {
        return Err(Error::invalid("--max-order", "must be in [1, 40]"));
    }
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Io {
        path: args.out.display().to_string(),
        source,
    })?;
    if args.half_scalp {
        let fibres = if args.fibres == 300 {
            65_000
        } else {
            args.fibres
        };
        let elements = if args.elements == 30 {
            5
        } else {
            args.elements
        };
        let h = superhelix_studies::electrostatics_study::run_half_scalp(
            fibres,
            elements,
            args.accuracy,
            &args.out,
        )?;
        println!(
            "half scalp: {fibres} fibres, {} particles: charged static solve {:.1} s ({:?} outer iterations, residual {:.1e}), \
             setup {:.1} s, mean field {:.2} kV/m",
            h.particles, h.case.seconds, h.case.iterations, h.case.residual, h.setup_seconds, h.case.mean_field / 1e3
        );
        println!("wrote {}", args.out.join("half_scalp.md").display());
        return Ok(ExitCode::SUCCESS);
    }
    let options = ExperimentOptions {
        fibres: args.fibres,
        elements: args.elements,
        orders: (1..=args.max_order).collect(),
        ..Default::default()
    };
    std::fs::create_dir_all(&args.out).map_err(|source| Error::Io {
        path: args.out.display().to_string(),
        source,
    })?;
    let e = run_experiments(&options, &args.out, |name| eprintln!("{name} …"))?;
    for f in write_report(&e, &args.out)? {
        println!("wrote {}", f.display());
    }
    for c in &e.cases {
        println!(
            "{:45} tips {:6.2} mm from the axis, {:5.2} cm deep, mean field {:6.2} kV/m, {:.1} s",
            c.description,
            c.tip_spread * 1e3,
            c.tip_depth * 1e2,
            c.mean_field / 1e3,
            c.seconds
        );
    }
    Ok(ExitCode::SUCCESS)
}

//! `superhelix coulomb-scaling`: the multipole method's cost against particles.

use super::common::with_threads;
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_studies::coulomb_scaling::{measure, plot, render};
use superhelix_studies::Error;

/// Arguments of `coulomb-scaling`.
#[derive(Args)]
pub struct CoulombScalingArgs {
    /// Requested accuracy.
    #[arg(long, default_value_t = 1e-6)]
    eps: f64,
    /// Largest set, particles (sizes go up by √10 from 10⁴).
    #[arg(long, default_value_t = 4_000_000)]
    max: usize,
    /// Particles of the direct sum's measurement.
    #[arg(long, default_value_t = 20_000)]
    direct: usize,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
    /// Folder for scaling.md and scaling.svg.
    #[arg(long, default_value = "coulomb-scaling")]
    out: PathBuf,
}

/// Run `coulomb-scaling`.
pub fn run(args: CoulombScalingArgs) -> Result<ExitCode, Error> {
    if args.max < 10_000 {
        return Err(Error::invalid("--max", "must be >= 10000"));
    }
    let mut sizes = Vec::new();
    let mut n = 10_000f64;
    while n <= args.max as f64 * 1.0001 {
        sizes.push(n.round() as usize);
        n *= 10f64.sqrt();
    }
    if sizes.last() != Some(&args.max) {
        sizes.push(args.max);
    }
    let s = with_threads(args.threads, || measure(&sizes, args.eps, args.direct))?;
    let io = |p: &std::path::Path| {
        let p = p.display().to_string();
        move |source| Error::Io { path: p, source }
    };
    std::fs::create_dir_all(&args.out).map_err(io(&args.out))?;
    let table = render(&s);
    print!("{table}");
    let md = args.out.join("scaling.md");
    std::fs::write(&md, &table).map_err(io(&md))?;
    let svg = args.out.join("scaling.svg");
    std::fs::write(&svg, plot(&s)?).map_err(io(&svg))?;
    println!("wrote {}\nwrote {}", md.display(), svg.display());
    Ok(ExitCode::SUCCESS)
}

//! `superhelix coulomb`: potential and field of a point set from `.npy` files.

use super::common::with_threads;
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_fmm::{FmmOptions, Softening};
use superhelix_studies::coulomb::{coulomb_files, Method, COULOMB_CONSTANT};
use superhelix_studies::Error;

/// Arguments of `coulomb`.
#[derive(Args)]
pub struct CoulombArgs {
    /// Positions, `.npy` of shape [n, 3] (float64 or float32), m.
    #[arg(long)]
    points: PathBuf,
    /// Charges, `.npy` of shape [n], C.
    #[arg(long)]
    charges: PathBuf,
    /// Requested relative accuracy of the field (multipole method).
    #[arg(long, default_value_t = 1e-6)]
    eps: f64,
    /// Expansion order p instead of the one chosen from --eps.
    #[arg(long)]
    order: Option<usize>,
    /// Opening criterion θ instead of the one chosen from --eps.
    #[arg(long)]
    theta: Option<f64>,
    /// Most particles per leaf of the octree.
    #[arg(long)]
    leaf_size: Option<usize>,
    /// Sum every pair directly instead (O(n²)).
    #[arg(long)]
    direct: bool,
    /// Radius of the ball each charge is spread over in the near field, m (0: point charges).
    #[arg(long, default_value_t = 0.0)]
    softening: f64,
    /// The constant k of Φ = k Σ q/r (default 1/(4πε₀): volts; 1: the plain kernel 1/r).
    #[arg(long, default_value_t = COULOMB_CONSTANT)]
    constant: f64,
    /// Folder for potential.npy and field.npy.
    #[arg(long)]
    out: PathBuf,
    /// Worker threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
}

/// Run `coulomb`.
pub fn run(args: CoulombArgs) -> Result<ExitCode, Error> {
    if !(args.softening.is_finite() && args.softening >= 0.0) {
        return Err(Error::invalid("--softening", "must be finite and >= 0"));
    }
    if !args.constant.is_finite() {
        return Err(Error::invalid("--constant", "must be finite"));
    }
    let softening = Softening {
        radius: args.softening,
    };
    let method = if args.direct {
        Method::Direct(softening)
    } else {
        let mut o = FmmOptions::for_accuracy(args.eps)
            .map_err(|e| Error::invalid("--eps", e.to_string()))?;
        if let Some(p) = args.order {
            o.order = p;
        }
        if let Some(t) = args.theta {
            o.theta = t;
        }
        if let Some(l) = args.leaf_size {
            o.leaf_size = l;
        }
        o.softening = softening;
        Method::Fmm(o)
    };
    let report = with_threads(args.threads, || {
        coulomb_files(
            &args.points,
            &args.charges,
            method,
            args.constant,
            &args.out,
        )
    })?;
    match (method, report.stats) {
        (Method::Fmm(o), Some(s)) => println!(
            "fmm: {} particles, p = {}, theta = {}, leaf {}: {:.3} s ({} boxes, {} leaves, depth {}, {} M2L, {} direct pairs)",
            report.particles, o.order, o.theta, o.leaf_size, report.seconds, s.nodes, s.leaves, s.depth, s.m2l,
            s.p2p_interactions
        ),
        _ => println!("direct: {} particles: {:.3} s", report.particles, report.seconds),
    }
    for f in &report.written {
        println!("wrote {}", f.display());
    }
    Ok(ExitCode::SUCCESS)
}

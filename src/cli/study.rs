//! `superhelix study`: what accuracy costs.

use clap::builder::PossibleValuesParser;
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_studies::study::{run_study, write_report, StudyOptions, PROBLEMS};
use superhelix_studies::Error;

/// Arguments of `study`.
#[derive(Args)]
pub struct StudyArgs {
    /// Only a reduced grid of each problem (the one `cargo test` runs).
    #[arg(long)]
    quick: bool,
    /// Only this problem (and not the cost against N, which is the whole study's).
    #[arg(long, value_name = "PROBLEM", value_parser = PossibleValuesParser::new(PROBLEMS))]
    only: Option<String>,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "study")]
    out: PathBuf,
}

/// Run `study`.
pub fn run(args: StudyArgs) -> Result<ExitCode, Error> {
    let out = &args.out;
    let options = StudyOptions {
        quick: args.quick,
        only: args.only.clone(),
        command: format!(
            "superhelix study{}{} --out {}",
            if args.quick { " --quick" } else { "" },
            args.only
                .as_ref()
                .map_or(String::new(), |o| format!(" --only {o}")),
            out.display()
        ),
    };
    let study = run_study(&options, superhelix_studies::kernel_factory())?;
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

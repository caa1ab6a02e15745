//! `superhelix merge PART_DIRS... --out DIR`: the parts of a split run joined
//! ([`superhelix_studies::merge`]).

use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;
use superhelix_studies::Error;

/// Arguments of `merge`.
#[derive(Args)]
pub struct MergeArgs {
    /// The output folders of `run --part K/P`, one per part, in any order.
    #[arg(required = true, value_name = "PART_DIRS")]
    parts: Vec<PathBuf>,
    /// Output directory of the whole scene.
    #[arg(long, value_name = "DIR", default_value = "out")]
    out: PathBuf,
}

/// Run `merge`.
pub fn run(args: MergeArgs) -> Result<ExitCode, Error> {
    let files = superhelix_studies::merge::merge(&args.parts, &args.out)?;
    for file in &files {
        println!("wrote {}", file.display());
    }
    println!(
        "merged {} parts into {}",
        args.parts.len(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

//! The `superhelix` command: `run` a scene to `frames.json`, `validate` a scene.

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
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Run { scene, out } => run(scene.as_deref(), &out),
        Command::Validate { scene } => validate(&scene),
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

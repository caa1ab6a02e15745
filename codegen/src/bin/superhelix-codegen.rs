//! Regenerate the checked-in kernels: `cargo run -p superhelix-codegen --release --
//! generated/src` writes every generated file there; `--check` only compares and exits
//! with 1 (printing the stale files) when they differ.

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut check = false;
    let mut dir = PathBuf::from("generated/src");
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "--check" => check = true,
            "-h" | "--help" => {
                println!(
                    "usage: superhelix-codegen [--check] [DIR]   (DIR defaults to generated/src)"
                );
                return ExitCode::SUCCESS;
            }
            other => dir = PathBuf::from(other),
        }
    }
    let files = match superhelix_codegen::kernels::checked_in_files() {
        Ok(files) => files,
        Err(e) => {
            eprintln!("error: generation failed: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut stale = 0;
    for (name, text) in files {
        let path = dir.join(&name);
        let current = std::fs::read_to_string(&path).unwrap_or_default();
        if current == text {
            continue;
        }
        stale += 1;
        if check {
            eprintln!("stale: {}", path.display());
        } else if let Err(e) = path
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| std::fs::write(&path, text))
        {
            eprintln!("error: {}: {e}", path.display());
            return ExitCode::FAILURE;
        } else {
            println!("wrote {}", path.display());
        }
    }
    if check && stale > 0 {
        eprintln!(
            "{stale} generated file(s) are stale: run `cargo run -p superhelix-codegen --release`"
        );
        return ExitCode::FAILURE;
    }
    ExitCode::SUCCESS
}

//! Generates the fixed-N modules for the numbers of elements listed in `SUPERHELIX_N`
//! (e.g. `SUPERHELIX_N=7,9 cargo build --release`) that are not checked in, into
//! `OUT_DIR`, with the same call a user's build script makes
//! (`superhelix_codegen::Kernels`); `src/lib.rs` includes them and adds them to
//! `fixed::visit_size`. Without `SUPERHELIX_N` it writes an empty list (text only, no
//! symbolic work) and reruns only when `SUPERHELIX_N` or this file changes. A malformed
//! list fails the build with a message naming the entry; nothing here panics.

use std::{env, path::PathBuf, process::ExitCode};
use superhelix_codegen::fixed_n::MAX_ELEMENTS;
use superhelix_codegen::sizes::CHECKED_IN_SIZES;
use superhelix_codegen::{Float, Kernels};

/// The sizes of `SUPERHELIX_N` (unset or empty: none), or the message for a bad entry.
fn requested() -> Result<Vec<usize>, String> {
    let list = match env::var("SUPERHELIX_N") {
        Ok(list) => list,
        Err(env::VarError::NotPresent) => return Ok(Vec::new()),
        Err(env::VarError::NotUnicode(_)) => {
            return Err("SUPERHELIX_N is not valid UTF-8".to_string())
        }
    };
    let mut sizes = Vec::new();
    for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match item.parse::<usize>() {
            Ok(n) if (1..=MAX_ELEMENTS).contains(&n) => sizes.push(n),
            Ok(n) => {
                return Err(format!(
                    "SUPERHELIX_N: N = {n} is out of range: N must be in 1..={MAX_ELEMENTS}"
                ))
            }
            Err(_) => {
                return Err(format!(
                    "SUPERHELIX_N: '{item}' is not a number of elements; expected a \
                     comma-separated list of integers in 1..={MAX_ELEMENTS}, e.g. SUPERHELIX_N=7,9"
                ))
            }
        }
    }
    Ok(sizes)
}

fn main() -> ExitCode {
    println!("cargo:rerun-if-env-changed=SUPERHELIX_N");
    println!("cargo:rerun-if-changed=build.rs");
    let sizes: Vec<usize> = match requested() {
        Ok(sizes) => sizes
            .into_iter()
            .filter(|n| !CHECKED_IN_SIZES.contains(n))
            .collect(),
        Err(message) => {
            eprintln!("error: {message}");
            return ExitCode::FAILURE;
        }
    };
    let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) else {
        eprintln!("error: OUT_DIR is not set (build.rs runs under cargo)");
        return ExitCode::FAILURE;
    };
    match Kernels::new()
        .elements(&sizes)
        .float(Float::F64)
        .float(Float::F32)
        .write_to(&out)
    {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: generating the fixed-N modules for SUPERHELIX_N: {e}");
            ExitCode::FAILURE
        }
    }
}

//! Writes the fixed-N strand of 7 elements in f64 and in f32 and its dispatch into
//! `OUT_DIR` (`n7.rs`, `n7_f32.rs`, `superhelix_kernels.rs`), which `src/lib.rs`
//! includes.

use std::process::ExitCode;
use superhelix_codegen::{Float, Kernels};

fn main() -> ExitCode {
    println!("cargo:rerun-if-changed=build.rs");
    let Some(out) = std::env::var_os("OUT_DIR") else {
        eprintln!("error: OUT_DIR is not set (build.rs runs under cargo)");
        return ExitCode::FAILURE;
    };
    match Kernels::new()
        .elements(&[7])
        .float(Float::F64)
        .float(Float::F32)
        .write_to(out)
    {
        Ok(_) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: generating the fixed-N strand: {e}");
            ExitCode::FAILURE
        }
    }
}

//! The embeddable crates build without std and without alloc: `tests/no_std_probe` is a
//! `#![no_std]` staticlib with its own panic handler and no global allocator that steps
//! a strand with the generated kernels, in f64 and in f32 (`n5::f32`); it compiles only
//! if neither std nor alloc is reached from superhelix-generated and superhelix-kernels.
//! Their normal dependencies hold none of the heavy crates an engine would not vendor.

use std::path::Path;
use std::process::Command;

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

#[test]
fn generated_kernels_build_without_std_and_alloc() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let probe = root.join("tests/no_std_probe/Cargo.toml");
    let target = root.join("target/no-std-probe");
    // an unoptimised build: whether std or alloc is reached does not depend on the
    // optimisation level, and the generated closed forms compile several times faster
    // without it
    let out = cargo()
        .args(["build", "--offline", "--manifest-path"])
        .arg(&probe)
        .arg("--target-dir")
        .arg(&target)
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "the no_std probe does not build:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lib = target.join("debug/libsuperhelix_no_std_probe.a");
    assert!(lib.exists(), "{} was not written", lib.display());
    let bytes = std::fs::read(&lib).expect("the probe library reads");
    for symbol in ["superhelix_probe_step", "superhelix_probe_step_f32"] {
        let name = symbol.as_bytes();
        assert!(
            bytes
                .windows(name.len() + 1)
                .any(|w| &w[..name.len()] == name
                    && !w[name.len()].is_ascii_alphanumeric()
                    && w[name.len()] != b'_'),
            "{symbol} is not in {}",
            lib.display()
        );
    }
}

#[test]
fn embeddable_crates_depend_on_nothing_heavy() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = cargo()
        .args([
            "tree",
            "--offline",
            "-e",
            "normal",
            "--prefix",
            "none",
            "--manifest-path",
        ])
        .arg(root.join("tests/no_std_probe/Cargo.toml"))
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let tree = String::from_utf8_lossy(&out.stdout);
    for heavy in ["faer", "rayon", "serde", "superhelix-runtime", "std "] {
        assert!(
            !tree.lines().any(|l| l.starts_with(heavy)),
            "the embeddable crates reach {heavy}:\n{tree}"
        );
    }
    assert!(tree.contains("superhelix-kernels"), "{tree}");
}

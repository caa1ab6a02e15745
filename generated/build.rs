//! Adds kernels for the numbers of elements listed in `SUPERHELIX_N` (e.g.
//! `SUPERHELIX_N=7,9 cargo build --release`) to the checked-in ones. The per-element
//! closed forms do not depend on N; what a size adds is its entry in the factory.

use std::{env, fs, path::Path};

/// Largest N accepted from `SUPERHELIX_N`.
const MAX_N: usize = 200;

fn main() {
    println!("cargo:rerun-if-env-changed=SUPERHELIX_N");
    let mut sizes = Vec::new();
    if let Ok(list) = env::var("SUPERHELIX_N") {
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            match item.parse::<usize>() {
                Ok(n) if (1..=MAX_N).contains(&n) => sizes.push(n),
                _ => {
                    println!(
                        "cargo:warning=SUPERHELIX_N: '{item}' is not a number of elements in 1..={MAX_N}; ignored"
                    );
                }
            }
        }
    }
    sizes.sort_unstable();
    sizes.dedup();
    let out = Path::new(&env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("extra_sizes.rs");
    let text = format!(
        "/// Sizes added at build time by `SUPERHELIX_N`.\npub const EXTRA_SIZES: &[usize] = &{sizes:?};\n"
    );
    fs::write(&out, text).expect("OUT_DIR is writable");
}

//! Memory of one strand and of one workspace of the fixed-N step at N = 5, 10 and 20
//! (the figures of docs/embedding.md):
//!
//! ```text
//! cargo run -p superhelix-capi --release --example memory
//! ```

use superhelix_kernels::fixed::{FixedStrand, FixedWorkspace};

fn row<const N: usize, const D: usize, const E: usize, const B: usize>() {
    let strand = FixedStrand::<N, D, B>::BYTES;
    let workspace = FixedWorkspace::<N, D, E>::BYTES;
    println!(
        "| {N:>2} | {strand:>6} B ({:>5.1} kB) | {workspace:>7} B ({:>6.1} kB) |",
        strand as f64 / 1000.0,
        workspace as f64 / 1000.0
    );
}

fn main() {
    println!("| N  | per strand          | per workspace         |");
    println!("|----|---------------------|-----------------------|");
    row::<5, 15, 6, 7>();
    row::<10, 30, 11, 15>();
    row::<20, 60, 21, 30>();
}

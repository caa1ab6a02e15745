//! The commands of the `superhelix` binary, one file each, and the plumbing they share.
//! What each command computes is in the library `superhelix-studies`; these files only
//! turn arguments into its calls and print or write what it returns.

pub mod bench;
pub mod common;
pub mod compare_kernels;
pub mod coulomb;
pub mod coulomb_scaling;
pub mod electrostatics;
pub mod merge;
pub mod quadrature_table;
pub mod render;
pub mod run;
pub mod stress;
pub mod study;
pub mod validate;

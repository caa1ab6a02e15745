//! The commands of the `superhelix` binary, one file each, and the plumbing they share.
//! The library halves of the measuring commands (`bench`, `compare-kernels`,
//! `quadrature-table`, `study`, `stress`, `render`) are modules of the `superhelix` crate.

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

//! The fixed-N strand of 7 elements, generated at build time by `build.rs` with
//! `superhelix_codegen::Kernels::new().elements(&[7]).float(Float::F64).float(Float::F32)
//! .write_to(out_dir)` and included here: [`n7`] (`n7::Strand`, `n7::Params`,
//! `n7::Workspace`, `n7::step`, `n7::linearly_implicit`, `n7::evaluate`,
//! `n7::centreline`, every size a literal), the same in f32 in [`n7::f32`]
//! (`n7::f32::Strand`, `n7::f32::step`, …), [`SIZES`] and [`visit_size`]. The crate depends on `superhelix-generated` only, and
//! like it builds without std and without an allocator.
#![no_std]
#![warn(missing_docs)]

include!(concat!(env!("OUT_DIR"), "/superhelix_kernels.rs"));

//! Where one strand's step keeps what it reads and writes. The step (`crate::fixed`'s
//! functions, written once) works on views of its owner's memory: [`ParamsView`],
//! [`StrandView`] and [`WorkView`], its matrices as [`Square`]s. A fixed-N strand lends
//! them from arrays of literal size (`crate::fixed::FixedStrand`,
//! `crate::fixed::FixedWorkspace`: on the stack, no allocation, the sizes constants the
//! compiler sees); a runtime-N strand from vectors of its size ([`heap`], feature `alloc`).

#[cfg(feature = "alloc")]
pub mod heap;
mod square;
mod views;

pub use square::Square;
pub(crate) use views::sized;
pub use views::{ParamsView, ProjectionView, StrandView, WorkView, STACK_VECTORS};

//! # superhelix-kernels
//!
//! The part of the Super-Helix model (Bertails et al. 2006) that one strand's time step
//! needs, with no allocation and no `std`: what a game engine vendors with the generated
//! fixed-N kernels of `superhelix-generated`.
//!
//! - [`element`]: the helical element in closed form (paper appendix A, eq. 7): its
//!   local frame E(u) and centreline p(u) and their derivatives with respect to the
//!   Darboux vector; [`helix_functions`] and [`jet`] are what it is built on.
//! - [`moments`]: the per-element integrals ([`moments::ElementMoments`]) and their
//!   assembly into the terms of the equation of motion (paper eq. 4–6): M(q) and the
//!   gravity force in O(N²), the full force in O(N), the Jacobians in O(N²), the rotary
//!   inertia ([`moments::rotary`]).
//! - [`field_split`]: the part of the field stiffness the implicit step's matrix takes,
//!   by a dissipative split (one Cholesky factorisation on the common path), with
//!   [`projection`] (a partial eigendecomposition) as its fallback.
//! - [`body_field`]: gravity, head motion and drag as a force per unit length affine in
//!   position and velocity.
//! - [`lanes`]: four f64 lanes (`F4`), what the generated closed forms and the rotary
//!   quadrature evaluate four points or elements at once with (`F32x4` in f32).
//! - [`float`]: the float type of the step ([`Float`]: `f64`, the default, or `f32`):
//!   the fixed-N step ([`fixed`]), the assembly, the projection and the energy balance
//!   are written once over it; in f64 they give the bits they always gave.
//! - [`storage`]: what one strand's step reads and writes, as views of its owner's memory;
//!   the step ([`fixed`]) is written once on them. A fixed-N strand lends arrays of literal
//!   size; with the `alloc` feature, [`storage::heap`] lends vectors of any N.
//!
//! Without features the crate is `no_std` and takes its elementary functions from
//! `libm`; `alloc` adds the runtime-N storage; the `std` feature (the runtime's, with
//! `alloc`) takes them from std, caches the Gauss–Legendre rules and picks AVX2 code at
//! run time.
#![no_std]
#![warn(missing_docs)]
#![allow(clippy::needless_range_loop, clippy::too_many_arguments)]

#[cfg(any(feature = "std", test))]
extern crate std;

pub mod body_field;
pub mod collider;
pub mod contact;
pub mod element;
pub mod energy;
pub mod field_split;
pub mod fixed;
pub mod float;
pub mod floating;
pub mod head;
pub mod helix_functions;
pub mod jet;
pub mod lane;
pub mod lanes;
pub mod material;
pub mod math;
pub mod moments;
pub mod point_load;
pub mod pose;
pub mod projection;
pub mod quadrature;
pub mod storage;
pub mod strand_point;
pub mod strand_terms;

pub use body_field::BodyField;
pub use float::{Arith, Float};
pub use pose::{darboux, Pose};

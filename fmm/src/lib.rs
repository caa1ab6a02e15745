//! # superhelix-fmm
//!
//! The Coulomb potential and field of a set of point charges,
//!
//! ```text
//! Φ_i = Σ_{j ≠ i} q_j φ(|x_i − x_j|),   E_i = −∇Φ(x_i),   φ(r) = 1/r
//! ```
//!
//! (eqs. 1 and 6 of Sobottka & Weber 2006, "Computing Static Electricity on Human
//! Hair", in the kernel `1/r`: multiply by `1/(4πε₀)` for SI units), by
//!
//! - [`Fmm`]: the fast multipole method (the paper's section 2.3.1, after Greengard and
//!   Rokhlin) on an adaptive octree with spherical-harmonic expansions of order p
//!   (eqs. 2–5): P2M, M2M, M2L, L2L, L2P and P2P, parallel with rayon;
//! - [`direct_sum`]: the O(n²) sum, vectorised over four targets and parallel: the
//!   reference, and the near field of the multipole method.
//!
//! Near field: a charge may stand for a piece of a charged fibre, and fibres cross;
//! [`Softening`] spreads each charge over a small ball, so that no configuration gives
//! an unbounded field, while the field beyond the ball's radius stays exactly `1/r²`.
//!
//! No Rust crate fitted: `kifmm` (kernel-independent FMM) downloads and builds FFTW at
//! build time, which cannot work offline, and uses equivalent-density expansions rather
//! than the spherical harmonics of the paper; `ferreus_bbfmm` is a black-box
//! (Chebyshev-interpolation) FMM without the a-priori error control of a multipole order.
#![warn(missing_docs)]

pub mod direct;
mod fmm;
pub mod harmonics;
pub mod operators;
pub mod samples;
pub mod tree;

pub use direct::{direct_at, direct_sum, Softening};
pub use fmm::{expected_error, Fmm, FmmOptions, FmmStats, Potentials, ERROR_BY_ORDER, MAX_ORDER};

/// Why an evaluation was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FmmError {
    /// The points and charges differ in number.
    #[error("{points} points but {charges} charges: one charge per point")]
    Lengths {
        /// Number of points.
        points: usize,
        /// Number of charges.
        charges: usize,
    },
    /// A coordinate or charge is not finite.
    #[error("{what}[{index}] is not finite")]
    NonFinite {
        /// `points` or `charges`.
        what: &'static str,
        /// The index.
        index: usize,
    },
    /// An option is out of range.
    #[error("{name} = {value}: must be in {allowed}")]
    Option {
        /// The option.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The allowed range.
        allowed: &'static str,
    },
}

pub(crate) fn check_input(points: &[[f64; 3]], charges: &[f64]) -> Result<(), FmmError> {
    if points.len() != charges.len() {
        return Err(FmmError::Lengths {
            points: points.len(),
            charges: charges.len(),
        });
    }
    if let Some(i) = points.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
        return Err(FmmError::NonFinite {
            what: "points",
            index: i,
        });
    }
    if let Some(i) = charges.iter().position(|q| !q.is_finite()) {
        return Err(FmmError::NonFinite {
            what: "charges",
            index: i,
        });
    }
    Ok(())
}

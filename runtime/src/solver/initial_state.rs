//! Checks of a strand's state at t = 0, run when a [`crate::Simulation`] is built (so
//! that `validate` refuses what `run` would refuse before its first step): a finite
//! centreline, finite forces and mass matrix, and, for explicit RK4, a time step within
//! its stability limit.
//!
//! # RK4's stability limit
//!
//! Classical RK4 is stable on y' = λy while |hλ| stays inside its stability region,
//! which reaches 2.83 on the imaginary axis and 2.785 on the negative real axis;
//! [`RK4_STABILITY_RADIUS`] = 2.78 is used for every direction. Linearised about the
//! initial state (at rest), the strand's equation M q̈ = F(q, q̇) (paper eq. 6) has the
//! oscillation frequencies ω of the generalized eigenproblem K x = ω² M x, with
//! K = −∂F/∂q (the elastic stiffness diag(l_Q (GJ, EI1, EI2)) plus the field's), and
//! the damping rates δ of D x = δ M x, with D = −∂F/∂q̇ (internal friction and drag).
//! The largest of ω_max and δ_max is the spectral radius ρ of the linearised system
//! (exactly so when friction is proportional; an estimate otherwise), and
//! dt ≤ 2.78 / ρ is RK4's limit. The twist modes of a nearly straight element are the
//! stiffest: their rotary inertia is small (~r² of the centreline terms).
//!
//! The largest dt accepted is [`RK4_SAFETY`] = 0.8 × 2.78/ρ: the limit is measured at
//! q0 only, and M(q), the field stiffness and the gyroscopic terms of a moving head
//! change it along the motion. The factor leaves a margin for that change without
//! refusing steps that run (the straight N = 3 fibre of `tests/bdf2.rs` runs RK4 at 0.69
//! of its limit at q0). It cannot guarantee a run: a released wavy strand (N = 5) stiffens
//! as its elements straighten and RK4 fails at 0.5 of its limit at q0 after 0.4 s; the
//! run-time error then says that the explicit steps grew unstable.

use super::system::StrandSystem;
use crate::bodies::Placement;
use crate::error::FieldError;
use crate::kernels::kernel::Terms;
use crate::model::reconstruction::sample_centreline;
use nalgebra::DMatrix;

/// |hλ| below which classical RK4 is stable in every direction of the left half-plane
/// that matters here (2.785 on the real axis, 2.83 on the imaginary one).
pub const RK4_STABILITY_RADIUS: f64 = 2.78;
/// Fraction of RK4's stability limit at q0 that a scene's dt may use.
pub const RK4_SAFETY: f64 = 0.8;

/// The spectral radius ρ = max(ω_max, δ_max) of a strand's equations linearised at
/// (q, q̇ = 0) (see the module doc), evaluated into the system's workspace; `None` when
/// M is not positive definite or a term is not finite.
pub fn linearised_spectral_radius(
    system: &mut StrandSystem,
    at: &Placement,
    q: &[f64],
) -> Option<f64> {
    let n = q.len();
    let v = vec![0.0; n];
    let terms = Terms {
        mass: true,
        force: true,
        stiffness: true,
        damping: true,
        velocity_term_jacobian: false,
        field_force: false,
        symmetric_stiffness: false,
        split_damping: false,
    };
    system.assemble(at, q, &v, terms);
    let t = &system.workspace.terms;
    let mass = DMatrix::from_fn(n, n, |i, j| 0.5 * (t.mass[(i, j)] + t.mass[(j, i)]));
    let stiffness = DMatrix::from_fn(n, n, |i, j| {
        -0.5 * (t.stiffness[(i, j)] + t.stiffness[(j, i)])
    });
    let damping = DMatrix::from_fn(n, n, |i, j| -0.5 * (t.damping[(i, j)] + t.damping[(j, i)]));
    let all_finite = |m: &DMatrix<f64>| m.iter().all(|x| x.is_finite());
    if !(all_finite(&mass) && all_finite(&stiffness) && all_finite(&damping)) {
        return None;
    }
    let l_inv = mass.cholesky()?.l().try_inverse()?;
    let largest = |a: &DMatrix<f64>| {
        let reduced = &l_inv * a * l_inv.transpose();
        let reduced = 0.5 * (&reduced + reduced.transpose());
        reduced
            .symmetric_eigenvalues()
            .iter()
            .fold(0.0_f64, |m, &x| m.max(x))
    };
    let omega = largest(&stiffness).sqrt();
    let delta = largest(&damping);
    let rho = omega.max(delta);
    rho.is_finite().then_some(rho)
}

/// Every problem of strand `index`'s initial state `q0` (at rest, head and bodies at `place`):
/// non-finite centreline, forces or mass matrix; with `rk4_dt`, a time step beyond
/// RK4's stability limit (reported on `simulation.dt`).
pub fn check_initial_state(
    index: usize,
    system: &mut StrandSystem,
    place: &Placement,
    q0: &[f64],
    rk4_dt: Option<f64>,
) -> Vec<FieldError> {
    let name = system.strand.name.clone();
    let at = |field: &str| format!("strands[{index}].{field}");
    let mut points = Vec::new();
    sample_centreline(&system.strand.geometry, q0, 1, &mut points);
    if points.iter().any(|p| !p.iter().all(|x| x.is_finite())) {
        return vec![FieldError::new(
            at("q0"),
            format!(
                "strand '{name}': the initial centreline is not finite (check length, element_lengths, root, q0 and the natural curvatures)"
            ),
        )];
    }
    let v = vec![0.0; q0.len()];
    let terms = Terms {
        mass: true,
        force: true,
        ..Default::default()
    };
    system.assemble(place, q0, &v, terms);
    let t = &system.workspace.terms;
    let n = q0.len();
    let force_finite = t.force[..n].iter().all(|x| x.is_finite());
    let mass_finite = (0..n).all(|j| (0..n).all(|i| t.mass[(i, j)].is_finite()));
    if !(force_finite && mass_finite) {
        let what = if mass_finite { "forces" } else { "mass matrix" };
        return vec![FieldError::new(
            at("q0"),
            format!(
                "strand '{name}': the {what} at the initial state are not finite (check radius, density, youngs_modulus, length, q0, point_loads and gravity)"
            ),
        )];
    }
    let Some(dt) = rk4_dt else {
        return Vec::new();
    };
    match linearised_spectral_radius(system, place, q0) {
        None => vec![FieldError::new(
            "simulation.integrator",
            format!(
                "rk4 needs a positive definite mass matrix, and strand '{name}' (strands[{index}]) has none at its initial state (a straight element without rotary inertia); use an implicit integrator"
            ),
        )],
        Some(rho) => {
            let limit = RK4_STABILITY_RADIUS / rho;
            let allowed = RK4_SAFETY * limit;
            if dt <= allowed {
                return Vec::new();
            }
            vec![FieldError::new(
                "simulation.dt",
                format!(
                    "explicit rk4 is unstable at dt = {dt:.3e} s for strand '{name}' (strands[{index}]): its stiffest mode at the initial state has |lambda| = {rho:.4e} 1/s (oscillation frequency or damping rate), RK4 is stable for dt <= {RK4_STABILITY_RADIUS}/|lambda| = {limit:.3e} s, and dt must be <= {RK4_SAFETY} x that = {allowed:.3e} s; use a smaller dt or an implicit integrator (linearly-implicit-euler, bdf2)"
                ),
            )]
        }
    }
}

//! Static equilibrium: `∇(U + V) = external forces`, i.e. F(q, 0) = 0, solved by Newton
//! with the exact stiffness and a backtracking line search on the energy.

use super::system::StrandSystem;
use crate::bodies::Placement;
use crate::kernels::kernel::Terms;
use crate::kernels::step_terms::KernelPoints;

/// How a static solve went.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StaticReport {
    /// Newton iterations taken.
    pub iterations: usize,
    /// max |F| at the end, in N·m (generalized forces).
    pub residual: f64,
    /// Scale the residual was compared with (max |F| of elasticity and loads at the start).
    pub force_scale: f64,
    /// Whether the tolerance was met.
    pub converged: bool,
}

/// Relative tolerance on the generalized force.
pub const STATIC_TOLERANCE: f64 = 1e-11;
/// Newton iteration cap.
pub const STATIC_MAX_ITERATIONS: usize = 200;

/// Armijo backtracking: the largest α = 2^-k with E(α) ≤ E(0) + 1e-4 α slope.
fn backtrack(energy_at: &mut impl FnMut(f64) -> f64, e0: f64, slope: f64) -> Result<f64, String> {
    let mut alpha = 1.0;
    while alpha >= 1e-10 {
        let e = energy_at(alpha);
        if e.is_finite() && e <= e0 + 1e-4 * alpha * slope {
            return Ok(alpha);
        }
        alpha *= 0.5;
    }
    Err("static solve: the line search found no decrease of the energy".into())
}

/// Solve the equilibrium of one strand starting from `q`, in place. The energy
/// E = U − ρS g·∫y − Σ f·y_p is minimised: Newton directions from the Hessian
/// −∂F/∂q (shifted by λ·diag(K) when not positive definite, λ growing until it is),
/// then backtracking until E decreases (Armijo).
pub fn solve_static(system: &mut StrandSystem, q: &mut [f64]) -> Result<StaticReport, String> {
    // Newton needs the whole stiffness, whatever the dynamic step's setting
    let explicit = std::mem::replace(&mut system.context.explicit_field_stiffness, false);
    let report = newton_static(system, q);
    system.context.explicit_field_stiffness = explicit;
    report
}

fn newton_static(system: &mut StrandSystem, q: &mut [f64]) -> Result<StaticReport, String> {
    let n = q.len();
    let zero = vec![0.0; n];
    // the head at rest, a body on its own motion at rest at its pose of t = 0
    let at = Placement::at_rest(0.0);
    let terms = Terms {
        force: true,
        stiffness: true,
        ..Default::default()
    };
    let mut report = StaticReport::default();
    let mut trial = vec![0.0; n];
    let mut force = vec![0.0; n];
    let mut balanced = vec![0.0; n];
    // generalized forces compared in the solver's units (a pinned root's joint: torques)
    let scale: Vec<f64> = match system.workspace.solver.scale() {
        Some(s) => s.to_vec(),
        None => vec![1.0; n],
    };
    let scaled_max = |f: &[f64]| {
        f.iter()
            .zip(&scale)
            .fold(0.0f64, |m, (f, s)| m.max((f * s).abs()))
    };
    if system.held.is_some() {
        // start on the constraint, with the holder's reaction there: its geometric
        // stiffness (a clamped tip's torque, which alone destabilises a twisted rod) is
        // then in the first Hessian
        let force_only = Terms {
            force: true,
            ..Default::default()
        };
        if let Some(held) = system.held.as_mut() {
            held.project(
                &mut KernelPoints(system.kernel.as_mut()),
                &system.strand.geometry,
                q,
                0.0,
            )
            .map_err(|e| e.to_string())?;
        }
        system.assemble(&at, q, &zero, force_only);
        force.copy_from_slice(&system.workspace.terms.force);
        if let Some(held) = system.held.as_mut() {
            held.balance_static(
                &mut KernelPoints(system.kernel.as_mut()),
                &system.strand.geometry,
                q,
                &mut force,
                0.0,
            )
            .ok_or("static solve: the held tip's constraints are dependent")?;
        }
    }
    for iteration in 0..=STATIC_MAX_ITERATIONS {
        system.assemble(&at, q, &zero, terms);
        let ws = &mut system.workspace;
        force.copy_from_slice(&ws.terms.force);
        balanced.copy_from_slice(&force);
        let mut feasible = true;
        if let Some(held) = system.held.as_mut() {
            // the force the holder leaves unbalanced
            let worst = held
                .balance_static(
                    &mut KernelPoints(system.kernel.as_mut()),
                    &system.strand.geometry,
                    q,
                    &mut balanced,
                    0.0,
                )
                .ok_or("static solve: the held tip's constraints are dependent")?;
            feasible = worst <= 1e3 * super::held_end::PROJECTION_TOLERANCE;
        }
        let residual = scaled_max(&balanced);
        if iteration == 0 {
            // scale: the largest elastic or external generalized force in play
            let elastic: f64 = (0..n)
                .map(|i| (ws.stiffness[i] * (q[i] - system.strand.natural[i]) * scale[i]).abs())
                .fold(0.0, f64::max);
            // and what the loads could exert: a force f at arm L on an element of
            // length l is a generalized force of f L l (a nearly straight start under a
            // compressive load has almost none yet)
            let g = &system.strand.geometry;
            let longest = g.lengths.iter().fold(0.0f64, |m, &l| m.max(l));
            let weight = system.context.effects.gravity.map_or(0.0, |g| g.norm())
                * system.strand.material.mass_per_length
                * g.length();
            let loads: f64 = system
                .strand
                .point_loads
                .iter()
                .map(|p| p.force.norm())
                .sum();
            let loads = (weight + loads) * g.length() * longest;
            report.force_scale = scaled_max(&force).max(elastic).max(loads).max(1e-300);
        }
        report.iterations = iteration;
        report.residual = residual;
        if residual <= STATIC_TOLERANCE * report.force_scale && feasible {
            report.converged = true;
            return Ok(report);
        }
        if iteration == STATIC_MAX_ITERATIONS {
            break;
        }
        // Newton direction: (−∂F/∂q + λ diag K) Δ = F
        let mut lambda = 0.0;
        // the shift of a coordinate without stiffness (a pinned root's joint): the mean
        // stiffness in the solver's units
        let stiff: Vec<f64> = (0..n)
            .filter(|&i| ws.stiffness[i] > 0.0)
            .map(|i| ws.stiffness[i])
            .collect();
        let mean = stiff.iter().sum::<f64>() / stiff.len().max(1) as f64;
        // With a held tip the Hessian need only be positive definite across the
        // constraint's tangent (a column held at its top is stable under loads that
        // buckle it free): H + ρ GᵀG (the augmented Lagrangian, with F − ρ Gᵀg) has the
        // same constrained Newton step and is positive definite for ρ large enough; ρ
        // grows from the stiffness's scale before the shift λ is tried.
        let largest = stiff.iter().fold(0.0f64, |m, &k| m.max(k));
        let mut rho = 0.0;
        let augmentable = system.held.is_some();
        loop {
            for j in 0..n {
                for i in 0..n {
                    let h = -0.5 * (ws.terms.stiffness[(i, j)] + ws.terms.stiffness[(j, i)]);
                    ws.solver.matrix[(i, j)] = h + if i == j {
                        let k = ws.stiffness[i];
                        lambda
                            * if k > 0.0 {
                                k
                            } else {
                                mean / (scale[i] * scale[i])
                            }
                    } else {
                        0.0
                    };
                }
            }
            ws.solver.rhs_mut().copy_from_slice(&force);
            if let (Some(held), true) = (system.held.as_ref(), rho > 0.0) {
                held.augment(
                    &mut ws.solver.matrix,
                    ws.solver.rhs.col_as_slice_mut(0),
                    rho,
                );
            }
            if ws.solver.solve_spd() {
                break;
            }
            if augmentable && lambda == 0.0 && rho < 1e12 * largest {
                rho = if rho == 0.0 {
                    system
                        .held
                        .as_ref()
                        .map_or(0.0, |h| h.augmentation_scale(largest))
                } else {
                    rho * 10.0
                };
                if rho > 0.0 {
                    continue;
                }
            }
            lambda = if lambda == 0.0 { 1e-3 } else { lambda * 10.0 };
            if lambda > 1e12 {
                return Err(
                    "static solve: no descent direction (Hessian not positive definite)".into(),
                );
            }
        }
        let mut step: Vec<f64> = ws.solver.solution().to_vec();
        if let Some(held) = system.held.as_mut() {
            // on the constraint's tangent: Δ = H⁻¹F − H⁻¹Gᵀμ with G Δ = −g
            let solver = &mut ws.solver;
            held.static_direction(&mut |x| solver.solve_factored_spd(x), &mut step)?;
        }
        let slope: f64 = -force.iter().zip(&step).map(|(f, d)| f * d).sum::<f64>();
        let e0 = system.energy(q, &zero);
        // Near the solution the energy decrease falls below the rounding of E: take the
        // full Newton step (quadratic convergence) instead of a meaningless line search.
        let alpha = if slope.abs() > 1e-10 * e0.abs() {
            let mut energy_at = |alpha: f64| {
                for i in 0..n {
                    trial[i] = q[i] + alpha * step[i];
                }
                if let Some(held) = system.held.as_mut() {
                    // the trial point back on the constraint (a failure: no decrease)
                    let kernel = system.kernel.as_mut();
                    if held
                        .project(
                            &mut KernelPoints(kernel),
                            &system.strand.geometry,
                            &mut trial,
                            0.0,
                        )
                        .is_err()
                    {
                        return f64::INFINITY;
                    }
                }
                system.energy(&trial, &zero)
            };
            backtrack(&mut energy_at, e0, slope)?
        } else {
            1.0
        };
        for i in 0..n {
            q[i] += alpha * step[i];
        }
        if let Some(held) = system.held.as_mut() {
            held.project(
                &mut KernelPoints(system.kernel.as_mut()),
                &system.strand.geometry,
                q,
                0.0,
            )
            .map_err(|e| e.to_string())?;
        }
    }
    Ok(report)
}

//! Static equilibrium: `∇(U + V) = external forces`, i.e. F(q, 0) = 0, solved by Newton
//! with the exact stiffness and a backtracking line search on the energy.

use super::system::StrandSystem;
use crate::bodies::Placement;
use crate::kernels::kernel::Terms;

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

fn max_abs(x: &[f64]) -> f64 {
    x.iter().fold(0.0, |m, v| m.max(v.abs()))
}

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
    for iteration in 0..=STATIC_MAX_ITERATIONS {
        system.assemble(&at, q, &zero, terms);
        let ws = &mut system.workspace;
        force.copy_from_slice(&ws.terms.force);
        let residual = max_abs(&force);
        if iteration == 0 {
            // scale: the largest elastic or external generalized force in play
            let elastic: f64 = (0..n)
                .map(|i| (ws.stiffness[i] * (q[i] - system.strand.natural[i])).abs())
                .fold(0.0, f64::max);
            report.force_scale = residual.max(elastic).max(1e-300);
        }
        report.iterations = iteration;
        report.residual = residual;
        if residual <= STATIC_TOLERANCE * report.force_scale {
            report.converged = true;
            return Ok(report);
        }
        if iteration == STATIC_MAX_ITERATIONS {
            break;
        }
        // Newton direction: (−∂F/∂q + λ diag K) Δ = F
        let mut lambda = 0.0;
        loop {
            for j in 0..n {
                for i in 0..n {
                    let h = -0.5 * (ws.terms.stiffness[(i, j)] + ws.terms.stiffness[(j, i)]);
                    ws.solver.matrix[(i, j)] = h + if i == j {
                        lambda * ws.stiffness[i]
                    } else {
                        0.0
                    };
                }
            }
            ws.solver.rhs_mut().copy_from_slice(&force);
            if ws.solver.solve_spd() {
                break;
            }
            lambda = if lambda == 0.0 { 1e-3 } else { lambda * 10.0 };
            if lambda > 1e12 {
                return Err(
                    "static solve: no descent direction (Hessian not positive definite)".into(),
                );
            }
        }
        let step: Vec<f64> = ws.solver.solution().to_vec();
        let slope: f64 = -force.iter().zip(&step).map(|(f, d)| f * d).sum::<f64>();
        let e0 = system.energy(q, &zero);
        // Near the solution the energy decrease falls below the rounding of E: take the
        // full Newton step (quadratic convergence) instead of a meaningless line search.
        let alpha = if slope.abs() > 1e-10 * e0.abs() {
            let mut energy_at = |alpha: f64| {
                for i in 0..n {
                    trial[i] = q[i] + alpha * step[i];
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
    }
    Ok(report)
}

//! The contacts that start within a step, in the step's solve: the candidates of
//! [`crate::forces::contacts::predicted`] found from the solve without them, their one-sided penalty
//! resolved on the Schur complement of the step's LU factors, and the end of the solve
//! checked on the strand's actual reconstruction (not the linear model) for samples the
//! prediction missed and for the linearisation's error.

use super::stats::StepStats;
use super::system::StrandSystem;
use crate::bodies::Placement;

/// Checks of the solve's end against the actual reconstruction: after the first solve
/// with the candidates, at most this many corrections (each one complementarity solve
/// and one reconstruction, no factorisation).
const END_CHECKS: usize = 2;

/// A linearised gap within this fraction of the contact radius of the measured one is
/// left as it is.
const GAP_TOLERANCE: f64 = 0.05;

/// At the end (q, q̇) of a step's solve (`system.workspace.solver` holding the LU factors
/// of its matrix, `StrandContacts::predict` called for it): add the candidates' forces, then check the
/// end on the actual reconstruction and correct (see the module page). A change `σ A⁻¹
/// Jᵀ f` of the velocity (A the step matrix, the contact forces f entering the
/// right-hand side as `σ Jᵀ f`) moves the end by `c` times it. Nothing without bodies.
pub(super) fn resolve(
    system: &mut StrandSystem,
    at: &Placement,
    (c, sigma): (f64, f64),
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    if let Some(contacts) = system.contacts.as_mut() {
        contacts.predicted_mut().map = (c, sigma);
    }
    correct(system, at, q, v, stats, false)
}

/// [`resolve`] again on a step whose end (q, q̇) was changed since (scaled to the
/// rotation limit), with its matrix's factors still in the solver: keeps the candidates
/// and their corrections, and corrects from that end.
pub(super) fn resolve_again(
    system: &mut StrandSystem,
    at: &Placement,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    correct(system, at, q, v, stats, true)
}

fn correct(
    system: &mut StrandSystem,
    at: &Placement,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
    again: bool,
) -> Result<(), String> {
    let StrandSystem {
        strand,
        kernel,
        workspace: ws,
        contacts,
        ..
    } = system;
    let Some(contacts) = contacts.as_mut() else {
        return Ok(());
    };
    if !contacts.has_bodies() {
        return Ok(());
    }
    let dofs = v.len();
    let geom = &strand.geometry;
    let tolerance = GAP_TOLERANCE * contacts.params().radius;
    let mut columns = 0;
    let q_lin = std::mem::take(&mut contacts.predicted_mut().q_lin);
    if q_lin.len() != dofs {
        // no prediction for this step
        contacts.predicted_mut().q_lin = q_lin;
        return Ok(());
    }
    let (c, sigma) = contacts.predicted_mut().map;
    let result = (|| -> Result<(), String> {
        {
            let pc = contacts.predicted_mut();
            pc.v_free.clear();
            pc.v_free.extend_from_slice(v);
            // q = q_lin + shift + c q̇
            pc.shift.clear();
            pc.shift
                .extend((0..dofs).map(|i| q[i] - c * v[i] - q_lin[i]));
            pc.lambda.clear();
            // the columns of the candidates kept from the first call are those of this matrix
            if again {
                columns = pc.candidates.len();
            }
        }
        contacts.linearize_predicted(kernel.as_mut(), &q_lin, &mut ws.jac, columns);
        for pass in 0..=END_CHECKS {
            let pc = contacts.predicted_mut();
            let m = pc.candidates.len();
            if m > 0 {
                for j in columns..m {
                    let (g, w) = (
                        &pc.g[j * dofs..(j + 1) * dofs],
                        &mut pc.w[j * dofs..(j + 1) * dofs],
                    );
                    w.copy_from_slice(g);
                    if !ws.solver.solve_factored(w) {
                        return Err("contacts within the step: singular step matrix".into());
                    }
                }
                columns = m;
                let v_free = std::mem::take(&mut pc.v_free);
                let shift = std::mem::take(&mut pc.shift);
                pc.free_gaps(dofs, Some(&shift), c, &v_free);
                pc.solve(dofs, c * sigma);
                v.copy_from_slice(&v_free);
                pc.apply(dofs, sigma, v);
                for i in 0..dofs {
                    q[i] = q_lin[i] + shift[i] + c * v[i];
                }
                (pc.v_free, pc.shift) = (v_free, shift);
            }
            if pass == END_CHECKS {
                break;
            }
            // the end on the actual reconstruction
            let before = contacts.check_predicted(at, geom, q);
            contacts.linearize_predicted(kernel.as_mut(), &q_lin, &mut ws.jac, before);
            let pc = contacts.predicted_mut();
            // new candidates are solved for
            let mut changed = pc.candidates.len() > before;
            for k in 0..pc.candidates.len() {
                let Some(end) = pc.candidates[k].end_gap else {
                    continue;
                };
                let pushed = pc.lambda.get(k).is_some_and(|&l| l > 0.0);
                if end >= 0.0 && !pushed {
                    continue;
                }
                let g = &pc.g[k * dofs..(k + 1) * dofs];
                let model = pc.candidates[k].gap + dot(g, &pc.shift) + c * dot(g, v);
                if (end - model).abs() > tolerance {
                    pc.candidates[k].gap += end - model;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        Ok(())
    })();
    contacts.predicted_mut().q_lin = q_lin;
    result?;
    if again {
        // counted at the step's first resolution
        return Ok(());
    }
    stats.contacts_predicted += contacts
        .predicted_mut()
        .lambda
        .iter()
        .filter(|&&l| l > 0.0)
        .count();
    Ok(())
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

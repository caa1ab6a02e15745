//! The contacts that start within a step, in the runtime's step: the candidates of
//! [`superhelix_kernels::contact::predicted`] found from the solve without them, their
//! one-sided penalty resolved on the Schur complement of the step's LU factors, and the
//! end of the solve checked on the strand's actual reconstruction (not the linear model)
//! for samples the prediction missed and for the linearisation's error. The resolution is
//! the kernels' (shared with the fixed-N step); this file hands it the step's factors,
//! the strand's Jacobian and its end check.

use super::dense_solve::DenseSolver;
use super::stats::StepStats;
use super::system::{OneStepFactors, StrandSystem};
use crate::bodies::Placement;
use crate::forces::contacts::predicted::PredictedContacts;
use crate::forces::contacts::StrandContacts;
use crate::kernels::kernel::StrandKernel;
use crate::StrandGeometry;
use nalgebra::Vector3;
use superhelix_kernels::contact::predicted::{self, PredictionHost, GAP_TOLERANCE};

/// At the end (q, q̇) of a step's solve (`system.workspace.solver` holding the LU factors
/// of its matrix, `StrandContacts::predict` called for it): add the candidates' forces, then check the
/// end on the actual reconstruction and correct (see the module page). A change `σ A⁻¹
/// Jᵀ f` of the velocity (A the step matrix, the contact forces f entering the
/// right-hand side as `σ Jᵀ f`) moves the end by `c` times it. Nothing without bodies.
pub(super) fn resolve(
    system: &mut StrandSystem,
    at: &Placement,
    map: (f64, f64),
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
) -> Result<(), String> {
    correct(system, at, Some(map), q, v, stats, false)
}

/// [`resolve`] again on a step whose end (q, q̇) was changed since (scaled to the
/// rotation limit, or moved by the pair solve), with its matrix's factors still in the
/// solver (`one_step`: those the one step left, `StrandWorkspace::one_step_factors`):
/// keeps the candidates and their corrections, and corrects from that end.
pub(super) fn resolve_again(
    system: &mut StrandSystem,
    at: &Placement,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
    one_step: bool,
) -> Result<(), String> {
    correct(system, at, None, q, v, stats, one_step)
}

/// The runtime's step as the resolution's host.
struct Host<'s> {
    contacts: &'s mut StrandContacts,
    kernel: &'s mut dyn StrandKernel,
    solver: &'s mut DenseSolver,
    /// The one step's factors, when the step was the one step's.
    one_step: Option<&'s mut OneStepFactors>,
    jac: &'s mut [Vector3<f64>],
    geom: &'s StrandGeometry,
    at: &'s Placement,
    dofs: usize,
}

impl PredictionHost<PredictedContacts> for Host<'_> {
    fn solve_factored(&mut self, x: &mut [f64]) -> bool {
        match self.one_step.as_deref_mut() {
            Some(f) => f.solve(x),
            None => self.solver.solve_factored(x),
        }
    }
    fn linearize(&mut self, buffers: &mut PredictedContacts, from: usize) {
        let kernel = &mut *self.kernel;
        predicted::linearize(buffers, self.dofs, from, self.jac, |q, s, jac| {
            kernel.point(q, s, jac, None);
        });
    }
    fn end_check(&mut self, buffers: &mut PredictedContacts, q: &[f64]) -> usize {
        self.contacts
            .check_predicted(buffers, self.at, self.geom, q)
    }
}

fn correct(
    system: &mut StrandSystem,
    at: &Placement,
    map: Option<(f64, f64)>,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
    one_step: bool,
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
    let tolerance = GAP_TOLERANCE * contacts.params().radius;
    let mut pc = std::mem::take(contacts.predicted_mut());
    let mut host = Host {
        contacts,
        kernel: kernel.as_mut(),
        solver: &mut ws.solver,
        one_step: one_step.then_some(&mut ws.one_step_factors),
        jac: &mut ws.jac,
        geom: &strand.geometry,
        at,
        dofs: v.len(),
    };
    let result = match map {
        Some(map) => predicted::resolve(&mut pc, &mut host, map, tolerance, q, v),
        None => predicted::resolve_again(&mut pc, &mut host, tolerance, q, v),
    };
    *host.contacts.predicted_mut() = pc;
    stats.contacts_predicted +=
        result.map_err(|_| "contacts within the step: singular step matrix".to_string())?;
    Ok(())
}

//! The contacts that start within a step, in the runtime's step: the candidates of
//! [`superhelix_kernels::contact::predicted`] found from the solve without them, their
//! one-sided penalty resolved on the Schur complement of the step's LU factors, and the
//! end of the solve checked on the strand's actual reconstruction (not the linear model)
//! for samples the prediction missed and for the linearisation's error. The resolution is
//! the kernels' (shared with the fixed-N step); this file hands it the step's factors,
//! the strand's Jacobian and its end check.

use super::stats::StepStats;
use super::system::{OneStepFactors, StrandSystem};
use crate::bodies::Placement;
use crate::forces::contacts::predicted::PredictedContacts;
use crate::forces::contacts::StrandContacts;
use crate::kernels::kernel::StrandKernel;
use crate::StrandGeometry;
use nalgebra::Vector3;
use superhelix_kernels::contact::predicted::{self, PredictionHost, GAP_TOLERANCE};

/// The contacts that started within a step, resolved again on a step whose end (q, q̇)
/// was changed since (moved by the pair solve), on the factors of its matrix the one step
/// left (`StrandWorkspace::one_step_factors`): keeps the candidates and their
/// corrections, and corrects from that end (see the module page). Nothing without
/// bodies.
pub(super) fn resolve_again(
    system: &mut StrandSystem,
    at: &Placement,
    q: &mut [f64],
    v: &mut [f64],
    stats: &mut StepStats,
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
        factors: &mut ws.one_step_factors,
        jac: &mut ws.jac,
        geom: &strand.geometry,
        at,
        dofs: v.len(),
    };
    let result = predicted::resolve_again(&mut pc, &mut host, tolerance, q, v);
    *host.contacts.predicted_mut() = pc;
    stats.contacts_predicted +=
        result.map_err(|_| "contacts within the step: singular step matrix".to_string())?;
    Ok(())
}

/// The runtime's step as the resolution's host.
struct Host<'s> {
    contacts: &'s mut StrandContacts,
    kernel: &'s mut dyn StrandKernel,
    /// The factors of the step's matrix the one step kept.
    factors: &'s mut OneStepFactors,
    jac: &'s mut [Vector3<f64>],
    geom: &'s StrandGeometry,
    at: &'s Placement,
    dofs: usize,
}

impl PredictionHost<PredictedContacts> for Host<'_> {
    fn solve_factored(&mut self, x: &mut [f64]) -> bool {
        self.factors.solve(x)
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

//! The energy measured by the runtime's kernels for the a-posteriori energy-balance test of
//! implicit steps; the balance itself ([`StateEnergy`], [`balance`], [`end_ceiling`]) is
//! in `superhelix_kernels::energy` (shared with the embedded fixed-N step) and
//! re-exported here.

use super::system::StrandSystem;
use crate::bodies::Placement;
use crate::forces::effects::body_field;
use crate::forces::head_motion::HeadState;
use crate::forces::point_loads::follower_power;
use crate::kernels::kernel::{BodyField, EvalInput, Terms};
use nalgebra::Vector3;
pub use superhelix_kernels::energy::*;

/// Measure the energy of (q, q̇) at time `t` with the head in state `head`: one kernel
/// evaluation of M (and ∫ρS y ds with it); when the head rotates, also of the force, with
/// the body field reduced to its part C1 linear in y, so that `force + b` is the
/// generalized force of C1 and q̇ᵀ(force + b) its power. The ceiling is E.
pub fn measure(
    system: &mut StrandSystem,
    head: &HeadState,
    t: f64,
    q: &[f64],
    v: &[f64],
) -> StateEnergy {
    let StrandSystem {
        strand,
        kernel,
        workspace,
        context,
        contacts,
        held,
    } = system;
    let kernel = kernel.as_mut();
    let (terms, jac) = (&mut workspace.terms, &mut workspace.jac);
    let (stiffness, friction) = (&workspace.stiffness, &workspace.friction);
    let effects = &context.effects;
    let rho_s = strand.material.mass_per_length;
    let full = body_field(effects, head, rho_s, strand.air_drag);
    let field = BodyField {
        uniform: Vector3::zeros(),
        linear: full.linear,
        velocity: nalgebra::Matrix3::zeros(),
    };
    kernel.evaluate(
        &EvalInput {
            q,
            v,
            field,
            // M and ∫ρS y ds; the field's force alone (no b) only for the power of C1
            // (a rotating head)
            terms: Terms {
                mass: true,
                field_force: field.has_linear(),
                ..Default::default()
            },
        },
        terms,
    );
    let n = q.len();
    let m = &terms.mass;
    let mut kinetic = 0.0;
    for j in 0..n {
        let mut mv = 0.0;
        for i in 0..n {
            mv += m[(i, j)] * v[i];
        }
        kinetic += 0.5 * mv * v[j];
    }
    let elastic: f64 = (0..n)
        .map(|i| 0.5 * stiffness[i] * (q[i] - strand.natural[i]).powi(2))
        .sum();
    let mut power = if field.has_linear() {
        (0..n).map(|i| v[i] * terms.force[i]).sum()
    } else {
        0.0
    };
    // follower loads have no potential: their power joins the work, and so does a
    // driven holder's
    power += follower_power(&strand.point_loads, &strand.geometry, kernel, q, v, jac);
    if let Some(h) = held {
        power += h.holder_power(t);
    }
    let moment = terms.first_moment / rho_s;
    let mut load_moment = 0.0;
    let mut load_rate = 0.0;
    if !strand.point_loads.is_empty() {
        let rt = head.rotation.transpose();
        // d(Rᵀ f)/dt = −ω × Rᵀ f (Ṙ = R[ω]×)
        let w = head.omega;
        for load in strand.point_loads.iter().filter(|l| !l.follows) {
            let f = rt * load.force;
            let y = kernel.point(q, load.s, jac, None);
            load_moment += f.dot(&y);
            load_rate += w.cross(&f).dot(&y);
        }
    }
    if let Some(c) = contacts {
        // the contact potential joins V (with the point loads' part, so that round-off
        // is scaled by it); its rate at fixed q joins the point loads' rate
        // and so does the work of the drag of the bodies on their own motion
        let at = Placement::new(*head, t);
        let (potential, rate) = c.energy(&at, &strand.geometry, q);
        let rate = rate + c.drag_power(&at, kernel, &strand.geometry, q, v, jac);
        load_moment -= potential;
        load_rate += rate;
        workspace.last_contact = (potential, rate);
    }
    let dissipation = (0..n).map(|i| friction[i] * v[i] * v[i]).sum::<f64>()
        + 2.0 * strand.air_drag / rho_s * kinetic;
    let length = strand.geometry.length();
    let potential = -full.uniform.dot(&moment) - load_moment;
    StateEnergy {
        time: t,
        kinetic,
        elastic,
        potential,
        moment,
        uniform: full.uniform,
        power,
        load_moment,
        load_rate,
        dissipation,
        ceiling: kinetic + elastic + potential,
        scale: kinetic + elastic + full.uniform.norm() * length * length,
    }
}

/// `energy` (measured by [`measure`] at this (q, q̇), head state and time, perhaps with its
/// velocities scaled since) with its contact part measured again: what changes between two
/// steps without the strand moving when contacts have a history (partners moved, anchors
/// slid, allowances shrank). The kernel's part (M, the field's power) is kept: equal to a
/// fresh [`measure`] up to round-off, at the cost of the contact terms alone.
pub fn remeasure_contacts(
    system: &mut StrandSystem,
    head: &HeadState,
    q: &[f64],
    v: &[f64],
    energy: &StateEnergy,
) -> StateEnergy {
    let StrandSystem {
        strand,
        kernel,
        workspace,
        contacts,
        ..
    } = system;
    let mut e = *energy;
    let Some(c) = contacts else {
        return e;
    };
    let at = Placement::new(*head, energy.time);
    let (potential, rate) = c.energy(&at, &strand.geometry, q);
    let rate = rate
        + c.drag_power(
            &at,
            kernel.as_mut(),
            &strand.geometry,
            q,
            v,
            &mut workspace.jac,
        );
    let (old_potential, old_rate) = workspace.last_contact;
    e.load_moment += old_potential - potential;
    e.potential += potential - old_potential;
    e.load_rate += rate - old_rate;
    // the contact potential's new reference shifts the bound the steps carry with it (a
    // ceiling reset to E would drop what the steps before had lost below it, and let the
    // next steps create that much)
    e.ceiling = energy.ceiling + (potential - old_potential);
    workspace.last_contact = (potential, rate);
    e
}

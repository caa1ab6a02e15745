//! `[electrostatics]`: charged tracer particles on the strands and how their forces are
//! computed (see `forces::electrostatics`).

use super::reader::{Bound, Node, Range};
use crate::bodies::BodySetup;
use crate::config::StrandSetup;
use crate::forces::electrostatics::{
    CoulombMethod, ElectrostaticsConfig, ScalpCharge, PAPER_CHARGE_PER_LENGTH,
    PAPER_PARTICLE_DENSITY,
};
use crate::scene::strands::MAX_CHARGE_RANGE;

/// Most tracer particles of a scene.
pub const MAX_PARTICLES: usize = 50_000_000;

/// ε₀, F/m.
const VACUUM_PERMITTIVITY: f64 = 8.8541878128e-12;
/// The field at which air breaks down (dry air at sea level), V/m.
pub const AIR_BREAKDOWN_FIELD: f64 = 3e6;

/// Read `[electrostatics]` for `strands`; strands with their own `charge_per_length`
/// keep it.
pub(super) fn read_electrostatics(
    mut n: Node<'_>,
    strands: &[StrandSetup],
    bodies: &[BodySetup],
) -> Option<ElectrostaticsConfig> {
    let d = ElectrostaticsConfig::paper(0);
    let density = n.optional_f64(
        "particle_density",
        PAPER_PARTICLE_DENSITY,
        Range::new(Bound::Excl(0.0), Bound::Incl(1e5)),
    );
    let lambda = n.optional_f64(
        "charge_per_length",
        PAPER_CHARGE_PER_LENGTH,
        MAX_CHARGE_RANGE,
    );
    let accuracy = n.optional_f64(
        "accuracy",
        d.accuracy,
        Range::new(Bound::Incl(1e-14), Bound::Incl(0.1)),
    );
    let softening = if n.has("softening") {
        n.f64("softening", Range::new(Bound::Incl(0.0), Bound::Incl(1.0)))
            .map(Some)
    } else {
        Some(None)
    };
    let update_every = n.optional("update_every", 1, |n, k| {
        n.count(k, 1, 1_000_000, "the cap on steps between updates")
    });
    let names = ["auto", "fmm", "direct"];
    let method = n.optional("method", CoulombMethod::Auto, |n, k| {
        n.choice(k, &names, CoulombMethod::from_name)
    });
    let charging_steps = n.optional("charging_steps", 1, |n, k| {
        n.count(k, 1, 1000, "the cap on charging steps")
    });
    let tolerance = n.optional_f64(
        "tolerance",
        d.tolerance,
        Range::new(Bound::Excl(0.0), Bound::Excl(1.0)),
    );
    let max_iterations = n.optional("max_iterations", d.max_iterations, |n, k| {
        n.count(k, 1, 1000, "the cap on outer iterations")
    });
    let scalp = match (n.has("scalp_body"), n.has("scalp_charge")) {
        (false, false) => Some(None),
        (true, true) => {
            let body = n.string("scalp_body").map(str::to_string);
            let charge = n.f64(
                "scalp_charge",
                Range::new(Bound::Incl(-1e-3), Bound::Incl(1e-3)),
            );
            match (body, charge) {
                (Some(body), Some(charge)) if bodies.iter().any(|b| b.name == body) => {
                    Some(Some(ScalpCharge { body, charge }))
                }
                (Some(body), Some(_)) => {
                    let names: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
                    n.error(
                        "scalp_body",
                        format!("no body named '{body}' in [[bodies]] (bodies: {names:?})"),
                    );
                    None
                }
                _ => None,
            }
        }
        (true, false) => {
            n.error(
                "scalp_charge",
                "required with scalp_body: the scalp's charge Q_S in C",
            );
            None
        }
        (false, true) => {
            n.error(
                "scalp_body",
                "required with scalp_charge: the name of the charged body",
            );
            None
        }
    };
    let (density, lambda) = (density?, lambda?);
    let particles: f64 = strands
        .iter()
        .map(|s| {
            (s.strand.geometry.lengths.iter().sum::<f64>() * density)
                .round()
                .max(1.0)
        })
        .sum();
    if particles > MAX_PARTICLES as f64 {
        n.error(
            "particle_density",
            format!("{particles:.0} particles in all, more than the cap of {MAX_PARTICLES}"),
        );
    }
    // a fibre holds no more charge than air lets it: beyond 2π r ε₀ E_b the field at its
    // surface passes air's breakdown field and the air conducts (corona)
    {
        let l = lambda;
        let over = strands.iter().find_map(|s| {
            let q = s.charge_per_length.unwrap_or(l);
            let r = crate::output::driver::display_radius(&s.strand.material);
            let max = 2.0 * std::f64::consts::PI * r * VACUUM_PERMITTIVITY * AIR_BREAKDOWN_FIELD;
            (q.abs() > max).then_some((s, q, r, max))
        });
        if let Some((s, q, r, max)) = over {
            let own = if s.charge_per_length.is_some() {
                format!(" (strand '{}''s own)", s.strand.name)
            } else {
                String::new()
            };
            n.error(
                "charge_per_length",
                format!(
                    "{q:e} C/m{own}: a fibre of radius {r:.3e} m holds at most {max:.3e} C/m (2π r ε₀ E_b: beyond, the field at its surface passes air's breakdown field of 3 MV/m)"
                ),
            );
        }
    }
    let config = ElectrostaticsConfig {
        particle_density: density,
        charge_per_length: strands
            .iter()
            .map(|s| s.charge_per_length.unwrap_or(lambda))
            .collect(),
        accuracy: accuracy?,
        softening: softening?.unwrap_or(1.0 / density),
        update_every: update_every?,
        method: method?,
        charging_steps: charging_steps?,
        tolerance: tolerance?,
        max_iterations: max_iterations?,
        scalp: scalp?,
    };
    n.finish();
    Some(config)
}

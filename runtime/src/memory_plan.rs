//! What a simulation will hold in memory, estimated before it is built, and the check
//! that refuses a scene that will not fit in the machine's available memory (as the
//! output plan refuses output beyond its limit): `validate` prints the estimate, and
//! [`crate::Simulation::new`] refuses before allocating, naming the estimate and the
//! limit, instead of being killed by the system part way.
//!
//! The formula, each term measured on the 2-vCPU reference machine as peak resident
//! memory (VmHWM) of `superhelix run` less the process alone, and checked within 25 %
//! against the measured peak on a table of scenes by `tests/memory_estimate.rs`:
//!
//! ```text
//! bytes = 10 MB (the process)
//!       + Σ strands: runtime engine  660 N² + 8,800 N       (nine dense 3N × 3N matrices:
//!                                                          the kernel's terms, the SPD
//!                                                          solver, the projection's
//!                                                          basis; per-element caches)
//!                    embedded engine 40 N² + 420 N + 1,800  (the fixed-N state)
//!                    + 2,000 N with body contacts         (contact samples, anchors)
//!       + 400 per tracer particle of [electrostatics]     (particles, multipole tree)
//!       + 20 per render-strand point when hair.usda is written
//!       + 1,250 per hair–hair pair of the scene's start     (the pair, its anchor, a
//!                                                          partner point per side)
//!       +   950 more per pair with coupling = "pair"       (the pair solve's sides:
//!                                                          points, compliances, the
//!                                                          samples' compliance rows)
//! ```
//!
//! (Runtime engine, bytes per strand measured: 22 k at N = 2, 57 k at 5, 145 k at 10,
//! 440 k at 20, 876 k at 30, 2.12 M at 50; embedded: 2.7 k, 5.0 k, 9.5 k, 24.6 k at N = 2,
//! 5, 10, 20.) The hair–hair pairs are counted at the scene's start
//! ([`hair_pairs_at_start`]); a sample keeps at most `max_pairs_per_sample` of them, so
//! they stay linear in the samples however the strands crowd later.

use crate::config::{Engine, SimulationSetup};
use crate::error::{Error, Result};

/// Bytes per strand of the runtime engine, per N².
pub const RUNTIME_BYTES_PER_N2: f64 = 660.0;
/// Bytes per strand of the runtime engine, per element.
pub const RUNTIME_BYTES_PER_ELEMENT: f64 = 8_800.0;
/// Bytes per strand of the embedded engine, per N².
pub const EMBEDDED_BYTES_PER_N2: f64 = 40.0;
/// Bytes per strand of the embedded engine, per element.
pub const EMBEDDED_BYTES_PER_ELEMENT: f64 = 420.0;
/// Bytes per strand of the embedded engine, whatever N.
pub const EMBEDDED_BYTES_PER_STRAND: f64 = 1_800.0;
/// Bytes per element of a strand with body contacts (the runtime engine).
pub const CONTACT_BYTES_PER_ELEMENT: f64 = 2_000.0;
/// Bytes per element of a strand with body contacts on the embedded engine: its samples'
/// arc lengths, weights, anchors and allowances (the scratch is a worker's). Measured:
/// 333 per element, 15,000 strands of N = 5 at 4 samples per element.
pub const EMBEDDED_CONTACT_BYTES_PER_ELEMENT: f64 = 350.0;
/// Bytes per tracer particle of a charged scene (position, charge, field, forces, the
/// multipole tree).
pub const BYTES_PER_PARTICLE: f64 = 400.0;
/// Bytes per render-strand point when `hair.usda` is written (its rest, blended and
/// kept-out positions, in f32).
pub const BYTES_PER_RENDER_POINT: f64 = 20.0;
/// Bytes per hair–hair pair (its pair and anchor, and the partner point it gives each of
/// its two strands, with the allocator's slack). Measured: 1,050 with 100 strands of
/// N = 5 on 1 dm², 1,400 with 500 strands of N = 8 (more pairs per sample, longer lists).
pub const BYTES_PER_HAIR_PAIR: f64 = 1_250.0;
/// Bytes per hair–hair pair more with `coupling = "pair"` (the pair solve's sides of
/// both strands: the points, velocities and compliances of each side, the compliance
/// rows at the samples around them, the factors kept per strand). Measured on 500
/// strands of N = 8 falling onto a sphere (1 dm²): 860 on the runtime engine, 1,040 on
/// the embedded engine.
pub const BYTES_PER_COUPLED_PAIR: f64 = 950.0;
/// The process itself (code, tables, thread stacks, buffers).
pub const BASE_BYTES: f64 = 10e6;

/// The estimate of a scene's memory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MemoryEstimate {
    /// Bytes the simulation is estimated to hold.
    pub bytes: u64,
    /// The engine the estimate is for.
    pub engine: Engine,
    /// The machine's available memory when it could be read (Linux: `MemAvailable` of
    /// `/proc/meminfo`), bytes.
    pub available: Option<u64>,
}

impl std::fmt::Display for MemoryEstimate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "memory: about {} estimated", human(self.bytes))?;
        match self.available {
            Some(a) => write!(f, " ({} available on this machine)", human(a)),
            None => Ok(()),
        }
    }
}

fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= 1e9 {
        format!("{:.1} GB", b / 1e9)
    } else if b >= 1e6 {
        format!("{:.0} MB", b / 1e6)
    } else {
        format!("{:.0} kB", b / 1e3)
    }
}

pub use crate::input::available_memory;

/// What `setup` will hold when simulated by `engine` and written in the scene's formats
/// ([`estimate_with`]).
pub fn estimate(setup: &SimulationSetup, engine: Engine) -> MemoryEstimate {
    let formats = setup
        .output
        .formats
        .unwrap_or(crate::config::Formats::DEFAULT);
    estimate_with(setup, engine, formats.usda)
}

/// What `setup` will hold when simulated by `engine`, with `usd` when `hair.usda` is
/// written (the render strands are built for it): the formula of the module page.
pub fn estimate_with(setup: &SimulationSetup, engine: Engine, usd: bool) -> MemoryEstimate {
    let contacts = !setup.bodies.is_empty() && setup.contacts.is_some();
    let per_strand = |n: usize| {
        let n = n as f64;
        let own = match engine {
            Engine::Embedded => {
                EMBEDDED_BYTES_PER_N2 * n * n
                    + EMBEDDED_BYTES_PER_ELEMENT * n
                    + EMBEDDED_BYTES_PER_STRAND
            }
            _ => RUNTIME_BYTES_PER_N2 * n * n + RUNTIME_BYTES_PER_ELEMENT * n,
        };
        own + match (contacts, engine) {
            (false, _) => 0.0,
            (true, Engine::Embedded) => EMBEDDED_CONTACT_BYTES_PER_ELEMENT * n,
            (true, _) => CONTACT_BYTES_PER_ELEMENT * n,
        }
    };
    let strands: f64 = setup
        .strands
        .iter()
        .map(|s| per_strand(s.strand.geometry.lengths.len()))
        .sum();
    let particles = setup.electrostatics.as_ref().map_or(0.0, |e| {
        setup
            .strands
            .iter()
            .map(|s| {
                (s.strand.geometry.length() * e.particle_density)
                    .round()
                    .max(1.0)
            })
            .sum::<f64>()
    });
    // a render strand has the points of a guide
    let guide_points = setup
        .strands
        .iter()
        .map(|s| 1 + setup.samples_per_element * s.strand.geometry.lengths.len())
        .max()
        .unwrap_or(0);
    let render = match (&setup.output.render, usd) {
        (Some(r), true) => (r.strands * guide_points) as f64,
        _ => 0.0,
    };
    let pairs = hair_pairs_at_start(setup) as f64;
    let coupled = setup
        .contacts
        .as_ref()
        .and_then(|c| c.hair_hair.as_ref())
        .is_some_and(|h| h.coupling == crate::forces::contacts::Coupling::Pair);
    let per_pair = BYTES_PER_HAIR_PAIR + if coupled { BYTES_PER_COUPLED_PAIR } else { 0.0 };
    let bytes = BASE_BYTES
        + strands
        + particles * BYTES_PER_PARTICLE
        + render * BYTES_PER_RENDER_POINT
        + pairs * per_pair;
    MemoryEstimate {
        bytes: bytes as u64,
        engine,
        available: available_memory(),
    }
}

/// The hair–hair pairs of `setup`'s start (0 without `[contacts.hair_hair]`): the
/// strands' contact samples at their initial state, placed by the head at time 0, searched
/// as the first step searches them ([`crate::forces::contacts::hair_hair::pairs_at_start`],
/// at most `max_pairs_per_sample` per sample).
pub fn hair_pairs_at_start(setup: &SimulationSetup) -> usize {
    use crate::forces::contacts::StrandContacts;
    use rayon::prelude::*;
    let Some(c) = setup.contacts.as_ref() else {
        return 0;
    };
    let Some(h) = c.hair_hair.as_ref() else {
        return 0;
    };
    let head = setup.head.state(0.0);
    let bodies: std::sync::Arc<[crate::bodies::Body]> = Vec::new().into();
    type Sampled = (Vec<(f64, f64)>, Vec<nalgebra::Vector3<f64>>);
    let (samples, points): (Vec<_>, Vec<_>) = setup
        .strands
        .par_iter()
        .map(|s| {
            let g = &s.strand.geometry;
            let rho_s = s.strand.material.mass_per_length;
            let mut contacts = StrandContacts::new(
                g,
                bodies.clone(),
                c.params(rho_s),
                Some(h.params(rho_s)),
                c.samples_per_element,
                c.free_ends(
                    s.strand.ends.root == crate::model::ends::RootEnd::Free,
                    s.tip.is_none(),
                ),
            );
            if s.q0.len() != g.dofs() || s.q0.iter().any(|x| !x.is_finite()) {
                return (Vec::new(), Vec::new());
            }
            contacts.sample_poses(g, &s.q0);
            let points = contacts
                .sample_positions()
                .map(|y| head.position + head.rotation * y)
                .collect();
            (contacts.samples().to_vec(), points)
        })
        .collect::<Vec<Sampled>>()
        .into_iter()
        .unzip();
    let arcs: Vec<&[(f64, f64)]> = samples.iter().map(|x| &x[..]).collect();
    let h_step = setup.config.dt;
    let fall = setup
        .environment
        .gravity
        .map_or(0.0, |g| g.norm() * h_step * h_step);
    crate::forces::contacts::hair_hair::pairs_at_start(
        &points,
        &arcs,
        h.self_contact.then(|| h.self_exclusion()),
        2.0 * h.radius,
        fall,
        h.max_pairs_per_sample,
    )
}

/// The peak resident memory of this process so far (Linux's `VmHWM`), bytes; `None`
/// elsewhere.
pub fn peak_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

impl MemoryEstimate {
    /// Refuse an estimate beyond the available memory, naming both (`strands`: what to
    /// change is the strands' count or N, or the engine).
    pub fn check(&self) -> Result<()> {
        match self.available {
            Some(a) if self.bytes > a => Err(Error::invalid(
                "strands",
                format!(
                    "the simulation needs about {} ({} engine), more than the {} this machine has available: fewer strands, fewer elements, or the embedded engine",
                    human(self.bytes),
                    match self.engine {
                        Engine::Embedded => "embedded",
                        _ => "runtime",
                    },
                    human(a)
                ),
            )),
            _ => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_estimate_beyond_the_available_memory_is_refused_naming_both() {
        let e = MemoryEstimate {
            bytes: 30_000_000_000,
            engine: Engine::Runtime,
            available: Some(24_000_000_000),
        };
        let message = e.check().expect_err("refused").to_string();
        assert!(
            message.contains("strands")
                && message.contains("30.0 GB")
                && message.contains("24.0 GB"),
            "{message}"
        );
        let fits = MemoryEstimate {
            bytes: 1_000_000,
            ..e
        };
        assert!(fits.check().is_ok());
        // unknown availability: nothing to refuse against
        let unknown = MemoryEstimate {
            available: None,
            ..e
        };
        assert!(unknown.check().is_ok());
    }

    #[test]
    fn the_formula_is_within_a_seventh_of_each_measured_strand() {
        // the bytes per strand measured (module page) against the formula's terms
        for (n, measured) in [
            (2usize, 22.2e3),
            (5, 56.8e3),
            (10, 145e3),
            (20, 440e3),
            (30, 876e3),
            (50, 2.12e6),
        ] {
            let n = n as f64;
            let formula = RUNTIME_BYTES_PER_N2 * n * n + RUNTIME_BYTES_PER_ELEMENT * n;
            assert!(
                (formula / measured - 1.0).abs() < 0.14,
                "runtime N = {n}: {formula} against {measured}"
            );
        }
        for (n, measured) in [(2usize, 2.7e3), (5, 5.0e3), (10, 9.5e3), (20, 24.6e3)] {
            let n = n as f64;
            let formula = EMBEDDED_BYTES_PER_N2 * n * n
                + EMBEDDED_BYTES_PER_ELEMENT * n
                + EMBEDDED_BYTES_PER_STRAND;
            assert!(
                (formula / measured - 1.0).abs() < 0.14,
                "embedded N = {n}: {formula} against {measured}"
            );
        }
    }
}

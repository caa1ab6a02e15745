//! What a simulation will hold in memory, estimated before it is built, and the check
//! that refuses a scene that will not fit in the machine's available memory (as the
//! output plan refuses output beyond its limit): `validate` prints the estimate, and
//! [`crate::Simulation::new`] refuses before allocating, naming the estimate and the
//! limit, instead of being killed by the system part way.
//!
//! Per strand, measured on the 2-vCPU reference machine (peak resident memory of
//! `superhelix run` on 200 strands, less the process's own ~5 MB): the runtime engine
//! keeps about ten dense 3N × 3N matrices (the step's mass, stiffness, damping and
//! Jacobian terms, the factorisations) and the kernel's tables: 0.67 MB at N = 20,
//! 2.0 MB at N = 50, 7.1 MB at N = 100, which [`RUNTIME_BYTES_PER_N2`] N² +
//! [`RUNTIME_BYTES_PER_STRAND`] bounds (0.85, 2.4 and 7.9 MB; 30 MB at N = 200). The
//! embedded engine keeps the fixed-N state, a few kB. A charged scene adds its tracer
//! particles, render strands their points.

use crate::config::{Engine, SimulationSetup};
use crate::error::{Error, Result};

/// Bytes per strand of the runtime engine, per N².
pub const RUNTIME_BYTES_PER_N2: f64 = 750.0;
/// Bytes per strand of the runtime engine, whatever N.
pub const RUNTIME_BYTES_PER_STRAND: f64 = 550e3;
/// Bytes per strand of the embedded engine, per N² (and [`EMBEDDED_BYTES_PER_STRAND`]).
pub const EMBEDDED_BYTES_PER_N2: f64 = 100.0;
/// Bytes per strand of the embedded engine, whatever N.
pub const EMBEDDED_BYTES_PER_STRAND: f64 = 4e3;
/// Bytes per tracer particle of a charged scene (position, charge, field, forces, the
/// multipole tree).
pub const BYTES_PER_PARTICLE: f64 = 400.0;
/// Bytes per render-strand point (its rest, blended and kept-out positions).
pub const BYTES_PER_RENDER_POINT: f64 = 48.0;
/// The process itself (code, tables, buffers).
pub const BASE_BYTES: f64 = 20e6;

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

/// What `setup` will hold when simulated by `engine`.
pub fn estimate(setup: &SimulationSetup, engine: Engine) -> MemoryEstimate {
    let per_strand = |n: usize| {
        let n2 = (n * n) as f64;
        match engine {
            Engine::Embedded => EMBEDDED_BYTES_PER_N2 * n2 + EMBEDDED_BYTES_PER_STRAND,
            _ => RUNTIME_BYTES_PER_N2 * n2 + RUNTIME_BYTES_PER_STRAND,
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
    let render = setup
        .output
        .render
        .as_ref()
        .map_or(0.0, |r| (r.strands * guide_points) as f64);
    let bytes =
        BASE_BYTES + strands + particles * BYTES_PER_PARTICLE + render * BYTES_PER_RENDER_POINT;
    MemoryEstimate {
        bytes: bytes as u64,
        engine,
        available: available_memory(),
    }
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
    fn the_estimate_bounds_the_measured_memory_per_strand() {
        // the runtime engine's measured bytes per strand (module page), each under the
        // estimate and within 40 % of it
        for (n, measured) in [(20usize, 0.67e6), (50, 2.0e6), (100, 7.1e6)] {
            let estimate = RUNTIME_BYTES_PER_N2 * (n * n) as f64 + RUNTIME_BYTES_PER_STRAND;
            assert!(
                measured <= estimate && estimate <= 1.4 * measured,
                "N = {n}: {estimate} against {measured}"
            );
        }
    }
}

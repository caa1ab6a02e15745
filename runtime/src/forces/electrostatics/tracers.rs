//! Tracer particles (paper section 2.2): each charged fibre carries point charges at a
//! density ρ_P, placed by arc length and moved with the fibre. A Super-Helix gives the
//! exact position at any arc length, so a particle is a fixed `s` on its strand, never
//! interpolated.

use crate::model::strand::Strand;

/// The particles of every strand: arc lengths and charges, strand after strand.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Tracers {
    /// `offsets[i]..offsets[i + 1]`: the particles of strand i.
    pub offsets: Vec<usize>,
    /// Arc length of each particle on its strand, m.
    pub s: Vec<f64>,
    /// Charge of each particle, C.
    pub charge: Vec<f64>,
}

impl Tracers {
    /// Place `max(1, round(L ρ_P))` particles on each strand of length L, at the midpoints
    /// of equal pieces (`s_k = (k + ½) L / n`), each carrying `λ L / n` so that the
    /// strand's charge is exactly `λ L`. A strand with λ = 0 carries none.
    pub fn place(strands: &[&Strand], density: f64, charge_per_length: &[f64]) -> Self {
        let mut t = Tracers {
            offsets: vec![0],
            ..Default::default()
        };
        for (strand, &lambda) in strands.iter().zip(charge_per_length) {
            let length: f64 = strand.geometry.lengths.iter().sum();
            if lambda != 0.0 {
                let n = ((length * density).round() as usize).max(1);
                let q = lambda * length / n as f64;
                for k in 0..n {
                    t.s.push((k as f64 + 0.5) * length / n as f64);
                    t.charge.push(q);
                }
            }
            t.offsets.push(t.s.len());
        }
        t
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.s.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.s.is_empty()
    }

    /// The particle range of strand `i`.
    pub fn of(&self, i: usize) -> core::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }
}

//! Helpers shared by the runtime's integration tests.
#![allow(dead_code)]

use nalgebra::{Matrix3, Vector3};
use superhelix_runtime::strand::StrandGeometry;

/// Deterministic xorshift generator (tests only).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-1, 1].
    pub fn sym(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(self.sym(), self.sym(), self.sym());
            if v.norm() > 0.1 {
                return v.normalize();
            }
        }
    }
}

/// A rotation from an axis-angle vector.
pub fn rotation(axis_angle: Vector3<f64>) -> Matrix3<f64> {
    *nalgebra::Rotation3::new(axis_angle).matrix()
}

/// A strand geometry with unequal element lengths and a tilted root frame.
pub fn geometry(n: usize, length: f64, rng: &mut Rng) -> StrandGeometry {
    let mut lengths: Vec<f64> = (0..n).map(|_| 0.5 + rng.next_f64()).collect();
    let total: f64 = lengths.iter().sum();
    lengths.iter_mut().for_each(|l| *l *= length / total);
    StrandGeometry {
        root_position: Vector3::new(0.01, -0.02, 0.03),
        root_frame: rotation(Vector3::new(0.3, -0.7, 1.1)),
        lengths,
        mass_per_length: 1.0e-5,
        // exaggerated (r ~ 1 cm) so that its terms are visible at test tolerances
        rotary_inertia: [2.0e-9, 0.8e-9, 1.2e-9],
    }
}

/// q whose elements have |d|·l equal to the given values (cycled), random directions;
/// a zero-twist planar arc where `planar` is set.
pub fn q_with_wl(geom: &StrandGeometry, wl: &[f64], rng: &mut Rng) -> Vec<f64> {
    let mut q = Vec::new();
    for (k, l) in geom.lengths.iter().enumerate() {
        let target = wl[k % wl.len()] / l;
        let dir = rng.unit();
        q.extend_from_slice(&[dir[0] * target, dir[1] * target, dir[2] * target]);
    }
    q
}

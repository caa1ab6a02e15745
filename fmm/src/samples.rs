//! Point sets for tests and benchmarks: uniform random points, and hair-like particles
//! (curly fibres hanging from the upper half of a sphere).

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// `n` points uniform in the unit cube and charges uniform in [−1, 1].
pub fn uniform_cube(n: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let points = (0..n)
        .map(|_| {
            [
                rng.random_range(0.0..1.0),
                rng.random_range(0.0..1.0),
                rng.random_range(0.0..1.0),
            ]
        })
        .collect();
    let charges = (0..n).map(|_| rng.random_range(-1.0..1.0)).collect();
    (points, charges)
}

/// Hair-like particles: `fibres` curly fibres of `per_fibre` particles, 30 cm long
/// (spacing 30 cm / `per_fibre`: 3 mm, the paper's 330 per metre, at 100), rooted at
/// random on the upper half of a sphere of radius 10 cm, leaving along the normal and
/// then falling in a helix of radius 1 cm and 2.5 cm pitch around a vertical axis.
/// Charges uniform in [−1, 1] (signed: the harder case for a multipole method).
pub fn curly_fibres(fibres: usize, per_fibre: usize, seed: u64) -> (Vec<[f64; 3]>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut points = Vec::with_capacity(fibres * per_fibre);
    let spacing = 0.3 / per_fibre.max(1) as f64;
    for _ in 0..fibres {
        // Uniform on the upper hemisphere.
        let z: f64 = rng.random_range(0.0..1.0);
        let phi = rng.random_range(0.0..2.0 * PI);
        let s = (1.0 - z * z).sqrt();
        let normal = [s * phi.cos(), s * phi.sin(), z];
        let root = [0.1 * normal[0], 0.1 * normal[1], 0.1 * normal[2]];
        let phase = rng.random_range(0.0..2.0 * PI);
        let (radius, pitch) = (0.01, 0.025);
        // Arc length per turn of the helix.
        let turn = (4.0 * PI * PI * radius * radius + pitch * pitch).sqrt();
        let lead = 0.02;
        for k in 0..per_fibre {
            let t = (k as f64 + 0.5) * spacing;
            if t < lead {
                points.push([
                    root[0] + t * normal[0],
                    root[1] + t * normal[1],
                    root[2] + t * normal[2],
                ]);
            } else {
                let u = t - lead;
                let angle = phase + 2.0 * PI * u / turn;
                let base = [
                    root[0] + lead * normal[0],
                    root[1] + lead * normal[1],
                    root[2] + lead * normal[2],
                ];
                points.push([
                    base[0] + radius * (angle.cos() - phase.cos()),
                    base[1] + radius * (angle.sin() - phase.sin()),
                    base[2] - pitch * u / turn,
                ]);
            }
        }
    }
    let charges = (0..points.len())
        .map(|_| rng.random_range(-1.0..1.0))
        .collect();
    (points, charges)
}

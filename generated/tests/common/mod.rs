//! Helpers shared by the element-point integration tests.

use superhelix_runtime::Vector3;

/// xorshift64, uniform in [−1, 1).
pub struct Rng(pub u64);

impl Rng {
    /// The next value in [−1, 1).
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Unit directions by kind: 0 random, 1 planar (d0 = 0), 2 pure κ1, 3 pure κ2, else
/// pure twist.
pub fn direction(rng: &mut Rng, kind: usize) -> Vector3<f64> {
    let s = if rng.next() < 0.0 { -1.0 } else { 1.0 };
    match kind {
        0 => loop {
            let v = Vector3::new(rng.next(), rng.next(), rng.next());
            if v.norm() > 0.1 {
                return v.normalize();
            }
        },
        1 => Vector3::new(0.0, rng.next(), rng.next()).normalize(),
        2 => Vector3::new(0.0, s, 0.0),
        3 => Vector3::new(0.0, 0.0, s),
        _ => Vector3::new(s, 0.0, 0.0),
    }
}

//! The direct sum: every pair of charges, with the softened kernel of [`Softening`];
//! the reference for the multipole method and its near field (P2P).
//!
//! The kernel is written branch-free over four targets at a time so that the compiler
//! puts the four in one AVX2 register (`direct_sum` dispatches at run time to a copy
//! compiled for AVX2 and FMA when the processor has them).

use rayon::prelude::*;

/// The near-field regularisation: each charge is spread uniformly over a ball of radius
/// `a` (the potential of a point charge outside the ball, bounded inside):
///
/// ```text
/// φ(r) = q / r                       r ≥ a
/// φ(r) = q (3a² − r²) / (2a³)        r < a        E(r) = q r / a³  (|E| ≤ q/a²)
/// ```
///
/// `a = 0` is the plain Coulomb kernel, for which two charges at the same point do not
/// act on each other. A charge never acts on itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Softening {
    /// Radius a of the ball, in the unit of the positions (≥ 0).
    pub radius: f64,
}

impl Softening {
    /// No softening: the plain `q / r`.
    pub const NONE: Softening = Softening { radius: 0.0 };
}

/// Sources in structure-of-arrays form.
pub(crate) struct SourceSlices<'a> {
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub z: &'a [f64],
    pub q: &'a [f64],
}

/// Add to the potential `phi` and the field `e = −∇Φ` at the four targets `t` the
/// contribution of the sources `s`, softened over `a2 = a²`.
#[inline(always)]
fn four_targets(
    t: [[f64; 3]; 4],
    s: &SourceSlices,
    a2: f64,
    phi: &mut [f64; 4],
    e: &mut [[f64; 4]; 3],
) {
    let tx = [t[0][0], t[1][0], t[2][0], t[3][0]];
    let ty = [t[0][1], t[1][1], t[2][1], t[3][1]];
    let tz = [t[0][2], t[1][2], t[2][2], t[3][2]];
    let mut ap = [0.0; 4];
    let mut ax = [0.0; 4];
    let mut ay = [0.0; 4];
    let mut az = [0.0; 4];
    for j in 0..s.q.len() {
        let (sx, sy, sz, q) = (s.x[j], s.y[j], s.z[j], s.q[j]);
        for l in 0..4 {
            let dx = tx[l] - sx;
            let dy = ty[l] - sy;
            let dz = tz[l] - sz;
            let r2 = dx * dx + dy * dy + dz * dz;
            let r2m = if r2 > a2 { r2 } else { a2 };
            let inv = if r2m > 0.0 { 1.0 / r2m.sqrt() } else { 0.0 };
            let inv2 = inv * inv;
            // s = r²/max(r², a²) ≤ 1: φ = q inv (3 − s)/2 is q/r outside the ball.
            let qi = q * inv;
            ap[l] += qi * (1.5 - 0.5 * r2 * inv2);
            let g = qi * inv2;
            ax[l] += g * dx;
            ay[l] += g * dy;
            az[l] += g * dz;
        }
    }
    for l in 0..4 {
        phi[l] += ap[l];
        e[0][l] += ax[l];
        e[1][l] += ay[l];
        e[2][l] += az[l];
    }
}

#[inline(always)]
fn targets_generic(
    targets: &[[f64; 3]],
    s: &SourceSlices,
    a2: f64,
    phi: &mut [f64],
    field: &mut [[f64; 3]],
) {
    let n = targets.len();
    let mut i = 0;
    while i < n {
        let mut t = [[0.0; 3]; 4];
        let take = (n - i).min(4);
        for l in 0..4 {
            // Padding lanes repeat the last target; their results are dropped.
            t[l] = targets[i + l.min(take - 1)];
        }
        let mut p4 = [0.0; 4];
        let mut e4 = [[0.0; 4]; 3];
        four_targets(t, s, a2, &mut p4, &mut e4);
        for l in 0..take {
            phi[i + l] += p4[l];
            field[i + l][0] += e4[0][l];
            field[i + l][1] += e4[1][l];
            field[i + l][2] += e4[2][l];
        }
        i += take;
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn targets_avx2(
    targets: &[[f64; 3]],
    s: &SourceSlices,
    a2: f64,
    phi: &mut [f64],
    field: &mut [[f64; 3]],
) {
    targets_generic(targets, s, a2, phi, field)
}

/// Add the softened potential and field at `targets` of the sources `s` (no self
/// exclusion: a source at a target's position adds `3q/(2a)` to its potential, 0 when
/// `a = 0`, and nothing to its field).
pub(crate) fn add_interactions(
    targets: &[[f64; 3]],
    s: &SourceSlices,
    softening: Softening,
    phi: &mut [f64],
    field: &mut [[f64; 3]],
) {
    let a2 = softening.radius * softening.radius;
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the processor has AVX2 and FMA (checked just above).
            unsafe { targets_avx2(targets, s, a2, phi, field) };
            return;
        }
    }
    targets_generic(targets, s, a2, phi, field)
}

/// The self term a target gets from [`add_interactions`] over a source set containing
/// itself: `3q/(2a)` (0 without softening).
pub(crate) fn self_potential(q: f64, softening: Softening) -> f64 {
    if softening.radius > 0.0 {
        1.5 * q / softening.radius
    } else {
        0.0
    }
}

/// The potential `Φ_i = Σ_{j≠i} q_j φ(|x_i − x_j|)` and the field `E_i = −∇Φ(x_i)` of
/// every charge due to all others, by the direct O(n²) sum, in parallel over targets
/// (rayon). Unit: the kernel `1/r` (multiply by `1/(4πε₀)` for SI).
pub fn direct_sum(
    points: &[[f64; 3]],
    charges: &[f64],
    softening: Softening,
) -> (Vec<f64>, Vec<[f64; 3]>) {
    let all: Vec<usize> = (0..points.len()).collect();
    direct_at(points, charges, &all, softening)
}

/// The potential and field at the charges `targets` (indices into `points`) due to all
/// other charges, by the direct sum: a reference for a sample of a large set.
pub fn direct_at(
    points: &[[f64; 3]],
    charges: &[f64],
    targets: &[usize],
    softening: Softening,
) -> (Vec<f64>, Vec<[f64; 3]>) {
    let x: Vec<f64> = points.iter().map(|p| p[0]).collect();
    let y: Vec<f64> = points.iter().map(|p| p[1]).collect();
    let z: Vec<f64> = points.iter().map(|p| p[2]).collect();
    let s = SourceSlices {
        x: &x,
        y: &y,
        z: &z,
        q: charges,
    };
    let t: Vec<[f64; 3]> = targets.iter().map(|&i| points[i]).collect();
    let mut phi = vec![0.0; t.len()];
    let mut field = vec![[0.0; 3]; t.len()];
    const CHUNK: usize = 16;
    phi.par_chunks_mut(CHUNK)
        .zip(field.par_chunks_mut(CHUNK))
        .zip(t.par_chunks(CHUNK))
        .for_each(|((ph, fi), tt)| add_interactions(tt, &s, softening, ph, fi));
    for (k, &i) in targets.iter().enumerate() {
        phi[k] -= self_potential(charges[i], softening);
    }
    (phi, field)
}

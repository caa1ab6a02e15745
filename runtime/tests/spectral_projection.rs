//! The negative semidefinite part `H⁻ = U min(Λ, 0) Uᵀ` of `superhelix_kernels::projection`
//! (the step's stiffness projection, from a partial eigendecomposition that reuses the
//! last basis while it still splits the matrix) against matrices of known spectra:
//! random, repeated, clustered across zero, graded over twelve decades, at n = 1–60;
//! on the heap storage (`storage::heap::HeapProjection`).

use superhelix_kernels::projection::ProjectionOutcome;
use superhelix_kernels::storage::heap::HeapProjection;

/// The kernels' projection on the heap storage, counting what each call did.
struct SpectralProjection {
    inner: HeapProjection,
    reused: u64,
    decomposed: u64,
}

impl SpectralProjection {
    fn new(n: usize) -> Self {
        SpectralProjection {
            inner: HeapProjection::new(n),
            reused: 0,
            decomposed: 0,
        }
    }

    /// Whether `h` was replaced by its negative semidefinite part.
    fn negative_part(&mut self, h: &mut [f64]) -> bool {
        match self.inner.negative_part(h) {
            ProjectionOutcome::Reused => {
                self.reused += 1;
                true
            }
            ProjectionOutcome::Decomposed => {
                self.decomposed += 1;
                true
            }
            ProjectionOutcome::Trivial => true,
            ProjectionOutcome::Failed => false,
        }
    }
}

/// Deterministic values in [−1, 1).
fn sequence(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// A random orthogonal n × n (column-major) from Householder products.
fn orthogonal(n: usize, seed: u64) -> Vec<f64> {
    let mut next = sequence(seed);
    let mut q = vec![0.0; n * n];
    for i in 0..n {
        q[i * n + i] = 1.0;
    }
    for _ in 0..3 {
        let v: Vec<f64> = (0..n).map(|_| next()).collect();
        let vv: f64 = v.iter().map(|x| x * x).sum();
        // q ← (I − 2 v vᵀ / vᵀv) q
        for c in 0..n {
            let dot: f64 = (0..n).map(|r| v[r] * q[c * n + r]).sum();
            for r in 0..n {
                q[c * n + r] -= 2.0 * dot / vv * v[r];
            }
        }
    }
    q
}

/// `Q diag(λ) Qᵀ` and its negative part `Q diag(min(λ, 0)) Qᵀ`.
fn from_spectrum(q: &[f64], lambda: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = lambda.len();
    let mut h = vec![0.0; n * n];
    let mut neg = vec![0.0; n * n];
    for c in 0..n {
        for r in 0..n {
            for k in 0..n {
                let x = q[k * n + r] * q[k * n + c];
                h[c * n + r] += lambda[k] * x;
                neg[c * n + r] += lambda[k].min(0.0) * x;
            }
        }
    }
    (h, neg)
}

fn max_abs(m: &[f64]) -> f64 {
    m.iter().fold(0.0f64, |a, x| a.max(x.abs()))
}

/// Checks the projection of `Q diag(λ) Qᵀ` against the known negative part.
fn check(lambda: &[f64], seed: u64) {
    let n = lambda.len();
    let q = orthogonal(n, seed);
    let (h, expected) = from_spectrum(&q, lambda);
    let mut p = h.clone();
    let mut s = SpectralProjection::new(n);
    assert!(s.negative_part(&mut p), "failed for λ = {lambda:?}");
    let scale = max_abs(&h).max(f64::MIN_POSITIVE);
    let err = p
        .iter()
        .zip(&expected)
        .fold(0.0f64, |a, (x, y)| a.max((x - y).abs()));
    // backward-stable algorithms: error ~ n ε ‖H‖ (eigenvalue errors), plus ε‖H‖/gap
    // for the vectors, which the rank sum over a whole cluster cancels; measured up
    // to 3.8 n ε over these tests (faer's full decomposition: the same order)
    assert!(
        err <= 16.0 * n as f64 * f64::EPSILON * scale,
        "n = {n}: error {err:.3e} against scale {scale:.3e}, λ = {lambda:?}"
    );
}

#[test]
fn random_spectra_of_the_step_sizes() {
    for &n in &[1usize, 2, 3, 6, 15, 30, 45, 60] {
        for seed in 0..20u64 {
            let mut next = sequence(100 + seed);
            let lambda: Vec<f64> = (0..n).map(|_| 10.0 * next()).collect();
            check(&lambda, seed);
        }
    }
}

#[test]
fn repeated_clustered_zero_and_graded_eigenvalues() {
    let n = 15;
    // repeated negative and positive eigenvalues (exact clusters)
    let mut lambda = vec![-1.0; 7];
    lambda.extend(vec![2.0; 8]);
    check(&lambda, 1);
    // a tight cluster straddling zero, and exact zeros
    let lambda: Vec<f64> = (0..n).map(|i| (i as f64 - 7.0) * 1e-9).collect();
    check(&lambda, 2);
    let mut lambda = vec![0.0; n];
    lambda[3] = -5.0;
    lambda[9] = 4.0;
    check(&lambda, 3);
    // graded: eigenvalues over twelve decades, both signs
    let lambda: Vec<f64> = (0..n)
        .map(|i| if i % 2 == 0 { 1.0 } else { -1.0 } * 10f64.powi(i as i32 - 6))
        .collect();
    check(&lambda, 4);
    // everything negative (returned unchanged) or non-negative (zero)
    check(&[-1.0, -2.0, -3.0, -4.0], 5);
    check(&[1.0, 0.0, 3.0, 4.0], 6);
}

#[test]
fn diagonal_tridiagonal_and_zero_matrices() {
    // already diagonal with repeated entries: T splits everywhere
    let n = 6;
    let d = [3.0, -1.0, 3.0, -1.0, 0.0, -1.0];
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        h[i * n + i] = d[i];
    }
    let mut s = SpectralProjection::new(n);
    assert!(s.negative_part(&mut h));
    for c in 0..n {
        for r in 0..n {
            let expected = if r == c { d[r].min(0.0) } else { 0.0 };
            assert!((h[c * n + r] - expected).abs() < 1e-15, "{r} {c}");
        }
    }
    let mut z = vec![0.0; 9];
    assert!(SpectralProjection::new(3).negative_part(&mut z));
    assert!(z.iter().all(|&x| x == 0.0));
}

#[test]
fn non_finite_input_is_refused_and_left_unchanged() {
    for bad in [f64::NAN, f64::INFINITY] {
        let mut h = vec![1.0, bad, bad, -1.0];
        let before: Vec<u64> = h.iter().map(|x| x.to_bits()).collect();
        assert!(!SpectralProjection::new(2).negative_part(&mut h));
        let after: Vec<u64> = h.iter().map(|x| x.to_bits()).collect();
        assert_eq!(after, before);
    }
}

/// `p` is the exact negative part `expected` of `h` to 16 n ε max|h| (the bound of
/// [`check`]).
fn assert_exact(p: &[f64], expected: &[f64], h: &[f64]) {
    let n = (h.len() as f64).sqrt() as usize;
    let err = p
        .iter()
        .zip(expected)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        err <= 16.0 * n as f64 * f64::EPSILON * max_abs(h),
        "{err:.3e}"
    );
}

fn frobenius(m: &[f64]) -> f64 {
    m.iter().map(|x| x * x).sum::<f64>().sqrt()
}

fn largest_eigenvalue(m: &[f64], n: usize) -> f64 {
    let a = faer::Mat::from_fn(n, n, |i, j| m[j * n + i]);
    let eig = a.self_adjoint_eigen(faer::Side::Lower).unwrap();
    (0..n).map(|k| eig.S()[k]).fold(f64::NEG_INFINITY, f64::max)
}

/// Reuse on either side of the spectrum: a small change keeps the basis, the result
/// is negative semidefinite and within the dropped coupling of the exact part; a
/// change that turns a direction of the other side negative is refused.
#[test]
fn reused_basis_stays_within_its_bound_and_refuses_a_new_negative_direction() {
    let n = 15;
    for &negatives in &[4usize, 11] {
        let lambda: Vec<f64> = (0..n)
            .map(|i| {
                if i < negatives {
                    -1.0 - i as f64
                } else {
                    0.5 + i as f64
                }
            })
            .collect();
        let q = orthogonal(n, 40 + negatives as u64);
        let (h0, expected0) = from_spectrum(&q, &lambda);
        let mut s = SpectralProjection::new(n);
        let mut p = h0.clone();
        assert!(s.negative_part(&mut p));
        assert_eq!((s.decomposed, s.reused), (1, 0));
        assert_exact(&p, &expected0, &h0);
        // which side the basis holds: the smaller one
        assert_eq!(s.inner.basis().1, negatives <= n - negatives);
        // a small symmetric change: reused, NSD, within 2 ‖ΔH‖_F of the exact part
        let mut next = sequence(77);
        let mut dh = vec![0.0; n * n];
        for c in 0..n {
            for r in c..n {
                let x = 1e-3 * next();
                dh[c * n + r] = x;
                dh[r * n + c] = x;
            }
        }
        let h1: Vec<f64> = h0.iter().zip(&dh).map(|(a, b)| a + b).collect();
        let mut p = h1.clone();
        assert!(s.negative_part(&mut p));
        assert_eq!((s.decomposed, s.reused), (1, 1), "negatives = {negatives}");
        let mut exact = h1.clone();
        assert!(SpectralProjection::new(n).negative_part(&mut exact));
        let err: Vec<f64> = p.iter().zip(&exact).map(|(a, b)| a - b).collect();
        assert!(
            frobenius(&err) <= 2.0 * frobenius(&dh),
            "{:.3e}",
            frobenius(&err)
        );
        assert!(frobenius(&err) > 0.0);
        assert!(largest_eigenvalue(&p, n) <= 1e-13 * frobenius(&h1));
        // a direction of the non-negative side (eigenvalue 0.5 + negatives) pushed to
        // −1 with no coupling: the basis must not be reused
        let o = negatives;
        let shift = -(1.5 + o as f64);
        let mut h2 = h0.clone();
        for c in 0..n {
            for r in 0..n {
                h2[c * n + r] += shift * q[o * n + r] * q[o * n + c];
            }
        }
        let mut lambda2 = lambda.clone();
        lambda2[o] = -1.0;
        let (_, expected2) = from_spectrum(&q, &lambda2);
        let mut p = h2.clone();
        assert!(s.negative_part(&mut p));
        assert_eq!((s.decomposed, s.reused), (2, 1), "negatives = {negatives}");
        assert_exact(&p, &expected2, &h2);
    }
}

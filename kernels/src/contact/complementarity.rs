//! The linear complementarity problem of the contacts that start within a step (the
//! runtime's `forces::contacts::predicted` states it; the fixed-N step will share it):
//!
//! ```text
//! λ ≥ 0,   S λ + a ≥ 0,   λ ⊥ (S λ + a)
//! ```
//!
//! for S a P-matrix (m × m), solved by block principal pivoting (Júdice and Pires 1994):
//! every infeasible index flipped at once while their number falls, with Murty's single
//! least-index flip as the backup after three rounds without progress, which terminates
//! for a P-matrix. The principal subproblems `S_AA λ_A = −a_A` are the caller's (its own
//! dense solver on its own storage). No `std`, no allocation.

/// Solve the problem for λ (into `lambda`, m long; `active`, m long, holds the last
/// active set) from the active set `a < 0`; `solve_active(active, lambda)` puts into
/// `lambda` the solution of `S_AA λ_A = −a_A`, 0 elsewhere. S is column-major. Returns
/// the number of pivoting rounds. Round-off at the boundary is tolerated, relative to
/// the gaps and to the forces; λ is left as the last subproblem gave it (the caller
/// clamps it at 0).
pub fn block_principal_pivoting(
    m: usize,
    s: &[f64],
    a: &[f64],
    lambda: &mut [f64],
    active: &mut [bool],
    mut solve_active: impl FnMut(&[bool], &mut [f64]),
) -> usize {
    for (act, &x) in active.iter_mut().zip(a).take(m) {
        *act = x < 0.0;
    }
    let mut pivots = 0;
    let scale = a.iter().take(m).fold(0.0f64, |mx, x| mx.max(x.abs()));
    let gap_tol = 1e-12 * scale.max(f64::MIN_POSITIVE);
    let mut best = m + 1;
    let mut backup = 3;
    for _ in 0..(10 * m + 20) {
        solve_active(active, lambda);
        let force_tol = 1e-12 * lambda.iter().take(m).fold(0.0f64, |mx, l| mx.max(l.abs()));
        let infeasible = |c: usize, active: &[bool], lambda: &[f64]| {
            if active[c] {
                lambda[c] < -force_tol
            } else {
                a[c] + (0..m).map(|j| s[c + j * m] * lambda[j]).sum::<f64>() < -gap_tol
            }
        };
        let count = (0..m).filter(|&c| infeasible(c, active, lambda)).count();
        if count == 0 {
            break;
        }
        pivots += 1;
        if count < best {
            best = count;
            backup = 3;
        } else if backup > 0 {
            backup -= 1;
        } else {
            if let Some(c) = (0..m).rev().find(|&c| infeasible(c, active, lambda)) {
                active[c] = !active[c];
            }
            continue;
        }
        for c in 0..m {
            if infeasible(c, active, lambda) {
                active[c] = !active[c];
            }
        }
    }
    pivots
}

/// The principal subproblem of [`block_principal_pivoting`] on caller storage: `S_AA λ_A
/// = −a_A` for the active set, 0 elsewhere (S m × m, column-major), by Gaussian
/// elimination with partial pivoting (Golub & Van Loan, algorithm 3.4.1) of the p × p
/// block in `sub` (≥ p², p the active count) with `rhs`, `index` and `perm` (≥ p). An
/// entry whose solution is not finite (a singular block: two candidates on the same
/// constraint) is left at 0: no force is better than a non-finite one.
#[allow(clippy::too_many_arguments)]
pub fn solve_principal(
    m: usize,
    s: &[f64],
    a: &[f64],
    active: &[bool],
    lambda: &mut [f64],
    sub: &mut [f64],
    rhs: &mut [f64],
    index: &mut [usize],
) {
    let mut p = 0;
    for c in 0..m {
        if active[c] {
            index[p] = c;
            p += 1;
        }
    }
    for l in lambda.iter_mut().take(m) {
        *l = 0.0;
    }
    if p == 0 {
        return;
    }
    for jj in 0..p {
        let j = index[jj];
        for ii in 0..p {
            sub[ii + jj * p] = s[index[ii] + j * m];
        }
        rhs[jj] = -a[j];
    }
    for k in 0..p {
        // pivot: the largest entry of column k at or below the diagonal
        let mut piv = k;
        let mut best = sub[k + k * p].abs();
        for r in k + 1..p {
            let x = sub[r + k * p].abs();
            if x > best {
                best = x;
                piv = r;
            }
        }
        if piv != k {
            for j in 0..p {
                sub.swap(k + j * p, piv + j * p);
            }
            rhs.swap(k, piv);
        }
        let d = sub[k + k * p];
        for r in k + 1..p {
            let f = sub[r + k * p] / d;
            if f != 0.0 {
                for j in k + 1..p {
                    sub[r + j * p] -= f * sub[k + j * p];
                }
                rhs[r] -= f * rhs[k];
            }
        }
    }
    for k in (0..p).rev() {
        let mut x = rhs[k];
        for j in k + 1..p {
            x -= sub[k + j * p] * rhs[j];
        }
        rhs[k] = x / sub[k + k * p];
    }
    for ii in 0..p {
        let x = rhs[ii];
        lambda[index[ii]] = if x.is_finite() { x } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

    /// S_AA λ_A = −a_A by Gaussian elimination with partial pivoting (the test's own).
    fn dense_active(m: usize, s: &[f64], a: &[f64], active: &[bool], lambda: &mut [f64]) {
        let idx: Vec<usize> = (0..m).filter(|&c| active[c]).collect();
        let p = idx.len();
        let mut mat: Vec<f64> = (0..p * p).map(|k| s[idx[k % p] + idx[k / p] * m]).collect();
        let mut rhs: Vec<f64> = idx.iter().map(|&i| -a[i]).collect();
        for k in 0..p {
            let piv = (k..p)
                .max_by(|&x, &y| mat[x + k * p].abs().total_cmp(&mat[y + k * p].abs()))
                .unwrap_or(k);
            for j in 0..p {
                mat.swap(k + j * p, piv + j * p);
            }
            rhs.swap(k, piv);
            for i in k + 1..p {
                let f = mat[i + k * p] / mat[k + k * p];
                for j in k..p {
                    mat[i + j * p] -= f * mat[k + j * p];
                }
                rhs[i] -= f * rhs[k];
            }
        }
        for k in (0..p).rev() {
            let sum: f64 = (k + 1..p).map(|j| mat[k + j * p] * rhs[j]).sum();
            rhs[k] = (rhs[k] - sum) / mat[k + k * p];
        }
        lambda.iter_mut().for_each(|l| *l = 0.0);
        for (k, &i) in idx.iter().enumerate() {
            lambda[i] = rhs[k];
        }
    }

    /// On 200 random problems with S = BᵀB + I (positive definite: a P-matrix) of sizes
    /// 1 to 8: the solution is complementary — λ ≥ 0, w = Sλ + a ≥ 0, λ_i w_i = 0 — to
    /// 1e-10 of the problem's scale, and equals the one found by enumerating every
    /// active set (the unique solution of a P-matrix problem).
    #[test]
    fn the_solution_is_complementary_and_the_unique_one() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for case in 0..200 {
            let m = 1 + case % 8;
            let b: Vec<f64> = (0..m * m).map(|_| next()).collect();
            let mut s = vec![0.0; m * m];
            for i in 0..m {
                for j in 0..m {
                    s[i + j * m] = (0..m).map(|k| b[k + i * m] * b[k + j * m]).sum::<f64>()
                        + if i == j { 1.0 } else { 0.0 };
                }
            }
            let a: Vec<f64> = (0..m).map(|_| next()).collect();
            let (mut lambda, mut active) = (vec![0.0; m], vec![false; m]);
            block_principal_pivoting(m, &s, &a, &mut lambda, &mut active, |act, l| {
                dense_active(m, &s, &a, act, l)
            });
            // the same problem with the subproblems by `solve_principal`
            let (mut lambda2, mut active2) = (vec![0.0; m], vec![false; m]);
            let (mut sub, mut rhs, mut index) = (vec![0.0; m * m], vec![0.0; m], vec![0; m]);
            block_principal_pivoting(m, &s, &a, &mut lambda2, &mut active2, |act, l| {
                solve_principal(m, &s, &a, act, l, &mut sub, &mut rhs, &mut index)
            });
            for i in 0..m {
                assert!(
                    (lambda2[i] - lambda[i]).abs() <= 1e-12,
                    "case {case}: λ[{i}]"
                );
            }
            let w: Vec<f64> = (0..m)
                .map(|i| a[i] + (0..m).map(|j| s[i + j * m] * lambda[j]).sum::<f64>())
                .collect();
            for i in 0..m {
                assert!(lambda[i] >= -1e-10 && w[i] >= -1e-10, "case {case}: {i}");
                assert!((lambda[i] * w[i]).abs() <= 1e-10, "case {case}: {i}");
            }
            // the enumeration: the one active set whose solution is complementary
            let mut found = 0;
            for mask in 0..(1u32 << m) {
                let act: Vec<bool> = (0..m).map(|i| mask >> i & 1 == 1).collect();
                let mut l = vec![0.0; m];
                dense_active(m, &s, &a, &act, &mut l);
                let ok = (0..m).all(|i| {
                    let wi = a[i] + (0..m).map(|j| s[i + j * m] * l[j]).sum::<f64>();
                    if act[i] {
                        l[i] >= -1e-12
                    } else {
                        wi >= -1e-12
                    }
                });
                if ok {
                    found += 1;
                    for i in 0..m {
                        assert!((l[i] - lambda[i]).abs() <= 1e-9, "case {case}: λ[{i}]");
                    }
                }
            }
            assert!(found >= 1, "case {case}: no complementary active set");
        }
    }
}

//! Contacts that start within a step: the samples that touch nothing at the step's start
//! but are predicted to reach a body before its end, and the one-sided penalty they add
//! to the step, resolved without a second factorisation.
//!
//! A sample touching a body at the start of a step has its penalty stiffness `k w n nᵀ`
//! along its Jacobian in the step's matrix ([`super::strand_contacts`]). A sample that
//! reaches a body only during the step would, with the start's samples alone, pass into
//! it unopposed (at one solve per step, `max_split_depth = 0`, within a whole frame).
//! Such a sample is predicted from the step's own solution without it: a sample that
//! ends that solution within one and a half contact radii of a body is a candidate
//! ([`super::StrandContacts::predict`]). Its penalty is the same law as a touching
//! sample's, one-sided: with the gap `φ = d − r` (d the distance of the centreline to the
//! body, r the contact radius) linearised along the Jacobian J and the body's normal n,
//!
//! ```text
//! φ(q⁺) ≈ φ(q_lin) + gᵀ (q⁺ − q_lin),   g = Jᵀ n,
//! λ = k w max(0, −φ(q⁺))                (the normal force, N)
//! ```
//!
//! The step's linear system `A q̇⁺ = r` gains `σ Σ g_c λ_c` on its right-hand side (σ the
//! step's force factor: h for implicit Euler) and `q⁺ = q_base + c q̇⁺`. With `W = A⁻¹ G`
//! (one back-substitution per candidate with the step's LU factors) the forces solve the
//! linear complementarity problem
//!
//! ```text
//! λ ≥ 0,   S λ + a ≥ 0,   λ ⊥ (S λ + a),
//! S = c σ Gᵀ W + diag(1 / (k w)),   a = φ(q_lin) + gᵀ (q_base − q_lin) + c gᵀ q̇_free
//! ```
//!
//! where `q̇_free` is the step's solution without them: it is exactly the step with the
//! rank-one stiffness `k w g gᵀ` of the candidates that end in contact added to the
//! matrix (the Schur complement of that matrix), and none for the others, so a predicted
//! contact that does not happen exerts nothing. The symmetric part of A is positive
//! definite (the mass plus dissipative and stabilising terms), so S is a P-matrix and the
//! problem has one solution; it is found by block principal pivoting with Murty's
//! least-index rule as its backup (Júdice and Pires), which terminates for P-matrices.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::lu::partial_pivoting as lu;
use faer::{MatMut, Par};
use nalgebra::Vector3;
use superhelix_kernels::contact::complementarity::block_principal_pivoting;

pub use superhelix_kernels::contact::candidates::Candidate;

/// The predicted contacts of one strand's step and the buffers of their complementarity
/// problem (see the module page), grown to the largest number of candidates met and
/// reused: a step allocates nothing once they have reached it.
#[derive(Default)]
pub struct PredictedContacts {
    /// The candidates of the coming step.
    pub candidates: Vec<Candidate>,
    /// Columns `g_c = Jᵀ n` (dofs × candidates, column-major).
    pub(crate) g: Vec<f64>,
    /// Columns `A⁻¹ g_c`.
    pub(crate) w: Vec<f64>,
    /// The forces λ of the last solve, N.
    pub lambda: Vec<f64>,
    /// `a` of the module page.
    a: Vec<f64>,
    /// S, candidates × candidates, column-major.
    s: Vec<f64>,
    active: Vec<bool>,
    /// The principal subproblem and its solution.
    sub: Vec<f64>,
    sub_rhs: Vec<f64>,
    index: Vec<usize>,
    perm: Vec<usize>,
    perm_inv: Vec<usize>,
    buffer: Option<(usize, MemBuffer)>,
    /// The step's linearisation point.
    pub(crate) q_lin: Vec<f64>,
    /// The step's map (c, σ) of the last resolution.
    pub(crate) map: (f64, f64),
    /// The samples' positions at the linearisation point, head coordinates.
    pub(crate) lin_y: Vec<Vector3<f64>>,
    /// Which samples touched a body at the linearisation point (their stiffness is in
    /// the step's matrix).
    pub(crate) touching: Vec<bool>,
    /// Which samples are candidates.
    pub(crate) listed: Vec<bool>,
    /// The tip's position at the linearisation point (the tip is not a sample: it is
    /// guarded by the end check, a candidate with `sample` out of range), and whether it
    /// is a candidate.
    pub(crate) lin_tip: Option<Vector3<f64>>,
    pub(crate) tip_listed: bool,
    /// The step's solution without the candidates.
    pub(crate) v_free: Vec<f64>,
    /// `q_base − q_lin` (empty: zero).
    pub(crate) shift: Vec<f64>,
    /// Principal pivots of the last solve (diagnostics).
    pub pivots: usize,
}

impl PredictedContacts {
    /// Forget the last prediction: until the next, nothing is resolved.
    pub fn forget(&mut self) {
        self.q_lin.clear();
        self.candidates.clear();
    }

    /// Size the columns for `dofs` coordinates and the present candidates.
    pub(crate) fn size_columns(&mut self, dofs: usize) {
        let m = self.candidates.len();
        self.g.resize(dofs * m, 0.0);
        self.w.resize(dofs * m, 0.0);
    }

    /// Solve the complementarity problem of the module page for the candidates' forces
    /// into [`Self::lambda`], given `c σ` (`cs`), the free gaps `a` computed by the caller
    /// from `q̇_free` (see [`Self::free_gaps`]) and the columns `g`, `w` of `dofs` rows.
    /// Returns the number of candidates that push (λ > 0).
    pub(crate) fn solve(&mut self, dofs: usize, cs: f64) -> usize {
        let m = self.candidates.len();
        self.s.resize(m * m, 0.0);
        for j in 0..m {
            let wj = &self.w[j * dofs..(j + 1) * dofs];
            for i in 0..m {
                let gi = &self.g[i * dofs..(i + 1) * dofs];
                let dot: f64 = gi.iter().zip(wj).map(|(a, b)| a * b).sum();
                self.s[i + j * m] = cs * dot;
            }
            self.s[j + j * m] += 1.0 / self.candidates[j].stiffness;
        }
        self.lambda.clear();
        self.lambda.resize(m, 0.0);
        self.active.clear();
        self.active.resize(m, false);
        // block principal pivoting (superhelix_kernels::contact::complementarity), the
        // principal subproblems by faer's LU on this buffer
        let PredictedContacts {
            s,
            a,
            lambda,
            active,
            sub,
            sub_rhs,
            index,
            perm,
            perm_inv,
            buffer,
            ..
        } = self;
        let mut scratch = ActiveScratch {
            sub,
            sub_rhs,
            index,
            perm,
            perm_inv,
            buffer,
        };
        self.pivots = block_principal_pivoting(m, s, a, lambda, active, |active, lambda| {
            scratch.solve(m, s, a, active, lambda)
        });
        for l in self.lambda.iter_mut() {
            *l = l.max(0.0);
        }
        self.lambda.iter().filter(|&&l| l > 0.0).count()
    }

    /// The gaps `a` of the module page, `a_c = gap_c + g_cᵀ (q_base − q_lin) + c g_cᵀ q̇`
    /// (`shift = q_base − q_lin`, `None` when zero).
    pub(crate) fn free_gaps(&mut self, dofs: usize, shift: Option<&[f64]>, c: f64, v: &[f64]) {
        let m = self.candidates.len();
        self.a.clear();
        for k in 0..m {
            let g = &self.g[k * dofs..(k + 1) * dofs];
            let mut a = self.candidates[k].gap;
            if let Some(shift) = shift {
                a += g.iter().zip(shift).map(|(x, y)| x * y).sum::<f64>();
            }
            a += c * g.iter().zip(v).map(|(x, y)| x * y).sum::<f64>();
            self.a.push(a);
        }
    }

    /// `v += σ W λ`.
    pub(crate) fn apply(&self, dofs: usize, sigma: f64, v: &mut [f64]) {
        for (k, &l) in self.lambda.iter().enumerate() {
            if l > 0.0 {
                let w = &self.w[k * dofs..(k + 1) * dofs];
                for (x, y) in v.iter_mut().zip(w) {
                    *x += sigma * l * y;
                }
            }
        }
    }

    /// The gap the linear model gives candidate `k` at the solution: `a_k + (S λ)_k −
    /// λ_k / (k w)`, m.
    #[cfg(test)]
    pub(crate) fn modelled_gap(&self, k: usize) -> f64 {
        let m = self.candidates.len();
        self.a[k]
            + (0..m)
                .map(|j| self.s[k + j * m] * self.lambda[j])
                .sum::<f64>()
            - self.lambda[k] / self.candidates[k].stiffness
    }
}

/// The buffers of the principal subproblems of [`PredictedContacts::solve`].
struct ActiveScratch<'a> {
    sub: &'a mut Vec<f64>,
    sub_rhs: &'a mut Vec<f64>,
    index: &'a mut Vec<usize>,
    perm: &'a mut Vec<usize>,
    perm_inv: &'a mut Vec<usize>,
    buffer: &'a mut Option<(usize, MemBuffer)>,
}

impl ActiveScratch<'_> {
    /// λ on the active set: `S_AA λ_A = −a_A`, 0 elsewhere (S m × m, column-major).
    fn solve(&mut self, m: usize, s: &[f64], a: &[f64], active: &[bool], lambda: &mut [f64]) {
        self.index.clear();
        self.index.extend((0..m).filter(|&c| active[c]));
        let p = self.index.len();
        for l in lambda.iter_mut() {
            *l = 0.0;
        }
        if p == 0 {
            return;
        }
        self.sub.resize(p * p, 0.0);
        self.sub_rhs.resize(p, 0.0);
        for (jj, &j) in self.index.iter().enumerate() {
            for (ii, &i) in self.index.iter().enumerate() {
                self.sub[ii + jj * p] = s[i + j * m];
            }
            self.sub_rhs[jj] = -a[j];
        }
        self.perm.resize(p, 0);
        self.perm_inv.resize(p, 0);
        if self.buffer.as_ref().is_none_or(|(cap, _)| *cap < p) {
            let req =
                lu::factor::lu_in_place_scratch::<usize, f64>(p, p, Par::Seq, Default::default())
                    .or(lu::solve::solve_in_place_scratch::<usize, f64>(
                        p,
                        1,
                        Par::Seq,
                    ));
            *self.buffer = Some((p, MemBuffer::new(req)));
        }
        let Some((_, buffer)) = self.buffer.as_mut() else {
            return;
        };
        let mut mat = MatMut::from_column_major_slice_mut(&mut self.sub[..p * p], p, p);
        let (_, perm) = lu::factor::lu_in_place(
            mat.as_mut(),
            self.perm,
            self.perm_inv,
            Par::Seq,
            MemStack::new(buffer),
            Default::default(),
        );
        let rhs = MatMut::from_column_major_slice_mut(&mut self.sub_rhs[..p], p, 1);
        lu::solve::solve_in_place(
            mat.as_ref(),
            mat.as_ref(),
            perm,
            rhs,
            Par::Seq,
            MemStack::new(buffer),
        );
        for (ii, &i) in self.index.iter().enumerate() {
            let x = self.sub_rhs[ii];
            // a singular block (two candidates on the same constraint) leaves no usable
            // force: none is better than a non-finite one
            lambda[i] = if x.is_finite() { x } else { 0.0 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(stiffness: f64, gap: f64) -> Candidate {
        Candidate {
            sample: 0,
            s: 0.0,
            stiffness,
            body: 0,
            normal: Vector3::z(),
            onset: 0.0,
            gap,
            end_gap: None,
        }
    }

    /// A point mass m falling at speed u onto a floor it is φ0 above, stepped by implicit
    /// Euler (A = m, σ = c = h): the one-sided penalty gives the closed form
    /// λ = k max(0, −φ_free) / (1 + k h²/m), and nothing when the point stops short.
    #[test]
    fn a_point_mass_landing_matches_the_closed_form() {
        let (m, h, k) = (1e-3, 1.0 / 30.0, 50.0);
        for (gap, u) in [(0.01, -1.0), (0.01, -0.1), (-0.001, 0.0)] {
            let mut p = PredictedContacts {
                candidates: vec![candidate(k, gap)],
                ..Default::default()
            };
            p.size_columns(1);
            p.g[0] = 1.0;
            p.w[0] = 1.0 / m;
            p.free_gaps(1, None, h, &[u]);
            p.solve(1, h * h);
            let free = gap + h * u;
            let expected = k * (-free).max(0.0) / (1.0 + k * h * h / m);
            assert!((p.lambda[0] - expected).abs() <= 1e-12 * expected.max(1.0));
            // the end gap of the linear model is the penalty's: λ = k max(0, −φ)
            let phi = p.modelled_gap(0);
            assert!((p.lambda[0] - k * (-phi).max(0.0)).abs() <= 1e-9 * expected.max(1e-9));
        }
    }

    /// Two coupled candidates where one pushes and the other is pulled clear: the solution
    /// satisfies complementarity (checked against every sign pattern).
    #[test]
    fn two_coupled_candidates_are_complementary() {
        let mut p = PredictedContacts {
            candidates: vec![candidate(100.0, 0.002), candidate(100.0, 0.001)],
            ..Default::default()
        };
        let dofs = 2;
        p.size_columns(dofs);
        // g columns and W = A⁻¹ G for A = [[2, 0.3], [-0.3, 1]] (skew part: Coriolis)
        let g = [1.0, 0.5, -0.4, 1.0];
        let det = 2.0 * 1.0 + 0.3 * 0.3;
        let inv = [1.0 / det, 0.3 / det, -0.3 / det, 2.0 / det];
        p.g.copy_from_slice(&g);
        for c in 0..2 {
            let (g0, g1) = (g[2 * c], g[2 * c + 1]);
            p.w[2 * c] = inv[0] * g0 + inv[2] * g1;
            p.w[2 * c + 1] = inv[1] * g0 + inv[3] * g1;
        }
        let v = [-0.3, 0.2];
        let h = 0.05;
        p.free_gaps(dofs, None, h, &v);
        p.solve(dofs, h * h);
        // w = S λ + a = φ + λ / (k w): λ ≥ 0, w ≥ 0, λ w = 0
        for k in 0..2 {
            let w = p.modelled_gap(k) + p.lambda[k] / 100.0;
            assert!(p.lambda[k] >= 0.0);
            assert!(w >= -1e-12, "{k}: {w}");
            assert!(p.lambda[k] * w <= 1e-12, "{k}: {} {w}", p.lambda[k]);
        }
        assert!(p.lambda.iter().any(|&l| l > 0.0));
    }
}

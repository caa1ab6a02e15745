//! Contacts that start within a step: the samples that touch nothing at the step's start
//! but are predicted to reach a collider before its end, and the one-sided penalty they
//! add to the step, resolved on the step's own factors (no second factorisation). The
//! runtime's step and the fixed-N step both resolve them here; each hands its factors,
//! its strand's Jacobian and its end check through [`PredictionHost`]. No `std`, no
//! allocation: the arrays are the caller's ([`PredictedBuffers`]).
//!
//! A sample touching a collider at the start of a step has its penalty stiffness `k w n
//! nᵀ` along its Jacobian in the step's matrix ([`super::body`]). A sample that reaches a
//! collider only during the step would, with the start's samples alone, pass into it
//! unopposed (at one solve per step, within a whole frame). Such a sample is predicted
//! from the step's own solution without it: a sample that ends that solution within one
//! and a half contact radii of a collider is a candidate ([`list`]). Its penalty is the
//! same law as a touching sample's, one-sided: with the gap `φ = d − r` (d the distance
//! of the centreline to the collider, r the contact radius) linearised along the Jacobian
//! J and the collider's normal n,
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
//! problem has one solution ([`super::complementarity`]).
//!
//! The end of the solve is then checked on the strand's actual reconstruction (not the
//! linear model), at most [`END_CHECKS`] times: samples the prediction missed become
//! candidates, and a candidate whose measured gap differs from the linear model's by
//! more than [`GAP_TOLERANCE`] of the contact radius has its gap corrected ([`resolve`]).

use super::body::{BodyContacts, ColliderSet};
use super::complementarity::{block_principal_pivoting, solve_principal};
use crate::head::HeadState;
use nalgebra::Vector3;

pub use super::candidates::Candidate;

type V3 = Vector3<f64>;

/// Checks of the solve's end against the actual reconstruction: after the first solve
/// with the candidates, at most this many corrections (each one complementarity solve
/// and one reconstruction, no factorisation).
pub const END_CHECKS: usize = 2;

/// A linearised gap within this fraction of the contact radius of the measured one is
/// left as it is.
pub const GAP_TOLERANCE: f64 = 0.05;

/// What a step's prediction carries besides its arrays.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PredictedScalars {
    /// Whether a prediction was made for the present solve (its linearisation point in
    /// the arrays' `q_lin`).
    pub predicted: bool,
    /// Candidates listed.
    pub count: usize,
    /// Candidates the last complementarity solve had (its forces in `lambda`).
    pub solved: usize,
    /// The tip's position at the linearisation point (the tip is not a sample: it is
    /// guarded by the end check, a candidate with `sample` out of range).
    pub lin_tip: Option<V3>,
    /// Whether the tip is a candidate.
    pub tip_listed: bool,
    /// The step's map (c, σ) of the last resolution: `q⁺ = q_base + c q̇⁺`, the forces
    /// entering the right-hand side as `σ Jᵀ f`.
    pub map: (f64, f64),
    /// Pivoting rounds of the last complementarity solve (diagnostics).
    pub pivots: usize,
}

/// A step's prediction arrays for `m` candidates of a strand of `dofs` coordinates and
/// its samples: each slice at least as long as stated (longer is fine: the functions
/// index by `m` and `dofs`).
pub struct PredictedArrays<'a> {
    /// The scalars.
    pub scalars: &'a mut PredictedScalars,
    /// The candidates (≥ m).
    pub candidates: &'a mut [Candidate],
    /// Columns `g_c = Jᵀ n` (dofs × m, column-major).
    pub g: &'a mut [f64],
    /// Columns `A⁻¹ g_c` (dofs × m).
    pub w: &'a mut [f64],
    /// The forces λ of the last solve, N (≥ m).
    pub lambda: &'a mut [f64],
    /// The free gaps `a` (≥ m).
    pub a: &'a mut [f64],
    /// The active set (≥ m).
    pub active: &'a mut [bool],
    /// S, m × m column-major (≥ m²).
    pub s: &'a mut [f64],
    /// The principal subproblem (≥ m²).
    pub sub: &'a mut [f64],
    /// Its right-hand side and solution (≥ m).
    pub sub_rhs: &'a mut [f64],
    /// Its indices (≥ m).
    pub index: &'a mut [usize],
    /// The samples' positions at the linearisation point, head coordinates (one per
    /// sample).
    pub lin_y: &'a mut [V3],
    /// Which samples touched a collider at the linearisation point (their stiffness is in
    /// the step's matrix).
    pub touching: &'a mut [bool],
    /// Which samples are candidates.
    pub listed: &'a mut [bool],
    /// The step's linearisation point (dofs).
    pub q_lin: &'a mut [f64],
    /// The step's solution without the candidates (dofs).
    pub v_free: &'a mut [f64],
    /// `q_base − q_lin` (dofs).
    pub shift: &'a mut [f64],
}

/// The lengths of the pools [`PredictedArrays::carve`] cuts a strand's prediction arrays
/// from (room for every sample and the tip as candidates).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PoolSizes {
    /// `f64`s.
    pub floats: usize,
    /// `bool`s.
    pub flags: usize,
    /// `usize`s.
    pub indices: usize,
    /// [`Candidate`]s.
    pub candidates: usize,
    /// Points (`Vector3<f64>`).
    pub points: usize,
}

impl PoolSizes {
    /// The pools for a strand of `samples` contact samples and `dofs` coordinates.
    pub const fn of(samples: usize, dofs: usize) -> Self {
        let m = samples + 1;
        PoolSizes {
            // g, w; lambda, a, sub_rhs; s, sub; q_lin, v_free, shift
            floats: 2 * m * dofs + 3 * m + 2 * m * m + 3 * dofs,
            // active; touching, listed
            flags: m + 2 * samples,
            indices: m,
            candidates: m,
            points: samples,
        }
    }
}

impl Candidate {
    /// A placeholder to fill storage with.
    pub const NONE: Candidate = Candidate {
        sample: 0,
        s: 0.0,
        stiffness: 0.0,
        body: 0,
        normal: Vector3::new(0.0, 0.0, 0.0),
        onset: 0.0,
        gap: 0.0,
        end_gap: None,
    };
}

impl<'a> PredictedArrays<'a> {
    /// The arrays of a strand of `samples` contact samples and `dofs` coordinates cut
    /// from the caller's pools, each at least [`PoolSizes::of`] long (`None` when one is
    /// shorter).
    #[allow(clippy::too_many_arguments)]
    pub fn carve(
        samples: usize,
        dofs: usize,
        scalars: &'a mut PredictedScalars,
        floats: &'a mut [f64],
        flags: &'a mut [bool],
        indices: &'a mut [usize],
        candidates: &'a mut [Candidate],
        points: &'a mut [V3],
    ) -> Option<Self> {
        let sizes = PoolSizes::of(samples, dofs);
        if floats.len() < sizes.floats
            || flags.len() < sizes.flags
            || indices.len() < sizes.indices
            || candidates.len() < sizes.candidates
            || points.len() < sizes.points
        {
            return None;
        }
        let m = samples + 1;
        let (g, rest) = floats.split_at_mut(m * dofs);
        let (w, rest) = rest.split_at_mut(m * dofs);
        let (lambda, rest) = rest.split_at_mut(m);
        let (a, rest) = rest.split_at_mut(m);
        let (sub_rhs, rest) = rest.split_at_mut(m);
        let (s, rest) = rest.split_at_mut(m * m);
        let (sub, rest) = rest.split_at_mut(m * m);
        let (q_lin, rest) = rest.split_at_mut(dofs);
        let (v_free, rest) = rest.split_at_mut(dofs);
        let (shift, _) = rest.split_at_mut(dofs);
        let (active, rest) = flags.split_at_mut(m);
        let (touching, rest) = rest.split_at_mut(samples);
        let (listed, _) = rest.split_at_mut(samples);
        Some(PredictedArrays {
            scalars,
            candidates,
            g,
            w,
            lambda,
            a,
            active,
            s,
            sub,
            sub_rhs,
            index: indices,
            lin_y: points,
            touching,
            listed,
            q_lin,
            v_free,
            shift,
        })
    }
}

/// Where a step's prediction arrays live: fixed storage with room for every sample and
/// the tip (m ≤ samples + 1), or buffers grown to the largest m met.
pub trait PredictedBuffers {
    /// The arrays for `m` candidates of `dofs` coordinates (and the samples'), the
    /// columns of the first candidates kept.
    fn arrays(&mut self, m: usize, dofs: usize) -> PredictedArrays<'_>;
}

/// Arrays with room for every candidate are their own buffers.
impl PredictedBuffers for PredictedArrays<'_> {
    fn arrays(&mut self, _m: usize, _dofs: usize) -> PredictedArrays<'_> {
        PredictedArrays {
            scalars: self.scalars,
            candidates: self.candidates,
            g: self.g,
            w: self.w,
            lambda: self.lambda,
            a: self.a,
            active: self.active,
            s: self.s,
            sub: self.sub,
            sub_rhs: self.sub_rhs,
            index: self.index,
            lin_y: self.lin_y,
            touching: self.touching,
            listed: self.listed,
            q_lin: self.q_lin,
            v_free: self.v_free,
            shift: self.shift,
        }
    }
}

/// What the resolution asks of the step that calls it.
pub trait PredictionHost<B: PredictedBuffers + ?Sized> {
    /// Solve `A x = b` in place with the step's factors; false when the solution is not
    /// finite.
    fn solve_factored(&mut self, x: &mut [f64]) -> bool;
    /// The columns `g_c` of the candidates from `from` on, at the linearisation point
    /// ([`linearize`] with the strand's Jacobian).
    fn linearize(&mut self, buffers: &mut B, from: usize);
    /// The end check at q ([`check`] with the samples' and the tip's positions at q and
    /// the colliders where they are at the step's end): returns the number of candidates
    /// before it.
    fn end_check(&mut self, buffers: &mut B, q: &[f64]) -> usize;
}

/// The step's matrix is singular for a candidate's column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SingularStep;

/// Forget the last prediction: until the next, nothing is resolved.
pub fn forget<B: PredictedBuffers + ?Sized>(buffers: &mut B) {
    let a = buffers.arrays(0, 0);
    a.scalars.predicted = false;
    a.scalars.count = 0;
}

/// Start a step's prediction at its linearisation point `q_lin`: the samples' positions
/// there (`lin_poses`, head coordinates) and whether each touches a collider, the tip's
/// position; no candidates yet.
pub fn begin<C: ColliderSet, B: PredictedBuffers + ?Sized>(
    buffers: &mut B,
    contacts: &BodyContacts<'_, C>,
    head: &HeadState,
    q_lin: &[f64],
    lin_poses: &[(V3, V3)],
    lin_tip: Option<V3>,
) {
    let dofs = q_lin.len();
    let a = buffers.arrays(0, dofs);
    a.scalars.predicted = true;
    a.scalars.count = 0;
    a.scalars.solved = 0;
    a.scalars.lin_tip = lin_tip;
    a.scalars.tip_listed = false;
    a.q_lin[..dofs].copy_from_slice(q_lin);
    for (k, pose) in lin_poses.iter().enumerate().take(contacts.samples.len()) {
        a.lin_y[k] = pose.0;
        a.listed[k] = false;
        a.touching[k] = contacts.touching(head, k, &pose.0).is_some();
    }
}

/// Add a candidate.
fn push<B: PredictedBuffers + ?Sized>(buffers: &mut B, dofs: usize, c: Candidate) {
    let m = buffers.arrays(0, dofs).scalars.count;
    let a = buffers.arrays(m + 1, dofs);
    a.candidates[m] = c;
    a.scalars.count = m + 1;
}

/// The candidates at the predicted end (`pred_poses`, the samples' poses of the step's
/// solution without them; the colliders where they are at the step's end): the samples
/// that touched nothing at the linearisation point and come within one and a half
/// contact radii of a collider. Returns whether there is any.
pub fn list<C: ColliderSet, B: PredictedBuffers + ?Sized>(
    buffers: &mut B,
    contacts: &BodyContacts<'_, C>,
    head: &HeadState,
    dofs: usize,
    pred_poses: &[(V3, V3)],
) -> bool {
    for (k, pose) in pred_poses.iter().enumerate().take(contacts.samples.len()) {
        let (touching, lin_y) = {
            let a = buffers.arrays(0, dofs);
            (a.touching[k], a.lin_y[k])
        };
        if touching {
            continue;
        }
        let Some((hit, onset)) = contacts.predicted_hit(head, k, &pose.0) else {
            continue;
        };
        buffers.arrays(0, dofs).listed[k] = true;
        let c = contacts.candidate(head, k, hit.body, onset, &lin_y, None);
        push(buffers, dofs, c);
    }
    buffers.arrays(0, dofs).scalars.count > 0
}

/// The columns `g_c = J(s_c)ᵀ n_c` of the candidates from `from` on: `jacobian(q_lin, s,
/// jac)` puts J(s) at the linearisation point into `jac` (one column per coordinate).
pub fn linearize<B: PredictedBuffers + ?Sized>(
    buffers: &mut B,
    dofs: usize,
    from: usize,
    jac: &mut [V3],
    mut jacobian: impl FnMut(&[f64], f64, &mut [V3]),
) {
    let m = buffers.arrays(0, dofs).scalars.count;
    let a = buffers.arrays(m, dofs);
    for c in from..m {
        let cand = a.candidates[c];
        jacobian(&a.q_lin[..dofs], cand.s, jac);
        let g = &mut a.g[c * dofs..(c + 1) * dofs];
        for (gi, ji) in g.iter_mut().zip(jac.iter()) {
            *gi = ji.dot(&cand.normal);
        }
    }
}

/// At the end of a step's solve (the samples' poses there `end_poses`, the tip's position
/// `tip_end`, the strand's length `length`; the colliders where they are at the step's
/// end): the gap of each candidate into its `end_gap`; and new candidates (linearised at
/// the start's position, their `end_gap` set): the samples that touched nothing at the
/// start and end within the contact radius of a collider, and those that touched (their
/// stiffness in the matrix) and whose centreline ends inside one; the tip, kept from
/// going deeper into a collider than it started the step (not inside, for a tip that
/// started outside). Returns the number of candidates before the additions.
#[allow(clippy::too_many_arguments)]
pub fn check<C: ColliderSet, B: PredictedBuffers + ?Sized>(
    buffers: &mut B,
    contacts: &BodyContacts<'_, C>,
    head: &HeadState,
    dofs: usize,
    end_poses: &[(V3, V3)],
    tip_end: Option<V3>,
    length: f64,
) -> usize {
    let before = buffers.arrays(0, dofs).scalars.count;
    {
        let a = buffers.arrays(before, dofs);
        for c in a.candidates[..before].iter_mut() {
            let y = match end_poses.get(c.sample) {
                Some(p) => p.0,
                None => tip_end.unwrap_or_default(),
            };
            let hit = contacts.query(head, c.body, &y);
            c.end_gap = Some(hit.distance - c.onset);
        }
    }
    let samples = contacts.samples.len().min(end_poses.len());
    for k in 0..samples {
        let (listed, touching, lin_y) = {
            let a = buffers.arrays(0, dofs);
            (a.listed[k], a.touching[k], a.lin_y[k])
        };
        if listed {
            continue;
        }
        let Some((hit, onset)) = contacts.end_hit(head, k, &end_poses[k].0, touching) else {
            continue;
        };
        buffers.arrays(0, dofs).listed[k] = true;
        let end = Some(hit.distance - onset);
        let c = contacts.candidate(head, k, hit.body, onset, &lin_y, end);
        push(buffers, dofs, c);
    }
    let (lin_tip, tip_listed) = {
        let s = buffers.arrays(0, dofs).scalars;
        (s.lin_tip, s.tip_listed)
    };
    if let (Some(end), Some(start), false) = (tip_end, lin_tip, tip_listed) {
        let (root_body, zone) = contacts.root_zone;
        let skip = (zone >= contacts.samples.len()).then_some(root_body);
        if let Some(hit) = contacts.nearest_within(head, &end, skip, None, 0.0) {
            let from = contacts.query(head, hit.body, &start);
            let onset = from.distance.min(0.0);
            if hit.distance < onset {
                let w = contacts.samples.last().map_or(0.0, |s| 0.5 * s.1);
                buffers.arrays(0, dofs).scalars.tip_listed = true;
                let c = Candidate {
                    sample: usize::MAX,
                    s: length,
                    stiffness: contacts.params.stiffness * w,
                    body: hit.body,
                    normal: from.normal,
                    onset,
                    gap: from.distance - onset,
                    end_gap: Some(hit.distance - onset),
                };
                push(buffers, dofs, c);
            }
        }
    }
    before
}

/// The gaps `a` of the module page, `a_c = gap_c + g_cᵀ shift + c g_cᵀ q̇` (`shift =
/// q_base − q_lin`, `None` when zero), for the `m` candidates.
pub fn free_gaps(
    a: &mut PredictedArrays<'_>,
    m: usize,
    dofs: usize,
    shift: Option<&[f64]>,
    c: f64,
    v: &[f64],
) {
    for k in 0..m {
        let g = &a.g[k * dofs..(k + 1) * dofs];
        let mut x = a.candidates[k].gap;
        if let Some(shift) = shift {
            x += g.iter().zip(shift).map(|(p, q)| p * q).sum::<f64>();
        }
        x += c * g.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
        a.a[k] = x;
    }
}

/// Solve the complementarity problem of the module page for the `m` candidates' forces
/// into `lambda`, given `c σ` (`cs`), the free gaps ([`free_gaps`]) and the columns `g`,
/// `w`. Returns the number of candidates that push (λ > 0).
pub fn solve_forces(a: &mut PredictedArrays<'_>, m: usize, dofs: usize, cs: f64) -> usize {
    for j in 0..m {
        let wj = &a.w[j * dofs..(j + 1) * dofs];
        // four products g_i · w_j at once, each summed in its own order (the same
        // result as one at a time, without waiting on one running sum)
        let mut i = 0;
        while i + 4 <= m {
            let g = &a.g[i * dofs..(i + 4) * dofs];
            let (g0, rest) = g.split_at(dofs);
            let (g1, rest) = rest.split_at(dofs);
            let (g2, g3) = rest.split_at(dofs);
            let mut d = [-0.0f64; 4];
            for k in 0..dofs {
                let w = wj[k];
                d[0] += g0[k] * w;
                d[1] += g1[k] * w;
                d[2] += g2[k] * w;
                d[3] += g3[k] * w;
            }
            for (r, dot) in d.iter().enumerate() {
                a.s[i + r + j * m] = cs * dot;
            }
            i += 4;
        }
        for i in i..m {
            let gi = &a.g[i * dofs..(i + 1) * dofs];
            a.s[i + j * m] = cs * dot(gi, wj);
        }
        a.s[j + j * m] += 1.0 / a.candidates[j].stiffness;
    }
    for k in 0..m {
        a.lambda[k] = 0.0;
        a.active[k] = false;
    }
    let PredictedArrays {
        s,
        a: gaps,
        lambda,
        active,
        sub,
        sub_rhs,
        index,
        scalars,
        ..
    } = a;
    let (s, gaps) = (&s[..m * m], &gaps[..m]);
    scalars.pivots = block_principal_pivoting(
        m,
        s,
        gaps,
        &mut lambda[..m],
        &mut active[..m],
        |active, lambda| solve_principal(m, s, gaps, active, lambda, sub, sub_rhs, index),
    );
    scalars.solved = m;
    let mut pushing = 0;
    for l in lambda[..m].iter_mut() {
        *l = l.max(0.0);
        if *l > 0.0 {
            pushing += 1;
        }
    }
    pushing
}

/// `v += σ W λ` over the `m` candidates of the last solve.
pub fn apply(a: &PredictedArrays<'_>, m: usize, dofs: usize, sigma: f64, v: &mut [f64]) {
    for (k, &l) in a.lambda[..m].iter().enumerate() {
        if l > 0.0 {
            let w = &a.w[k * dofs..(k + 1) * dofs];
            for (x, y) in v.iter_mut().zip(w) {
                *x += sigma * l * y;
            }
        }
    }
}

/// The gap the linear model gives candidate `k` of `m` at the last solve: `a_k + (S λ)_k
/// − λ_k / (k w)`, m.
pub fn modelled_gap(a: &PredictedArrays<'_>, m: usize, k: usize) -> f64 {
    a.a[k] + (0..m).map(|j| a.s[k + j * m] * a.lambda[j]).sum::<f64>()
        - a.lambda[k] / a.candidates[k].stiffness
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// At the end (q, q̇) of a step's solve (the host holding the factors of its matrix, the
/// prediction [`begin`]/[`list`]ed for it, `map` the step's `(c, σ)`): add the
/// candidates' forces, then check the end on the actual reconstruction and correct (see
/// the module page). A change `σ A⁻¹ Jᵀ f` of the velocity moves the end by `c` times
/// it. `tolerance` is [`GAP_TOLERANCE`] times the contact radius. Returns the number of
/// candidates that push. Nothing without a prediction.
pub fn resolve<B: PredictedBuffers + ?Sized, H: PredictionHost<B> + ?Sized>(
    buffers: &mut B,
    host: &mut H,
    map: (f64, f64),
    tolerance: f64,
    q: &mut [f64],
    v: &mut [f64],
) -> Result<usize, SingularStep> {
    buffers.arrays(0, v.len()).scalars.map = map;
    correct(buffers, host, tolerance, q, v, false)
}

/// [`resolve`] again on a step whose end (q, q̇) was changed since (scaled to the
/// rotation limit), with its matrix's factors still in the host: keeps the candidates
/// and their corrections, and corrects from that end. Returns 0 (counted at the step's
/// first resolution).
pub fn resolve_again<B: PredictedBuffers + ?Sized, H: PredictionHost<B> + ?Sized>(
    buffers: &mut B,
    host: &mut H,
    tolerance: f64,
    q: &mut [f64],
    v: &mut [f64],
) -> Result<usize, SingularStep> {
    correct(buffers, host, tolerance, q, v, true)
}

fn correct<B: PredictedBuffers + ?Sized, H: PredictionHost<B> + ?Sized>(
    buffers: &mut B,
    host: &mut H,
    tolerance: f64,
    q: &mut [f64],
    v: &mut [f64],
    again: bool,
) -> Result<usize, SingularStep> {
    let dofs = v.len();
    let (c, sigma) = {
        let a = buffers.arrays(0, dofs);
        if !a.scalars.predicted {
            // no prediction for this step
            return Ok(0);
        }
        let (c, sigma) = a.scalars.map;
        a.v_free[..dofs].copy_from_slice(v);
        // q = q_lin + shift + c q̇
        for i in 0..dofs {
            a.shift[i] = q[i] - c * v[i] - a.q_lin[i];
        }
        a.scalars.solved = 0;
        (c, sigma)
    };
    // the columns of the candidates kept from the first call are those of this matrix
    let mut columns = if again {
        buffers.arrays(0, dofs).scalars.count
    } else {
        0
    };
    host.linearize(buffers, columns);
    for pass in 0..=END_CHECKS {
        let m = buffers.arrays(0, dofs).scalars.count;
        if m > 0 {
            let mut a = buffers.arrays(m, dofs);
            for j in columns..m {
                let (g, w) = (
                    &a.g[j * dofs..(j + 1) * dofs],
                    &mut a.w[j * dofs..(j + 1) * dofs],
                );
                w.copy_from_slice(g);
                if !host.solve_factored(w) {
                    return Err(SingularStep);
                }
            }
            columns = m;
            let (v_free, shift) = (
                core::mem::take(&mut a.v_free),
                core::mem::take(&mut a.shift),
            );
            free_gaps(&mut a, m, dofs, Some(&shift[..dofs]), c, &v_free[..dofs]);
            solve_forces(&mut a, m, dofs, c * sigma);
            v.copy_from_slice(&v_free[..dofs]);
            apply(&a, m, dofs, sigma, v);
            for i in 0..dofs {
                q[i] = a.q_lin[i] + shift[i] + c * v[i];
            }
        }
        if pass == END_CHECKS {
            break;
        }
        // the end on the actual reconstruction
        let before = host.end_check(buffers, q);
        host.linearize(buffers, before);
        let m = buffers.arrays(0, dofs).scalars.count;
        let a = buffers.arrays(m, dofs);
        // new candidates are solved for
        let mut changed = m > before;
        let solved = a.scalars.solved;
        for k in 0..m {
            let Some(end) = a.candidates[k].end_gap else {
                continue;
            };
            let pushed = k < solved && a.lambda[k] > 0.0;
            if end >= 0.0 && !pushed {
                continue;
            }
            let g = &a.g[k * dofs..(k + 1) * dofs];
            let model = a.candidates[k].gap + dot(g, &a.shift[..dofs]) + c * dot(g, v);
            if (end - model).abs() > tolerance {
                a.candidates[k].gap += end - model;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    if again {
        return Ok(0);
    }
    let a = buffers.arrays(0, dofs);
    let solved = a.scalars.solved;
    Ok(a.lambda[..solved].iter().filter(|&&l| l > 0.0).count())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::vec;
    use std::vec::Vec;

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

    /// Owned arrays for `m` candidates of `dofs` coordinates.
    struct Owned {
        scalars: PredictedScalars,
        candidates: Vec<Candidate>,
        f: [Vec<f64>; 10],
        active: Vec<bool>,
        index: Vec<usize>,
        lin_y: Vec<V3>,
        flags: [Vec<bool>; 2],
    }

    impl Owned {
        fn new(cands: &[Candidate], dofs: usize) -> Self {
            let m = cands.len();
            let sizes = [dofs * m, dofs * m, m, m, m * m, m * m, m, dofs, dofs, dofs];
            Owned {
                scalars: PredictedScalars {
                    count: m,
                    ..Default::default()
                },
                candidates: cands.to_vec(),
                f: sizes.map(|n| vec![0.0; n]),
                active: vec![false; m],
                index: vec![0; m],
                lin_y: Vec::new(),
                flags: [Vec::new(), Vec::new()],
            }
        }
        fn arrays(&mut self) -> PredictedArrays<'_> {
            let [g, w, lambda, a, s, sub, sub_rhs, q_lin, v_free, shift] = &mut self.f;
            let [touching, listed] = &mut self.flags;
            PredictedArrays {
                scalars: &mut self.scalars,
                candidates: &mut self.candidates,
                g,
                w,
                lambda,
                a,
                active: &mut self.active,
                s,
                sub,
                sub_rhs,
                index: &mut self.index,
                lin_y: &mut self.lin_y,
                touching,
                listed,
                q_lin,
                v_free,
                shift,
            }
        }
    }

    /// A point mass m falling at speed u onto a floor it is φ0 above, stepped by implicit
    /// Euler (A = m, σ = c = h): the one-sided penalty gives the closed form
    /// λ = k max(0, −φ_free) / (1 + k h²/m), and nothing when the point stops short.
    #[test]
    fn a_point_mass_landing_matches_the_closed_form() {
        let (m, h, k) = (1e-3, 1.0 / 30.0, 50.0);
        for (gap, u) in [(0.01, -1.0), (0.01, -0.1), (-0.001, 0.0)] {
            let mut owned = Owned::new(&[candidate(k, gap)], 1);
            let mut p = owned.arrays();
            p.g[0] = 1.0;
            p.w[0] = 1.0 / m;
            free_gaps(&mut p, 1, 1, None, h, &[u]);
            solve_forces(&mut p, 1, 1, h * h);
            let free = gap + h * u;
            let expected = k * (-free).max(0.0) / (1.0 + k * h * h / m);
            assert!((p.lambda[0] - expected).abs() <= 1e-12 * expected.max(1.0));
            // the end gap of the linear model is the penalty's: λ = k max(0, −φ)
            let phi = modelled_gap(&p, 1, 0);
            assert!((p.lambda[0] - k * (-phi).max(0.0)).abs() <= 1e-9 * expected.max(1e-9));
        }
    }

    /// Two coupled candidates where one pushes and the other is pulled clear: the solution
    /// satisfies complementarity.
    #[test]
    fn two_coupled_candidates_are_complementary() {
        let mut owned = Owned::new(&[candidate(100.0, 0.002), candidate(100.0, 0.001)], 2);
        let mut p = owned.arrays();
        let dofs = 2;
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
        free_gaps(&mut p, 2, dofs, None, h, &v);
        solve_forces(&mut p, 2, dofs, h * h);
        // w = S λ + a = φ + λ / (k w): λ ≥ 0, w ≥ 0, λ w = 0
        for k in 0..2 {
            let w = modelled_gap(&p, 2, k) + p.lambda[k] / 100.0;
            assert!(p.lambda[k] >= 0.0);
            assert!(w >= -1e-12, "{k}: {w}");
            assert!(p.lambda[k] * w <= 1e-12, "{k}: {} {w}", p.lambda[k]);
        }
        assert!(p.lambda.iter().any(|&l| l > 0.0));
    }
}

//! The force of a pair of two strands in contact, solved once for both after their steps
//! (`[contacts.hair_hair] coupling = "pair"`).
//!
//! Each strand steps on its own (in parallel). A strand that saw its partner as an
//! immovable ball where it was at the step's start would push, and be pushed, as if the
//! other had no mass, and the two forces of a pair would not be equal and opposite while
//! the strands move (two free rods colliding lost 0.89 of their total momentum that
//! way, `coupling = "ball"`). Here a strand's step leaves its pairs with other strands
//! out (their Coulomb friction excepted, which stays in each strand's step), and after
//! every strand has stepped the pairs' forces are solved together, equal and opposite by
//! construction, and added to both strands' steps as the force they would have added to
//! the right-hand side:
//!
//! ```text
//! q̇⁺ = q̇_free + σ A⁻¹ Jᵀ F,   q⁺ = q_free + c (q̇⁺ − q̇_free)
//! ```
//!
//! with A the strand's step matrix (the factors its linearly implicit solve left, or the
//! linearly implicit matrix at the end after a BDF2 or Newton solve), σ = h the step (F's impulse is
//! σ F) and c the length of the piece the factors are for (the step's, or its last
//! piece's when it was split), J the Jacobian at the pair's point. The relative
//! velocity and the separation of the pair's two points are then linear in F, through
//! each side's compliance `D = J A⁻¹ Jᵀ` (3 × 3). The force is the pair's penalty along
//! the line of centres n at the step's start (from the other point to this one; a point
//! carried through the other strand within a step still counts as deep), with its
//! damping, and the damping of the relative velocity across n (without friction):
//!
//! ```text
//! f_n = max(0, k w (r − n·Δx) − c_h w n·Δv),   f_t = −c_h w P Δv,   P = I − n nᵀ
//! ```
//!
//! at the step's end (Δx, Δv the separation and relative velocity; k, c_h the mean of
//! the two strands'). The pairs are solved by Gauss–Seidel, each pair's force in closed
//! form for the others' (its own compliance in the denominator, as an implicit penalty
//! has it: stable at any k). A strand with a held tip sees its pairs through its
//! constrained compliance and the holder's reaction takes its share; a strand with a
//! free root keeps its momentum, the impulse σ Σ F added
//! ([`super::free_root_momentum`]).
//!
//! With the step's own matrix the force is what the step would have added to its
//! right-hand side: two rods pressed together settle where the penalty balances the
//! loads, and moving, the two sides share every impulse: the momentum of two free rods
//! colliding is kept to round-off.

use super::free_root_momentum;
use super::held_end::HeldTip;
use super::predicted_contacts::resolve_again;
use super::stats::StepStats;
use super::system::StrandSystem;
use super::StrandState;
use crate::bodies::Placement;
use crate::kernels::step_terms::KernelPoints;
use nalgebra::{Matrix3, Matrix6x3, Vector3, Vector6};
use superhelix_kernels::contact::partners::{HairHairParams, PartnerPoint};

/// Most Gauss–Seidel sweeps over the pairs of a step. The forces are equal and opposite
/// after any number of sweeps (the momentum is kept whatever the count); the sweeps
/// bring each pair's force to its penalty at the step's end, and what they leave is
/// taken up at the next step.
const MAX_SWEEPS: usize = 30;

/// The sweeps stop when no pair's force changed by more than this fraction of the
/// largest.
const SWEEP_TOLERANCE: f64 = 1e-9;

/// Sweeps whose largest force grew beyond this multiple of the first sweep's have
/// diverged.
const EXPLODED: f64 = 1e6;

/// Sweeps that ran out are kept when their last changed no force by more than this
/// fraction of the largest.
const ACCEPTED_CHANGE: f64 = 0.1;

/// The smallest relaxation of the sweeps (see [`solve`]).
const MIN_RELAXATION: f64 = 1.0 / 64.0;

/// No side: a pair's slot not yet filled, a side without a response.
const NONE: usize = usize::MAX;

/// The sides of the coupled pairs of one strand at its free step's end, and the change
/// of its velocity the pair forces make (buffers kept from step to step).
#[derive(Debug, Default)]
pub struct StrandSides {
    dofs: usize,
    /// Per side (every coupled partner of the step): the pair's index among the step's
    /// pairs.
    pair: Vec<usize>,
    /// y and ẏ at the free end, head frame.
    point: Vec<Vector3<f64>>,
    velocity: Vec<Vector3<f64>>,
    /// The partner's arc length on this strand, m.
    arc: Vec<f64>,
    /// n, head frame (from the other strand's point to this one's, at the step's start).
    normal: Vec<Vector3<f64>>,
    /// The pair's weight (arc length), m, and reach, m.
    weight: Vec<f64>,
    reach: Vec<f64>,
    /// This strand's penalty stiffness (N/m²), normal damping and tangential damping
    /// (N s/m²; the tangential 0 with Coulomb friction, which the step holds).
    stiffness: f64,
    damping: f64,
    tangential: f64,
    /// Per side: where its response is among the responses ([`NONE`]: the pair cannot
    /// touch, [`select`]).
    response_of: Vec<usize>,
    /// Per contact sample of the strand: its node ([`NONE`]: none). J and U are taken at
    /// the strand's contact samples (the nodes), and a pair's point between two samples
    /// interpolates them linearly (U = A⁻¹ Jᵀ is linear in J): a sample's pairs, up to
    /// `max_pairs_per_sample` of them, share its rows.
    node_of: Vec<usize>,
    /// Per node: J (∂y/∂q_j, `dofs` each) and the rows of `U = A⁻¹ Jᵀ` (constrained by a
    /// held tip), `dofs` each; the held tip's impulse per unit force along each axis.
    jac: Vec<Vector3<f64>>,
    response: Vec<Vector3<f64>>,
    node_held: Vec<Matrix6x3<f64>>,
    /// Per response: its two nodes and the weight t of the second.
    nodes: Vec<(usize, usize, f64)>,
    /// Per response: `D = J U`, the side's compliance at the point.
    compliance: Vec<Matrix3<f64>>,
    /// Per response: the held tip's impulse per unit force along each axis.
    held: Vec<Matrix6x3<f64>>,
    /// Per response: the pair's force on this side after [`solve`], N (head frame).
    force: Vec<Vector3<f64>>,
    /// The change of q̇ so far.
    dv: Vec<f64>,
    /// A back-substitution's buffer.
    column: Vec<f64>,
    /// J at a point (`dofs` columns).
    point_jac: Vec<Vector3<f64>>,
    /// σ (the impulse's duration) and c (the end moves by c times the velocity change).
    sigma: f64,
    c: f64,
    /// The factors are those the step's own solve left (its contacts with bodies that
    /// started within it can be resolved again on them).
    own_factors: bool,
    /// The strand's compliance at one of its pairs is indefinite: its pairs are left
    /// out of this step's solve.
    excluded: bool,
}

impl StrandSides {
    fn clear(&mut self, dofs: usize) {
        self.dofs = dofs;
        self.pair.clear();
        self.point.clear();
        self.velocity.clear();
        self.arc.clear();
        self.normal.clear();
        self.weight.clear();
        self.reach.clear();
        self.response_of.clear();
        self.node_of.clear();
        self.jac.clear();
        self.response.clear();
        self.node_held.clear();
        self.nodes.clear();
        self.compliance.clear();
        self.held.clear();
        self.force.clear();
        self.dv.clear();
        self.dv.resize(dofs, 0.0);
        self.excluded = false;
    }

    /// The sides of pairs that may touch this step.
    pub fn responses(&self) -> usize {
        self.compliance.len()
    }

    /// Whether the strand has a pair that may touch this step.
    pub fn is_empty(&self) -> bool {
        self.compliance.is_empty()
    }

    /// `J dv` at node k.
    fn node_moved(&self, k: usize) -> Vector3<f64> {
        self.jac[k * self.dofs..(k + 1) * self.dofs]
            .iter()
            .zip(&self.dv)
            .map(|(j, d)| j * *d)
            .sum()
    }

    /// `J dv` at response r.
    fn moved(&self, r: usize) -> Vector3<f64> {
        let (a, b, t) = self.nodes[r];
        if t == 0.0 {
            return self.node_moved(a);
        }
        self.node_moved(a) * (1.0 - t) + self.node_moved(b) * t
    }

    /// `dv += σ U F` at response r.
    fn push(&mut self, r: usize, force: &Vector3<f64>) {
        let (a, b, t) = self.nodes[r];
        let f = force * self.sigma;
        let (fa, fb) = (f * (1.0 - t), f * t);
        let dofs = self.dofs;
        let rows_a = &self.response[a * dofs..(a + 1) * dofs];
        if t == 0.0 {
            for (d, u) in self.dv.iter_mut().zip(rows_a) {
                *d += u.dot(&f);
            }
            return;
        }
        let rows_b = &self.response[b * dofs..(b + 1) * dofs];
        for ((d, u), w) in self.dv.iter_mut().zip(rows_a).zip(rows_b) {
            *d += u.dot(&fa) + w.dot(&fb);
        }
    }
}

/// The positive semidefinite part of the symmetric part of a side's compliance
/// `J A⁻¹ Jᵀ` (A is not symmetric: gyroscopic and Coriolis terms): the diagonal block
/// each pair's update divides by. The updates themselves move the strand by its actual
/// `A⁻¹ Jᵀ`, so the forces the sweeps converge to do not depend on it; only how fast
/// they converge does. Also whether the symmetric part has a negative eigenvalue (beyond
/// round-off).
fn positive_part(d: &Matrix3<f64>) -> (Matrix3<f64>, bool) {
    let sym = (d + d.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let largest = eig.eigenvalues.max();
    let indefinite = eig.eigenvalues.min() < -1e-9 * largest.abs();
    let clamped = eig.eigenvalues.map(|x| x.max(0.0));
    (
        eig.eigenvectors * Matrix3::from_diagonal(&clamped) * eig.eigenvectors.transpose(),
        indefinite,
    )
}

/// `J q̇`.
fn velocity_of(jac: &[Vector3<f64>], v: &[f64]) -> Vector3<f64> {
    jac.iter().zip(v).map(|(j, v)| j * *v).sum()
}

/// What the pair solve asks of a strand after its step: its coupled law, partners and
/// samples, its end (q, q̇), its points there, the factors of its step's matrix, its held
/// tip and free root, its contacts with bodies. The runtime engine's strands
/// ([`RuntimeStrand`]) and the embedded engine's (`super::embedded`) are both, on their
/// own storage: the solve itself ([`strand_ends`], [`select`], [`strand_responses`],
/// [`solve`], [`apply`]) is written once.
pub trait CoupledStrand {
    /// The hair–hair law of its pairs when they are coupled (`None`: not).
    fn coupled_law(&self) -> Option<HairHairParams>;
    /// Its partners of the step, in arc-length order.
    fn partners(&self) -> &[PartnerPoint];
    /// Its contact samples (arc length, weight).
    fn samples(&self) -> &[(f64, f64)];
    /// q and q̇ at the end of its step.
    fn end(&self) -> (&[f64], &[f64]);
    /// The point y(s) at its q (head frame), J(s) = ∂y/∂q into `jac`.
    fn point(&mut self, s: f64, jac: &mut [Vector3<f64>]) -> Vector3<f64>;
    /// The length of the piece the kept factors of its step's matrix are for (0: none)
    /// and whether they are its step's own (not the linearly implicit matrix at the end,
    /// factored after a BDF2 or Newton solve).
    fn factors(&self) -> (f64, bool);
    /// `A x = b` in place on the kept factors; false when singular.
    fn solve(&mut self, x: &mut [f64]) -> bool;
    /// Whether its tip is held.
    fn holds_tip(&self) -> bool;
    /// A held tip's rows for a change of its end on the kept factors (`t` the end's
    /// time); nothing without one.
    fn prepare_held(&mut self, t: f64) -> Result<(), String>;
    /// A change `u` of q̇ constrained by the held tip, and the holder's multipliers
    /// (zero without one).
    fn constrain_held(&mut self, u: &mut [f64]) -> Result<Vector6<f64>, String>;
    /// Whether its momentum is kept through the pairs' impulses (a free root, no held
    /// tip: [`super::free_root_momentum`]).
    fn keeps_momentum(&self) -> bool;
    /// Its linear momentum `M_X q̇` at its end.
    fn momentum(&mut self) -> [f64; 3];
    /// Move its end by a change of q̇: q̇ += dv, q += c dv.
    fn move_end(&mut self, dv: &[f64], c: f64);
    /// Resolve its contacts with bodies that started within the step again from its
    /// moved end, on the kept factors (`at`: the end's placement).
    fn resolve_again(&mut self, at: &Placement, stats: &mut StepStats) -> Result<(), String>;
    /// Move Ẋ so that its momentum is `target`.
    fn correct_momentum(&mut self, target: [f64; 3]);
    /// The holder's impulse `λ σ` added to its reaction and the held tip's drift
    /// projected out (nothing without a held tip).
    fn finish_held(&mut self, lambda: &Vector6<f64>, sigma: f64, t: f64) -> Result<(), String>;
    /// The contacts' bookkeeping of the step's end (`at`), after the pair solve moved
    /// it; `h` the step.
    fn end_contacts(&mut self, at: &Placement, h: f64);
}

/// A strand of the runtime engine with its state, as the pair solve sees it.
pub struct RuntimeStrand<'a> {
    /// The strand's system.
    pub system: &'a mut StrandSystem,
    /// Its state at the end of its step.
    pub state: &'a mut StrandState,
}

impl CoupledStrand for RuntimeStrand<'_> {
    fn coupled_law(&self) -> Option<HairHairParams> {
        let contacts = self.system.contacts.as_ref()?;
        contacts.hair_params().filter(|p| p.coupled).copied()
    }
    fn partners(&self) -> &[PartnerPoint] {
        self.system.contacts.as_ref().map_or(&[], |c| c.partners())
    }
    fn samples(&self) -> &[(f64, f64)] {
        self.system.contacts.as_ref().map_or(&[], |c| c.samples())
    }
    fn end(&self) -> (&[f64], &[f64]) {
        (&self.state.q, &self.state.v)
    }
    fn point(&mut self, s: f64, jac: &mut [Vector3<f64>]) -> Vector3<f64> {
        let ws = &mut self.system.workspace;
        let y = self
            .system
            .kernel
            .point(&self.state.q, s, &mut ws.jac, None);
        jac.copy_from_slice(&ws.jac[..jac.len()]);
        y
    }
    fn factors(&self) -> (f64, bool) {
        let f = &self.system.workspace.one_step_factors;
        (f.piece, f.own)
    }
    fn solve(&mut self, x: &mut [f64]) -> bool {
        self.system.workspace.one_step_factors.solve(x)
    }
    fn holds_tip(&self) -> bool {
        self.system.held.is_some()
    }
    fn prepare_held(&mut self, t: f64) -> Result<(), String> {
        let StrandSystem {
            strand,
            kernel,
            workspace: ws,
            held,
            ..
        } = &mut *self.system;
        let Some(held) = held.as_mut() else {
            return Ok(());
        };
        let factors = &mut ws.one_step_factors;
        held.prepare_change(
            &mut KernelPoints(kernel.as_mut()),
            &strand.geometry,
            &mut |x| factors.solve(x),
            &self.state.q,
            t,
        )
        .ok_or_else(|| "held tip: singular step matrix".to_string())
    }
    fn constrain_held(&mut self, u: &mut [f64]) -> Result<Vector6<f64>, String> {
        constrain(self.system.held.as_ref(), u)
    }
    fn keeps_momentum(&self) -> bool {
        free_root_momentum::applies(self.system)
    }
    fn momentum(&mut self) -> [f64; 3] {
        free_root_momentum::momentum_at(self.system, &self.state.q, &self.state.v)
    }
    fn move_end(&mut self, dv: &[f64], c: f64) {
        move_by(&mut self.state.q, &mut self.state.v, dv, c);
    }
    fn resolve_again(&mut self, at: &Placement, stats: &mut StepStats) -> Result<(), String> {
        let StrandState { q, v, .. } = &mut *self.state;
        resolve_again(self.system, at, q, v, stats)
    }
    fn correct_momentum(&mut self, target: [f64; 3]) {
        let StrandState { q, v, .. } = &mut *self.state;
        free_root_momentum::correct(self.system, q, v, target);
    }
    fn finish_held(&mut self, lambda: &Vector6<f64>, sigma: f64, t: f64) -> Result<(), String> {
        let system = &mut *self.system;
        let Some(held) = system.held.as_mut() else {
            return Ok(());
        };
        held.add_impulse(lambda, sigma, t);
        held.project(
            &mut KernelPoints(system.kernel.as_mut()),
            &system.strand.geometry,
            &mut self.state.q,
            t,
        )
        .map(|_| ())
        .map_err(|e| e.to_string())
    }
    fn end_contacts(&mut self, at: &Placement, h: f64) {
        if let Some(c) = &mut self.system.contacts {
            c.after_step(at, &self.system.strand.geometry, &self.state.q, h);
        }
    }
}

/// A change `u` of q̇ constrained by `held` ([`HeldTip::constrain_change`]), and the
/// holder's multipliers (zero without a held tip).
pub(super) fn constrain(held: Option<&HeldTip>, u: &mut [f64]) -> Result<Vector6<f64>, String> {
    match held {
        Some(held) => held.constrain_change(u).ok_or_else(|| {
            "held tip: the constraints are dependent (singular G A⁻¹ Gᵀ)".to_string()
        }),
        None => Ok(Vector6::zeros()),
    }
}

/// q̇ += dv, q += c dv.
pub(super) fn move_by(q: &mut [f64], v: &mut [f64], dv: &[f64], c: f64) {
    for j in 0..v.len() {
        v[j] += dv[j];
        q[j] += c * dv[j];
    }
}

/// The sides of `strand`'s coupled pairs at the end (q, q̇) of its free step (the head
/// at `at`), into `sides`: each side's point y and velocity ẏ there (the pairs that may
/// touch are then selected from both sides' ends, [`select`]).
pub fn strand_ends<S: CoupledStrand + ?Sized>(
    strand: &mut S,
    at: &Placement,
    sides: &mut StrandSides,
) {
    let dofs = strand.end().0.len();
    sides.clear(dofs);
    let Some(hh) = strand.coupled_law() else {
        return;
    };
    sides.stiffness = hh.stiffness;
    sides.damping = hh.damping;
    sides.tangential = if hh.friction.is_some() {
        0.0
    } else {
        hh.damping
    };
    let rt = at.head.rotation.transpose();
    let mut jac = std::mem::take(&mut sides.point_jac);
    jac.resize(dofs, Vector3::zeros());
    for k in 0..strand.partners().len() {
        let partner = strand.partners()[k];
        if partner.partner_s.is_some() || partner.normal == Vector3::zeros() {
            continue;
        }
        let y = strand.point(partner.s, &mut jac);
        sides.pair.push(partner.pair);
        sides.point.push(y);
        sides.velocity.push(velocity_of(&jac, strand.end().1));
        sides.arc.push(partner.s);
        sides.normal.push(rt * partner.normal);
        sides.weight.push(partner.weight);
        sides.reach.push(partner.reach);
        sides.response_of.push(NONE);
    }
    sides.point_jac = jac;
}

/// A pair the step's solve takes: its two sides (strand, side; the first side's first)
/// and the normal its penalty acts along.
#[derive(Debug, Clone, Copy)]
pub struct Chosen {
    sides: [(usize, usize); 2],
    /// The line of centres at the step's start n₀, the penalty's direction and the
    /// gap's (a point carried through the other strand within the step counts as deep,
    /// not as on the far side).
    normal: Vector3<f64>,
}

/// The pairs (`pairs`: the step's pair count) whose two sides are among `sides` and
/// overlap at the free end: closer than the reach, or carried through each other across
/// n₀ within the step and still facing each other across it. Two points that slid past
/// each other are left out (pushing them apart along n₀ by their approach would put
/// energy in: on a head shaken at one solve per strand-step it whipped the strands to
/// |q̇| = 5.4·10³). Marks their sides for [`strand_responses`].
pub fn select(sides: &mut [StrandSides], pairs: usize) -> Vec<Chosen> {
    let mut slots = vec![[(NONE, NONE); 2]; pairs];
    for (i, s) in sides.iter().enumerate() {
        for (k, &p) in s.pair.iter().enumerate() {
            let Some(slot) = slots.get_mut(p) else {
                continue;
            };
            if slot[0].0 == NONE {
                slot[0] = (i, k);
            } else {
                slot[1] = (i, k);
            }
        }
    }
    let chosen: Vec<Chosen> = slots
        .into_iter()
        .filter_map(|[(i, a), (j, b)]| {
            if i == NONE || j == NONE {
                return None;
            }
            let (sa, sb) = (&sides[i], &sides[j]);
            let n0 = sa.normal[a];
            let offset = sa.point[a] - sb.point[b];
            let along = n0.dot(&offset);
            let reach = sa.reach[a];
            let distance = offset.norm();
            if along > 0.0 {
                // on its side: touching if within the reach
                if distance >= reach {
                    return None;
                }
            } else if (offset - n0 * along).norm() >= reach {
                // carried through (or onto the other's centreline), but no longer facing
                // the other point across n₀
                return None;
            }
            Some(Chosen {
                sides: [(i, a), (j, b)],
                normal: n0,
            })
        })
        .collect();
    for c in &chosen {
        let [(i, a), (j, b)] = c.sides;
        sides[i].response_of[a] = 0;
        sides[j].response_of[b] = 0;
    }
    chosen
}

/// The responses of the sides [`select`] marked: J and the compliance rows `A⁻¹ Jᵀ` at
/// the end q of the free step of `h` (the head and bodies at `at`) at the contact
/// samples around each side's point (interpolated there), on the factors of the step
/// matrix the one step kept (its last linearly implicit piece's, or after BDF2 or Newton
/// the linearly implicit matrix at the step's end, `superhelix_kernels::fixed::factor_step_views`),
/// constrained by a held tip.
pub fn strand_responses<S: CoupledStrand + ?Sized>(
    strand: &mut S,
    at: &Placement,
    h: f64,
    stats: &mut StepStats,
    sides: &mut StrandSides,
) -> Result<(), String> {
    let dofs = strand.end().0.len();
    if sides.response_of.iter().all(|&r| r == NONE) {
        return Ok(());
    }
    // the step matrix's factors the one step kept: its last linearly implicit piece's,
    // or the linearly implicit matrix at its end (after BDF2 or Newton)
    let (piece, own) = strand.factors();
    if piece <= 0.0 {
        return Err(
            "hair–hair pairs: the strand's step left no step matrix (a singular one)".into(),
        );
    }
    sides.own_factors = own;
    sides.sigma = h;
    sides.c = piece;
    strand.prepare_held(at.time)?;
    let held = strand.holds_tip();
    let samples_len = strand.samples().len();
    sides.node_of.resize(samples_len, NONE);
    let mut column = std::mem::take(&mut sides.column);
    column.resize(dofs, 0.0);
    let mut jac = std::mem::take(&mut sides.point_jac);
    jac.resize(dofs, Vector3::zeros());
    let mut indefinite_anywhere = false;
    for k in 0..sides.pair.len() {
        if sides.response_of[k] == NONE {
            continue;
        }
        sides.response_of[k] = sides.compliance.len();
        // the two samples around the pair's point (the nearest one beyond the ends)
        let s = sides.arc[k];
        let samples = strand.samples();
        let above = samples.partition_point(|x| x.0 < s);
        let (lo, hi, t) = if samples.is_empty() {
            return Err("hair–hair pairs: a strand without contact samples".into());
        } else if above == 0 {
            (0, 0, 0.0)
        } else if above == samples.len() {
            (above - 1, above - 1, 0.0)
        } else {
            let (s0, s1) = (samples[above - 1].0, samples[above].0);
            (above - 1, above, ((s - s0) / (s1 - s0)).clamp(0.0, 1.0))
        };
        for sample in [lo, hi] {
            if sides.node_of[sample] != NONE {
                continue;
            }
            sides.node_of[sample] = sides.node_held.len();
            let arc = strand.samples()[sample].0;
            strand.point(arc, &mut jac);
            let start = sides.jac.len();
            sides.jac.extend_from_slice(&jac);
            sides.response.resize(start + dofs, Vector3::zeros());
            let mut held_impulse = Matrix6x3::zeros();
            for axis in 0..3 {
                for (x, j) in column.iter_mut().zip(&jac) {
                    *x = j[axis];
                }
                if !strand.solve(&mut column) {
                    return Err("hair–hair pairs: singular step matrix".into());
                }
                if held {
                    let lambda = strand.constrain_held(&mut column)?;
                    held_impulse.set_column(axis, &lambda);
                }
                for (r, x) in sides.response[start..].iter_mut().zip(&column) {
                    r[axis] = *x;
                }
            }
            sides.node_held.push(held_impulse);
        }
        let (a, b) = (sides.node_of[lo], sides.node_of[hi]);
        sides.nodes.push((a, b, t));
        // D = J U at the interpolated point
        let mut d = Matrix3::zeros();
        let node = |n: usize| n * dofs..(n + 1) * dofs;
        for ((ja, jb), (ua, ub)) in sides.jac[node(a)]
            .iter()
            .zip(&sides.jac[node(b)])
            .zip(sides.response[node(a)].iter().zip(&sides.response[node(b)]))
        {
            let j = ja * (1.0 - t) + jb * t;
            let u = ua * (1.0 - t) + ub * t;
            d += j * u.transpose();
        }
        let (positive, indefinite) = positive_part(&d);
        indefinite_anywhere |= indefinite;
        sides.compliance.push(positive);
        sides
            .held
            .push(sides.node_held[a] * (1.0 - t) + sides.node_held[b] * t);
        sides.force.push(Vector3::zeros());
    }
    if indefinite_anywhere {
        // the step's compliance is not positive at a pair (the strand's gyroscopic
        // terms outweigh its mass there): the sweeps would diverge, and meeting the
        // strand as a wall where its step ended whips its partners. Its pairs take no
        // force this step
        sides.excluded = true;
        stats.pairs_indefinite += sides.compliance.len();
    }
    sides.column = column;
    sides.point_jac = jac;
    Ok(())
}

/// Solve the forces of the pairs `chosen` ([`select`]), accumulating each strand's
/// velocity change. Returns the sweeps taken; `None` (and no velocity change) when they
/// did not converge within [`MAX_SWEEPS`] at every relaxation down to
/// [`MIN_RELAXATION`].
pub fn solve(sides: &mut [StrandSides], chosen: &[Chosen]) -> Option<usize> {
    // the force on each pair's first side (the second takes its opposite)
    let mut force = vec![Vector3::zeros(); chosen.len()];
    let mut sweeps = 0;
    // the relaxation: each pair's update moves its force this fraction of the way to
    // its closed form. A's skew part (a turning head's Coriolis term, the gyroscopic
    // one) makes the compliances unsymmetric, where plain Gauss–Seidel can diverge; its
    // symmetric part stays positive definite, so a small enough fraction converges
    let mut relax = 1.0;
    let mut last_change = f64::INFINITY;
    let mut last_largest = 0.0;
    let mut first_largest = 0.0;
    let mut growing = 0;
    let mut converged = chosen.is_empty();
    while sweeps < MAX_SWEEPS {
        sweeps += 1;
        let (mut largest, mut change) = (0.0f64, 0.0f64);
        for (p, pair) in chosen.iter().enumerate() {
            let [(i, a), (j, b)] = pair.sides;
            let (sa, sb) = (&sides[i], &sides[j]);
            if sa.excluded || sb.excluded {
                continue;
            }
            let (ra, rb) = (sa.response_of[a], sb.response_of[b]);
            let n = pair.normal;
            // the relative velocity and the separation are linear in the pair's force F:
            // by σ_a D_a + σ_b D_b and (c σ D)_a + (c σ D)_b (each side's end moves by c
            // times its velocity change)
            let (ma, mb) = (sa.moved(ra), sb.moved(rb));
            let relative = sa.velocity[a] + ma - sb.velocity[b] - mb;
            let separation = sa.point[a] + ma * sa.c - sb.point[b] - mb * sb.c;
            let d = sa.compliance[ra] * sa.sigma + sb.compliance[rb] * sb.sigma;
            let dc = sa.compliance[ra] * (sa.sigma * sa.c) + sb.compliance[rb] * (sb.sigma * sb.c);
            let old = force[p];
            // without this pair's own force
            let relative0 = relative - d * old;
            let separation0 = separation - dc * old;
            let weight = sa.weight[a].min(sb.weight[b]);
            let kw = 0.5 * (sa.stiffness + sb.stiffness) * weight;
            let cw = 0.5 * (sa.damping + sb.damping) * weight;
            let tw = 0.5 * (sa.tangential + sb.tangential) * weight;
            let reach = sa.reach[a];
            // the normal force, the tangential part held
            let across = old - n * n.dot(&old);
            let gap = n.dot(&(separation0 + dc * across));
            let speed = n.dot(&(relative0 + d * across));
            let normal = ((kw * (reach - gap) - cw * speed)
                / (1.0 + kw * n.dot(&(dc * n)) + cw * n.dot(&(d * n))))
            .max(0.0);
            // the tangential damping of the relative velocity across n, while in contact:
            // (I + t P D P) f_t = −t P (v₀ + D n f)
            let mut tangential = Vector3::zeros();
            if normal > 0.0 && tw > 0.0 {
                let plane = Matrix3::identity() - n * n.transpose();
                let m = Matrix3::identity() + plane * d * plane * tw;
                let rhs = -(plane * (relative0 + d * n * normal)) * tw;
                if let Some(x) = m.lu().solve(&rhs) {
                    tangential = plane * x;
                }
            }
            let new = old + (n * normal + tangential - old) * relax;
            let df = new - old;
            if df != Vector3::zeros() {
                sides[i].push(ra, &df);
                sides[j].push(rb, &-df);
            }
            force[p] = new;
            largest = largest.max(new.norm());
            change = change.max(df.norm());
        }
        if change <= SWEEP_TOLERANCE * largest {
            converged = true;
            break;
        }
        if sweeps == 1 {
            first_largest = largest;
        }
        // diverging: the change grew for two sweeps running (halve the relaxation and go
        // on), or exploded (start again from no force at half the relaxation)
        growing = if change > last_change { growing + 1 } else { 0 };
        last_change = change;
        last_largest = largest;
        if !change.is_finite() || largest > EXPLODED * first_largest {
            relax *= 0.5;
            force.fill(Vector3::zeros());
            for side in sides.iter_mut() {
                side.dv.fill(0.0);
            }
            (growing, last_change) = (0, f64::INFINITY);
            if relax < MIN_RELAXATION {
                break;
            }
        } else if growing >= 2 && relax > MIN_RELAXATION {
            relax *= 0.5;
            growing = 0;
        }
    }
    // sweeps that ran out while still closing in are kept
    converged |= last_change.is_finite() && last_change <= ACCEPTED_CHANGE * last_largest;
    if !converged {
        // no force rather than a wrong one: the pairs are counted
        for side in sides.iter_mut() {
            side.dv.fill(0.0);
        }
        return None;
    }
    for (p, pair) in chosen.iter().enumerate() {
        let [(i, a), (j, b)] = pair.sides;
        let (ra, rb) = (sides[i].response_of[a], sides[j].response_of[b]);
        sides[i].force[ra] = force[p];
        sides[j].force[rb] = -force[p];
    }
    Some(sweeps)
}

/// Apply the velocity change [`solve`] accumulated for this strand to its end (q, q̇)
/// (time `t_end`), with the holder's reaction and a free root's momentum updated; the
/// held tip's drift projected out.
pub fn apply<S: CoupledStrand + ?Sized>(
    strand: &mut S,
    sides: &StrandSides,
    at: &Placement,
    stats: &mut StepStats,
) -> Result<(), String> {
    let t_end = at.time;
    if sides.is_empty() || sides.dv.iter().all(|&x| x == 0.0) {
        return Ok(());
    }
    let target = strand.keeps_momentum().then(|| {
        let mut p = strand.momentum();
        for f in &sides.force {
            for k in 0..3 {
                p[k] += sides.sigma * f[k];
            }
        }
        p
    });
    strand.move_end(&sides.dv, sides.c);
    // the contacts with bodies that started within the step, resolved again from the
    // moved end on the same factors (the pairs may have pushed a point into a body)
    if sides.own_factors {
        strand.resolve_again(at, stats)?;
    }
    if let Some(target) = target {
        strand.correct_momentum(target);
    }
    if strand.holds_tip() {
        let mut lambda = Vector6::zeros();
        for (l, f) in sides.held.iter().zip(&sides.force) {
            lambda += l * (f * sides.sigma);
        }
        strand.finish_held(&lambda, sides.sigma, t_end)?;
    }
    Ok(())
}

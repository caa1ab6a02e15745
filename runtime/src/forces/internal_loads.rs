//! Internal loads of a strand and the reactions of its holders.
//!
//! The internal force n(s) and moment m(s) are those the part of the strand beyond s
//! exerts on the part before it (the convention of Kirchhoff's rod equations, Audoly and
//! Pomeau 2006, cited in section 3.5 of the Super-Helix paper); the moment is taken about
//! the centreline point y(s). Two measures are given, as a rod code gives them:
//!
//! - **Constitutive, per element.** The elastic law behind the internal energy (5c) and
//!   the dissipation (5d): along the material frame (n0, n1, n2),
//!   `m_Q = ((EI)_0 (τ_Q − τⁿ_Q), (EI)_1 (κ1_Q − κ1ⁿ_Q), (EI)_2 (κ2_Q − κ2ⁿ_Q)) + γ q̇_Q`,
//!   constant over element Q as its curvatures are (equation (3)).
//! - **Balance, at every element end s_k.** Newton and Euler for the part beyond s_k,
//!   written in the head frame where the body field holds gravity, the head's fictitious
//!   forces and air drag (design page "Energies and the equation of motion"):
//!   `n(s_k) = ∫_{s_k}^L f ds + Σ F_p + F_L − dP_k/dt`,
//!   `m(s_k) = ∫ (y − y_k) × f ds + Σ (y_p − y_k) × F_p + (y_L − y_k) × F_L + M_L
//!   − (dH_k/dt − y_k × dP_k/dt)`, where f is the body field's force per length, F_p the
//!   point loads beyond s_k, (F_L, M_L) a holder's reaction on a held tip, and
//!   P_k = ∫ ρS ẏ ds, H_k = ∫ y × ρS ẏ ds the part's momentum and angular momentum about
//!   the head's origin. The root's reaction is `(−n(0), −m(0))`, what the holder applies.
//!
//! In a static equilibrium the two agree in the way a Galerkin discretisation makes them
//! agree: each element's constitutive moment is the mean over the element of the balance
//! moment (to first order in the deflection; `tests/internal_loads.rs` holds both to the
//! cantilever's closed forms). The integrals are Gauss–Legendre with [`POINTS`] points per
//! element on the closed-form reconstruction.
//!
//! **Inertia.** dP_k/dt and dH_k/dt are backward differences of the momenta at the
//! present state and at up to two earlier ones the caller kept ([`Momenta`]; with two,
//! second order in the step, the variable-step BDF2 formula). With none, the inertia is
//! taken as zero, which is exact in a static equilibrium. The cross-sections' rotary
//! inertia (about 10⁻⁶ of the centreline's for a hair) is left out of the balance.
//!
//! **What is not counted.** Forces this module cannot place along the strand: contacts
//! with bodies or other strands and Coulomb forces. [`crate::simulation::Simulation`]
//! refuses internal loads for a scene that has them rather than report a balance that
//! leaves them out.

use crate::forces::effects::{body_field, GlobalEffects};
use crate::forces::point_loads::head_force;
use crate::model::kinematics::relative_velocities;
use crate::model::quadrature::gauss_legendre;
use crate::model::reconstruction::{element_ends, poses_at_sorted, positions_at_sorted, Pose};
use crate::model::strand::Strand;
use nalgebra::{Vector3, Vector6};
use superhelix_kernels::head::HeadState;

/// Gauss–Legendre points per element for the balance's integrals.
pub const POINTS: usize = 10;

/// The momentum P_k and angular momentum H_k (about the head's origin) of the part of a
/// strand beyond each of its element ends, relative to the head, in head coordinates, at
/// one time: what [`internal_loads`] differences for the inertia.
#[derive(Debug, Clone, PartialEq)]
pub struct Momenta {
    /// The simulated time of the state, s.
    pub time: f64,
    /// P_k, kg·m/s, one per element end beyond the root joint (root first).
    pub momentum: Vec<Vector3<f64>>,
    /// H_k, kg·m²/s, likewise.
    pub angular: Vec<Vector3<f64>>,
}

/// The internal loads of one strand at one state (see the module page). World
/// coordinates; arc length from the root (a pinned or free root's joint not counted).
#[derive(Debug, Clone, PartialEq)]
pub struct InternalLoads {
    /// Arc length of each element end, root first, m (N + 1 values).
    pub arcs: Vec<f64>,
    /// The centreline at each element end, m.
    pub positions: Vec<Vector3<f64>>,
    /// n(s_k), N.
    pub force: Vec<Vector3<f64>>,
    /// m(s_k) about the centreline point, N·m.
    pub moment: Vec<Vector3<f64>>,
    /// Each element's constitutive moment along its material frame (twist about n0,
    /// bending about n1, about n2), N·m.
    pub element_moment: Vec<Vector3<f64>>,
    /// The same, in world coordinates, with the frame at the element's middle, N·m.
    pub element_moment_world: Vec<Vector3<f64>>,
    /// What the holder of a clamped or pinned root applies to the strand: force (N) then
    /// moment about the root (N·m). `None` for a free root.
    pub root_reaction: Option<Vector6<f64>>,
    /// What the holder of a held tip applies to it: force, then moment about the tip.
    pub tip_reaction: Option<Vector6<f64>>,
    /// Whether the inertia was counted (earlier momenta were given).
    pub inertia: bool,
}

/// A strand at one state, and what acts on it there.
pub struct LoadState<'a> {
    /// The strand.
    pub strand: &'a Strand,
    /// Its coordinates.
    pub q: &'a [f64],
    /// Its velocities.
    pub v: &'a [f64],
    /// The head then.
    pub head: &'a HeadState,
    /// Gravity and whether the head moves.
    pub effects: GlobalEffects,
    /// A held tip's reaction (world: force, then moment about the tip).
    pub tip_reaction: Option<Vector6<f64>>,
}

/// The Gauss points of every element beyond the root joint (increasing arc length from
/// the strand's start, joint included) with their weights, and each element's range.
fn quadrature(strand: &Strand) -> (Vec<f64>, Vec<f64>) {
    let rule = gauss_legendre(POINTS);
    let joint = strand.ends.joint_elements();
    let (mut arcs, mut weights) = (Vec::new(), Vec::new());
    let mut start = 0.0;
    for (e, &l) in strand.geometry.lengths.iter().enumerate() {
        if e >= joint {
            for (x, w) in rule.nodes().iter().zip(rule.weights()) {
                arcs.push(start + 0.5 * l * (1.0 + x));
                weights.push(0.5 * l * w);
            }
        }
        start += l;
    }
    (arcs, weights)
}

/// Suffix sums over elements (POINTS values each) of `values`, one per element end
/// beyond the joint (the last, at the tip, zero).
fn suffix(values: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
    let elements = values.len() / POINTS;
    let mut out = vec![Vector3::zeros(); elements + 1];
    for e in (0..elements).rev() {
        let part: Vector3<f64> = values[e * POINTS..(e + 1) * POINTS].iter().sum();
        out[e] = out[e + 1] + part;
    }
    out
}

/// The momenta of the parts beyond each element end at (q, q̇) and `time` (head
/// coordinates, relative to the head).
pub fn momenta(strand: &Strand, q: &[f64], v: &[f64], time: f64) -> Momenta {
    let (arcs, weights) = quadrature(strand);
    let mut y = Vec::new();
    positions_at_sorted(&strand.geometry, q, arcs.iter().copied(), &mut y);
    let ydot = relative_velocities(&strand.geometry, q, v, &arcs);
    momenta_of(strand, &y, &ydot, &weights, time)
}

/// [`momenta`] from the Gauss points' positions `y`, velocities `ydot` and weights.
fn momenta_of(
    strand: &Strand,
    y: &[Vector3<f64>],
    ydot: &[Vector3<f64>],
    weights: &[f64],
    time: f64,
) -> Momenta {
    let rho = strand.geometry.mass_per_length;
    let p: Vec<_> = ydot
        .iter()
        .zip(weights)
        .map(|(u, w)| u * (rho * w))
        .collect();
    let h: Vec<_> = y.iter().zip(&p).map(|(y, p)| y.cross(p)).collect();
    Momenta {
        time,
        momentum: suffix(&p),
        angular: suffix(&h),
    }
}

/// Keep the momenta of strand `i` at (q, q̇, `time`) in `kept` (one list per strand,
/// oldest first), dropping all but the last two: what [`internal_loads`] differences.
pub fn keep(kept: &mut Vec<Vec<Momenta>>, i: usize, now: Momenta) {
    if kept.len() <= i {
        kept.resize_with(i + 1, Vec::new);
    }
    let list = &mut kept[i];
    list.push(now);
    if list.len() > 2 {
        list.remove(0);
    }
}

/// The rate of the momenta at `now` from up to two earlier ones (oldest first): the
/// backward difference of first order with one, the variable-step BDF2 formula with two.
/// `None` without any usable (earlier times, the same element count). The rates are
/// returned in a [`Momenta`] of time `now.time`.
fn rates(now: &Momenta, earlier: &[Momenta]) -> Option<Momenta> {
    let usable: Vec<&Momenta> = earlier
        .iter()
        .filter(|m| m.momentum.len() == now.momentum.len())
        .collect();
    // (weights of the present state and of the earlier ones, oldest first)
    let (c_now, back): (f64, Vec<(f64, &Momenta)>) = match usable.as_slice() {
        [.., a, b] if a.time < b.time && b.time < now.time => {
            let (h1, h2) = (b.time - a.time, now.time - b.time);
            (
                1.0 / h2 + 1.0 / (h1 + h2),
                vec![(h2 / (h1 * (h1 + h2)), *a), (-(h1 + h2) / (h1 * h2), *b)],
            )
        }
        [.., b] if b.time < now.time => {
            let h = now.time - b.time;
            (1.0 / h, vec![(-1.0 / h, *b)])
        }
        _ => return None,
    };
    let combine = |pick: fn(&Momenta) -> &Vec<Vector3<f64>>| -> Vec<Vector3<f64>> {
        (0..now.momentum.len())
            .map(|k| {
                back.iter()
                    .fold(pick(now)[k] * c_now, |acc, (c, m)| acc + pick(m)[k] * *c)
            })
            .collect()
    };
    Some(Momenta {
        time: now.time,
        momentum: combine(|m| &m.momentum),
        angular: combine(|m| &m.angular),
    })
}

/// The internal loads of `state`'s strand at simulated time `time` (see the module
/// page); `earlier` up to two of its earlier [`momenta`], oldest first (none: the inertia
/// counts as zero).
pub fn internal_loads(state: &LoadState<'_>, time: f64, earlier: &[Momenta]) -> InternalLoads {
    let strand = state.strand;
    let geom = &strand.geometry;
    let (q, v, head) = (state.q, state.v, state.head);
    let joint = strand.ends.joint_elements();
    let n = geom.elements();
    let (arcs, weights) = quadrature(strand);
    // the body field's force per length f = c0 + C1 y + C2 ẏ at the Gauss points
    let field = body_field(&state.effects, head, geom.mass_per_length, strand.air_drag);
    let mut y = Vec::new();
    positions_at_sorted(geom, q, arcs.iter().copied(), &mut y);
    let ydot = relative_velocities(geom, q, v, &arcs);
    let f: Vec<Vector3<f64>> = y
        .iter()
        .zip(&ydot)
        .zip(&weights)
        .map(|((y, u), w)| (field.uniform + field.linear * y + field.velocity * u) * *w)
        .collect();
    let torque: Vec<_> = y.iter().zip(&f).map(|(y, f)| y.cross(f)).collect();
    let (mut forces, mut torques) = (suffix(&f), suffix(&torque));
    // the element ends beyond the joint, and their arc lengths from the strand's start
    let mut ends: Vec<Pose> = vec![geom.root_pose(q); n + 1];
    element_ends(geom, q, &mut ends);
    let ends = &ends[joint..];
    let mut starts = vec![0.0; n + 1];
    for e in 0..n {
        starts[e + 1] = starts[e] + geom.lengths[e];
    }
    let starts = &starts[joint..];
    let length = geom.length();
    // point loads, in the part beyond every end before them (a load at the tip in all)
    let rt = head.rotation.transpose();
    for load in &strand.point_loads {
        let fh = head_force(load, &rt, geom, q);
        let mut at = Vec::new();
        positions_at_sorted(geom, q, [load.s], &mut at);
        let couple = rt * load.torque;
        for k in 0..starts.len() {
            if load.s > starts[k] || load.s >= length {
                forces[k] += fh;
                torques[k] += at[0].cross(&fh) + couple;
            }
        }
    }
    // the holder's reaction on a held tip
    if let Some(r) = state.tip_reaction {
        let fh = rt * Vector3::new(r[0], r[1], r[2]);
        let mh = rt * Vector3::new(r[3], r[4], r[5]);
        let tip = ends[ends.len() - 1].position;
        for k in 0..starts.len() {
            forces[k] += fh;
            torques[k] += tip.cross(&fh) + mh;
        }
    }
    let now = momenta_of(strand, &y, &ydot, &weights, time);
    let inertia = rates(&now, earlier);
    if let Some(rate) = &inertia {
        for k in 0..starts.len() {
            forces[k] -= rate.momentum[k];
            torques[k] -= rate.angular[k];
        }
    }
    // to world coordinates, the moment about y(s_k)
    let r = head.rotation;
    let force: Vec<Vector3<f64>> = forces.iter().map(|f| r * f).collect();
    let moment: Vec<Vector3<f64>> = torques
        .iter()
        .zip(&forces)
        .zip(ends)
        .map(|((t, f), end)| r * (t - end.position.cross(f)))
        .collect();
    let positions: Vec<Vector3<f64>> = ends
        .iter()
        .map(|e| head.position + r * e.position)
        .collect();
    // the constitutive moment per element, and at the element's middle in the world
    let stiffness = strand.material.stiffness;
    let element_moment: Vec<Vector3<f64>> = (joint..n)
        .map(|e| {
            Vector3::from_fn(|c, _| {
                let i = 3 * e + c;
                stiffness[c] * (q[i] - strand.natural[i]) + strand.internal_friction * v[i]
            })
        })
        .collect();
    let mut middles = Vec::new();
    poses_at_sorted(
        geom,
        q,
        (joint..n).map(|e| starts[e - joint] + 0.5 * geom.lengths[e]),
        &mut middles,
    );
    let element_moment_world = element_moment
        .iter()
        .zip(&middles)
        .map(|(m, pose)| r * (pose.frame * m))
        .collect();
    let root_reaction = (strand.ends.root != crate::model::ends::RootEnd::Free).then(|| {
        let (f, m) = (-force[0], -moment[0]);
        Vector6::new(f[0], f[1], f[2], m[0], m[1], m[2])
    });
    InternalLoads {
        arcs: starts.iter().map(|s| s - starts[0]).collect(),
        positions,
        force,
        moment,
        element_moment,
        element_moment_world,
        root_reaction,
        tip_reaction: state.tip_reaction,
        inertia: inertia.is_some(),
    }
}

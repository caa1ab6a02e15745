//! A strand's static description: geometry, material, natural shape, loads.

use crate::model::ends::{RootEnd, StrandEnds, ROOT_JOINT_FRACTION};
use crate::model::material::Material;
use nalgebra::{Matrix3, Vector3};

/// What a kernel needs to know of a strand's shape: the clamped root frame in head
/// coordinates, the element lengths and the mass per length.
#[derive(Debug, Clone, PartialEq)]
pub struct StrandGeometry {
    /// Root position r_0, head coordinates, metres.
    pub root_position: Vector3<f64>,
    /// Root frame F_0: columns (n0, n1, n2), n0 the tangent.
    pub root_frame: Matrix3<f64>,
    /// Element lengths l_Q (all > 0); N = `lengths.len()`.
    pub lengths: Vec<f64>,
    /// ρS, kg/m.
    pub mass_per_length: f64,
    /// Rotary inertia per unit length of the cross-section about the material axes
    /// (n0, n1, n2), kg·m. The paper's kinetic energy (5b) has only the centreline term,
    /// which leaves M singular whenever an element is straight (∂r/∂τ = 0 there: twist
    /// moves no mass). With the rotational kinetic energy of the cross-sections
    /// `½∫ Ωᵀ diag(ρI) Ω ds` of Kirchhoff's dynamic rods, M is positive definite at every
    /// q; its size relative to the centreline term is about r²/l², below 1e-6 for hair.
    /// Zeros give the paper's model exactly.
    pub rotary_inertia: [f64; 3],
    /// A floating (free) root: three more coordinates after the chain's 3N, the
    /// translation X of the root from `root_position` ([`crate::model::ends`]).
    pub floating: bool,
}

impl StrandGeometry {
    /// The shape the kernels' terms take (root, lengths, ρS, rotary inertia).
    pub fn shape(&self) -> superhelix_kernels::strand_terms::StrandShape<'_, f64> {
        superhelix_kernels::strand_terms::StrandShape {
            root_position: self.root_position,
            root_frame: self.root_frame,
            lengths: &self.lengths,
            mass_per_length: self.mass_per_length,
            rotary_inertia: self.rotary_inertia,
        }
    }

    /// A geometry with rotary inertia taken from `material`.
    pub fn new(
        root_position: Vector3<f64>,
        root_frame: Matrix3<f64>,
        lengths: Vec<f64>,
        material: &Material,
    ) -> Self {
        StrandGeometry {
            root_position,
            root_frame,
            lengths,
            mass_per_length: material.mass_per_length,
            rotary_inertia: material.rotary_inertia,
            floating: false,
        }
    }
    /// Number of elements N.
    pub fn elements(&self) -> usize {
        self.lengths.len()
    }
    /// Number of generalized coordinates: 3N, and 3 more for a floating root's
    /// translation.
    pub fn dofs(&self) -> usize {
        3 * self.lengths.len() + if self.floating { 3 } else { 0 }
    }
    /// Number of the chain's coordinates 3N (the curvatures and twists of the elements,
    /// first in q).
    pub fn chain_dofs(&self) -> usize {
        3 * self.lengths.len()
    }
    /// The root's pose at q: `root_position` moved by a floating root's translation
    /// (the last three coordinates), and the root frame.
    pub fn root_pose(&self, q: &[f64]) -> crate::model::reconstruction::Pose {
        let n = self.chain_dofs();
        let translation = if self.floating && q.len() >= n + 3 {
            Vector3::new(q[n], q[n + 1], q[n + 2])
        } else {
            Vector3::zeros()
        };
        crate::model::reconstruction::Pose {
            position: self.root_position + translation,
            frame: self.root_frame,
        }
    }
    /// Total length L.
    pub fn length(&self) -> f64 {
        self.lengths.iter().sum()
    }
    /// Element containing arc length `s` (clamped to [0, L]) and the local abscissa in it.
    pub fn locate(&self, s: f64) -> (usize, f64) {
        let mut start = 0.0;
        let n = self.lengths.len();
        for (q, &l) in self.lengths.iter().enumerate() {
            if s <= start + l || q + 1 == n {
                return (q, (s - start).clamp(0.0, l));
            }
            start += l;
        }
        (0, 0.0)
    }
}

/// Largest magnitude of a point load, newtons (the scene's and
/// `Simulation::set_point_loads`' bound).
pub const MAX_POINT_LOAD: f64 = 1e6;

/// A constant force applied at one point of a strand (`superhelix_kernels::point_load`:
/// the one step's terms and energy of it).
pub use superhelix_kernels::point_load::PointLoad;

/// Everything that defines one strand's mechanics.
#[derive(Debug, Clone, PartialEq)]
pub struct Strand {
    /// Name, used in outputs and error messages.
    pub name: String,
    /// Root frame, element lengths, mass per length.
    pub geometry: StrandGeometry,
    /// Mass per length and stiffnesses (GJ, EI1, EI2).
    pub material: Material,
    /// Natural twist and curvatures q_n (3N), in the order of `q`.
    pub natural: Vec<f64>,
    /// Internal friction γ, kg·m³/s.
    pub internal_friction: f64,
    /// Air drag ν, kg/(m·s).
    pub air_drag: f64,
    /// Point loads.
    pub point_loads: Vec<PointLoad>,
    /// How its ends are held (default: the hair's, clamped root and free tip). A pinned
    /// root's joint is the first element of `geometry` ([`Strand::pin_root`]).
    pub ends: StrandEnds,
}

impl Strand {
    /// Whether a point load follows the material frame ([`PointLoad::follows`]).
    pub fn has_follower_loads(&self) -> bool {
        self.point_loads.iter().any(|l| l.follows)
    }

    /// Diagonal of the stiffness matrix K = diag(l_Q · (GJ, EI1, EI2)) (eq. 5c).
    /// A pinned root's joint has none.
    pub fn stiffness_diagonal(&self) -> Vec<f64> {
        let joint = self.ends.joint_elements();
        let mut k = Vec::with_capacity(self.geometry.dofs());
        for (e, &l) in self.geometry.lengths.iter().enumerate() {
            for i in 0..3 {
                k.push(if e < joint {
                    0.0
                } else {
                    l * self.material.stiffness[i]
                });
            }
        }
        k.resize(self.geometry.dofs(), 0.0);
        k
    }

    /// The elastic energy ½ (q − q_n)ᵀ K (q − q_n) at `q` (eq. 5c's K), J: the elements'
    /// twist and bending, none for a pinned root's joint or a free root's translation.
    pub fn elastic_energy(&self, q: &[f64]) -> f64 {
        self.stiffness_diagonal()
            .iter()
            .zip(q)
            .zip(&self.natural)
            .map(|((k, q), n)| 0.5 * k * (q - n) * (q - n))
            .sum()
    }

    /// Diagonal of the internal friction matrix γ l_Q (none on a pinned or free root's
    /// joint, nor on a free root's translation).
    pub fn friction_diagonal(&self) -> Vec<f64> {
        let joint = self.ends.joint_elements();
        let chain = self.geometry.chain_dofs();
        (0..self.geometry.dofs())
            .map(|i| {
                if i / 3 < joint || i >= chain {
                    0.0
                } else {
                    self.geometry.lengths[i / 3] * self.internal_friction
                }
            })
            .collect()
    }

    /// Pin the root (a clamped root before): insert the root joint, an element of length
    /// [`ROOT_JOINT_FRACTION`]·L with zero natural curvature, in front of the strand's
    /// own, and the joint's three coordinates (zero: the root frame as given) in front of
    /// `q0`. See [`crate::model::ends`].
    pub fn pin_root(&mut self, q0: &mut Vec<f64>) {
        if self.ends.root != RootEnd::Clamped {
            return;
        }
        let joint = ROOT_JOINT_FRACTION * self.geometry.length();
        // a q0 with the joint's coordinates already (a run's whole q) keeps them
        if q0.len() == self.geometry.dofs() {
            q0.splice(0..0, [0.0; 3]);
        }
        self.geometry.lengths.insert(0, joint);
        self.natural.splice(0..0, [0.0; 3]);
        self.ends.root = RootEnd::Pinned;
    }

    /// Free the root (a clamped or pinned root before): pin it ([`Strand::pin_root`]),
    /// then add the root's translation X as three coordinates after the chain's, zero in
    /// `q0` (the root where `geometry.root_position` puts it). See
    /// [`crate::model::ends`].
    pub fn free_root(&mut self, q0: &mut Vec<f64>) {
        if self.ends.root == RootEnd::Free {
            return;
        }
        self.pin_root(q0);
        self.geometry.floating = true;
        self.natural.extend([0.0; 3]);
        // a q0 with the root's translation already (a run's whole q) keeps it
        if q0.len() < self.geometry.dofs() {
            q0.extend([0.0; 3]);
        }
        self.ends.root = RootEnd::Free;
    }

    /// Scale of the step's linear algebra per coordinate: 1/l₀ on a pinned root's joint
    /// (its coordinates are then the root frame's rotation θ = l₀ d₀), `None` without one.
    pub fn solver_scale(&self) -> Option<Vec<f64>> {
        let joint = self.ends.joint_elements();
        let chain = self.geometry.chain_dofs();
        (joint > 0).then(|| {
            (0..self.geometry.dofs())
                .map(|i| {
                    if i / 3 < joint && i < chain {
                        1.0 / self.geometry.lengths[i / 3]
                    } else {
                        1.0
                    }
                })
                .collect()
        })
    }
}

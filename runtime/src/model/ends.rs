//! The two ends of a rod: how the root is held (clamped, the hair's case, or pinned) and
//! whether the second end (the tip) is free or held (pinned, clamped or sliding, at a
//! fixed place or driven by a motion).
//!
//! - A **clamped root** is the paper's: the root frame F₀ is given (section 3.1).
//! - A **pinned root** holds the root's position and lets its frame turn: the strand gets
//!   a *root joint*, a first element of length [`ROOT_JOINT_FRACTION`]·L with no
//!   stiffness and no internal friction, whose Darboux vector d₀ is the rotation of the
//!   frame: the rest of the strand starts from `F₀ exp(l₀ [d₀]×)`, so `θ = l₀ d₀` is the
//!   rotation vector of the root frame from its initial orientation (eq. 2 of the paper
//!   with the element's length taken to a sliver). The root point then moves by at most
//!   2 l₀ = 2·10⁻¹⁰ L. The solver works on θ (its linear algebra is scaled by 1/l₀), so
//!   the tiny length costs no accuracy.
//! - A **free root** is a pinned root whose position is free too: the root's
//!   translation X from its initial place is three more coordinates, after the chain's
//!   3N, so that `y(s) = X + y_chain(s)` and `J = [J_chain | I₃]`. Its rows of the
//!   equation of motion are the rod's total momentum balance, `m Ẍ + Σ q̈ + b_X = ∫F ds`,
//!   with `Σ = ∫ρS J_chain ds` and `b_X = ∫ρS J̇ q̇ ds` (eq. 7 of the paper written for
//!   the coordinates (q, X); [`crate::kernels::floating`]).
//! - A **held tip** is a holonomic constraint on the chain's last pose, `y(L, q) = p(t)`
//!   (pinned), plus the frame `F_N(q) = F*(t)` (clamped), or only the two directions
//!   across an axis (sliding), or the frame and those two (clamped-sliding): its multipliers are solved with each implicit step and the
//!   static solve ([`crate::solver::held_end`]), and the drift left is projected out.

use nalgebra::Vector3;

/// Length of a pinned root's joint element, as a fraction of the strand's length.
pub const ROOT_JOINT_FRACTION: f64 = 1e-10;

/// How the root is held.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RootEnd {
    /// Position and frame given (the hair's root); default.
    #[default]
    Clamped,
    /// Position given, frame free: the root joint's three rotations are coordinates
    /// with no stiffness.
    Pinned,
    /// Nothing held (a floating rod): the root joint's three rotations, as for a pinned
    /// root, and the root's translation X are coordinates.
    Free,
}

impl RootEnd {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            RootEnd::Clamped => "clamped",
            RootEnd::Pinned => "pinned",
            RootEnd::Free => "free",
        }
    }
}

/// What a held tip holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeldKind {
    /// The tip's position (3 constraints); its frame turns freely.
    Pinned,
    /// The tip's position and frame (6 constraints).
    Clamped,
    /// The tip's position across an axis (2 constraints): the tip slides along the axis
    /// under the loads, and is driven across it by the motion.
    Sliding,
    /// The tip's frame and its position across an axis (5 constraints): a clamp on a
    /// slider, free only along the axis (Greenhill's twisted shaft, a beam whose end may
    /// draw in).
    ClampedSliding,
}

impl HeldKind {
    /// Name as written in scenes.
    pub fn name(self) -> &'static str {
        match self {
            HeldKind::Pinned => "pinned",
            HeldKind::Clamped => "clamped",
            HeldKind::Sliding => "sliding",
            HeldKind::ClampedSliding => "clamped-sliding",
        }
    }

    /// Whether the tip slides along an axis (its position is held across it only).
    pub fn slides(self) -> bool {
        matches!(self, HeldKind::Sliding | HeldKind::ClampedSliding)
    }

    /// Whether the tip's frame is held.
    pub fn holds_frame(self) -> bool {
        matches!(self, HeldKind::Clamped | HeldKind::ClampedSliding)
    }

    /// Number of position constraints (the first rows): 2 across the axis of a sliding
    /// tip, else 3.
    pub fn position_rows(self) -> usize {
        if self.slides() {
            2
        } else {
            3
        }
    }

    /// Number of scalar constraints: the position rows, then 3 for a held frame.
    pub fn rows(self) -> usize {
        self.position_rows() + if self.holds_frame() { 3 } else { 0 }
    }
}

/// How a strand's root is held (its tip: [`crate::config::HeldEnd`] in its setup).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StrandEnds {
    /// The root.
    pub root: RootEnd,
}

impl StrandEnds {
    /// Elements of the root joint in front of the strand's own (1 for a pinned root).
    pub fn joint_elements(&self) -> usize {
        match self.root {
            RootEnd::Clamped => 0,
            RootEnd::Pinned | RootEnd::Free => 1,
        }
    }
}

/// A unit vector perpendicular to the unit vector `v` (from the world axis least aligned
/// with it).
pub fn perpendicular(v: &Vector3<f64>) -> Vector3<f64> {
    let e = Vector3::ith(v.iamin(), 1.0);
    (e - v * v.dot(&e)).normalize()
}

/// The half angle x of a circular arc of length `length` whose chord is `span` (`0 < span
/// < length`): `sin x / x = span / length`, by bisection on (0, π). The start of a rope
/// between two holders closer than its length (`x` its tilt at the ends, `length / 2x`
/// its radius).
pub fn arc_half_angle(length: f64, span: f64) -> f64 {
    let (mut lo, mut hi) = (1e-9, std::f64::consts::PI);
    for _ in 0..200 {
        let x = 0.5 * (lo + hi);
        if x.sin() / x > span / length {
            lo = x;
        } else {
            hi = x;
        }
    }
    0.5 * (lo + hi)
}

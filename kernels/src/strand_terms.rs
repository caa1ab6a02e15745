//! The terms of one strand's equation of motion (paper eq. 4–6) from element moments:
//! the driver shared by the runtime's runtime-N moment kernel (buffers in `Vec`s) and
//! the fixed-N strands of `superhelix-generated` (buffers in arrays of literal size).
//!
//! [`evaluate_terms`] computes what [`Terms`] asks for at (q, q̇) in a [`BodyField`]: M(q)
//! and the gravity force in O(N²) ([`crate::moments::assemble_mass_gram_and_gravity`]),
//! the force ∫ JᵀF − b in O(N) ([`crate::moments::assemble_force`]), the field
//! stiffness, the damping and ∂b/∂q̇ in O(N²) ([`crate::moments::jacobians`]), and the
//! rotary inertia's parts ([`crate::moments::rotary`]). Allocates nothing.

use crate::body_field::BodyField;
use crate::element::{ElementPoint, RotaryPoints};
use crate::float::Float;
use crate::moments::jacobians::{
    add_field_hessian, add_velocity_jacobian, add_weighted_gram, VelocityRow,
};
use crate::moments::rotary::{add_rotary_terms, rotary_element, rotary_points, RotaryElement};
use crate::moments::{
    assemble_force, assemble_inertial_and_field_force, assemble_mass_gram_and_gravity,
    end_derivatives_from, frame_motions, frame_velocities, suffix_bodies, ElementMoments,
    EndDerivatives, FrameMotion, SuffixBody,
};
use crate::pose::{darboux, Pose};
use crate::storage::Square;
use crate::strand_point::strand_point_pose;
use nalgebra::{Matrix3, Vector3};

/// Where the moment assembly gets its per-element integrals, in the float type `T`
/// (`f64` unless named).
pub trait MomentSource<T: Float = f64> {
    /// Fill every field of `out` for Darboux vector `d`, length `l`, rotary inertia
    /// `rotary` (= diag D).
    fn moments(&self, d: &Vector3<T>, l: T, rotary: &[T; 3], out: &mut ElementMoments<T>);
    /// [`MomentSource::moments`] for elements `d[p]`, `l[p]` into `out[p]` (one element
    /// after the other unless a source does better).
    fn moments_batch(
        &self,
        d: &[Vector3<T>],
        l: &[T],
        rotary: &[T; 3],
        out: &mut [ElementMoments<T>],
    ) {
        for ((d, &l), out) in d.iter().zip(l).zip(out.iter_mut()) {
            self.moments(d, l, rotary, out);
        }
    }
    /// [`MomentSource::moments_batch`] for the fields of M only (those the mass
    /// assembly reads; the others may be left as they were), the same bits for those.
    /// Defaults to the full batch.
    fn mass_moments_batch(
        &self,
        d: &[Vector3<T>],
        l: &[T],
        rotary: &[T; 3],
        out: &mut [ElementMoments<T>],
    ) {
        self.moments_batch(d, l, rotary, out);
    }
    /// [`MomentSource::moments_batch`] for the fields that are not M's (the mass fields
    /// may be left as they were: the caller holds them for these elements, by
    /// [`MomentSource::mass_moments_batch`] or an earlier full batch), the same bits for
    /// those. Defaults to the full batch.
    fn force_moments_batch(
        &self,
        d: &[Vector3<T>],
        l: &[T],
        rotary: &[T; 3],
        out: &mut [ElementMoments<T>],
    ) {
        self.moments_batch(d, l, rotary, out);
    }
    /// E(u), p(u), w_i(u) and their d-derivatives (see [`ElementPoint`]).
    fn point(&self, d: &Vector3<T>, u: T, out: &mut ElementPoint<T>) {
        *out = ElementPoint::by_jets(d, u);
    }
    /// The fields of [`ElementPoint`] the rotary-inertia quadrature
    /// ([`rotary_element`]) reads: `frame`, `w` and `dw` (the generated source also fills
    /// `p` and `dp`, which are `w[0]` and `dw[0]`), the same values as
    /// [`MomentSource::point`]; `out.d2p` is unspecified afterwards (a source may leave
    /// it as it was). Defaults to [`MomentSource::point`].
    fn rotary_point(&self, d: &Vector3<T>, u: T, out: &mut ElementPoint<T>) {
        self.point(d, u, out);
    }
    /// [`MomentSource::rotary_point`] at the abscissae `u` (at most four; any beyond are
    /// ignored), lane k of `out` for `u[k]`; the lanes beyond `u.len()` are unspecified
    /// afterwards. Defaults to [`MomentSource::rotary_point`] point by point; a source
    /// may evaluate the four lanes together, but must give the same bits.
    fn rotary_points(&self, d: &Vector3<T>, u: &[T], out: &mut RotaryPoints<T>) {
        let mut point = ElementPoint::default();
        for (k, &u) in u.iter().take(4).enumerate() {
            self.rotary_point(d, u, &mut point);
            out.set_lane(k, &point);
        }
    }
    /// Short description (`closed form`, `quadrature moments`).
    fn describe(&self) -> &'static str;
    /// True for generated closed forms.
    fn is_generated(&self) -> bool;
}

/// The mechanics of one strand as its step asks for them: the terms of the equation of
/// motion (paper eq. 4–6) at (q, q̇), the energy measure of the balance, and the
/// centreline at the element ends. Every [`MomentSource`] is one, through the moment
/// assembly ([`evaluate_terms`], [`evaluate_energy`], [`element_ends`]: a reference
/// `&S` to the source is the `StepTerms`); a runtime's own kernels (a quadrature over the
/// strand, a free root's) are others, writing the same outputs.
pub trait StepTerms<T: Float = f64> {
    /// The terms `terms` at (q, q̇) in `field`, as [`evaluate_terms`] gives them: M
    /// (when asked) into `buffers.mass`, the vectors into `out`, the matrices through
    /// `sink` (n² column-major each).
    #[allow(clippy::too_many_arguments)]
    fn evaluate(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        v: &[T],
        field: &BodyField<T>,
        terms: Terms,
        out: &mut TermVectors<'_, T>,
        sink: &mut dyn FnMut(TermMatrix, &[T]),
    );
    /// The kinetic energy, ∫ρS y ds and the power of the linear field `linear` at
    /// (q, q̇), as [`evaluate_energy`] gives them (`prepare_terms`: a terms evaluation at
    /// this q follows).
    #[allow(clippy::too_many_arguments)]
    fn energy(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        v: &[T],
        linear: Option<&Matrix3<T>>,
        prepare_terms: bool,
    ) -> StrandEnergy<T>;
    /// The poses at the N + 1 element ends at q ([`element_ends`]).
    fn ends(&mut self, shape: &StrandShape<'_, T>, q: &[T], ends: &mut [Pose<T>]);
    /// The point y(s) at q, with J(s) = ∂y(s)/∂q into `scratch.jac` (3N columns) and,
    /// when `hessian` is (c, H), c · ∂²y(s)/∂q∂q added to H: what a point load acts
    /// through ([`crate::strand_point::strand_point`] for a moment source).
    fn point(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
        hessian: Option<(Vector3<T>, &mut Square<'_, T>)>,
    ) -> Vector3<T>;
    /// The material frame F(s) at q (columns n0 — the tangent —, n1, n2): the axes of
    /// a follower load. `scratch.jac` is unspecified afterwards.
    fn frame(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
    ) -> Matrix3<T>;
}

/// The scratch of a strand's points ([`StepTerms::point`]): J(s) and the chain of
/// element ends up to s.
pub struct PointScratch<'a, T: Float = f64> {
    /// J(s), 3N columns.
    pub jac: &'a mut [Vector3<T>],
    /// The poses at the element ends, N + 1.
    pub ends: &'a mut [Pose<T>],
    /// The element ends' derivatives, N.
    pub derivs: &'a mut [EndDerivatives<T>],
}

/// A strand's points as a hook of the step sees them ([`crate::fixed::EndHooks`]): the
/// point y(s) with its Jacobian and the poses at the element ends, from whatever gives
/// the step its terms. Object safe, so that a hook is not generic over the step's source.
pub trait StrandPoints<T: Float = f64> {
    /// The point y(s) at q, head coordinates; J(s) = ∂y(s)/∂q into `jac` (3N columns).
    fn point(&mut self, q: &[T], s: T, jac: &mut [Vector3<T>]) -> Vector3<T>;
    /// [`Self::point`], with `c · ∂²y(s)/∂q∂q` added to `hessian` (the curvature of the
    /// strand under a force c at s).
    fn point_curvature(
        &mut self,
        q: &[T],
        s: T,
        jac: &mut [Vector3<T>],
        c: Vector3<T>,
        hessian: &mut Square<'_, T>,
    ) -> Vector3<T>;
    /// The poses at the N + 1 element ends at q.
    fn ends(&mut self, q: &[T], ends: &mut [Pose<T>]);
}

/// The points of the strand whose terms `source` gives ([`StepTerms::point`],
/// [`StepTerms::ends`]), at `shape`, with the step's point scratch.
pub struct PointsOf<'s, 'a, 'b, S: ?Sized, T: Float = f64> {
    /// What gives the step its terms.
    pub source: &'s mut S,
    /// The strand's shape.
    pub shape: StrandShape<'a, T>,
    /// The step's point scratch.
    pub scratch: &'s mut PointScratch<'b, T>,
}

impl<S: StepTerms<T> + ?Sized, T: Float> PointsOf<'_, '_, '_, S, T> {
    /// [`StepTerms::point`], J(s) copied into `jac`.
    fn point_into(
        &mut self,
        q: &[T],
        s: T,
        jac: &mut [Vector3<T>],
        hessian: Option<(Vector3<T>, &mut Square<'_, T>)>,
    ) -> Vector3<T> {
        let y = self.source.point(&self.shape, q, s, self.scratch, hessian);
        let n = jac.len().min(self.scratch.jac.len());
        jac[..n].copy_from_slice(&self.scratch.jac[..n]);
        y
    }
}

impl<S: StepTerms<T> + ?Sized, T: Float> StrandPoints<T> for PointsOf<'_, '_, '_, S, T> {
    fn point(&mut self, q: &[T], s: T, jac: &mut [Vector3<T>]) -> Vector3<T> {
        self.point_into(q, s, jac, None)
    }

    fn point_curvature(
        &mut self,
        q: &[T],
        s: T,
        jac: &mut [Vector3<T>],
        c: Vector3<T>,
        hessian: &mut Square<'_, T>,
    ) -> Vector3<T> {
        self.point_into(q, s, jac, Some((c, hessian)))
    }

    fn ends(&mut self, q: &[T], ends: &mut [Pose<T>]) {
        self.source.ends(&self.shape, q, ends);
    }
}

/// [`StepTerms::point`] of a moment source.
fn source_point<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    q: &[T],
    s: T,
    scratch: &mut PointScratch<'_, T>,
    hessian: Option<(Vector3<T>, &mut Square<'_, T>)>,
) -> Pose<T> {
    let root = Pose {
        position: shape.root_position,
        frame: shape.root_frame,
    };
    let PointScratch { jac, ends, derivs } = scratch;
    let (c, mut h) = match hessian {
        Some((c, h)) => (Some(c), Some(h)),
        None => (None, None),
    };
    let mut add = |k: usize, l: usize, value: T| {
        if let Some(h) = h.as_deref_mut() {
            h[l][k] += value;
        }
    };
    strand_point_pose(
        source,
        &root,
        shape.lengths,
        ends,
        derivs,
        None,
        q,
        s,
        jac,
        c.map(|c| (c, &mut add)),
    )
}

impl<T: Float, S: MomentSource<T> + ?Sized> StepTerms<T> for &S {
    fn evaluate(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        v: &[T],
        field: &BodyField<T>,
        terms: Terms,
        out: &mut TermVectors<'_, T>,
        sink: &mut dyn FnMut(TermMatrix, &[T]),
    ) {
        evaluate_terms(*self, shape, buffers, q, v, field, terms, out, sink);
    }
    fn energy(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        v: &[T],
        linear: Option<&Matrix3<T>>,
        prepare_terms: bool,
    ) -> StrandEnergy<T> {
        evaluate_energy(*self, shape, buffers, q, v, linear, prepare_terms)
    }
    fn ends(&mut self, shape: &StrandShape<'_, T>, q: &[T], ends: &mut [Pose<T>]) {
        element_ends(*self, shape, q, ends);
    }
    fn point(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
        hessian: Option<(Vector3<T>, &mut Square<'_, T>)>,
    ) -> Vector3<T> {
        source_point(*self, shape, q, s, scratch, hessian).position
    }
    fn frame(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
    ) -> Matrix3<T> {
        source_point(*self, shape, q, s, scratch, None).frame
    }
}

/// Which outputs [`evaluate_terms`] must fill. What is not asked is not computed (and
/// its buffer is left untouched).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Terms {
    /// M(q) = ∫ ρS JᵀJ ds.
    pub mass: bool,
    /// `force` = ∫ Jᵀ F ds − b(q, q̇), and `velocity_term` = b.
    pub force: bool,
    /// `stiffness` = ∂/∂q of ∫ Jᵀ(c0 + C1 y) ds: the Hessian of the first moment
    /// contracted with the field, plus ∫ JᵀC1J.
    pub stiffness: bool,
    /// `damping` = ∫ Jᵀ C2 J ds = ∂(∫ JᵀF)/∂q̇.
    pub damping: bool,
    /// `velocity_term_jacobian` = ∂b/∂q̇ = 2 ∫ ρS Jᵀ J̇ ds.
    pub velocity_term_jacobian: bool,
    /// `force` = ∫ Jᵀ F ds alone, without b (what the power of a field needs: b, and the
    /// rotary inertia's part of it, are not computed), and ∫ρS y ds; `velocity_term` is
    /// unspecified afterwards. Ignored when `force` is asked.
    pub field_force: bool,
    /// Only the symmetric part of `stiffness` is needed (a step that keeps its
    /// symmetrised field stiffness): the antisymmetric part of C1 (a head's angular
    /// acceleration and the drag of its rotation) is left out of ∫JᵀC1J, whose weighted
    /// Gram matrix then takes one pass instead of two.
    pub symmetric_stiffness: bool,
    /// Assemble a damping C2 = c I + A (drag and a rotating head's Coriolis term, A
    /// antisymmetric) as c ∫ JᵀJ ds (kept with M) plus one antisymmetric pass for A:
    /// the same matrix to rounding, for half the passes (the fixed-N step asks it; the
    /// runtime engine keeps the general two-pass form).
    pub split_damping: bool,
}

impl Terms {
    /// Everything.
    pub fn all() -> Self {
        Terms {
            mass: true,
            force: true,
            stiffness: true,
            damping: true,
            velocity_term_jacobian: true,
            field_force: false,
            symmetric_stiffness: false,
            split_damping: false,
        }
    }
}

/// What the terms depend on besides q and q̇: the clamped root, the element lengths, the
/// mass per length and the rotary inertia of the cross-section.
#[derive(Debug, Clone, Copy)]
pub struct StrandShape<'a, T: Float = f64> {
    /// Root position r_0, head coordinates, metres.
    pub root_position: Vector3<T>,
    /// Root frame F_0 (columns n0, n1, n2; n0 the tangent).
    pub root_frame: Matrix3<T>,
    /// Element lengths l_Q; N = `lengths.len()`.
    pub lengths: &'a [T],
    /// ρS, kg/m.
    pub mass_per_length: T,
    /// ρ(I1 + I2), ρI1, ρI2, kg·m (zeros: the paper's kinetic energy without rotary
    /// inertia).
    pub rotary_inertia: [T; 3],
}

/// The buffers of one evaluation, sized for N elements (3N coordinates): `ends`,
/// `motions` and `bodies` N + 1 long, the 3N × 3N matrices column-major (9N² long),
/// `velocity_rows` 3N long, the others N long. The owner keeps them (a `Vec` each in the
/// runtime, arrays of literal size in a fixed-N strand).
pub struct MomentBuffers<'a, T: Float = f64> {
    /// Poses at the element ends.
    pub ends: &'a mut [Pose<T>],
    /// The Darboux vector of each element.
    pub darboux: &'a mut [Vector3<T>],
    /// End derivatives of each element.
    pub end_derivs: &'a mut [EndDerivatives<T>],
    /// Element moments.
    pub moments: &'a mut [ElementMoments<T>],
    /// Frame motions at the element ends.
    pub motions: &'a mut [FrameMotion<T>],
    /// Suffix bodies.
    pub bodies: &'a mut [SuffixBody<T>],
    /// Rotary-inertia integrals of each element.
    pub rotary: &'a mut [RotaryElement<T>],
    /// Scratch of the rotary terms.
    pub beyond: &'a mut [(Matrix3<T>, Matrix3<T>)],
    /// Scratch of ∂b/∂q̇.
    pub velocity_rows: &'a mut [VelocityRow<T>],
    /// M at the prepared q (column-major), valid when `*mass_valid`.
    pub mass: &'a mut [T],
    /// The centreline Gram matrix ∫ JᵀJ ds at the prepared q, with `mass`.
    pub gram: &'a mut [T],
    /// Whether `mass` and `gram` hold the prepared q's.
    pub mass_valid: &'a mut bool,
    /// Column-major 3N × 3N scratch (the stiffness, damping and ∂b/∂q̇ in turn).
    pub matrix: &'a mut [T],
    /// 3N scratch.
    pub vector: &'a mut [T],
    /// The q the ends, end derivatives and moments were prepared for (NaN before the
    /// first evaluation: equal to no q).
    pub prepared: &'a mut [T],
    /// The q the fields of M in `moments` (those [`MomentSource::mass_moments_batch`]
    /// fills) hold (NaN: none): equal to `prepared` after a full preparation, ahead of
    /// it after an energy measure ([`evaluate_energy`] without `prepare_terms`).
    pub mass_prepared: &'a mut [T],
}

/// Which matrix [`evaluate_terms`] hands to its sink.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TermMatrix {
    /// M(q).
    Mass,
    /// ∂(∫ Jᵀ (c0 + C1 y) ds)/∂q.
    Stiffness,
    /// ∫ Jᵀ C2 J ds.
    Damping,
    /// ∂b/∂q̇.
    VelocityTermJacobian,
}

/// The vector outputs of [`evaluate_terms`] (3N each), and ∫ρS y ds.
pub struct TermVectors<'a, T: Float = f64> {
    /// ∫ Jᵀ F ds − b(q, q̇).
    pub force: &'a mut [T],
    /// b(q, q̇) = ∫ ρS Jᵀ (J̇ q̇) ds.
    pub velocity_term: &'a mut [T],
    /// ∫ ρS y ds (with `mass` or `force`).
    pub first_moment: &'a mut Vector3<T>,
}

/// Element ends, end derivatives and moments for q, all from the source. They depend on
/// q only: kept when q is the one they were prepared for.
pub fn prepare<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    b: &mut MomentBuffers<'_, T>,
    q: &[T],
) {
    if *b.prepared == *q {
        return;
    }
    b.prepared.copy_from_slice(q);
    *b.mass_valid = false;
    ends_and_derivatives(source, shape, b, q, true);
    if *b.mass_prepared == *q {
        // M's moments at q are held (an energy measure of this state)
        source.force_moments_batch(b.darboux, shape.lengths, &shape.rotary_inertia, b.moments);
    } else {
        source.moments_batch(b.darboux, shape.lengths, &shape.rotary_inertia, b.moments);
        b.mass_prepared.copy_from_slice(q);
    }
}

/// The Darboux vectors, element ends and end derivatives of q, from the source's element
/// points; the second derivatives (`d2p`, `dw`) only when `second` (else left as they
/// were: what the velocities of the frames need is `dp` and `dtheta`).
fn ends_and_derivatives<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    b: &mut MomentBuffers<'_, T>,
    q: &[T],
    second: bool,
) {
    b.ends[0] = Pose {
        position: shape.root_position,
        frame: shape.root_frame,
    };
    let mut point = ElementPoint::default();
    for (p, &l) in shape.lengths.iter().enumerate() {
        let d = darboux(q, p);
        b.darboux[p] = d;
        source.point(&d, l, &mut point);
        let start = b.ends[p];
        b.ends[p + 1] = Pose {
            position: start.position + start.frame * point.p,
            frame: start.frame * point.frame,
        };
        if second {
            b.end_derivs[p] = end_derivatives_from(&start.frame, &point);
        } else {
            let e = &mut b.end_derivs[p];
            e.dp = point.dp.map(|v| start.frame * v);
            e.dtheta = point.w.map(|v| start.frame * v);
        }
    }
}

/// What an energy measurement reads at (q, q̇), from [`evaluate_energy`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrandEnergy<T: Float = f64> {
    /// The kinetic energy ½ q̇ᵀ M q̇ (centreline and rotary inertia).
    pub kinetic: T,
    /// ∫ ρS y ds.
    pub first_moment: Vector3<T>,
    /// The power ∫ ẏ · C1 y ds = q̇ · ∫ Jᵀ C1 y ds of the linear field C1 given (0 without).
    pub power: T,
}

/// The kinetic energy ½ q̇ᵀ M q̇, ∫ρS y ds and, with `linear = Some(C1)`, the power
/// ∫ ẏ · C1 y ds of a linear field (a rotating head's), in O(N) from the element moments
/// of M only ([`MomentSource::mass_moments_batch`]) and the frame motions, with no
/// matrix: what an energy measurement needs.
///
/// On element P, with ω = Fᵀ Ω_P and c = Fᵀ ṙ_P its start frame's angular velocity and
/// start point's velocity in its own frame and π(u) = Σ_j q̇_j ∂p/∂d_j, the centreline
/// moves as ẏ = F (c + ω × p + π) (docs/moment-assembly.md) and the cross-sections turn at
/// Ωs = ω + Σ_j q̇_j w_j, so
///
/// - ∫ |ẏ|² = |c|² l + 2 c · (ω × ∫p) + 2 c · Σ q̇_j ∫p_j + |ω|² tr ∫ppᵀ − ωᵀ(∫ppᵀ)ω
///   + 2 ω · Σ q̇_j ∫p × p_j + Σ q̇_i q̇_j ∫p_i · p_j,
/// - ∫ Ωsᵀ I Ωs = ωᵀ(∫I)ω + 2 ω · Σ q̇_j ∫I w_j + Σ q̇_i q̇_j ∫w_iᵀ I w_j,
/// - ∫ ẏ · C1 y = (∫ẏ) · C1 r_P + tr(FᵀC1F L), L = ∫p cᵀ − (∫ppᵀ)[ω]× + Σ q̇_j ∫p p_jᵀ,
///
/// T = ½ Σ_P (ρS ∫|ẏ|² + ∫ Ωsᵀ I Ωs), the paper's kinetic energy (eq. 4's M) with the
/// rotary inertia of docs/model.md.
///
/// With `prepare_terms` the buffers are [`prepare`]d for q (every element moment, for
/// the cost of the force-only ones too), so that an [`evaluate_terms`] at the same q that
/// follows (the next piece of a split step starts where this one was measured) reuses
/// them; without, only the moments of M are computed and the buffers are left prepared
/// for no q. The energy is the same, bit for bit.
pub fn evaluate_energy<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    b: &mut MomentBuffers<'_, T>,
    q: &[T],
    v: &[T],
    linear: Option<&Matrix3<T>>,
    prepare_terms: bool,
) -> StrandEnergy<T> {
    if prepare_terms {
        prepare(source, shape, b, q);
    } else {
        b.prepared[0] = T::nan();
        *b.mass_valid = false;
        ends_and_derivatives(source, shape, b, q, false);
        if *b.mass_prepared != *q {
            source.mass_moments_batch(b.darboux, shape.lengths, &shape.rotary_inertia, b.moments);
            b.mass_prepared.copy_from_slice(q);
        }
    }
    frame_velocities(b.ends, b.end_derivs, v, b.motions);
    let two = T::of(2.0);
    let (mut centreline, mut rotary, mut power) = (T::zero(), T::zero(), T::zero());
    let mut first = Vector3::zeros();
    for (p, &l) in shape.lengths.iter().enumerate() {
        let m = &b.moments[p];
        let pose = &b.ends[p];
        let f = pose.frame;
        let motion = &b.motions[p];
        let om = f.transpose() * motion.omega;
        let c = f.transpose() * motion.velocity;
        let qd = Vector3::new(v[3 * p], v[3 * p + 1], v[3 * p + 2]);
        let mut pi = Vector3::zeros();
        let mut turn = Vector3::zeros();
        let mut rot_w = Vector3::zeros();
        for j in 0..3 {
            pi += m.dfirst[j] * qd[j];
            turn += m.cross[j] * qd[j];
            rot_w += m.rot_w[j] * qd[j];
        }
        let swept = om.cross(&m.first);
        centreline += c.dot(&c) * l + two * c.dot(&(swept + pi)) + om.dot(&om) * m.second.trace()
            - om.dot(&(m.second * om))
            + two * om.dot(&turn)
            + qd.dot(&(m.gram * qd));
        rotary += om.dot(&(m.rot * om)) + two * om.dot(&rot_w) + qd.dot(&(m.rot_ww * qd));
        first += pose.position * l + f * m.first;
        if let Some(c1) = linear {
            let velocity = f * (c * l + swept + pi);
            let mut local = m.first * c.transpose() - m.second * om.cross_matrix();
            for j in 0..3 {
                local += m.pdp[j] * qd[j];
            }
            let a = f.transpose() * c1 * f;
            power += velocity.dot(&(c1 * pose.position)) + (a * local).trace();
        }
    }
    let rho_s = shape.mass_per_length;
    StrandEnergy {
        kinetic: T::of(0.5) * (rho_s * centreline + rotary),
        first_moment: first * rho_s,
        power,
    }
}

/// `m` is a multiple of the identity.
fn is_scalar<T: Float>(m: &Matrix3<T>) -> bool {
    *m == Matrix3::identity() * m[(0, 0)]
}

/// `m = c I + A` with A antisymmetric (exactly, as the body field builds its velocity
/// part): `(c, A)`.
fn isotropic_plus_antisymmetric<T: Float>(m: &Matrix3<T>) -> Option<(T, Matrix3<T>)> {
    let c = m[(0, 0)];
    if m[(1, 1)] != c || m[(2, 2)] != c {
        return None;
    }
    let mut rest = *m;
    for i in 0..3 {
        rest[(i, i)] = T::zero();
    }
    (rest == -rest.transpose()).then_some((c, rest))
}

/// ∫ρS y ds from the suffix bodies.
fn first_moment<T: Float>(b: &MomentBuffers<'_, T>, rho_s: T) -> Vector3<T> {
    (b.bodies[0].first + b.ends[0].position * b.bodies[0].mass) * rho_s
}

/// Evaluate the terms `terms` asks for at (q, q̇) in `field`: each requested matrix is
/// handed to `sink` (column-major, 3N × 3N) once assembled, the vectors written into
/// `out`. Allocates nothing.
#[allow(clippy::too_many_arguments)]
pub fn evaluate_terms<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    b: &mut MomentBuffers<'_, T>,
    q: &[T],
    v: &[T],
    field: &BodyField<T>,
    terms: Terms,
    out: &mut TermVectors<'_, T>,
    sink: &mut dyn FnMut(TermMatrix, &[T]),
) {
    let t = terms;
    prepare(source, shape, b, q);
    let rho_s = shape.mass_per_length;
    let has_rotary = shape.rotary_inertia != [T::zero(); 3];
    let lengths = shape.lengths;
    let needs_velocity = t.force || t.velocity_term_jacobian;
    // the field's force reads the frame motions for its C2 ẏ part
    let field_force = t.field_force && !t.force;
    if needs_velocity || field_force {
        frame_motions(b.ends, b.end_derivs, v, b.motions);
    }
    suffix_bodies(
        b.ends,
        lengths,
        b.moments,
        b.motions,
        v,
        t.velocity_term_jacobian,
        b.bodies,
    );
    if t.mass {
        if *b.mass_valid {
            *out.first_moment = first_moment(b, rho_s);
        } else {
            assemble_mass_gram_and_gravity(
                b.bodies,
                rho_s,
                lengths,
                b.ends,
                b.end_derivs,
                b.moments,
                &field.uniform,
                b.mass,
                Some(&mut *b.gram),
                b.vector,
                out.first_moment,
            );
            *b.mass_valid = true;
        }
        sink(TermMatrix::Mass, b.mass);
    }
    if has_rotary && needs_velocity {
        for p in 0..lengths.len() {
            let d = b.darboux[p];
            let l = lengths[p];
            b.rotary[p] = rotary_element(
                &|u: &[T], out: &mut RotaryPoints<T>| source.rotary_points(&d, u, out),
                l,
                &shape.rotary_inertia,
                &b.moments[p],
                &b.ends[p],
                &b.motions[p],
                &v[3 * p..3 * p + 3],
                rotary_points((d.norm() * l).as_f64()),
                t.velocity_term_jacobian,
            );
        }
    }
    if t.force || field_force {
        *out.first_moment = first_moment(b, rho_s);
    }
    if t.force {
        // −b of the centreline (ρS, no field) and the field with ρS = 0 (the assembly
        // is linear in the field and in ρS), in one pass
        assemble_inertial_and_field_force(
            rho_s,
            lengths,
            b.ends,
            b.end_derivs,
            b.moments,
            b.motions,
            v,
            field,
            out.velocity_term,
            out.force,
        );
        for x in out.velocity_term.iter_mut() {
            *x = -*x;
        }
        if has_rotary {
            add_rotary_terms(
                b.end_derivs,
                b.rotary,
                b.motions,
                v,
                Some(&mut *out.velocity_term),
                None,
                b.beyond,
            );
        }
        for (f, x) in out.force.iter_mut().zip(out.velocity_term.iter()) {
            *f -= *x;
        }
    } else if field_force {
        assemble_force(
            T::zero(),
            lengths,
            b.ends,
            b.end_derivs,
            b.moments,
            b.motions,
            v,
            field,
            out.force,
        );
    }
    if t.stiffness {
        b.matrix.fill(T::zero());
        add_field_hessian(
            &field.uniform,
            &field.linear,
            b.ends,
            b.end_derivs,
            b.moments,
            b.bodies,
            b.matrix,
        );
        if field.has_linear() {
            let c1 = if t.symmetric_stiffness {
                (field.linear + field.linear.transpose()) * T::of(0.5)
            } else {
                field.linear
            };
            add_weighted_gram(
                &c1,
                T::one(),
                b.ends,
                b.end_derivs,
                b.moments,
                b.bodies,
                b.matrix,
            );
        }
        sink(TermMatrix::Stiffness, b.matrix);
    }
    if t.damping {
        // C2 = c I + A (drag −ν I, A the Coriolis −2ρS[ω]×, antisymmetric): c ∫ JᵀJ ds
        // from the Gram matrix kept with M, the rest ∫ JᵀAJ ds by its weighted Gram
        // matrix (one pass for an antisymmetric A); an exactly scalar C2 always takes
        // the Gram matrix, c I + A when asked, any other C2 the two-pass form
        let split = if !*b.mass_valid {
            None
        } else if is_scalar(&field.velocity) {
            Some((field.velocity[(0, 0)], Matrix3::zeros()))
        } else if t.split_damping {
            isotropic_plus_antisymmetric(&field.velocity)
        } else {
            None
        };
        let rest = match split {
            Some((c, rest)) => {
                for (m, g) in b.matrix.iter_mut().zip(b.gram.iter()) {
                    *m = c * *g;
                }
                rest
            }
            None => {
                b.matrix.fill(T::zero());
                field.velocity
            }
        };
        if rest != Matrix3::zeros() {
            add_weighted_gram(
                &rest,
                T::one(),
                b.ends,
                b.end_derivs,
                b.moments,
                b.bodies,
                b.matrix,
            );
        }
        sink(TermMatrix::Damping, b.matrix);
    }
    if t.velocity_term_jacobian {
        b.matrix.fill(T::zero());
        add_velocity_jacobian(
            T::of(2.0) * rho_s,
            b.ends,
            b.end_derivs,
            b.moments,
            b.motions,
            b.bodies,
            v,
            b.velocity_rows,
            b.matrix,
        );
        if has_rotary {
            add_rotary_terms(
                b.end_derivs,
                b.rotary,
                b.motions,
                v,
                None,
                Some(&mut *b.matrix),
                b.beyond,
            );
        }
        sink(TermMatrix::VelocityTermJacobian, b.matrix);
    }
}

/// The poses at the N + 1 element ends for q, from the source's element points.
pub fn element_ends<T: Float, S: MomentSource<T> + ?Sized>(
    source: &S,
    shape: &StrandShape<'_, T>,
    q: &[T],
    ends: &mut [Pose<T>],
) {
    ends[0] = Pose {
        position: shape.root_position,
        frame: shape.root_frame,
    };
    let mut point = ElementPoint::default();
    for (p, &l) in shape.lengths.iter().enumerate() {
        source.point(&darboux(q, p), l, &mut point);
        let start = ends[p];
        ends[p + 1] = Pose {
            position: start.position + start.frame * point.p,
            frame: start.frame * point.frame,
        };
    }
}

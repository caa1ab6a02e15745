//! A strand kernel assembled from element moments (docs/moment-assembly.md): M and the
//! gravity force in O(N²) ([`crate::kernels::moments::assemble_mass_and_gravity`]), the full force
//! (field and −b) in O(N) ([`crate::kernels::moments::assemble_force`]), the damping, field stiffness
//! and ∂b/∂q̇ in O(N²) ([`crate::kernels::moments::jacobians`]), rotary inertia from
//! [`crate::kernels::moments::rotary`].
//!
//! The element moments come from a [`MomentSource`]: the generated closed forms
//! (`superhelix-generated`) or, as a reference, [`QuadratureMoments`]. Buffers are sized
//! once at construction; `evaluate` allocates nothing.

use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms};
use crate::kernels::moments::jacobians::{
    add_field_hessian, add_velocity_jacobian, add_weighted_gram, VelocityRow,
};
use crate::kernels::moments::rotary::{
    add_rotary_terms, rotary_element, rotary_points, RotaryElement,
};
use crate::kernels::moments::{
    assemble_force, assemble_mass_gram_and_gravity, end_derivatives_from, frame_motions,
    suffix_bodies, ElementMoments, EndDerivatives, FrameMotion, SuffixBody, Wrench,
};
use crate::model::element::{ElementPoint, RotaryPoints};
use crate::model::reconstruction::{darboux, Pose};
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};

/// Where a moment kernel gets its per-element integrals.
pub trait MomentSource: Send {
    /// Fill every field of `out` for Darboux vector `d`, length `l`, rotary inertia
    /// `rotary` (= diag D).
    fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments);
    /// [`MomentSource::moments`] for elements `d[p]`, `l[p]` into `out[p]` (one element
    /// after the other unless a source does better).
    fn moments_batch(
        &self,
        d: &[Vector3<f64>],
        l: &[f64],
        rotary: &[f64; 3],
        out: &mut [ElementMoments],
    ) {
        for ((d, &l), out) in d.iter().zip(l).zip(out.iter_mut()) {
            self.moments(d, l, rotary, out);
        }
    }
    /// E(u), p(u), w_i(u) and their d-derivatives (see [`ElementPoint`]).
    fn point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        *out = ElementPoint::by_jets(d, u);
    }
    /// The fields of [`ElementPoint`] the rotary-inertia quadrature
    /// ([`rotary_element`]) reads: `frame`, `w` and `dw` (the generated source also fills
    /// `p` and `dp`, which are `w[0]` and `dw[0]`), the same values as
    /// [`MomentSource::point`]; `out.d2p` is unspecified afterwards (a source may leave
    /// it as it was). Defaults to [`MomentSource::point`].
    fn rotary_point(&self, d: &Vector3<f64>, u: f64, out: &mut ElementPoint) {
        self.point(d, u, out);
    }
    /// [`MomentSource::rotary_point`] at the abscissae `u` (at most four; any beyond are
    /// ignored), lane k of `out` for `u[k]`; the lanes beyond `u.len()` are unspecified
    /// afterwards. Defaults to [`MomentSource::rotary_point`] point by point; a source
    /// may evaluate the four lanes together, but must give the same bits.
    fn rotary_points(&self, d: &Vector3<f64>, u: &[f64], out: &mut RotaryPoints) {
        let mut point = ElementPoint::default();
        for (k, &u) in u.iter().take(4).enumerate() {
            self.rotary_point(d, u, &mut point);
            out.set_lane(k, &point);
        }
    }
    /// Short description (`closed form`, `quadrature`).
    fn describe(&self) -> String;
    /// True for generated closed forms.
    fn is_generated(&self) -> bool;
}

/// Element moments by Gauss–Legendre quadrature with `16 + 2⌈W·l⌉` points (or a fixed
/// number): the reference the closed forms are checked against.
#[derive(Debug, Clone, Copy, Default)]
pub struct QuadratureMoments {
    /// Fixed number of points, or `None` for `16 + 2⌈W·l⌉`.
    pub points: Option<usize>,
}

impl MomentSource for QuadratureMoments {
    fn moments(&self, d: &Vector3<f64>, l: f64, rotary: &[f64; 3], out: &mut ElementMoments) {
        let n = self
            .points
            .unwrap_or(16 + 2 * (d.norm() * l).ceil().min(400.0) as usize);
        *out = ElementMoments::by_quadrature(d, l, rotary, n);
    }
    fn describe(&self) -> String {
        "quadrature moments".to_string()
    }
    fn is_generated(&self) -> bool {
        false
    }
}

/// A kernel assembled from element moments.
pub struct MomentKernel<S: MomentSource> {
    geom: StrandGeometry,
    source: S,
    ends: Vec<Pose>,
    darboux: Vec<Vector3<f64>>,
    end_derivs: Vec<EndDerivatives>,
    moments: Vec<ElementMoments>,
    motions: Vec<FrameMotion>,
    bodies: Vec<SuffixBody>,
    wrenches: Vec<Wrench>,
    rotary: Vec<RotaryElement>,
    beyond: Vec<(Matrix3<f64>, Matrix3<f64>)>,
    velocity_rows: Vec<VelocityRow>,
    /// Column-major 3N × 3N scratch.
    matrix: Vec<f64>,
    /// M at the prepared q (column-major), once assembled: the integrator asks for M
    /// twice at the same q (a step's end energy, then the next step).
    mass: Vec<f64>,
    /// The centreline Gram matrix ∫ JᵀJ ds at the prepared q, with `mass`: an isotropic
    /// drag's damping is −ν times it.
    gram: Vec<f64>,
    mass_valid: bool,
    vector: Vec<f64>,
    /// The q the element ends, end derivatives and moments were prepared for (NaN before
    /// the first evaluation: equal to no q).
    prepared: Vec<f64>,
}

impl<S: MomentSource> MomentKernel<S> {
    /// A kernel for this geometry with moments from `source`.
    pub fn new(geom: StrandGeometry, source: S) -> Self {
        let n = geom.elements();
        MomentKernel {
            source,
            ends: vec![Pose::default(); n + 1],
            darboux: vec![Vector3::zeros(); n],
            end_derivs: vec![EndDerivatives::default(); n],
            moments: vec![ElementMoments::default(); n],
            motions: vec![FrameMotion::default(); n + 1],
            bodies: vec![SuffixBody::default(); n + 1],
            wrenches: vec![Wrench::default(); n],
            rotary: vec![RotaryElement::default(); n],
            beyond: vec![(Matrix3::zeros(), Matrix3::zeros()); n],
            velocity_rows: vec![VelocityRow::default(); 3 * n],
            matrix: vec![0.0; 9 * n * n],
            mass: vec![0.0; 9 * n * n],
            gram: vec![0.0; 9 * n * n],
            mass_valid: false,
            vector: vec![0.0; 3 * n],
            prepared: vec![f64::NAN; 3 * n],
            geom,
        }
    }

    /// Element ends, end derivatives and moments for q, all from the source (the
    /// reconstruction of the generated kernels is the generated element point). They
    /// depend on q only: kept when q is the one they were prepared for (the integrator
    /// evaluates at the same q twice in a row: the energy of a step's end, then the next
    /// step's terms).
    fn prepare(&mut self, q: &[f64]) {
        if self.prepared == q {
            return;
        }
        self.prepared.copy_from_slice(q);
        self.mass_valid = false;
        self.ends[0] = Pose {
            position: self.geom.root_position,
            frame: self.geom.root_frame,
        };
        let rotary = self.geom.rotary_inertia;
        let mut point = ElementPoint::default();
        for (p, &l) in self.geom.lengths.iter().enumerate() {
            let d = darboux(q, p);
            self.darboux[p] = d;
            self.source.point(&d, l, &mut point);
            let start = self.ends[p];
            self.ends[p + 1] = Pose {
                position: start.position + start.frame * point.p,
                frame: start.frame * point.frame,
            };
            self.end_derivs[p] = end_derivatives_from(&start.frame, &point);
        }
        self.source.moments_batch(
            &self.darboux,
            &self.geom.lengths,
            &rotary,
            &mut self.moments,
        );
    }

    /// Copy the column-major scratch into `mat` (overwrite).
    fn store(&self, mat: &mut Mat<f64>) {
        store(&self.matrix, mat);
    }

    /// ∫ρS y ds from the suffix bodies.
    fn first_moment(&self, rho_s: f64) -> Vector3<f64> {
        (self.bodies[0].first + self.ends[0].position * self.bodies[0].mass) * rho_s
    }
}

/// `m` is a multiple of the identity.
fn is_scalar(m: &Matrix3<f64>) -> bool {
    *m == Matrix3::identity() * m[(0, 0)]
}

/// Copy a column-major n × n `src` into `mat` (overwrite).
fn store(src: &[f64], mat: &mut Mat<f64>) {
    let n = mat.nrows();
    for c in 0..n {
        mat.col_as_slice_mut(c)
            .copy_from_slice(&src[c * n..(c + 1) * n]);
    }
}

impl<S: MomentSource> StrandKernel for MomentKernel<S> {
    fn geometry(&self) -> &StrandGeometry {
        &self.geom
    }

    fn description(&self) -> String {
        format!(
            "moment assembly ({}), N={}",
            self.source.describe(),
            self.geom.elements()
        )
    }

    fn is_generated(&self) -> bool {
        self.source.is_generated()
    }

    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        let t = input.terms;
        let (q, v, field) = (input.q, input.v, &input.field);
        self.prepare(q);
        let rho_s = self.geom.mass_per_length;
        let has_rotary = self.geom.rotary_inertia != [0.0; 3];
        let lengths = &self.geom.lengths;
        let needs_velocity = t.force || t.velocity_term_jacobian;
        if needs_velocity {
            frame_motions(&self.ends, &self.end_derivs, v, &mut self.motions);
        }
        suffix_bodies(
            &self.ends,
            lengths,
            &self.moments,
            &self.motions,
            v,
            t.velocity_term_jacobian,
            &mut self.bodies,
        );
        if t.mass {
            if self.mass_valid {
                out.first_moment = self.first_moment(rho_s);
            } else {
                assemble_mass_gram_and_gravity(
                    &self.bodies,
                    rho_s,
                    lengths,
                    &self.ends,
                    &self.end_derivs,
                    &self.moments,
                    &field.uniform,
                    &mut self.mass,
                    Some(&mut self.gram),
                    &mut self.vector,
                    &mut out.first_moment,
                );
                self.mass_valid = true;
            }
            store(&self.mass, &mut out.mass);
        }
        if has_rotary && needs_velocity {
            for p in 0..lengths.len() {
                let d = self.darboux[p];
                let l = lengths[p];
                let source = &self.source;
                self.rotary[p] = rotary_element(
                    &|u: &[f64], out: &mut RotaryPoints| source.rotary_points(&d, u, out),
                    l,
                    &self.geom.rotary_inertia,
                    &self.moments[p],
                    &self.ends[p],
                    &self.motions[p],
                    &v[3 * p..3 * p + 3],
                    rotary_points(d.norm() * l),
                    t.velocity_term_jacobian,
                );
            }
        }
        if t.force {
            out.first_moment = self.first_moment(rho_s);
            // −b of the centreline, then the field with ρS = 0 (the assembly is linear
            // in the field and in ρS)
            assemble_force(
                &mut self.wrenches,
                rho_s,
                lengths,
                &self.ends,
                &self.end_derivs,
                &self.moments,
                &self.motions,
                v,
                &crate::kernels::kernel::BodyField::zero(),
                &mut out.velocity_term,
            );
            for b in out.velocity_term.iter_mut() {
                *b = -*b;
            }
            if has_rotary {
                add_rotary_terms(
                    &self.end_derivs,
                    &self.rotary,
                    &self.motions,
                    v,
                    Some(&mut out.velocity_term),
                    None,
                    &mut self.beyond,
                );
            }
            assemble_force(
                &mut self.wrenches,
                0.0,
                lengths,
                &self.ends,
                &self.end_derivs,
                &self.moments,
                &self.motions,
                v,
                field,
                &mut out.force,
            );
            for (f, b) in out.force.iter_mut().zip(&out.velocity_term) {
                *f -= b;
            }
        }
        if t.stiffness {
            self.matrix.fill(0.0);
            add_field_hessian(
                &field.uniform,
                &field.linear,
                &self.ends,
                &self.end_derivs,
                &self.moments,
                &self.bodies,
                &mut self.matrix,
            );
            if field.has_linear() {
                add_weighted_gram(
                    &field.linear,
                    1.0,
                    &self.ends,
                    &self.end_derivs,
                    &self.moments,
                    &self.bodies,
                    &mut self.matrix,
                );
            }
            self.store(&mut out.stiffness);
        }
        if t.damping && self.mass_valid && is_scalar(&field.velocity) {
            // C2 = −ν I: −ν ∫ JᵀJ ds, kept with M
            let c = field.velocity[(0, 0)];
            for (m, g) in self.matrix.iter_mut().zip(&self.gram) {
                *m = c * g;
            }
            self.store(&mut out.damping);
        } else if t.damping {
            self.matrix.fill(0.0);
            add_weighted_gram(
                &field.velocity,
                1.0,
                &self.ends,
                &self.end_derivs,
                &self.moments,
                &self.bodies,
                &mut self.matrix,
            );
            self.store(&mut out.damping);
        }
        if t.velocity_term_jacobian {
            self.matrix.fill(0.0);
            add_velocity_jacobian(
                2.0 * rho_s,
                &self.ends,
                &self.end_derivs,
                &self.moments,
                &self.motions,
                &self.bodies,
                v,
                &mut self.velocity_rows,
                &mut self.matrix,
            );
            if has_rotary {
                add_rotary_terms(
                    &self.end_derivs,
                    &self.rotary,
                    &self.motions,
                    v,
                    None,
                    Some(&mut self.matrix),
                    &mut self.beyond,
                );
            }
            self.store(&mut out.velocity_term_jacobian);
        }
    }

    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        ends[0] = Pose {
            position: self.geom.root_position,
            frame: self.geom.root_frame,
        };
        let mut point = ElementPoint::default();
        for (p, &l) in self.geom.lengths.iter().enumerate() {
            self.source.point(&darboux(q, p), l, &mut point);
            let start = ends[p];
            ends[p + 1] = Pose {
                position: start.position + start.frame * point.p,
                frame: start.frame * point.frame,
            };
        }
    }

    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
    ) -> Vector3<f64> {
        let (e, u) = self.geom.locate(s);
        // ends and end derivatives of the elements up to e
        self.ends[0] = Pose {
            position: self.geom.root_position,
            frame: self.geom.root_frame,
        };
        let mut pt = ElementPoint::default();
        for p in 0..e {
            let d = darboux(q, p);
            self.source.point(&d, self.geom.lengths[p], &mut pt);
            let start = self.ends[p];
            self.ends[p + 1] = Pose {
                position: start.position + start.frame * pt.p,
                frame: start.frame * pt.frame,
            };
            self.end_derivs[p] = end_derivatives_from(&start.frame, &pt);
        }
        self.source.point(&darboux(q, e), u, &mut pt);
        let f = self.ends[e].frame;
        let y = self.ends[e].position + f * pt.p;
        for col in jac.iter_mut() {
            *col = Vector3::zeros();
        }
        for qe in 0..e {
            let ed = &self.end_derivs[qe];
            let rho = y - self.ends[qe + 1].position;
            for i in 0..3 {
                jac[3 * qe + i] = ed.dp[i] + ed.dtheta[i].cross(&rho);
            }
        }
        for i in 0..3 {
            jac[3 * e + i] = f * pt.dp[i];
        }
        if let Some((c, h)) = hessian {
            // k upstream of l (different elements): c·(dθ_k × J_l)
            for l in 3..3 * (e + 1) {
                for k in 0..3 * (l / 3) {
                    let val = c.cross(&self.end_derivs[k / 3].dtheta[k % 3]).dot(&jac[l]);
                    h[(k, l)] += val;
                    h[(l, k)] += val;
                }
            }
            // pairs within an element upstream of e
            for qe in 0..e {
                let ed = &self.end_derivs[qe];
                let rho = y - self.ends[qe + 1].position;
                for i in 0..3 {
                    for j in 0..3 {
                        let d2 = ed.d2p[i][j]
                            + ed.dw[i][j].cross(&rho)
                            + ed.dtheta[i].cross(&ed.dtheta[j].cross(&rho));
                        h[(3 * qe + i, 3 * qe + j)] += c.dot(&d2);
                    }
                }
            }
            // pairs within element e
            let cf = f.transpose() * c;
            for i in 0..3 {
                for j in 0..3 {
                    h[(3 * e + i, 3 * e + j)] += cf.dot(&pt.d2p[i][j]);
                }
            }
        }
        y
    }
}

//! A free root's terms: any [`StepTerms`] of a chain of N elements (3N coordinates q_c),
//! wrapped to add the root's translation X as three coordinates after them
//! ([`crate::storage::ParamsView::free_root`]: 3N + 3 coordinates).
//!
//! With `y(s) = X + y_c(s, q_c)` the Jacobian is `J = [J_c | I₃]`, and the terms of the
//! equation of motion (paper eq. 4–7, written for the coordinates (q_c, X)) are the
//! chain's plus what the three new columns bring:
//!
//! - mass: `M = [[M_c, Σᵀ], [Σ, m I₃]]` with `Σ = ∫ρS J_c ds` (3 × 3N) and `m = ρS L`
//!   (the cross-sections' rotary inertia does not see a translation);
//! - velocity term: `b = [b_c; b_X]`, `b_X,k = q̇_cᵀ H_k q̇_c` with `H_k = ∫ρS ∂²y_k/∂q_c² ds`;
//! - force: the chain's force with the field taken at `X + y_c` (its uniform part
//!   `c0 + C1 X + C2 Ẋ`), and `∫F ds − b_X` on X, `∫F ds = L c0' + C1 ∫y_c ds + C2 Σ q̇_c / ρS`;
//! - the Jacobians of the force (stiffness, damping, ∂b/∂q̇) with their X rows and
//!   columns: `C Σ / ρS` in the rows, `Cᵀ Σ / ρS` transposed in the columns, `L C` in the
//!   corner, for C = C1 (stiffness) or C2 (damping); ∂b_X/∂q̇_c = 2 H_k q̇_c.
//!
//! `Σ` and `H_k` are the chain's own field force and field stiffness for the uniform
//! fields `ρS e_k` (`∫J_cᵀ c0 ds` and the Hessian of the first moment contracted with
//! c0): three more evaluations of the chain, with its closed forms or quadrature, so that
//! the translation's terms are as exact as the chain's. Written once for every engine: the
//! runtime's free-root kernel evaluates through it, and so does a fixed-N strand.

use crate::body_field::BodyField;
use crate::float::Float;
use crate::pose::Pose;
use crate::storage::Square;
use crate::strand_terms::{
    MomentBuffers, PointScratch, StepTerms, StrandEnergy, StrandShape, TermMatrix, TermVectors,
    Terms,
};
use nalgebra::{Matrix3, Vector3};

/// The scratch of [`Floating`] for a chain of n = 3N coordinates, on the caller's
/// slices ([`FloatingScratch::lengths`] gives their lengths).
pub struct FloatingScratch<'a, T: Float = f64> {
    /// Σ, row k at `[k n, (k + 1) n)`: ∫ρS (J_c)_k ds.
    pub sigma: &'a mut [T],
    /// H_k, n × n column-major each, one after the other.
    pub hessians: &'a mut [T],
    /// n zeros (the unit fields' evaluations carry no velocity).
    pub zero: &'a mut [T],
    /// n values of scratch.
    pub vector: &'a mut [T],
    /// (n + 3)² values: a matrix with its X rows and columns.
    pub bordered: &'a mut [T],
}

impl<'a, T: Float> FloatingScratch<'a, T> {
    /// The lengths of (`sigma`, `hessians`, `zero`, `vector`, `bordered`) for a chain of
    /// `n` coordinates.
    pub const fn lengths(n: usize) -> [usize; 5] {
        [3 * n, 3 * n * n, n, n, (n + 3) * (n + 3)]
    }

    /// The total of [`Self::lengths`].
    pub const fn len(n: usize) -> usize {
        let l = Self::lengths(n);
        l[0] + l[1] + l[2] + l[3] + l[4]
    }

    /// The scratch on one slice of at least [`Self::len`] values (`None`: shorter).
    pub fn on(data: &'a mut [T], n: usize) -> Option<Self> {
        let [a, b, c, d, e] = Self::lengths(n);
        let data = data.get_mut(..a + b + c + d + e)?;
        let (sigma, rest) = data.split_at_mut(a);
        let (hessians, rest) = rest.split_at_mut(b);
        let (zero, rest) = rest.split_at_mut(c);
        let (vector, bordered) = rest.split_at_mut(d);
        zero.fill(T::zero());
        Some(FloatingScratch {
            sigma,
            hessians,
            zero,
            vector,
            bordered,
        })
    }
}

/// A free-root strand's terms: the chain's terms `chain` (3N coordinates) with the
/// translation's (3N + 3).
pub struct Floating<'a, S, T: Float = f64> {
    /// The chain's terms.
    pub chain: S,
    /// The scratch.
    pub scratch: FloatingScratch<'a, T>,
}

fn translation<T: Float>(q: &[T], n: usize) -> Vector3<T> {
    Vector3::new(q[n], q[n + 1], q[n + 2])
}

/// ρS L of `shape`.
fn mass<T: Float>(shape: &StrandShape<'_, T>) -> (T, T) {
    let length: T = shape.lengths.iter().copied().sum();
    (length, shape.mass_per_length * length)
}

impl<S: StepTerms<T>, T: Float> Floating<'_, S, T> {
    /// Σ (and the H_k with `hessians`) at the chain's q: three evaluations of the chain
    /// in the uniform fields ρS e_k.
    fn unit_fields(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        hessians: bool,
    ) {
        let n = q.len();
        let sc = &mut self.scratch;
        for k in 0..3 {
            let mut uniform = Vector3::zeros();
            uniform[k] = shape.mass_per_length;
            let field = BodyField {
                uniform,
                ..BodyField::zero()
            };
            let mut first = Vector3::zeros();
            let hessian = &mut sc.hessians[k * n * n..(k + 1) * n * n];
            self.chain.evaluate(
                shape,
                &mut chain_buffers(buffers, shape.lengths.len()),
                q,
                sc.zero,
                &field,
                Terms {
                    field_force: true,
                    stiffness: hessians,
                    ..Terms::default()
                },
                &mut TermVectors {
                    force: &mut sc.sigma[k * n..(k + 1) * n],
                    velocity_term: sc.vector,
                    first_moment: &mut first,
                },
                &mut |which, m| {
                    if which == TermMatrix::Stiffness {
                        hessian.copy_from_slice(&m[..n * n]);
                    }
                },
            );
        }
    }
}

impl<S: StepTerms<T>, T: Float> Floating<'_, S, T> {
    /// The strand's linear momentum `P = M_X(q) q̇ = Σ q̇_c + ρS L Ẋ` at (q, q̇), M_X the
    /// mass matrix's X rows (the rows [`StepTerms::evaluate`] gives M: Σ from the chain
    /// in the uniform fields ρS e_k, then ρS L I), summed in the order of those rows.
    pub fn momentum(
        &mut self,
        shape: &StrandShape<'_, T>,
        buffers: &mut MomentBuffers<'_, T>,
        q: &[T],
        v: &[T],
    ) -> Vector3<T> {
        let n = q.len() - 3;
        self.unit_fields(shape, buffers, &q[..n], false);
        let (_, m) = mass(shape);
        let sigma = &*self.scratch.sigma;
        Vector3::from_fn(|k, _| {
            let chain = (0..n)
                .map(|j| sigma[k * n + j] * v[j])
                .fold(T::zero(), |a, b| a + b);
            chain + m * v[n + k]
        })
    }
}

/// The first values of `s`, at most `len`.
fn cut<X>(s: &mut [X], len: usize) -> &mut [X] {
    let len = len.min(s.len());
    &mut s[..len]
}

/// `b` as the chain's evaluation takes it: each buffer cut to a chain of `elements`
/// elements (the caller's may be sized for the strand's 3N + 3 coordinates, N + 1
/// elements).
fn chain_buffers<'b, T: Float>(
    b: &'b mut MomentBuffers<'_, T>,
    elements: usize,
) -> MomentBuffers<'b, T> {
    let (m, n) = (elements, 3 * elements);
    MomentBuffers {
        ends: cut(b.ends, m + 1),
        darboux: cut(b.darboux, m),
        end_derivs: cut(b.end_derivs, m),
        moments: cut(b.moments, m),
        motions: cut(b.motions, m + 1),
        bodies: cut(b.bodies, m + 1),
        rotary: cut(b.rotary, m),
        beyond: cut(b.beyond, m),
        velocity_rows: cut(b.velocity_rows, n),
        mass: cut(b.mass, n * n),
        gram: cut(b.gram, n * n),
        mass_valid: b.mass_valid,
        matrix: cut(b.matrix, n * n),
        vector: cut(b.vector, n),
        prepared: cut(b.prepared, n),
        mass_prepared: cut(b.mass_prepared, n),
    }
}

/// `(H_k q̇)_j`.
fn hv<T: Float>(hessians: &[T], n: usize, k: usize, j: usize, v: &[T]) -> T {
    // H_k is symmetric: its column j is its row j
    let col = &hessians[k * n * n + j * n..k * n * n + (j + 1) * n];
    col.iter().zip(v).map(|(&h, &x)| h * x).sum()
}

/// `chain` (n × n, column-major) with the X rows and columns of `∫JᵀC J ds` into `out`
/// ((n + 3)², column-major).
fn border<T: Float>(out: &mut [T], chain: &[T], sigma: &[T], c: &Matrix3<T>, rho: T, length: T) {
    let m = chain.len().isqrt();
    let n3 = m + 3;
    for j in 0..m {
        out[j * n3..j * n3 + m].copy_from_slice(&chain[j * m..(j + 1) * m]);
        let s = Vector3::new(sigma[j], sigma[m + j], sigma[2 * m + j]) / rho;
        let row = c * s; // ∂(∫F ds)/∂q_j: C Σ / ρS
        let col = c.transpose() * s; // ∫J_cᵀ C ds: (Σᵀ C / ρS)_j
        for k in 0..3 {
            out[j * n3 + m + k] = row[k];
            out[(m + k) * n3 + j] = col[k];
        }
    }
    for l in 0..3 {
        for k in 0..3 {
            out[(m + l) * n3 + m + k] = length * c[(k, l)];
        }
    }
}

impl<S: StepTerms<T>, T: Float> StepTerms<T> for Floating<'_, S, T> {
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
        let n = q.len() - 3;
        let (qc, vc) = (&q[..n], &v[..n]);
        let (x, xdot) = (translation(q, n), translation(v, n));
        let rho = shape.mass_per_length;
        let (length, m) = mass(shape);
        // the field at X + y_c with velocity Ẋ + J_c q̇_c
        let shifted = BodyField {
            uniform: field.uniform + field.linear * x + field.velocity * xdot,
            ..*field
        };
        let any_force = terms.force || terms.field_force;
        let need_sigma = terms.mass || any_force || terms.stiffness || terms.damping;
        let need_hessian = terms.force || terms.velocity_term_jacobian;
        if need_sigma || need_hessian {
            self.unit_fields(shape, buffers, qc, need_hessian);
        }
        let mut first = Vector3::zeros();
        {
            let sc = &mut self.scratch;
            let (sigma, hessians, bordered) = (&*sc.sigma, &*sc.hessians, &mut *sc.bordered);
            let n3 = n + 3;
            let mut border_sink = |which: TermMatrix, chain: &[T]| {
                let chain = &chain[..n * n];
                match which {
                    TermMatrix::Stiffness => {
                        border(bordered, chain, sigma, &field.linear, rho, length)
                    }
                    TermMatrix::Damping => {
                        border(bordered, chain, sigma, &field.velocity, rho, length)
                    }
                    TermMatrix::VelocityTermJacobian => {
                        for j in 0..n {
                            bordered[j * n3..j * n3 + n]
                                .copy_from_slice(&chain[j * n..(j + 1) * n]);
                            for k in 0..3 {
                                bordered[j * n3 + n + k] = T::of(2.0) * hv(hessians, n, k, j, vc);
                                bordered[(n + k) * n3 + j] = T::zero();
                            }
                        }
                        for l in 0..3 {
                            for k in 0..3 {
                                bordered[(n + l) * n3 + n + k] = T::zero();
                            }
                        }
                    }
                    TermMatrix::Mass => return,
                }
                sink(which, &bordered[..n3 * n3]);
            };
            self.chain.evaluate(
                shape,
                &mut chain_buffers(buffers, shape.lengths.len()),
                qc,
                vc,
                &shifted,
                terms,
                &mut TermVectors {
                    force: &mut out.force[..n],
                    velocity_term: &mut out.velocity_term[..n],
                    first_moment: &mut first,
                },
                &mut border_sink,
            );
        }
        let sigma = &*self.scratch.sigma;
        if terms.mass {
            // M_c from stride n to stride n + 3 (in place, from the back), then Σ and m I
            let n3 = n + 3;
            let mass = &mut buffers.mass[..n3 * n3];
            for j in (0..n).rev() {
                for i in (0..n).rev() {
                    mass[j * n3 + i] = mass[j * n + i];
                }
            }
            for j in 0..n {
                for k in 0..3 {
                    let s = sigma[k * n + j];
                    mass[j * n3 + n + k] = s;
                    mass[(n + k) * n3 + j] = s;
                }
            }
            for l in 0..3 {
                for k in 0..3 {
                    mass[(n + l) * n3 + n + k] = if k == l { m } else { T::zero() };
                }
            }
            // (M's cache holds the chain's M in the chain's layout, which this is not)
            *buffers.mass_valid = false;
        }
        if terms.mass || any_force {
            *out.first_moment = first + x * m;
        }
        if any_force {
            let sigma_v = Vector3::from_fn(|k, _| {
                (0..n)
                    .map(|j| sigma[k * n + j] * vc[j])
                    .fold(T::zero(), |a, b| a + b)
            });
            let total = shifted.uniform * length
                + field.linear * (first / rho)
                + field.velocity * (sigma_v / rho);
            let hessians = &*self.scratch.hessians;
            for k in 0..3 {
                let b = if terms.force {
                    (0..n)
                        .map(|j| vc[j] * hv(hessians, n, k, j, vc))
                        .fold(T::zero(), |a, b| a + b)
                } else {
                    T::zero()
                };
                out.velocity_term[n + k] = b;
                out.force[n + k] = total[k] - b;
            }
        }
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
        let n = q.len() - 3;
        let (qc, vc) = (&q[..n], &v[..n]);
        let (x, xdot) = (translation(q, n), translation(v, n));
        let rho = shape.mass_per_length;
        let (length, m) = mass(shape);
        let chain = self.chain.energy(
            shape,
            &mut chain_buffers(buffers, shape.lengths.len()),
            qc,
            vc,
            linear,
            prepare_terms,
        );
        self.unit_fields(shape, buffers, qc, false);
        let sigma = &*self.scratch.sigma;
        let sigma_v = Vector3::from_fn(|k, _| {
            (0..n)
                .map(|j| sigma[k * n + j] * vc[j])
                .fold(T::zero(), |a, b| a + b)
        });
        // ½ [q̇_cᵀ M_c q̇_c + 2 Ẋ · Σ q̇_c + m |Ẋ|²]
        let kinetic = chain.kinetic + xdot.dot(&sigma_v) + T::of(0.5) * m * xdot.norm_squared();
        // ∫ (Ẋ + J_c q̇_c) · C1 (X + y_c) ds
        let power = match linear {
            Some(c1) => {
                let cx = c1 * x;
                chain.power
                    + (sigma_v / rho).dot(&cx)
                    + xdot.dot(&(cx * length + c1 * (chain.first_moment / rho)))
            }
            None => T::zero(),
        };
        StrandEnergy {
            kinetic,
            first_moment: chain.first_moment + x * m,
            power,
        }
    }

    fn ends(&mut self, shape: &StrandShape<'_, T>, q: &[T], ends: &mut [Pose<T>]) {
        let n = q.len() - 3;
        let x = translation(q, n);
        let count = shape.lengths.len() + 1;
        self.chain.ends(shape, &q[..n], &mut ends[..count]);
        for e in ends[..count].iter_mut() {
            e.position += x;
        }
    }

    fn point(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
        hessian: Option<(Vector3<T>, &mut Square<'_, T>)>,
    ) -> Vector3<T> {
        let n = q.len() - 3;
        let x = translation(q, n);
        let y = {
            let mut chain_scratch = PointScratch {
                jac: &mut scratch.jac[..n],
                ends: &mut *scratch.ends,
                derivs: &mut *scratch.derivs,
            };
            match hessian {
                Some((c, h)) => {
                    // the chain's c · ∂²y/∂q_c² (X enters y linearly: no more)
                    let mut chain_h = match Square::new(&mut self.scratch.bordered[..], n) {
                        Some(m) => m,
                        None => return Vector3::zeros(),
                    };
                    chain_h.fill(T::zero());
                    let y = self.chain.point(
                        shape,
                        &q[..n],
                        s,
                        &mut chain_scratch,
                        Some((c, &mut chain_h)),
                    );
                    let n3 = h.n();
                    let (src, dst) = (chain_h.as_slice(), h.as_mut_slice());
                    for j in 0..n {
                        for i in 0..n {
                            dst[j * n3 + i] += src[j * n + i];
                        }
                    }
                    y
                }
                None => self
                    .chain
                    .point(shape, &q[..n], s, &mut chain_scratch, None),
            }
        };
        for (k, col) in scratch.jac[n..n + 3].iter_mut().enumerate() {
            let mut e = Vector3::zeros();
            e[k] = T::one();
            *col = e;
        }
        y + x
    }

    fn frame(
        &mut self,
        shape: &StrandShape<'_, T>,
        q: &[T],
        s: T,
        scratch: &mut PointScratch<'_, T>,
    ) -> Matrix3<T> {
        let n = q.len() - 3;
        let mut chain_scratch = PointScratch {
            jac: &mut scratch.jac[..n],
            ends: &mut *scratch.ends,
            derivs: &mut *scratch.derivs,
        };
        self.chain.frame(shape, &q[..n], s, &mut chain_scratch)
    }
}

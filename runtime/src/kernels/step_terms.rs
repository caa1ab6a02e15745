//! A runtime kernel as the terms of the one step (`superhelix_kernels::strand_terms::StepTerms`):
//! any [`StrandKernel`] (the generic quadrature kernel, the moment kernels, a free root's)
//! gives the step of `superhelix-kernels` its terms, copied from the kernel's
//! [`StrandTerms`] into the step's buffers (n² per matrix asked: what an evaluation
//! costs beyond the kernel's own work is these copies).

use super::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use crate::model::reconstruction::{pose_at, Pose};
use faer::Mat;
use nalgebra::{Matrix3, Vector3};
use superhelix_kernels::storage::Square;
use superhelix_kernels::strand_terms::{
    MomentBuffers, PointScratch, StepTerms, StrandEnergy, StrandPoints, StrandShape, TermMatrix,
    TermVectors,
};

/// A kernel with the buffers it writes to: the step's terms.
pub struct KernelTerms<'a> {
    kernel: &'a mut dyn StrandKernel,
    terms: &'a mut StrandTerms,
    flat: &'a mut Vec<f64>,
}

impl<'a> KernelTerms<'a> {
    /// `kernel`'s terms, evaluated into `terms` (sized for the kernel's strand) and
    /// handed to the step through `flat` (resized to n² when it is not).
    pub fn new(
        kernel: &'a mut dyn StrandKernel,
        terms: &'a mut StrandTerms,
        flat: &'a mut Vec<f64>,
    ) -> Self {
        KernelTerms {
            kernel,
            terms,
            flat,
        }
    }
}

/// `m` (n × n) into `out`, column by column.
fn copy_columns(m: &Mat<f64>, out: &mut [f64]) {
    let n = m.nrows();
    for (j, col) in out.chunks_exact_mut(n).enumerate().take(m.ncols()) {
        col.copy_from_slice(&m.col_as_slice(j)[..n]);
    }
}

impl StepTerms<f64> for KernelTerms<'_> {
    fn evaluate(
        &mut self,
        _shape: &StrandShape<'_, f64>,
        buffers: &mut MomentBuffers<'_, f64>,
        q: &[f64],
        v: &[f64],
        field: &BodyField,
        terms: Terms,
        out: &mut TermVectors<'_, f64>,
        sink: &mut dyn FnMut(TermMatrix, &[f64]),
    ) {
        let n = q.len();
        self.kernel.evaluate(
            &EvalInput {
                q,
                v,
                field: *field,
                terms,
            },
            self.terms,
        );
        let t = &*self.terms;
        if terms.mass {
            copy_columns(&t.mass, &mut buffers.mass[..n * n]);
            // (the moment assembly's cache of M does not hold this kernel's)
            *buffers.mass_valid = false;
        }
        if terms.force || terms.field_force {
            out.force.copy_from_slice(&t.force);
            out.velocity_term.copy_from_slice(&t.velocity_term);
        }
        if terms.mass || terms.force || terms.field_force {
            *out.first_moment = t.first_moment;
        }
        self.flat.resize(n * n, 0.0);
        for (asked, which, m) in [
            (terms.stiffness, TermMatrix::Stiffness, &t.stiffness),
            (terms.damping, TermMatrix::Damping, &t.damping),
            (
                terms.velocity_term_jacobian,
                TermMatrix::VelocityTermJacobian,
                &t.velocity_term_jacobian,
            ),
        ] {
            if asked {
                copy_columns(m, self.flat);
                sink(which, self.flat);
            }
        }
    }

    fn energy(
        &mut self,
        _shape: &StrandShape<'_, f64>,
        _buffers: &mut MomentBuffers<'_, f64>,
        q: &[f64],
        v: &[f64],
        linear: Option<&Matrix3<f64>>,
        _prepare_terms: bool,
    ) -> StrandEnergy<f64> {
        // M and ∫ρS y ds; the field's force alone (no b) only for the power of C1 (a
        // rotating head): the runtime's energy measure
        let field = BodyField {
            uniform: Vector3::zeros(),
            linear: linear.copied().unwrap_or_else(Matrix3::zeros),
            velocity: Matrix3::zeros(),
        };
        self.kernel.evaluate(
            &EvalInput {
                q,
                v,
                field,
                terms: Terms {
                    mass: true,
                    field_force: linear.is_some(),
                    ..Default::default()
                },
            },
            self.terms,
        );
        let t = &*self.terms;
        let n = q.len();
        let mut kinetic = 0.0;
        for j in 0..n {
            let mut mv = 0.0;
            for i in 0..n {
                mv += t.mass[(i, j)] * v[i];
            }
            kinetic += 0.5 * mv * v[j];
        }
        let power = if linear.is_some() {
            (0..n).map(|i| v[i] * t.force[i]).sum()
        } else {
            0.0
        };
        StrandEnergy {
            kinetic,
            first_moment: t.first_moment,
            power,
        }
    }

    fn ends(&mut self, _shape: &StrandShape<'_, f64>, q: &[f64], ends: &mut [Pose]) {
        self.kernel.element_ends(q, ends);
    }

    fn point(
        &mut self,
        _shape: &StrandShape<'_, f64>,
        q: &[f64],
        s: f64,
        scratch: &mut PointScratch<'_, f64>,
        hessian: Option<(Vector3<f64>, &mut Square<'_, f64>)>,
    ) -> Vector3<f64> {
        match hessian {
            None => self.kernel.point(q, s, scratch.jac, None),
            Some((c, h)) => {
                // c · ∂²y/∂q² into the kernel's stiffness (free once the step has its
                // copy), then added to the step's
                let n = q.len();
                let m = &mut self.terms.stiffness;
                m.fill(0.0);
                let y = self.kernel.point(q, s, scratch.jac, Some((c, m)));
                for j in 0..n {
                    let col = &m.col_as_slice(j)[..n];
                    for (hij, mij) in h[j].iter_mut().zip(col) {
                        *hij += mij;
                    }
                }
                y
            }
        }
    }

    fn frame(
        &mut self,
        _shape: &StrandShape<'_, f64>,
        q: &[f64],
        s: f64,
        _scratch: &mut PointScratch<'_, f64>,
    ) -> Matrix3<f64> {
        pose_at(self.kernel.geometry(), q, s).frame
    }
}

/// A kernel's points as a hook of the step sees them (a held tip's rows outside the one
/// step: the static solve, the start's reaction, the pair solve).
pub struct KernelPoints<'a>(pub &'a mut dyn StrandKernel);

impl StrandPoints<f64> for KernelPoints<'_> {
    fn point(&mut self, q: &[f64], s: f64, jac: &mut [Vector3<f64>]) -> Vector3<f64> {
        self.0.point(q, s, jac, None)
    }

    /// (Allocates an n × n matrix for the kernel's curvature: outside the step only.)
    fn point_curvature(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        c: Vector3<f64>,
        hessian: &mut Square<'_, f64>,
    ) -> Vector3<f64> {
        let n = q.len();
        let mut m = Mat::<f64>::zeros(n, n);
        let y = self.0.point(q, s, jac, Some((c, &mut m)));
        for j in 0..n {
            for (hij, mij) in hessian[j].iter_mut().zip(&m.col_as_slice(j)[..n]) {
                *hij += mij;
            }
        }
        y
    }

    fn ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        self.0.element_ends(q, ends);
    }
}

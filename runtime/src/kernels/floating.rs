//! The kernel of a rod with a free root ([`crate::model::ends`]): any kernel of its
//! chain, wrapped to add the root's translation X as three coordinates after the
//! chain's 3N. The translation's terms (paper eq. 4–7 written for (q, X): M's Σ rows and
//! m I corner, b_X, ∫F ds on X, the Jacobians' X rows and columns) are the kernels'
//! [`superhelix_kernels::floating::Floating`], written once for every engine, over the
//! chain kernel's terms ([`KernelTerms`]); this kernel hands them to the runtime's
//! consumers of [`StrandKernel`] (RK4, the statics, the one step through
//! [`KernelTerms`]).

use super::kernel::{EvalInput, StrandKernel, StrandTerms};
use super::moments::kernel::store;
use super::step_terms::KernelTerms;
use crate::model::reconstruction::Pose;
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::Vector3;
use superhelix_kernels::floating::{Floating, FloatingScratch};
use superhelix_kernels::storage::Square;
use superhelix_kernels::strand_terms::{
    MomentBuffers, PointScratch, StepTerms, TermMatrix, TermVectors,
};

/// A free-root rod's kernel: the chain's kernel and the translation's terms.
pub struct FloatingKernel {
    /// The rod's geometry (`floating`: 3N + 3 coordinates).
    geometry: StrandGeometry,
    /// The chain's kernel (3N coordinates).
    chain: Box<dyn StrandKernel>,
    /// The chain's terms (3N), as [`KernelTerms`] evaluates them.
    terms: StrandTerms,
    /// [`KernelTerms`]' matrix buffer.
    flat: Vec<f64>,
    /// The scratch of [`Floating`] ([`FloatingScratch::len`] of 3N).
    scratch: Vec<f64>,
    /// M, (3N + 3)², column-major.
    mass: Vec<f64>,
}

impl FloatingKernel {
    /// Wrap `chain`, the kernel of the chain of `geometry` (whose `floating` is set).
    pub fn new(geometry: StrandGeometry, chain: Box<dyn StrandKernel>) -> Self {
        let n = geometry.chain_dofs();
        FloatingKernel {
            geometry,
            chain,
            terms: StrandTerms::new(n),
            flat: vec![0.0; n * n],
            scratch: vec![0.0; FloatingScratch::<f64>::len(n)],
            mass: vec![0.0; (n + 3) * (n + 3)],
        }
    }

    /// The chain's geometry of a floating `geometry` (its `floating` cleared).
    pub fn chain_geometry(geometry: &StrandGeometry) -> StrandGeometry {
        StrandGeometry {
            floating: false,
            ..geometry.clone()
        }
    }
}

/// The kernels' free-root terms over the chain kernel of `k`, with the geometry and M's
/// buffer (`None`: the scratch does not fit, which [`FloatingKernel::new`] rules out).
type Parts<'a> = (
    Floating<'a, KernelTerms<'a>>,
    &'a StrandGeometry,
    &'a mut Vec<f64>,
);

impl FloatingKernel {
    fn parts(&mut self) -> Option<Parts<'_>> {
        let n = self.geometry.chain_dofs();
        let FloatingKernel {
            geometry,
            chain,
            terms,
            flat,
            scratch,
            mass,
        } = self;
        let scratch = FloatingScratch::on(scratch, n)?;
        Some((
            Floating {
                chain: KernelTerms::new(chain.as_mut(), terms, flat),
                scratch,
            },
            geometry,
            mass,
        ))
    }
}

impl StrandKernel for FloatingKernel {
    fn geometry(&self) -> &StrandGeometry {
        &self.geometry
    }

    fn description(&self) -> String {
        format!("{}, free root", self.chain.description())
    }

    fn is_generated(&self) -> bool {
        self.chain.is_generated()
    }

    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        let Some((mut floating, geometry, mass)) = self.parts() else {
            return;
        };
        // (the chain kernel keeps its own moments: the buffers carry only M)
        let mut mass_valid = false;
        let mut buffers = MomentBuffers {
            ends: &mut [],
            darboux: &mut [],
            end_derivs: &mut [],
            moments: &mut [],
            motions: &mut [],
            bodies: &mut [],
            rotary: &mut [],
            beyond: &mut [],
            velocity_rows: &mut [],
            mass,
            gram: &mut [],
            mass_valid: &mut mass_valid,
            matrix: &mut [],
            vector: &mut [],
            prepared: &mut [],
            mass_prepared: &mut [],
        };
        let StrandTerms {
            mass: out_mass,
            force,
            velocity_term,
            stiffness,
            damping,
            velocity_term_jacobian,
            first_moment,
        } = out;
        floating.evaluate(
            &geometry.shape(),
            &mut buffers,
            input.q,
            input.v,
            &input.field,
            input.terms,
            &mut TermVectors {
                force,
                velocity_term,
                first_moment,
            },
            &mut |which, m| match which {
                TermMatrix::Stiffness => store(m, stiffness),
                TermMatrix::Damping => store(m, damping),
                TermMatrix::VelocityTermJacobian => store(m, velocity_term_jacobian),
                TermMatrix::Mass => store(m, out_mass),
            },
        );
        if input.terms.mass {
            store(buffers.mass, out_mass);
        }
    }

    fn point(
        &mut self,
        q: &[f64],
        s: f64,
        jac: &mut [Vector3<f64>],
        hessian: Option<(Vector3<f64>, &mut Mat<f64>)>,
    ) -> Vector3<f64> {
        let n = self.geometry.chain_dofs();
        let Some((mut floating, geometry, mass)) = self.parts() else {
            return Vector3::zeros();
        };
        let mut points = PointScratch {
            jac,
            ends: &mut [],
            derivs: &mut [],
        };
        match hessian {
            None => floating.point(&geometry.shape(), q, s, &mut points, None),
            Some((c, h)) => {
                // c · ∂²y/∂q² into M's buffer (free between evaluations), added to `h`
                let n3 = n + 3;
                mass.fill(0.0);
                let Some(mut square) = Square::new(mass, n3) else {
                    return Vector3::zeros();
                };
                let y =
                    floating.point(&geometry.shape(), q, s, &mut points, Some((c, &mut square)));
                for j in 0..n3 {
                    for i in 0..n3 {
                        h[(i, j)] += mass[j * n3 + i];
                    }
                }
                y
            }
        }
    }

    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        if let Some((mut floating, geometry, _)) = self.parts() {
            floating.ends(&geometry.shape(), q, ends);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::generic::{GenericKernel, QuadratureRule};
    use crate::kernels::kernel::{BodyField, Terms};
    use crate::kernels::moments::kernel::MomentKernel;
    use crate::model::material::Material;
    use nalgebra::Rotation3;

    fn geometry() -> StrandGeometry {
        let mut g = StrandGeometry::new(
            Vector3::new(0.01, -0.02, 0.03),
            *Rotation3::from_euler_angles(0.3, -0.2, 0.7).matrix(),
            vec![0.03, 0.05, 0.02],
            &Material {
                mass_per_length: 2e-3,
                stiffness: [1e-4, 1e-4, 1e-4],
                rotary_inertia: [0.0; 3],
            },
        );
        g.floating = true;
        g
    }

    fn kernels(g: &StrandGeometry) -> Vec<FloatingKernel> {
        let chain = FloatingKernel::chain_geometry(g);
        vec![
            FloatingKernel::new(
                g.clone(),
                Box::new(GenericKernel::new(chain.clone(), QuadratureRule::Adaptive)),
            ),
            FloatingKernel::new(
                g.clone(),
                Box::new(MomentKernel::new(chain, superhelix_generated::ClosedForm)),
            ),
        ]
    }

    /// ∫ρS y ds by a fine midpoint rule on the reconstruction.
    fn first_moment(g: &StrandGeometry, q: &[f64]) -> Vector3<f64> {
        let samples = 20000;
        let ds = g.length() / samples as f64;
        let mut out = Vec::new();
        crate::model::reconstruction::positions_at_sorted(
            g,
            q,
            (0..samples).map(|k| (k as f64 + 0.5) * ds),
            &mut out,
        );
        out.iter().sum::<Vector3<f64>>() * (g.mass_per_length * ds)
    }

    #[test]
    fn the_translations_rows_are_the_derivatives_of_the_first_moment() {
        let g = geometry();
        let n = g.dofs();
        let q: Vec<f64> = (0..n).map(|i| 15.0 * ((i as f64) * 1.3).sin()).collect();
        let v: Vec<f64> = (0..n).map(|i| 4.0 * ((i as f64) * 0.7).cos()).collect();
        let mut out = StrandTerms::new(n);
        for mut k in kernels(&g) {
            k.evaluate(
                &EvalInput {
                    q: &q,
                    v: &v,
                    field: BodyField::zero(),
                    terms: Terms::all(),
                },
                &mut out,
            );
            // the mass's X rows: ∂(∫ρS y ds)/∂q, by central differences
            let eps = 1e-6;
            let mut worst = 0.0f64;
            for j in 0..n {
                let mut qp = q.clone();
                let mut qm = q.clone();
                qp[j] += eps;
                qm[j] -= eps;
                let d = (first_moment(&g, &qp) - first_moment(&g, &qm)) / (2.0 * eps);
                for k in 0..3 {
                    worst = worst.max((out.mass[(n - 3 + k, j)] - d[k]).abs());
                    assert_eq!(out.mass[(n - 3 + k, j)], out.mass[(j, n - 3 + k)]);
                }
            }
            let m = g.mass_per_length * g.length();
            assert!(
                worst < 1e-6 * m,
                "{}: mass rows off by {worst:e}",
                k.description()
            );
            // b_X = d²/dt² of the first moment at q̈ = 0 (h large enough for the second
            // difference to stand above rounding; its truncation error is ~1e-7)
            let h = 1e-2;
            let at = |t: f64| {
                let qt: Vec<f64> = q.iter().zip(&v).map(|(a, b)| a + t * b).collect();
                first_moment(&g, &qt)
            };
            let b = (at(h) + at(-h) - 2.0 * at(0.0)) / (h * h);
            for k in 0..3 {
                let got = out.velocity_term[n - 3 + k];
                assert!(
                    (got - b[k]).abs() < 1e-4 * b.norm(),
                    "{}: b_X[{k}] = {got} against {}",
                    k,
                    b[k]
                );
                assert!((out.force[n - 3 + k] + got).abs() < 1e-15 * b.norm().max(1.0));
            }
        }
    }

    #[test]
    fn the_translations_stiffness_and_damping_are_the_derivatives_of_the_force() {
        // a field with every part (c0, C1 with an antisymmetric part, C2): at q̇ = 0 the
        // force is ∫Jᵀ(c0 + C1 y) ds, whose derivative in q is the stiffness and in q̇
        // the damping (b is quadratic in q̇); the X rows and columns by central
        // differences, the chain's block as the chain kernel gives it
        let g = geometry();
        let n = g.dofs();
        let q: Vec<f64> = (0..n).map(|i| 15.0 * ((i as f64) * 1.3).sin()).collect();
        let zero = vec![0.0; n];
        let field = BodyField {
            uniform: Vector3::new(0.3, -1.1, 0.7),
            linear: nalgebra::Matrix3::new(0.4, -0.9, 0.2, 0.5, -0.3, 0.8, -0.6, 0.1, 0.2),
            velocity: nalgebra::Matrix3::new(-0.2, 0.7, 0.0, -0.7, -0.2, 0.3, 0.0, -0.3, -0.2),
        };
        for mut k in kernels(&g) {
            let mut out = StrandTerms::new(n);
            k.evaluate(
                &EvalInput {
                    q: &q,
                    v: &zero,
                    field,
                    terms: Terms::all(),
                },
                &mut out,
            );
            let mut force_at = |q: &[f64], v: &[f64]| {
                let mut t = StrandTerms::new(n);
                k.evaluate(
                    &EvalInput {
                        q,
                        v,
                        field,
                        terms: Terms {
                            force: true,
                            ..Terms::default()
                        },
                    },
                    &mut t,
                );
                t.force
            };
            let eps = 1e-6;
            let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
            for j in 0..n {
                for (v_side, matrix) in [(false, &out.stiffness), (true, &out.damping)] {
                    let (mut qp, mut qm) = (q.clone(), q.clone());
                    let (mut vp, mut vm) = (zero.clone(), zero.clone());
                    if v_side {
                        vp[j] += eps;
                        vm[j] -= eps;
                    } else {
                        qp[j] += eps;
                        qm[j] -= eps;
                    }
                    let (fp, fm) = (force_at(&qp, &vp), force_at(&qm, &vm));
                    for i in 0..n {
                        // the X rows and columns
                        if i < n - 3 && j < n - 3 {
                            continue;
                        }
                        let d = (fp[i] - fm[i]) / (2.0 * eps);
                        worst = worst.max((matrix[(i, j)] - d).abs());
                        scale = scale.max(d.abs());
                    }
                }
            }
            assert!(scale > 1e-4, "{}: nothing to compare", k.description());
            assert!(
                worst < 1e-6 * scale,
                "{}: X rows and columns off by {worst:e} (scale {scale:e})",
                k.description()
            );
        }
    }

    #[test]
    fn the_translations_velocity_term_jacobian_is_the_derivative_of_b() {
        // ∂b/∂q̇: the X rows 2 H_k q̇ and the X columns 0, by central differences of b in q̇
        let g = geometry();
        let n = g.dofs();
        let q: Vec<f64> = (0..n).map(|i| 15.0 * ((i as f64) * 1.3).sin()).collect();
        let v: Vec<f64> = (0..n).map(|i| 4.0 * ((i as f64) * 0.7).cos()).collect();
        for mut k in kernels(&g) {
            let mut out = StrandTerms::new(n);
            k.evaluate(
                &EvalInput {
                    q: &q,
                    v: &v,
                    field: BodyField::zero(),
                    terms: Terms::all(),
                },
                &mut out,
            );
            let mut b_at = |v: &[f64]| {
                let mut t = StrandTerms::new(n);
                k.evaluate(
                    &EvalInput {
                        q: &q,
                        v,
                        field: BodyField::zero(),
                        terms: Terms {
                            force: true,
                            ..Terms::default()
                        },
                    },
                    &mut t,
                );
                t.velocity_term
            };
            let eps = 1e-5;
            let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
            for j in 0..n {
                let (mut vp, mut vm) = (v.clone(), v.clone());
                vp[j] += eps;
                vm[j] -= eps;
                let (bp, bm) = (b_at(&vp), b_at(&vm));
                for i in 0..n {
                    if i < n - 3 && j < n - 3 {
                        continue;
                    }
                    let d = (bp[i] - bm[i]) / (2.0 * eps);
                    worst = worst.max((out.velocity_term_jacobian[(i, j)] - d).abs());
                    scale = scale.max(d.abs());
                }
            }
            // (the rows scale with the strand's mass m = ρS L: 2.4e-8 here, 1e-4 of m)
            let m = g.mass_per_length * g.length();
            assert!(scale > 1e-6 * m, "{}: nothing to compare", k.description());
            assert!(
                worst < 1e-7 * scale,
                "{}: ∂b/∂q̇'s X rows and columns off by {worst:e} (scale {scale:e})",
                k.description()
            );
        }
    }
}

//! The kernel of a rod with a free root ([`crate::model::ends`]): any kernel of its
//! chain, wrapped to add the root's translation X as three coordinates after the
//! chain's 3N.
//!
//! With `y(s) = X + y_c(s, q)` the Jacobian is `J = [J_c | I₃]`, and the terms of the
//! equation of motion (paper eq. 4–7, written for the coordinates (q, X)) are the
//! chain's plus what the three new columns bring:
//!
//! - mass: `M = [[M_c, Σᵀ], [Σ, m I₃]]` with `Σ = ∫ρS J_c ds` (3 × 3N) and `m = ρS L`
//!   (the cross-sections' rotary inertia does not see a translation);
//! - velocity term: `b = [b_c; b_X]`, `b_X,k = q̇ᵀ H_k q̇` with `H_k = ∫ρS ∂²y_k/∂q² ds`;
//! - force: the chain's force with the field taken at `X + y_c`, and `∫F ds − b_X` on X;
//! - the Jacobians of the force (stiffness, damping, ∂b/∂q̇) with their X rows and
//!   columns.
//!
//! `Σ` and `H_k` are the chain kernel's own field force and field stiffness for the
//! uniform field `ρS e_k` (`∫J_cᵀ c0 ds` and the Hessian of the first moment
//! contracted with c0, [`Terms::stiffness`]): three more evaluations of the chain
//! kernel, with its quadrature or closed forms, so that the translation's terms are as
//! exact as the chain's.

use super::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::model::reconstruction::Pose;
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::Vector3;
use superhelix_kernels::body_field::BodyField;

/// A free-root rod's kernel: the chain's kernel and the translation's terms.
pub struct FloatingKernel {
    /// The rod's geometry (`floating`: 3N + 3 coordinates).
    geometry: StrandGeometry,
    /// The chain's kernel (3N coordinates).
    chain: Box<dyn StrandKernel>,
    /// The chain's terms at (q, q̇).
    terms: StrandTerms,
    /// The chain's terms for the uniform fields ρS e_k: Σ row k and H_k.
    unit: [StrandTerms; 3],
    /// Zero chain velocities (the unit fields' evaluations carry no b).
    zero_v: Vec<f64>,
    /// The chain's Hessian of a point (for [`StrandKernel::point`]).
    hessian: Mat<f64>,
}

impl FloatingKernel {
    /// Wrap `chain`, the kernel of the chain of `geometry` (whose `floating` is set).
    pub fn new(geometry: StrandGeometry, chain: Box<dyn StrandKernel>) -> Self {
        let n = geometry.chain_dofs();
        FloatingKernel {
            geometry,
            chain,
            terms: StrandTerms::new(n),
            unit: std::array::from_fn(|_| StrandTerms::new(n)),
            zero_v: vec![0.0; n],
            hessian: Mat::zeros(n, n),
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

fn translation(q: &[f64], n: usize) -> Vector3<f64> {
    Vector3::new(q[n], q[n + 1], q[n + 2])
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
        let n = self.geometry.chain_dofs();
        let t = input.terms;
        let (q, v) = (&input.q[..n], &input.v[..n]);
        let x = translation(input.q, n);
        let xdot = translation(input.v, n);
        let f = input.field;
        let rho_s = self.geometry.mass_per_length;
        let length = self.geometry.length();
        // the field at X + y_c with velocity Ẋ + J_c q̇
        let shifted = BodyField {
            uniform: f.uniform + f.linear * x + f.velocity * xdot,
            ..f
        };
        self.chain.evaluate(
            &EvalInput {
                q,
                v,
                field: shifted,
                terms: t,
            },
            &mut self.terms,
        );
        let any_force = t.force || t.field_force;
        let need_sigma = t.mass || any_force || t.stiffness || t.damping;
        let need_hessian = t.force || t.velocity_term_jacobian;
        if need_sigma || need_hessian {
            for (k, unit) in self.unit.iter_mut().enumerate() {
                let mut uniform = Vector3::zeros();
                uniform[k] = rho_s;
                self.chain.evaluate(
                    &EvalInput {
                        q,
                        v: &self.zero_v,
                        field: BodyField {
                            uniform,
                            ..BodyField::zero()
                        },
                        terms: Terms {
                            mass: false,
                            force: false,
                            stiffness: need_hessian,
                            damping: false,
                            velocity_term_jacobian: false,
                            field_force: true,
                            symmetric_stiffness: false,
                            split_damping: false,
                        },
                    },
                    unit,
                );
            }
        }
        // Σ row k, column j: ∫ρS (J_c)_kj ds
        let sigma = |k: usize, j: usize, unit: &[StrandTerms; 3]| unit[k].force[j];
        // (H_k q̇)_j
        let hv = |k: usize, j: usize, unit: &[StrandTerms; 3]| {
            let h = &unit[k].stiffness;
            (0..n).map(|i| h[(j, i)] * v[i]).sum::<f64>()
        };
        let c = &self.terms;
        if t.mass {
            copy_block(&mut out.mass, &c.mass, n);
            for k in 0..3 {
                for j in 0..n {
                    let s = sigma(k, j, &self.unit);
                    out.mass[(n + k, j)] = s;
                    out.mass[(j, n + k)] = s;
                }
                for l in 0..3 {
                    out.mass[(n + k, n + l)] = if k == l { rho_s * length } else { 0.0 };
                }
            }
        }
        if t.mass || any_force {
            out.first_moment = c.first_moment + x * (rho_s * length);
        }
        if any_force {
            out.force[..n].copy_from_slice(&c.force[..n]);
            out.velocity_term[..n].copy_from_slice(&c.velocity_term[..n]);
            // ∫F ds = L c0' + C1 ∫y_c ds + C2 ∫J_c q̇ ds
            let sigma_v = Vector3::from_fn(|k, _| {
                (0..n).map(|j| sigma(k, j, &self.unit) * v[j]).sum::<f64>()
            });
            let total = shifted.uniform * length
                + f.linear * (c.first_moment / rho_s)
                + f.velocity * (sigma_v / rho_s);
            for k in 0..3 {
                let b = if t.force {
                    (0..n).map(|j| v[j] * hv(k, j, &self.unit)).sum::<f64>()
                } else {
                    0.0
                };
                out.velocity_term[n + k] = b;
                out.force[n + k] = total[k] - b;
            }
        }
        // the X rows and columns of ∫Jᵀ C J ds for C = C1 (stiffness) or C2 (damping)
        let border = |m: &mut Mat<f64>, inner: &Mat<f64>, cm: &nalgebra::Matrix3<f64>| {
            copy_block(m, inner, n);
            for j in 0..n {
                let s = Vector3::from_fn(|k, _| sigma(k, j, &self.unit) / rho_s);
                let row = cm * s; // ∂(∫F ds)/∂q_j part: C Σ/ρS
                let col = cm.transpose() * s; // ∫J_cᵀ C ds: (Σᵀ C / ρS)_j
                for k in 0..3 {
                    m[(n + k, j)] = row[k];
                    m[(j, n + k)] = col[k];
                }
            }
            for k in 0..3 {
                for l in 0..3 {
                    m[(n + k, n + l)] = length * cm[(k, l)];
                }
            }
        };
        if t.stiffness {
            border(&mut out.stiffness, &c.stiffness, &f.linear);
        }
        if t.damping {
            border(&mut out.damping, &c.damping, &f.velocity);
        }
        if t.velocity_term_jacobian {
            copy_block(
                &mut out.velocity_term_jacobian,
                &c.velocity_term_jacobian,
                n,
            );
            for k in 0..3 {
                for j in 0..n {
                    out.velocity_term_jacobian[(n + k, j)] = 2.0 * hv(k, j, &self.unit);
                    out.velocity_term_jacobian[(j, n + k)] = 0.0;
                }
                for l in 0..3 {
                    out.velocity_term_jacobian[(n + k, n + l)] = 0.0;
                }
            }
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
        let x = translation(q, n);
        let (chain_jac, own) = jac.split_at_mut(n);
        let y = match hessian {
            Some((c, h)) => {
                self.hessian.fill(0.0);
                let y = self
                    .chain
                    .point(&q[..n], s, chain_jac, Some((c, &mut self.hessian)));
                for j in 0..n {
                    for i in 0..n {
                        h[(i, j)] += self.hessian[(i, j)];
                    }
                }
                y
            }
            None => self.chain.point(&q[..n], s, chain_jac, None),
        };
        for (k, col) in own.iter_mut().take(3).enumerate() {
            *col = Vector3::ith(k, 1.0);
        }
        y + x
    }

    fn element_ends(&mut self, q: &[f64], ends: &mut [Pose]) {
        let n = self.geometry.chain_dofs();
        let x = translation(q, n);
        self.chain.element_ends(&q[..n], ends);
        for e in ends.iter_mut() {
            e.position += x;
        }
    }
}

/// Copy the n × n top-left block of `src` into that of `dst`.
fn copy_block(dst: &mut Mat<f64>, src: &Mat<f64>, n: usize) {
    for j in 0..n {
        for i in 0..n {
            dst[(i, j)] = src[(i, j)];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kernels::generic::{GenericKernel, QuadratureRule};
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
}

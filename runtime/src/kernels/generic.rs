//! The generic runtime-N kernel: closed-form reconstruction, exact derivatives, and
//! Gauss–Legendre quadrature of the integrals of eq. (4)–(6). It is the yardstick the
//! generated kernels are compared against.
//!
//! Derivatives use the rigid-motion structure of the design page ("Efficient
//! assembly"): for s beyond element Q, `J_k(s) = dp_k + dθ_k × (y(s) − r_{Q+1})` where
//! `dp_k = F_Q ∂p_Q(l_Q)/∂d_i` and `dθ_k = F_Q w_i(l_Q)`; within the point's own element
//! `J_k = F_P ∂p_P(u)/∂d_i`. Second derivatives follow the same pattern: for k upstream
//! of l, `∂²y/∂q_k∂q_l = dθ_k × J_l(s)`; within one element they come from second
//! derivatives of the element's closed form (jets in d, see [`crate::model::jet`]).

use crate::kernels::kernel::{EvalInput, KernelFactory, StrandKernel, StrandTerms, Terms};
use crate::model::element::{element_jets, local_pose, ElementJets};
use crate::model::quadrature::gauss_legendre;
use crate::model::reconstruction::{darboux, element_ends, Pose};
use crate::model::strand::StrandGeometry;
use faer::Mat;
use nalgebra::{Matrix3, Vector3};

/// Quadrature of the generic kernel.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum QuadratureRule {
    /// Order per element `8 + ⌈1.5 |d|·l⌉`: the integrands are trigonometric of
    /// frequency up to 2|d| times low-degree polynomials, and Gauss–Legendre with n
    /// points resolves `e^{iωu}` over l once 2n exceeds about e·ωl/2.
    #[default]
    Adaptive,
    /// The same number of Gauss–Legendre points in every element.
    Fixed(usize),
}

impl QuadratureRule {
    /// Number of points for an element whose |d|·l is `wl`.
    pub fn order(self, wl: f64) -> usize {
        match self {
            QuadratureRule::Adaptive => 8 + (1.5 * wl).ceil().min(240.0) as usize,
            QuadratureRule::Fixed(n) => n.max(1),
        }
    }
}

/// Derivatives at the end of one element, in head coordinates.
#[derive(Debug, Clone, Copy, Default)]
struct EndDerivatives {
    /// dp_k = F_Q ∂p(l)/∂d_i
    dp: [Vector3<f64>; 3],
    /// dθ_k = F_Q w_i(l)
    dth: [Vector3<f64>; 3],
    /// F_Q ∂²p(l)/∂d_i∂d_j
    d2p: [[Vector3<f64>; 3]; 3],
    /// F_Q ∂w_i(l)/∂d_j
    dw: [[Vector3<f64>; 3]; 3],
}

/// The generic kernel for one strand.
pub struct GenericKernel {
    geom: StrandGeometry,
    rule: QuadratureRule,
    ends: Vec<Pose>,
    end_derivs: Vec<EndDerivatives>,
    /// Angular velocity of frame F_Q (Q = 0..N).
    omega: Vec<Vector3<f64>>,
    jac: Vec<Vector3<f64>>,
    jdot: Vec<Vector3<f64>>,
    tmp: Vec<Vector3<f64>>,
    /// Angular Jacobian Θ (world angular velocity of the frame at the point = Θ q̇).
    theta: Vec<Vector3<f64>>,
    /// Θ̇_k = Σ_l q̇_l ∂Θ_k/∂q_l.
    theta_dot: Vec<Vector3<f64>>,
    /// The rotary-inertia part of M (to separate it from the centreline part).
    rotary_mass: Mat<f64>,
}

impl GenericKernel {
    /// A generic kernel with the given quadrature.
    pub fn new(geom: StrandGeometry, rule: QuadratureRule) -> Self {
        let n = geom.elements();
        GenericKernel {
            rule,
            ends: vec![Pose::default(); n + 1],
            end_derivs: vec![EndDerivatives::default(); n],
            omega: vec![Vector3::zeros(); n + 1],
            jac: vec![Vector3::zeros(); 3 * n],
            jdot: vec![Vector3::zeros(); 3 * n],
            tmp: vec![Vector3::zeros(); 3 * n],
            theta: vec![Vector3::zeros(); 3 * n],
            theta_dot: vec![Vector3::zeros(); 3 * n],
            rotary_mass: Mat::zeros(3 * n, 3 * n),
            geom,
        }
    }

    /// The quadrature in use.
    pub fn rule(&self) -> QuadratureRule {
        self.rule
    }

    /// Element ends and their derivatives for this q.
    fn prepare(&mut self, q: &[f64]) {
        element_ends(&self.geom, q, &mut self.ends);
        for (k, &l) in self.geom.lengths.iter().enumerate() {
            let jets = element_jets(&darboux(q, k), l, true);
            let f = self.ends[k].frame;
            let e = &mut self.end_derivs[k];
            for i in 0..3 {
                e.dp[i] = f * jets.dp(i);
                e.dth[i] = f * jets.w_value(i);
                for j in 0..3 {
                    e.d2p[i][j] = f * jets.d2p(i, j);
                    e.dw[i][j] = f * jets.dw(i, j);
                }
            }
        }
    }

    /// Angular velocities of the element frames for velocities v.
    fn prepare_velocity(&mut self, v: &[f64]) {
        self.omega[0] = Vector3::zeros();
        for k in 0..self.geom.elements() {
            let e = &self.end_derivs[k];
            self.omega[k + 1] = self.omega[k]
                + e.dth[0] * v[3 * k]
                + e.dth[1] * v[3 * k + 1]
                + e.dth[2] * v[3 * k + 2];
        }
    }

    /// y and J at local abscissa u of element `p` (after `prepare`); columns beyond
    /// element p are not touched.
    fn point_jacobian(&mut self, p: usize, jets: &ElementJets) -> Vector3<f64> {
        let start = self.ends[p];
        let y = start.position + start.frame * jets.p_value();
        for qe in 0..p {
            let rho = y - self.ends[qe + 1].position;
            let e = &self.end_derivs[qe];
            for i in 0..3 {
                self.jac[3 * qe + i] = e.dp[i] + e.dth[i].cross(&rho);
            }
        }
        for i in 0..3 {
            self.jac[3 * p + i] = start.frame * jets.dp(i);
        }
        y
    }

    /// J̇ (columns 0..3(p+1)) at the point, for velocities v (after `prepare_velocity`).
    /// Returns ẏ = J v and J̇ v.
    fn point_jdot(
        &mut self,
        p: usize,
        jets: &ElementJets,
        y: &Vector3<f64>,
        v: &[f64],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let m = 3 * (p + 1);
        let ydot: Vector3<f64> = (0..m).map(|k| self.jac[k] * v[k]).sum();
        let mut upstream = Vector3::zeros();
        for qe in 0..p {
            let e = &self.end_derivs[qe];
            let rho = y - self.ends[qe + 1].position;
            let vq = [v[3 * qe], v[3 * qe + 1], v[3 * qe + 2]];
            let omega_q = e.dth[0] * vq[0] + e.dth[1] * vq[1] + e.dth[2] * vq[2];
            for j in 0..3 {
                upstream += self.jac[3 * qe + j] * vq[j];
            }
            let downstream = ydot - upstream;
            for i in 0..3 {
                let k = 3 * qe + i;
                let mut same = Vector3::zeros();
                let mut dwv = Vector3::zeros();
                for j in 0..3 {
                    same += e.d2p[i][j] * vq[j];
                    dwv += e.dw[i][j] * vq[j];
                }
                self.jdot[k] = self.omega[qe].cross(&self.jac[k])
                    + e.dth[i].cross(&downstream)
                    + same
                    + dwv.cross(&rho)
                    + e.dth[i].cross(&omega_q.cross(&rho));
            }
        }
        let f = self.ends[p].frame;
        for i in 0..3 {
            let k = 3 * p + i;
            let mut same = Vector3::zeros();
            for j in 0..3 {
                same += jets.d2p(i, j) * v[3 * p + j];
            }
            self.jdot[k] = self.omega[p].cross(&self.jac[k]) + f * same;
        }
        let acc = (0..m).map(|k| self.jdot[k] * v[k]).sum();
        (ydot, acc)
    }

    /// Rotary-inertia parts of M, b and ∂b/∂q̇ at one quadrature point: the kinetic
    /// energy `½ Ωᵀ I Ω` gives `M += Θᵀ I Θ` and `b += Θᵀ (I Θ̇q̇ + Ω × IΩ)`.
    #[allow(clippy::too_many_arguments)]
    fn add_rotary_terms(
        &mut self,
        p: usize,
        u: f64,
        d: &Vector3<f64>,
        jets: &ElementJets,
        v: &[f64],
        t: Terms,
        w: f64,
        out: &mut StrandTerms,
    ) {
        let m = 3 * (p + 1);
        let inertia = self.point_rotation(p, u, d, jets);
        if t.mass {
            for k in 0..m {
                self.tmp[k] = inertia * self.theta[k];
            }
            add_gram(&mut self.rotary_mass, &self.theta, &self.tmp, m, w);
        }
        if !(t.force || t.velocity_term_jacobian) {
            return;
        }
        let (omega, alpha) = self.point_theta_dot(p, jets, v);
        if t.force {
            let torque = inertia * alpha + omega.cross(&(inertia * omega));
            for k in 0..m {
                let b = w * self.theta[k].dot(&torque);
                out.velocity_term[k] += b;
                out.force[k] -= b;
            }
        }
        if t.velocity_term_jacobian {
            self.add_rotary_velocity_jacobian(
                p,
                jets,
                &inertia,
                &omega,
                v,
                w,
                &mut out.velocity_term_jacobian,
            );
        }
    }

    /// Rotary inertia of the cross-section at local abscissa u of element p, in head
    /// coordinates, and the angular Jacobian Θ there (columns 0..3(p+1)).
    fn point_rotation(
        &mut self,
        p: usize,
        u: f64,
        d: &Vector3<f64>,
        jets: &ElementJets,
    ) -> Matrix3<f64> {
        let (e_u, _) = local_pose(d, u);
        let f = self.ends[p].frame;
        let fu = f * e_u;
        let inertia =
            fu * Matrix3::from_diagonal(&Vector3::from(self.geom.rotary_inertia)) * fu.transpose();
        for qe in 0..p {
            for i in 0..3 {
                self.theta[3 * qe + i] = self.end_derivs[qe].dth[i];
            }
        }
        for i in 0..3 {
            self.theta[3 * p + i] = f * jets.w_value(i);
        }
        inertia
    }

    /// Θ̇ columns and the frame's angular velocity Ω = Θ q̇ and Θ̇ q̇ at the point
    /// (after `point_rotation` and `prepare_velocity`).
    fn point_theta_dot(
        &mut self,
        p: usize,
        jets: &ElementJets,
        v: &[f64],
    ) -> (Vector3<f64>, Vector3<f64>) {
        let m = 3 * (p + 1);
        let f = self.ends[p].frame;
        for qe in 0..=p {
            for i in 0..3 {
                let k = 3 * qe + i;
                let mut same = Vector3::zeros();
                for j in 0..3 {
                    let dw = if qe < p {
                        self.end_derivs[qe].dw[i][j]
                    } else {
                        f * jets.dw(i, j)
                    };
                    same += dw * v[3 * qe + j];
                }
                self.theta_dot[k] = self.omega[qe].cross(&self.theta[k]) + same;
            }
        }
        let omega: Vector3<f64> = (0..m).map(|k| self.theta[k] * v[k]).sum();
        let alpha = (0..m).map(|k| self.theta_dot[k] * v[k]).sum();
        (omega, alpha)
    }

    /// Adds 2nd part of ∂b/∂q̇ from rotary inertia: weight Θᵀ ∂(I Θ̇q̇ + Ω × IΩ)/∂q̇.
    fn add_rotary_velocity_jacobian(
        &mut self,
        p: usize,
        jets: &ElementJets,
        inertia: &Matrix3<f64>,
        omega: &Vector3<f64>,
        v: &[f64],
        weight: f64,
        out: &mut Mat<f64>,
    ) {
        let m = 3 * (p + 1);
        let f = self.ends[p].frame;
        let i_omega = inertia * omega;
        for qe in 0..=p {
            for j in 0..3 {
                let col = 3 * qe + j;
                // s_m = Σ_k q̇_k ∂Θ_k/∂q_m
                let mut s = Vector3::zeros();
                for i in 0..3 {
                    let dw = if qe < p {
                        self.end_derivs[qe].dw[i][j]
                    } else {
                        f * jets.dw(i, j)
                    };
                    s += dw * v[3 * qe + i];
                }
                if qe < p {
                    s += self.end_derivs[qe].dth[j].cross(&(omega - self.omega[qe + 1]));
                }
                let th = self.theta[col];
                self.tmp[col] = inertia * (self.theta_dot[col] + s) + omega.cross(&(inertia * th))
                    - i_omega.cross(&th);
            }
        }
        add_gram(out, &self.theta, &self.tmp, m, weight);
    }

    /// Adds `weight · c · ∂²y/∂q∂q` at the point to H (upper and lower parts).
    fn add_hessian(
        &mut self,
        p: usize,
        jets: &ElementJets,
        y: &Vector3<f64>,
        c: &Vector3<f64>,
        weight: f64,
        h: &mut Mat<f64>,
    ) {
        let m = 3 * (p + 1);
        // g_k = c × dθ_k for columns upstream of element p
        for qe in 0..p {
            for i in 0..3 {
                self.tmp[3 * qe + i] = c.cross(&self.end_derivs[qe].dth[i]) * weight;
            }
        }
        // pairs in different elements: k in Q < Q' ∋ l: c·(dθ_k × J_l) = (c × dθ_k)·J_l
        for l in 3..m {
            let ql = l / 3;
            let jl = self.jac[l];
            for k in 0..3 * ql {
                let val = self.tmp[k].dot(&jl);
                h[(k, l)] += val;
                h[(l, k)] += val;
            }
        }
        // pairs within one element upstream of p
        for qe in 0..p {
            let e = &self.end_derivs[qe];
            let rho = y - self.ends[qe + 1].position;
            for i in 0..3 {
                for j in 0..3 {
                    let d2 = e.d2p[i][j]
                        + e.dw[i][j].cross(&rho)
                        + e.dth[i].cross(&e.dth[j].cross(&rho));
                    h[(3 * qe + i, 3 * qe + j)] += weight * c.dot(&d2);
                }
            }
        }
        // pairs within element p itself
        let f = self.ends[p].frame;
        let cf = f.transpose() * c * weight;
        for i in 0..3 {
            for j in 0..3 {
                h[(3 * p + i, 3 * p + j)] += cf.dot(&jets.d2p(i, j));
            }
        }
    }
}

/// Adds weight · Σ_{k,l<m} a_k · (B b_l) into `mat` (k rows, l columns) over the first m
/// columns; with `b == a` and B = I this is a Gram matrix.
fn add_gram(mat: &mut Mat<f64>, a: &[Vector3<f64>], b: &[Vector3<f64>], m: usize, weight: f64) {
    for l in 0..m {
        let col = mat.col_as_slice_mut(l);
        let bl = b[l] * weight;
        for k in 0..m {
            col[k] += a[k].dot(&bl);
        }
    }
}

fn zero_mat(m: &mut Mat<f64>) {
    m.fill(0.0);
}

impl StrandKernel for GenericKernel {
    fn geometry(&self) -> &StrandGeometry {
        &self.geom
    }

    fn description(&self) -> String {
        match self.rule {
            QuadratureRule::Adaptive => "generic (adaptive Gauss-Legendre)".to_string(),
            QuadratureRule::Fixed(n) => format!("generic ({n}-point Gauss-Legendre)"),
        }
    }

    fn is_generated(&self) -> bool {
        false
    }

    fn evaluate(&mut self, input: &EvalInput<'_>, out: &mut StrandTerms) {
        let mut t = input.terms;
        // the field's force alone: the force less b, with b added back at the end
        let field_force = t.field_force && !t.force;
        t.force |= field_force;
        let (q, v, field) = (input.q, input.v, input.field);
        let rho_s = self.geom.mass_per_length;
        let need_jdot = t.force || t.velocity_term_jacobian;
        self.prepare(q);
        if need_jdot {
            self.prepare_velocity(v);
        }
        if t.mass {
            zero_mat(&mut out.mass);
            zero_mat(&mut self.rotary_mass);
        }
        if t.force {
            out.force.fill(0.0);
            out.velocity_term.fill(0.0);
        }
        if t.mass || t.force {
            out.first_moment = Vector3::zeros();
        }
        if t.stiffness {
            zero_mat(&mut out.stiffness);
        }
        if t.damping {
            zero_mat(&mut out.damping);
        }
        if t.velocity_term_jacobian {
            zero_mat(&mut out.velocity_term_jacobian);
        }
        // With an isotropic C2 = c I, ∫ JᵀC2J = (c/ρS) M: no extra work.
        let iso_damping = field.isotropic_velocity().filter(|_| t.mass);
        let has_linear = field.has_linear();
        let has_rotary = self.geom.rotary_inertia != [0.0; 3] && (t.mass || need_jdot);
        for p in 0..self.geom.elements() {
            let l = self.geom.lengths[p];
            let d = darboux(q, p);
            let rule = gauss_legendre(self.rule.order(d.norm() * l));
            let m = 3 * (p + 1);
            for (x, wgl) in rule.nodes().iter().zip(rule.weights()) {
                let u = 0.5 * l * (x + 1.0);
                let w = 0.5 * l * wgl;
                let jets = element_jets(&d, u, has_rotary);
                let y = self.point_jacobian(p, &jets);
                if t.mass {
                    add_gram(&mut out.mass, &self.jac, &self.jac, m, w * rho_s);
                }
                if t.mass || t.force {
                    out.first_moment += y * (w * rho_s);
                }
                if has_rotary {
                    self.add_rotary_terms(p, u, &d, &jets, v, t, w, out);
                }
                if need_jdot {
                    let (ydot, acc) = self.point_jdot(p, &jets, &y, v);
                    if t.force {
                        let f = field.uniform + field.linear * y + field.velocity * ydot;
                        for k in 0..m {
                            let b = rho_s * self.jac[k].dot(&acc);
                            out.velocity_term[k] += w * b;
                            out.force[k] += w * (self.jac[k].dot(&f) - b);
                        }
                    }
                    if t.velocity_term_jacobian {
                        let (jac, jdot) = (&self.jac, &self.jdot);
                        add_gram(
                            &mut out.velocity_term_jacobian,
                            jac,
                            jdot,
                            m,
                            2.0 * w * rho_s,
                        );
                    }
                }
                if t.stiffness {
                    let c = field.uniform + field.linear * y;
                    self.add_hessian(p, &jets, &y, &c, w, &mut out.stiffness);
                    if has_linear {
                        for k in 0..m {
                            self.tmp[k] = field.linear * self.jac[k];
                        }
                        add_gram(&mut out.stiffness, &self.jac, &self.tmp, m, w);
                    }
                }
                if t.damping && iso_damping.is_none() {
                    for k in 0..m {
                        self.tmp[k] = field.velocity * self.jac[k];
                    }
                    add_gram(&mut out.damping, &self.jac, &self.tmp, m, w);
                }
            }
        }
        if let (true, Some(c)) = (t.damping, iso_damping) {
            // drag acts on the centreline only: the centreline part of M
            out.damping.copy_from(&out.mass);
            out.damping *= faer::Scale(c / rho_s);
        }
        if t.mass && has_rotary {
            out.mass += &self.rotary_mass;
        }
        if field_force {
            for (f, b) in out.force.iter_mut().zip(out.velocity_term.iter()) {
                *f += *b;
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
        self.prepare(q);
        let (p, u) = self.geom.locate(s);
        let jets = element_jets(&darboux(q, p), u, false);
        let y = self.point_jacobian(p, &jets);
        let m = 3 * (p + 1);
        jac[..m].copy_from_slice(&self.jac[..m]);
        for col in jac.iter_mut().skip(m) {
            *col = Vector3::zeros();
        }
        if let Some((c, h)) = hessian {
            self.add_hessian(p, &jets, &y, &c, 1.0, h);
        }
        y
    }
}

/// Makes [`GenericKernel`]s for any N.
#[derive(Debug, Clone, Copy, Default)]
pub struct GenericKernelFactory {
    /// Quadrature of the kernels made.
    pub rule: QuadratureRule,
}

impl KernelFactory for GenericKernelFactory {
    fn create(&self, geometry: &StrandGeometry) -> Option<Box<dyn StrandKernel>> {
        Some(Box::new(GenericKernel::new(geometry.clone(), self.rule)))
    }
    fn available(&self) -> Vec<usize> {
        Vec::new()
    }
}

//! A sag-free start (inverse statics): the natural curvatures that make a given shape an
//! equilibrium under gravity, so that a groomed or imported shape is what the hair looks
//! like at rest instead of the shape it starts from before sagging.
//!
//! At rest (q̇ = 0, head still) the equation of motion (paper eq. 4–5, `docs/model.md`)
//! reduces to the statics `K (q − q_n) = G(q)`, with K = diag(l_Q EI_i) the stiffness of
//! the elastic energy (eq. 5c) and `G(q) = ∫ Jᵀ ρS g ds` the generalized gravity force
//! (eq. 5a, J = ∂y/∂q). For a given q this is linear in q_n, so
//!
//! ```text
//! q_n = q − K⁻¹ G(q)
//! ```
//!
//! in closed form. With these natural curvatures the strand at q feels no net force:
//! it stays where it is (up to round-off, and as long as the equilibrium is stable: a
//! long strand held straight up against gravity is not).

use crate::forces::effects::{body_field, GlobalEffects};
use crate::forces::head_motion::HeadState;
use crate::kernels::closed_form::kernel_factory;
use crate::kernels::generic::{GenericKernel, QuadratureRule};
use crate::kernels::kernel::{EvalInput, StrandKernel, StrandTerms, Terms};
use crate::model::strand::{Strand, StrandGeometry};
use nalgebra::Vector3;

/// The kernel a groom's statics use for a strand of `geometry`: its generated kernel
/// (the one `kernels = "auto"` steps it with), else the generic one.
pub fn groom_kernel(geometry: &StrandGeometry) -> Box<dyn StrandKernel> {
    kernel_factory().create(geometry).unwrap_or_else(|| {
        Box::new(GenericKernel::new(
            geometry.clone(),
            QuadratureRule::Adaptive,
        ))
    })
}

/// The generalized gravity force `G(q) = ∫ Jᵀ ρS g ds` of `strand` at `q` with gravity
/// `gravity` (m/s², head coordinates), computed by the strand's generated kernel (the
/// one `kernels = "auto"` steps it with).
pub fn gravity_force(strand: &Strand, q: &[f64], gravity: &Vector3<f64>) -> Vec<f64> {
    let mut kernel = groom_kernel(&strand.geometry);
    let effects = GlobalEffects {
        gravity: Some(*gravity),
        head_moves: false,
    };
    // no air drag: at q̇ = 0 with a still head it exerts nothing
    let field = body_field(
        &effects,
        &HeadState::rest(),
        strand.material.mass_per_length,
        0.0,
    );
    let zero = vec![0.0; q.len()];
    let mut out = StrandTerms::new(q.len());
    kernel.evaluate(
        &EvalInput {
            q,
            v: &zero,
            field,
            terms: Terms {
                force: true,
                ..Default::default()
            },
        },
        &mut out,
    );
    out.force
}

/// The natural curvatures `q_n = q − K⁻¹ G(q)` that make `q` an equilibrium of `strand`
/// under `gravity` (head coordinates; the module doc). Point loads are not included.
pub fn sag_free_natural(strand: &Strand, q: &[f64], gravity: &Vector3<f64>) -> Vec<f64> {
    let force = gravity_force(strand, q, gravity);
    let stiffness = strand.stiffness_diagonal();
    q.iter()
        .zip(&force)
        .zip(&stiffness)
        .map(|((q, f), k)| q - f / k)
        .collect()
}

/// What [`sag_free_supported`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Supported {
    /// The natural curvatures, as [`sag_free_natural`]'s.
    pub natural: Vec<f64>,
    /// The normal force each support carries, N, in the order of the supports.
    pub forces: Vec<f64>,
}

/// The natural curvatures that make `q` an equilibrium of `strand` under `gravity` with
/// the bodies it rests on carrying what they can: `K (q − q_n) = G(q) + Σ_k λ_k a_k`,
/// with `a_k = J_kᵀ n_k` the generalized force of a unit normal force at the k-th sample
/// that touches a body (`supports`, from the contacts' `support_directions`) and the
/// forces λ_k ≥ 0 (a body pushes, never pulls) that make the change of shape the
/// elastic energy must hold the least: λ minimizes `‖K^{-1/2} (G + A λ)‖²`, a
/// non-negative least-squares problem (Lawson and Hanson's active-set method, [`nnls`]).
/// Long hair lying over a head hangs from its root by the strand's inextensibility and
/// rests on the scalp; the elastic part then holds only what the supports cannot (the
/// tangential part of the weight on a slope, the moments between supports).
///
/// Without supports this is [`sag_free_natural`]. The penalty contacts of the run carry
/// λ_k once the sample is λ_k / (k w_k) deep: a strand groomed at the contact radius from
/// its body settles by that depth (micrometres for the default stiffness) and by its fit
/// error against the surface.
pub fn sag_free_supported(
    strand: &Strand,
    q: &[f64],
    gravity: &Vector3<f64>,
    supports: &[Vec<f64>],
) -> Supported {
    let force = gravity_force(strand, q, gravity);
    let stiffness = strand.stiffness_diagonal();
    let n = q.len();
    let m = supports.len();
    let forces = if m == 0 {
        Vec::new()
    } else {
        // minimize ‖B λ − b‖ with B = K^{-1/2} A, b = −K^{-1/2} G
        let scale: Vec<f64> = stiffness.iter().map(|k| 1.0 / k.sqrt()).collect();
        let b = nalgebra::DMatrix::from_fn(n, m, |i, j| supports[j][i] * scale[i]);
        let rhs = nalgebra::DVector::from_fn(n, |i, _| -force[i] * scale[i]);
        nnls(&b, &rhs).iter().copied().collect()
    };
    let natural = (0..n)
        .map(|i| {
            let carried: f64 = supports.iter().zip(&forces).map(|(a, l)| a[i] * l).sum();
            q[i] - (force[i] + carried) / stiffness[i]
        })
        .collect();
    Supported { natural, forces }
}

/// Non-negative least squares: the x ≥ 0 that minimizes ‖A x − b‖ (Lawson and Hanson,
/// *Solving Least Squares Problems*, 1974, ch. 23: the active-set method). Columns enter
/// the passive set by the largest gradient of the residual, the unconstrained
/// least-squares solution on the passive set is taken when it is positive, otherwise the
/// step towards it stops at the first variable that reaches zero, which leaves the set.
/// At most `3 × columns` outer iterations; an x that stops there is still feasible.
pub fn nnls(a: &nalgebra::DMatrix<f64>, b: &nalgebra::DVector<f64>) -> nalgebra::DVector<f64> {
    let m = a.ncols();
    let mut x = nalgebra::DVector::<f64>::zeros(m);
    let mut passive = vec![false; m];
    let scale = a.norm() * b.norm();
    let tol = 1e-12 * scale.max(f64::MIN_POSITIVE);
    let solve = |passive: &[bool]| -> nalgebra::DVector<f64> {
        let cols: Vec<usize> = (0..m).filter(|&j| passive[j]).collect();
        let sub = nalgebra::DMatrix::from_fn(a.nrows(), cols.len(), |i, c| a[(i, cols[c])]);
        let z = sub
            .svd(true, true)
            .solve(b, 1e-14)
            .unwrap_or_else(|_| nalgebra::DVector::zeros(cols.len()));
        let mut full = nalgebra::DVector::zeros(m);
        for (c, &j) in cols.iter().enumerate() {
            full[j] = z[c];
        }
        full
    };
    for _ in 0..3 * m.max(1) {
        let w = a.transpose() * (b - a * &x);
        let Some((t, wt)) = (0..m)
            .filter(|&j| !passive[j])
            .map(|j| (j, w[j]))
            .max_by(|p, q| p.1.total_cmp(&q.1))
        else {
            break;
        };
        if wt <= tol {
            break;
        }
        passive[t] = true;
        loop {
            let z = solve(&passive);
            if (0..m).filter(|&j| passive[j]).all(|j| z[j] > 0.0) {
                x = z;
                break;
            }
            // step from x towards z until the first passive variable reaches zero
            let Some((first, alpha)) = (0..m)
                .filter(|&j| passive[j] && z[j] <= 0.0)
                .map(|j| (j, x[j] / (x[j] - z[j])))
                .min_by(|p, q| p.1.total_cmp(&q.1))
            else {
                break;
            };
            let alpha = if alpha.is_finite() { alpha } else { 0.0 };
            x += (z - &x) * alpha;
            // the variable that reached zero leaves (rounding may leave it a hair above),
            // and so does any other that did
            passive[first] = false;
            x[first] = 0.0;
            for j in 0..m {
                if passive[j] && x[j] <= tol {
                    passive[j] = false;
                    x[j] = 0.0;
                }
            }
            if !passive.iter().any(|&p| p) {
                break;
            }
        }
    }
    x.iter_mut().for_each(|v| *v = v.max(0.0));
    x
}

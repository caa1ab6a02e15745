//! A free root's linear momentum kept through the linearly implicit step.
//!
//! A strand with a free root carries its root's translation X among its coordinates,
//! after the chain's 3N ([`ParamsView::free_root`]), and its linear momentum is
//! `P(q, q̇) = M_X(q) q̇` with `M_X` the mass matrix's X rows (`∫ ρS J ds`, since
//! ∂y/∂X = I). Newton's second law for the whole strand is `dP/dt = Σ F` (the X rows of
//! the generalized force, internal forces cancelling), which the equation of motion
//! `M q̈ = F − b` holds because the X rows of the quadratic velocity term are
//! `b_X = Ṁ_X q̇` (paper eq. 6; ∂T/∂X = 0).
//!
//! The step solves its X rows at the start's configuration q₀:
//! `M_X(q₀) (q̇⁺ − q̇) = h F_X − (h/2) (B q̇⁺)_X` (with `b ≈ ½ B q̇⁺`), and the momentum
//! it ends with is measured at the end's configuration q⁺: `M_X(q⁺) q̇⁺`. Where an
//! element turns within the step the two differ at first order, by much more than the
//! impulse when the rotation is fast (uncorrected, a rod pulled sideways at its tip
//! loses 13 % of `F t` in its first step and keeps the loss), so the run no longer
//! follows F = ma. The correction moves Ẋ alone so that the momentum at the end is the
//! start's plus the step's impulse `h F_X = M_X(q₀) q̇⁺ + (h/2)(B q̇⁺)_X − P(q₀, q̇)`:
//! `Ẋ += (P_target − M_X(q⁺) q̇⁺)/m`, second order in h ([`momentum_target`],
//! [`correct_momentum`]). It costs one mass matrix at q⁺ a step, on free-root strands
//! only. When the energy balance limits the kinetic energy, the motion about the centre
//! of mass is scaled and the momentum kept ([`scale_to_kinetic`]).

use super::step::evaluate_at;
use crate::body_field::BodyField;
use crate::float::Float;
use crate::storage::{ParamsView, WorkView};
use crate::strand_terms::{StepTerms, Terms};

/// The momentum the step's own impulse gives (`P_target` above), from the mass matrix
/// and ∂b/∂q̇ still in `ws` for the start's configuration, and the solved velocities `v`
/// of a step of `h` seconds.
pub(crate) fn momentum_target<T: Float, const NC: usize>(
    ws: &WorkView<'_, T, NC>,
    v: &[T],
    h: T,
) -> [T; 3] {
    let n = v.len();
    let x = n - 3;
    let (mass, b) = (&*ws.assembly.mass, &ws.velocity_jacobian);
    let half_h = T::of(0.5) * h;
    let mut p = [T::zero(); 3];
    for (k, pk) in p.iter_mut().enumerate() {
        for (j, &vj) in v.iter().enumerate() {
            *pk += (mass[j * n + x + k] + half_h * b[j][x + k]) * vj;
        }
    }
    p
}

/// `M_X v` and the strand's mass `m` with M evaluated at q into `ws`.
fn momentum_at<S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    params: &ParamsView<'_, T>,
    q: &[T],
    v: &[T],
    ws: &mut WorkView<'_, T, NC>,
) -> ([T; 3], T) {
    let terms = Terms {
        mass: true,
        ..Default::default()
    };
    evaluate_at(source, params, q, v, &BodyField::zero(), terms, ws);
    let n = v.len();
    let x = n - 3;
    let mass = &*ws.assembly.mass;
    let mut p = [T::zero(); 3];
    for (k, pk) in p.iter_mut().enumerate() {
        for (j, &vj) in v.iter().enumerate() {
            *pk += mass[j * n + x + k] * vj;
        }
    }
    (p, mass[x * n + x])
}

/// Move Ẋ (the last three of `v`) so that the momentum at (`q`, `v`) is `target`
/// (`v` outside `ws`: M is evaluated into it).
pub(crate) fn correct_momentum<S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    params: &ParamsView<'_, T>,
    q: &[T],
    v: &mut [T],
    target: [T; 3],
    ws: &mut WorkView<'_, T, NC>,
) {
    let (p, mass) = momentum_at(source, params, q, v, ws);
    let x = v.len() - 3;
    for k in 0..3 {
        v[x + k] += (target[k] - p[k]) / mass;
    }
}

/// Scale the velocities `v` at `q` so that the kinetic energy becomes `kinetic` (below
/// the `present` one), keeping the linear momentum: the motion relative to the centre
/// of mass is scaled, `q̇ → λ q̇ + (1 − λ) e_X V` with `V = P/m` (a uniform
/// translation, Ẋ = V and the chain at rest, carries the momentum P and the kinetic
/// energy ½ m V², and the rest carries no momentum, so the two energies add). When the
/// translation alone holds more than `kinetic`, all velocities are scaled (the bound
/// cannot be met keeping the momentum). Returns `√(kinetic / present)`, which scales
/// the end's energy record.
pub(crate) fn scale_to_kinetic<S: StepTerms<T> + ?Sized, T: Float, const NC: usize>(
    source: &mut S,
    params: &ParamsView<'_, T>,
    q: &[T],
    v: &mut [T],
    (present, kinetic): (T, T),
    ws: &mut WorkView<'_, T, NC>,
) -> T {
    let plain = (kinetic / present).sqrt();
    let (p, mass) = momentum_at(source, params, q, v, ws);
    let x = v.len() - 3;
    let translation = p.iter().map(|&c| c * c).sum::<T>() / (T::of(2.0) * mass);
    if kinetic <= translation || present <= translation {
        v.iter_mut().for_each(|x| *x *= plain);
        return plain;
    }
    let lambda = ((kinetic - translation) / (present - translation)).sqrt();
    v.iter_mut().for_each(|x| *x *= lambda);
    for k in 0..3 {
        v[x + k] += (T::one() - lambda) * p[k] / mass;
    }
    plain
}

#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;
    use crate::pose::Pose;
    use crate::storage::heap::HeapWorkspace;
    use crate::storage::Square;
    use crate::strand_terms::{
        MomentBuffers, PointScratch, StrandEnergy, StrandShape, TermMatrix, TermVectors,
    };
    use nalgebra::{Matrix3, Vector3};

    /// A strand of two elements and a free root (n = 9) whose mass matrix is `m` at
    /// every q, shaped as a free rod's: SPD, the X rows `[Σᵀ | m I₃]` (∂y/∂X = I, so
    /// `M_XX = ∫ρS ds I`) coupled to the chain's.
    struct ConstantMass {
        m: [f64; 81],
    }

    impl ConstantMass {
        fn new() -> Self {
            // Aᵀ A + I with A a fixed pattern, its X block replaced by 10 I
            let mut m = [0.0; 81];
            for i in 0..9 {
                for j in 0..9 {
                    let a = |r: usize, c: usize| ((r * 7 + c * 3) % 5) as f64 * 0.1;
                    m[j * 9 + i] = (0..9).map(|r| a(r, i) * a(r, j)).sum::<f64>()
                        + if i == j { 1.0 } else { 0.0 };
                    if i >= 6 && j >= 6 {
                        m[j * 9 + i] = if i == j { 10.0 } else { 0.0 };
                    }
                }
            }
            ConstantMass { m }
        }

        fn momentum(&self, v: &[f64]) -> [f64; 3] {
            let mut p = [0.0; 3];
            for (k, pk) in p.iter_mut().enumerate() {
                *pk = (0..9).map(|j| self.m[j * 9 + 6 + k] * v[j]).sum();
            }
            p
        }

        fn kinetic(&self, v: &[f64]) -> f64 {
            (0..9)
                .map(|j| (0..9).map(|i| self.m[j * 9 + i] * v[i]).sum::<f64>() * v[j])
                .sum::<f64>()
                * 0.5
        }
    }

    impl StepTerms<f64> for ConstantMass {
        fn evaluate(
            &mut self,
            _shape: &StrandShape<'_, f64>,
            buffers: &mut MomentBuffers<'_, f64>,
            _q: &[f64],
            _v: &[f64],
            _field: &BodyField<f64>,
            terms: Terms,
            _out: &mut TermVectors<'_, f64>,
            _sink: &mut dyn FnMut(TermMatrix, &[f64]),
        ) {
            if terms.mass {
                buffers.mass[..81].copy_from_slice(&self.m);
                *buffers.mass_valid = false;
            }
        }
        fn energy(
            &mut self,
            _shape: &StrandShape<'_, f64>,
            _buffers: &mut MomentBuffers<'_, f64>,
            _q: &[f64],
            v: &[f64],
            _linear: Option<&Matrix3<f64>>,
            _prepare_terms: bool,
        ) -> StrandEnergy<f64> {
            StrandEnergy {
                kinetic: self.kinetic(v),
                first_moment: Vector3::zeros(),
                power: 0.0,
            }
        }
        fn ends(&mut self, _shape: &StrandShape<'_, f64>, _q: &[f64], _ends: &mut [Pose<f64>]) {}
        fn point(
            &mut self,
            _shape: &StrandShape<'_, f64>,
            _q: &[f64],
            _s: f64,
            _scratch: &mut PointScratch<'_, f64>,
            _hessian: Option<(Vector3<f64>, &mut Square<'_, f64>)>,
        ) -> Vector3<f64> {
            Vector3::zeros()
        }
        fn frame(
            &mut self,
            _shape: &StrandShape<'_, f64>,
            _q: &[f64],
            _s: f64,
            _scratch: &mut PointScratch<'_, f64>,
        ) -> Matrix3<f64> {
            Matrix3::identity()
        }
    }

    fn params<'a>(lengths: &'a [f64], zeros: &'a [f64]) -> ParamsView<'a, f64> {
        ParamsView {
            root_position: Vector3::zeros(),
            root_frame: Matrix3::identity(),
            lengths,
            natural: zeros,
            stiffness: zeros,
            friction: zeros,
            mass_per_length: 1.0,
            air_drag: 0.0,
            rotary_inertia: [0.0; 3],
            loads: &[],
            scale: &[],
        }
    }

    #[test]
    fn the_momentum_is_corrected_to_its_target_and_kept_when_the_energy_is_limited() {
        let mut source = ConstantMass::new();
        let (lengths, zeros) = ([0.1, 0.1], [0.0; 9]);
        let p = params(&lengths, &zeros);
        assert!(p.free_root());
        let mut ws = HeapWorkspace::<f64>::new();
        let mut view = ws.view(3);
        let q = [0.0; 9];
        let mut v = [0.3, -0.2, 0.5, 0.1, 0.7, -0.4, 0.2, -0.6, 0.9];
        // the X rows of M v moved to a target: Ẋ alone changes, by (target − P)/m_XX
        let target = [1.0, -2.0, 0.5];
        let before = v;
        correct_momentum(&mut source, &p, &q, &mut v, target, &mut view);
        let after = source.momentum(&v);
        assert_eq!(v[..6], before[..6]);
        for k in 0..3 {
            assert!((after[k] - target[k]).abs() <= 1e-15 * 4.0, "{after:?}");
        }
        // the kinetic energy scaled down to a bound above the translation's: the
        // momentum kept to round-off, the energy reached
        let mut v = [0.3, -0.2, 0.5, 0.1, 0.7, -0.4, 0.02, -0.06, 0.09];
        let present = source.kinetic(&v);
        let p0 = source.momentum(&v);
        let kinetic = 0.5 * present;
        let lambda = scale_to_kinetic(&mut source, &p, &q, &mut v, (present, kinetic), &mut view);
        let p1 = source.momentum(&v);
        assert!((lambda - 0.5f64.sqrt()).abs() < 1e-15);
        for k in 0..3 {
            assert!(
                (p1[k] - p0[k]).abs() <= 1e-14 * p0[k].abs().max(1e-3),
                "{p1:?} {p0:?}"
            );
        }
        let reached = source.kinetic(&v);
        assert!(
            (reached - kinetic).abs() <= 1e-12 * kinetic,
            "{reached:e} for {kinetic:e}"
        );
    }
}

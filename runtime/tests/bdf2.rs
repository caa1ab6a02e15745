//! The second-order integrator (issue #4, "What accuracy costs in time"): linearised
//! BDF2 against an explicit RK4 reference (order of convergence), on a stiff strand at the
//! paper's step (stability, dissipation), and its history handling. Its statics are in
//! `physics.rs` (`damped_dynamics_settle_into_the_static_equilibrium_...`).

mod common;
use common::*;
use nalgebra::{DMatrix, DVector, Vector3};
use superhelix_runtime::config::{IntegratorKind, KernelChoice, SimulationConfig};
use superhelix_runtime::kernels::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix_runtime::model::material::CrossSection;
use superhelix_runtime::model::strand::Strand;
use superhelix_runtime::{GenericKernel, HeadMotion, QuadratureRule, Simulation};

/// The smooth preset's cross-section, E = 1 GPa, circular; `stiffness` scales E.
fn round_fibre(stiffness: f64) -> CrossSection {
    CrossSection {
        radius: 50e-6,
        ellipticity: 1.0,
        youngs_modulus: 1e9 * stiffness,
        poisson: 0.48,
        density: 1300.0,
        shear_factor: 1.0,
    }
}

fn simulation(strand: &Strand, integrator: IntegratorKind, dt: f64, gravity: bool) -> Simulation {
    let config = SimulationConfig {
        dt,
        integrator,
        kernels: KernelChoice::Generic,
        ..SimulationConfig::default()
    };
    let gravity = gravity.then(|| Vector3::new(0.0, 0.0, -9.81));
    Simulation::new(
        setup(vec![strand.clone()], config, gravity, HeadMotion::Still),
        None,
    )
    .expect("valid setup")
}

/// The first bending mode of the discrete model at q = 0 (K x = ω² M x), scaled to a
/// largest entry of 1.
fn first_mode(strand: &Strand) -> Vec<f64> {
    let n = strand.geometry.dofs();
    let mut kernel = GenericKernel::new(strand.geometry.clone(), QuadratureRule::Adaptive);
    let mut out = StrandTerms::new(n);
    let zero = vec![0.0; n];
    let terms = Terms {
        mass: true,
        ..Default::default()
    };
    kernel.evaluate(
        &EvalInput {
            q: &zero,
            v: &zero,
            field: BodyField::zero(),
            terms,
        },
        &mut out,
    );
    let m = DMatrix::from_fn(n, n, |i, j| out.mass[(i, j)]);
    let k = DVector::from_vec(strand.stiffness_diagonal());
    let l = m.cholesky().expect("M is SPD").l();
    let linv = l.try_inverse().expect("L is invertible");
    let c = &linv * DMatrix::from_diagonal(&k) * linv.transpose();
    let eig = c.symmetric_eigen();
    let i = (0..n)
        .min_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]))
        .expect("n > 0");
    let x = linv.transpose() * eig.eigenvectors.column(i);
    let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter().map(|v| v / scale).collect()
}

/// Tip positions every `sample` seconds over `duration` (the start included), and the
/// substeps taken.
fn tip_samples(
    strand: &Strand,
    q0: &[f64],
    integrator: IntegratorKind,
    dt: f64,
    duration: f64,
    sample: f64,
) -> (Vec<Vector3<f64>>, usize) {
    let mut sim = simulation(strand, integrator, dt, false);
    sim.set_state(0, q0, &vec![0.0; q0.len()]);
    let length = strand.geometry.length();
    let every = (sample / dt).round() as usize;
    let steps = (duration / dt).round() as usize;
    let mut tips = vec![sim.position_at(0, length)];
    for k in 1..=steps {
        sim.step().expect("step");
        if k % every == 0 {
            tips.push(sim.position_at(0, length));
        }
    }
    (tips, sim.stats().substeps)
}

fn max_distance(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
}

#[test]
fn bdf2_converges_at_second_order_on_a_swinging_strand() {
    // A 5 cm fibre (N = 3) swinging freely at large amplitude in its first bending mode
    // (largest curvature 20 rad/m: the tip moves 0.77 L), no gravity, no damping: a
    // smooth, nonlinear motion. Released from rest under gravity instead, the strand
    // also rings in its higher modes, which BDF2 hardly damps and no step here resolves
    // (measured orders 1.0-1.8). One period (0.2 s), the tip every 10 ms.
    let length = 0.05;
    let strand = cross_section_strand(
        round_fibre(1.0),
        3,
        length,
        Vector3::x(),
        [0.0; 3],
        0.0,
        0.0,
    );
    let q0: Vec<f64> = first_mode(&strand).iter().map(|x| 20.0 * x).collect();
    let (duration, sample) = (0.2, 0.01);
    // RK4 (explicit: the twist of the rotary inertia bounds its step near 3e-5 s)
    let (reference, _) = tip_samples(&strand, &q0, IntegratorKind::Rk4, 1e-5, duration, sample);
    let (check, _) = tip_samples(&strand, &q0, IntegratorKind::Rk4, 2e-5, duration, sample);
    let reference_error = max_distance(&reference, &check) / length;
    let excursion = reference
        .iter()
        .map(|p| (p - reference[0]).norm())
        .fold(0.0, f64::max)
        / length;
    println!("RK4 1e-5 vs 2e-5 s: {reference_error:.2e} L; tip excursion {excursion:.2} L");
    assert!(excursion > 0.3, "large amplitude: {excursion}");
    let mut finest = [0.0; 2];
    for (k, integrator) in [IntegratorKind::Bdf2, IntegratorKind::LinearlyImplicitEuler]
        .into_iter()
        .enumerate()
    {
        let errors: Vec<f64> = [200.0, 400.0, 800.0]
            .iter()
            .map(|rate| {
                let (tips, substeps) =
                    tip_samples(&strand, &q0, integrator, 1.0 / rate, duration, sample);
                // a uniform step: the order is that of the scheme, not of the step control
                assert_eq!(substeps, 0, "{integrator:?} at dt = 1/{rate} split steps");
                max_distance(&tips, &reference) / length
            })
            .collect();
        let orders: Vec<f64> = errors.windows(2).map(|w| (w[0] / w[1]).log2()).collect();
        println!("{integrator:?}: errors (/L) at dt = 1/200, 1/400, 1/800: {errors:?}, observed orders {orders:.3?}");
        // measured: BDF2 1.9e-2, 4.6e-3, 1.2e-3 L (orders 2.01, 1.94); LIE 0.16, 8.8e-2,
        // 4.7e-2 L (0.82, 0.91)
        let range = if integrator == IntegratorKind::Bdf2 {
            1.7..2.3
        } else {
            0.7..1.2
        };
        for order in &orders {
            assert!(range.contains(order), "{integrator:?}: orders {orders:?}");
        }
        // the reference is exact at this scale
        assert!(reference_error < 1e-4 * errors[2]);
        finest[k] = errors[2];
    }
    // at 1/800 s BDF2 is 39 times closer than implicit Euler
    assert!(finest[0] < finest[1] / 20.0, "{finest:?}");
}

/// Run a 25 cm fibre released horizontal under gravity, no damping, its twist seeded with
/// 1e-6 rad/m, for 2 s at dt = 1/30 s; returns (largest (E − E0)/(m g L) after the first
/// step, final (E − E0)/(m g L), largest twist, substeps).
fn released(stiffness: f64, integrator: IntegratorKind) -> (f64, f64, f64, usize) {
    let length = 0.25;
    let strand = cross_section_strand(
        round_fibre(stiffness),
        10,
        length,
        Vector3::x(),
        [0.0; 3],
        0.0,
        0.0,
    );
    let mut sim = simulation(&strand, integrator, 1.0 / 30.0, true);
    let dofs = strand.geometry.dofs();
    let q0: Vec<f64> = (0..dofs)
        .map(|i| if i % 3 == 0 { 1e-6 } else { 0.0 })
        .collect();
    sim.set_state(0, &q0, &vec![0.0; dofs]);
    let e0 = sim.energy(0);
    let scale = strand.material.mass_per_length * length * 9.81 * length;
    let mut rise = f64::NEG_INFINITY;
    let mut twist = 0.0f64;
    for _ in 0..60 {
        sim.step().expect("stable step");
        assert!(sim.q(0).iter().chain(sim.v(0)).all(|x| x.is_finite()));
        rise = rise.max((sim.energy(0) - e0) / scale);
        twist = sim
            .q(0)
            .iter()
            .step_by(3)
            .fold(twist, |m, x| m.max(x.abs()));
    }
    let last = (sim.energy(0) - e0) / scale;
    (rise, last, twist, sim.stats().substeps)
}

#[test]
fn bdf2_is_stable_and_dissipates_less_than_implicit_euler_on_a_stiff_strand_at_30_fps() {
    // N = 10, dt = 1/30 s, no friction or drag: the twist (rotary inertia) and the upper
    // bending modes have ω dt from ~10 to ~1e4, the first bending mode ω dt = 0.41 at 100
    // times the smooth preset's stiffness (1.3 at 1x, where large rotations also make
    // steps split: implicit Euler substeps, then BDF2 steps of twice the last substep).
    for stiffness in [100.0, 1.0] {
        let (lie_rise, lie_last, _, _) = released(stiffness, IntegratorKind::LinearlyImplicitEuler);
        let (rise, last, twist, substeps) = released(stiffness, IntegratorKind::Bdf2);
        println!(
            "stiffness x{stiffness}: BDF2 max (E - E0)/mgL {rise:.3e}, final {last:.3e}, \
             twist {twist:.2e}, {substeps} substeps; LIE max {lie_rise:.3e}, final {lie_last:.3e}"
        );
        // no energy created (the only dissipation is numerical): measured max −1.2e-2
        // (x100) and −1.8e-2 (x1), the first (implicit Euler) step's loss
        assert!(rise < 1e-6, "x{stiffness}: energy rises by {rise:e} mgL");
        // the stiff modes stay damped: the twist seeded at 1e-6 does not grow at 100x
        // (measured 1.8e-7); at 1x it is driven by the large rotations (1.4e-6)
        let twist_limit = if stiffness > 1.0 { 1e-6 } else { 1e-4 };
        assert!(twist < twist_limit, "x{stiffness}: twist {twist:e}");
        // but the resolved motion is damped less: implicit Euler loses 1.6 (x100) and 1.5
        // (x1) times as much energy over the 2 s
        assert!(
            lie_last < 1.3 * last,
            "x{stiffness}: LIE {lie_last:e}, BDF2 {last:e}"
        );
        if stiffness == 1.0 {
            assert!(substeps > 0, "the 1x case exercises variable steps");
        }
    }
}

#[test]
fn bdf2_forgets_its_history_when_the_state_is_set() {
    // After set_state the next step is a fresh start (implicit Euler), so a simulation
    // that ran before and one that did not continue identically from the same state.
    let strand = preset_strand(
        superhelix_runtime::model::material::Preset::Wavy,
        5,
        0.15,
        Vector3::x(),
    );
    let dofs = strand.geometry.dofs();
    let q0 = strand.natural.clone();
    let v0 = vec![0.0; dofs];
    let run = |warm_up: usize| {
        let mut sim = simulation(&strand, IntegratorKind::Bdf2, 1.0 / 30.0, true);
        for _ in 0..warm_up {
            sim.step().expect("step");
        }
        sim.set_state(0, &q0, &v0);
        for _ in 0..20 {
            sim.step().expect("step");
        }
        (sim.q(0).to_vec(), sim.v(0).to_vec())
    };
    let fresh = run(0);
    let after = run(7);
    assert_eq!(fresh, after);
    assert!(fresh.0.iter().zip(&q0).any(|(a, b)| a != b), "it moved");
}

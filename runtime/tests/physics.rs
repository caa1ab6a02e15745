//! Issue #2, points 3–5: energy conservation, small oscillations against Euler–Bernoulli,
//! static cantilever against F L³/(3EI).

mod common;
use common::*;
use nalgebra::{DMatrix, Vector3};
use superhelix_runtime::config::{IntegratorKind, KernelChoice, Mode, SimulationConfig};
use superhelix_runtime::kernels::kernel::{BodyField, EvalInput, StrandKernel, StrandTerms, Terms};
use superhelix_runtime::model::material::{CrossSection, Preset};
use superhelix_runtime::model::strand::{PointLoad, Strand};
use superhelix_runtime::{GenericKernel, HeadMotion, QuadratureRule, Simulation};

fn config(integrator: IntegratorKind, dt: f64) -> SimulationConfig {
    SimulationConfig {
        dt,
        integrator,
        kernels: KernelChoice::Generic,
        ..SimulationConfig::default()
    }
}

/// Hair of the smooth preset but E = 1 GPa, circular: EI = E π r⁴ / 4.
fn round_fibre() -> CrossSection {
    CrossSection {
        radius: 50e-6,
        ellipticity: 1.0,
        youngs_modulus: 1e9,
        poisson: 0.48,
        density: 1300.0,
        shear_factor: 1.0,
    }
}

#[test]
fn rk4_conserves_energy_of_a_curly_strand_without_dissipation() {
    // curly preset, N = 4, gamma = nu = 0, gravity, still head; released from its natural
    // shape sticking out sideways, it falls and swings.
    for rotary in [false, true] {
        let mut strand = preset_strand(Preset::Curly, 4, 0.08, Vector3::new(1.0, 0.0, 0.0));
        strand.internal_friction = 0.0;
        strand.air_drag = 0.0;
        if !rotary {
            strand.geometry.rotary_inertia = [0.0; 3];
        }
        // 0.2 s of free fall and swing; RK4 is unstable from dt = 4e-4 on (stiff twist)
        let (dt, steps) = (1e-4, 2000);
        let mut sim = Simulation::new(
            setup(
                vec![strand],
                config(IntegratorKind::Rk4, dt),
                Some(Vector3::new(0.0, 0.0, -9.81)),
                HeadMotion::Still,
            ),
            None,
        )
        .expect("valid setup");
        let e0 = sim.energy(0);
        let mut drift: f64 = 0.0;
        let mut kinetic_max: f64 = 0.0;
        for _ in 0..steps {
            sim.step().expect("step");
            drift = drift.max((sim.energy(0) - e0).abs());
            kinetic_max = kinetic_max.max(sim.kinetic_energy(0));
        }
        // the strand really moves: its kinetic energy reaches a few % of |E0|
        assert!(kinetic_max > 0.02 * e0.abs(), "max T = {kinetic_max:e}");
        let rel = drift / e0.abs();
        println!("rotary={rotary}: E0 = {e0:e}, max T = {kinetic_max:e}, max |E - E0| / |E0| = {rel:e} over {steps} steps");
        assert!(rel <= 1e-6, "energy drift {rel:e}");
    }
}

/// Generalized eigenpairs of K x = λ M x at q = 0, ascending.
fn eigenpairs(strand: &Strand) -> Vec<(f64, Vec<f64>)> {
    let n = strand.geometry.dofs();
    let mut kernel = GenericKernel::new(strand.geometry.clone(), QuadratureRule::Adaptive);
    let mut out = StrandTerms::new(n);
    let zero = vec![0.0; n];
    kernel.evaluate(
        &EvalInput {
            q: &zero,
            v: &zero,
            field: BodyField::zero(),
            terms: Terms {
                mass: true,
                ..Default::default()
            },
        },
        &mut out,
    );
    let m = DMatrix::from_fn(n, n, |i, j| out.mass[(i, j)]);
    let k = strand.stiffness_diagonal();
    let l = m.cholesky().expect("M is SPD").l();
    let linv = l.clone().try_inverse().expect("invertible");
    let c = &linv * DMatrix::from_diagonal(&nalgebra::DVector::from_vec(k)) * linv.transpose();
    let eig = c.symmetric_eigen();
    let mut pairs: Vec<(f64, Vec<f64>)> = (0..n)
        .map(|i| {
            // x = L⁻ᵀ z
            let x = linv.transpose() * eig.eigenvectors.column(i);
            (eig.eigenvalues[i], x.iter().copied().collect())
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    pairs
}

/// First-mode angular frequency measured from zero crossings of the tip's transverse
/// displacement, linearly implicit Euler at a step of 1/2000 of the period.
fn measured_frequency(strand: &Strand, omega_expected: f64, mode: &[f64]) -> f64 {
    let n = strand.geometry.dofs();
    let period = 2.0 * std::f64::consts::PI / omega_expected;
    let dt = period / 2000.0;
    let mut sim = Simulation::new(
        setup(
            vec![strand.clone()],
            config(IntegratorKind::LinearlyImplicitEuler, dt),
            None,
            HeadMotion::Still,
        ),
        None,
    )
    .expect("setup");
    // the first mode, small: largest curvature 1e-3 rad/m
    let scale = 1e-3 / mode.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let q0: Vec<f64> = mode.iter().map(|x| x * scale).collect();
    sim.set_state(0, &q0, &vec![0.0; n]);
    let length = strand.geometry.length();
    let tip = |sim: &Simulation| sim.position_at(0, length).z;
    let mut crossings = Vec::new();
    let mut prev = tip(&sim);
    while crossings.len() < 5 {
        sim.step().expect("step");
        let z = tip(&sim);
        if prev.signum() != z.signum() {
            // linear interpolation of the crossing time
            crossings.push(sim.time() - dt * z / (z - prev));
        }
        prev = z;
        assert!(sim.time() < 10.0 * period, "no oscillation");
    }
    // two full periods between crossings 1 and 5
    2.0 * std::f64::consts::PI / ((crossings[4] - crossings[0]) / 2.0)
}

#[test]
fn first_bending_frequency_matches_the_discrete_eigenvalue_and_euler_bernoulli() {
    let cs = round_fibre();
    let m = cs.material();
    let length: f64 = 0.2;
    let eb = 1.8751_f64.powi(2) * (m.stiffness[1] / (m.mass_per_length * length.powi(4))).sqrt();
    // the design page's discretisation errors: 27 %, 0.8 %, 0.19 %, 0.05 %
    let expected = [(1, 0.27), (5, 0.008), (10, 0.0019), (20, 0.0005)];
    let mut errors = Vec::new();
    for (n, expected_error) in expected {
        let strand = cross_section_strand(cs, n, length, Vector3::x(), [0.0; 3], 0.0, 0.0);
        let pairs = eigenpairs(&strand);
        let omega = pairs[0].0.sqrt();
        let error = omega / eb - 1.0;
        println!(
            "N = {n}: omega_1 = {omega:.6} rad/s, Euler-Bernoulli {eb:.6}, error {:.4} %",
            100.0 * error
        );
        assert!(
            error > 0.0,
            "the discrete model is stiffer than the continuum"
        );
        assert!(
            (error / expected_error - 1.0).abs() < 0.15,
            "N = {n}: error {error} vs about {expected_error}"
        );
        errors.push(error);
        if n <= 10 {
            let measured = measured_frequency(&strand, omega, &pairs[0].1);
            // implicit Euler at 2000 steps per period lowers the frequency by (ωh)²/3 =
            // 3.3e-6 (its amplification 1/(1 + iωh) turns by atan ωh a step); measured
            // within 1.3e-7 of that: the bound is 1e-6 around it
            let shift = -(2.0 * std::f64::consts::PI / 2000.0).powi(2) / 3.0;
            let deviation = measured / omega - 1.0;
            println!(
                "N = {n}: simulated {measured:.9} rad/s, {deviation:.3e} from the eigenvalue (implicit Euler: {shift:.3e})"
            );
            assert!(
                (deviation - shift).abs() < 1e-6,
                "simulated {measured} vs eigen {omega}: {deviation:e}, expected {shift:e}"
            );
        }
    }
    // second-order convergence: halving the element length divides the error by ~4
    for w in errors.windows(2).skip(1) {
        let ratio = w[0] / w[1];
        assert!((3.0..5.0).contains(&ratio), "convergence ratio {ratio}");
    }
}

#[test]
fn static_tip_load_deflects_as_f_l3_over_3ei() {
    let cs = round_fibre();
    let ei = cs.material().stiffness[1];
    let length: f64 = 0.1;
    // deflection 1e-4 L: geometric nonlinearity ~1e-8, far below the tolerance
    let delta = 1e-4 * length;
    let force = 3.0 * ei * delta / length.powi(3);
    let mut errors = Vec::new();
    for n in [2, 5, 10, 20] {
        let mut strand = cross_section_strand(cs, n, length, Vector3::x(), [0.0; 3], 0.0, 0.0);
        strand.point_loads.push(PointLoad {
            s: length,
            force: Vector3::new(0.0, 0.0, -force),
            follows: false,
            torque: nalgebra::Vector3::zeros(),
        });
        let cfg = SimulationConfig {
            mode: Mode::Static,
            ..config(IntegratorKind::LinearlyImplicitEuler, 0.01)
        };
        let mut sim = Simulation::new(setup(vec![strand], cfg, None, HeadMotion::Still), None)
            .expect("setup");
        let report = sim.solve_static().expect("static solve")[0];
        assert!(report.converged, "{report:?}");
        let tip = sim.position_at(0, length);
        let error = -tip.z / delta - 1.0;
        println!("N = {n}: tip deflection {:.6e} vs F L^3/3EI = {delta:.6e}, error {:.4} % ({} Newton iterations)", -tip.z, 100.0 * error, report.iterations);
        // Piecewise-constant curvature equal to the element mean of M(s)/EI turns
        // δ = ∫ κ(s)(L − s) ds into its midpoint rule: δ_N = δ (1 − 1/(4N²)) exactly.
        let analytic = -1.0 / (4.0 * (n * n) as f64);
        assert!(
            (error - analytic).abs() < 1e-6,
            "N = {n}: error {error} vs -1/(4N^2) = {analytic}"
        );
        errors.push(error.abs());
        if n == 20 {
            assert!(error.abs() < 0.005, "N = 20: error {error}");
        }
    }
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "no convergence with N: {errors:?}");
    }
}

#[test]
fn damped_dynamics_settle_into_the_static_equilibrium_with_every_implicit_integrator() {
    // A wavy strand (N = 5) released sideways under gravity with internal friction and
    // drag comes to rest where the static solver puts it: four solvers, one answer.
    let strand = preset_strand(Preset::Wavy, 5, 0.15, Vector3::new(1.0, 0.0, 0.0));
    let gravity = Some(Vector3::new(0.0, 0.0, -9.81));
    let static_cfg = SimulationConfig {
        mode: Mode::Static,
        ..config(IntegratorKind::LinearlyImplicitEuler, 0.01)
    };
    let mut statics = Simulation::new(
        setup(vec![strand.clone()], static_cfg, gravity, HeadMotion::Still),
        None,
    )
    .expect("setup");
    let report = statics.solve_static().expect("static")[0];
    assert!(report.converged, "{report:?}");
    let q_static = statics.q(0).to_vec();
    let scale = q_static.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let mut finals = Vec::new();
    for integrator in [
        IntegratorKind::LinearlyImplicitEuler,
        IntegratorKind::NewtonImplicitEuler,
        IntegratorKind::Bdf2,
    ] {
        let mut sim = Simulation::new(
            setup(
                vec![strand.clone()],
                config(integrator, 1.0 / 30.0),
                gravity,
                HeadMotion::Still,
            ),
            None,
        )
        .expect("setup");
        for _ in 0..900 {
            sim.step().expect("step");
        }
        let worst = sim
            .q(0)
            .iter()
            .zip(&q_static)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        println!(
            "{integrator:?}: max |q - q_static| / max |q_static| = {:e}, stats {:?}",
            worst / scale,
            sim.stats()
        );
        // 30 s of damped motion: the residual motion has decayed far below 1e-6
        assert!(
            worst < 1e-6 * scale,
            "{integrator:?} ends {worst:e} from the static solution"
        );
        assert!(sim.max_speed() < 1e-6 * scale);
        if integrator == IntegratorKind::NewtonImplicitEuler {
            assert_eq!(sim.stats().newton_unconverged, 0);
            assert!(sim.stats().newton_iterations >= 900);
        }
        finals.push(sim.q(0).to_vec());
    }
    // BDF2 and implicit Euler come to the same static shape (an equilibrium is a fixed
    // point of both)
    let apart = finals[0]
        .iter()
        .zip(&finals[2])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!(
        "LIE vs BDF2 final shapes: {:e} of max |q_static|",
        apart / scale
    );
    assert!(apart < 2e-6 * scale);
}

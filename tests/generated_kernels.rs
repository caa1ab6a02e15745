//! The generated kernels are interchangeable with the generic path: the same scene run
//! on either gives the same motion (issue #3).

use superhelix::runtime::config::{
    IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup, StrandSetup,
};
use superhelix::runtime::model::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::model::strand::{Strand, StrandGeometry};
use superhelix::runtime::{Environment, HeadMotion, Simulation};
use superhelix::runtime::{Matrix3, Vector3};

fn setup(n: usize, kernels: KernelChoice, integrator: IntegratorKind) -> SimulationSetup {
    let strands = Preset::ALL
        .iter()
        .map(|&preset| {
            let p = preset.params();
            let material = p.cross_section.material();
            let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
            Strand {
                name: preset.name().to_string(),
                geometry: StrandGeometry::new(
                    Vector3::new(0.1, 0.0, 0.0),
                    Matrix3::identity(),
                    vec![0.2 / n as f64; n],
                    &material,
                ),
                material,
                natural: (0..n).flat_map(|_| natural).collect(),
                internal_friction: p.internal_friction,
                air_drag: p.air_drag,
                point_loads: Vec::new(),
                ends: Default::default(),
            }
        })
        .map(|s| StrandSetup {
            charge_per_length: None,
            tip: None,
            q0: s.natural.clone(),
            group: s.name.clone(),
            strand: s,
        })
        .collect();
    SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            dt: 1.0 / 30.0,
            duration: 1.0,
            integrator,
            kernels,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        },
        head: HeadMotion::Oscillate {
            axis: Vector3::z(),
            amplitude: 10f64.to_radians(),
            frequency_hz: 1.0,
            center: Vector3::zeros(),
        },
        strands,
        bodies: Vec::new(),
        samples_per_element: 2,
        output: Default::default(),
    }
}

/// Final (q, q̇) of every strand after 1 s.
fn run(n: usize, kernels: KernelChoice, integrator: IntegratorKind) -> Vec<(Vec<f64>, Vec<f64>)> {
    let mut sim = Simulation::new(setup(n, kernels, integrator), superhelix::kernel_factory())
        .expect("valid setup");
    for i in 0..sim.strand_count() {
        assert_eq!(
            sim.uses_generated_kernel(i),
            kernels == KernelChoice::Generated
        );
    }
    for _ in 0..30 {
        sim.step().expect("stable step");
    }
    (0..sim.strand_count())
        .map(|i| (sim.q(i).to_vec(), sim.v(i).to_vec()))
        .collect()
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn generated_and_generic_kernels_give_the_same_motion() {
    let mut worst = 0.0f64;
    for (n, integrator) in [
        (5, IntegratorKind::LinearlyImplicitEuler),
        (10, IntegratorKind::LinearlyImplicitEuler),
        (5, IntegratorKind::NewtonImplicitEuler),
        (5, IntegratorKind::Bdf2),
    ] {
        let generated = run(n, KernelChoice::Generated, integrator);
        let generic = run(n, KernelChoice::Generic, integrator);
        for ((qa, va), (qb, vb)) in generated.iter().zip(&generic) {
            // per-evaluation agreement is ~1e-14; 30 implicit steps of a damped motion
            // amplify it little (the tolerance leaves three orders of magnitude)
            let dev = max_rel(qa, qb).max(max_rel(va, vb));
            worst = worst.max(dev);
            assert!(
                dev < 1e-9,
                "N={n} {integrator:?}: relative deviation {dev:.2e}"
            );
        }
    }
    println!("generated vs generic after 1 s: worst relative deviation of q, q̇ {worst:.2e}");
}

#[test]
fn generated_kernels_are_refused_for_a_size_without_them() {
    let available = superhelix::kernel_factory()
        .map(|f| f.available())
        .unwrap_or_default();
    let n = (1..100)
        .find(|n| !available.contains(n))
        .expect("some N missing");
    let err = match Simulation::new(
        setup(
            n,
            KernelChoice::Generated,
            IntegratorKind::LinearlyImplicitEuler,
        ),
        superhelix::kernel_factory(),
    ) {
        Ok(_) => panic!("N={n} has no generated kernel and must be refused"),
        Err(e) => e.to_string(),
    };
    assert!(err.contains(&format!("N = {n}")), "{err}");
    assert!(err.contains("SUPERHELIX_N"), "{err}");
}

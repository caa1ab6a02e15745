//! Hard cases that must stay numerically stable.
//!
//! Issue #2, point 6: every preset, N = 10, dt = 1/30 s, the head oscillating at 3 Hz
//! through ±40° for 10 s: all values finite, bounded kinetic energy, and the same result
//! run to run.

use superhelix::runtime::{Matrix3, Vector3};
use superhelix::runtime::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::simulation::{IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup, StrandSetup};
use superhelix::runtime::strand::{Strand, StrandGeometry};
use superhelix::runtime::{Environment, HeadMotion, Simulation};

fn preset_strand(preset: Preset, n: usize, length: f64) -> Strand {
    let p = preset.params();
    let material = p.cross_section.material();
    // root on a 10 cm head, pointing sideways: n0 = x, n1 = y, n2 = z
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    Strand {
        name: preset.name().to_string(),
        geometry: StrandGeometry::new(Vector3::new(0.1, 0.0, 0.0), Matrix3::identity(), vec![length / n as f64; n], &material),
        material,
        natural: (0..n).flat_map(|_| natural).collect(),
        internal_friction: p.internal_friction,
        air_drag: p.air_drag,
        point_loads: Vec::new(),
    }
}

/// Run every preset on a head oscillating at `hz` through ±`deg`; returns the final q of
/// each strand and the largest kinetic energy seen, relative to the bound
/// ½ m (Ω_max (r + L))² of a strand dragged rigidly at the head's top speed.
fn run(n: usize, dt: f64, duration: f64, hz: f64, deg: f64) -> (Vec<Vec<f64>>, f64) {
    let length = 0.25;
    let strands: Vec<Strand> = Preset::ALL.iter().map(|&p| preset_strand(p, n, length)).collect();
    let amplitude = deg.to_radians();
    let setup = SimulationSetup {
        config: SimulationConfig {
            dt,
            duration,
            integrator: IntegratorKind::LinearlyImplicitEuler,
            kernels: KernelChoice::Auto,
            ..SimulationConfig::default()
        },
        environment: Environment { gravity: Some(Vector3::new(0.0, 0.0, -9.81)) },
        head: HeadMotion::Oscillate { axis: Vector3::z(), amplitude, frequency_hz: hz, center: Vector3::zeros() },
        strands: strands.into_iter().map(|s| StrandSetup { q0: s.natural.clone(), strand: s }).collect(),
        samples_per_element: 4,
    };
    let mut sim = Simulation::new(setup, superhelix::kernel_factory()).expect("valid setup");
    let omega_max = amplitude * 2.0 * std::f64::consts::PI * hz;
    let mut worst: f64 = 0.0;
    let steps = (duration / dt).round() as usize;
    for _ in 0..steps {
        sim.step().expect("stable step");
        for i in 0..sim.strand_count() {
            let mass = sim.strand(i).material.mass_per_length * length;
            let bound = 0.5 * mass * (omega_max * (0.1 + length)).powi(2);
            worst = worst.max(sim.kinetic_energy(i) / bound);
            assert!(sim.q(i).iter().chain(sim.v(i)).all(|x| x.is_finite()));
        }
    }
    ((0..sim.strand_count()).map(|i| sim.q(i).to_vec()).collect(), worst)
}

#[test]
fn every_preset_survives_a_3hz_40deg_shake_at_30_fps_deterministically() {
    let (first, worst) = run(10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    println!("largest kinetic energy / rigid-drag bound: {worst:.3}");
    // the strand moves relative to the head no faster than the head itself drags it
    assert!(worst < 1.0, "kinetic energy {worst} x the rigid-drag bound");
    let (second, _) = run(10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    assert_eq!(first, second, "two runs differ");
}

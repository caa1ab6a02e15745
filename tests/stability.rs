//! Hard cases that must stay numerically stable.
//!
//! Issue #2, point 6: every preset, N = 10, dt = 1/30 s, the head oscillating at 3 Hz
//! through ±40° for 10 s: all values finite, bounded kinetic energy, and the same result
//! run to run.

use superhelix::runtime::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::simulation::{
    IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup, StrandSetup,
};
use superhelix::runtime::strand::{Strand, StrandGeometry};
use superhelix::runtime::{Environment, HeadMotion, Simulation};
use superhelix::runtime::{Matrix3, Vector3};

fn preset_strand(preset: Preset, n: usize, length: f64) -> Strand {
    let p = preset.params();
    let material = p.cross_section.material();
    // root on a 10 cm head, pointing sideways: n0 = x, n1 = y, n2 = z
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    Strand {
        name: preset.name().to_string(),
        geometry: StrandGeometry::new(
            Vector3::new(0.1, 0.0, 0.0),
            Matrix3::identity(),
            vec![length / n as f64; n],
            &material,
        ),
        material,
        natural: (0..n).flat_map(|_| natural).collect(),
        internal_friction: p.internal_friction,
        air_drag: p.air_drag,
        point_loads: Vec::new(),
    }
}

/// Largest kinetic energy (relative to the head) seen in the first and the second half
/// of a run, in units of ½ m (Ω_max (r + L))²: the kinetic energy of the strand dragged
/// rigidly at the head's top speed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct KineticPeaks {
    first_half: f64,
    second_half: f64,
    /// Largest ratio, over the strands, of the mean kinetic energy of the second half to
    /// that of the first.
    mean_growth: f64,
}

/// Run every preset on a head oscillating at `hz` through ±`deg`; returns the final q of
/// each strand and the kinetic-energy peaks (worst strand).
fn run(n: usize, dt: f64, duration: f64, hz: f64, deg: f64) -> (Vec<Vec<f64>>, KineticPeaks) {
    let length = 0.25;
    let strands: Vec<Strand> = Preset::ALL
        .iter()
        .map(|&p| preset_strand(p, n, length))
        .collect();
    let amplitude = deg.to_radians();
    let setup = SimulationSetup {
        config: SimulationConfig {
            dt,
            duration,
            integrator: IntegratorKind::LinearlyImplicitEuler,
            kernels: KernelChoice::Auto,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        },
        head: HeadMotion::Oscillate {
            axis: Vector3::z(),
            amplitude,
            frequency_hz: hz,
            center: Vector3::zeros(),
        },
        strands: strands
            .into_iter()
            .map(|s| StrandSetup {
                q0: s.natural.clone(),
                strand: s,
            })
            .collect(),
        samples_per_element: 4,
    };
    let mut sim = Simulation::new(setup, superhelix::kernel_factory()).expect("valid setup");
    let omega_max = amplitude * 2.0 * std::f64::consts::PI * hz;
    let mut peaks = KineticPeaks {
        first_half: 0.0,
        second_half: 0.0,
        mean_growth: 0.0,
    };
    let steps = (duration / dt).round() as usize;
    let mut sums = vec![[0.0f64; 2]; sim.strand_count()];
    for step in 0..steps {
        sim.step().expect("stable step");
        for (i, sum) in sums.iter_mut().enumerate() {
            let mass = sim.strand(i).material.mass_per_length * length;
            let scale = 0.5 * mass * (omega_max * (0.1 + length)).powi(2);
            let k = sim.kinetic_energy(i) / scale;
            let peak = if step < steps / 2 {
                &mut peaks.first_half
            } else {
                &mut peaks.second_half
            };
            *peak = peak.max(k);
            sum[usize::from(step >= steps / 2)] += k;
            assert!(sim.q(i).iter().chain(sim.v(i)).all(|x| x.is_finite()));
        }
    }
    peaks.mean_growth = sums.iter().map(|s| s[1] / s[0]).fold(0.0, f64::max);
    println!("solver: {:?}", sim.stats());
    (
        (0..sim.strand_count()).map(|i| sim.q(i).to_vec()).collect(),
        peaks,
    )
}

#[test]
fn every_preset_survives_a_3hz_40deg_shake_at_30_fps_deterministically() {
    let (first, peaks) = run(10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    println!("kinetic energy peaks / rigid-drag scale: {peaks:?}");
    // Bounded: a whip concentrates energy in its tip, so the relative kinetic energy may
    // exceed the rigid-drag scale a few times, but never beyond 10x the scale (tip 3x the
    // head's speed), and it must not grow: under periodic forcing with friction and drag
    // each strand's mean kinetic energy over the second half stays within 1.5x that of the
    // first. (Means rather than peaks, which are more sensitive to the irregular
    // whipping. Measured: peaks 1.31 and 1.59 times the scale, mean growth 1.06, the same
    // to 1e-6 on the generic and the generated kernels.)
    assert!(
        peaks.first_half < 10.0 && peaks.second_half < 10.0,
        "{peaks:?}"
    );
    assert!(peaks.mean_growth < 1.5, "kinetic energy grows: {peaks:?}");
    let (second, _) = run(10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    assert_eq!(first, second, "two runs differ");
}

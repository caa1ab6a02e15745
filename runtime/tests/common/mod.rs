//! Helpers shared by the runtime's integration tests.
#![allow(dead_code)]

use nalgebra::{Matrix3, Vector3};
use superhelix_runtime::model::strand::StrandGeometry;

/// Deterministic xorshift generator (tests only).
pub struct Rng(pub u64);

impl Rng {
    pub fn next_f64(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [-1, 1].
    pub fn sym(&mut self) -> f64 {
        2.0 * self.next_f64() - 1.0
    }
    pub fn unit(&mut self) -> Vector3<f64> {
        loop {
            let v = Vector3::new(self.sym(), self.sym(), self.sym());
            if v.norm() > 0.1 {
                return v.normalize();
            }
        }
    }
}

/// A rotation from an axis-angle vector.
pub fn rotation(axis_angle: Vector3<f64>) -> Matrix3<f64> {
    *nalgebra::Rotation3::new(axis_angle).matrix()
}

/// A strand geometry with unequal element lengths and a tilted root frame.
pub fn geometry(n: usize, length: f64, rng: &mut Rng) -> StrandGeometry {
    let mut lengths: Vec<f64> = (0..n).map(|_| 0.5 + rng.next_f64()).collect();
    let total: f64 = lengths.iter().sum();
    lengths.iter_mut().for_each(|l| *l *= length / total);
    StrandGeometry {
        root_position: Vector3::new(0.01, -0.02, 0.03),
        root_frame: rotation(Vector3::new(0.3, -0.7, 1.1)),
        lengths,
        mass_per_length: 1.0e-5,
        // exaggerated (r ~ 1 cm) so that its terms are visible at test tolerances
        rotary_inertia: [2.0e-9, 0.8e-9, 1.2e-9],
        floating: false,
    }
}

/// q whose elements have |d|·l equal to the given values (cycled), random directions;
/// a zero-twist planar arc where `planar` is set.
pub fn q_with_wl(geom: &StrandGeometry, wl: &[f64], rng: &mut Rng) -> Vec<f64> {
    let mut q = Vec::new();
    for (k, l) in geom.lengths.iter().enumerate() {
        let target = wl[k % wl.len()] / l;
        let dir = rng.unit();
        q.extend_from_slice(&[dir[0] * target, dir[1] * target, dir[2] * target]);
    }
    q
}

use superhelix_runtime::config::{SimulationConfig, SimulationSetup, StrandSetup};
use superhelix_runtime::model::material::{helix_curvature, CrossSection, HelixForm, Preset};
use superhelix_runtime::model::strand::Strand;
use superhelix_runtime::{Environment, HeadMotion};

/// A strand of N equal elements from a preset, root at the origin, n0 = `direction`,
/// n1 ⟂ n0; natural shape from the preset's helix (exact form); γ and ν from the preset.
pub fn preset_strand(preset: Preset, n: usize, length: f64, direction: Vector3<f64>) -> Strand {
    let p = preset.params();
    cross_section_strand(
        p.cross_section,
        n,
        length,
        direction,
        helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact),
        p.internal_friction,
        p.air_drag,
    )
}

/// A strand from a cross-section and a uniform natural curvature.
pub fn cross_section_strand(
    cs: CrossSection,
    n: usize,
    length: f64,
    direction: Vector3<f64>,
    natural: [f64; 3],
    gamma: f64,
    nu: f64,
) -> Strand {
    let material = cs.material();
    let n0 = direction.normalize();
    let helper = if n0.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let n1 = (helper - n0 * n0.dot(&helper)).normalize();
    let n2 = n0.cross(&n1);
    let frame = Matrix3::from_columns(&[n0, n1, n2]);
    Strand {
        name: format!("strand-n{n}"),
        geometry: StrandGeometry::new(
            Vector3::zeros(),
            frame,
            vec![length / n as f64; n],
            &material,
        ),
        material,
        natural: (0..n).flat_map(|_| natural).collect(),
        internal_friction: gamma,
        air_drag: nu,
        point_loads: Vec::new(),
        ends: Default::default(),
    }
}

/// A setup with these strands starting at their natural shape, at rest.
pub fn setup(
    strands: Vec<Strand>,
    config: SimulationConfig,
    gravity: Option<Vector3<f64>>,
    head: HeadMotion,
) -> SimulationSetup {
    SimulationSetup {
        electrostatics: None,
        contacts: None,
        config,
        environment: Environment { gravity },
        head,
        strands: strands
            .into_iter()
            .map(|s| StrandSetup {
                charge_per_length: None,
                tip: None,
                q0: s.natural.clone(),
                group: s.name.clone(),
                strand: s,
            })
            .collect(),
        bodies: Vec::new(),
        samples_per_element: 4,
        output: Default::default(),
    }
}

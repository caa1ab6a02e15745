use superhelix::runtime::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::simulation::{IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup, StrandSetup};
use superhelix::runtime::strand::{Strand, StrandGeometry};
use superhelix::runtime::{Environment, HeadMotion, Simulation, Matrix3, Vector3};
fn main() {
    let preset = Preset::from_name(&std::env::var("PRESET").unwrap_or("wavy".into())).unwrap(); let n = 10; let length = 0.25;
    let p = preset.params();
    let material = p.cross_section.material();
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    let s = Strand { name: "w".into(), geometry: StrandGeometry::new(Vector3::new(0.1,0.,0.), Matrix3::identity(), vec![length/n as f64; n], &material), material, natural: (0..n).flat_map(|_| natural).collect(), internal_friction: p.internal_friction, air_drag: p.air_drag, point_loads: vec![] };
    let head = if std::env::args().nth(1).as_deref() == Some("still") { HeadMotion::Still } else { HeadMotion::Oscillate { axis: Vector3::z(), amplitude: 40f64.to_radians(), frequency_hz: 3.0, center: Vector3::zeros() } };
    let setup = SimulationSetup { config: SimulationConfig { dt: std::env::var("DT").ok().and_then(|x| x.parse().ok()).unwrap_or(1.0/30.0), integrator: if std::env::var("NEWTON").is_ok() { IntegratorKind::NewtonImplicitEuler } else { IntegratorKind::LinearlyImplicitEuler }, kernels: KernelChoice::Generic, ..Default::default() }, environment: Environment { gravity: Some(Vector3::new(0.,0.,-9.81)) }, head, strands: vec![StrandSetup { q0: s.natural.clone(), strand: s }], samples_per_element: 4 };
    let mut sim = Simulation::new(setup, None).unwrap();
    println!("natural {:?}", natural);
    let every: usize = std::env::var("EVERY").ok().and_then(|x| x.parse().ok()).unwrap_or(1); for k in 0..40*every { let r = sim.step(); if k % every != every - 1 { continue; } let r = sim.step(); let q = sim.q(0); let mq = q.iter().fold(0f64, |m, x| m.max(x.abs())); let iq = q.iter().enumerate().max_by(|a,b| a.1.abs().total_cmp(&b.1.abs())).unwrap().0; let iv = sim.v(0).iter().enumerate().max_by(|a,b| a.1.abs().total_cmp(&b.1.abs())).unwrap().0; print!("iq={iq} iv={iv} "); println!("{k} t={:.3} max|q|={mq:.3e} max|v|={:.3e} T={:.3e} stats={:?} {:?}", sim.time(), sim.max_speed(), sim.kinetic_energy(0), sim.stats(), r.err()); }
}

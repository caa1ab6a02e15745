//! The humidity of the air, end to end: a scene's `environment.relative_humidity` makes a
//! horizontal cantilever of a preset heavier and softer, and its static tip deflection
//! under gravity grows as the mass over the bending stiffness.

use superhelix_runtime::model::humidity::HumidityScaling;
use superhelix_runtime::{parse_scene, Simulation};

const LENGTH: f64 = 0.01;

/// Static tip deflection (m, downwards) of a horizontal smooth-preset strand under
/// gravity, at `environment` (a line of `[environment]`, or empty).
fn tip_deflection(environment: &str) -> f64 {
    let text = format!(
        "[simulation]\nmode = \"static\"\n[environment]\n{environment}\n\
         [[strands]]\npreset = \"smooth\"\nlength = {LENGTH}\nelements = 10\n\
         direction = [1.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n"
    );
    let setup = parse_scene(&text).expect("valid scene");
    let mut sim = Simulation::new(setup, None).expect("simulation");
    let report = sim.solve_static().expect("static solve")[0];
    assert!(report.converged, "{report:?}");
    -sim.position_at(0, LENGTH).z
}

#[test]
fn a_cantilever_sags_more_in_humid_air_and_less_in_dry_air() {
    let plain = tip_deflection("");
    let at65 = tip_deflection("relative_humidity = 65");
    let wet = tip_deflection("relative_humidity = 100");
    let dry = tip_deflection("relative_humidity = 0");
    assert_eq!(at65, plain, "65 % is the presets' own humidity");
    assert!(
        plain > 0.0 && plain < 1e-2 * LENGTH,
        "small deflection: {plain}"
    );
    assert!(wet > at65, "heavier and softer at 100 %: {wet} vs {at65}");
    assert!(dry < at65, "lighter and stiffer at 0 %: {dry} vs {at65}");
    // linear cantilever under its weight: δ = ρS g L⁴ / (8 EI), so δ ∝ mass / (E r⁴)
    for (rh, deflection) in [(100.0, wet), (0.0, dry)] {
        let f = HumidityScaling::at(rh).unwrap();
        let predicted = f.mass_per_length / (f.youngs_modulus * f.radius.powi(4));
        let ratio = deflection / at65;
        println!("RH {rh} %: deflection {deflection:.6e} m, ratio to 65 % {ratio:.6} (linear theory {predicted:.6})");
        assert!(
            (ratio / predicted - 1.0).abs() < 1e-4,
            "RH {rh}: ratio {ratio} vs {predicted}"
        );
    }
}

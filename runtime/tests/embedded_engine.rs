//! `engine = "embedded"` in a scene: the same steps as the runtime engine, and a clear
//! refusal, naming the field, of what the embedded engine does not do.

use superhelix_runtime::{parse_scene, Error, Simulation};

/// Two strands of different N (two fixed-N groups) on a head shaking at 2 Hz by ±30°,
/// gravity, the presets' drag and friction.
fn scene(engine: &str, extra: &str) -> String {
    format!(
        r#"
[simulation]
dt = 0.03333333333333333
duration = 0.5
engine = "{engine}"
{extra}

[environment]
gravity = [0.0, 0.0, -9.81]

[head]
motion = {{ kind = "oscillate", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }}

[[strands]]
name = "curly"
root = [0.09, 0.0, 0.0]
direction = [1.0, 0.0, -1.0]
length = 0.2
elements = 5
preset = "curly"

[[strands]]
name = "wavy"
root = [0.0, 0.09, 0.0]
direction = [0.0, 1.0, -1.0]
length = 0.25
elements = 8
preset = "wavy"
"#
    )
}

fn simulation(text: &str) -> superhelix_runtime::Result<Simulation> {
    let setup = parse_scene(text)?;
    Simulation::new(
        setup,
        Some(superhelix_runtime::kernels::closed_form::kernel_factory()),
    )
}

#[test]
fn embedded_engine_takes_the_runtime_engines_steps() {
    let mut runtime = simulation(&scene("runtime", "")).expect("valid scene");
    let mut embedded = simulation(&scene("embedded", "")).expect("valid scene");
    assert!(embedded.kernel_description(0).contains("embedded"));
    let mut worst: f64 = 0.0;
    for _ in 0..15 {
        runtime.step().expect("runtime step");
        embedded.step().expect("embedded step");
        for i in 0..2 {
            let (a, b) = (runtime.q(i), embedded.q(i));
            let scale = a.iter().fold(1.0f64, |m, x| m.max(x.abs()));
            for (x, y) in a.iter().zip(b) {
                worst = worst.max((x - y).abs() / scale);
            }
        }
    }
    assert!(worst <= 1e-12, "largest relative |Δq| {worst:.3e}");
    // the checks after the fact act on both sides alike
    assert_eq!(runtime.stats().substeps, embedded.stats().substeps);
}

#[test]
fn embedded_engine_refuses_what_it_does_not_do() {
    let refused = |text: &str, field: &str| match simulation(text) {
        Err(Error::Invalid(errors)) => assert!(
            errors.iter().any(|e| e.to_string().contains(field)),
            "{field} not named in {errors:?}"
        ),
        Err(other) => panic!("expected a field error naming {field}, got {other}"),
        Ok(_) => panic!("expected {field} to be refused"),
    };
    refused(
        &scene("embedded", "integrator = \"bdf2\""),
        "simulation.engine",
    );
    refused(
        &scene("embedded", "kernels = \"generic\""),
        "simulation.kernels",
    );
    refused(&scene("embedded", "mode = \"static\""), "simulation.engine");
    let with_load =
        scene("embedded", "") + "[[strands.point_loads]]\ns = 0.25\nforce = [0.0, 0.0, -1e-6]\n";
    refused(&with_load, "strands[1].point_loads");
    let odd_n = scene("embedded", "").replace("elements = 8", "elements = 7");
    refused(&odd_n, "SUPERHELIX_N=7");
}

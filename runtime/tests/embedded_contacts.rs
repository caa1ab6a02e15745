//! The embedded engine's contacts (the fixed-N step of `superhelix-kernels` with
//! colliders) against the runtime engine's on the same scene: a patch of strands falling
//! onto a ball, with each friction model, the contacts that start within a step caught by
//! the depth check on both (`predict = false`, the embedded engine's only mode).

use superhelix_runtime::config::Engine;
use superhelix_runtime::{engine_for, parse_scene, Simulation};

/// Ball radius and strand length, m.
const BALL: f64 = 0.1;
const LENGTH: f64 = 0.2;

/// Four horizontal wavy strands of N = 5 rooted in a row 3 cm above a ball's top (4 cm
/// across), falling onto it
/// for `duration` s on `engine`, with `friction` and the prediction as given.
fn scene(engine: &str, friction: &str, predict: Option<bool>, duration: f64) -> String {
    let predict = predict.map_or(String::new(), |p| format!("predict = {p}"));
    format!(
        r#"
[simulation]
duration = {duration}
engine = "{engine}"

[[bodies]]
name = "ball"
shape = "sphere"
radius = {BALL}
center = [0.0, 0.0, 0.0]

[contacts]
radius = 1e-3
friction = "{friction}"
{predict}

[[patches]]
name = "patch"
count = [4, 1]
size = [0.04, 0.0]
length = {LENGTH}
elements = 5
preset = "wavy"
center = [0.0, 0.0, 0.13]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
"#
    )
}

/// The centrelines of every strand (4 points per element), world coordinates.
fn centrelines(sim: &mut Simulation, strands: usize) -> Vec<[f64; 3]> {
    (0..strands)
        .flat_map(|i| sim.centreline_world(i, 4))
        .collect()
}

/// Each friction model, 1 s of falling onto the ball: the embedded engine's centrelines
/// are the runtime engine's to 1e-12 L at every step (the same law, queries and checks on
/// both engines; their steps' arithmetic differs in order only, as without contacts),
/// 1e-8 L with Coulomb friction, whose anchors' stick-or-slide switch amplifies the
/// round-off; the strands land (a centreline point within the contact radius of the
/// ball at the end) and no point of them goes more than 0.5 mm into it on either engine.
/// A rule that differs parts them by millimetres (the contacts that start within a step
/// predicted on one engine only parted such a patch by 3.6 mm).
#[test]
fn the_embedded_engine_lands_strands_on_a_ball_as_the_runtime_does() {
    // the round-off of two implementations of the same arithmetic (one step: 3e-17 m);
    // a Coulomb anchor's stick-or-slide switch amplifies it (measured: 1e-9 m over 1 s)
    for (friction, bound) in [("none", 1e-12), ("viscous", 1e-12), ("coulomb", 1e-8)] {
        let setup =
            |engine| parse_scene(&scene(engine, friction, Some(false), 1.0)).expect("scene");
        let mut embedded = Simulation::new(setup("embedded"), None).expect("embedded");
        let mut runtime = Simulation::new(setup("runtime"), None).expect("runtime");
        assert_eq!(embedded.engine(), Engine::Embedded);
        assert_eq!(runtime.engine(), Engine::Runtime);
        let mut deepest = [0.0f64; 2];
        let mut worst = 0.0f64;
        while runtime.time() < 1.0 - 1e-9 {
            embedded.step().expect("embedded step");
            runtime.step().expect("runtime step");
            let (a, b) = (centrelines(&mut embedded, 4), centrelines(&mut runtime, 4));
            for (p, q) in a.iter().zip(&b) {
                let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
                worst = worst.max(d);
            }
            deepest[0] = deepest[0].max(embedded.max_penetration().expect("contacts"));
            deepest[1] = deepest[1].max(runtime.max_penetration().expect("contacts"));
        }
        assert!(
            worst <= bound * LENGTH,
            "{friction}: the engines part by {worst:e} m"
        );
        assert!(
            deepest.iter().all(|&d| d <= 5e-4),
            "{friction}: deepest points {deepest:?} m (embedded, runtime)"
        );
        let nearest = centrelines(&mut embedded, 4)
            .iter()
            .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - BALL)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (-5e-4..=1e-3).contains(&nearest),
            "{friction}: the strands end {nearest:e} m from the ball (deepest {deepest:?})"
        );
    }
}

/// `engine = "auto"` runs a scene with contacts on the embedded engine when it does not
/// ask for the contacts that start within a step to be predicted (`predict = false`),
/// and on the runtime engine, naming `contacts.predict`, when it does (the default);
/// `engine = "embedded"` with the prediction on is refused, naming the field.
#[test]
fn auto_takes_the_embedded_engine_for_contacts_without_prediction() {
    let setup = |predict| parse_scene(&scene("auto", "viscous", predict, 0.1)).expect("scene");
    assert_eq!(engine_for(&setup(Some(false))), (Engine::Embedded, None));
    let (engine, reason) = engine_for(&setup(None));
    assert_eq!(engine, Engine::Runtime);
    let reason = reason.expect("a reason");
    assert_eq!(reason.field, "contacts.predict", "{reason:?}");
    let refused = Simulation::new(
        parse_scene(&scene("embedded", "viscous", Some(true), 0.1)).expect("scene"),
        None,
    );
    let message = refused.err().expect("refused").to_string();
    assert!(message.contains("contacts.predict"), "{message}");
}

/// A run of the embedded engine with Coulomb contacts stopped halfway, its state taken
/// and restored into a new simulation of the same scene, ends where the run without the
/// stop does, bit for bit: the anchors, allowances and root zones are in the state.
#[test]
fn an_embedded_run_with_contacts_resumes_from_its_state_exactly() {
    let setup = || parse_scene(&scene("embedded", "coulomb", Some(false), 1.0)).expect("scene");
    let mut whole = Simulation::new(setup(), None).expect("simulation");
    let mut first = Simulation::new(setup(), None).expect("simulation");
    for _ in 0..15 {
        whole.step().expect("step");
        first.step().expect("step");
    }
    let mut second = Simulation::new(setup(), None).expect("simulation");
    second.restore(first.state()).expect("restore");
    for _ in 0..15 {
        whole.step().expect("step");
        second.step().expect("step");
    }
    assert_eq!(centrelines(&mut whole, 4), centrelines(&mut second, 4));
}

//! The embedded engine's contacts (the fixed-N step of `superhelix-kernels` with
//! colliders) against the runtime engine's on the same scene: a patch of strands falling
//! onto a ball, with each friction model, the contacts that start within a step
//! predicted and resolved on the step's factors (`predict = true`, the default) or caught
//! by the depth check alone (`predict = false`).

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

/// The largest distance between the two simulations' centreline points (4 strands), m.
fn apart(a: &mut Simulation, b: &mut Simulation) -> f64 {
    let (a, b) = (centrelines(a, 4), centrelines(b, 4));
    a.iter()
        .zip(&b)
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max)
}

/// Each friction model, with the contacts that start within a step predicted and not,
/// 1 s of falling onto the ball: the embedded engine's centrelines are the runtime
/// engine's to 1e-12 L at every step (the same law, queries, prediction and checks on
/// both engines; their steps' arithmetic differs in order only, as without contacts;
/// measured 5e-15 to 8e-14 m), 1e-8 L with Coulomb friction, whose anchors'
/// stick-or-slide switch amplifies the round-off (measured 1.4e-9 m); the same number of
/// predicted contacts push on both (none without the prediction); the strands land (a centreline point within the contact radius of the
/// ball at the end) and no point of them goes more than 0.5 mm into it on either engine.
/// A rule that differs parts them by millimetres (the contacts that start within a step
/// predicted on one engine only parted such a patch by 3.6 mm).
#[test]
fn the_embedded_engine_lands_strands_on_a_ball_as_the_runtime_does() {
    // the round-off of two implementations of the same arithmetic (one step: 3e-17 m);
    // a Coulomb anchor's stick-or-slide switch amplifies it (measured: 1e-9 m over 1 s)
    let cases = [("none", 1e-12), ("viscous", 1e-12), ("coulomb", 1e-8)];
    for ((friction, bound), predict) in cases.into_iter().flat_map(|c| [(c, false), (c, true)]) {
        let setup =
            |engine| parse_scene(&scene(engine, friction, Some(predict), 1.0)).expect("scene");
        let mut embedded = Simulation::new(setup("embedded"), None).expect("embedded");
        let mut runtime = Simulation::new(setup("runtime"), None).expect("runtime");
        assert_eq!(embedded.engine(), Engine::Embedded);
        assert_eq!(runtime.engine(), Engine::Runtime);
        let mut deepest = [0.0f64; 2];
        let mut worst = 0.0f64;
        while runtime.time() < 1.0 - 1e-9 {
            embedded.step().expect("embedded step");
            runtime.step().expect("runtime step");
            worst = worst.max(apart(&mut embedded, &mut runtime));
            deepest[0] = deepest[0].max(embedded.max_penetration().expect("contacts"));
            deepest[1] = deepest[1].max(runtime.max_penetration().expect("contacts"));
        }
        // the prediction acted, on both engines alike
        let predicted = [embedded.stats(), runtime.stats()].map(|s| s.contacts_predicted);
        assert_eq!(
            predicted[0], predicted[1],
            "{friction}, predict = {predict}"
        );
        assert_eq!(
            predicted[0] > 0,
            predict,
            "{friction}: {predicted:?} predicted"
        );
        assert!(
            worst <= bound * LENGTH,
            "{friction}, predict = {predict}: the engines part by {worst:e} m"
        );
        assert!(
            deepest.iter().all(|&d| d <= 5e-4),
            "{friction}, predict = {predict}: deepest points {deepest:?} m (embedded, runtime)"
        );
        let nearest = centrelines(&mut embedded, 4)
            .iter()
            .map(|p| (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt() - BALL)
            .fold(f64::INFINITY, f64::min);
        assert!(
            (-5e-4..=1e-3).contains(&nearest),
            "{friction}, predict = {predict}: the strands end {nearest:e} m from the ball (deepest {deepest:?})"
        );
    }
}

/// `engine = "auto"` runs a scene with bodies on the embedded engine, with the contacts
/// that start within a step predicted (the default) or not, and on the runtime engine,
/// naming `contacts.hair_hair`, when its strands touch each other.
#[test]
fn auto_takes_the_embedded_engine_for_contacts_with_bodies() {
    let setup = |predict| parse_scene(&scene("auto", "viscous", predict, 0.1)).expect("scene");
    assert_eq!(engine_for(&setup(Some(false))), (Engine::Embedded, None));
    assert_eq!(engine_for(&setup(None)), (Engine::Embedded, None));
    let hair = scene("auto", "viscous", None, 0.1).replace(
        "[[patches]]",
        "[contacts.hair_hair]\nradius = 0.002\n\n[[patches]]",
    );
    let (engine, reason) = engine_for(&parse_scene(&hair).expect("scene"));
    assert_eq!(engine, Engine::Runtime);
    let reason = reason.expect("a reason");
    assert_eq!(reason.field, "contacts.hair_hair", "{reason:?}");
}

/// A run of the embedded engine with Coulomb contacts stopped halfway, its state taken
/// and restored into a new simulation of the same scene, ends where the run without the
/// stop does, bit for bit: the anchors, allowances and root zones are in the state.
#[test]
fn an_embedded_run_with_contacts_resumes_from_its_state_exactly() {
    for predict in [false, true] {
        resumes_exactly(predict);
    }
}

fn resumes_exactly(predict: bool) {
    let setup = || parse_scene(&scene("embedded", "coulomb", Some(predict), 1.0)).expect("scene");
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

/// The step budget's rules on both engines — one solve per step (`max_split_depth = 0`),
/// the field stiffness explicit, no energy balance (the full-head scenes' settings) —
/// and a split limited to two levels with the projected stiffness and the balance: the
/// patch falling onto the ball with viscous friction and the prediction, 1 s, gives the
/// same splits, rotation limits and predicted contacts on the embedded engine as on the
/// runtime's (31 splits at depth 2; 24 limited steps at depth 0, 11 with one level and
/// the explicit stiffness) and the same centrelines to 1e-11 L (the same rules in the
/// fixed-N step: the rotation limited at the deepest split, the split pieces of an
/// explicit step on the projected stiffness; measured 8e-14 to 1.5e-12 L, the round-off
/// of two orders of the same arithmetic), and no point goes more than 0.5 mm into the
/// ball.
#[test]
fn the_step_budgets_rules_agree_on_both_engines() {
    for rules in [
        "max_split_depth = 0\nfield_stiffness = \"explicit\"\nenergy_balance = false",
        "max_split_depth = 2",
        "max_split_depth = 1\nfield_stiffness = \"explicit\"",
    ] {
        let setup = |engine| {
            let text = scene(engine, "viscous", None, 1.0)
                .replace("[simulation]\n", &format!("[simulation]\n{rules}\n"));
            parse_scene(&text).expect("scene")
        };
        assert_eq!(
            engine_for(&setup("auto")),
            (Engine::Embedded, None),
            "{rules}"
        );
        let mut embedded = Simulation::new(setup("embedded"), None).expect("embedded");
        let mut runtime = Simulation::new(setup("runtime"), None).expect("runtime");
        let (mut worst, mut deepest) = (0.0f64, 0.0f64);
        while runtime.time() < 1.0 - 1e-9 {
            embedded.step().expect("embedded step");
            runtime.step().expect("runtime step");
            worst = worst.max(apart(&mut embedded, &mut runtime));
            deepest = deepest.max(embedded.max_penetration().expect("contacts"));
        }
        let (e, r) = (embedded.stats(), runtime.stats());
        assert_eq!(
            (e.substeps, e.rotation_limited, e.contacts_predicted),
            (r.substeps, r.rotation_limited, r.contacts_predicted),
            "{rules}"
        );
        assert!(
            worst <= 1e-11 * LENGTH,
            "{rules}: the engines part by {worst:e} m"
        );
        assert!(deepest <= 5e-4, "{rules}: {deepest} m inside the ball");
    }
}

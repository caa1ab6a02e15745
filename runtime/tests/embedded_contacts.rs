//! The embedded engine's contacts (the fixed-N step of `superhelix-kernels` with
//! colliders) against the runtime engine's on the same scene: a patch of strands falling
//! onto a ball, with each friction model, the contacts that start within a step
//! predicted and resolved on the step's factors (`predict = true`, the default) or caught
//! by the depth check alone (`predict = false`).

use superhelix_runtime::config::Engine;
use superhelix_runtime::{engine_for, parse_scene, Simulation, SimulationSetup};

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

/// The scene `setup` gives for an engine on the embedded engine, on the runtime engine,
/// and on the runtime engine again from q0 changed by 1e-15 (relative): the scene's own
/// sensitivity to round-off.
fn engines_and_spread(setup: impl Fn(&str) -> SimulationSetup) -> [Simulation; 3] {
    let embedded = Simulation::new(setup("embedded"), None).expect("embedded");
    let runtime = Simulation::new(setup("runtime"), None).expect("runtime");
    let mut perturbed = Simulation::new(setup("runtime"), None).expect("runtime");
    for i in 0..perturbed.strand_count() {
        let q: Vec<f64> = perturbed.q(i).iter().map(|x| x * (1.0 + 1e-15)).collect();
        let v = perturbed.v(i).to_vec();
        perturbed.set_state(i, &q, &v);
    }
    [embedded, runtime, perturbed]
}

/// How far the embedded and the runtime engine part, over the first 0.2 s (`early`) and
/// over the run (`worst`), and the scene's own spread (the runtime engine against itself
/// from a perturbed q0) over the same stretches, m.
#[derive(Default)]
struct Parting {
    early: f64,
    worst: f64,
    early_spread: f64,
    spread: f64,
}

impl Parting {
    /// After a step to time `t`: the engines `apart`, the perturbed run `spread` away.
    fn record(&mut self, t: f64, apart: f64, spread: f64) {
        self.worst = self.worst.max(apart);
        self.spread = self.spread.max(spread);
        if t <= 0.2 + 1e-9 {
            self.early = self.early.max(apart);
            self.early_spread = self.spread;
        }
    }
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

/// The patch of [`scene`] with its strands 3 mm apart and hair–hair contacts of reach
/// 4 mm (`hair_hair` the extra lines of `[contacts.hair_hair]`): the strands start within
/// each other's reach and press on each other as they fall onto the ball.
fn hair_scene(engine: &str, friction: &str, hair_hair: &str, duration: f64) -> String {
    scene(engine, friction, None, duration)
        .replace("size = [0.04, 0.0]", "size = [0.009, 0.0]")
        .replace(
            "[[patches]]",
            &format!("[contacts.hair_hair]\nradius = 0.002\n{hair_hair}\n\n[[patches]]"),
        )
}

/// Hair–hair contacts (`coupling = "ball"`: each strand steps against its partners'
/// points, found by the runtime's broad phase and handed to each engine's step), with
/// and without Coulomb friction between the rods, and with self-contact (pairs of two
/// parts of one strand, stepped on both parts: 494 pairs after the first step against
/// 346 without), 1 s of four strands pressed together
/// falling onto a ball, on both engines and on the runtime engine again from q0 changed
/// by 1e-15 (relative): the scene's own sensitivity to round-off. The pressed bundle
/// amplifies round-off (measured over 1 s: 4.0e-6 m without rod friction, 20 mm with it,
/// whose stick-or-slip switches, 2.2e-8 m with self-contact), so the engines, whose
/// arithmetic differs in order only, cannot agree closer than that: their centrelines
/// agree over the first 0.2 s, and over the whole second, to 1e-11 L and 1e-9 L
/// respectively or ten times the scene's own spread then, whichever is more (measured
/// over 0.2 s: 6.2e-14 m against a spread of 4.7e-14 m, 3.4e-13 m against 4.6e-13 m,
/// 4.2e-12 m against 4.1e-12 m; over 1 s: 5.2e-6 m against 4.0e-6 m, 27 mm against 20 mm,
/// 2.2e-8 m against 2.2e-8 m); the same
/// pairs each step while they agree to 1e-12 L; the strands
/// touch each other on both (partners within reach counted by `contact_summary`), and no
/// point goes more than 0.5 mm into the ball.
#[test]
fn the_embedded_engine_steps_hair_against_hair_as_the_runtime_does() {
    let cases = [
        ("viscous", ""),
        (
            "coulomb",
            "friction = \"coulomb\"\nfriction_coefficient = 0.3",
        ),
        ("viscous", "self_contact = true"),
    ];
    // the pairs after the first step, per case
    let mut first_pairs = Vec::new();
    for (friction, hair_hair) in cases {
        let setup = |engine: &str| {
            parse_scene(&hair_scene(engine, friction, hair_hair, 1.0)).expect("hair scene")
        };
        let [mut embedded, mut runtime, mut perturbed] = engines_and_spread(setup);
        assert_eq!(embedded.engine(), Engine::Embedded);
        let mut parting = Parting::default();
        let (mut touching, mut deepest) = ([0usize; 2], 0.0f64);
        while runtime.time() < 1.0 - 1e-9 {
            for sim in [&mut embedded, &mut runtime, &mut perturbed] {
                sim.step().expect("step");
            }
            if first_pairs.len() < cases.len() && runtime.steps() == 1 {
                first_pairs.push(runtime.hair_pairs().expect("hair–hair").pairs);
            }
            let apart_now = apart(&mut embedded, &mut runtime);
            if apart_now <= 1e-12 * LENGTH {
                assert_eq!(
                    embedded.hair_pairs(),
                    runtime.hair_pairs(),
                    "{friction}: the pairs at t = {}",
                    runtime.time()
                );
            }
            let spread_now = apart(&mut runtime, &mut perturbed);
            parting.record(runtime.time(), apart_now, spread_now);
            for (sim, n) in [&embedded, &runtime].into_iter().zip(&mut touching) {
                *n += (0..4)
                    .map(|i| sim.contact_summary(i).expect("contacts").hair_contacts)
                    .sum::<usize>();
            }
            for sim in [&mut embedded, &mut runtime] {
                deepest = deepest.max(sim.max_penetration().expect("contacts"));
            }
        }
        let Parting {
            early,
            worst,
            early_spread,
            spread,
        } = parting;
        assert!(
            touching.iter().all(|&n| n > 0),
            "{friction}: partners within reach over the run {touching:?} (embedded, runtime)"
        );
        assert!(
            early <= (1e-11 * LENGTH).max(10.0 * early_spread),
            "{friction}: the engines part by {early:e} m over 0.2 s, the scene from itself by \
             {early_spread:e} m"
        );
        assert!(
            worst <= (1e-9 * LENGTH).max(10.0 * spread),
            "{friction}: the engines part by {worst:e} m, the scene from itself by {spread:e} m"
        );
        assert!(deepest <= 5e-4, "{friction}: deepest point {deepest:e} m");
    }
    // with self-contact, pairs of two parts of one strand join the others
    assert!(
        first_pairs[2] > first_pairs[0],
        "pairs after the first step: {first_pairs:?} (the last with self-contact)"
    );
}

/// `engine = "auto"` runs a scene with bodies on the embedded engine, with the contacts
/// that start within a step predicted (the default) or not, and with hair–hair contacts
/// (self-contact included), with `coupling = "ball"` or `"pair"`.
#[test]
fn auto_takes_the_embedded_engine_for_contacts_with_bodies() {
    let setup = |predict| parse_scene(&scene("auto", "viscous", predict, 0.1)).expect("scene");
    assert_eq!(engine_for(&setup(Some(false))), (Engine::Embedded, None));
    assert_eq!(engine_for(&setup(None)), (Engine::Embedded, None));
    let hair =
        |extra: &str| parse_scene(&hair_scene("auto", "viscous", extra, 0.1)).expect("scene");
    assert_eq!(engine_for(&hair("")), (Engine::Embedded, None));
    assert_eq!(
        engine_for(&hair("self_contact = true")),
        (Engine::Embedded, None)
    );
    assert_eq!(
        engine_for(&hair("coupling = \"pair\"")),
        (Engine::Embedded, None)
    );
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

/// The same with hair–hair contacts and rod friction (self-contact too): the pairs,
/// their anchors and the samples' last positions (the partners' velocities) are in the
/// state.
#[test]
fn an_embedded_run_with_hair_hair_contacts_resumes_from_its_state_exactly() {
    let text = hair_scene(
        "embedded",
        "coulomb",
        "friction = \"coulomb\"\nfriction_coefficient = 0.3\nself_contact = true",
        1.0,
    );
    resumes_exactly_from(|| parse_scene(&text).expect("hair scene"));
}

fn resumes_exactly(predict: bool) {
    resumes_exactly_from(|| {
        parse_scene(&scene("embedded", "coulomb", Some(predict), 1.0)).expect("scene")
    });
}

fn resumes_exactly_from(setup: impl Fn() -> superhelix_runtime::SimulationSetup) {
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

/// Under the error control (`tolerance = 1e-3`) with contacts, each friction model, 1 s
/// of the patch falling onto the ball: `auto` takes the embedded engine, and its
/// centrelines are the runtime engine's (the same error-controlled step of the kernels,
/// their contacts on either engine's storage) to 1e-11 L over the first 0.2 s, and over
/// the whole second to 1e-9 L or ten times the scene's own spread then, whichever is
/// more (the runtime engine again from q0 changed by 1e-15, relative: the error
/// control's accept-or-reject decisions and the anchors' stick-or-slide amplify
/// round-off; measured: the same bits without friction and with viscous friction, with
/// Coulomb friction 0 over 0.2 s and 9.5e-5 m over 1 s against a spread of 1.1e-4 m);
/// the same step counts while they agree; predicted contacts pushed on both; no point
/// more than 0.5 mm into the ball. A run stopped halfway and restored ends
/// where the run without the stop does, bit for bit (the error control's history and
/// step size, the anchors and allowances are in the state).
#[test]
fn under_the_error_control_the_embedded_engine_lands_strands_as_the_runtime_does() {
    for friction in ["none", "viscous", "coulomb"] {
        let setup = |engine: &str| {
            let text = scene(engine, friction, None, 1.0)
                .replace("[simulation]\n", "[simulation]\ntolerance = 1e-3\n");
            parse_scene(&text).expect("scene")
        };
        assert_eq!(engine_for(&setup("auto")), (Engine::Embedded, None));
        let [mut embedded, mut runtime, mut perturbed] = engines_and_spread(setup);
        let mut parting = Parting::default();
        let mut deepest = 0.0f64;
        let mut counts_agree = true;
        while runtime.time() < 1.0 - 1e-9 {
            for sim in [&mut embedded, &mut runtime, &mut perturbed] {
                sim.step().expect("step");
            }
            let apart_now = apart(&mut embedded, &mut runtime);
            if apart_now <= 1e-12 * LENGTH {
                let (e, r) = (embedded.stats(), runtime.stats());
                counts_agree &= (e.error_steps, e.error_rejected, e.contacts_predicted)
                    == (r.error_steps, r.error_rejected, r.contacts_predicted);
            }
            let spread_now = apart(&mut runtime, &mut perturbed);
            parting.record(runtime.time(), apart_now, spread_now);
            for sim in [&mut embedded, &mut runtime] {
                deepest = deepest.max(sim.max_penetration().expect("contacts"));
            }
        }
        let (e, r) = (embedded.stats(), runtime.stats());
        let Parting {
            early,
            worst,
            early_spread,
            spread,
        } = parting;
        println!(
            "{friction}: apart {early:.2e} m over 0.2 s (spread {early_spread:.2e}), {worst:.2e} m over 1 s (spread {spread:.2e}); steps {} / {}, rejected {} / {}, predicted {} / {}; deepest {deepest:.2e} m",
            e.error_steps, r.error_steps, e.error_rejected, r.error_rejected, e.contacts_predicted, r.contacts_predicted
        );
        assert!(
            counts_agree,
            "{friction}: the step counts differ while the engines agree"
        );
        assert!(
            e.contacts_predicted > 0 && r.contacts_predicted > 0,
            "{friction}: predicted {} / {}",
            e.contacts_predicted,
            r.contacts_predicted
        );
        assert!(
            early <= 1e-11 * LENGTH,
            "{friction}: the engines part by {early:e} m over 0.2 s"
        );
        assert!(
            worst <= (1e-9 * LENGTH).max(10.0 * spread),
            "{friction}: the engines part by {worst:e} m, the scene from itself by {spread:e} m"
        );
        assert!(deepest <= 5e-4, "{friction}: deepest point {deepest:e} m");
    }
    resumes_exactly_from(|| {
        let text = scene("embedded", "coulomb", None, 1.0)
            .replace("[simulation]\n", "[simulation]\ntolerance = 1e-3\n");
        parse_scene(&text).expect("scene")
    });
}

/// Under a tolerance without the prediction of contacts that start within a step
/// (`predict = false`), what keeps a strand's centreline out of the ball at the loosest
/// tolerance (0.5) is the contacts' depth check: a step in which a sample goes deeper
/// than `split_depth` (here 0.02 mm) beyond its start's depth is rejected, whatever its
/// error estimate (which compares two solutions that both go in), and retried at half
/// its size. Both engines reject such steps (`StepStats::error_rejected_deep`, the same
/// ones while they agree), and no centreline point ends deeper in the ball than
/// `split_depth` (measured: none inside; without the check, 0.10 mm).
#[test]
fn under_a_loose_tolerance_the_depth_check_keeps_strands_out_of_the_ball() {
    const SPLIT_DEPTH: f64 = 2e-5;
    let setup = |engine: &str| {
        let text = scene(engine, "none", Some(false), 0.5)
            .replace("[simulation]\n", "[simulation]\ntolerance = 0.5\n")
            .replace(
                "radius = 1e-3\n",
                &format!("radius = 1e-3\nsplit_depth = {SPLIT_DEPTH}\n"),
            );
        parse_scene(&text).expect("scene")
    };
    let mut embedded = Simulation::new(setup("auto"), None).expect("embedded");
    assert_eq!(embedded.engine(), Engine::Embedded);
    let mut runtime = Simulation::new(setup("runtime"), None).expect("runtime");
    let mut deepest = 0.0f64;
    let mut agree = true;
    while runtime.time() < 0.5 - 1e-9 {
        for sim in [&mut embedded, &mut runtime] {
            sim.step().expect("step");
            deepest = deepest.max(sim.max_penetration().expect("contacts"));
        }
        if apart(&mut embedded, &mut runtime) <= 1e-12 * LENGTH {
            agree &= embedded.stats().error_rejected_deep == runtime.stats().error_rejected_deep;
        }
    }
    let (e, r) = (embedded.stats(), runtime.stats());
    println!(
        "rejected by depth {} / {} of {} / {} rejected, {} / {} steps; deepest {deepest:.2e} m",
        e.error_rejected_deep,
        r.error_rejected_deep,
        e.error_rejected,
        r.error_rejected,
        e.error_steps,
        r.error_steps
    );
    assert!(agree, "the depth rejections differ while the engines agree");
    assert!(
        e.error_rejected_deep > 0 && r.error_rejected_deep > 0,
        "{e:?} / {r:?}"
    );
    assert!(e.error_rejected_deep <= e.error_rejected);
    assert_eq!(e.contacts_predicted + r.contacts_predicted, 0);
    assert!(deepest <= SPLIT_DEPTH, "deepest point {deepest:e} m");
}

//! The pair solve of `coupling = "pair"` on the embedded engine against the runtime
//! engine's: the same solve (`solver::pair_coupling`, written once over a coupled
//! strand of either engine) on each engine's strands after their steps.

use superhelix_runtime::config::Engine;
use superhelix_runtime::{engine_for, parse_scene, Simulation};

/// The largest distance between the two simulations' centreline points (4 per
/// element), m.
fn apart(a: &mut Simulation, b: &mut Simulation) -> f64 {
    let mut worst = 0.0f64;
    for i in 0..a.strand_count() {
        let (pa, pb) = (a.centreline_world(i, 4), b.centreline_world(i, 4));
        for (p, q) in pa.iter().zip(&pb) {
            let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
            worst = worst.max(d);
        }
    }
    worst
}

/// Two rods of 10 cm with free roots (9 elements and the joint), no gravity, the upper
/// one thrown down onto the lower one at 0.1 m/s (`integrator` as given).
fn free_rods(engine: &str, integrator: &str) -> String {
    let rod = |name: &str, root: [f64; 3], direction: [f64; 3]| {
        format!(
            r#"
[[strands]]
name = "{name}"
root = {root:?}
length = 0.1
elements = 9
radius = 1e-4
youngs_modulus = 1e8
direction = {direction:?}
normal = [0.0, 0.0, 1.0]
natural = [0.0, 0.0, 0.0]
initial = "straight"
air_drag = 0.0
internal_friction = 0.0
[strands.ends]
root = "free"
"#
        )
    };
    format!(
        r#"
[simulation]
dt = 1e-3
duration = 1.0
engine = "{engine}"
integrator = "{integrator}"
[environment]
gravity = "none"
[contacts]
bodies = []
samples_per_element = 16
[contacts.hair_hair]
radius = 0.001
stiffness = 1e3
coupling = "pair"
{}{}"#,
        rod("lower", [-0.05, 0.01, 0.0], [1.0, 0.0, 0.0]),
        rod("upper", [0.0, -0.04, 0.004], [0.0, 1.0, 0.0]),
    )
}

/// Two crossing rods of 10 cm (N = 10, pinned at their roots, their tips held on a
/// line across their axes), the upper pressed onto the lower by a load at its middle,
/// under gravity.
fn crossing_rods(engine: &str) -> String {
    let rod = |name: &str, root: &str, direction: &str, extra: &str| {
        format!(
            "[[strands]]\nname = \"{name}\"\nroot = {root}\nlength = 0.1\nelements = 9\nradius = 1e-4\n\
             direction = {direction}\nnormal = [0.0, 0.0, 1.0]\nnatural = [0.0, 0.0, 0.0]\n\
             initial = \"straight\"\nair_drag = 3e-4\n{extra}[strands.ends]\nroot = \"pinned\"\n\
             [strands.ends.tip]\nkind = \"sliding\"\naxis = {direction}\n"
        )
    };
    format!(
        "[simulation]\ndt = 0.002\nduration = 1.0\nengine = \"{engine}\"\n[environment]\n\
         gravity = \"none\"\n[contacts]\nbodies = []\nsamples_per_element = 16\n\
         [contacts.hair_hair]\nradius = 0.001\nstiffness = 1e4\ncoupling = \"pair\"\n{}{}",
        rod("lower", "[-0.05, 0.0, 0.0]", "[1.0, 0.0, 0.0]", ""),
        rod(
            "upper",
            "[0.0, -0.05, 0.002]",
            "[0.0, 1.0, 0.0]",
            "[[strands.point_loads]]\ns = 0.05\nforce = [0.0, 0.0, -1e-5]\n"
        )
    )
}

/// Four wavy strands of N = 5, 3 mm apart within each other's reach (4 mm), falling
/// onto a ball: pairs and contacts with a body, predicted within a step, together.
fn bundle_on_a_ball(engine: &str) -> String {
    format!(
        r#"
[simulation]
duration = 1.0
engine = "{engine}"

[[bodies]]
name = "ball"
shape = "sphere"
radius = 0.1
center = [0.0, 0.0, 0.0]

[contacts]
radius = 1e-3
friction = "viscous"

[contacts.hair_hair]
radius = 0.002
coupling = "pair"

[[patches]]
name = "patch"
count = [4, 1]
size = [0.009, 0.0]
length = 0.2
elements = 5
preset = "wavy"
center = [0.0, 0.0, 0.13]
direction = [1.0, 0.0, 0.0]
normal = [0.0, 0.0, 1.0]
"#
    )
}

/// q and q̇ of every strand, as bits.
fn bits(sim: &Simulation) -> Vec<u64> {
    (0..sim.strand_count())
        .flat_map(|i| {
            sim.q(i)
                .iter()
                .chain(sim.v(i))
                .map(|x| x.to_bits())
                .collect::<Vec<_>>()
        })
        .collect()
}

/// The scene `text` (with `ENGINE` for the engine) on both engines, the upper rod of
/// [`free_rods`] thrown down when `throw`.
fn both(text: &str, throw: bool) -> [Simulation; 2] {
    let setup = |engine: &str| parse_scene(&text.replace("ENGINE", engine)).expect("scene");
    let mut sims = [
        Simulation::new(setup("embedded"), None).expect("embedded"),
        Simulation::new(setup("runtime"), None).expect("runtime"),
    ];
    assert_eq!(sims[0].engine(), Engine::Embedded);
    assert_eq!(sims[1].engine(), Engine::Runtime);
    if throw {
        for sim in &mut sims {
            let n = sim.q(1).len();
            let (q, mut v) = (sim.q(1).to_vec(), sim.v(1).to_vec());
            v[n - 1] = -0.1;
            sim.set_state(1, &q, &v);
        }
    }
    sims
}

/// The pair solve on the embedded engine is the runtime engine's (the same solve on the
/// same steps, through each engine's strands): two free rods colliding (a free root's
/// momentum kept through the pairs' impulses) and two crossing rods pinned at their
/// roots with their tips held on sliding props (the holders' share of the pair
/// impulses) take the same bits on both engines at every step — q, q̇ and the holders'
/// reactions — with linearly implicit Euler, as do the pairs' counts. After BDF2 steps
/// each engine factors the linearly implicit matrix at the step's end for the pairs
/// (`superhelix_kernels::fixed::factor_step_views`) with its own contacts' points (the
/// embedded engine's chained closed forms, the runtime's kernel), which differ in the
/// last bits: the free rods part by 1.3e-12 L over the collision (asserted 1e-10 L).
/// The contact acts in every case (the lower rod takes up momentum; the props read
/// the load).
#[test]
fn the_pair_solve_on_the_embedded_engine_is_the_runtime_engines() {
    // free rods, linearly implicit Euler: the same bits at every step
    let [mut e, mut r] = both(&free_rods("ENGINE", "linearly-implicit-euler"), true);
    let mut touched = false;
    while r.time() < 0.3 - 1e-9 {
        e.step().expect("embedded step");
        r.step().expect("runtime step");
        assert_eq!(bits(&e), bits(&r), "free rods at t = {}", r.time());
        touched |= e.hair_pairs().is_some_and(|p| p.pairs > 0);
    }
    assert!(touched, "the rods never came within reach");
    // the lower rod was at rest: the collision moved it
    let lower_speed = e.v(0).iter().fold(0.0f64, |m, x| m.max(x.abs()));
    assert!(
        lower_speed > 1e-3,
        "the lower rod's largest rate {lower_speed:e}"
    );
    let (se, sr) = (e.stats(), r.stats());
    assert_eq!(
        (se.pairs_indefinite, se.pairs_unresolved),
        (sr.pairs_indefinite, sr.pairs_unresolved)
    );
    // free rods, BDF2: the pairs on the linearly implicit matrix at the end
    let [mut e, mut r] = both(&free_rods("ENGINE", "bdf2"), true);
    let mut worst = 0.0f64;
    while r.time() < 0.3 - 1e-9 {
        e.step().expect("embedded step");
        r.step().expect("runtime step");
        worst = worst.max(apart(&mut e, &mut r));
    }
    assert!(
        worst <= 1e-10 * 0.1,
        "bdf2: the engines part by {worst:e} m"
    );
    // crossing rods with held tips: the same bits and reactions
    let [mut e, mut r] = both(&crossing_rods("ENGINE"), false);
    while r.time() < 1.0 - 1e-9 {
        e.step().expect("embedded step");
        r.step().expect("runtime step");
        assert_eq!(bits(&e), bits(&r), "crossing rods at t = {}", r.time());
        for i in 0..2 {
            assert_eq!(
                e.held_reaction(i).map(|x| x.map(f64::to_bits)),
                r.held_reaction(i).map(|x| x.map(f64::to_bits)),
                "the reaction on rod {i} at t = {}",
                r.time()
            );
        }
    }
    // the upper rod pressed 1e-5 N onto the lower one: the lower's prop reads a share
    let prop = e.held_reaction(0).expect("held")[2];
    assert!(prop.abs() > 1e-7, "the lower rod's prop reads {prop:e} N");
}

/// Pairs and contacts with a body together: four strands 3 mm apart within each other's
/// reach falling onto a ball (contacts that start within a step predicted, and resolved
/// again after the pair solve moved the strands), on both engines. The embedded engine's
/// contacts with the ball place its points through chained closed forms, the runtime's
/// through its kernel: they differ in the last bits from the first contacts with the
/// ball (at 0.2 s), and the pressed bundle amplifies that as it amplifies any round-off —
/// the runtime engine against itself from q0 changed by 1e-15 (relative) parts by as
/// much. Over 0.3 s the engines agree to 1e-10 L or ten times that spread, whichever is
/// more (measured 8.0e-13 m against a spread of 5.6e-12 m), with the same predicted
/// contacts and pair counts, and no point goes more than 0.6 mm into the ball (the
/// bundle presses its lowest strand 0.55 mm in on both engines at 0.23 s).
#[test]
fn pairs_and_a_ball_on_the_embedded_engine_are_the_runtime_engines() {
    let text = bundle_on_a_ball("ENGINE");
    let [mut e, mut r] = both(&text, false);
    let mut perturbed = Simulation::new(
        parse_scene(&text.replace("ENGINE", "runtime")).expect("scene"),
        None,
    )
    .expect("runtime");
    for i in 0..perturbed.strand_count() {
        let q: Vec<f64> = perturbed.q(i).iter().map(|x| x * (1.0 + 1e-15)).collect();
        let v = perturbed.v(i).to_vec();
        perturbed.set_state(i, &q, &v);
    }
    let (mut worst, mut spread, mut deepest) = (0.0f64, 0.0f64, 0.0f64);
    while r.time() < 0.3 - 1e-9 {
        for sim in [&mut e, &mut r, &mut perturbed] {
            sim.step().expect("step");
        }
        worst = worst.max(apart(&mut e, &mut r));
        spread = spread.max(apart(&mut r, &mut perturbed));
        for sim in [&mut e, &mut r] {
            deepest = deepest.max(sim.max_penetration().expect("contacts"));
        }
    }
    println!("apart {worst:e} m, spread {spread:e} m, deepest {deepest:e} m");
    assert!(
        worst <= (1e-10 * 0.2f64).max(10.0 * spread),
        "the engines part by {worst:e} m, the scene from itself by {spread:e} m"
    );
    let (se, sr) = (e.stats(), r.stats());
    assert!(se.contacts_predicted > 0, "no contact predicted");
    assert_eq!(se.contacts_predicted, sr.contacts_predicted);
    assert_eq!(
        (se.pairs_indefinite, se.pairs_unresolved),
        (sr.pairs_indefinite, sr.pairs_unresolved)
    );
    let touching: usize = (0..4)
        .map(|i| e.contact_summary(i).expect("contacts").hair_contacts)
        .sum();
    assert!(touching > 0, "no pair within reach at the end");
    assert!(deepest <= 6e-4, "deepest point {deepest:e} m");
}

/// A run of the embedded engine with coupled pairs stopped halfway, its state taken and
/// restored into a new simulation of the same scene, ends where the run without the
/// stop does, bit for bit (the pair solve keeps nothing from one step to the next but
/// what the strands' states hold), with held tips and with bodies; `auto` takes the
/// embedded engine for each scene.
#[test]
fn an_embedded_run_with_coupled_pairs_resumes_exactly_and_auto_takes_it() {
    for text in [crossing_rods("ENGINE"), bundle_on_a_ball("ENGINE")] {
        let setup = |engine: &str| parse_scene(&text.replace("ENGINE", engine)).expect("scene");
        assert_eq!(engine_for(&setup("auto")), (Engine::Embedded, None));
        let mut whole = Simulation::new(setup("embedded"), None).expect("simulation");
        let mut first = Simulation::new(setup("embedded"), None).expect("simulation");
        for _ in 0..8 {
            whole.step().expect("step");
            first.step().expect("step");
        }
        let mut second = Simulation::new(setup("embedded"), None).expect("simulation");
        second.restore(first.state()).expect("restore");
        for _ in 0..8 {
            whole.step().expect("step");
            second.step().expect("step");
        }
        assert_eq!(bits(&whole), bits(&second));
        assert_eq!(whole.stats(), second.stats());
    }
}

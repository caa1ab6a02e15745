//! The error-controlled step (`[simulation] tolerance`) against independent references
//! (other schemes with fixed steps and no error estimate: explicit RK4 at 1/60000 s, or
//! Richardson-extrapolated BDF2 where internal friction makes RK4 too stiff, see
//! [`reference_tips`]): the study's `swing` (a straight
//! 20 cm strand of the smooth preset released horizontal under gravity, N = 5), 0.5 s,
//! the tip compared at every 1/30 s, on the embedded engine (the fixed-N
//! `step_to_tolerance`, which `engine = "auto"` takes) and the runtime engine; the same
//! on a nodding head; frictionless N = 3 helices of three presets, 1 s ([`HELICES`]).
//! With a body contact: the swing down a frictionless plane inclined
//! at 45° that the strand lies on from the start ([`incline`]), on the runtime engine. There
//! the promise (at most 3 τ) fails, with and without the strand's friction (issue #51):
//! those tests are ignored, with the measured figures, as is the helices' (one cell below
//! the band).
//!
//! With contacts the references hold only where no contact starts with a speed: the swing
//! falling onto a floor 10 cm below its root (its tip landing at about 1.4 m/s, the
//! penalty's damping switched on at once) has no reference within 10⁻⁷ L at any
//! affordable step. Measured, the tip's largest difference over the frames after the
//! landing: RK4 at 1/30000 and 1/60000 s, 1.5·10⁻² L; at 1/60000 and 1/120000 s,
//! 1.5·10⁻² L; at 1/120000 and 1/240000 s, 4.6·10⁻³ L (frictionless strand); BDF2 with the
//! preset's friction, Richardson-extrapolated from 256/512 and from 512/1024 steps a frame,
//! 1.1·10⁻² L apart (from 512/1024 and 1024/2048, 1.1·10⁻³ L). The incline's references
//! converge as they do without contacts.
//!
//! A contact that starts within a fixed step makes the fixed steps converge at first
//! order, so the references of a strand that lands on something ([`contact_reference`]:
//! BDF2 at 8192 steps a frame, its own error the difference from 4096, about 10⁻⁴ L)
//! judge τ down to 10⁻³: the swing onto a moving ball with Coulomb friction
//! ([`MOVING_BALL`]), and two strands in hair–hair contact ([`CROSSING`]). Every
//! strand's tip is compared.

use superhelix_runtime::config::Engine;
use superhelix_runtime::{engine_for, parse_scene, validate_scene, Simulation};

const LENGTH: f64 = 0.2;

/// A strand the tests follow: its `[[strands]]` entry (the last table of the scene) and
/// how many frames of 1/30 s they compare.
#[derive(Clone, Copy, Debug)]
enum Problem {
    /// The study's `swing`: a straight 20 cm strand of the smooth preset released
    /// horizontal under gravity, N = 5, 0.5 s.
    Swing,
    /// The swing's strand over 1/3 s: long enough to land on what is under it and go on
    /// (the contacts' tests, whose references are costly).
    Landing,
    /// A 20 cm strand of N = 3 released from rest in its natural shape under gravity,
    /// 1 s (the independent check of issue #51): [`HELICES`]`[k]`.
    Helix(usize),
}

/// cos 45°.
const S: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// The helices of [`Problem::Helix`]: preset, root direction, initial shape (at rest in
/// its helix). A helix released straight, springing into its shape with nothing to damp
/// it, has no reference: RK4's tips at 1/240000 and 1/480000 s still differ by 0.7 L after
/// the second (curly, horizontal; wavy, hanging), so no scheme's error over the second
/// can track a tolerance there.
const HELICES: [(&str, [f64; 3], &str); 8] = [
    ("curly", [1.0, 0.0, 0.0], "natural"),
    ("curly", [0.0, 0.0, -1.0], "natural"),
    ("curly", [S, 0.0, -S], "natural"),
    ("wavy", [1.0, 0.0, 0.0], "natural"),
    ("wavy", [0.0, 0.0, -1.0], "natural"),
    ("wavy", [S, 0.0, S], "natural"),
    ("fuzzy", [1.0, 0.0, 0.0], "natural"),
    ("fuzzy", [0.0, 0.0, -1.0], "natural"),
];

impl Problem {
    fn frames(self) -> usize {
        match self {
            Problem::Swing => 15,
            Problem::Landing => 10,
            Problem::Helix(_) => 30,
        }
    }
    fn strand(self) -> String {
        let (shape, direction) = match self {
            Problem::Swing | Problem::Landing => (
                "elements = 5\nnatural = [0.0, 0.0, 0.0]\ninitial = \"straight\"".to_string(),
                [1.0, 0.0, 0.0],
            ),
            Problem::Helix(k) => (
                format!(
                    "elements = 3\npreset = \"{}\"\ninitial = \"{}\"",
                    HELICES[k].0, HELICES[k].2
                ),
                HELICES[k].1,
            ),
        };
        format!(
            "[[strands]]\nroot = [0.0, 0.0, 0.0]\ndirection = {direction:?}\nnormal = [0.0, 1.0, 0.0]\nlength = {LENGTH}\n{shape}\n"
        )
    }
}

fn swing(tolerance: f64, extra: &str) -> String {
    scene(Problem::Swing, tolerance, extra)
}

fn scene(problem: Problem, tolerance: f64, extra: &str) -> String {
    let duration = problem.frames() as f64 / 30.0;
    format!(
        "\n[simulation]\ndt = 0.03333333333333333\nduration = {duration}\ntolerance = {tolerance:e}\n{extra}\n{}",
        problem.strand()
    )
}

/// `scene` with no internal friction and no air drag on its strand when `frictionless`
/// (keys of its last table, the strand's).
fn without_friction(scene: String, frictionless: bool) -> String {
    if !frictionless {
        return scene;
    }
    format!("{scene}internal_friction = 0.0\nair_drag = 0.0\n")
}

/// The samples of strand 0 touching a body at the last evaluation (0 without contacts).
fn touching(sim: &Simulation) -> usize {
    sim.contact_summary(0).map_or(0, |c| c.body_contacts)
}

/// The largest distance between two lists of tips, relative to the length.
fn largest_apart(a: &[nalgebra::Vector3<f64>], b: &[nalgebra::Vector3<f64>]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).norm())
        .fold(0.0, f64::max)
        / LENGTH
}

/// Every strand's tip at every frame, the solves taken and steps rejected on `engine`, and the
/// fewest contact samples touching a body at a frame (0 without contacts);
/// `frictionless`: no internal friction and no air drag; `head`: a `[head]` section, or
/// bodies and `[contacts]`, or nothing.
fn tips_with(
    tolerance: f64,
    frictionless: bool,
    engine: Engine,
    head: &str,
) -> (Vec<nalgebra::Vector3<f64>>, usize, usize, usize) {
    tips_of(Problem::Swing, tolerance, frictionless, engine, head)
}

/// [`tips_with`] for `problem`.
fn tips_of(
    problem: Problem,
    tolerance: f64,
    frictionless: bool,
    engine: Engine,
    head: &str,
) -> (Vec<nalgebra::Vector3<f64>>, usize, usize, usize) {
    let (out, sim, fewest) = simulated(problem, tolerance, frictionless, engine, head);
    let stats = sim.stats();
    (out, stats.attempts, stats.error_rejected, fewest)
}

/// [`tips_of`]'s tips, the simulation at the end and the fewest contact samples touching.
fn simulated(
    problem: Problem,
    tolerance: f64,
    frictionless: bool,
    engine: Engine,
    head: &str,
) -> (Vec<nalgebra::Vector3<f64>>, Simulation, usize) {
    let name = match engine {
        Engine::Runtime => "runtime",
        _ => "auto",
    };
    let text = without_friction(
        scene(problem, tolerance, &format!("engine = \"{name}\"\n{head}")),
        frictionless,
    );
    let setup = parse_scene(&text).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(setup, None).unwrap_or_else(|e| panic!("{e}"));
    let expected = match engine {
        Engine::Runtime => Engine::Runtime,
        _ => Engine::Embedded,
    };
    assert_eq!(sim.engine(), expected, "auto takes the embedded engine");
    let mut out = Vec::new();
    let mut fewest = usize::MAX;
    for k in 1..=problem.frames() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        // the steps end on the scene's time steps
        assert!(
            (sim.time() - k as f64 / 30.0).abs() < 1e-12,
            "t = {}",
            sim.time()
        );
        for i in 0..sim.strand_count() {
            out.push(sim.position_at(i, LENGTH));
        }
        fewest = fewest.min(touching(&sim));
    }
    (out, sim, fewest)
}

/// Every strand's tip every 1/30 s of `problem` on the runtime engine with `integrator` and fixed
/// steps of 1/30/`substeps` s (no tolerance), `frictionless` and `head` as in
/// [`tips_with`]. On the [`incline`], asserts that every contact sample
/// touches the body at every frame: the reference stays on it.
fn fixed_tips(
    problem: Problem,
    integrator: &str,
    substeps: usize,
    frictionless: bool,
    head: &str,
) -> Vec<nalgebra::Vector3<f64>> {
    let dt = 1.0 / (30.0 * substeps as f64);
    let text = scene(
        problem,
        1e-3,
        &format!("engine = \"runtime\"\nintegrator = \"{integrator}\"\n{head}"),
    )
    .replace("tolerance = 1e-3\n", "")
    .replace("dt = 0.03333333333333333", &format!("dt = {dt:e}"));
    let text = without_friction(text, frictionless);
    let setup = parse_scene(&text).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(setup, None).unwrap_or_else(|e| panic!("{e}"));
    // the samples of every element, and the free tip's own end sample
    let samples = sim.samples_per_element() * sim.strand(0).geometry.elements() + 1;
    let mut out = Vec::new();
    for _ in 1..=problem.frames() {
        for _ in 0..substeps {
            sim.step().unwrap_or_else(|e| panic!("{e}"));
        }
        for i in 0..sim.strand_count() {
            out.push(sim.position_at(i, LENGTH));
        }
        if text.contains("name = \"incline\"") {
            assert_eq!(
                touching(&sim),
                samples,
                "{integrator}, {substeps} steps a frame: the strand left the body at t = {}",
                sim.time()
            );
        }
    }
    out
}

/// The tip every 1/30 s by schemes other than the one tested, with no error control:
/// frictionless, explicit RK4 (fourth order, no linearisation) with steps of 1/60000 s;
/// with the preset's internal friction (whose damping mode, |λ| ≈ 2.7e7 1/s, puts RK4's
/// stability limit at 8e-8 s), BDF2 with fixed steps of 1/15360 and 1/30720 s combined by
/// Richardson extrapolation (x + (x − x₂)/3 of the two).
///
/// Each reference's own error, estimated from the same scheme at twice the step, is
/// asserted below 1e-7 L, 50 times below the error of the tightest tolerance tested.
fn reference_tips(problem: Problem, frictionless: bool, head: &str) -> Vec<nalgebra::Vector3<f64>> {
    if frictionless {
        // RK4's error falls 16-fold from one step to its half: the finer one's is about
        // their difference / 15; the steps are halved until it is below 1e-9 L (a strand
        // released straight into its helix needs 1/240000 s)
        let mut substeps = 1000;
        let mut half = fixed_tips(problem, "rk4", substeps, true, head);
        loop {
            let full = fixed_tips(problem, "rk4", 2 * substeps, true, head);
            let own = largest_apart(&half, &full) / 15.0;
            if own < 1e-9 || substeps >= 8000 {
                eprintln!(
                    "reference (RK4, 1/{} s): estimated error {own:.2e} L",
                    60 * substeps
                );
                assert!(own < 1e-7, "{own:e}");
                return full;
            }
            (half, substeps) = (full, 2 * substeps);
        }
    }
    let richardson = |c: &[nalgebra::Vector3<f64>], f: &[nalgebra::Vector3<f64>]| {
        c.iter()
            .zip(f)
            .map(|(c, f)| f + (f - c) / 3.0)
            .collect::<Vec<_>>()
    };
    let levels: Vec<_> = [256, 512, 1024]
        .iter()
        .map(|&k| fixed_tips(problem, "bdf2", k, false, head))
        .collect();
    let (first, second) = (
        richardson(&levels[0], &levels[1]),
        richardson(&levels[1], &levels[2]),
    );
    // the two extrapolations' difference bounds the first's error, more than the second's
    let own = largest_apart(&first, &second);
    eprintln!("reference (BDF2, Richardson): estimated error {own:.2e} L");
    assert!(own < 1e-7, "{own:e}");
    second
}

/// The largest error of the tip over the run, relative to the length, against the
/// independent reference ([`reference_tips`]), for each tolerance; the solves taken; and
/// the fewest contact samples touching a body at a frame (0 without contacts). `head` as
/// in [`tips_with`].
fn errors_with(
    frictionless: bool,
    tolerances: &[f64],
    engine: Engine,
    head: &str,
) -> Vec<(f64, usize, usize)> {
    errors_of(Problem::Swing, frictionless, tolerances, engine, head)
}

/// [`errors_with`] for `problem`.
fn errors_of(
    problem: Problem,
    frictionless: bool,
    tolerances: &[f64],
    engine: Engine,
    head: &str,
) -> Vec<(f64, usize, usize)> {
    let reference = reference_tips(problem, frictionless, head);
    tolerances
        .iter()
        .map(|&tolerance| {
            let (run, solves, rejected, fewest) =
                tips_of(problem, tolerance, frictionless, engine, head);
            let error = largest_apart(&run, &reference);
            let contacts = if head.contains("[contacts]") {
                format!(", at least {fewest} contact samples touching at each frame")
            } else {
                String::new()
            };
            eprintln!(
                "{problem:?}, {engine:?}: frictionless {frictionless}, tolerance {tolerance:.0e}: largest tip error {error:.3e} L ({:.2} τ), {solves} solves, {rejected} steps rejected{contacts}",
                error / tolerance
            );
            (error, solves, fewest)
        })
        .collect()
}

const TOLERANCES: [f64; 6] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];

/// The largest error of the tip over the run is within [0.2, 3] τ, from τ = 1e-1 to 1e-6
/// (issue #51's band: at most 3 τ, and not below τ/5, the tolerance not spent on needless
/// steps); a tighter tolerance costs more solves.
fn as_accurate_as_asked(frictionless: bool, engine: Engine) {
    as_accurate_as_asked_with(frictionless, engine, "");
}

/// [`as_accurate_as_asked`] with `head` (as in [`tips_with`]); returns what
/// [`errors_with`] measured.
fn as_accurate_as_asked_with(
    frictionless: bool,
    engine: Engine,
    head: &str,
) -> Vec<(f64, usize, usize)> {
    let measured = errors_with(frictionless, &TOLERANCES, engine, head);
    for (&tolerance, &(error, _, _)) in TOLERANCES.iter().zip(&measured) {
        assert!(
            error <= 3.0 * tolerance && error >= 0.2 * tolerance,
            "tolerance {tolerance:e}: error {error:e}"
        );
    }
    assert!(measured.windows(2).all(|w| w[1].1 > w[0].1));
    measured
}

/// With the preset's friction and drag: measured 0.28 to 0.50 τ, τ = 1e-1 to 1e-6 (both
/// engines).
#[test]
fn the_swing_is_as_accurate_as_asked() {
    as_accurate_as_asked(false, Engine::Auto);
    as_accurate_as_asked(false, Engine::Runtime);
}

/// Without friction or drag nothing damps the local errors, and they add up over the
/// run: measured 0.22 to 0.70 τ, τ = 1e-1 to 1e-6 (both engines).
#[test]
fn a_frictionless_swing_is_as_accurate_as_asked() {
    as_accurate_as_asked(true, Engine::Auto);
    as_accurate_as_asked(true, Engine::Runtime);
}

/// The frictionless [`HELICES`] against RK4 (its own error estimated below 1e-9 L), τ
/// from 1e-1 to 1e-6, on the embedded engine: issue #51 asks the largest tip error over
/// the second within [0.2, 3] τ. Measured, in τ (solves), τ = 1e-1 … 1e-6:
///
/// ```text
/// 0 curly, horizontal   0.13 (42)   0.71 (511)  0.84 (2497)  0.46 (10856)  1.00 (36380)  1.01 (115005)
/// 1 curly, hanging      0.33 (64)   0.63 (433)  1.02 (1894)  0.85 (7982)   1.34 (27827)  1.33 (87930)
/// 2 curly, 45° down     0.29 (66)   0.90 (412)  1.04 (2145)  0.59 (11127)  1.22 (36509)  1.19 (114553)
/// 3 wavy, horizontal    0.37 (38)   0.41 (456)  0.65 (1882)  0.65 (5704)   0.64 (17905)  0.59 (56547)
/// 4 wavy, hanging       1.22 (98)   1.09 (442)  0.92 (1264)  0.94 (4075)   0.95 (12979)  0.96 (41022)
/// 5 wavy, 45° up        0.28 (42)   0.54 (304)  0.86 (1585)  1.03 (5011)   1.04 (15805)  1.11 (49930)
/// 6 fuzzy, horizontal   0.46 (138)  0.41 (525)  0.67 (3118)  0.51 (14410)  0.72 (46187)  0.64 (145945)
/// 7 fuzzy, hanging      0.31 (135)  0.37 (758)  0.43 (3606)  0.29 (15636)  0.67 (46379)  0.71 (149138)
/// ```
///
/// Every cell but one is within [0.2, 3] τ; the curly horizontal helix at τ = 1e-1 is
/// more accurate than asked (0.13 τ). `cargo test -p superhelix-runtime --release --test
/// error_control -- --ignored --nocapture frictionless_helices` (`HELIX=k` for one).
#[test]
#[ignore = "fails: 0.13 τ for the curly horizontal helix at τ = 1e-1 (asked: at least 0.2 τ); the 47 other cells 0.29 to 1.34 τ (issue #51)"]
fn frictionless_helices_are_as_accurate_as_asked() {
    let tolerances = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6];
    let mut failed = Vec::new();
    let only: Option<usize> = std::env::var("HELIX").ok().and_then(|k| k.parse().ok());
    for k in (0..HELICES.len()).filter(|k| only.is_none_or(|o| o == *k)) {
        let measured = errors_of(Problem::Helix(k), true, &tolerances, Engine::Auto, "");
        let ratios: Vec<String> = tolerances
            .iter()
            .zip(&measured)
            .map(|(t, m)| format!("{:.2} ({})", m.0 / t, m.1))
            .collect();
        eprintln!("helix {k} {:?}: {}", HELICES[k], ratios.join("  "));
        for (&tolerance, &(error, _, _)) in tolerances.iter().zip(&measured) {
            if !(0.2 * tolerance..=3.0 * tolerance).contains(&error) {
                failed.push(format!(
                    "helix {k} at {tolerance:e}: {:.2} τ",
                    error / tolerance
                ));
            }
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
}

/// A plane inclined at 45° (its outward normal (0, 1, 1)/√2) one contact radius (1 mm)
/// plus `offset` (m) from the strand's line, which it holds, frictionless contact: the
/// swing starts lying on it (at zero depth along its whole length with no offset) and,
/// pressed on it by gravity's normal component (sinking about 0.07 µm at the default
/// penalty), swings down it under g sin 45°, the tip reaching 13 cm below the root.
/// Every one of its 21 contact samples (4 an element and the free tip's own) touches the
/// plane at every frame of the references ([`fixed_tips`] asserts it), so no contact
/// starts with a speed and the references converge as without contacts (at offset 0:
/// RK4, the frictionless strand, estimated error 2.0·10⁻¹⁴ L; BDF2 with Richardson, the
/// preset's friction, 9.8·10⁻⁸ L).
fn incline(offset: f64) -> String {
    let d = -(1e-3 + offset) * std::f64::consts::FRAC_1_SQRT_2;
    format!(
        "[[bodies]]\nname = \"incline\"\nshape = \"plane\"\nattached = \"world\"\npoint = [0.0, {d:e}, {d:e}]\nnormal = [0.0, 0.7071067811865476, 0.7071067811865476]\n[contacts]\nradius = 0.001\nfriction = \"none\""
    )
}

/// The tips every 1/30 s of the [`Problem::Landing`] with `extra` (bodies, strands, `[contacts]`), the
/// strand with the preset's friction, by BDF2 with fixed steps of 1/(30 · 8192) s (none
/// shorter is affordable: a contact that starts within a step makes the fixed steps
/// converge at first order). Its own error, estimated by its difference from the run at
/// twice the step (at first order, about the finer run's error), is asserted below
/// `within` L and returned.
fn contact_reference(extra: &str, within: f64) -> (Vec<nalgebra::Vector3<f64>>, f64) {
    let coarse = fixed_tips(Problem::Landing, "bdf2", 4096, false, extra);
    let fine = fixed_tips(Problem::Landing, "bdf2", 8192, false, extra);
    let own = largest_apart(&coarse, &fine);
    eprintln!("reference (BDF2, 1/245760 s): estimated error {own:.2e} L");
    assert!(own < within, "{own:e}");
    (fine, own)
}

/// The largest tip error over the frames and the strands of the [`Problem::Landing`] with `extra`
/// against `reference`, relative to the length, and the solves, at each tolerance, on
/// both engines; asserts each within [0.2, 3] τ.
fn contact_errors(extra: &str, reference: &[nalgebra::Vector3<f64>], tolerances: &[f64]) {
    contact_runs(extra, reference, tolerances, 0.2);
}

/// [`contact_errors`] with the band's lower end at `lowest` τ, returning for each engine and
/// tolerance (in that order) how many times the Coulomb forces were recomputed (0 without
/// `[electrostatics]`).
fn contact_runs(
    extra: &str,
    reference: &[nalgebra::Vector3<f64>],
    tolerances: &[f64],
    lowest: f64,
) -> Vec<u64> {
    let mut failed = Vec::new();
    let mut updates = Vec::new();
    for engine in [Engine::Auto, Engine::Runtime] {
        for &tolerance in tolerances {
            let (run, sim, _) = simulated(Problem::Landing, tolerance, false, engine, extra);
            let stats = sim.stats();
            let (solves, rejected) = (stats.attempts, stats.error_rejected);
            let coulomb = sim.electrostatics().map_or(0, |e| e.updates().updates);
            assert_eq!(run.len(), reference.len());
            let error = largest_apart(&run, reference);
            eprintln!(
                "{engine:?}, tolerance {tolerance:.1e}: largest tip error {error:.3e} L ({:.2} τ), {solves} solves, {rejected} steps rejected, {coulomb} updates of the Coulomb forces",
                error / tolerance
            );
            if !(lowest * tolerance..=3.0 * tolerance).contains(&error) {
                failed.push(format!(
                    "{engine:?} at {tolerance:e}: {:.2} τ",
                    error / tolerance
                ));
            }
            updates.push(coulomb);
        }
    }
    assert!(failed.is_empty(), "{failed:?}");
    updates
}

/// A ball of 3 cm under the middle of the swing's strand (its top 5 mm below the
/// strand), on its own motion, moving along the strand (±5 mm at 1 Hz), Coulomb friction
/// (μ = 0.3): the strand swings down onto it, drapes over it and is dragged to and fro.
const MOVING_BALL: &str = "[[bodies]]\nname = \"ball\"\nshape = \"sphere\"\ncenter = [0.1, 0.0, -0.035]\nradius = 0.03\n[bodies.motion]\nkind = \"translate-oscillate\"\ndirection = [1.0, 0.0, 0.0]\namplitude = 0.005\nfrequency_hz = 1.0\n[contacts]\nfriction = \"coulomb\"";

/// The swing onto the [`MOVING_BALL`] (issue #51: a strand falling onto a moving sphere
/// with Coulomb friction, at three tolerances) against [`contact_reference`] (its own
/// error measured 6.4·10⁻⁵ L), on both engines. Measured, τ = 1e-1, 3e-2, 1e-2, 3e-3, 1e-3:
/// 0.84, 1.41, 1.28, 1.86, 0.79 τ (65, 106, 170, 297, 476 solves; the same on both
/// engines); the test takes 1e-1, 1e-2 and 1e-3.
#[test]
fn a_swing_onto_a_moving_ball_is_as_accurate_as_asked() {
    let (reference, _) = contact_reference(MOVING_BALL, 1e-4);
    contact_errors(MOVING_BALL, &reference, &[1e-1, 1e-2, 1e-3]);
}

/// [`MOVING_BALL`] between the tolerances its test asserts: the error is not monotone in
/// τ there, and the band does not hold at every one. Measured, τ = 5e-2, 2e-2, 5e-3,
/// 2e-3, 1.5e-3, 1.2e-3, 1.1e-3, 9e-4, 8e-4, 7e-4, 5e-4: 1.02, 0.80, 2.44, 1.79, 2.05,
/// 1.83, 3.09, 1.10, 0.93, 1.43, 2.59 τ (both engines): where within a step the strand
/// meets the ball decides, as on the ball moving up and down.
#[test]
#[ignore = "fails: 3.09 τ at τ = 1.1e-3 (issue #51)"]
fn a_swing_onto_a_moving_ball_is_as_accurate_as_asked_between_its_tolerances() {
    let (reference, _) = contact_reference(MOVING_BALL, 1e-4);
    contact_errors(
        MOVING_BALL,
        &reference,
        &[
            5e-2, 2e-2, 5e-3, 2e-3, 1.5e-3, 1.2e-3, 1.1e-3, 9e-4, 8e-4, 7e-4, 5e-4,
        ],
    );
}

/// [`MOVING_BALL`] moving up and down instead (±5 mm at 1 Hz, its top reaching the
/// strand's line): the tolerance fails at τ = 3e-3 and 1e-3. Measured, τ = 1e-1, 3e-2,
/// 1e-2, 3e-3, 1e-3: 0.41, 0.36, 1.40, 5.72, 3.22 τ (both engines; reference 6.1·10⁻⁵ L).
#[test]
#[ignore = "fails: 5.72 τ at τ = 3e-3, 3.22 τ at 1e-3 (issue #51)"]
fn a_swing_onto_a_ball_moving_up_and_down_is_as_accurate_as_asked() {
    let extra = MOVING_BALL.replace("direction = [1.0, 0.0, 0.0]", "direction = [0.0, 0.0, 1.0]");
    let (reference, _) = contact_reference(&extra, 1e-4);
    contact_errors(&extra, &reference, &[1e-1, 3e-2, 1e-2, 3e-3, 1e-3]);
}

/// A second strand hanging from a root 2 cm below the swing's line and 2 mm beside it, 10
/// cm out, `[contacts.hair_hair]` (R = 2 mm, frictionless): the swing comes down onto
/// it, brushes past it and swings on. Strand 0 is the hanging one.
const CROSSING: &str = "[contacts]\nfriction = \"none\"\n[contacts.hair_hair]\nradius = 0.002\n[[strands]]\nroot = [0.1, 0.002, -0.02]\ndirection = [0.0, 0.0, -1.0]\nnormal = [0.0, 1.0, 0.0]\nlength = 0.2\nelements = 5\nnatural = [0.0, 0.0, 0.0]\ninitial = \"straight\"";

/// The two strands of [`CROSSING`] (issue #51: two strands in hair–hair contact, at three
/// tolerances), both tips against [`contact_reference`] (its own error measured
/// 1.5·10⁻⁴ L), on both engines. Under a tolerance the pairs are searched as the strands
/// move (`Simulation::step_by`); searched once a frame, as fixed steps do, the swing was
/// 4.6 to 140 τ off from τ = 1e-1 to 1e-3. Measured, τ = 1e-1, 3e-2, 1e-2, 3e-3, 1e-3:
/// 0.07, 1.45, 2.94, 1.16, 2.51 τ (458, 475, 490, 691, 1354 solves; the same on both
/// engines): at τ ≥ 3e-2 the searches' own rule (no sample moves more than half the
/// contacts' reach between two) sets the intervals, and the run is more accurate than
/// asked, so the test takes 1e-2, 3e-3 and 1e-3.
#[test]
fn two_strands_in_hair_contact_are_as_accurate_as_asked() {
    let (reference, _) = contact_reference(CROSSING, 2e-4);
    contact_errors(CROSSING, &reference, &[1e-2, 3e-3, 1e-3]);
}

/// A second strand hanging from a root 2 cm below the swing's line and 2 cm beside it, 10
/// cm out, both charged alike (`[electrostatics]`, 4·10⁻⁹ C/m, direct sum): the swing
/// comes down past it and the two repel (at 1 cm the force per length, 2 k λ²/d ≈ 2.9·10⁻⁵
/// N/m, is about half the swing's weight per length). Strand 0 is the hanging one. With
/// the energy balance, which counts an update's change of the forces as no work the
/// strands did (`StrandWorkspace::shift_load_energy`): counted as work, the balance
/// took it from the velocities and fixed steps converged at about half an order (1.9·10⁻⁴
/// and 1.5·10⁻⁴ L between 1024, 2048 and 4096 steps a frame; now 2.3·10⁻⁵ and 1.1·10⁻⁵ L,
/// as without the balance).
const CHARGED: &str = "[electrostatics]\ncharge_per_length = 4e-9\nmethod = \"direct\"\n[[strands]]\nroot = [0.1, 0.02, -0.02]\ndirection = [0.0, 0.0, -1.0]\nnormal = [0.0, 1.0, 0.0]\nlength = 0.2\nelements = 5\nnatural = [0.0, 0.0, 0.0]\ninitial = \"straight\"";

/// The tips every 1/30 s of the [`Problem::Landing`] with [`CHARGED`] by BDF2 with fixed
/// steps, the Coulomb forces recomputed at the start of each and held over it (so the
/// steps converge at first order): 2 x(dt/2) − x(dt) at 1024, 2048 and 4096 steps a frame,
/// the last two's, its own error estimated by its distance from the first two's
/// (asserted below `within` L).
fn charged_reference(within: f64) -> Vec<nalgebra::Vector3<f64>> {
    let levels: Vec<_> = [1024, 2048, 4096]
        .iter()
        .map(|&k| fixed_tips(Problem::Landing, "bdf2", k, false, CHARGED))
        .collect();
    let extrapolate = |c: &[nalgebra::Vector3<f64>], f: &[nalgebra::Vector3<f64>]| {
        c.iter()
            .zip(f)
            .map(|(c, f)| 2.0 * f - c)
            .collect::<Vec<_>>()
    };
    let first = extrapolate(&levels[0], &levels[1]);
    let second = extrapolate(&levels[1], &levels[2]);
    let own = largest_apart(&first, &second);
    eprintln!(
        "reference (BDF2, first-order Richardson): estimated error {own:.2e} L (4096 steps a frame alone: {:.2e} L; 1024 to 2048: {:.2e} L, 2048 to 4096: {:.2e} L)",
        largest_apart(&levels[2], &second),
        largest_apart(&levels[0], &levels[1]),
        largest_apart(&levels[1], &levels[2]),
    );
    assert!(own < within, "{own:e}");
    second
}

/// The two strands of [`CHARGED`] (issue #51: `[electrostatics]` under a tolerance, the
/// charges' update tied to the steps), both tips against [`charged_reference`] (its own
/// error 3.9·10⁻⁸ L), on both engines. Measured, τ = 1e-1, 1e-2, 1e-3: 0.38, 0.46, 0.56
/// τ (38, 206, 1768 solves; the same on both engines); with the forces updated only at
/// the frames, as fixed steps of 1/30 s do, 0.45, 2.95 and 25 τ.
///
/// The same with `[contacts.hair_hair]` of a reach (1 mm) the strands never come within:
/// the pairs' searches then take intervals of at most half the reach's travel (about 940
/// in the 1/3 s, whatever τ), far more than the charges need, and the forces keep their
/// own schedule (`Simulation::step_by`). Measured: 0.21, 0.23, 0.54 τ with 9, 95 and 942
/// updates of the forces (13, 92, 866 without the searches). The errors stay within 3 τ
/// (below 0.2 τ would be the searches' short intervals, not the charges), and the
/// updates are as many as without the searches, within a quarter.
#[test]
fn two_charged_strands_are_as_accurate_as_asked() {
    let reference = charged_reference(2e-5);
    let tolerances = [1e-1, 1e-2, 1e-3];
    let alone = contact_runs(CHARGED, &reference, &tolerances, 0.2);
    let searched = format!(
        "[contacts]\nfriction = \"none\"\n[contacts.hair_hair]\nradius = 0.0005\n{CHARGED}"
    );
    let with_searches = contact_runs(&searched, &reference, &tolerances, 0.0);
    for (a, b) in alone.iter().zip(&with_searches) {
        assert!(
            *a > 0 && (*b as f64) <= 1.25 * *a as f64,
            "{b} updates with the searches, {a} without: {alone:?} and {with_searches:?}"
        );
    }
}

/// The offsets of the [`incline`] its tests take (m): whether the tolerance holds must not
/// hang on a nanometre.
const OFFSETS: [f64; 4] = [0.0, 1e-15, 1e-12, 1e-9];

/// With contacts and a tolerance `engine = "auto"` takes the embedded engine (its
/// error-controlled step takes the contacts), with the contacts that start within a step
/// predicted or not. The tests below name the runtime engine.
#[test]
fn auto_takes_the_embedded_engine_with_contacts_under_a_tolerance() {
    let text = swing(1e-3, &format!("engine = \"auto\"\n{}", incline(0.0)));
    let without = text.replace(
        "friction = \"none\"",
        "friction = \"none\"\npredict = false",
    );
    assert_ne!(without, text);
    for scene in [&without, &text] {
        let setup = parse_scene(scene).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(engine_for(&setup), (Engine::Embedded, None));
        let sim = Simulation::new(setup, None).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(sim.engine(), Engine::Embedded);
    }
}

/// The swing down the [`incline`] at each of the [`OFFSETS`], the strand with the
/// preset's friction and drag, against BDF2 with Richardson, on the runtime engine: the
/// tolerance is not honoured at τ = 1e-1 to 1e-2. Measured at offset 0 (the test stops
/// there), τ = 1e-1 … 1e-6, in τ (solves, fewest of the 21 contact samples touching at a
/// frame; the reference keeps all 21 on the plane):
///
/// ```text
/// 1.59 (176, 0)  6.05 (405, 3)  1.90 (443, 11)  1.23 (731, 21)  0.74 (2123, 21)  0.75 (6584, 21)
/// ```
///
/// At loose tolerances the strand leaves the plane it lies on. Issue #51 (the tolerance
/// does not buy accuracy with contacts).
#[test]
#[ignore = "fails: 6.05 τ at τ = 1e-2 (asked ≤ 3 τ): the strand leaves the incline it lies on (issue #51)"]
fn a_swing_down_an_incline_is_as_accurate_as_asked() {
    for offset in OFFSETS {
        eprintln!("incline offset {offset:e} m:");
        as_accurate_as_asked_with(false, Engine::Runtime, &incline(offset));
    }
}

/// The swing down the [`incline`] at each of the [`OFFSETS`] without friction or drag,
/// against RK4, on the runtime engine: the tolerance is not honoured from τ = 1e-1 to
/// 1e-4. Measured at offset 0 (the test stops there), τ = 1e-1 … 1e-6, in τ (solves,
/// fewest of the 21 contact samples touching at a frame):
///
/// ```text
/// 13.57 (818, 0)  90.18 (7403, 0)  4.54 (11417, 3)  3.24 (2585, 18)  0.85 (3631, 21)  1.02 (10982, 21)
/// ```
///
/// At τ = 1e-1 and 1e-2 the strand bounces off the plane (0.9 L off at 1e-2); the
/// reference keeps all 21 samples on it at every frame. Issue #51.
#[test]
#[ignore = "fails: 13.6 τ at τ = 1e-1, 90 τ at 1e-2, 4.5 τ at 1e-3, 3.2 τ at 1e-4 (asked ≤ 3 τ): the frictionless strand bounces off the incline (issue #51)"]
fn a_frictionless_swing_down_an_incline_is_as_accurate_as_asked() {
    for offset in OFFSETS {
        eprintln!("incline offset {offset:e} m:");
        as_accurate_as_asked_with(true, Engine::Runtime, &incline(offset));
    }
}

/// The embedded engine's error-controlled step (`superhelix_kernels::fixed::
/// step_to_tolerance`) is the runtime's: the same steps, accepted and rejected, and the
/// same tip to round-off (measured: at most 9.6e-14 L apart), with the head still and
/// nodding (±20° at 1 Hz about a point 10 cm below the root).
/// The head nodding (±20° at 1 Hz about a point 10 cm below the root), the strand
/// frictionless: the tolerance holds against RK4 with the same head, on both engines
/// (measured 0.50 to 1.27 τ, τ = 1e-1 to 1e-6).
#[test]
fn a_swing_on_a_nodding_head_is_as_accurate_as_asked() {
    for engine in [Engine::Auto, Engine::Runtime] {
        as_accurate_as_asked_with(true, engine, NODDING);
    }
}

/// A head nodding ±20° at 1 Hz about a point 10 cm below the root.
const NODDING: &str = "[head]\nmotion = { kind = \"oscillate\", axis = [0.0, 1.0, 0.0], angle_deg = 20.0, frequency_hz = 1.0, center = [0.0, 0.0, -0.1] }";

#[test]
fn the_embedded_error_controlled_step_is_the_runtimes() {
    let nodding = "[head]\nmotion = { kind = \"oscillate\", axis = [0.0, 1.0, 0.0], angle_deg = 20.0, frequency_hz = 1.0, center = [0.0, 0.0, -0.1] }";
    for (head, frictionless) in [("", false), ("", true), (nodding, false), (nodding, true)] {
        for tolerance in [1e-2, 1e-3, 1e-5] {
            let (a, solves_a, rejected_a, _) =
                tips_with(tolerance, frictionless, Engine::Auto, head);
            let (b, solves_b, rejected_b, _) =
                tips_with(tolerance, frictionless, Engine::Runtime, head);
            let apart = largest_apart(&a, &b);
            eprintln!(
                "head moving {}, frictionless {frictionless}, tolerance {tolerance:.0e}: tips {apart:.2e} L apart;",
                !head.is_empty()
            );
            eprintln!(
                "   solves {solves_a} and {solves_b}, rejected {rejected_a} and {rejected_b}"
            );
            // the docs say within 2e-13 L; 9.6e-14 measured (rounding of the two
            // assemblies), so 2e-13 fails on any difference beyond it
            assert!(apart < 2e-13, "{apart:e} L apart");
            assert_eq!((solves_a, rejected_a), (solves_b, rejected_b));
        }
    }
}

/// What cannot honour a tolerance is refused, naming the field.
#[test]
fn a_tolerance_is_refused_where_it_cannot_act() {
    let cases = [
        (swing(1e-3, "integrator = \"rk4\""), "simulation.tolerance"),
        (
            swing(1e-3, "integrator = \"newton-implicit-euler\""),
            "simulation.tolerance",
        ),
        (swing(0.0, ""), "simulation.tolerance"),
        (swing(2.0, ""), "simulation.tolerance"),
    ];
    for (text, field) in cases {
        let problems = validate_scene(&text);
        assert!(
            problems.iter().any(|p| p.field == field),
            "{field} not refused: {problems:?}"
        );
    }
    assert!(validate_scene(&swing(1e-3, "")).is_empty());
    assert!(validate_scene(&swing(1e-3, "integrator = \"bdf2\"")).is_empty());
    assert!(validate_scene(&swing(1e-3, "engine = \"embedded\"")).is_empty());
    // contacts and electrostatics act within the error-controlled steps
    let with_effects = swing(
        1e-3,
        "[[bodies]]\nname = \"ball\"\nshape = \"sphere\"\nattached = \"world\"\ncenter = [0.1, 0.0, -0.1]\nradius = 0.05\n[contacts]\nradius = 0.001\n[electrostatics]\ncharge_per_length = -1e-10",
    );
    assert!(
        validate_scene(&with_effects).is_empty(),
        "{:?}",
        validate_scene(&with_effects)
    );
}

/// Without the energy balance (`energy_balance = false`) the error-controlled step
/// measures no energy and limits none, on both engines (the one step of the kernels):
/// the frictionless swing, on a still and on the nodding head, takes the same steps on
/// both and their tips agree to 2e-13 L (the rounding of the two assemblies, as with the
/// balance); on the still head the balance acts when it is on (the run with it ends
/// 5.3e-5 L away; on the nodding head it takes nothing here).
#[test]
fn without_the_energy_balance_both_engines_take_the_same_steps() {
    let nodding = format!("energy_balance = false\n{NODDING}");
    for head in ["energy_balance = false", nodding.as_str()] {
        let (a, solves_a, rejected_a, _) = tips_with(1e-3, true, Engine::Auto, head);
        let (b, solves_b, rejected_b, _) = tips_with(1e-3, true, Engine::Runtime, head);
        let (c, _, _, _) = tips_with(
            1e-3,
            true,
            Engine::Runtime,
            &head.replace("energy_balance = false", ""),
        );
        let (engines, balance) = (largest_apart(&a, &b), largest_apart(&b, &c));
        eprintln!(
            "{head:?}: engines {engines:.2e} L apart, solves {solves_a} / {solves_b}, rejected {rejected_a} / {rejected_b}; with the balance {balance:.2e} L away"
        );
        assert!(engines < 2e-13, "{engines:e} L apart");
        assert_eq!((solves_a, rejected_a), (solves_b, rejected_b));
        if !head.contains("[head]") {
            assert!(balance > 1e-9, "the balance did not act: {balance:e} L");
        }
    }
}

/// [`CROSSING`] on a head moving ±1 cm at 2 Hz across the two strands: fixed BDF2 steps,
/// the pairs searched at every step, should converge towards the run at 1024 steps a
/// frame (the tip error at 256 steps a frame at most half of that at 64). A partner's
/// point stands still in the world between two searches while the strand it belongs to
/// moves with the head, and the runs do not converge: 8.6·10⁻² and 9.8·10⁻² L at 64 and
/// 256 steps a frame (partners moving along their velocities: 6.8·10⁻² and 2.5·10⁻² L;
/// issue #51's plan, docs/architecture.md).
#[test]
#[ignore = "fails: 8.6e-2 L at 64 steps a frame, 9.8e-2 L at 256 (issue #51)"]
fn hair_pairs_on_a_moving_head_converge_with_the_step() {
    let extra = format!(
        "[head]\nmotion = {{ kind = \"translate-oscillate\", direction = [0.0, 1.0, 0.0], amplitude = 0.01, frequency_hz = 2.0 }}\n{CROSSING}"
    );
    let fine = fixed_tips(Problem::Landing, "bdf2", 1024, false, &extra);
    let error = |k| {
        largest_apart(
            &fixed_tips(Problem::Landing, "bdf2", k, false, &extra),
            &fine,
        )
    };
    let (coarse, finer) = (error(64), error(256));
    eprintln!("64 steps a frame: {coarse:.3e} L, 256: {finer:.3e} L");
    assert!(finer <= 0.5 * coarse, "{coarse:e} → {finer:e}");
}

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

/// The largest |Δq| between two simulations of the scene's two strands, each relative to
/// the larger of 1 and the strand's largest |q| in `a`.
fn q_apart(a: &Simulation, b: &Simulation) -> f64 {
    (0..2)
        .map(|i| {
            let scale = a.q(i).iter().fold(1.0f64, |m, x| m.max(x.abs()));
            a.q(i)
                .iter()
                .zip(b.q(i))
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs() / scale))
        })
        .fold(0.0, f64::max)
}

/// A simulation of `text` restored to `saved` (the state before step `from`) and
/// stepped to step `to` ends where `whole`, the run that was not stopped, ends: q and q̇
/// to the bit. Returns it for further comparison.
fn resumes_exactly(
    text: &str,
    saved: Option<superhelix_runtime::simulation::state::SimulationState>,
    (from, to): (usize, usize),
    whole: &Simulation,
) -> Simulation {
    let mut resumed = simulation(text).expect("valid scene");
    resumed
        .restore(saved.expect("a saved state"))
        .expect("restore");
    for _ in from..to {
        resumed.step().expect("resumed step");
    }
    for i in 0..2 {
        assert_eq!(resumed.q(i), whole.q(i), "strand {i}");
        assert_eq!(resumed.v(i), whole.v(i), "strand {i}");
    }
    resumed
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

/// `text` with its last strand's root pinned.
fn pinned(text: &str) -> String {
    format!("{text}[strands.ends]\nroot = \"pinned\"\n")
}

/// `text` with its last strand's root free.
fn free(text: &str) -> String {
    format!("{text}[strands.ends]\nroot = \"free\"\n")
}

#[test]
fn a_pinned_root_on_the_embedded_engine_is_the_runtime_engines_and_resumes_exactly() {
    // the wavy strand pinned at its root (its joint an element of the strand: 7 + 1 = 8
    // elements, a generated size) on the shaking head, with and without point loads: the
    // joint's coordinates scaled as the runtime engine scales them
    // (`Strand::solver_scale`, lent to the step as `ParamsView::scale`)
    for text in [scene("", ""), loaded("", "")] {
        let text = pinned(&text.replace("elements = 8", "elements = 7"));
        let with = |engine: &str| text.replace("engine = \"\"", &format!("engine = \"{engine}\""));
        let mut runtime = simulation(&with("runtime")).expect("valid scene");
        let mut embedded = simulation(&with("auto")).expect("valid scene");
        assert_eq!(
            embedded.engine(),
            superhelix_runtime::config::Engine::Embedded
        );
        assert_eq!(embedded.q(1).len(), 3 * 8);
        // the scene's own sensitivity: the runtime engine from q0 changed by 1e-15
        let mut perturbed = simulation(&with("runtime")).expect("valid scene");
        for i in 0..2 {
            let q: Vec<f64> = perturbed.q(i).iter().map(|x| x * (1.0 + 1e-15)).collect();
            let v = perturbed.v(i).to_vec();
            perturbed.set_state(i, &q, &v);
        }
        let mut saved = None;
        let (mut worst, mut spread): (f64, f64) = (0.0, 0.0);
        for k in 0..15 {
            if k == 6 {
                saved = Some(embedded.state());
            }
            runtime.step().expect("runtime step");
            embedded.step().expect("embedded step");
            perturbed.step().expect("perturbed step");
            worst = worst.max(q_apart(&runtime, &embedded));
            spread = spread.max(q_apart(&runtime, &perturbed));
        }
        eprintln!(
            "pinned: engines {worst:.3e} apart, the scene from itself {spread:.3e}; {:?}",
            embedded.stats()
        );
        // unloaded the same bits; the loads' terms to round-off as in
        // point_loads_on_the_embedded_engine_are_the_runtime_engines, which the pinned
        // wavy strand whipped by its tip loads (487 substeps in 15 steps) carries as far
        // as the scene carries a change of q0 by 1e-15
        assert!(
            worst <= (1e-12f64).max(10.0 * spread),
            "largest relative |Δq| {worst:.3e}, spread {spread:.3e}"
        );
        assert_eq!(runtime.stats().substeps, embedded.stats().substeps);
        // the joint turns: the root is not clamped
        let joint = embedded.q(1)[..3]
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(joint > 1e-3, "the joint's coordinates {joint:e}");
        resumes_exactly(&with("auto"), saved, (6, 15), &embedded);
    }
}

/// `text` with its strands charged (`[electrostatics]`).
fn charged(text: &str) -> String {
    format!("{text}\n[electrostatics]\ncharge_per_length = -1e-9\nmethod = \"direct\"\n")
}

/// The scene's strands under point loads: on the curly strand a dead load pulling
/// sideways and up at mid-length, on the wavy one a dead load at its tip and a follower
/// load along its tip's n1 (about half their weights each).
fn loaded(engine: &str, extra: &str) -> String {
    scene(engine, extra).replace(
        "preset = \"curly\"\n",
        "preset = \"curly\"\n[[strands.point_loads]]\ns = 0.1\nforce = [0.0, 4e-5, 3e-5]\n",
    ) + "[[strands.point_loads]]\ns = 0.25\nforce = [5e-5, 0.0, 0.0]\n\
         [[strands.point_loads]]\ns = 0.25\nforce = [0.0, 4e-5, 0.0]\nfollows = true\n"
}

#[test]
fn point_loads_on_the_embedded_engine_are_the_runtime_engines() {
    // dead and follower loads on a shaking head, with fixed steps and under a tolerance:
    // both engines on the one step, the runtime's kernels and the fixed-N closed forms
    for extra in ["", "tolerance = 1e-3"] {
        let mut runtime = simulation(&loaded("runtime", extra)).expect("valid scene");
        let mut embedded = simulation(&loaded("auto", extra)).expect("valid scene");
        assert_eq!(
            embedded.engine(),
            superhelix_runtime::config::Engine::Embedded
        );
        let mut unloaded = simulation(&scene("embedded", extra)).expect("valid scene");
        let mut unloaded_runtime = simulation(&scene("runtime", extra)).expect("valid scene");
        let (mut worst, mut moved, mut baseline): (f64, f64, f64) = (0.0, 0.0, 0.0);
        for _ in 0..15 {
            runtime.step().expect("runtime step");
            embedded.step().expect("embedded step");
            unloaded.step().expect("unloaded step");
            unloaded_runtime.step().expect("unloaded step");
            for i in 0..2 {
                let (a, b) = (runtime.q(i), embedded.q(i));
                let scale = a.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                for ((x, y), z) in a.iter().zip(b).zip(unloaded.q(i)) {
                    worst = worst.max((x - y).abs() / scale);
                    moved = moved.max((x - z).abs() / scale);
                }
                let (a, b) = (unloaded_runtime.q(i), unloaded.q(i));
                let scale = a.iter().fold(1.0f64, |m, x| m.max(x.abs()));
                for (x, y) in a.iter().zip(b) {
                    baseline = baseline.max((x - y).abs() / scale);
                }
            }
        }
        eprintln!("{extra:?}: engines {worst:.3e} apart (unloaded {baseline:.3e}), the loads moved q by {moved:.3e}");
        // unloaded, the two engines give the same bits; the loads' terms come from the
        // runtime's kernel (its point, the frame by the reconstruction) on one side and
        // from the closed forms' strand point on the other, equal to round-off: measured
        // 5.5e-13 at fixed steps, 4.9e-12 under the tolerance (its step sizes follow
        // the error estimates, round-off and all)
        assert_eq!(baseline, 0.0, "{extra:?}");
        let bound = if extra.is_empty() { 1e-12 } else { 2e-11 };
        assert!(
            worst <= bound,
            "{extra:?}: largest relative |Δq| {worst:.3e}"
        );
        // the loads act: q is not the unloaded strands'
        assert!(moved > 1e-2, "{extra:?}: the loads moved q by {moved:.3e}");
        assert_eq!(
            runtime.stats().substeps,
            embedded.stats().substeps,
            "{extra:?}"
        );
        // every solve has gravity's and the loads' stiffness in its matrix, by the
        // projection: counted on both engines, the error-controlled step's solves too
        for sim in [&runtime, &embedded] {
            let s = sim.stats();
            assert!(s.attempts > 0, "{extra:?}: {s:?}");
            assert_eq!(s.field_projected, s.attempts, "{extra:?}: {s:?}");
        }
    }
}

#[test]
fn charged_strands_on_the_embedded_engine_are_the_runtime_engines_and_resume_exactly() {
    // the Coulomb forces reach both engines' strands as point loads, refreshed every
    // step; a run restored from a state saved halfway ends where the whole run does
    let text = |engine: &str| charged(&loaded(engine, ""));
    let mut runtime = simulation(&text("runtime")).expect("valid scene");
    let mut embedded = simulation(&text("auto")).expect("valid scene");
    assert_eq!(
        embedded.engine(),
        superhelix_runtime::config::Engine::Embedded
    );
    let mut uncharged = simulation(&loaded("auto", "")).expect("valid scene");
    let mut saved = None;
    let (mut worst, mut moved): (f64, f64) = (0.0, 0.0);
    for k in 0..15 {
        if k == 7 {
            saved = Some(embedded.state());
        }
        runtime.step().expect("runtime step");
        embedded.step().expect("embedded step");
        uncharged.step().expect("uncharged step");
        worst = worst.max(q_apart(&runtime, &embedded));
        moved = moved.max(q_apart(&runtime, &uncharged));
    }
    eprintln!("charged: engines {worst:.3e} apart, the charges moved q by {moved:.3e}");
    // as under the scene's loads alone (point_loads_on_the_embedded_engine_are_the_
    // runtime_engines, 5.5e-13): the same terms to round-off, and the charges' forces
    // follow the strands' positions, round-off and all (measured 1.1e-12)
    assert!(worst <= 1e-11, "largest relative |Δq| {worst:.3e}");
    assert!(moved > 1e-6, "the charges moved q by {moved:.3e}");
    resumes_exactly(&text("auto"), saved, (7, 15), &embedded);
}

/// `integrator` on the shaking head of [`scene`], with and without the point loads of
/// [`loaded`]: the embedded engine takes the runtime engine's steps (to round-off),
/// its splits and Newton iterations, resumes a checkpoint to the bit, and is not the
/// linearly implicit Euler step.
fn engines_agree_under(integrator: &str) {
    let line = format!("integrator = \"{integrator}\"");
    for text in [scene("", &line), loaded("", &line)] {
        let with = |engine: &str| text.replace("engine = \"\"", &format!("engine = \"{engine}\""));
        let mut runtime = simulation(&with("runtime")).expect("valid scene");
        let mut embedded = simulation(&with("auto")).expect("valid scene");
        assert_eq!(
            embedded.engine(),
            superhelix_runtime::config::Engine::Embedded
        );
        let mut euler = simulation(&with("auto").replace(&line, "")).expect("valid scene");
        let mut saved = None;
        let (mut worst, mut apart): (f64, f64) = (0.0, 0.0);
        for k in 0..15 {
            if k == 6 {
                saved = Some(embedded.state());
            }
            runtime.step().expect("runtime step");
            embedded.step().expect("embedded step");
            euler.step().expect("euler step");
            worst = worst.max(q_apart(&runtime, &embedded));
            apart = apart.max(q_apart(&runtime, &euler));
        }
        let (r, e) = (runtime.stats(), embedded.stats());
        eprintln!(
            "{integrator}: engines {worst:.3e} apart, {apart:.3e} from linearly implicit Euler; \
             Newton iterations {} / {}, unconverged {} / {}",
            r.newton_iterations, e.newton_iterations, r.newton_unconverged, e.newton_unconverged
        );
        // the same steps and splits; the loads' terms to round-off as in
        // point_loads_on_the_embedded_engine_are_the_runtime_engines (Newton's solves
        // carry that round-off through their iterations: 1.7e-12 measured with loads)
        let bound = if integrator == "bdf2" { 1e-12 } else { 1e-11 };
        assert!(worst <= bound, "largest relative |Δq| {worst:.3e}");
        assert_eq!(r.substeps, e.substeps);
        assert_eq!(r.newton_iterations, e.newton_iterations);
        assert_eq!(r.newton_unconverged, e.newton_unconverged);
        if integrator == "newton-implicit-euler" {
            // every piece took Newton iterations, and some converged (at 33 ms on the
            // shaking head about half do not: the linearly implicit solve replaces them)
            assert!(e.newton_iterations >= 2 * e.attempts, "{e:?}");
            assert!(e.newton_unconverged < e.attempts, "{e:?}");
        } else {
            assert_eq!(e.newton_iterations, 0);
        }
        // the integrator was taken: not the linearly implicit Euler steps
        assert!(apart > 1e-3, "{apart:.3e} from linearly implicit Euler");
        let resumed = resumes_exactly(&with("auto"), saved, (6, 15), &embedded);
        assert_eq!(resumed.stats().newton_iterations, e.newton_iterations);
    }
}

#[test]
fn bdf2_on_the_embedded_engine_is_the_runtime_engines_and_resumes_exactly() {
    // BDF2 with fixed steps on the shaking head (its first steps split: the history is
    // the last accepted piece's, and BDF2 resumes after a split once)
    engines_agree_under("bdf2");
}

#[test]
fn newton_on_the_embedded_engine_is_the_runtime_engines_and_resumes_exactly() {
    // Newton-iterated implicit Euler: the checked step's split and balance, its solves
    // iterated on the terms of the step's end
    engines_agree_under("newton-implicit-euler");
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
        &scene("embedded", "integrator = \"rk4\""),
        "simulation.engine",
    );
    refused(
        &scene("embedded", "kernels = \"generic\""),
        "simulation.kernels",
    );
    refused(&scene("embedded", "mode = \"static\""), "simulation.engine");
    refused(&free(&scene("embedded", "")), "strands[1].ends");
    let odd_n = scene("embedded", "").replace("elements = 8", "elements = 7");
    refused(&odd_n, "SUPERHELIX_N=7");
}

#[test]
fn auto_takes_the_embedded_engine_exactly_where_it_can_run_the_scene() {
    use superhelix_runtime::config::Engine;
    // the default (no `engine` in the scene) is auto
    let plain = scene("auto", "").replace("engine = \"auto\"\n", "");
    let sim = simulation(&plain).expect("valid scene");
    assert_eq!(sim.engine(), Engine::Embedded);
    let setup = parse_scene(&plain).expect("valid scene");
    assert_eq!(
        superhelix_runtime::engine_for(&setup),
        (Engine::Embedded, None)
    );
    // each thing the embedded engine refuses sends the scene to the runtime engine, and
    // engine_for names it
    let odd_n = scene("auto", "").replace("elements = 8", "elements = 7");
    for (text, field) in [
        (
            // (a step RK4 is stable at)
            scene("auto", "integrator = \"rk4\"").replace("dt = 0.03333333333333333", "dt = 3e-7"),
            "simulation.engine",
        ),
        (scene("auto", "kernels = \"generic\""), "simulation.kernels"),
        (free(&scene("auto", "")), "strands[1].ends"),
        (odd_n, "SUPERHELIX_N=7"),
    ] {
        let sim = simulation(&text).expect("valid scene");
        assert_eq!(sim.engine(), Engine::Runtime, "{field}");
        let setup = parse_scene(&text).expect("valid scene");
        let (engine, why) = superhelix_runtime::engine_for(&setup);
        assert_eq!(engine, Engine::Runtime);
        let why = why.map(|e| e.to_string()).unwrap_or_default();
        assert!(why.contains(field), "{field} not named in {why}");
    }
    // the step budget's rules are the fixed-N step's too
    for rules in [
        "max_split_depth = 0",
        "energy_balance = false",
        "field_stiffness = \"explicit\"",
        "integrator = \"newton-implicit-euler\"",
    ] {
        let sim = simulation(&scene("auto", rules)).expect("valid scene");
        assert_eq!(sim.engine(), Engine::Embedded, "{rules}");
    }
    // named explicitly, the runtime engine is kept
    let runtime = simulation(&scene("runtime", "")).expect("valid scene");
    assert_eq!(runtime.engine(), Engine::Runtime);
}

#[test]
fn a_static_solve_on_the_embedded_engine_is_the_runtime_engines() {
    // a dynamic scene on either engine, solved for its equilibrium from the same state
    let mut runtime = simulation(&scene("runtime", "")).expect("valid scene");
    let mut embedded = simulation(&scene("embedded", "")).expect("valid scene");
    let a = runtime.solve_static().expect("runtime statics");
    let b = embedded.solve_static().expect("embedded statics");
    assert_eq!(a.len(), 2);
    assert!(a.iter().chain(&b).all(|r| r.converged), "{a:?} {b:?}");
    for i in 0..2 {
        let (x, y) = (runtime.q(i), embedded.q(i));
        let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let worst = x
            .iter()
            .zip(y)
            .fold(0.0f64, |m, (p, r)| m.max((p - r).abs() / scale));
        // the same Newton iteration on the generated fixed-N kernel and on the moment
        // kernel of the same closed forms (they agree to ~1e-12)
        assert!(
            worst <= 1e-9,
            "strand {i}: largest relative |Δq| {worst:.3e}"
        );
        let (fx, fy) = (runtime.static_force(i), embedded.static_force(i));
        let largest = fx.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = fx
            .iter()
            .zip(&fy)
            .fold(0.0f64, |m, (p, r)| m.max((p - r).abs()));
        assert!(
            diff <= 1e-9 * largest.max(1e-12),
            "strand {i}: F differs by {diff:e}"
        );
    }
}

/// The scene's strands on a head turning at 180°/s that stops within 0.1 s at t = 0.5 s
/// (its inertial phase starts at 0.6 s, inside the step [0.58333, 0.625] at 1/24 s), and
/// a jolt of the head (two phase changes, at 0.1 and 0.15 s).
fn phased_scene(engine: &str, motion: &str, extra: &str) -> String {
    scene(engine, extra)
        .replace("dt = 0.03333333333333333", "dt = 0.041666666666666664")
        .replace("duration = 0.5", "duration = 0.75")
        .replace(
            "motion = { kind = \"oscillate\", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }",
            motion,
        )
}

#[test]
fn a_step_across_a_change_of_the_heads_motion_is_two_steps_cut_there() {
    // the steps land on the head's phase changes (`phase_cut`): a frame step across one
    // gives the state of two steps ending and starting there (to round-off: the two runs'
    // clocks may differ in their last bit after the cut), so an inertial phase's energy
    // ceiling is the energy at its exact start; a step not cut there differs by far more
    // (the linearisation is taken at other states)
    let stop = "motion = { kind = \"sudden-stop\", axis = [0.0, 0.0, 1.0], angular_speed_deg = 180.0, stop_time = 0.5, stop_duration = 0.1 }";
    let jolt = "motion = { kind = \"jolt\", direction = [0.0, 1.0, 0.0], acceleration = 30.0, start = 0.1, duration = 0.05 }";
    for (motion, changes) in [(stop, vec![0.6]), (jolt, vec![0.1, 0.15])] {
        for engine in ["runtime", "embedded"] {
            for extra in ["", "tolerance = 1e-3"] {
                let case = format!("{engine} {extra} {motion}");
                let text = phased_scene(engine, motion, extra);
                let mut whole = simulation(&text).expect("valid scene");
                let mut cut = simulation(&text).expect("valid scene");
                let dt = whole.config().dt;
                let mut crossed = 0;
                for _ in 0..18 {
                    whole.step().expect("step");
                    let (t, end) = (cut.time(), whole.time());
                    match changes.iter().find(|&&b| b > t + 1e-9 && b < end - 1e-9) {
                        Some(&b) => {
                            cut.step_by(b - t).expect("step to the change");
                            cut.step_by(end - b).expect("step from the change");
                            crossed += 1;
                        }
                        None => cut.step_by(dt).expect("step"),
                    }
                    for i in 0..2 {
                        for (k, (a, b)) in whole.q(i).iter().zip(cut.q(i)).enumerate() {
                            let scale = 1e-12 * a.abs().max(1.0);
                            assert!(
                                (a - b).abs() <= scale,
                                "{case}: q[{k}] at t = {end}: {a} vs {b}"
                            );
                        }
                        for (k, (a, b)) in whole.v(i).iter().zip(cut.v(i)).enumerate() {
                            let scale = 1e-10 * a.abs().max(1.0);
                            assert!(
                                (a - b).abs() <= scale,
                                "{case}: q̇[{k}] at t = {end}: {a} vs {b}"
                            );
                        }
                    }
                }
                assert_eq!(crossed, changes.len(), "{case}");
            }
        }
    }
}

#[test]
fn strands_at_rest_or_on_a_smoothly_moving_head_take_one_solve_per_step() {
    // the scene's two strands (N = 5 and 8, curly and wavy, with their drag and friction)
    // settled on a still head, then the head nodding smoothly (0.5 Hz by ±15°) and
    // turning at 30°/s: every step is one solve on both engines, nothing split or limited
    let nod = "motion = { kind = \"oscillate\", axis = [0.0, 1.0, 0.0], angle_deg = 15.0, frequency_hz = 0.5 }";
    let turn = "motion = { kind = \"sudden-stop\", axis = [0.0, 0.0, 1.0], angular_speed_deg = 30.0, stop_time = 100.0, stop_duration = 1.0 }";
    for engine in ["runtime", "embedded"] {
        let still = scene(engine, "").replace(
            "motion = { kind = \"oscillate\", axis = [0.0, 0.0, 1.0], angle_deg = 30.0, frequency_hz = 2.0 }",
            "motion = { kind = \"still\" }",
        );
        let mut rest = simulation(&still).expect("valid scene");
        rest.solve_static().expect("static equilibrium");
        for motion in ["motion = { kind = \"still\" }", nod, turn] {
            let text = still.replace("motion = { kind = \"still\" }", motion);
            let mut sim = simulation(&text).expect("valid scene");
            for i in 0..2 {
                let v = vec![0.0; rest.q(i).len()];
                sim.set_state(i, rest.q(i), &v);
            }
            for _ in 0..15 {
                sim.step().expect("step");
            }
            let stats = sim.stats();
            let case = format!("{engine}, {motion}");
            assert_eq!(stats.attempts, 2 * 15, "{case}: {stats:?}");
            assert_eq!(stats.substeps, 0, "{case}: {stats:?}");
            assert_eq!(stats.energy_limited, 0, "{case}: {stats:?}");
            if motion != "motion = { kind = \"still\" }" {
                // the strands did move with the head
                assert!(sim.max_speed() > 1e-3, "{case}: {}", sim.max_speed());
            }
        }
    }
}

/// A frictionless straight 20 cm strand (N = 5) released horizontal under gravity on a
/// still head, 15 steps of 1/30 s: (E(0.5 s) − E(0)) / (m g L), the run's statistics.
fn released_swing(
    engine: &str,
    extra: &str,
) -> (f64, superhelix_runtime::solver::stats::StepStats) {
    let text = format!(
        r#"
[simulation]
dt = 0.03333333333333333
duration = 0.5
engine = "{engine}"
{extra}
[environment]
gravity = [0.0, 0.0, -9.81]
[[strands]]
name = "swing"
root = [0.09, 0.0, 0.0]
direction = [1.0, 0.0, 0.0]
length = 0.2
elements = 5
preset = "smooth"
internal_friction = 0.0
air_drag = 0.0
"#
    );
    let mut sim = simulation(&text).expect("valid scene");
    let e0 = sim.energy(0);
    for _ in 0..15 {
        sim.step().expect("step");
    }
    let scale = sim.strand(0).geometry.mass_per_length * 0.2 * 9.81 * 0.2;
    ((sim.energy(0) - e0) / scale, sim.stats())
}

#[test]
fn a_swinging_strand_splits_the_steps_that_lose_too_much_energy() {
    // implicit Euler damps what it does not resolve: the steps of a swing that rotate an
    // element beyond 0.2 rad and lose more than 0.4 % of the energy scale beyond the
    // dissipation bound (none here) are split, on both engines alike
    let (unchecked, plain) = released_swing("runtime", "energy_balance = false");
    let (runtime, stats) = released_swing("runtime", "");
    let (embedded, fixed) = released_swing("embedded", "");
    eprintln!(
        "E(0.5 s) - E(0), / mgL: whole steps {unchecked:.4e} ({} solves), split {runtime:.4e} \
         ({} solves, {} for the energy), embedded {embedded:.4e} ({} solves)",
        plain.attempts, stats.attempts, stats.energy_rejected, fixed.attempts
    );
    assert_eq!(plain.energy_rejected, 0);
    assert!(stats.energy_rejected > 0, "{stats:?}");
    assert_eq!(
        (stats.attempts, stats.energy_rejected),
        (fixed.attempts, fixed.energy_rejected)
    );
    assert!(
        (runtime - embedded).abs() <= 1e-9,
        "{runtime:e} vs {embedded:e}"
    );
    // no energy created, and far less lost than by the whole steps (measured −0.26 mgL
    // whole, −0.12 mgL split, in 60 solves against 15)
    assert!(runtime < 0.0 && unchecked < 0.0);
    assert!(
        runtime > 0.5 * unchecked,
        "{runtime:e} against {unchecked:e}"
    );
}

/// A scene file of `scenes/` with `engine` set and `duration`.
fn scene_file(text: &str, engine: &str, duration: &str) -> String {
    text.replacen(
        "[simulation]\n",
        &format!("[simulation]\nengine = \"{engine}\"\n"),
        1,
    )
    .replacen("duration = 2.0", &format!("duration = {duration}"), 1)
}

#[test]
fn a_held_tip_on_the_embedded_engine_is_the_runtime_engines_and_resumes_exactly() {
    use superhelix_runtime::config::Engine;
    // the buckling column (tip sliding on its axis, under a dead load) and Greenhill's
    // shaft (tip clamped on a slider, twisted): the held tip the one step's hook on both
    // engines, the same constraint rows, reactions and drift to the bit. The driven rope
    // (root pinned, its joint an element: 9 + 1 elements; tip pinned to a holder moving
    // up and down) resting on a ball (its tip's samples left to the holder, the ball's
    // force in the reaction at rest): the same steps to round-off, as far apart as the
    // same rope with a free tip (the two engines' contacts find a pinned strand's sample
    // points by different chains of the same closed forms: 1.2e-10 m apart over 0.2 s,
    // `superhelix run` of either scene)
    let rope = scene_file(
        include_str!("../../scenes/rod-driven.toml"),
        "ENGINE",
        "0.2",
    )
    .replace("elements = 30", "elements = 9")
        + "\n[[bodies]]\nname = \"ball\"\nshape = \"sphere\"\ncenter = [0.2, 0.0, -0.1645]\n\
           radius = 0.04\n\n[contacts]\nradius = 2e-4\nfriction = \"none\"\n\
           friction_coefficient = 0.3\n";
    for (name, text, steps) in [
        (
            "buckling",
            scene_file(
                include_str!("../../scenes/rod-buckling.toml"),
                "ENGINE",
                "0.2",
            ),
            60,
        ),
        (
            "greenhill",
            scene_file(
                include_str!("../../scenes/rod-greenhill.toml"),
                "ENGINE",
                "0.2",
            ),
            60,
        ),
        ("driven rope on a ball", rope, 90),
    ] {
        let with = |engine: &str| text.replace("ENGINE", engine);
        let mut runtime = simulation(&with("runtime")).expect("valid scene");
        let mut embedded = simulation(&with("auto")).expect("valid scene");
        assert_eq!(embedded.engine(), Engine::Embedded, "{name}");
        // the reaction at rest (frame 0) is the same
        assert_eq!(
            runtime.held_reaction(0),
            embedded.held_reaction(0),
            "{name}"
        );
        let on_ball = name.contains("ball");
        let length = embedded.strand(0).geometry.length();
        let mut saved = None;
        let (mut drift, mut touched, mut worst): (f64, usize, f64) = (0.0, 0, 0.0);
        for k in 0..steps {
            if k == steps / 2 {
                saved = Some(embedded.state());
            }
            runtime.step().expect("runtime step");
            embedded.step().expect("embedded step");
            let (a, b) = (runtime.take_held_drift(0), embedded.take_held_drift(0));
            if on_ball {
                let (p, r) = (
                    runtime.centreline_world(0, 4),
                    embedded.centreline_world(0, 4),
                );
                let apart = p
                    .iter()
                    .zip(&r)
                    .map(|(x, y)| {
                        let d: Vec<f64> = x.iter().zip(y).map(|(u, w)| u - w).collect();
                        (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
                    })
                    .fold(0.0, f64::max);
                worst = worst.max(apart / length);
            } else {
                assert_eq!(runtime.q(0), embedded.q(0), "{name}: step {k}");
                assert_eq!(runtime.v(0), embedded.v(0), "{name}: step {k}");
                assert_eq!(
                    runtime.held_reaction(0),
                    embedded.held_reaction(0),
                    "{name}"
                );
                assert_eq!(a, b, "{name}: drift at step {k}");
            }
            drift = drift.max(b.expect("a held tip"));
            if let Some(c) = embedded.contact_summary(0) {
                touched = touched.max(c.body_contacts);
            }
        }
        if on_ball {
            // (the rope does rest on the ball)
            assert!(touched > 0, "{name}: no sample touched the ball");
            assert!(worst <= 1e-9, "{name}: the engines {worst:.3e} L apart");
        }
        assert_eq!(
            runtime.stats().substeps,
            embedded.stats().substeps,
            "{name}"
        );
        if on_ball {
            eprintln!("{name}: the engines {worst:.3e} L apart");
        }
        // the holder pulls (a reaction of the order of the loads), the tip stays on it
        let reaction = embedded.held_reaction(0).expect("a held tip");
        assert!(reaction.norm() > 1e-6, "{name}: reaction {reaction:?}");
        assert!(drift <= 1e-9, "{name}: drift {drift:e} L");
        // a checkpoint halfway resumes to the bit, the holder's reaction with it
        let mut resumed = simulation(&with("auto")).expect("valid scene");
        resumed
            .restore(saved.expect("a saved state"))
            .expect("restore");
        for _ in steps / 2..steps {
            resumed.step().expect("resumed step");
        }
        assert_eq!(resumed.q(0), embedded.q(0), "{name}");
        assert_eq!(resumed.v(0), embedded.v(0), "{name}");
        assert_eq!(
            resumed.held_reaction(0),
            embedded.held_reaction(0),
            "{name}"
        );
        eprintln!(
            "{name}: {} steps, {} substeps, reaction {:.3e} N, drift {drift:.1e} L, \
             {touched} samples on the ball at most",
            steps,
            embedded.stats().substeps,
            reaction.fixed_rows::<3>(0).norm()
        );
    }
}

#[test]
fn a_free_root_on_the_embedded_engine_is_the_runtime_engines_and_resumes_exactly() {
    use superhelix_runtime::config::Engine;
    // the wavy strand with a free root on the shaking head (its chain 7 + 1 elements, the
    // joint counted: a checked-in size), with and without point loads: the translation's
    // terms the kernels' `Floating` over the closed forms on the embedded engine, over the
    // runtime's kernel on the runtime engine. Unloaded the same bits over 15 steps; the
    // loaded rod whips (9 to 25 substeps a step) and from its eighth step the energy
    // checks' decisions part any two runs, the scene from itself under a change of q0 by
    // 1e-15 too (1.6e-3 apart at step 8): compared over its first 7 steps, where both
    // stay at round-off
    for (text, steps) in [(scene("", ""), 15), (loaded("", ""), 7)] {
        let text = free(&text.replace("elements = 8", "elements = 7"));
        let with = |engine: &str| text.replace("engine = \"\"", &format!("engine = \"{engine}\""));
        let mut runtime = simulation(&with("runtime")).expect("valid scene");
        let mut embedded = simulation(&with("auto")).expect("valid scene");
        assert_eq!(embedded.engine(), Engine::Embedded);
        assert_eq!(embedded.q(1).len(), 3 * 8 + 3);
        let x0 = embedded.q(1)[24..].to_vec();
        let mut perturbed = simulation(&with("runtime")).expect("valid scene");
        for i in 0..2 {
            let q: Vec<f64> = perturbed.q(i).iter().map(|x| x * (1.0 + 1e-15)).collect();
            let v = perturbed.v(i).to_vec();
            perturbed.set_state(i, &q, &v);
        }
        let mut saved = None;
        let (mut worst, mut spread): (f64, f64) = (0.0, 0.0);
        for k in 0..steps {
            if k == steps / 2 {
                saved = Some(embedded.state());
            }
            runtime.step().expect("runtime step");
            embedded.step().expect("embedded step");
            perturbed.step().expect("perturbed step");
            worst = worst.max(q_apart(&runtime, &embedded));
            spread = spread.max(q_apart(&runtime, &perturbed));
        }
        let moved = embedded.q(1)[24..]
            .iter()
            .zip(&x0)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        eprintln!(
            "free root: engines {worst:.3e} apart, the scene from itself {spread:.3e}; the root moved {moved:.3e} m; {:?}",
            embedded.stats()
        );
        assert!(moved > 0.1, "the free root moved {moved} m");
        assert!(
            worst <= (1e-12f64).max(10.0 * spread),
            "largest relative |Δq| {worst:.3e}, spread {spread:.3e}"
        );
        assert_eq!(runtime.stats().substeps, embedded.stats().substeps);
        resumes_exactly(&with("auto"), saved, (steps / 2, steps), &embedded);
    }
    // the open ring of rod-free.toml (elements = 11: a chain of 12 with the joint)
    // dropped onto a floor with Coulomb friction: it lands, rocks and stands; the
    // contacts' points moved by the root's translation on the embedded engine, the
    // runtime's kernel points on the runtime engine
    let ring = include_str!("../../scenes/rod-free.toml")
        .replace("elements = 12", "elements = 11")
        .replace("duration = 1.0", "duration = 0.6");
    let with = |engine: &str| {
        ring.replacen(
            "[simulation]\n",
            &format!("[simulation]\nengine = \"{engine}\"\n"),
            1,
        )
    };
    let mut runtime = simulation(&with("runtime")).expect("valid scene");
    let mut embedded = simulation(&with("auto")).expect("valid scene");
    assert_eq!(embedded.engine(), Engine::Embedded);
    let length = embedded.strand(0).geometry.length();
    let (mut worst, mut touched): (f64, usize) = (0.0, 0);
    let mut saved = None;
    let steps = 600;
    for k in 0..steps {
        if k == steps / 2 {
            saved = Some(embedded.state());
        }
        runtime.step().expect("runtime step");
        embedded.step().expect("embedded step");
        let (a, b) = (
            runtime.centreline_world(0, 4),
            embedded.centreline_world(0, 4),
        );
        for (x, y) in a.iter().zip(&b) {
            let d = ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt();
            worst = worst.max(d / length);
        }
        if let Some(c) = embedded.contact_summary(0) {
            touched = touched.max(c.body_contacts);
        }
    }
    let deepest = embedded.max_penetration().unwrap_or(0.0);
    eprintln!(
        "free ring on the floor: engines {worst:.3e} L apart over 0.6 s, {touched} samples on the floor at most, deepest {deepest:.2e} m; {:?}",
        embedded.stats()
    );
    assert!(touched > 0, "the ring never reached the floor");
    assert!(worst <= 1e-9, "the engines {worst:.3e} L apart");
    let mut resumed = simulation(&with("auto")).expect("valid scene");
    resumed
        .restore(saved.expect("a saved state"))
        .expect("restore");
    for _ in steps / 2..steps {
        resumed.step().expect("resumed step");
    }
    assert_eq!(resumed.q(0), embedded.q(0));
    assert_eq!(resumed.v(0), embedded.v(0));
    // a free root whose chain (12 + 1) has no fixed-N code in this build: auto names it
    let setup = parse_scene(include_str!("../../scenes/rod-free.toml")).expect("valid scene");
    let (engine, why) = superhelix_runtime::engine_for(&setup);
    assert_eq!(engine, Engine::Runtime);
    assert!(why.is_some_and(|e| e.to_string().contains("strands[0].ends")));
}

#[test]
fn the_free_root_groups_are_the_sizes_with_fixed_n_code() {
    for n in 0..=64 {
        let group = superhelix_runtime::solver::embedded::floating_group_for(n);
        assert_eq!(
            group.is_some(),
            superhelix_generated::fixed::SIZES.contains(&n),
            "N = {n}"
        );
        if let (Some(free), Some(held)) =
            (group, superhelix_runtime::solver::embedded::group_for(n))
        {
            // 3N + 3 coordinates against 3N: a larger strand
            assert!(free.strand_bytes() > held.strand_bytes(), "N = {n}");
        }
    }
}

/// A run's whole q (a pinned root's joint first, a free root's translation last) fed back
/// as a scene's `q0` starts the rod exactly where the run left it (continuation): the
/// same q to the bit and the same centreline, on a pinned root after a third of a second
/// on the shaking head, and on a free one.
#[test]
fn a_runs_whole_q_is_a_scenes_q0() {
    for (name, held) in [("pinned", pinned as fn(&str) -> String), ("free", free)] {
        let engine = if name == "free" {
            "runtime"
        } else {
            "embedded"
        };
        // 7 + 1 elements with the joint: a fixed-N group of the embedded engine
        let text = held(&scene(engine, "").replace("elements = 8", "elements = 7"));
        let mut sim = simulation(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        for _ in 0..10 {
            sim.step().unwrap_or_else(|e| panic!("{name}: {e}"));
        }
        let q = sim.q(1).to_vec();
        assert_eq!(q.len(), 3 * 7 + if name == "free" { 6 } else { 3 });
        let values: Vec<String> = q.iter().map(|x| format!("{x:?}")).collect();
        let again = text.replace(
            "preset = \"wavy\"\n",
            &format!("preset = \"wavy\"\nq0 = [{}]\n", values.join(", ")),
        );
        let fresh = simulation(&again).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(fresh.q(1), q.as_slice(), "{name}");
        let length = sim.strand(1).geometry.length();
        for k in 0..=10 {
            let s = length * k as f64 / 10.0;
            let (a, b) = (sim.position_at(1, s), fresh.position_at(1, s));
            assert!(
                (a - b).norm() < 1e-12,
                "{name} at s = {s}: {a:?} against {b:?}"
            );
        }
    }
}

/// Gravity changed between two steps (`Simulation::set_gravity`) acts on both engines
/// alike: after 5 steps gravity is turned sideways and doubled, and 10 steps later the
/// engines still agree to 1e-12 (as without the change), while the state is far from the
/// run left with the scene's gravity (the change took effect).
#[test]
fn gravity_set_between_steps_acts_on_both_engines_alike() {
    let sideways = Some(nalgebra::Vector3::new(19.62, 0.0, 0.0));
    let mut runs: Vec<Simulation> = ["runtime", "embedded", "embedded"]
        .iter()
        .map(|e| simulation(&scene(e, "")).expect("valid scene"))
        .collect();
    for k in 0..15 {
        if k == 5 {
            runs[0].set_gravity(sideways);
            runs[1].set_gravity(sideways);
        }
        for r in &mut runs {
            r.step().expect("step");
        }
    }
    assert_eq!(runs[1].gravity(), sideways);
    let apart = q_apart(&runs[0], &runs[1]);
    assert!(apart <= 1e-12, "engines {apart:.3e} apart");
    let changed = q_apart(&runs[1], &runs[2]);
    assert!(
        changed > 1e-2,
        "the change moved the strands by only {changed:.3e}"
    );
}

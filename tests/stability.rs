//! Hard cases that must stay numerically stable.
//!
//! Issue #2, point 6: every preset, N = 10, dt = 1/30 s, the head oscillating at 3 Hz
//! through ±40° for 10 s: all values finite, bounded kinetic energy, and the same result
//! run to run.
//!
//! Issue #4, second section: the hard-case matrix of [`superhelix::stress`] (also run by
//! `superhelix stress`). Its quick subset runs by default; the full matrix, one test per
//! group, with `cargo test --release --test stability -- --ignored`.

use superhelix::runtime::config::{
    FieldStiffness, IntegratorKind, KernelChoice, SimulationConfig, SimulationSetup, StrandSetup,
};
use superhelix::runtime::model::material::{helix_curvature, HelixForm, Preset};
use superhelix::runtime::model::strand::{Strand, StrandGeometry};
use superhelix::runtime::{Environment, HeadMotion, Simulation};
use superhelix::runtime::{Matrix3, Vector3};
use superhelix::stress;

fn preset_strand(preset: Preset, n: usize, length: f64) -> Strand {
    let p = preset.params();
    let material = p.cross_section.material();
    // root on a 10 cm head, pointing sideways: n0 = x, n1 = y, n2 = z
    let natural = helix_curvature(p.helix_radius, p.helix_step, HelixForm::Exact);
    Strand {
        name: preset.name().to_string(),
        geometry: StrandGeometry::new(
            Vector3::new(0.1, 0.0, 0.0),
            Matrix3::identity(),
            vec![length / n as f64; n],
            &material,
        ),
        material,
        natural: (0..n).flat_map(|_| natural).collect(),
        internal_friction: p.internal_friction,
        air_drag: p.air_drag,
        point_loads: Vec::new(),
        ends: Default::default(),
    }
}

/// Largest kinetic energy (relative to the head) seen in the first and the second half
/// of a run, in units of ½ m (Ω_max (r + L))²: the kinetic energy of the strand dragged
/// rigidly at the head's top speed.
#[derive(Debug, Clone, Copy, PartialEq)]
struct KineticPeaks {
    first_half: f64,
    second_half: f64,
    /// Largest ratio, over the strands, of the mean kinetic energy of the second half to
    /// that of the first.
    mean_growth: f64,
    /// Largest mean kinetic energy of a strand over the second half, same unit.
    second_half_mean: f64,
}

/// Run every preset on a head oscillating at `hz` through ±`deg`; returns the final q of
/// each strand and the kinetic-energy peaks (worst strand).
fn run(
    integrator: IntegratorKind,
    n: usize,
    dt: f64,
    duration: f64,
    hz: f64,
    deg: f64,
) -> (Vec<Vec<f64>>, KineticPeaks) {
    let length = 0.25;
    let strands: Vec<Strand> = Preset::ALL
        .iter()
        .map(|&p| preset_strand(p, n, length))
        .collect();
    let amplitude = deg.to_radians();
    let setup = SimulationSetup {
        electrostatics: None,
        contacts: None,
        config: SimulationConfig {
            dt,
            duration,
            integrator,
            kernels: KernelChoice::Auto,
            ..SimulationConfig::default()
        },
        environment: Environment {
            gravity: Some(Vector3::new(0.0, 0.0, -9.81)),
        },
        head: HeadMotion::Oscillate {
            axis: Vector3::z(),
            amplitude,
            frequency_hz: hz,
            center: Vector3::zeros(),
        },
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
    };
    let mut sim = Simulation::new(setup, superhelix::kernel_factory()).expect("valid setup");
    let omega_max = amplitude * 2.0 * std::f64::consts::PI * hz;
    let mut peaks = KineticPeaks {
        first_half: 0.0,
        second_half: 0.0,
        mean_growth: 0.0,
        second_half_mean: 0.0,
    };
    let steps = (duration / dt).round() as usize;
    let mut sums = vec![[0.0f64; 2]; sim.strand_count()];
    for step in 0..steps {
        sim.step().expect("stable step");
        for (i, sum) in sums.iter_mut().enumerate() {
            let mass = sim.strand(i).material.mass_per_length * length;
            let scale = 0.5 * mass * (omega_max * (0.1 + length)).powi(2);
            let k = sim.kinetic_energy(i) / scale;
            let peak = if step < steps / 2 {
                &mut peaks.first_half
            } else {
                &mut peaks.second_half
            };
            *peak = peak.max(k);
            sum[usize::from(step >= steps / 2)] += k;
            assert!(sim.q(i).iter().chain(sim.v(i)).all(|x| x.is_finite()));
        }
    }
    peaks.mean_growth = sums.iter().map(|s| s[1] / s[0]).fold(0.0, f64::max);
    let half = (steps - steps / 2) as f64;
    peaks.second_half_mean = sums.iter().map(|s| s[1] / half).fold(0.0, f64::max);
    println!("solver: {:?}", sim.stats());
    (
        (0..sim.strand_count()).map(|i| sim.q(i).to_vec()).collect(),
        peaks,
    )
}

/// The bound both shake tests put on a run's kinetic-energy peaks: below 10 times the
/// rigid-drag scale in each half of the run (why 10: see the implicit Euler test).
#[track_caller]
fn assert_peaks_bounded(peaks: &KineticPeaks) {
    assert!(
        peaks.first_half < 10.0 && peaks.second_half < 10.0,
        "{peaks:?}"
    );
}

#[test]
fn every_preset_survives_a_3hz_40deg_shake_at_30_fps_deterministically() {
    let lie = IntegratorKind::LinearlyImplicitEuler;
    let (first, peaks) = run(lie, 10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    println!("kinetic energy peaks / rigid-drag scale: {peaks:?}");
    // Bounded: a whip concentrates energy in its tip, so the relative kinetic energy may
    // exceed the rigid-drag scale a few times, but never beyond 10x the scale (tip 3x the
    // head's speed), and it must not grow: under periodic forcing with friction and drag
    // each strand's mean kinetic energy over the second half stays within 1.5x that of the
    // first. (Means rather than peaks, which are more sensitive to the irregular
    // whipping. Measured: peaks 1.31 and 1.59 times the scale, mean growth 1.06, the same
    // to 1e-6 on the generic and the generated kernels.)
    assert_peaks_bounded(&peaks);
    assert!(peaks.mean_growth < 1.5, "kinetic energy grows: {peaks:?}");
    let (second, _) = run(lie, 10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    assert_eq!(first, second, "two runs differ");
}

/// Run `cases` and print the report; fail, naming every case, strand, time and cause, on
/// a failure of a case whose name `is_known` does not accept. Returns the results for the
/// caller's own checks of the known failures.
fn run_failing_only_where_known(
    cases: &[stress::Case],
    is_known: impl Fn(&str) -> bool,
) -> Vec<stress::CaseResult> {
    let start = std::time::Instant::now();
    let results = stress::run_cases(cases);
    let text = stress::render(&results, start.elapsed().as_secs_f64());
    println!("{text}");
    let unexpected: Vec<String> = results
        .iter()
        .filter(|r| !is_known(r.name.as_str()))
        .filter_map(stress::failure_line)
        .collect();
    assert!(
        unexpected.is_empty(),
        "{} case(s) failed:\n{}",
        unexpected.len(),
        unexpected.join("\n")
    );
    results
}

/// Run `cases`; fail, naming every case, strand, time and cause, on a failure that is not
/// in `KNOWN_FAILURES`, and on a known failure that passes.
fn run_and_check(cases: &[stress::Case]) {
    let results = run_failing_only_where_known(cases, stress::is_known_failure);
    let fixed: Vec<&str> = results
        .iter()
        .filter(|r| r.passed() && stress::is_known_failure(&r.name))
        .map(|r| r.name.as_str())
        .collect();
    assert!(
        fixed.is_empty(),
        "known failures that pass now (remove them from stress::KNOWN_FAILURES): {fixed:?}"
    );
}

#[test]
fn quick_subset_of_the_hard_cases_passes() {
    let cases = stress::quick_cases();
    assert!(cases.len() >= 80, "{}", cases.len());
    assert!(cases.iter().all(|c| !stress::is_known_failure(&c.name)));
    run_and_check(&cases);
}

#[test]
fn quick_subset_of_the_hard_cases_passes_with_the_dissipative_split() {
    // `field_stiffness = "split"` (superhelix_kernels::field_split): the same checks, every
    // case passes; the split takes the field stiffness of 40,725 solves, its fallback (the
    // spectral projection where the factorisation breaks down) 11, and the frictionless
    // and touching strands keep the projection on 11,850. The fallback is held to the bound,
    // 5 % of the solves of strands that take the split
    let cases = stress::with_field_stiffness(stress::quick_cases(), FieldStiffness::Split);
    assert!(cases.len() >= 80, "{}", cases.len());
    let results = run_failing_only_where_known(&cases, |_| false);
    let split: usize = results.iter().map(|r| r.field_split).sum();
    let projected: usize = results.iter().map(|r| r.field_projected).sum();
    let undamped: usize = results.iter().map(|r| r.field_undamped).sum();
    println!("split {split}, fallback {projected}, kept on the projection {undamped}");
    assert!(split > 10_000 && undamped > 0, "{split} {undamped}");
    assert!(
        projected as f64 <= 0.05 * (split + projected) as f64,
        "{projected} of {}",
        split + projected
    );
}

#[test]
fn free_rods_dropped_onto_a_floor_at_one_solve_per_step_create_no_energy() {
    // the hard cases' free rods dropped onto a floor (N = 5 and 20, 30 and 100 frames per
    // second), at the step budget of one solve per strand-step, by linearly implicit Euler
    // and BDF2: a step whose end has more potential energy than the balance allows
    // cannot be split there; its change of q is pulled back (`energy_pulled_back`). Accepted
    // as it was, the N = 20 rod at 100 frames per second gained 0.075 S (0.29 S by BDF2)
    // against the cases' limit of 10⁻⁶ S
    let floor: Vec<stress::Case> = stress::all_cases()
        .into_iter()
        .filter(|c| c.name.starts_with("ends/free-root/floor/"))
        .collect();
    assert_eq!(floor.len(), 4);
    let mut cases = stress::with_max_split_depth(floor.clone(), 0);
    cases.extend(stress::with_max_split_depth(
        stress::with_integrator(floor, IntegratorKind::Bdf2),
        0,
    ));
    let results = run_failing_only_where_known(&cases, |_| false);
    let unbalanced: usize = results.iter().map(|r| r.unbalanced).sum();
    assert_eq!(unbalanced, 0);
}

#[test]
fn free_rods_under_a_tolerance_pass() {
    // the hard cases' free rods (flailing, dropped on a floor) under the error control:
    // the step's estimate compares the element ends of its two solutions; a free root's
    // translation is a coordinate but not an element, and an estimate that counted an
    // end past the strand's last compared stale poses, found the steps never accurate
    // enough and shrank them to nothing ("dt: must be finite and > 0" on the flailing rod)
    let free: Vec<stress::Case> = stress::quick_cases()
        .into_iter()
        .filter(|c| c.name.starts_with("ends/free-root/"))
        .collect();
    assert!(
        free.iter().any(|c| c.name.contains("/flail/")),
        "{:?}",
        free.iter().map(|c| &c.name).collect::<Vec<_>>()
    );
    let results = run_failing_only_where_known(&stress::with_tolerance(free, 1e-3), |_| false);
    assert!(results.iter().all(|r| r.solves > 0));
}

fn full_group(group: &str) {
    let cases: Vec<stress::Case> = stress::all_cases()
        .into_iter()
        .filter(|c| c.group == group)
        .collect();
    assert!(!cases.is_empty(), "no group {group}");
    run_and_check(&cases);
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_every_preset_n_dt_and_head_motion() {
    full_group("matrix");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_long_strands() {
    full_group("long-1m");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_scaled_stiffness() {
    full_group("stiffness");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_extreme_curvature() {
    full_group("curvature");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_kinked_start() {
    full_group("kinked");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_zero_and_huge_friction() {
    full_group("friction");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_conservative_energy() {
    full_group("conservative");
}

#[test]
#[ignore = "full matrix: cargo test --release --test stability -- --ignored"]
fn full_matrix_compression_buckling() {
    full_group("buckling");
}

/// The contacts group (80 cases, about 20 s), whose figures docs/hard-cases.md cites:
/// run by default.
#[test]
fn full_matrix_contacts() {
    full_group("contacts");
}

#[test]
fn every_held_end_and_load_of_a_rod_stays_sound() {
    // the ends group is short (36 cases, seconds): the whole of it runs by default
    full_group("ends");
}

#[test]
fn the_matrix_covers_every_preset_n_dt_and_motion_and_the_extremes() {
    let cases = stress::all_cases();
    let mut names: Vec<&str> = cases.iter().map(|c| c.name.as_str()).collect();
    names.sort_unstable();
    let total = names.len();
    names.dedup();
    assert_eq!(names.len(), total, "case names are unique");
    let matrix = cases.iter().filter(|c| c.group == "matrix").count();
    assert_eq!(matrix, 4 * 5 * 3 * 5);
    for group in [
        "matrix",
        "long-1m",
        "stiffness",
        "curvature",
        "kinked",
        "friction",
        "conservative",
        "buckling",
        "contacts",
        "ends",
    ] {
        assert!(cases.iter().any(|c| c.group == group), "{group}");
    }
    for known in stress::KNOWN_FAILURES {
        assert!(names.binary_search(known).is_ok(), "unknown case {known}");
    }
    for c in &cases {
        assert_eq!(c.setup.strands.len(), 1, "{}", c.name);
    }
}

/// A case that fails: the kinked wavy strand of the conservative group at N = 20 under
/// explicit RK4 at dt = 1/30 s (beyond its stability limit by orders of magnitude).
fn failing_case() -> stress::Case {
    let mut case = named_case("conservative/wavy/N20/fps30/still/kink3/linear");
    case.name = "conservative/wavy/N20/fps30/still/kink3/rk4".to_string();
    case.setup.config.integrator = IntegratorKind::Rk4;
    case
}

#[test]
fn a_failing_case_names_its_strand_time_and_cause() {
    let case = failing_case();
    assert!(!stress::is_known_failure(&case.name));
    let result = stress::run_case(&case);
    let failure = result.failure.clone().expect("the case fails");
    assert_eq!(failure.strand, "wavy");
    // refused before its first step, for the cause: RK4's stability limit
    assert!(failure.time >= 0.0 && failure.time <= 1.0, "{failure:?}");
    assert!(failure.cause.contains("rk4 is unstable"), "{failure:?}");
    let line = stress::failure_line(&result).expect("a line");
    assert!(
        line.starts_with(&format!("FAIL {}: strand 'wavy' at t = ", case.name)),
        "{line}"
    );
    // the report lists it and counts it in the last line
    let text = stress::render(std::slice::from_ref(&result), 0.0);
    assert!(text.contains(&line), "{text}");
    assert_eq!(text.lines().last(), Some("cases=1 failed=1"), "{text}");
}

#[test]
fn the_report_flags_a_known_failure_that_passes() {
    // a passing result under the name of a known failure (if the list has one) is
    // reported, so that the list is kept exact; a passing result otherwise is not
    let case = named_case("matrix/curly/N5/fps30/still");
    let mut result = stress::run_case(&case);
    assert!(result.passed(), "{:?}", stress::failure_line(&result));
    // one strand: a solve at least per step, counted in the detail line
    assert_eq!(result.strand_steps, result.steps);
    assert!(result.solves >= result.strand_steps, "{result:?}");
    assert!(
        stress::detail_line(&result).contains(&format!(" solves={} ", result.solves)),
        "{}",
        stress::detail_line(&result)
    );
    let text = stress::render(std::slice::from_ref(&result), 0.0);
    assert!(!text.contains("PASS (known failure)"), "{text}");
    if let Some(known) = stress::KNOWN_FAILURES.first() {
        result.name = known.to_string();
        let text = stress::render(std::slice::from_ref(&result), 0.0);
        assert!(
            text.contains(&format!("PASS (known failure) {known}")),
            "{text}"
        );
    }
}

#[test]
fn the_former_known_failures_pass_with_the_energy_balance_of_implicit_steps() {
    // one of each group that failed before the integrators checked the energy balance of
    // their steps (81 of the 848 cases, `stress::KNOWN_FAILURES`): a straight strand after
    // a stop and a jolt, a 1 m strand and a frictionless one on the 5 Hz shake, a kinked
    // frictionless strand under each implicit integrator (Newton's unconverged solves
    // replaced by the linearly implicit step)
    let names = [
        "matrix/smooth/N20/fps24/stop",
        "matrix/smooth/N5/fps100/jolt",
        "long/smooth/N20/fps30/shake",
        "friction/wavy/N10/fps30/shake/gamma0",
        "conservative/wavy/N20/fps30/still/kink3/linear",
        "conservative/smooth/N5/fps30/still/kink3/newton",
    ];
    let cases: Vec<stress::Case> = stress::all_cases()
        .into_iter()
        .filter(|c| names.contains(&c.name.as_str()))
        .collect();
    assert_eq!(cases.len(), names.len());
    let results = stress::run_cases(&cases);
    for r in &results {
        println!("{}", stress::detail_line(r));
        assert!(r.passed(), "{:?}", stress::failure_line(r));
        assert_eq!(r.unbalanced, 0, "{}", r.name);
        if r.conservative {
            // no energy beyond round-off above the initial value
            let growth = r.energy_growth.expect("energy checked");
            assert!(growth <= 1e-9, "{}: {growth:e}", r.name);
        }
    }
    let newton = results
        .iter()
        .find(|r| r.name.ends_with("/newton"))
        .expect("newton case");
    assert!(
        newton.newton_fallbacks > 0,
        "{}",
        stress::detail_line(newton)
    );
}

/// The case of the full matrix with this name.
fn named_case(name: &str) -> stress::Case {
    stress::all_cases()
        .into_iter()
        .find(|c| c.name == name)
        .unwrap_or_else(|| panic!("no stress case named {name}"))
}

#[test]
fn head_frame_energy_is_simulation_energy_for_a_still_head() {
    // the energy the runner computes for a head in uniform motion (first moment by
    // quadrature) against the kernel's, on kinked and tightly curled strands
    for name in [
        "kinked/curly/N5/fps30/still/kink3",
        "curvature/fuzzy/N10/fps30/still/wl100",
        "matrix/smooth/N20/fps30/still",
    ] {
        let case = named_case(name);
        let mut sim =
            Simulation::new(case.setup.clone(), superhelix::kernel_factory()).expect("setup");
        for _ in 0..3 {
            sim.step().expect("step");
        }
        let g = Vector3::new(0.0, 0.0, -stress::GRAVITY);
        let ours = stress::head_frame_energy(&mut sim, 0, &HeadMotion::Still.state(0.0), &g);
        let kernel = sim.energy(0);
        let scale = sim.kinetic_energy(0).abs() + ours.abs() + kernel.abs();
        assert!(
            (ours - kernel).abs() <= 1e-12 * scale,
            "{name}: {ours:e} vs {kernel:e}"
        );
    }
}

#[test]
fn stress_command_prints_the_summary_line() {
    let run = |filter: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_superhelix"))
            .args(["stress", "--filter", filter])
            .output()
            .expect("superhelix runs")
    };
    let out = run("matrix/curly/N5/fps30/still");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert_eq!(stdout.lines().last(), Some("cases=1 failed=0"), "{stdout}");
    let out = run("no case has this name");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert_eq!(stdout.lines().last(), Some("cases=0 failed=0"), "{stdout}");
}

#[test]
fn stress_runs_the_cases_at_a_step_budget() {
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_superhelix"))
            .arg("stress")
            .args(args)
            .output()
            .expect("superhelix runs")
    };
    // a whipping case (the 5 Hz shake) that splits its steps by default, at one solve
    // per strand-step: renamed, and not split
    let filter = "matrix/fuzzy/N5/fps30/shake";
    let default = run(&["--filter", filter, "--verbose"]);
    let default = String::from_utf8_lossy(&default.stdout).to_string();
    assert!(!default.contains("substeps=0 "), "{default}");
    let out = run(&["--filter", filter, "--verbose", "--max-split-depth", "0"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(stdout.lines().last(), Some("cases=1 failed=0"), "{stdout}");
    let line = stdout
        .lines()
        .find(|l| l.contains(&format!("{filter}@depth0 ")))
        .unwrap_or_else(|| panic!("no budget case in {stdout}"));
    assert!(line.contains(" substeps=0 "), "{line}");
    // the default depth leaves the names alone; a depth beyond it is refused, named
    let out = run(&["--filter", filter, "--max-split-depth", "8"]);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().last(),
        Some("cases=1 failed=0")
    );
    let out = run(&["--max-split-depth", "9"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_ne!(out.status.code(), Some(0));
    assert!(
        stderr.contains("--max-split-depth") && stderr.contains("0..=8"),
        "{stderr}"
    );
}

#[test]
fn a_frictionless_curly_strand_falling_does_not_gain_energy() {
    // Regression: taking the field stiffness H whole whenever K − H is positive definite
    // (instead of only its negative semidefinite part) let these gain 8e-3 to 0.11 S of
    // energy within 0.2 s; with the projection their energy only decreases.
    for name in [
        "conservative/fuzzy/N10/fps100/still/fall/linear",
        "conservative/fuzzy/N20/fps24/still/fall/linear",
        "conservative/fuzzy/N20/fps100/still/fall/linear",
    ] {
        let mut case = named_case(name);
        let result = stress::run_case(&case);
        assert!(result.passed(), "{:?}", stress::failure_line(&result));
        let growth = result.energy_growth.expect("energy checked");
        assert!(growth < 0.0, "{name}: {growth:e}");
        // by the step itself, not by the integrator's checks: without the energy balance
        // (no step split or limited for its energy) it only decreases too (measured
        // −1.3e-3, −1.2e-2 and −1.3e-4 S)
        case.setup.config.energy_balance = false;
        let unchecked = stress::run_case(&case);
        let growth = unchecked.energy_growth.expect("energy checked");
        assert!(growth < 0.0, "{}", stress::detail_line(&unchecked));
    }
}

#[test]
fn bdf2_survives_the_same_shake_bounded() {
    // The second-order integrator on the same 10 s shake: bounded by the same limit, and
    // its mean kinetic energy over the second half below B/2, the level under which the
    // stress suite does not count growth (stress::MEAN_LEVEL). Measured: peaks 1.21 and
    // 1.13, second-half mean 0.415 (implicit Euler: 1.31, 1.59, 0.420). Its mean growth
    // is 2.7 (implicit Euler 1.06): its light damping lets the whipping response build up
    // over more than the first 5 s — implicit Euler itself, at dt = 1/240 s, grows 1.86
    // times — so the ratio is not asserted.
    let (_, peaks) = run(IntegratorKind::Bdf2, 10, 1.0 / 30.0, 10.0, 3.0, 40.0);
    println!("BDF2 kinetic energy peaks / rigid-drag scale: {peaks:?}");
    assert_peaks_bounded(&peaks);
    assert!(peaks.second_half_mean < stress::MEAN_LEVEL, "{peaks:?}");
}

#[test]
fn quick_subset_of_the_hard_cases_with_bdf2_fails_only_where_known() {
    // `superhelix stress --quick --integrator bdf2`: the same checks; the cases listed in
    // stress::KNOWN_FAILURES_BDF2 (none since the energy-balance acceptance) may fail, no
    // other may
    let cases = stress::with_integrator(stress::quick_cases(), IntegratorKind::Bdf2);
    assert!(cases.len() >= 80, "{}", cases.len());
    let results =
        run_failing_only_where_known(&cases, |name| stress::KNOWN_FAILURES_BDF2.contains(&name));
    for known in stress::KNOWN_FAILURES_BDF2 {
        assert!(
            results.iter().any(|r| r.name == *known),
            "{known} is not in the quick subset"
        );
    }
}

#[test]
fn with_the_field_stiffness_explicit_a_split_step_keeps_strands_out_of_the_bar() {
    // A step that must be split takes the projected stiffness for its pieces: with the
    // explicit stiffness in its pieces too, these strands thrown onto the bar went 1.05 to
    // 3.7 mm into it (the contact forces' curvature on the twist, stiff beyond any
    // substep); the cases allow 1 mm
    let names = [
        "contacts/smooth/N5/fps30/jolt/viscous",
        "contacts/smooth/N10/fps30/jolt/viscous",
        "contacts/smooth/N5/fps30/stop/viscous",
        "contacts/smooth/N10/fps30/nod/viscous",
        "contacts/wavy/N5/fps30/shake/coulomb",
    ];
    let cases: Vec<stress::Case> = names.iter().map(|n| named_case(n)).collect();
    let cases = stress::with_field_stiffness(cases, FieldStiffness::Explicit);
    for result in stress::run_cases(&cases) {
        assert!(result.name.ends_with("@explicit"), "{}", result.name);
        assert!(result.passed(), "{:?}", stress::failure_line(&result));
        assert!(
            result.penetration <= 1e-3,
            "{}",
            stress::detail_line(&result)
        );
    }
}

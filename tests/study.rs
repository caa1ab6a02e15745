//! `superhelix study --quick` end to end (the CI run of the study): the report, the
//! plots, the JSON, and the physics the figures must show.

use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

fn scratch() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-study-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn problem<'a>(study: &'a Value, key: &str) -> &'a Value {
    study["problems"]
        .as_array()
        .and_then(|ps| ps.iter().find(|p| p["key"] == key))
        .unwrap_or_else(|| panic!("problem {key} missing from study.json"))
}

fn point<'a>(problem: &'a Value, label: &str) -> &'a Value {
    problem["points"]
        .as_array()
        .and_then(|ps| ps.iter().find(|p| p["label"] == label))
        .unwrap_or_else(|| panic!("point {label} missing"))
}

fn num(v: &Value, field: &str) -> f64 {
    v[field]
        .as_f64()
        .unwrap_or_else(|| panic!("{field} of {v} is not a number"))
}

/// `superhelix study ARGS --out DIR`'s output.
fn study_into(args: &[&str], dir: &std::path::Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .arg("study")
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"))
}

#[test]
fn quick_study_writes_report_plots_and_sound_figures() {
    let dir = scratch();
    let start = std::time::Instant::now();
    let out = study_into(&["--quick"], &dir);
    let seconds = start.elapsed().as_secs_f64();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    println!("{stdout}quick study: {seconds:.1} s");

    // report.md: every problem, the budget tables of the four error-against-cost
    // problems, the plots embedded, and the command
    let report = std::fs::read_to_string(dir.join("report.md")).expect("report.md");
    for key in superhelix::study::PROBLEMS {
        assert!(report.contains(&format!("(`{key}`)")), "report lacks {key}");
    }
    assert_eq!(
        report.matches("Pareto-best setting for a budget").count(),
        4
    );
    assert!(report.contains("superhelix study --quick --out"));
    assert!(report.contains("F L³/(3EI)") && report.contains("Euler–Bernoulli"));
    assert!(report.contains("Measured orders"), "floppy orders");

    // the SVG plots: size, title, axis titles, legend entries; each integrator in its
    // fixed colour (LIE blue, NIE orange, BDF2 green) in every cost plot
    for key in ["swing", "curly", "frequency", "cantilever", "floppy"] {
        assert!(
            report.contains(&format!("]({key}.svg)")),
            "{key}.svg not embedded"
        );
        let svg = std::fs::read_to_string(dir.join(format!("{key}.svg"))).expect("svg");
        let (w, h) = superhelix::study_plot::SIZE;
        assert!(
            svg.starts_with(&format!("<svg width=\"{w}\" height=\"{h}\"")),
            "{key}.svg size"
        );
        let texts = svg.matches("<text").count();
        assert!(texts >= 10, "{key}.svg has {texts} texts");
        let title = problem_title(&report, key);
        assert!(svg.contains(&title), "{key}.svg lacks its title {title}");
        assert!(svg.contains("error: "), "{key}.svg lacks the y title");
        if key == "floppy" {
            assert!(svg.contains("time step dt (s)"), "{key}.svg x title");
            assert!(
                svg.contains("BDF2, frictionless (order"),
                "{key}.svg legend"
            );
        } else {
            assert!(svg.contains("cost: CPU time per"), "{key}.svg x title");
            assert!(svg.contains("Pareto front"), "{key}.svg legend");
        }
        if !["cantilever", "floppy"].contains(&key) {
            assert!(svg.contains("LIE generated") && svg.contains("BDF2 generated"));
            for colour in ["#1F77B4", "#FF7F0E", "#2CA02C"] {
                assert!(svg.contains(colour), "{key}.svg lacks {colour}");
            }
        }
    }
    assert!(!dir.join("rotary.svg").exists(), "rotary is a table");

    let text = std::fs::read_to_string(dir.join("study.json")).expect("study.json");
    let study: Value = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(study["quick"], true);

    // every run of the grid succeeded, and each problem has a Pareto front
    for key in ["swing", "curly", "frequency", "cantilever"] {
        let p = problem(&study, key);
        let points = p["points"].as_array().expect("points");
        assert!(points.len() >= 9, "{key}: {} points", points.len());
        for pt in points {
            assert!(pt.get("failed").is_none(), "{key}: {pt}");
            assert!(num(pt, "cost_seconds") > 0.0, "{key}: {pt}");
        }
        assert!(points.iter().any(|pt| pt["pareto"] == true), "{key}");
    }

    // cantilever: δ_N = δ (1 − 1/(4N²)) exactly, for every kernel; error falls with N
    let cantilever = problem(&study, "cantilever");
    let mut previous = f64::INFINITY;
    for n in [2usize, 5, 10, 20] {
        let expected = -1.0 / (4.0 * (n * n) as f64);
        for kernels in ["generated", "generic-2", "generic-adaptive"] {
            let pt = point(cantilever, &format!("N={n} {kernels}"));
            let signed = num(pt, "signed_error");
            assert!(
                (signed - expected).abs() < 1e-6,
                "N={n} {kernels}: {signed} vs {expected}"
            );
        }
        let e = num(point(cantilever, &format!("N={n} generated")), "error");
        assert!(e < previous, "cantilever error does not fall with N");
        previous = e;
    }

    // frequency: the discrete model at N = 20 is within 0.1 % of Euler–Bernoulli, and
    // stiffer; its error falls as 1/N²
    let frequency = problem(&study, "frequency");
    let spatial = frequency["spatial"].as_array().expect("spatial");
    let at = |n: u64| {
        spatial
            .iter()
            .find(|s| s["elements"] == n)
            .map(|s| num(s, "signed_error"))
            .unwrap_or_else(|| panic!("no spatial entry for N = {n}"))
    };
    assert!(at(20) > 0.0 && at(20) < 1e-3, "N = 20: {}", at(20));
    let ratio = at(10) / at(20);
    assert!(
        (3.5..4.5).contains(&ratio),
        "1/N² convergence: ratio {ratio}"
    );
    // simulated: at dt = 1/240 the measured frequency is the eigenvalue's less the
    // period error ≈ (ω dt)²/3 of implicit Euler, which BDF2 shares
    let omega_dt = 30.84_f64 / 240.0;
    for n in [5u64, 10, 20] {
        for integrator in ["LIE", "BDF2"] {
            let measured = num(
                point(frequency, &format!("N={n} dt=1/240 {integrator} generated")),
                "signed_error",
            );
            let predicted = at(n) - omega_dt * omega_dt / 3.0;
            assert!(
                (measured - predicted).abs() < 1e-3,
                "N={n} {integrator}: simulated {measured} vs predicted {predicted}"
            );
        }
    }

    // trajectories: a smaller step does not make the swing worse at N = 20, and the
    // generic kernels agree with the generated one where both run
    let swing = problem(&study, "swing");
    let coarse = num(point(swing, "N=20 dt=1/30 LIE generated"), "error");
    let fine = num(point(swing, "N=20 dt=1/240 LIE generated"), "error");
    assert!(fine < coarse, "swing: dt 1/240 {fine} vs 1/30 {coarse}");
    // the second-order integrator: where the step limits the error (N = 20, the finest
    // dt), BDF2 is far closer than implicit Euler at the same cost per step (measured 20x
    // on swing, 16x on curly; the reference's own floor, its distance from BDF2 at the
    // reference step, is 1.1e-3 L on swing and 8e-5 L on curly)
    for key in ["swing", "curly"] {
        let p = problem(&study, key);
        let lie = num(point(p, "N=20 dt=1/240 LIE generated"), "error");
        let bdf2 = num(point(p, "N=20 dt=1/240 BDF2 generated"), "error");
        assert!(bdf2 < lie / 5.0, "{key}: BDF2 {bdf2} vs LIE {lie}");
    }
    for key in ["swing", "curly"] {
        let p = problem(&study, key);
        let generated = num(point(p, "N=5 dt=1/120 LIE generated"), "error");
        let generic = num(point(p, "N=5 dt=1/120 LIE generic-adaptive"), "error");
        assert!(
            (generated - generic).abs() < 0.05 * generated,
            "{key}: generated {generated} vs generic-adaptive {generic}"
        );
    }

    // floppy: BDF2 converges at second order with and without friction; frictionless,
    // linearly implicit Euler barely converges (its error at 1/1000 s is still 0.35 of
    // that at 1/30 s; first order would give 0.03) and BDF2 is far closer there
    let floppy = problem(&study, "floppy");
    let series = |integrator: &str, friction: bool| {
        floppy["convergence"]
            .as_array()
            .and_then(|c| {
                c.iter()
                    .find(|s| s["integrator"] == integrator && s["friction"] == friction)
            })
            .unwrap_or_else(|| panic!("floppy: no series {integrator} {friction}"))
    };
    let errors = |s: &Value| -> Vec<f64> {
        s["dt_error"]
            .as_array()
            .map(|ps| {
                ps.iter()
                    .map(|p| p[1].as_f64().unwrap_or(f64::NAN))
                    .collect()
            })
            .unwrap_or_default()
    };
    for friction in [false, true] {
        let order = num(series("bdf2", friction), "order");
        assert!(
            (1.6..=2.4).contains(&order),
            "floppy BDF2 (friction {friction}): order {order}"
        );
    }
    let lie = errors(series("linearly-implicit-euler", false));
    let bdf2 = errors(series("bdf2", false));
    let (first, last) = (lie[0], lie[lie.len() - 1]);
    assert!(
        last > 0.2 * first,
        "floppy LIE: {last} at the smallest dt vs {first}"
    );
    assert!(
        bdf2[bdf2.len() - 1] < 0.1 * last,
        "floppy: BDF2 {bdf2:?} vs LIE {lie:?}"
    );
    let lie_friction = errors(series("linearly-implicit-euler", true));
    for w in lie_friction.windows(2) {
        assert!(w[1] < w[0], "floppy LIE with friction: {lie_friction:?}");
    }

    // rotary: percents on the twist of the twisted strand; nothing visible (< 1e-4) on
    // the bending and centreline of the planar one, whose twist stays zero
    let rotary = problem(&study, "rotary")["rotary"]
        .as_array()
        .expect("rotary")
        .clone();
    assert_eq!(rotary.len(), 2);
    let twisted = &rotary[0];
    let planar = &rotary[1];
    assert!(num(twisted, "twist") > 1e-2, "rotary: {twisted}");
    assert!(planar["twist"].is_null(), "rotary: {planar}");
    assert!(num(planar, "bending") < 1e-4, "rotary: {planar}");
    assert!(num(planar, "centreline") < 1e-4, "rotary: {planar}");

    // tolerance: every case within issue #51's band [0.2, 3] τ of a reference good to
    // far below the tightest tolerance, tighter tolerances costing more, and the cost
    // comparison with fixed steps (the full range, to 1e-6, is the ignored test below)
    let cases = problem(&study, "tolerance")["tolerance"]
        .as_array()
        .expect("tolerance cases")
        .clone();
    check_tolerance_cases(&cases, 4);
    let svg = std::fs::read_to_string(dir.join("tolerance_cost.svg")).expect("tolerance_cost.svg");
    assert!(svg.contains("best fixed step") && svg.contains("implicit solves"));
    assert!(report.contains("Cost at equal error") && report.contains("tolerance_cost.svg"));
    let svg = std::fs::read_to_string(dir.join("tolerance.svg")).expect("tolerance.svg");
    assert!(svg.contains("tolerance asked for") && svg.contains("error = tolerance"));

    let _ = std::fs::remove_dir_all(&dir);
}

/// The tolerance problem's cases (`study.json`) against issue #51's demands: five cases
/// at `tolerances` tolerances each, every reference's estimated error below 5 % of the
/// tightest tolerance, every error within [0.2, 3] τ, solves growing as τ shrinks, and
/// a fixed-step run as accurate as each tolerance down to 1e-3 for the cost comparison.
fn check_tolerance_cases(cases: &[Value], tolerances: usize) {
    assert_eq!(cases.len(), 5);
    for case in cases {
        let name = format!("{} (friction {})", case["problem"], case["friction"]);
        let points = case["points"].as_array().expect("points");
        assert_eq!(points.len(), tolerances, "{name}");
        let tightest = points
            .iter()
            .map(|p| num(p, "tolerance"))
            .fold(1.0, f64::min);
        let own = num(case, "reference_error");
        assert!(own < 0.05 * tightest, "{name}: reference good to {own:e}");
        for p in points {
            let (t, e) = (num(p, "tolerance"), num(p, "error"));
            assert!(
                (0.2 * t..=3.0 * t).contains(&e),
                "tolerance, {name}: error {e:e} at {t:e}"
            );
        }
        let solves: Vec<f64> = points.iter().map(|p| num(p, "solves")).collect();
        assert!(solves.windows(2).all(|w| w[1] > w[0]), "{name}: {solves:?}");
        // the fixed ladder is as accurate as the tolerances down to 1e-3, so that the
        // cost comparison has a fixed step at their errors
        for p in points.iter().filter(|p| num(p, "tolerance") >= 1e-3) {
            let fixed = num(p, "fixed_solves_at_error");
            assert!(fixed >= 1.0, "{name}: {p}");
        }
    }
}

/// `superhelix study --only tolerance`: the full range τ = 1e-1 … 1e-6 of issue #51
/// (about 2 minutes on two cores).
#[test]
#[ignore = "the full tolerance study, about 2 minutes; run with --ignored"]
fn the_tolerance_holds_from_1e_1_to_1e_6_on_the_study_strands() {
    let dir = scratch().with_extension("tolerance");
    let out = study_into(&["--only", "tolerance"], &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.join("study.json")).expect("study.json");
    let study: Value = serde_json::from_str(&text).expect("study.json parses");
    let problems = study["problems"].as_array().expect("problems");
    assert_eq!(problems.len(), 1, "--only runs one problem");
    assert!(study["cost_by_elements"]
        .as_array()
        .is_some_and(|c| c.is_empty()));
    let cases = problem(&study, "tolerance")["tolerance"]
        .as_array()
        .expect("tolerance cases")
        .clone();
    let _ = std::fs::remove_dir_all(&dir);
    check_tolerance_cases(&cases, 6);
}

#[test]
fn only_names_a_problem() {
    let out = study_into(&["--only", "sing"], &scratch().with_extension("only"));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("--only") && stderr.contains("swing, curly"),
        "{stderr}"
    );
}

/// The title of problem `key` in the report's heading `## <title> (`key`)`.
fn problem_title(report: &str, key: &str) -> String {
    report
        .lines()
        .find_map(|l| {
            l.strip_prefix("## ")
                .and_then(|l| l.strip_suffix(&format!(" (`{key}`)")))
        })
        .unwrap_or_else(|| panic!("no heading for {key}"))
        .to_string()
}

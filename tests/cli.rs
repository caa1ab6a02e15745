//! The `superhelix` binary, end to end.

mod support;

use support::{scratch, superhelix, text, write};

fn repo(path: &str) -> String {
    format!("{}/{path}", env!("CARGO_MANIFEST_DIR"))
}

const STRAND: &str = "[[strands]]\nlength = 0.3\n";

/// An N this build has no generated kernels for.
fn no_generated_kernel() -> usize {
    let available = superhelix::kernel_factory()
        .map(|f| f.available())
        .unwrap_or_default();
    (1..=200).find(|n| !available.contains(n)).unwrap_or(200)
}

/// Broken scenes and a field path each must report.
fn broken() -> Vec<(String, &'static str)> {
    vec![
        (format!("[simulation]\ndt = 0.0\n{STRAND}"), "simulation.dt"),
        (format!("[simulation]\nduration = -1.0\n{STRAND}"), "simulation.duration"),
        (format!("[simulation]\noutput_fps = 0\n{STRAND}"), "simulation.output_fps"),
        (format!("[simulation]\nintegrator = \"leapfrog\"\n{STRAND}"), "simulation.integrator"),
        (format!("[simulation]\nkernels = \"gpu\"\n{STRAND}"), "simulation.kernels"),
        (format!("[simulation]\nmode = \"fast\"\n{STRAND}"), "simulation.mode"),
        (
            format!("[simulation]\nmode = \"static\"\ntolerance = 1e-4\n{STRAND}"),
            "simulation.tolerance",
        ),
        (
            format!("[simulation]\nmode = \"static\"\n[output]\ncheckpoint_every = 5\n{STRAND}"),
            "output.checkpoint_every",
        ),
        (format!("[head]\nmotion = {{ kind = \"wobble\" }}\n{STRAND}"), "head.motion.kind"),
        (format!("[[bodies]]\nshape = \"sphere\"\nradius = 0.02\n[bodies.motion]\nkind = \"keyframes\"\nkeys = [{{ t = 1.0 }}, {{ t = 0.5 }}]\n{STRAND}"), "bodies[0].motion.keys[1].t"),
        (format!("[[bodies]]\nshape = \"sphere\"\nradius = 0.02\nattached = \"world\"\nmotion = {{ kind = \"still\" }}\n{STRAND}"), "bodies[0].motion"),
        ("[[strands]]\nlength = -0.3\n".to_string(), "strands[0].length"),
        ("[[strands]]\nlength = 0.3\nelements = 0\n".to_string(), "strands[0].elements"),
        ("[[strands]]\nlength = 0.3\npreset = \"frizzy\"\n".to_string(), "strands[0].preset"),
        ("[[strands]]\nlength = 0.3\npoisson = 0.7\n".to_string(), "strands[0].poisson"),
        ("[[strands]]\nlength = 0.3\nradius = 0.0\n".to_string(), "strands[0].radius"),
        ("[[strands]]\nlength = 0.3\ncolour = \"red\"\n".to_string(), "strands[0].colour"),
        ("[[strands]]\nlength = 0.3\nelements = 2\nq0 = [0.0]\n".to_string(), "strands[0].q0"),
        ("[[strands]]\nlength = 0.3\ndirection = [0.0, 0.0, 1.0]\nnormal = [0.0, 0.0, 3.0]\n".to_string(), "strands[0].normal"),
        ("[[strands]]\nlength = 0.3\nelement_lengths = [0.1, 0.1]\n".to_string(), "strands[0].element_lengths"),
        ("[[strands]]\nlength = 0.3\n[[strands.point_loads]]\ns = 0.4\nforce = [0.0, 0.0, 1.0]\n".to_string(), "strands[0].point_loads[0].s"),
        (format!("{STRAND}[[strands]]\nlength = 0.2\nhelix_radius = -1.0\n"), "strands[1].helix_radius"),
        ("[simulation]\ndt = 0.01\n".to_string(), "strands"),
        // what `run` refuses before its first step
        ("[[strands]]\nlength = 1e300\n".to_string(), "strands[0].length"),
        ("[[strands]]\nlength = 0.3\nelements = 1\nq0 = [1e300, 0.0, 0.0]\n".to_string(), "strands[0].q0[0]"),
        ("[[strands]]\nlength = 0.3\nradius = 1e200\n".to_string(), "strands[0].radius"),
        ("[[strands]]\nlength = 0.3\nnatural = [0.0, 1e7, 0.0]\n".to_string(), "strands[0].natural"),
        ("[[strands]]\nlength = 0.3\n[[strands.point_loads]]\ns = 0.3\nforce = [0.0, 0.0, 1e300]\n".to_string(), "strands[0].point_loads[0].force[2]"),
        (format!("[simulation]\nkernels = \"generated\"\n[[strands]]\nlength = 0.3\nelements = {}\n", no_generated_kernel()), "simulation.kernels"),
        (format!("[simulation]\nintegrator = \"rk4\"\ndt = 0.0333333\n{STRAND}"), "simulation.dt"),
        // physical ranges: what would overflow the float32 outputs is refused up front
        (format!("[head]\nmotion = {{ kind = \"jolt\", direction = [1.0, 0.0, 0.0], acceleration = 1e300, start = 0.0, duration = 0.1 }}\n{STRAND}"), "head.motion.acceleration"),
        (format!("[head]\nmotion = {{ kind = \"translate-oscillate\", direction = [1.0, 0.0, 0.0], amplitude = 1e39, frequency_hz = 1.0 }}\n{STRAND}"), "head.motion.amplitude"),
        (format!("[head]\nmotion = {{ kind = \"keyframes\", keys = [{{ t = 0.0 }}, {{ t = 1.0, position = [1e300, 0.0, 0.0] }}] }}\n{STRAND}"), "head.motion.keys[1].position"),
        (format!("[head]\nmotion = {{ kind = \"sudden-stop\", axis = [0.0, 0.0, 1.0], angular_speed_deg = 1e300, stop_time = 0.1, stop_duration = 0.1 }}\n{STRAND}"), "head.motion.angular_speed_deg"),
        (format!("[environment]\ngravity = [0.0, 0.0, -1e300]\n{STRAND}"), "environment.gravity"),
        (format!("[environment]\nair_drag = 1e300\n{STRAND}"), "environment.air_drag"),
        ("[[strands]]\nlength = 0.3\ndensity = 1e300\n".to_string(), "strands[0].density"),
        ("[[strands]]\nlength = 0.3\nyoungs_modulus = 1e300\n".to_string(), "strands[0].youngs_modulus"),
        ("[[strands]]\nlength = 0.3\nair_drag = 1e300\n".to_string(), "strands[0].air_drag"),
        ("[[strands]]\nlength = 0.3\ninternal_friction = 1e300\n".to_string(), "strands[0].internal_friction"),
        ("[[strands]]\nlength = 0.3\nroot = [1e300, 0.0, 0.0]\n".to_string(), "strands[0].root"),
        (format!("[[bodies]]\nshape = \"sphere\"\nradius = 0.02\ncenter = [0.0, 1e300, 0.0]\n{STRAND}"), "bodies[0].center"),
    ]
}

#[test]
fn validate_reports_each_broken_field_with_exit_code_1() {
    let dir = scratch("broken");
    for (i, (scene, field)) in broken().into_iter().enumerate() {
        let path = write(&dir, &format!("broken{i}.toml"), &scene);
        let out = superhelix(&["validate", &path.to_string_lossy()]);
        let all = text(&out);
        assert_eq!(out.status.code(), Some(1), "{field}:\n{all}");
        // the field, or one entry of it (`force[2]`)
        assert!(
            all.contains(&format!("{field}: ")) || all.contains(&format!("{field}[")),
            "{field} not in:\n{all}"
        );
    }
}

#[test]
fn validate_reports_syntax_errors_with_their_line() {
    let dir = scratch("syntax");
    let path = write(
        &dir,
        "syntax.toml",
        "[simulation]\ndt = 0.1\nduration = = 2\n",
    );
    let out = superhelix(&["validate", &path.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(text(&out).contains("line 3, column"), "{}", text(&out));
}

#[test]
fn validate_accepts_the_example_scenes_and_the_default_scene() {
    let mut scenes: Vec<String> = std::fs::read_dir(repo("scenes"))
        .unwrap_or_else(|e| panic!("scenes/: {e}"))
        .filter_map(|entry| entry.ok().map(|e| e.path().to_string_lossy().into_owned()))
        .filter(|p| p.ends_with(".toml"))
        .collect();
    assert!(scenes.len() >= 3, "{scenes:?}");
    scenes.push(repo("src/default_scene.toml"));
    // two validations at a time (each is a process of its own)
    let next = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|scope| {
        for _ in 0..2 {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(scene) = scenes.get(k) else { break };
                let out = superhelix(&["validate", scene]);
                assert_eq!(out.status.code(), Some(0), "{scene}:\n{}", text(&out));
                assert!(
                    String::from_utf8_lossy(&out.stdout).starts_with("ok: "),
                    "{scene}"
                );
            });
        }
    });
    let out = superhelix(&["validate", &repo("src/default_scene.toml")]);
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).lines().next(),
        Some("ok: 100 strands, 90 steps")
    );
}

#[test]
fn missing_files_and_bad_usage_fail_cleanly() {
    let out = superhelix(&["validate", "/nonexistent/scene.toml"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/scene.toml"));
    assert_eq!(superhelix(&[]).status.code(), Some(2));
    assert_eq!(superhelix(&["run", "--frobnicate"]).status.code(), Some(2));
    assert_eq!(superhelix(&["validate"]).status.code(), Some(2));
    let out = superhelix(&["run", "/nonexistent/scene.toml"]);
    assert_eq!(out.status.code(), Some(1));
}

/// `validate` takes `run`'s options and refuses what `run` would refuse with them, each
/// named; `run` refuses a bad option before it makes its output folder.
#[test]
fn validate_takes_runs_options_and_refuses_what_run_refuses() {
    let dir = scratch("validate-options");
    let scene = write(
        &dir,
        "s.toml",
        &format!("[simulation]\nduration = 0.1\n{STRAND}"),
    );
    let scene = scene.to_string_lossy().into_owned();
    let fixed = write(
        &dir,
        "static.toml",
        &format!("[simulation]\nmode = \"static\"\n{STRAND}"),
    );
    let fixed = fixed.to_string_lossy().into_owned();
    let out = dir.join("out");
    let outs = out.to_string_lossy().into_owned();
    let refused = |args: &[&str], expect: &[&str]| {
        let o = superhelix(args);
        let said = text(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}:\n{said}");
        for e in expect {
            assert!(said.contains(e), "{args:?}: {e:?} not in:\n{said}");
        }
        assert!(!said.contains("invalid scene"), "{said}");
    };
    for command in ["validate", "run"] {
        let with_out = |extra: &[&'static str]| {
            let mut a = vec![command, scene.as_str()];
            a.extend_from_slice(extra);
            if command == "run" {
                a.extend(["--out", outs.as_str()]);
            }
            a
        };
        refused(
            &with_out(&["--tolerance", "0.6"]),
            &["--tolerance", "0.6", "must be in"],
        );
        refused(
            &with_out(&["--tolerance", "0"]),
            &["--tolerance", "must be in"],
        );
        refused(
            &with_out(&["--part", "1/1000000000"]),
            &["--part", "at most the scene's number of strands (1)"],
        );
        refused(&with_out(&["--format", "mp4"]), &["mp4"]);
        assert!(!out.exists(), "{command} made {outs} before refusing");
        let mut a = vec![command, fixed.as_str(), "--tolerance", "1e-4"];
        if command == "run" {
            a.extend(["--out", outs.as_str()]);
        }
        refused(&a, &["--tolerance", "static"]);
        assert!(!out.exists(), "{command} made {outs} before refusing");
    }
    // what validate accepts with the options, run runs
    let o = superhelix(&[
        "validate",
        &scene,
        "--tolerance",
        "1e-4",
        "--part",
        "1/1",
        "--format",
        "npy",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(
        text(&o).contains("part 1/1: 1 of 1 strands"),
        "{}",
        text(&o)
    );
    // the output limit: refused as run refuses it, lifted as run lifts it
    let small = write(
        &dir,
        "small-limit.toml",
        &format!("[simulation]\nduration = 0.1\n[output]\nmax_bytes = 100\n{STRAND}"),
    );
    let small = small.to_string_lossy().into_owned();
    refused(&["validate", &small], &["output"]);
    let o = superhelix(&["validate", &small, "--allow-large-output"]);
    assert!(o.status.success(), "{}", text(&o));
}

/// Progress (frames, time per frame, time left; spinners for reading and writing) is
/// drawn only on a terminal: piped, `run` and `validate` print their report lines alone,
/// with no carriage return or escape sequence.
#[test]
fn progress_stays_off_a_pipe() {
    let dir = scratch("progress-pipe");
    let scene = write(
        &dir,
        "s.toml",
        &format!("[simulation]\nduration = 0.2\n{STRAND}"),
    );
    let scene = scene.to_string_lossy().into_owned();
    let out = dir.join("out").to_string_lossy().into_owned();
    for args in [
        vec![
            "run",
            scene.as_str(),
            "--out",
            out.as_str(),
            "--format",
            "npy",
        ],
        vec!["validate", scene.as_str()],
    ] {
        let o = superhelix(&args);
        assert!(o.status.success(), "{}", text(&o));
        let said = text(&o);
        for mark in [
            "per frame",
            "reading the scene",
            "building the simulation",
            "\r",
            "\u{1b}[",
        ] {
            assert!(!said.contains(mark), "{args:?} printed {mark:?}:\n{said}");
        }
    }
}

/// A clamped tip held in a frame its strand does not start in (and 1 cm short, so that
/// the straight strand cannot reach it): validate names the frame (its angle, the fields
/// that set it) beside the distance.
#[test]
fn a_tip_held_in_another_frame_than_its_start_names_the_frame() {
    let dir = scratch("held-frame");
    let scene = write(
        &dir,
        "s.toml",
        "[simulation]\nduration = 0.1\n[[strands]]\nlength = 0.2\n[strands.ends.tip]\nkind = \"clamped\"\nposition = [0.0, 0.0, -0.19]\ndirection = [1.0, 0.0, 0.0]\n",
    );
    let o = superhelix(&["validate", &scene.to_string_lossy()]);
    let said = text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    for e in [
        "strands[0].ends.tip",
        "its frame is turned 120.0° from the held frame (ends.tip.direction, ends.tip.normal)",
        "leave out direction and normal",
    ] {
        assert!(said.contains(e), "{e:?} not in:\n{said}");
    }
}

#[test]
fn run_rejects_an_invalid_scene_before_simulating() {
    let dir = scratch("run-invalid");
    let path = write(&dir, "bad.toml", "[[strands]]\nlength = -1.0\n");
    let out = superhelix(&[
        "run",
        &path.to_string_lossy(),
        "--out",
        &dir.join("out").to_string_lossy(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("strands[0].length"));
    assert!(!dir.join("out").join("frames.json").exists());
}

fn as_f64(v: &serde_json::Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

#[test]
fn run_writes_frames_of_the_default_scene() {
    let dir = scratch("run-default");
    let out_dir = dir.join("out");
    let out = superhelix(&["run", "--out", &out_dir.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    // the plan, every file written, the summary
    let stdout = String::from_utf8_lossy(&out.stdout);
    let lines: Vec<&str> = stdout.lines().collect();
    // the grooms' reports, then the plan
    let plan = lines
        .iter()
        .position(|l| l.starts_with("output: "))
        .unwrap_or_else(|| panic!("no plan: {stdout}"));
    assert!(
        lines[..plan].iter().all(|l| l.starts_with("groom ")),
        "{stdout}"
    );
    let frames_path = out_dir.join("frames.json");
    assert!(
        lines.contains(&format!("wrote {}", frames_path.display()).as_str()),
        "{stdout}"
    );
    let summary = lines.last().copied().unwrap_or_default();
    assert!(
        summary.contains("strand-steps/s") && summary.contains("max |q̇|"),
        "{stdout}"
    );

    let json = std::fs::read_to_string(&frames_path).unwrap_or_else(|e| panic!("frames.json: {e}"));
    let frames: serde_json::Value =
        serde_json::from_str(&json).unwrap_or_else(|e| panic!("frames.json: {e}"));
    assert_eq!(frames["format"], "superhelix-frames");
    assert_eq!(frames["version"], 2);
    let setup =
        superhelix::parse_scene(superhelix::DEFAULT_SCENE).unwrap_or_else(|e| panic!("{e}"));
    let expected_frames = (setup.config.duration * setup.config.output_fps).floor() as usize + 1;
    let layout = &frames["layout"];
    assert_eq!(
        layout["planned_frames"].as_u64(),
        Some(expected_frames as u64)
    );
    let strands = layout["strands"]
        .as_array()
        .unwrap_or_else(|| panic!("strands"));
    assert_eq!(strands.len(), setup.strands.len());
    let mut offsets = vec![0];
    for (json, s) in strands.iter().zip(&setup.strands) {
        assert_eq!(json["name"], s.strand.name.as_str());
        // the groom's name is the group of its strands
        assert!(s
            .strand
            .name
            .starts_with(json["group"].as_str().unwrap_or("?")));
        let n = s.strand.geometry.elements();
        let points = 1 + n * setup.samples_per_element;
        assert_eq!(json["points"].as_u64(), Some(points as u64));
        assert_eq!(json["coordinates"].as_u64(), Some(3 * n as u64));
        offsets.push(offsets.last().copied().unwrap_or(0) + points);
    }
    let total_q: usize = setup.strands.iter().map(|s| s.q0.len()).sum();
    let list = frames["frames"]
        .as_array()
        .unwrap_or_else(|| panic!("frames"));
    assert_eq!(list.len(), expected_frames);
    for (k, frame) in list.iter().enumerate() {
        assert_eq!(frame["index"].as_u64(), Some(k as u64));
        assert!((as_f64(&frame["time"]) - k as f64 / setup.config.output_fps).abs() < 1e-9);
        let points = frame["points"]
            .as_array()
            .unwrap_or_else(|| panic!("points"));
        assert_eq!(points.len(), offsets.last().copied().unwrap_or(0));
        assert_eq!(frame["q"].as_array().map(Vec::len), Some(total_q));
        for p in points {
            assert!(p
                .as_array()
                .is_some_and(|p| p.len() == 3 && p.iter().all(|x| as_f64(x).is_finite())));
        }
    }
    // The head is at rest at t = 0 (X = 0, R = I): each strand's first point is its root.
    let first = list[0]["points"]
        .as_array()
        .unwrap_or_else(|| panic!("points"));
    for (s, &offset) in setup.strands.iter().zip(&offsets) {
        let root = &first[offset];
        for i in 0..3 {
            assert!((as_f64(&root[i]) - s.strand.geometry.root_position[i]).abs() < 1e-12);
        }
    }
    // the plan's estimate of frames.json is within 10% of the file
    let planned = lines[plan]
        .split("frames.json ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|mb| mb.parse::<f64>().ok())
        .unwrap_or_else(|| panic!("{}", lines[plan]));
    assert!(
        lines[plan].contains(&format!("frames.json {planned} MB")),
        "{}",
        lines[plan]
    );
    let size = json.len() as f64 / 1e6;
    assert!(
        (planned / size - 1.0).abs() < 0.1,
        "planned {planned} MB, file {size} MB"
    );
}

/// The integrator a scene file selects (its `integrator` key, or the default).
fn superhelix_runtime_integrator_of(path: &str) -> &'static str {
    let text = std::fs::read_to_string(path).expect("scene readable");
    superhelix::parse_scene(&text)
        .expect("scene parses")
        .config
        .integrator
        .name()
}

/// The bench's last lines: `strand_steps_per_second=`, then `solves_per_strand_step=`,
/// the solves it counted over the strand-steps it ran (`strands=S steps=K`).
fn check_bench_figures(stdout: &str) {
    let lines: Vec<&str> = stdout.lines().collect();
    let n = lines.len();
    assert!(n >= 2, "{stdout}");
    assert!(
        lines[n - 2].starts_with("strand_steps_per_second="),
        "{stdout}"
    );
    let per_step: f64 = lines[n - 1]
        .strip_prefix("solves_per_strand_step=")
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{stdout}"));
    let field = |key: &str| -> f64 {
        stdout
            .split_whitespace()
            .find_map(|w| w.strip_prefix(key))
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {key} in {stdout}"))
    };
    let solves: f64 = stdout
        .split(" solves)")
        .next()
        .and_then(|head| head.rsplit('(').next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no solve count in {stdout}"));
    let strand_steps = field("strands=") * field("steps=");
    assert!(
        (per_step - solves / strand_steps).abs() <= 5e-4 && per_step >= 1.0,
        "{per_step} vs {solves} / {strand_steps}: {stdout}"
    );
}

#[test]
fn bench_runs_a_scene_with_its_effects_or_a_subset() {
    let scene = repo("scenes/curly-nod.toml");
    let out = superhelix(&["bench", "--scene", &scene, "--steps", "3"]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success(), "{}", text(&out));
    assert!(
        stdout.contains("effects=gravity,drag,friction,head"),
        "{stdout}"
    );
    check_bench_figures(&stdout);
    let out = superhelix(&[
        "bench",
        "--scene",
        &scene,
        "--steps",
        "3",
        "--effects",
        "gravity",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success(), "{}", text(&out));
    assert!(stdout.contains("effects=gravity integrator="), "{stdout}");
    // the scene's integrator unless --integrator names another; a wrong name is refused
    let own = superhelix_runtime_integrator_of(&scene);
    assert!(
        stdout.contains(&format!("integrator={own}\n")),
        "{own}: {stdout}"
    );
    let out = superhelix(&[
        "bench",
        "--scene",
        &scene,
        "--steps",
        "2",
        "--integrator",
        "bdf2",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success(), "{}", text(&out));
    assert!(stdout.contains("integrator=bdf2\n"), "{stdout}");
    let out = superhelix(&[
        "bench",
        "--scene",
        &scene,
        "--steps",
        "1",
        "--integrator",
        "euler",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--integrator"),
        "{}",
        text(&out)
    );
    // an effect the scene does not have is refused, naming it and what the scene has
    let cantilever = repo("scenes/cantilever.toml");
    let out = superhelix(&[
        "bench",
        "--scene",
        &cantilever,
        "--steps",
        "1",
        "--effects",
        "head",
    ]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--effects") && err.contains("no head"),
        "{err}"
    );
}

#[test]
fn bench_runs_on_the_threads_it_is_given_and_refuses_zero() {
    for threads in ["1", "2"] {
        let out = superhelix(&[
            "bench",
            "--elements",
            "2",
            "--strands",
            "3",
            "--steps",
            "2",
            "--threads",
            threads,
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout).to_string();
        assert!(out.status.success(), "{}", text(&out));
        assert!(
            stdout.contains(&format!(" {threads} threads\n")),
            "{threads}: {stdout}"
        );
        check_bench_figures(&stdout);
    }
    let out = superhelix(&["bench", "--steps", "1", "--threads", "0"]);
    assert_eq!(out.status.code(), Some(1), "{}", text(&out));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--threads"),
        "{}",
        text(&out)
    );
}

#[test]
fn validate_and_run_refuse_rk4_beyond_its_stability_limit_with_the_cause() {
    let dir = scratch("rk4");
    // wavy, N = 5: the stiffest mode at q0 has |lambda| = 3.5e3 1/s, limit 7.95e-4 s
    let scene = |dt: f64| {
        format!("[simulation]\nintegrator = \"rk4\"\ndt = {dt}\nduration = 0.002\n[[strands]]\nlength = 0.3\npreset = \"wavy\"\nelements = 5\n")
    };
    let bad = write(&dir, "bad.toml", &scene(1.0 / 30.0));
    let out = superhelix(&["validate", &bad.to_string_lossy()]);
    let all = text(&out);
    assert_eq!(out.status.code(), Some(1), "{all}");
    assert!(
        all.contains("simulation.dt: explicit rk4 is unstable"),
        "{all}"
    );
    assert!(!all.contains("positive definite"), "{all}");
    // the largest dt accepted, as the message states it, is accepted; 1.2 x it is not
    let allowed: f64 = all
        .split("that = ")
        .nth(1)
        .and_then(|t| t.split(" s;").next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no largest dt in: {all}"));
    assert!((3e-4..7e-4).contains(&allowed), "{allowed}");
    let out = superhelix(&[
        "run",
        &bad.to_string_lossy(),
        "--out",
        &dir.join("o1").to_string_lossy(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out).contains("simulation.dt: explicit rk4 is unstable"),
        "{}",
        text(&out)
    );
    let near = write(&dir, "near.toml", &scene(1.2 * allowed));
    assert_eq!(
        superhelix(&["validate", &near.to_string_lossy()])
            .status
            .code(),
        Some(1)
    );
    let good = write(&dir, "good.toml", &scene(0.99 * allowed));
    let out = superhelix(&["validate", &good.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let out = superhelix(&[
        "run",
        &good.to_string_lossy(),
        "--out",
        &dir.join("o2").to_string_lossy(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
}

/// `validate` and `run` print each groom's report: the curves' fit errors.
#[test]
fn validate_prints_the_fit_error_of_imported_curves() {
    let out = superhelix(&["validate", &repo("scenes/imported-curves.toml")]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("ok: 12 strands, 90 steps"), "{stdout}");
    assert!(
        stdout.contains("groom 'curls': 12 strands fitted to the curves of 'data/curls.obj' with N = 10: fit error"),
        "{stdout}"
    );
}

/// A mesh body's `path` is relative to the scene file, not to the working directory.
#[test]
fn validate_reads_a_mesh_body_relative_to_the_scene_file() {
    let dir = scratch("mesh-body");
    let _ = std::fs::create_dir_all(dir.join("meshes"));
    write(
        &dir,
        "meshes/tetra.obj",
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    );
    let body = "[[bodies]]\nshape = \"mesh\"\npath = \"meshes/tetra.obj\"\ncell = 0.01\n";
    let scene = write(&dir, "scene.toml", &format!("{STRAND}{body}"));
    let out = superhelix(&["validate", &scene.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out));
    let missing = write(
        &dir,
        "missing.toml",
        &format!("{STRAND}{}", body.replace("tetra", "none")),
    );
    let out = superhelix(&["validate", &missing.to_string_lossy()]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out).contains("bodies[0].path: cannot read"),
        "{}",
        text(&out)
    );
}

/// `run --tolerance` takes error-controlled steps and reports them in the summary; a
/// tolerance out of range is refused naming the field, before anything is simulated.
#[test]
fn run_takes_a_tolerance_and_reports_its_steps() {
    let dir = scratch("tolerance");
    let scene = write(
        &dir,
        "swing.toml",
        "[simulation]\ndt = 0.03333333333333333\nduration = 0.2\n[[strands]]\nlength = 0.2\nelements = 5\ndirection = [1.0, 0.0, 0.0]\nnatural = [0.0, 0.0, 0.0]\ninitial = \"straight\"\n[[strands]]\nlength = 0.1\nelements = 5\ndirection = [1.0, 0.0, 0.0]\nnatural = [0.0, 0.0, 0.0]\ninitial = \"straight\"\n",
    );
    let scene = scene.to_string_lossy().to_string();
    let out_dir = dir.join("out").to_string_lossy().to_string();
    let run = |tolerance: &str| {
        superhelix(&[
            "run",
            &scene,
            "--out",
            &out_dir,
            "--format",
            "json",
            "--format",
            "npy",
            "--tolerance",
            tolerance,
        ])
    };
    let out = run("1e-3");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(out.status.success(), "{}", text(&out));
    let last = stdout.lines().last().unwrap_or_default();
    // "...; tolerance 1.0e-3: largest estimated error E L, S steps taken, R rejected (D by
    // the contacts' depth check), ..."
    let after = |key: &str, end: &str| -> f64 {
        let from = last.find(key).map(|i| i + key.len()).unwrap_or(last.len());
        let rest = &last[from..];
        rest[..rest.find(end).unwrap_or(rest.len())]
            .trim()
            .parse()
            .unwrap_or(f64::NAN)
    };
    let largest = after("largest estimated error", " L");
    let taken = after(" L,", " steps taken");
    let rejected = after("steps taken,", " rejected");
    // of those, the ones the contacts' depth check rejected
    let deep = after("rejected (", " by the contacts' depth check");
    assert!((0.0..=rejected).contains(&deep), "{stdout}");
    assert!(largest > 0.0 && largest <= 1e-3, "{stdout}");
    assert!(taken >= 6.0, "{stdout}");
    // every frame says what the steps since the previous frame did, and the frames add up
    // to the run's summary
    let json: serde_json::Value = std::fs::read(dir.join("out/frames.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    let frames = json["frames"].as_array().cloned().unwrap_or_default();
    assert_eq!(frames.len(), 7);
    let column = |key: &str| -> Vec<f64> {
        frames
            .iter()
            .map(|f| f["error_control"][key].as_f64().unwrap_or(f64::NAN))
            .collect()
    };
    let steps = column("steps");
    assert_eq!(steps[0], 0.0, "frame 0 has no steps behind it");
    assert_eq!(steps.iter().sum::<f64>(), taken);
    assert_eq!(column("rejected").iter().sum::<f64>(), rejected);
    let errors = column("largest_error");
    // (the summary prints three digits)
    let frame_largest = errors.iter().copied().fold(0.0, f64::max);
    assert!(
        (frame_largest / largest - 1.0).abs() < 6e-3,
        "{frame_largest} vs {largest}"
    );
    let (small, large) = (column("smallest_step"), column("largest_step"));
    for k in 1..frames.len() {
        assert!(
            errors[k] > 0.0 && errors[k] <= 1e-3,
            "frame {k}: {}",
            errors[k]
        );
        // each strand's steps of a frame fill its 1/30 s (two strands)
        let dt = 1.0 / 30.0;
        assert!(small[k] > 0.0 && small[k] <= large[k] && large[k] <= dt * (1.0 + 1e-12));
        assert!(steps[k] * large[k] >= 2.0 * dt * (1.0 - 1e-12), "frame {k}");
        assert!(steps[k] * small[k] <= 2.0 * dt * (1.0 + 1e-12), "frame {k}");
    }
    // the same figures in frames.steps.npy, named by frames.index.json
    let index: serde_json::Value = std::fs::read(dir.join("out/frames.index.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    assert_eq!(index["error_control"]["file"], "frames.steps.npy");
    assert_eq!(index["error_control"]["columns"][1], "steps");
    let npy = std::fs::read(dir.join("out/frames.steps.npy")).unwrap_or_default();
    assert!(npy.len() > 10 && npy.starts_with(b"\x93NUMPY"));
    let header = u16::from_le_bytes([npy[8], npy[9]]) as usize + 10;
    assert!(String::from_utf8_lossy(&npy[10..header]).contains("'shape': (7, 5)"));
    let values: Vec<f64> = npy[header..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    assert_eq!(values.len(), 35);
    for k in 0..7 {
        assert_eq!(values[5 * k], errors[k]);
        assert_eq!(values[5 * k + 1], steps[k]);
        assert_eq!(values[5 * k + 3], small[k]);
    }
    // per strand, over the run: strand_steps.npy, named by the index, adds up to the summary
    assert_eq!(index["error_control"]["strands_file"], "strand_steps.npy");
    assert_eq!(
        index["error_control"]["strands_columns"][3],
        "smallest_step"
    );
    let npy = std::fs::read(dir.join("out/strand_steps.npy")).unwrap_or_default();
    assert!(npy.len() > 10 && npy.starts_with(b"\x93NUMPY"));
    let header = u16::from_le_bytes([npy[8], npy[9]]) as usize + 10;
    assert!(String::from_utf8_lossy(&npy[10..header]).contains("'shape': (2, 5)"));
    let rows: Vec<f64> = npy[header..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
        .collect();
    assert_eq!(rows.len(), 10);
    assert_eq!(rows[0] + rows[5], taken);
    assert_eq!(rows[1] + rows[6], rejected);
    assert_eq!(rows[2].max(rows[7]), frame_largest);
    let smallest = small[1..].iter().copied().fold(f64::INFINITY, f64::min);
    assert_eq!(rows[3].min(rows[8]), smallest);
    // the shorter strand has its own steps
    assert_ne!(rows[0], rows[5]);
    let which = if rows[3] <= rows[8] { 0 } else { 1 };
    assert!(last.contains(&format!("(strand {which};")), "{stdout}");
    let out = run("5");
    assert!(!out.status.success());
    assert!(
        text(&out).contains("--tolerance: 5: must be in"),
        "{}",
        text(&out)
    );
}

/// Output piped into a reader that stops reading (`| head -1`): the command ends by
/// SIGPIPE as any Unix tool does, without a panic.
#[cfg(unix)]
#[test]
fn a_closed_standard_output_ends_the_command_without_a_panic() {
    use std::os::unix::process::ExitStatusExt;
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args(["stress", "--quick"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(
        out.status.signal(),
        Some(libc::SIGPIPE),
        "{:?}: {err}",
        out.status
    );
}

/// A scene that would not fit in memory (150,000 strands of N = 200 on the runtime
/// engine: terabytes) is refused by `validate` and by `run` on the estimate, naming it
/// and the machine's available memory, before anything is allocated for its strands.
#[cfg(target_os = "linux")]
#[test]
fn a_scene_beyond_the_machines_memory_is_refused_on_its_estimate() {
    let dir = scratch("memory");
    let scene = write(
        &dir,
        "big.toml",
        "[[tresses]]\nname = \"t\"\ncount = 150000\nsemi_axes = [0.05, 0.03]\nlength = 0.2\nelements = 200\n",
    );
    for command in ["validate", "run"] {
        let (scene, out_dir) = (scene.to_string_lossy(), dir.join("out"));
        let out_dir = out_dir.to_string_lossy();
        // run: past the output plan's limit, so that the memory is what refuses it
        let args: Vec<&str> = if command == "run" {
            vec![command, &scene, "--out", &out_dir, "--allow-large-output"]
        } else {
            vec![command, &scene]
        };
        let out = superhelix(&args);
        let all = text(&out);
        assert_eq!(out.status.code(), Some(1), "{command}: {all}");
        assert!(
            all.contains("strands: the simulation needs about")
                && all.contains("GB")
                && all.contains("available"),
            "{command}: {all}"
        );
    }
}

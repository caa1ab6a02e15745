//! `superhelix run` and `validate` and their output: the plan and its limit, formats,
//! `--out` checks, a diverging run, and Ctrl-C in the middle of a run.

mod support;

use std::path::Path;
use std::process::Command;
use superhelix::runtime::output::npy::NpyFrameStore;
use superhelix::runtime::output::{FrameStore, JsonFrameStore};
use support::{scratch, stderr, stdout, superhelix};

/// `support::write` with the path as a string, as the commands take it.
fn write(dir: &Path, name: &str, contents: &str) -> String {
    s(&support::write(dir, name, contents))
}

fn s(p: &Path) -> String {
    p.to_string_lossy().into_owned()
}

/// 13 lines: 1000 strands of 40 points at 300 frames per second for 10 s.
const HUGE: &str = "[simulation]\nmode = \"dynamic\"\nduration = 10.0\noutput_fps = 300\n\
[output]\nsamples_per_element = 4\nformats = [\"json\"]\n\
[[patches]]\nname = \"carpet\"\ncount = [40, 25]\nsize = [0.1, 0.1]\nlength = 0.1\nelements = 10\n";

#[test]
fn validate_says_strand_or_strands_and_prints_the_plan() {
    let dir = scratch("validate");
    let one = write(&dir, "one.toml", "[[strands]]\nlength = 0.3\n");
    let out = superhelix(&["validate", &one]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = stdout(&out);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], "ok: 1 strand, 60 steps");
    // one strand of the default N = 10 with nothing the embedded engine lacks
    assert_eq!(
        lines[1],
        "engine: embedded (the fixed-N step; 5168 B per strand at N = 10, and one workspace per thread)"
    );
    assert!(
        lines[2].starts_with("memory: about ") && lines[2].contains("estimated"),
        "{text}"
    );
    assert!(
        lines[3].starts_with("output: ") && lines[3].contains("frames.json"),
        "{text}"
    );
    let two = write(
        &dir,
        "two.toml",
        "[[strands]]\nlength = 0.3\n[[strands]]\nlength = 0.2\n",
    );
    assert!(stdout(&superhelix(&["validate", &two])).starts_with("ok: 2 strands, 60 steps\n"));
    // problems go to stderr, one a line
    let bad = write(
        &dir,
        "bad.toml",
        "[[strands]]\nlength = 0.3\npoisson = 0.7\n[simulation]\ndt = 0.0\n",
    );
    let out = superhelix(&["validate", &bad]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(stdout(&out), "");
    let err = stderr(&out);
    assert!(
        err.lines().any(|l| l.starts_with("strands[0].poisson: ")),
        "{err}"
    );
    assert!(
        err.lines().any(|l| l.starts_with("simulation.dt: ")),
        "{err}"
    );
    assert!(
        err.lines()
            .last()
            .is_some_and(|l| l.ends_with("2 problem(s)")),
        "{err}"
    );
}

#[test]
fn an_oversized_plan_is_refused_by_validate_and_run_unless_lifted() {
    let dir = scratch("huge");
    let huge = write(&dir, "huge.toml", HUGE);
    assert_eq!(HUGE.lines().count(), 13);
    let out = superhelix(&["validate", &huge]);
    assert_eq!(out.status.code(), Some(1), "{}", stdout(&out));
    let err = stderr(&out);
    assert!(
        err.contains("GB")
            && err.contains("2.0 GB")
            && err.contains("max_bytes")
            && err.contains("--allow-large-output"),
        "{err}"
    );
    // run refuses before simulating or creating anything
    let out_dir = dir.join("out");
    let out = superhelix(&["run", &huge, "--out", &s(&out_dir)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("--allow-large-output"),
        "{}",
        stderr(&out)
    );
    assert!(!out_dir.exists());
    // max_bytes in the scene lifts the limit for validate (and so for run)
    let lifted = HUGE.replace("[output]\n", "[output]\nmax_bytes = 1e11\n");
    let lifted = write(&dir, "lifted.toml", &lifted);
    let out = superhelix(&["validate", &lifted]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    // under the default formats the frames go to frames.npy, and the run says so
    let default = write(
        &dir,
        "default.toml",
        &HUGE.replace("formats = [\"json\"]\n", ""),
    );
    let out = superhelix(&["validate", &default]);
    let text = stdout(&out);
    let plan = text
        .lines()
        .find(|l| l.starts_with("output: "))
        .unwrap_or_default();
    assert!(
        plan.contains("(frames.npy ") && !plan.contains("frames.json"),
        "{text}"
    );
    assert!(text.contains("writing frames.npy instead"), "{text}");
    // and at 5.9 GB this plan is over the limit too
    assert_eq!(out.status.code(), Some(1), "{text}");
}

#[test]
fn allow_large_output_lifts_the_limit_of_run() {
    // a plan of a few kB against a limit of 1 kB: refused, then allowed and written
    let dir = scratch("allow");
    let scene = write(
        &dir,
        "small.toml",
        "[simulation]\nduration = 0.1\n[output]\nmax_bytes = 1000\nformats = [\"json\"]\n[[strands]]\nlength = 0.1\n",
    );
    let out_dir = dir.join("out");
    let out = superhelix(&["run", &scene, "--out", &s(&out_dir)]);
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("1.0 kB"), "{}", stderr(&out));
    let out = superhelix(&["run", &scene, "--out", &s(&out_dir), "--allow-large-output"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(out_dir.join("frames.json").is_file());
}

#[test]
fn format_replaces_the_scene_list_and_bad_names_are_refused() {
    let dir = scratch("format");
    let scene = write(
        &dir,
        "scene.toml",
        "[simulation]\nduration = 0.1\n[output]\nformats = [\"usda\"]\n[[strands]]\nlength = 0.1\n",
    );
    let out_dir = dir.join("out");
    let out = superhelix(&["run", &scene, "--out", &s(&out_dir), "--format", "json"]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let plan = stdout(&out);
    let first = plan.lines().next().unwrap_or_default();
    assert!(
        first.contains("(frames.json ") && !first.contains("hair.usda"),
        "{plan}"
    );
    for bad in [
        &["--format", "json,vtk"][..],
        &["--format", "json", "--format", "pdf"],
    ] {
        let mut args = vec!["run", &scene, "--out"];
        let o = s(&dir.join("never"));
        args.push(&o);
        args.extend_from_slice(bad);
        let out = superhelix(&args);
        assert_eq!(out.status.code(), Some(1));
        let err = stderr(&out);
        assert!(
            err.contains("--format[1]") && err.contains("json, npy, usda"),
            "{err}"
        );
        assert!(!dir.join("never").exists());
    }
    let bad_scene = write(
        &dir,
        "bad.toml",
        "[output]\nformats = [\"json\", \"vrml\"]\n[[strands]]\nlength = 0.1\n",
    );
    let out = superhelix(&["validate", &bad_scene]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("output.formats[1]: unknown format \"vrml\""),
        "{}",
        stderr(&out)
    );
}

#[test]
fn out_pointing_at_a_file_is_refused_before_simulating() {
    let dir = scratch("out-file");
    let file = dir.join("taken");
    std::fs::write(&file, "not a directory").unwrap_or_else(|e| panic!("{e}"));
    // a long run: refusing it at once shows nothing was simulated
    let scene = write(
        &dir,
        "long.toml",
        "[simulation]\nduration = 1000.0\n[[strands]]\nlength = 0.3\n",
    );
    let out = superhelix(&["run", &scene, "--out", &s(&file)]);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        stderr(&out).trim(),
        format!(
            "error: --out: {} is a file, expected a directory",
            file.display()
        )
    );
    // refused before the first step: no step count printed, the file left as it was
    assert!(!stdout(&out).contains("steps x"), "{}", stdout(&out));
    assert_eq!(
        std::fs::read_to_string(&file).unwrap_or_default(),
        "not a directory"
    );
}

/// A run that diverges after it started keeps every frame written before, names the
/// strand and the time, and writes no non-finite number. Explicit RK4 at a dt that
/// `validate` accepts (within the stability limit at t = 0) on a wavy strand whose
/// stiffest mode stiffens as it moves: it blows up after about 0.37 s.
#[test]
fn a_diverging_run_keeps_its_frames_and_names_the_strand_and_time() {
    let dir = scratch("diverge");
    let scene = write(
        &dir,
        "diverge.toml",
        "[simulation]\nintegrator = \"rk4\"\ndt = 5e-4\nduration = 1.0\noutput_fps = 30\n\
         [[strands]]\nname = \"wavy\"\nlength = 0.3\npreset = \"wavy\"\nelements = 5\n",
    );
    let checked = superhelix(&["validate", &scene]);
    assert_eq!(checked.status.code(), Some(0), "{}", stderr(&checked));
    let out_dir = dir.join("out");
    let out = superhelix(&["run", &scene, "--out", &s(&out_dir), "--format", "json"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains("strand 'wavy' (index 0) failed at t = ") && err.contains("RK4"),
        "{err}"
    );
    let store =
        JsonFrameStore::open(&out_dir.join("frames.json")).unwrap_or_else(|e| panic!("{e}"));
    let kept = store.frame_count();
    assert!((1..31).contains(&kept), "{kept} frames: {err}");
    assert!(
        err.contains(&format!("{kept} of 31 frames written to ")),
        "{err}"
    );
    assert!(store.is_complete());
    for k in 0..kept {
        assert!(store.q(k).is_some_and(|q| q.iter().all(|x| x.is_finite())));
    }
}

/// Ctrl-C in the middle of a long run: exit 130, the message, every frame written
/// readable and consecutive, frames.npy equal to frames.json to float32 precision, and
/// the post-run files written from the frames kept.
#[cfg(unix)]
#[test]
fn sigint_stops_the_run_and_keeps_every_frame_written() {
    let dir = scratch("sigint");
    // 100 strands over 20 s: far longer than the test waits
    let scene = write(
        &dir,
        "long.toml",
        "[simulation]\nduration = 20.0\n\
         [[patches]]\nname = \"p\"\ncount = [10, 10]\nsize = [0.05, 0.05]\nlength = 0.2\nelements = 8\npreset = \"wavy\"\n",
    );
    let out_dir = dir.join("out");
    let mut child = Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args([
            "run",
            &scene,
            "--out",
            &s(&out_dir),
            "--format",
            "json,npy,obj",
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    let partial = out_dir.join("frames.json.partial");
    // no deadline: if no frame ever came, the run would end on its own and fail below
    loop {
        let frames = std::fs::read(&partial)
            .ok()
            .and_then(|b| JsonFrameStore::from_bytes(&b).ok())
            .map_or(0, |s| s.frame_count());
        if frames >= 2 {
            break;
        }
        if let Ok(Some(status)) = child.try_wait() {
            panic!("the run ended before it could be interrupted: {status}");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let pid = child.id() as libc::pid_t;
    // SAFETY: kill(2) on the child's pid, which has not been reaped yet.
    assert_eq!(unsafe { libc::kill(pid, libc::SIGINT) }, 0);
    let out = child
        .wait_with_output()
        .unwrap_or_else(|e| panic!("wait: {e}"));
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(130), "{err}");
    let line = err
        .lines()
        .find(|l| l.starts_with("interrupted at t = "))
        .unwrap_or_else(|| panic!("no interruption message in {err}"));
    // "interrupted at t = 0.533 s: 17 of 601 frames written to out/"
    let written: usize = line
        .split(": ")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(
        line.contains(&format!(
            "{written} of 601 frames written to {}",
            out_dir.display()
        )),
        "{line}"
    );
    assert!(written >= 2, "{line}");
    assert!(!partial.exists());
    let text =
        std::fs::read_to_string(out_dir.join("frames.json")).unwrap_or_else(|e| panic!("{e}"));
    let json: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("frames.json: {e}"));
    let frames = json["frames"]
        .as_array()
        .unwrap_or_else(|| panic!("frames"));
    assert_eq!(frames.len(), written);
    for (k, frame) in frames.iter().enumerate() {
        assert_eq!(frame["index"].as_u64(), Some(k as u64));
        let t = frame["time"].as_f64().unwrap_or(f64::NAN);
        assert!((t - k as f64 / 30.0).abs() < 1e-9, "frame {k} at {t}");
        let points = frame["points"]
            .as_array()
            .unwrap_or_else(|| panic!("points"));
        assert_eq!(points.len(), 100 * 33);
        let numbers = points
            .iter()
            .flat_map(|p| p.as_array().into_iter().flatten())
            .chain(frame["q"].as_array().into_iter().flatten());
        assert!(numbers.clone().count() == 100 * 33 * 3 + 100 * 24);
        assert!(numbers
            .map(|x| x.as_f64().unwrap_or(f64::NAN))
            .all(f64::is_finite));
    }
    // frames.npy holds the same frames, rounded to float32
    let mut npy =
        NpyFrameStore::open(&out_dir.join("frames.npy")).unwrap_or_else(|e| panic!("{e}"));
    let mut json =
        JsonFrameStore::open(&out_dir.join("frames.json")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(npy.frame_count(), written);
    assert_eq!(npy.layout(), json.layout());
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for k in 0..written {
        assert_eq!(npy.time(k), json.time(k));
        npy.points(k, &mut a).unwrap_or_else(|e| panic!("{e}"));
        json.points(k, &mut b).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(a.len(), b.len());
        for (p, q) in a.iter().zip(&b) {
            for i in 0..3 {
                // f32 rounding: half an ulp of float32, relative 2^-24
                assert!(
                    (p[i] - q[i]).abs() <= q[i].abs() * 6e-8,
                    "frame {k}: {p:?} vs {q:?}"
                );
            }
        }
    }
    assert!(out_dir.join("last_frame.obj").is_file(), "{}", stdout(&out));
}

/// `run` with `[render]`: the render strands are a prim of `hair.usda` and drawn in the
/// picture; the plan counts them; the frames hold only the guides.
#[test]
fn run_writes_the_render_strands_of_a_render_table() {
    let dir = scratch("render-table");
    let scene = format!(
        "{}\n[[bodies]]\nname = \"head\"\nshape = \"sphere\"\nradius = 0.03\ncenter = [0.0, 0.0, 0.04]\n\n[render]\nstrands = 40\nscalp_body = \"head\"\n",
        support::SCENE
    );
    let path = write(&dir, "render.toml", &scene);
    let plain = write(&dir, "plain.toml", support::SCENE);
    let out_dir = dir.join("out");
    let out = superhelix(&[
        "run",
        &path,
        "--out",
        &s(&out_dir),
        "--format",
        "npy,usda,png",
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let usda = std::fs::read_to_string(out_dir.join("hair.usda")).unwrap_or_default();
    assert!(
        usda.contains("def BasisCurves \"render\""),
        "no render prim"
    );
    // 40 curves of 13 points (the most of any strand)
    let counts = format!("int[] curveVertexCounts = [{}]", vec!["13"; 40].join(", "));
    assert!(usda.contains(&counts), "render counts missing");
    assert!(out_dir.join("preview.png").is_file());
    // the frames are the guides' alone
    let store = NpyFrameStore::open(&out_dir).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(store.layout().strands.len(), 4);
    // the plan of the render scene is larger by the render strands' points:
    // 40 x 13 points x 3 floats x 14 bytes x 7 frames + 40 x 40 bytes
    let plan = |p: &str| -> String {
        let out = superhelix(&["validate", p]);
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        stdout(&out)
    };
    let (with, without) = (plan(&path), plan(&plain));
    let usda_bytes = |text: &str| -> f64 {
        let at = text.find("hair.usda ").unwrap_or(0) + "hair.usda ".len();
        let rest = &text[at..];
        let number: String = rest
            .chars()
            .take_while(|c| *c == '.' || c.is_ascii_digit())
            .collect();
        let value: f64 = number.parse().unwrap_or(f64::NAN);
        if rest[number.len()..].trim_start().starts_with("MB") {
            value * 1e6
        } else {
            value * 1e3
        }
    };
    let added = usda_bytes(&with) - usda_bytes(&without);
    let expected = (40 * 13 * 3 * 14 * 7 + 40 * 40) as f64;
    // the plan prints 3 significant digits
    assert!(
        (added - expected).abs() < 0.01 * expected + 1000.0,
        "{with}\n{without}"
    );
}

/// `[output] nodes = K` writes every strand at K evenly spaced arc lengths and its d1
/// director between them, in float64: on a natural helix the nodes keep the helix's
/// chord lengths, on a straight rod with natural twist τ the director turns by τ per unit
/// length, and a pinned root's joint is not counted.
#[test]
fn nodes_sample_each_strand_at_even_arc_length_with_its_director() {
    use superhelix::runtime::output::npy::read_f64;
    let dir = scratch("nodes");
    let (radius, step, tau) = (0.01_f64, 0.02_f64, 20.0_f64);
    let scene = write(
        &dir,
        "nodes.toml",
        &format!(
            "[simulation]\nduration = 0.1\n[environment]\ngravity = \"none\"\n\
             [output]\nnodes = 9\nformats = [\"npy\"]\n\
             [[strands]]\nname = \"helix\"\nlength = 0.2\nelements = 5\n\
             helix_radius = {radius}\nhelix_step = {step}\n\
             [[strands]]\nname = \"twist\"\nlength = 0.1\nelements = 5\n\
             direction = [1.0, 0.0, 0.0]\nnatural = [{tau}, 0.0, 0.0]\n\
             [[strands]]\nname = \"pinned\"\nlength = 0.1\nelements = 5\n\
             direction = [0.0, 1.0, 0.0]\nnatural = [0.0, 0.0, 0.0]\n\
             [strands.ends]\nroot = \"pinned\"\n"
        ),
    );
    let plan = superhelix(&["validate", &scene]);
    assert!(plan.status.success(), "{}", stderr(&plan));
    assert!(
        stdout(&plan).contains("frames.nodes.npy"),
        "{}",
        stdout(&plan)
    );
    let out_dir = s(&dir.join("out"));
    let out = superhelix(&["run", &scene, "--out", &out_dir]);
    assert!(out.status.success(), "{}", stderr(&out));
    let (shape, nodes) = read_f64(&dir.join("out/frames.nodes.npy")).expect("nodes");
    assert_eq!(shape, vec![4, 3, 9, 3]);
    let (shape, d1) = read_f64(&dir.join("out/frames.d1.npy")).expect("d1");
    assert_eq!(shape, vec![4, 3, 8, 3]);
    let v = |a: &[f64], frame: usize, strand: usize, j: usize, per: usize| {
        let at = ((frame * 3 + strand) * per + j) * 3;
        [a[at], a[at + 1], a[at + 2]]
    };
    let dist = |a: [f64; 3], b: [f64; 3]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let frame = 3;
    // the helix: |p(s) − p(0)|² = 2R²(1 − cos φ) + c²φ², φ = s / √(R² + c²), c = step/2π
    let c = step / std::f64::consts::TAU;
    let mut worst: f64 = 0.0;
    for j in 0..9 {
        let s = 0.2 * j as f64 / 8.0;
        let phi = s / (radius * radius + c * c).sqrt();
        let chord = (2.0 * radius * radius * (1.0 - phi.cos()) + c * c * phi * phi).sqrt();
        let measured = dist(v(&nodes, frame, 0, j, 9), v(&nodes, frame, 0, 0, 9));
        worst = worst.max((measured - chord).abs() / 0.2);
    }
    assert!(worst < 1e-9, "helix chords off by {worst:e} L");
    // the twisted rod: straight along x, d1 across it, turned by τ Δs between segments
    let root = v(&nodes, frame, 1, 0, 9);
    let first = v(&d1, frame, 1, 0, 8);
    for j in 0..9 {
        let p = v(&nodes, frame, 1, j, 9);
        let expected = [root[0] + 0.1 * j as f64 / 8.0, root[1], root[2]];
        assert!(dist(p, expected) < 1e-9 * 0.1, "node {j}: {p:?}");
    }
    for j in 0..8 {
        let d = v(&d1, frame, 1, j, 8);
        assert!((dot(d, d) - 1.0).abs() < 1e-12, "segment {j}: {d:?}");
        assert!(d[0].abs() < 1e-9, "segment {j}: {d:?}");
        let turned = dot(d, first).clamp(-1.0, 1.0).acos();
        let expected = tau * 0.1 * j as f64 / 8.0;
        assert!(
            (turned - expected).abs() < 1e-7,
            "segment {j}: {turned} vs {expected}"
        );
    }
    // the pinned root: the nodes start at the joint's end, even along y
    let root = v(&nodes, frame, 2, 0, 9);
    for j in 0..9 {
        let p = v(&nodes, frame, 2, j, 9);
        let expected = [root[0], root[1] + 0.1 * j as f64 / 8.0, root[2]];
        assert!(dist(p, expected) < 1e-9 * 0.1, "node {j}: {p:?}");
    }
    // a single node is refused, naming the field
    let bad = write(
        &dir,
        "bad.toml",
        "[output]\nnodes = 1\n[[strands]]\nlength = 0.1\n",
    );
    let out = superhelix(&["validate", &bad]);
    assert!(!out.status.success());
    assert!(stderr(&out).contains("output.nodes"), "{}", stderr(&out));
}

/// `[output] times` puts the frames at exactly those times, off the step grid: the root of
/// a strand on a head oscillating as X = A sin(2πft) is where the motion puts it at each
/// time to round-off (a frame at the nearest step would be up to 2πfA·dt/2 ≈ 6e-4 m off).
/// Times out of order, past the duration or in a static run are refused, naming the field.
#[test]
fn frames_land_on_the_requested_times() {
    let dir = scratch("times");
    let (amplitude, frequency) = (0.01_f64, 2.0_f64);
    let times = [0.0, 0.0123, 0.05, 0.0777, 0.1];
    let list = times.map(|t| t.to_string()).join(", ");
    let scene = write(
        &dir,
        "times.toml",
        &format!(
            "[simulation]\ndt = 0.01\nduration = 0.1\n\
             [head]\nmotion = {{ kind = \"translate-oscillate\", direction = [1.0, 0.0, 0.0], \
             amplitude = {amplitude}, frequency_hz = {frequency} }}\n\
             [output]\ntimes = [{list}]\nformats = [\"json\", \"usda\"]\n\
             [[strands]]\nlength = 0.1\nelements = 5\n"
        ),
    );
    let out_dir = s(&dir.join("out"));
    let out = superhelix(&["run", &scene, "--out", &out_dir]);
    assert!(out.status.success(), "{}", stderr(&out));
    // two steps of 0.01 s are split (at 0.0123 and 0.0777): 12 steps
    assert!(
        stdout(&out).contains("12 steps x 1 strand"),
        "{}",
        stdout(&out)
    );
    let mut store = JsonFrameStore::open(&dir.join("out/frames.json")).expect("frames.json");
    assert_eq!(store.frame_count(), times.len());
    let mut points = Vec::new();
    for (k, &t) in times.iter().enumerate() {
        assert_eq!(store.time(k), t);
        assert!(
            (store.state_time(k) - t).abs() < 1e-15,
            "frame {k}: {}",
            store.state_time(k)
        );
        store.points(k, &mut points).expect("points");
        let x = amplitude * (std::f64::consts::TAU * frequency * t).sin();
        assert!(
            (points[0][0] - x).abs() < 1e-15,
            "frame {k}: root at {:?}, head at {x}",
            points[0]
        );
    }
    // the stage's time codes are t · output_fps (30)
    let stage = std::fs::read_to_string(dir.join("out/hair.usda")).unwrap_or_default();
    assert!(
        stage.contains("endTimeCode = 3\n"),
        "{}",
        &stage[..stage.len().min(400)]
    );
    for code in ["0: [", "0.369: [", "1.5: [", "2.331: [", "3: ["] {
        assert!(stage.contains(code), "{code} not in the stage");
    }
    for (times, field) in [
        ("[0.05, 0.02]", "output.times[1]"),
        ("[0.05, 0.2]", "output.times[1]"),
        ("[]", "output.times"),
    ] {
        let bad = write(
            &dir,
            "bad.toml",
            &format!("[simulation]\nduration = 0.1\n[output]\ntimes = {times}\n[[strands]]\nlength = 0.1\n"),
        );
        let out = superhelix(&["validate", &bad]);
        assert!(!out.status.success(), "{times}");
        assert!(stderr(&out).contains(field), "{times}: {}", stderr(&out));
    }
    let bad = write(
        &dir,
        "static.toml",
        "[simulation]\nmode = \"static\"\n[output]\ntimes = [0.0]\n[[strands]]\nlength = 0.1\n",
    );
    let out = superhelix(&["validate", &bad]);
    assert!(stderr(&out).contains("output.times"), "{}", stderr(&out));
}

/// A full disk (here: a process file-size limit, whose writes then fail with "File too
/// large" as on a full disk) stops the run with an error naming the file; the frames
/// written stay readable, and no temporary file is left behind.
#[cfg(unix)]
#[test]
fn a_full_disk_stops_the_run_naming_the_file_and_keeps_what_was_written() {
    let dir = scratch("disk-full");
    // 100 strands of 41 points: about 49 kB a frame, 31 frames
    let scene = write(
        &dir,
        "scene.toml",
        "[simulation]\nduration = 1.0\noutput_fps = 30\n[output]\nformats = [\"npy\"]\n\
         samples_per_element = 4\n[[patches]]\nname = \"p\"\ncount = [10, 10]\nsize = [0.05, 0.05]\n\
         length = 0.1\nelements = 10\n",
    );
    let (out, out_dir) = run_with_file_limit(&scene, &dir.join("out"), 400_000);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}\n{}", stdout(&out));
    assert!(
        err.contains("frames.npy") && err.contains("File too large"),
        "{err}"
    );
    let store = NpyFrameStore::open(&out_dir.join("frames.npy")).expect("frames.npy readable");
    let kept = store.frame_count();
    assert!((1..31).contains(&kept), "{kept} frames kept");
    assert_eq!(stray_temporaries(&out_dir), Vec::<String>::new());
    // one strand: its frames fit, its picture does not
    let one = write(
        &dir,
        "one.toml",
        "[simulation]\nduration = 1.0\noutput_fps = 30\n[output]\nformats = [\"npy\", \"png\"]\n\
         [[strands]]\nlength = 0.1\nelements = 10\n",
    );
    let (out, out_dir) = run_with_file_limit(&one, &dir.join("one"), 40_000);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}\n{}", stdout(&out));
    assert!(
        err.contains("preview") && err.contains("File too large"),
        "{err}"
    );
    let store = NpyFrameStore::open(&out_dir.join("frames.npy")).expect("frames.npy readable");
    assert_eq!(store.frame_count(), 31);
    assert_eq!(stray_temporaries(&out_dir), Vec::<String>::new());
}

/// `superhelix run SCENE --out OUT` with every file it writes limited to `limit` bytes
/// (writes beyond fail with EFBIG, not a signal).
#[cfg(unix)]
fn run_with_file_limit(
    scene: &str,
    out: &Path,
    limit: u64,
) -> (std::process::Output, std::path::PathBuf) {
    use std::os::unix::process::CommandExt;
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_superhelix"));
    cmd.args(["run", scene, "--out", &s(out)]);
    // SAFETY: between fork and exec only async-signal-safe calls (signal, setrlimit)
    unsafe {
        cmd.pre_exec(move || {
            libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
            let r = libc::rlimit {
                rlim_cur: limit,
                rlim_max: limit,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &r) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let output = cmd
        .output()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    (output, out.to_path_buf())
}

/// The `*.tmp` files in `dir`.
fn stray_temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".tmp"))
                .collect()
        })
        .unwrap_or_default()
}

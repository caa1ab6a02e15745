//! The C example `capi/examples/colliders.c` (strands dropped on a head sphere with two
//! shoulder capsules and a box given as a grid of signed distances, a game loop reading
//! back the contacts every frame), compiled with the system C compiler (`$CC`, else
//! `cc`) against the static library cargo built for this test, run, and compared with
//! the same scene as `superhelix run` runs it: the scene file this test writes (the grid
//! the example wrote as a `.npy` file, a `shape = "grid"` body), parsed and run by the
//! runtime library's `parse_scene_at`, `Simulation::new` with the closed-form kernels
//! and `run_to_frames` (the driver `run` streams its frames from), on the engine `run`
//! picks for it (`engine = "auto"`: the embedded one).
//!
//! - The centrelines agree at every frame to ≤ 1e-10 L at the element ends (the same
//!   fixed-N step with the same contacts on the same colliders: round-off only).
//! - No strand point ends more than 0.5 mm inside a collider: the example's own reading
//!   (`sh_batch_contacts`, the deepest-point sweep every 0.5 mm of arc length) after
//!   every step, and this test's check of the runtime's centreline points (4 per
//!   element) against the colliders' exact distances.
//! - The strands end on the colliders: each strand's nearest point is within 2 contact
//!   radii of the collider it falls on (a test that would pass with no collider fails).
//! - With the shoulders shrugging (their poses set before every step,
//!   `sh_batch_set_collider_pose`), no point goes deeper than 0.5 mm either, and the
//!   strands on them are lifted.
//! - With error-controlled steps (`tolerance 1e-3`, `sh_batch_set_tolerance` with the
//!   contacts; 8 contact points per element, `samples 8`, for both) the same checks hold
//!   against the scene with `tolerance = 1e-3`; the strands, which these steps damp less,
//!   still bounce at 1 s: each touches what it fell on within the last quarter second.
//!   With 4 points per element, 12.5 mm apart, a strand these steps drape over the box's
//!   edge dips 1.3 mm into it between two points (docs/contacts.md, "Deepest point").

use nalgebra::Vector3;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use superhelix_runtime::config::Engine;
use superhelix_runtime::{engine_for, parse_scene_at, run_to_frames, Simulation};

const N: usize = 5;
const STRANDS: usize = 6;
const FRAMES: usize = 60;
const LENGTH: f64 = 0.25;
const HEAD_RADIUS: f64 = 0.1;
const CONTACT_RADIUS: f64 = 1e-3;
/// The shoulders (start, end, radius) at rest, and the box (centre, half-sizes).
const SHOULDERS: [([f64; 3], [f64; 3], f64); 2] = [
    ([0.07, 0.0, -0.19], [0.28, 0.0, -0.23], 0.045),
    ([-0.07, 0.0, -0.19], [-0.28, 0.0, -0.23], 0.045),
];
const BOX_CENTER: [f64; 3] = [0.0, -0.15, -0.19];
const BOX_HALF: [f64; 3] = [0.12, 0.06, 0.04];

/// The compiled example (built once per test process).
fn example() -> &'static Path {
    static EXE: OnceLock<PathBuf> = OnceLock::new();
    EXE.get_or_init(|| {
        let deps = std::env::current_exe()
            .expect("test executable")
            .parent()
            .expect("deps directory")
            .to_path_buf();
        let lib = deps.join("libsuperhelix_capi.a");
        assert!(lib.exists(), "{} not found", lib.display());
        let capi = Path::new(env!("CARGO_MANIFEST_DIR"));
        let out_dir = deps.join("..").join("capi-example");
        std::fs::create_dir_all(&out_dir).expect("output directory");
        let exe = out_dir.join("colliders");
        let cc = std::env::var("CC").unwrap_or_else(|_| "cc".to_string());
        let output = Command::new(&cc)
            .args([
                "-std=c99",
                "-O2",
                "-Wall",
                "-Wextra",
                "-pedantic",
                "-Werror",
                "-I",
            ])
            .arg(capi.join("include"))
            .arg(capi.join("examples").join("colliders.c"))
            .arg(&lib)
            .args(["-lpthread", "-ldl", "-lm", "-o"])
            .arg(&exe)
            .output()
            .unwrap_or_else(|e| panic!("running the C compiler `{cc}`: {e}"));
        assert!(
            output.status.success(),
            "`{cc}` failed on colliders.c:\n{}",
            String::from_utf8_lossy(&output.stderr)
        );
        exe
    })
}

/// What the example printed.
#[derive(Debug)]
struct Printed {
    /// nx, ny, nz, origin, spacing.
    grid: ([usize; 3], [f64; 3], f64),
    roots: [[f64; 3]; STRANDS],
    directions: [[f64; 3]; STRANDS],
    /// After each step (index 0: the first step).
    deepest: Vec<f64>,
    touching: Vec<usize>,
    /// `points[frame - 1][strand][i]`.
    points: Vec<[[[f64; 3]; N + 1]; STRANDS]>,
}

fn run_example(args: &[&str]) -> Printed {
    let output = Command::new(example())
        .args(args)
        .output()
        .expect("run colliders");
    let stdout = String::from_utf8(output.stdout).expect("UTF-8 output");
    assert!(
        output.status.success(),
        "colliders {args:?} failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let nan3 = [f64::NAN; 3];
    let mut p = Printed {
        grid: ([0; 3], nan3, f64::NAN),
        roots: [nan3; STRANDS],
        directions: [nan3; STRANDS],
        deepest: vec![f64::NAN; FRAMES],
        touching: vec![0; FRAMES],
        points: vec![[[nan3; N + 1]; STRANDS]; FRAMES],
    };
    for line in stdout.lines().filter(|l| !l.starts_with('#')) {
        let w: Vec<&str> = line.split_whitespace().collect();
        let x = |k: usize| -> f64 { w[k].parse().expect("number") };
        let u = |k: usize| -> usize { w[k].parse().expect("index") };
        match w[0] {
            "grid" => p.grid = ([u(1), u(2), u(3)], [x(4), x(5), x(6)], x(7)),
            "root" => p.roots[u(1)] = [x(2), x(3), x(4)],
            "direction" => p.directions[u(1)] = [x(2), x(3), x(4)],
            "deepest" => p.deepest[u(1) - 1] = x(2),
            "touching" => p.touching[u(1) - 1] = u(2),
            "point" => p.points[u(1) - 1][u(2)][u(3)] = [x(4), x(5), x(6)],
            other => panic!("unexpected line `{other}`"),
        }
    }
    let all = p.roots.iter().chain(&p.directions).flatten();
    let all = all.chain(p.points.iter().flatten().flatten().flatten());
    assert!(
        all.chain(&p.deepest).all(|x| x.is_finite()),
        "incomplete output:\n{stdout}"
    );
    p
}

/// A number as TOML reads it back to the same double.
fn num(x: f64) -> String {
    format!("{x:?}")
}

fn vec3(v: &[f64; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// The example's scene as a scene file: its strands, colliders and contacts.
fn scene(p: &Printed, grid_file: &str) -> String {
    let mut s = format!(
        "[simulation]\ndt = {}\nduration = 1.0\noutput_fps = 60\nengine = \"auto\"\n\n\
         [environment]\ngravity = [0.0, 0.0, -9.81]\n\n\
         [contacts]\nfriction = \"coulomb\"\nfriction_coefficient = 0.3\n\
         kinetic_friction_coefficient = 0.2\n\n",
        num(1.0 / 60.0)
    );
    for (root, direction) in p.roots.iter().zip(&p.directions) {
        s += &format!(
            "[[strands]]\nroot = {}\ndirection = {}\nnormal = [0.0, 0.0, 1.0]\n\
             length = {LENGTH}\nelements = {N}\nnatural = [0.0, 0.0, 0.0]\nradius = 50e-6\n\
             ellipticity = 1.0\nyoungs_modulus = 1.5e9\npoisson = 0.48\ndensity = 1300.0\n\
             internal_friction = 5e-11\nair_drag = 5e-6\n\n",
            vec3(root),
            vec3(direction)
        );
    }
    s += &format!(
        "[[bodies]]\nname = \"head\"\nshape = \"sphere\"\nradius = {HEAD_RADIUS}\n\
         attached = \"head\"\n\n"
    );
    for (k, (start, end, radius)) in SHOULDERS.iter().enumerate() {
        s += &format!(
            "[[bodies]]\nname = \"shoulder{k}\"\nshape = \"capsule\"\nstart = {}\nend = {}\n\
             radius = {radius}\nattached = \"motion\"\n[bodies.motion]\nkind = \"still\"\n\n",
            vec3(start),
            vec3(end)
        );
    }
    let (_, origin, cell) = p.grid;
    s += &format!(
        "[[bodies]]\nname = \"box\"\nshape = \"grid\"\npath = \"{grid_file}\"\n\
         origin = {}\ncell = {}\nattached = \"world\"\n",
        vec3(&origin),
        num(cell)
    );
    s
}

/// The exact signed distance of each collider at x (head at rest: head = world), and the
/// box's.
fn distances(x: &Vector3<f64>, lift: f64) -> [f64; 4] {
    let capsule = |(a, b, r): ([f64; 3], [f64; 3], f64)| {
        let (a, b) = (
            Vector3::from(a) + Vector3::z() * lift,
            Vector3::from(b) + Vector3::z() * lift,
        );
        let t = ((x - a).dot(&(b - a)) / (b - a).norm_squared()).clamp(0.0, 1.0);
        (x - (a + (b - a) * t)).norm() - r
    };
    let q = Vector3::from_fn(|a, _| (x[a] - BOX_CENTER[a]).abs() - BOX_HALF[a]);
    let outside = q.map(|v| v.max(0.0)).norm();
    let inside = q.max().min(0.0);
    [
        x.norm() - HEAD_RADIUS,
        capsule(SHOULDERS[0]),
        capsule(SHOULDERS[1]),
        outside + inside,
    ]
}

/// A folder of its own for this test's files.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-capi-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temporary folder");
    dir
}

#[test]
fn c_example_with_colliders_matches_the_run_of_the_same_scene() {
    matches_the_run("colliders", None);
}

#[test]
fn c_example_with_colliders_under_a_tolerance_matches_the_run_of_the_same_scene() {
    matches_the_run("colliders-tolerance", Some("1e-3"));
}

/// The example (with error-controlled steps at `tolerance` and 8 contact points per
/// element when given) against the run of its scene: the checks of the module page.
fn matches_the_run(name: &str, tolerance: Option<&str>) {
    let dir = temp_dir(name);
    let grid = dir.join("box.npy");
    let mut args = vec![grid.to_str().expect("UTF-8 path")];
    if let Some(t) = tolerance {
        args.extend(["tolerance", t, "samples", "8"]);
    }
    let p = run_example(&args);
    let mut text = scene(&p, "box.npy");
    if let Some(t) = tolerance {
        text = text
            .replace(
                "[simulation]\n",
                &format!("[simulation]\ntolerance = {t}\n"),
            )
            .replace("[contacts]\n", "[contacts]\nsamples_per_element = 8\n");
    }
    std::fs::write(dir.join("scene.toml"), &text).expect("write the scene");
    let setup = parse_scene_at(&text, &dir).unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_eq!(
        engine_for(&setup).0,
        Engine::Embedded,
        "run's engine for the scene"
    );
    let factory = superhelix_runtime::kernels::closed_form::kernel_factory();
    let mut sim = Simulation::new(setup.clone(), Some(factory)).expect("the scene builds");
    let (frames, summary) = run_to_frames(
        &mut sim,
        &setup.config,
        setup.samples_per_element,
        |_, _| {},
    )
    .expect("the run");
    assert_eq!(frames.frame_times.len(), FRAMES + 1);
    let per = setup.samples_per_element;

    // the centrelines at the element ends, every frame
    let mut largest = 0.0f64;
    for (f, c_frame) in p.points.iter().enumerate() {
        for (s, c_points) in c_frame.iter().enumerate() {
            let run = &frames.strands[s].points[f + 1];
            for (i, c) in c_points.iter().enumerate() {
                let r = run[per * i];
                let d = (0..3).fold(0.0f64, |m, a| m.max((c[a] - r[a]).abs()));
                largest = largest.max(d / LENGTH);
            }
        }
    }
    let c_deepest = p.deepest.iter().fold(0.0f64, |m, &d| m.max(d));
    eprintln!(
        "C example vs run (tolerance {tolerance:?}): largest centreline difference {largest:.3e} L over {FRAMES} frames; \
         deepest point {c_deepest:.3e} m (C, after any step), {:?} m (run); contact points \
         touching at the end: {}",
        summary.deepest_inside,
        p.touching[FRAMES - 1]
    );
    assert!(largest <= 1e-10, "the centrelines differ by {largest:e} L");

    // no point deeper than 0.5 mm: the library's sweep after every step, and the exact
    // distances at the run's centreline points
    let bound = 5e-4;
    assert!(c_deepest <= bound, "{c_deepest} m inside a collider");
    let run_deepest = summary.deepest_inside.unwrap_or(0.0);
    assert!(
        (c_deepest - run_deepest).abs() <= 1e-10 * LENGTH,
        "deepest {c_deepest} m (C) against {run_deepest} m (run)"
    );
    // where the strands lie: at the end; under the error control, whose steps damp
    // nothing of their own, the strands still bounce at 1 s: over the last quarter second
    let landed = if tolerance.is_some() {
        FRAMES - FRAMES / 4
    } else {
        FRAMES
    };
    let mut nearest = [[f64::INFINITY; 4]; STRANDS];
    for (s, strand) in frames.strands.iter().enumerate() {
        for (f, points) in strand.points.iter().enumerate().skip(1) {
            for (j, x) in points.iter().enumerate() {
                let d = distances(&Vector3::from(*x), 0.0);
                // the root sits on the head's surface (its root zone)
                let from = if j < per { 1 } else { 0 };
                for (b, &db) in d.iter().enumerate().skip(from) {
                    assert!(
                        db >= -bound,
                        "strand {s}, frame {f}, point {j}: {db} m in body {b}"
                    );
                }
                if f >= landed {
                    for (n, &db) in nearest[s].iter_mut().zip(&d) {
                        *n = n.min(db);
                    }
                }
            }
        }
    }
    // each strand ends lying on what it fell on (touches it over the last quarter second
    // under the error control): strands 0 and 4 on the right shoulder, 1 and 5 on the
    // left, 2 and 3 on the box
    for (s, body) in [(0, 1), (4, 1), (1, 2), (5, 2), (2, 3), (3, 3)] {
        assert!(
            nearest[s][body] <= 2.0 * CONTACT_RADIUS,
            "strand {s} ends {} m from body {body}",
            nearest[s][body]
        );
    }
    assert!(p.touching[FRAMES - 1] > 0);
}

#[test]
fn c_example_with_shrugging_shoulders_keeps_the_strands_out() {
    let p = run_example(&["shrug"]);
    let c_deepest = p.deepest.iter().fold(0.0f64, |m, &d| m.max(d));
    eprintln!("shrugging: deepest point {c_deepest:.3e} m after any step");
    assert!(c_deepest <= 5e-4, "{c_deepest} m inside a collider");
    // the shoulders are 2 cm up at 0.75 s (frame 45): the strands lying on them, lifted
    let lift = |f: usize| {
        [0, 1, 4, 5]
            .iter()
            .map(|&s| p.points[f - 1][s][N][2])
            .sum::<f64>()
            / 4.0
    };
    assert!(
        lift(45) - lift(30) > 0.01,
        "tips at {} m (0.5 s) and {} m (0.75 s)",
        lift(30),
        lift(45)
    );
    // and the exact distances at the element ends, the shoulders where the step ended
    for (f, frame) in p.points.iter().enumerate() {
        let t = (f + 1) as f64 / 60.0;
        let u = if t < 0.75 {
            (t - 0.5) / 0.25
        } else {
            (1.0 - t) / 0.25
        }
        .clamp(0.0, 1.0);
        let up = 0.02 * u * u * (3.0 - 2.0 * u);
        for (s, points) in frame.iter().enumerate() {
            for (i, x) in points.iter().enumerate().skip(1) {
                let d = distances(&Vector3::from(*x), up);
                assert!(
                    d.iter().all(|&db| db >= -5e-4),
                    "strand {s}, frame {}, end {i}: {d:?}",
                    f + 1
                );
            }
        }
    }
}

//! `[[grooms]]`: roots on a scalp region of a body (sphere, ellipsoid, mesh), curves read
//! from OBJ and USDA files (the project's own writer, and pxr's when it is installed),
//! the fit report, the sag-free start against a control, and every refusal naming its
//! field.

use std::path::{Path, PathBuf};
use superhelix_runtime::groom::{read_curves, GroomSource};
use superhelix_runtime::kernels::closed_form::kernel_factory;
use superhelix_runtime::model::reconstruction::sample_centreline;
use superhelix_runtime::output::frames::{FrameLayout, StrandInfo};
use superhelix_runtime::output::memory::MemoryFrames;
use superhelix_runtime::output::usd::write_usda;
use superhelix_runtime::{parse_scene_at, parse_scene_reporting, Bodies, HeadState};
use superhelix_runtime::{Error, Simulation, SimulationSetup, Vector3};

/// A fresh folder for one test's files.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-grooms-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("temporary folder");
    dir
}

fn setup_in(text: &str, dir: &Path) -> SimulationSetup {
    match parse_scene_at(text, dir) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

/// The problems of an invalid scene, as `field: message` lines.
fn problems(text: &str, dir: &Path) -> String {
    match parse_scene_at(text, dir) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(Error::Invalid(errors)) => errors
            .iter()
            .map(|e| format!("{}: {}", e.field, e.message))
            .collect::<Vec<_>>()
            .join("\n"),
        Err(e) => e.to_string(),
    }
}

const HEAD: &str = r#"
[[bodies]]
name = "head"
shape = "ellipsoid"
center = [0.0, 0.0, 0.0]
radii = [0.095, 0.075, 0.11]
"#;

#[test]
fn roots_on_an_ellipsoid_cap_are_poisson_disk_on_the_surface_with_combed_frames() {
    let dir = scratch("ellipsoid");
    let text = format!(
        r#"{HEAD}
[[grooms]]
name = "top"
body = "head"
count = 300
axis = [0.0, 0.0, 1.0]
max_angle_deg = 70.0
cut_normal = [-1.0, 0.0, 0.0]
cut_point = [0.02, 0.0, 0.0]
comb = [-1.0, 0.0, -1.0]
tilt_deg = 20.0
preset = "wavy"
length = 0.12
elements = 4
length_variation = 0.2
curvature_variation = 0.1
seed = 7
"#
    );
    let (setup, reports) = parse_scene_reporting(&text, &dir).expect("valid");
    assert_eq!(setup.strands.len(), 300);
    let bodies = Bodies::build(&setup.bodies).expect("bodies");
    let placed = bodies.at(HeadState::rest(), 0.0);
    let comb = Vector3::new(-1.0, 0.0, -1.0).normalize();
    let mut lengths = Vec::new();
    let mut turned = 0;
    for s in &setup.strands {
        let g = &s.strand.geometry;
        let p = placed.query(0, &g.root_position);
        assert!(
            p.distance.abs() < 1e-9,
            "root off the surface by {}",
            p.distance
        );
        let d = g.root_position;
        let angle = (d.z / d.norm()).acos().to_degrees();
        assert!(
            angle <= 70.0 + 1e-9 && d.x <= 0.02 + 1e-12,
            "outside the region: {d:?}"
        );
        let (n0, n1) = (g.root_frame.column(0), g.root_frame.column(1));
        let along = comb - p.normal * p.normal.dot(&comb);
        let mut points = Vec::new();
        sample_centreline(g, &s.q0, 8, &mut points);
        // beyond its first point no point of a strand is inside the head
        let deepest = points[1..]
            .iter()
            .map(|x| placed.query(0, x).distance)
            .fold(f64::MAX, f64::min);
        assert!(
            deepest >= -1e-12,
            "{} enters the head by {deepest:e} m",
            s.strand.name
        );
        // n0 is the normal tilted by 20 degrees towards the comb, n1 along the comb; or,
        // when that frame would take the strand into the head, the axis of the first
        // element's helix (its Darboux vector) is
        let tilted = |d: &Vector3<f64>| {
            (d.dot(&p.normal) - 20f64.to_radians().cos()).abs() < 1e-9
                && d.cross(&p.normal).dot(&along.cross(&p.normal)) > 0.0
        };
        let as_groomed = tilted(&n0.into_owned()) && n1.dot(&along) > 0.0;
        let axis = g.root_frame * Vector3::new(s.q0[0], s.q0[1], s.q0[2]).normalize();
        assert!(
            as_groomed || tilted(&axis),
            "{}: neither frame",
            s.strand.name
        );
        assert!(n1.dot(&n0).abs() < 1e-12 && (g.root_frame.determinant() - 1.0).abs() < 1e-12);
        turned += usize::from(!as_groomed);
        assert!(s.group == "top" && s.strand.name.starts_with("top_"));
        lengths.push(g.length());
    }
    let (lo, hi) = lengths
        .iter()
        .fold((f64::MAX, 0.0f64), |(a, b), &l| (a.min(l), b.max(l)));
    assert!(
        lo >= 0.12 * 0.8 - 1e-12 && hi <= 0.12 * 1.2 + 1e-12 && hi - lo > 0.03,
        "{lo} {hi}"
    );
    let report = &reports[0];
    println!("{report}");
    let clearance = report
        .clearance
        .expect("a surface groom reports its clearance");
    assert_eq!(
        (clearance.lifted, clearance.entering),
        (turned, 0),
        "{report}"
    );
    let GroomSource::Surface {
        min_spacing,
        packing_spacing,
        area,
        ..
    } = report.source
    else {
        panic!("surface");
    };
    assert!(min_spacing / packing_spacing > 0.5, "{report}");
    assert!(area > 0.01 && area < 0.05);
    // the same scene gives the same roots; another seed others
    let again = setup_in(&text, &dir);
    assert_eq!(again.strands, setup.strands);
    let other = setup_in(&text.replace("seed = 7", "seed = 8"), &dir);
    assert_ne!(
        other.strands[0].strand.geometry.root_position,
        setup.strands[0].strand.geometry.root_position
    );
}

#[test]
fn density_gives_roots_in_proportion_to_the_area() {
    let dir = scratch("density");
    // a sphere of radius 0.1 m: the cap within 60 degrees of +z has area 2 pi r^2 (1 - cos 60)
    let text = r#"
[[bodies]]
name = "ball"
shape = "sphere"
radius = 0.1

[[grooms]]
body = "ball"
density = 20000.0
max_angle_deg = 60.0
length = 0.05
elements = 2
"#;
    let setup = setup_in(text, &dir);
    let expected = 20000.0 * 2.0 * std::f64::consts::PI * 0.01 * 0.5;
    let n = setup.strands.len() as f64;
    println!("density: {n} roots, expected {expected:.1}");
    assert!((n / expected - 1.0).abs() < 0.02, "{n} vs {expected}");
}

/// A closed cube of side `a` centred at the origin, outward triangles.
fn cube_obj(a: f64) -> String {
    let h = a / 2.0;
    let mut s = String::new();
    for k in 0..8 {
        let (x, y, z) = (
            if k & 1 == 0 { -h } else { h },
            if k & 2 == 0 { -h } else { h },
            if k & 4 == 0 { -h } else { h },
        );
        s += &format!("v {x} {y} {z}\n");
    }
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        s += &format!(
            "f {} {} {}\nf {} {} {}\n",
            f[0], f[1], f[2], f[0], f[2], f[3]
        );
    }
    s
}

#[test]
fn roots_on_a_mesh_lie_on_its_triangles() {
    let dir = scratch("mesh");
    std::fs::write(dir.join("cube.obj"), cube_obj(0.2)).expect("write");
    let text = r#"
[[bodies]]
name = "block"
shape = "mesh"
path = "cube.obj"

[[grooms]]
body = "block"
count = 200
axis = [0.0, 0.0, 1.0]
max_angle_deg = 30.0
length = 0.05
elements = 2
"#;
    let setup = setup_in(text, &dir);
    assert_eq!(setup.strands.len(), 200);
    for s in &setup.strands {
        let g = &s.strand.geometry;
        // a cap of 30 degrees from the centre stays on the top face (tan 30 < 1)
        assert!(
            (g.root_position.z - 0.1).abs() < 1e-12,
            "{:?}",
            g.root_position
        );
        assert!(g.root_position.x.abs() <= 0.1 && g.root_position.y.abs() <= 0.1);
        assert!(g.root_frame.column(0).z > 0.5, "leaves outward");
    }
    // the whole cube: roots on every face
    let all = setup_in(&text.replace("max_angle_deg = 30.0\n", ""), &dir);
    let bottom = all
        .strands
        .iter()
        .filter(|s| (s.strand.geometry.root_position.z + 0.1).abs() < 1e-12)
        .count();
    assert!(
        (15..=50).contains(&bottom),
        "{bottom} of 200 on the bottom face (1/6 of the area)"
    );
}

/// A polyline hair: a helix of radius `r` and step `step` hanging from `root`.
fn helix_points(
    root: Vector3<f64>,
    r: f64,
    step: f64,
    turns: f64,
    count: usize,
) -> Vec<Vector3<f64>> {
    (0..count)
        .map(|k| {
            let t = std::f64::consts::TAU * turns * k as f64 / (count - 1) as f64;
            root + Vector3::new(
                r * (t.cos() - 1.0),
                r * t.sin(),
                -step * t / std::f64::consts::TAU,
            )
        })
        .collect()
}

#[test]
fn curves_from_an_obj_file_are_fitted_and_reported() {
    let dir = scratch("obj-curves");
    let mut obj = String::from("# three curls\n");
    let mut base = 0;
    for (k, r) in [0.006, 0.008, 0.01].iter().enumerate() {
        let points = helix_points(Vector3::new(0.03 * k as f64, 0.0, 0.1), *r, 0.012, 3.0, 61);
        for p in &points {
            obj += &format!("v {} {} {}\n", p.x, p.y, p.z);
        }
        obj += "l";
        for i in 0..points.len() {
            obj += &format!(" {}", base + i + 1);
        }
        obj += "\n";
        base += points.len();
    }
    std::fs::write(dir.join("curls.obj"), obj).expect("write");
    let text = r#"
[[grooms]]
name = "curls"
curves = "curls.obj"
preset = "curly"
elements = 8
"#;
    let (setup, reports) = parse_scene_reporting(text, &dir).expect("valid");
    assert_eq!(setup.strands.len(), 3);
    let report = &reports[0];
    println!("{report}");
    let GroomSource::Curves {
        curves, elements, ..
    } = &report.source
    else {
        panic!("curves");
    };
    assert_eq!(*elements, 8);
    for c in curves {
        // a circular helix is a Super-Helix: fitted to round-off
        assert!(c.error.max < 1e-8, "{c:?}");
        assert_eq!(c.points, 61);
    }
    let s = &setup.strands[1];
    assert_eq!(
        s.strand.geometry.root_position,
        Vector3::new(0.03, 0.0, 0.1)
    );
    assert_eq!(s.strand.geometry.elements(), 8);
    // sag-free by default for curves: the natural shape is not the fitted one
    assert!(report.sag_free_change.is_some_and(|c| c > 0.0));
    assert_ne!(s.strand.natural, s.q0);
    let off = setup_in(&format!("{text}sag_free = false\n"), &dir);
    assert_eq!(off.strands[1].strand.natural, off.strands[1].q0);
    // the report goes through validate: the scene builds
    Simulation::new(setup, Some(kernel_factory())).expect("builds");
}

#[test]
fn usda_curves_written_by_the_project_and_by_pxr_are_read() {
    let dir = scratch("usda");
    // the project's writer: two groups, three strands, two frames; frame 0 is read
    let strands: Vec<Vec<Vector3<f64>>> = (0..3)
        .map(|k| {
            helix_points(
                Vector3::new(0.02 * k as f64, 0.01, 0.0),
                0.007,
                0.01,
                2.0,
                33,
            )
        })
        .collect();
    let layout = FrameLayout {
        strands: (0..3)
            .map(|k| StrandInfo {
                name: format!("s{k}"),
                group: if k < 2 { "a" } else { "b" }.into(),
                radius: 5e-5,
                points: 33,
                coordinates: 24,
            })
            .collect(),
        output_fps: 30.0,
        planned_frames: 2,
        held_tips: Vec::new(),
    };
    let mut frames = MemoryFrames::new(layout);
    for shift in [0.0, 0.05] {
        frames.times.push(shift);
        frames.state_times.push(shift);
        frames.points.push(
            strands
                .iter()
                .flatten()
                .map(|p| [p.x + shift, p.y, p.z])
                .collect(),
        );
        frames.q.push(vec![0.0; 72]);
    }
    let path = dir.join("hair.usda");
    write_usda(&path, &mut frames, None).expect("written");
    let curves = read_curves(&path).expect("read");
    assert_eq!(curves.len(), 3);
    for (c, s) in curves.iter().zip(&strands) {
        assert_eq!(c.points.len(), 33);
        for (p, q) in c.points.iter().zip(s) {
            assert!((p - q).norm() <= 1e-7 * (1.0 + q.norm()), "{p:?} {q:?}");
        }
    }
    // the same file as a groom
    let text = "[[grooms]]\ncurves = \"hair.usda\"\nelements = 6\nsag_free = false\n";
    let (_, reports) = parse_scene_reporting(text, &dir).expect("valid");
    println!("{}", reports[0]);
    // the float32 points of the file fit a Super-Helix to about their precision
    assert!(reports[0].worst_fit().is_some_and(|(_, max, _)| max < 1e-5));

    // pxr's writer, when it is installed
    let script = format!(
        r#"
from pxr import Usd, UsdGeom, Vt, Gf
stage = Usd.Stage.CreateNew({path:?})
UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
root = UsdGeom.Xform.Define(stage, "/groom")
c = UsdGeom.BasisCurves.Define(stage, "/groom/guides")
c.CreateTypeAttr("linear")
c.CreateCurveVertexCountsAttr(Vt.IntArray([3, 2]))
c.CreatePointsAttr(Vt.Vec3fArray([Gf.Vec3f(0, 0, 0), Gf.Vec3f(0, 0, -0.01), Gf.Vec3f(0.001, 0, -0.02), Gf.Vec3f(0.1, 0, 0), Gf.Vec3f(0.1, 0, -0.05)]))
c.CreateWidthsAttr(Vt.FloatArray([0.0001]))
c.GetPointsAttr().Set(Vt.Vec3fArray([Gf.Vec3f(9, 9, 9)] * 5), 4.0)
stage.GetRootLayer().Save()
"#,
        path = dir.join("pxr.usda").display().to_string()
    );
    match std::process::Command::new("python3")
        .args(["-c", &script])
        .output()
    {
        Ok(out) if out.status.success() => {
            let curves = read_curves(&dir.join("pxr.usda")).expect("pxr's file is read");
            assert_eq!(curves.len(), 2);
            assert_eq!(curves[0].points.len(), 3);
            assert!((curves[0].points[2] - Vector3::new(0.001, 0.0, -0.02)).norm() < 1e-9);
            assert!((curves[1].points[1] - Vector3::new(0.1, 0.0, -0.05)).norm() < 1e-9);
            println!("read the curves of a stage written by pxr");
        }
        _ => {
            let why = "python3 with pxr (usd-core) is not available: pxr's file not tested";
            // CI has the tool (.ci/run installs usd-core): a skip there is a failure
            assert!(
                std::env::var_os("SUPERHELIX_REQUIRE_TOOLS").is_none(),
                "{why}"
            );
            println!("skipped: {why}");
        }
    }
}

/// The largest displacement of a centreline point over the first `steps` steps.
fn max_motion(setup: SimulationSetup, steps: usize) -> f64 {
    let mut sim = Simulation::new(setup, Some(kernel_factory())).expect("builds");
    let per = 4;
    let start: Vec<Vec<[f64; 3]>> = (0..sim.strand_count())
        .map(|i| sim.centreline_world(i, per))
        .collect();
    let mut worst = 0.0f64;
    for _ in 0..steps {
        sim.step().expect("steps");
        for (i, s) in start.iter().enumerate() {
            for (a, b) in s.iter().zip(sim.centreline_world(i, per)) {
                let d = Vector3::from(*a) - Vector3::from(b);
                worst = worst.max(d.norm());
            }
        }
    }
    worst
}

#[test]
fn a_sag_free_groom_holds_still_under_gravity_and_the_same_groom_without_it_sags() {
    let dir = scratch("sag");
    // curly and wavy strands on the back of a still head, gravity, dt = 1/30 s, 1 s
    let groom = |preset: &str, seed: u64, sag_free: bool| {
        format!(
            r#"
[[grooms]]
name = "{preset}"
body = "head"
count = 6
axis = [-1.0, 0.0, 0.2]
max_angle_deg = 45.0
comb = [0.0, 0.0, -1.0]
tilt_deg = 30.0
preset = "{preset}"
length = 0.15
elements = {n}
curvature_variation = 0.2
length_variation = 0.2
seed = {seed}
sag_free = {sag_free}
"#,
            n = if preset == "curly" { 8 } else { 5 },
        )
    };
    let scene = |sag_free: bool| {
        format!(
            "[simulation]\ndt = 0.03333333333333333\nduration = 1.0\n{HEAD}{}{}",
            groom("curly", 1, sag_free),
            groom("wavy", 2, sag_free)
        )
    };
    let (setup, reports) = parse_scene_reporting(&scene(true), &dir).expect("valid");
    for r in &reports {
        println!("{r}");
    }
    assert_eq!(setup.strands.len(), 12);
    let held = max_motion(setup, 30);
    let sagging = max_motion(setup_in(&scene(false), &dir), 30);
    // the same with the strands touching the head (contacts with Coulomb friction): the
    // groom leaves the scalp at its tilt and no contact sample is within the contact
    // radius at rest, so the contacts carry nothing and the groom still holds; the
    // control sags onto the head and is held by it
    let contacts = "\n[contacts]\nradius = 0.002\nfriction = \"coulomb\"\n";
    let held_contacts = max_motion(setup_in(&format!("{}{contacts}", scene(true)), &dir), 30);
    let sagging_contacts = max_motion(setup_in(&format!("{}{contacts}", scene(false)), &dir), 30);
    println!(
        "largest motion of a centreline point in the first second: sag-free {:.3e} m, without {:.3e} m; with contacts {:.3e} m, without sag-free {:.3e} m",
        held, sagging, held_contacts, sagging_contacts
    );
    // measured 5.4e-17 m and 4.2e-17 m: round-off on coordinates of a few decimetres
    // (ε · 0.3 m ≈ 7e-17); the bound is a hundred times that
    assert!(held < 1e-14, "sag-free groom moved {held} m");
    assert!(sagging > 1e-2, "the control sagged only {sagging} m");
    assert!(
        held_contacts < 1e-14,
        "sag-free groom with contacts moved {held_contacts} m"
    );
    assert!(
        sagging_contacts > 1e-2,
        "the control with contacts sagged only {sagging_contacts} m"
    );
}

#[test]
fn groom_problems_name_their_field_and_range() {
    let dir = scratch("problems");
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 0 0 -0.1\nl 1 5\n").expect("write");
    std::fs::write(dir.join("bad.usda"), "#usda 1.0\ndef BasisCurves \"c\" {\n int[] curveVertexCounts = [2]\n point3f[] points = [(0, 0, 0), (0, 0, oops)]\n}\n").expect("write");
    let world =
        "[[bodies]]\nname = \"floor\"\nshape = \"sphere\"\nradius = 1.0\nattached = \"world\"\n\
                 [[bodies]]\nname = \"ground\"\nshape = \"plane\"\nnormal = [0.0, 0.0, 1.0]\n";
    let cases: Vec<(String, &str, &str)> = vec![
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\nlength = 0.1\n"), "grooms[0].count", "required: count (roots) or density"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\ndensity = 10.0\nlength = 0.1\n"), "grooms[0].count", "either count or density"),
        (format!("{HEAD}[[grooms]]\nbody = \"nose\"\ncount = 3\nlength = 0.1\n"), "grooms[0].body", "no body named 'nose'"),
        (format!("{world}[[grooms]]\nbody = \"floor\"\ncount = 3\nlength = 0.1\n"), "grooms[0].body", "attached = \"head\""),
        (format!("{world}[[grooms]]\nbody = \"ground\"\ncount = 3\nlength = 0.1\nattached = 1\n"), "grooms[0].attached", "unknown field"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\ntilt_deg = 90.0\n"), "grooms[0].tilt_deg", "must be in [0, 90)"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\nmax_angle_deg = 0.0\n"), "grooms[0].max_angle_deg", "must be in (0, 180]"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\nlength_variation = 1.0\n"), "grooms[0].length_variation", "must be in [0, 1)"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 0\nlength = 0.1\n"), "grooms[0].count", ">= 1"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ndensity = -1.0\nlength = 0.1\n"), "grooms[0].density", "must be in (0, 1000000000]"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\ndirection = [0.0, 0.0, 1.0]\n"), "grooms[0].direction", "comb and tilt_deg"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\nsag_free = \"yes\"\n"), "grooms[0].sag_free", "expected true or false"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\ncut_point = [0.0, 0.0, 0.0]\n"), "grooms[0].cut_point", "needs cut_normal"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\nmax_angle_deg = 10.0\naxis = [0.0, 0.0, 1.0]\ncut_normal = [0.0, 0.0, -1.0]\n"), "grooms[0].max_angle_deg", "contains no part"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncount = 3\nlength = 0.1\nscale = 2.0\n"), "grooms[0].scale", "not taken by a groom with body"),
        (format!("{HEAD}[[grooms]]\nbody = \"head\"\ncurves = \"x.obj\"\n"), "grooms[0].curves", "not both"),
        ("[[grooms]]\nlength = 0.1\n".to_string(), "grooms[0].body", "required"),
        ("[[grooms]]\ncurves = \"missing.obj\"\n".to_string(), "grooms[0].curves", "cannot read"),
        ("[[grooms]]\ncurves = \"bad.obj\"\n".to_string(), "grooms[0].curves", "bad.obj' line 3: vertex index 5 is out of range"),
        ("[[grooms]]\ncurves = \"bad.usda\"\n".to_string(), "grooms[0].curves", "bad.usda' line 4: 'oops' is not a finite number"),
        ("[[grooms]]\ncurves = \"bad.txt\"\n".to_string(), "grooms[0].curves", ".obj (polylines) or .usda"),
        ("[[grooms]]\ncurves = \"bad.obj\"\nlength = 0.2\n".to_string(), "grooms[0].length", "not taken by a groom with curves"),
        ("[[grooms]]\ncurves = \"bad.obj\"\ncount = 2\n".to_string(), "grooms[0].count", "not taken by a groom with curves"),
        ("[[grooms]]\ncurves = \"bad.obj\"\nmax_fit_error = 0.0\n".to_string(), "grooms[0].max_fit_error", "must be in (0, 1]"),
    ];
    // an entry of neither or both kinds still has its fields checked, not called unknown
    for text in [
        "[[grooms]]\ncount = 3\nlength = 0.1\npreset = \"curly\"\n".to_string(),
        format!("{HEAD}[[grooms]]\nbody = \"head\"\ncurves = \"x.obj\"\ncount = 3\nlength = 0.1\n"),
    ] {
        let found = problems(&text, &dir);
        assert!(!found.contains("unknown field"), "{found}");
    }
    for (text, field, what) in cases {
        let found = problems(&text, &dir);
        assert!(
            found
                .lines()
                .any(|l| l.starts_with(&format!("{field}: ")) && l.contains(what)),
            "expected '{field}: ...{what}...' in:\n{found}\nfor\n{text}"
        );
    }
}

#[test]
fn a_bound_on_the_fit_error_refuses_curves_that_miss_it() {
    let dir = scratch("bound");
    // a zigzag no smooth strand follows closely
    let mut obj = String::new();
    for k in 0..21 {
        let x = if k % 2 == 0 { 0.0 } else { 0.004 };
        obj += &format!("v {x} 0 {}\n", -0.01 * k as f64);
    }
    obj += "l";
    for k in 1..=21 {
        obj += &format!(" {k}");
    }
    obj += "\n";
    std::fs::write(dir.join("zigzag.obj"), obj).expect("write");
    let text = "[[grooms]]\ncurves = \"zigzag.obj\"\nelements = 3\nmax_fit_error = 0.001\n";
    let found = problems(text, &dir);
    assert!(
        found.contains("grooms[0].max_fit_error: 'zigzag.obj' line")
            || found.contains("zigzag.obj"),
        "{found}"
    );
    let loose = setup_in(&text.replace("0.001", "0.5"), &dir);
    assert_eq!(loose.strands.len(), 1);
}

/// `scenes/<name>` of the repository.
fn scene_file(name: &str) -> (String, PathBuf) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    (text, dir)
}

#[test]
fn the_example_groom_scenes_are_valid() {
    for name in ["groom-curly.toml", "imported-curves.toml"] {
        let (text, dir) = scene_file(name);
        let (setup, reports) = match parse_scene_reporting(&text, &dir) {
            Ok(r) => r,
            Err(e) => panic!("{name}: {e}"),
        };
        for r in &reports {
            println!("{name}: {r}");
        }
        // what `superhelix validate` builds before the first step
        let mut sim = Simulation::new(setup.clone(), Some(kernel_factory())).expect("builds");
        sim.step().expect("first step");
        if name == "imported-curves.toml" {
            assert_eq!(setup.strands.len(), 12);
            // the file's points are rounded to 0.01 mm and its curls widen along the
            // hair: 10 elements follow them within 0.05 % of the length (measured: RMS
            // 5.9e-5, max 1.2e-4)
            let (rms, max, _) = reports[0].worst_fit().expect("curves");
            assert!(rms < 2e-4 && max < 5e-4, "{}", reports[0]);
        } else {
            assert_eq!(setup.strands.len(), 100);
        }
        // with the head still, the sag-free strands hold their shape
        let still: String = text
            .lines()
            .filter(|l| *l != "[head]" && !l.starts_with("motion = "))
            .map(|l| format!("{l}\n"))
            .collect();
        let moved = max_motion(setup_in(&still, &dir), 30);
        println!("{name}, head still: the largest motion in 1 s is {moved:.2e} m");
        // measured 8.5e-17 and 5.0e-17 m: round-off (see above)
        assert!(moved < 1e-14, "{name}: {moved} m");
    }
}

/// A straight horizontal 10 cm strand groomed from a curve (clamped at its root, the
/// origin, along +x), its tip resting on a horizontal cylinder along y (radius 1 cm,
/// contact radius 0.1 mm, the tip 1 µm inside it: in contact, with no more penalty at
/// rest than the micrometre gives), frictionless.
fn propped_groom(dir: &Path, sag_free: bool) -> String {
    let length = 0.1;
    let obj = dir.join("straight.obj");
    let points: String = (0..=10)
        .map(|i| format!("v {} 0 0\n", length * i as f64 / 10.0))
        .collect();
    let line: String = (1..=11).map(|i| format!(" {i}")).collect();
    std::fs::write(&obj, format!("{points}l{line}\n")).expect("curve file");
    let (radius, contact) = (0.01, 1e-4);
    format!(
        r#"
[simulation]
dt = 0.03333333333333333
duration = 1.0
[[bodies]]
name = "cylinder"
shape = "capsule"
attached = "world"
start = [{length}, -1.0, {z}]
end = [{length}, 1.0, {z}]
radius = {radius}
[contacts]
radius = {contact}
stiffness = 1e6
friction = "none"
samples_per_element = 32
[[grooms]]
name = "propped"
curves = "straight.obj"
preset = "smooth"
elements = 20
comb = [0.0, 0.0, 1.0]
sag_free = {sag_free}
"#,
        z = -radius - contact + 1e-6
    )
}

#[test]
fn a_sag_free_groom_resting_on_a_body_lets_it_carry_the_beam_theory_share_and_holds() {
    let dir = scratch("propped");
    let (setup, reports) = parse_scene_reporting(&propped_groom(&dir, true), &dir).expect("valid");
    let report = format!("{}", reports[0]);
    println!("{report}");
    // the least elastic change the support allows is the propped cantilever's: the
    // support carries 3wL/8 of the weight wL (Menabrea: the redundant reaction minimizes
    // the complementary energy), within the discretization (N = 20 elements of constant
    // curvature) and the spread of the support over the samples in contact
    let carried = reports[0]
        .sag_free_carried
        .expect("contacts: a share is reported");
    assert!(
        (carried - 0.375).abs() < 0.005,
        "the cylinder carries {carried:.4} of the weight (beam theory: 0.375)"
    );
    let held = max_motion(setup, 30);
    let sagging = max_motion(setup_in(&propped_groom(&dir, false), &dir), 30);
    println!(
        "carried {carried:.4} of the weight; largest motion in the first second: sag-free {held:.3e} m, without {sagging:.3e} m"
    );
    assert!(
        held < 1e-5,
        "the sag-free groom on its support moved {held} m"
    );
    assert!(
        sagging > 1e-3,
        "the control (not sag-free) sagged only {sagging} m onto the support"
    );
}

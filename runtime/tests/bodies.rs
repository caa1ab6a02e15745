//! The bodies of a scene through the whole path: `[[bodies]]` read with the scene's
//! folder, built by `Simulation::new` (either engine), queried at the simulation's head
//! state as it moves; mesh problems reported by the scene check with their field.

use nalgebra::Vector3;
use superhelix_runtime::{parse_scene_at, validate_scene_at, HeadMotion, Simulation};

/// An octahedron of half-diagonal 0.1 about the origin, as OBJ text.
const OCTAHEDRON: &str = "v 0.1 0 0\nv -0.1 0 0\nv 0 0.1 0\nv 0 -0.1 0\nv 0 0 0.1\nv 0 0 -0.1\n\
f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n";

fn scene(engine: &str) -> String {
    format!(
        r#"
[simulation]
dt = 0.01
duration = 0.05
engine = "{engine}"
[head]
motion = {{ kind = "oscillate", axis = [0.0, 1.0, 0.0], angle_deg = 40.0, frequency_hz = 3.0, center = [0.0, 0.0, -0.1] }}
[[strands]]
root = [0.0, 0.0, 0.1]
length = 0.2
elements = 5
[[bodies]]
name = "scalp"
shape = "sphere"
center = [0.0, 0.0, 0.02]
radius = 0.08
[[bodies]]
name = "floor"
shape = "plane"
point = [0.0, 0.0, -1.0]
normal = [0.0, 0.0, 1.0]
attached = "world"
[[bodies]]
name = "face"
shape = "mesh"
path = "meshes/octahedron.obj"
cell = 0.005
"#
    )
}

fn folder(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "superhelix-bodies-scene-{}-{name}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("meshes")).unwrap_or_else(|e| panic!("{e}"));
    dir
}

#[test]
fn bodies_on_the_head_follow_the_simulated_head_and_the_floor_stays() {
    let dir = folder("follow");
    std::fs::write(dir.join("meshes/octahedron.obj"), OCTAHEDRON).unwrap_or_else(|e| panic!("{e}"));
    for engine in ["runtime", "embedded"] {
        let setup = parse_scene_at(&scene(engine), &dir).unwrap_or_else(|e| panic!("{e}"));
        let motion: HeadMotion = setup.head.clone();
        let mut sim = Simulation::new(setup, None).unwrap_or_else(|e| panic!("{engine}: {e}"));
        assert_eq!(sim.bodies().bodies().len(), 3);
        let x = Vector3::new(0.12, 0.03, 0.05);
        let mut distances = Vec::new();
        for _ in 0..4 {
            sim.step().unwrap_or_else(|e| panic!("{e}"));
            let head = motion.state(sim.time());
            let bodies = sim.bodies();
            let y = head.rotation.transpose() * (x - head.position);
            let scalp = bodies.query(0, &x).distance;
            assert!((scalp - ((y - Vector3::new(0.0, 0.0, 0.02)).norm() - 0.08)).abs() < 1e-15);
            assert_eq!(bodies.query(1, &x).distance, x.z + 1.0);
            // the mesh answers for the point carried into head coordinates
            let face = bodies.query(2, &x);
            let local = bodies.bodies()[2].query(&Default::default(), &y);
            assert!((face.distance - local.distance).abs() < 1e-15);
            assert!((face.closest - head.to_world(&local.closest)).norm() < 1e-15);
            distances.push(scalp);
        }
        assert!(
            (distances[0] - distances[3]).abs() > 1e-3,
            "the head moved: {distances:?}"
        );
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_missing_or_open_mesh_is_reported_on_its_path_by_the_scene_check() {
    let dir = folder("broken");
    let problems = validate_scene_at(&scene("runtime"), &dir, None);
    assert!(
        problems
            .iter()
            .any(|p| p.field == "bodies[2].path" && p.message.contains("cannot read")),
        "{problems:?}"
    );
    let open: String = OCTAHEDRON
        .lines()
        .take(13)
        .map(|l| format!("{l}\n"))
        .collect();
    std::fs::write(dir.join("meshes/octahedron.obj"), open).unwrap_or_else(|e| panic!("{e}"));
    let problems = validate_scene_at(&scene("runtime"), &dir, None);
    assert!(
        problems
            .iter()
            .any(|p| p.field == "bodies[2].path" && p.message.contains("open")),
        "{problems:?}"
    );
    let _ = std::fs::remove_dir_all(dir);
}

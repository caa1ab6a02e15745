//! A short simulation streamed into `frames.npy`, for the tests of the written files.

use std::path::{Path, PathBuf};
use superhelix::runtime::output::frames::{FrameLayout, FrameSink, FrameView, StrandInfo};
use superhelix::runtime::output::npy::NpyFrameSink;

/// Two patches ("front": 2 strands, "back": 1) and a single strand ("solo"), 0.2 s at 30 fps.
pub const SCENE: &str = r#"
[simulation]
dt = 0.03333333333333333
duration = 0.2
output_fps = 30

[output]
samples_per_element = 3

[[strands]]
name = "solo"
length = 0.15
elements = 3
direction = [0.0, 1.0, -1.0]

[[patches]]
name = "front"
preset = "curly"
center = [0.05, 0.0, 0.0]
direction = [1.0, 0.0, -1.0]
normal = [0.0, 1.0, 0.0]
count = [2, 1]
size = [0.02, 0.0]
length = 0.2
elements = 4

[[patches]]
name = "back"
center = [-0.05, 0.0, 0.0]
direction = [-1.0, 0.0, -1.0]
normal = [0.0, -1.0, 0.0]
count = [1, 1]
size = [0.0, 0.0]
length = 0.1
elements = 2
"#;

/// A fresh scratch directory.
pub fn scratch(name: &str) -> PathBuf {
    let dir =
        std::env::temp_dir().join(format!("superhelix-writers-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    dir
}

/// Group of a strand of this scene: patch strands are named `<patch>_<i>_<j>`.
fn group_of(name: &str) -> String {
    let parts: Vec<&str> = name.rsplitn(3, '_').collect();
    if parts.len() == 3 && parts[..2].iter().all(|p| p.parse::<usize>().is_ok()) {
        parts[2].to_string()
    } else {
        name.to_string()
    }
}

/// Simulate `scene`, writing every frame (the state nearest to `k / output_fps`) to
/// `dir/frames.npy`; returns the layout.
pub fn simulate_to_npy(scene: &str, dir: &Path) -> FrameLayout {
    let setup = superhelix::parse_scene(scene).unwrap_or_else(|e| panic!("{e}"));
    let spe = setup.samples_per_element;
    let mut sim = superhelix::open_simulation(setup.clone()).unwrap_or_else(|e| panic!("{e}"));
    let frames = (setup.config.duration * setup.config.output_fps + 1e-9).floor() as usize + 1;
    let layout = FrameLayout {
        strands: setup
            .strands
            .iter()
            .map(|s| StrandInfo {
                name: s.strand.name.clone(),
                group: group_of(&s.strand.name),
                radius: 5e-5,
                points: 1 + spe * s.strand.geometry.lengths.len(),
                coordinates: s.q0.len(),
            })
            .collect(),
        output_fps: setup.config.output_fps,
        planned_frames: frames,
    };
    let mut sink = NpyFrameSink::create(dir, &layout).unwrap_or_else(|e| panic!("{e}"));
    let dt = setup.config.dt;
    for k in 0..frames {
        let t = k as f64 / setup.config.output_fps;
        while sim.time() + 0.5 * dt < t {
            sim.step().unwrap_or_else(|e| panic!("{e}"));
        }
        let mut points = Vec::new();
        let mut q = Vec::new();
        for i in 0..sim.strand_count() {
            points.extend(sim.centreline_world(i, spe));
            q.extend_from_slice(sim.q(i));
        }
        let view = FrameView {
            index: k,
            time: t,
            state_time: sim.time(),
            points: &points,
            q: &q,
        };
        sink.write_frame(&view).unwrap_or_else(|e| panic!("{e}"));
    }
    sink.finish().unwrap_or_else(|e| panic!("{e}"));
    layout
}

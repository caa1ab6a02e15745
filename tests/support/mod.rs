//! What the integration tests share: running the `superhelix` binary, scratch
//! directories and files, and a short simulation streamed into `frames.npy`.
// Each test crate compiles this module and uses a part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::AtomicBool;
use superhelix::runtime::output::frames::FrameLayout;
use superhelix::runtime::output::npy::NpyFrameSink;
use superhelix::runtime::output::{frame_layout, run_streaming, StopReason};

/// A scene of a patch "p" of 4 × 4 wavy strands (N = 6, 20 cm) on a head rocking about
/// y by ±30° at 1.5 Hz, next to a ball: `simulation` goes into `[simulation]`, `sections`
/// (contacts, output) between the ball and the patch.
pub fn rocking_patch(simulation: &str, sections: &str) -> String {
    format!(
        r#"
[simulation]
{simulation}
[head]
motion = {{ kind = "oscillate", axis = [0.0, 1.0, 0.0], angle_deg = 30.0, frequency_hz = 1.5 }}
[[bodies]]
name = "ball"
shape = "sphere"
center = [0.06, 0.0, -0.1]
radius = 0.04
{sections}
[[patches]]
name = "p"
count = [4, 4]
size = [0.03, 0.03]
length = 0.2
elements = 6
preset = "wavy"
"#
    )
}

/// The files of `dir` a run writes its results to (not the pictures: their encoder's
/// bytes are not the simulation's), sorted.
pub fn results(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.flatten().map(|e| e.path()).collect())
        .unwrap_or_default();
    files.retain(|p| {
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
        name.starts_with("frames") || name.ends_with(".usda") || name.ends_with(".obj")
    });
    files.sort();
    files
}

/// 20 charged curly strands (N = 5, 20 cm; 8000 particles at 2000 per metre, enough for
/// the multipole method) for `duration` seconds: `electrostatics` goes into
/// `[electrostatics]`, `sections` before the patch.
pub fn charged_tress(duration: f64, electrostatics: &str, sections: &str) -> String {
    format!(
        r#"
[simulation]
duration = {duration}
[electrostatics]
method = "fmm"
particle_density = 2000
charge_per_length = -1e-9
{electrostatics}
{sections}
[[patches]]
name = "tress"
count = [5, 4]
size = [0.01, 0.008]
length = 0.2
elements = 5
preset = "curly"
"#
    )
}

/// Contacts with the bodies and between the strands, both with Coulomb friction.
pub const FRICTION_CONTACTS: &str = r#"
[contacts]
friction = "coulomb"
friction_coefficient = 0.3
[contacts.hair_hair]
radius = 0.002
friction = "coulomb"
friction_coefficient = 0.2
"#;

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

/// Run the `superhelix` binary with `args`.
pub fn superhelix(args: &[&str]) -> Output {
    match Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args(args)
        .output()
    {
        Ok(out) => out,
        Err(e) => panic!("cannot start superhelix: {e}"),
    }
}

/// Standard output of a finished command.
pub fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Standard error of a finished command.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Standard output then standard error.
pub fn text(out: &Output) -> String {
    format!("{}{}", stdout(out), stderr(out))
}

/// A fresh scratch directory for one test (named by the test binary's process).
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    dir
}

/// Write `contents` to `dir/name`; returns the path.
pub fn write(dir: &Path, name: &str, contents: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, contents).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    path
}

/// Run `scene` through the run driver with only the `frames.npy` sink into `dir`;
/// returns the layout.
pub fn simulate_to_npy(scene: &str, dir: &Path) -> FrameLayout {
    let setup = superhelix::parse_scene(scene).unwrap_or_else(|e| panic!("{e}"));
    let spe = setup.samples_per_element;
    let mut sim = superhelix::open_simulation(setup.clone()).unwrap_or_else(|e| panic!("{e}"));
    let layout = frame_layout(sim.as_ref(), &setup.config, spe);
    let mut sink = NpyFrameSink::create(dir, &layout).unwrap_or_else(|e| panic!("{e}"));
    let stop = AtomicBool::new(false);
    let outcome = run_streaming(
        sim.as_mut(),
        &setup.config,
        spe,
        &mut [&mut sink],
        &stop,
        |_, _| {},
    );
    assert!(
        matches!(outcome.stop, StopReason::Completed),
        "{:?}",
        outcome.stop
    );
    layout
}

//! Checkpoints and `run --resume` (docs/output.md, "Checkpoints and resume"): for every
//! scene kind (contacts and hair–hair contact with friction, both engines, error-controlled
//! steps, a two-step integrator, static electricity between two updates, render strands, a driven
//! held tip with nodes), a run that goes on from a checkpoint writes the same bytes as
//! one that never stopped, on another thread count too; a checkpoint does not change what
//! a run writes; a checkpoint of another scene, a damaged one and frame files shorter than
//! it says are refused, naming what is wrong.

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use support::{charged_tress, results, rocking_patch, scratch, write, FRICTION_CONTACTS};

/// The rocking patch of 16 frames on `engine`, with `extra` in `[simulation]` and
/// `contacts`, a checkpoint every 10 frames.
fn hair(engine: &str, extra: &str, contacts: &str) -> String {
    rocking_patch(
        &format!("duration = 0.5\nengine = \"{engine}\"\n{extra}"),
        &format!("{contacts}\n[output]\ncheckpoint_every = 10\n"),
    )
}

/// 20 charged strands (8000 particles, the multipole method), the forces refreshed every
/// 4 steps: the checkpoint (after step 6) falls between two refreshes.
fn charged() -> String {
    charged_tress(0.4, "update_every = 4", "[output]\ncheckpoint_every = 7")
}

fn command(args: &[&str], threads: usize) -> Output {
    command_with(args, threads, None)
}

/// `command` with one environment variable set (a test hook of
/// `superhelix_runtime::output::test_hooks`).
fn command_with(args: &[&str], threads: usize, env: Option<(&str, &str)>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_superhelix"));
    c.args(args).env("RAYON_NUM_THREADS", threads.to_string());
    if let Some((k, v)) = env {
        c.env(k, v);
    }
    c.output()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"))
}

/// The frame `said` says a resumed run goes on from.
fn resumed_at(said: &str) -> Option<usize> {
    said.split("resuming from the checkpoint at frame ")
        .nth(1)?
        .split(' ')
        .next()?
        .parse()
        .ok()
}

/// Run `scene` into `out` on 2 threads with the test hook `hook` set, which must stop
/// it (as a kill would) with a checkpoint on disk; then resume it to the end on 1
/// thread. Returns the frame the resumed run said it went on from.
fn stop_and_resume(
    name: &str,
    scene: &str,
    formats: &str,
    out: &Path,
    hook: (&str, &str),
) -> usize {
    let o = command_with(
        &[
            "run",
            scene,
            "--out",
            &out.to_string_lossy(),
            "--format",
            formats,
        ],
        2,
        Some(hook),
    );
    assert!(
        !o.status.success(),
        "{name}: the run was not stopped by {hook:?} (the scene is too short for it):\n{}",
        support::text(&o)
    );
    assert!(
        out.join("checkpoint.bin").exists(),
        "{name}: stopped by {hook:?} without a checkpoint"
    );
    let said = succeed(
        &[
            "run",
            scene,
            "--resume",
            &out.to_string_lossy(),
            "--format",
            formats,
        ],
        1,
    );
    resumed_at(&said).unwrap_or_else(|| panic!("{name}: the run did not resume:\n{said}"))
}

/// `checkpoint_every` of `scene`.
fn checkpoint_every(scene: &str) -> usize {
    scene
        .split("checkpoint_every = ")
        .nth(1)
        .and_then(|s| s.split(|c: char| !c.is_ascii_digit()).next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no checkpoint_every in the scene"))
}

fn succeed(args: &[&str], threads: usize) -> String {
    let o = command(args, threads);
    let text = support::text(&o);
    assert!(o.status.success(), "superhelix {args:?}:\n{text}");
    text
}

fn same_files(name: &str, a: &Path, b: &Path) {
    let files = results(a);
    assert!(files.len() >= 2, "{name}: {files:?}");
    let names = |d: &Path| -> Vec<_> {
        results(d)
            .iter()
            .map(|p| p.file_name().map(|n| n.to_owned()))
            .collect()
    };
    assert_eq!(names(a), names(b), "{name}: the files differ");
    for f in files {
        let file = f.file_name().unwrap_or_default();
        let x = std::fs::read(&f).unwrap_or_default();
        let y = std::fs::read(b.join(file)).unwrap_or_default();
        assert!(!x.is_empty(), "{name}: {} is empty", f.display());
        assert!(
            x == y,
            "{name}: {} differs between {} and {}",
            file.to_string_lossy(),
            a.display(),
            b.display()
        );
    }
}

/// Run `scene` to the end on 2 threads (its checkpoints on); run it again, stopped by an
/// abort two frames after its first checkpoint (the frames after the checkpoint partly
/// on disk, as a kill leaves them), and go on from the checkpoint on 1 thread: both
/// write the same bytes; and a run without checkpoints writes the same frames. Returns
/// the scene's folder.
fn resumed_equals_uninterrupted(name: &str, scene: &str, formats: &str) -> PathBuf {
    let dir = scratch(&format!("checkpoint-{name}"));
    let path = write(&dir, "scene.toml", scene);
    let path = path.to_string_lossy();
    let (whole, resumed, plain) = (dir.join("whole"), dir.join("resumed"), dir.join("plain"));
    let out = |d: &Path| d.to_string_lossy().into_owned();
    succeed(
        &["run", &path, "--out", &out(&whole), "--format", formats],
        2,
    );
    assert!(
        whole.join("checkpoint.bin").exists(),
        "{name}: no checkpoint written"
    );
    let stop = (checkpoint_every(scene) + 3).to_string();
    let from = stop_and_resume(
        name,
        &path,
        formats,
        &resumed,
        ("SUPERHELIX_TEST_ABORT_AFTER_FRAMES", &stop),
    );
    assert!(
        from > 0 && from < checkpoint_every(scene) + 3,
        "{name}: resumed at frame {from}"
    );
    same_files(name, &whole, &resumed);
    // a checkpoint changes nothing a run writes
    let without = scene.replace("checkpoint_every = ", "checkpoint_every = 0 # ");
    let plain_scene = write(&dir, "plain.toml", &without);
    succeed(
        &[
            "run",
            &plain_scene.to_string_lossy(),
            "--out",
            &out(&plain),
            "--format",
            formats,
        ],
        2,
    );
    assert!(
        !plain.join("checkpoint.bin").exists(),
        "{name}: checkpoint_every = 0 wrote one"
    );
    same_files(name, &whole, &plain);
    dir
}

#[test]
fn contacts_and_hair_hair_with_friction_resume_bit_for_bit() {
    let scene = hair("runtime", "", FRICTION_CONTACTS);
    resumed_equals_uninterrupted("contacts", &scene, "json,npy,usda,obj");
}

/// A rope held against a drum by Coulomb friction (scenes/rod-capstan.toml, its first
/// 0.1 s): the friction anchors on the drum are held across the checkpoint.
#[test]
fn body_friction_anchors_resume_bit_for_bit() {
    let root = env!("CARGO_MANIFEST_DIR");
    let scene = std::fs::read_to_string(format!("{root}/scenes/rod-capstan.toml"))
        .expect("scenes/rod-capstan.toml")
        .replace("duration = 0.5", "duration = 0.1")
        .replace("[output]\n", "[output]\ncheckpoint_every = 4\n");
    resumed_equals_uninterrupted("capstan", &scene, "json,npy");
}

#[test]
fn both_engines_resume_bit_for_bit_with_fixed_and_error_controlled_steps() {
    for engine in ["embedded", "runtime"] {
        let fixed = hair(engine, "", "");
        resumed_equals_uninterrupted(&format!("{engine}-fixed"), &fixed, "json,npy");
        let tolerance = hair(engine, "tolerance = 1e-4", "");
        resumed_equals_uninterrupted(&format!("{engine}-tolerance"), &tolerance, "npy");
    }
}

/// A stop between the writing of a checkpoint's temporary file and its rename (the
/// second checkpoint: the first is on disk, the second's `checkpoint.bin.tmp` beside it)
/// leaves a run that resumes from the first and ends with the bytes of one never
/// stopped.
#[test]
fn a_stop_before_the_checkpoint_rename_resumes_from_the_one_before() {
    let scene = hair("embedded", "", "").replace("checkpoint_every = 10", "checkpoint_every = 5");
    let dir = scratch("checkpoint-rename");
    let path = write(&dir, "scene.toml", &scene);
    let path = path.to_string_lossy();
    let (whole, stopped) = (dir.join("whole"), dir.join("stopped"));
    succeed(
        &[
            "run",
            &path,
            "--out",
            &whole.to_string_lossy(),
            "--format",
            "json,npy",
        ],
        2,
    );
    let from = stop_and_resume(
        "rename",
        &path,
        "json,npy",
        &stopped,
        ("SUPERHELIX_TEST_ABORT_BEFORE_RENAME", "checkpoint.bin:2"),
    );
    // the first checkpoint's frame, not the second's (10)
    assert_eq!(from, 5);
    same_files("rename", &whole, &stopped);
}

#[test]
fn the_two_step_integrator_resumes_with_its_history() {
    let scene = hair("runtime", "integrator = \"bdf2\"", "");
    resumed_equals_uninterrupted("bdf2", &scene, "npy");
}

#[test]
fn static_electricity_resumes_between_two_updates() {
    resumed_equals_uninterrupted("charged", &charged(), "json,npy");
}

/// Under a tolerance the forces keep their own schedule (the time of the last update, the
/// particles' positions and the head's frame then, how fast they moved): a resumed run
/// takes it up where the checkpoint left it.
#[test]
fn static_electricity_under_a_tolerance_resumes_on_its_schedule() {
    let scene = charged().replace("[simulation]\n", "[simulation]\ntolerance = 1e-2\n");
    assert!(scene.contains("tolerance"));
    resumed_equals_uninterrupted("charged-tolerance", &scene, "json,npy");
}

#[test]
fn render_strands_and_a_driven_held_tip_with_nodes_resume_bit_for_bit() {
    let root = env!("CARGO_MANIFEST_DIR");
    let nape = std::fs::read_to_string(format!("{root}/scenes/render-nape.toml"))
        .expect("scenes/render-nape.toml")
        .replace("\"data/", &format!("\"{root}/scenes/data/"))
        .replace("duration = 2.0", "duration = 0.6");
    let nape = format!("{nape}\n[output]\ncheckpoint_every = 11\n");
    resumed_equals_uninterrupted("render", &nape, "npy,usda");
    let rod = std::fs::read_to_string(format!("{root}/scenes/rod-driven.toml"))
        .expect("scenes/rod-driven.toml")
        .replace("duration = 2.0", "duration = 0.5")
        .replace("[output]\n", "[output]\ncheckpoint_every = 9\nnodes = 12\n");
    let dir = resumed_equals_uninterrupted("held", &rod, "json,npy");
    for file in ["frames.held.npy", "frames.nodes.npy", "frames.d1.npy"] {
        assert!(dir.join("resumed").join(file).exists(), "{file}");
    }
}

#[test]
fn a_checkpoint_of_another_scene_a_damaged_one_or_short_frames_are_refused_by_name() {
    let scene = hair("embedded", "", "");
    let dir = scratch("checkpoint-refusals");
    let path = write(&dir, "scene.toml", &scene);
    let out = dir.join("out");
    let (path, outs) = (path.to_string_lossy(), out.to_string_lossy());
    succeed(&["run", &path, "--out", &outs, "--format", "npy"], 2);
    let refused = |scene: &str, expect: &[&str]| {
        let o = command(&["run", scene, "--resume", &outs, "--format", "npy"], 2);
        let text = support::text(&o);
        assert!(!o.status.success(), "{text}");
        for e in expect {
            assert!(text.contains(e), "expected {e:?} in:\n{text}");
        }
    };
    // another scene: the first key that differs is named
    let other = write(
        &dir,
        "other.toml",
        &scene.replace("duration = 0.5", "duration = 0.6"),
    );
    refused(
        &other.to_string_lossy(),
        &[
            "--resume",
            "simulation.duration: 0.5 in the checkpoint, 0.6 in the scene",
        ],
    );
    // other formats
    let o = command(&["run", &path, "--resume", &outs, "--format", "json"], 2);
    assert!(
        support::text(&o).contains("the formats: npy in the checkpoint, json now"),
        "{}",
        support::text(&o)
    );
    // frames cut shorter than the checkpoint says
    let npy = out.join("frames.npy");
    let bytes = std::fs::read(&npy).unwrap_or_default();
    let kept = bytes.clone();
    std::fs::write(&npy, &bytes[..bytes.len() / 4]).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &path,
        &[
            "frames.npy",
            "does not hold the frames its checkpoint names",
        ],
    );
    std::fs::write(&npy, &kept).unwrap_or_else(|e| panic!("{e}"));
    // a damaged checkpoint: one byte changed, then cut short, then not one at all
    let ck = out.join("checkpoint.bin");
    let good = std::fs::read(&ck).unwrap_or_default();
    let mut flipped = good.clone();
    let middle = flipped.len() / 2;
    flipped[middle] ^= 0x40;
    std::fs::write(&ck, &flipped).unwrap_or_else(|e| panic!("{e}"));
    refused(&path, &["checkpoint.bin is damaged", "checksum"]);
    std::fs::write(&ck, &good[..good.len() - 10]).unwrap_or_else(|e| panic!("{e}"));
    refused(&path, &["checkpoint.bin is damaged"]);
    std::fs::write(&ck, b"{\"not\": \"a checkpoint\"}").unwrap_or_else(|e| panic!("{e}"));
    refused(
        &path,
        &["checkpoint.bin is damaged", "not a superhelix checkpoint"],
    );
    // a device in its place (read whole, /dev/zero would fill the memory) or a folder:
    // refused before it is read
    std::fs::remove_file(&ck).unwrap_or_else(|e| panic!("{e}"));
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", &ck).unwrap_or_else(|e| panic!("{e}"));
        refused(&path, &["checkpoint.bin is not a regular file"]);
        std::fs::remove_file(&ck).unwrap_or_else(|e| panic!("{e}"));
    }
    std::fs::create_dir(&ck).unwrap_or_else(|e| panic!("{e}"));
    refused(&path, &["checkpoint.bin is not a regular file"]);
    std::fs::remove_dir(&ck).unwrap_or_else(|e| panic!("{e}"));
    // restored, with a frame file missing or a folder in its place: named, with what to do
    std::fs::write(&ck, &good).unwrap_or_else(|e| panic!("{e}"));
    let npy = out.join("frames.npy");
    let saved = std::fs::read(&npy).unwrap_or_default();
    std::fs::remove_file(&npy).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &path,
        &[
            "frames.npy is missing",
            "copy the run's folder whole",
            "checkpoint.bin to start again",
        ],
    );
    std::fs::create_dir(&npy).unwrap_or_else(|e| panic!("{e}"));
    refused(&path, &["frames.npy is not a file"]);
    std::fs::remove_dir(&npy).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(&npy, &saved).unwrap_or_else(|e| panic!("{e}"));
    // a file given as the folder
    let o = command(&["run", &path, "--resume", &path, "--format", "npy"], 2);
    assert!(
        !o.status.success() && support::text(&o).contains("is a file, not a folder"),
        "{}",
        support::text(&o)
    );
    // restored, it resumes
    succeed(&["run", &path, "--resume", &outs, "--format", "npy"], 2);
    // a run from t = 0 into the folder leaves no earlier checkpoint behind
    let plain = write(
        &dir,
        "plain.toml",
        &scene.replace("checkpoint_every = 10", "checkpoint_every = 0"),
    );
    succeed(
        &[
            "run",
            &plain.to_string_lossy(),
            "--out",
            &outs,
            "--format",
            "npy",
        ],
        2,
    );
    assert!(!ck.exists(), "a stale checkpoint.bin was left");
    // checkpoints without a frame file are refused before the run
    let o = command(&["run", &path, "--out", &outs, "--format", "usda"], 2);
    let text = support::text(&o);
    assert!(
        !o.status.success() && text.contains("output.checkpoint_every"),
        "{text}"
    );
}

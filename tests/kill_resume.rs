//! Durability under SIGKILL: `superhelix run --resume DIR` killed at pseudo-random
//! moments (at least 20 times, a fixed seed) always leaves outputs that numpy, Python's
//! json module and pxr open (`tests/python/check_outputs.py`: frames.npy; frames.json
//! and hair.usda when a run got as far as writing them), and the run resumed to its end
//! then writes the same bytes as a run never killed (docs/output.md, "Checkpoints and
//! resume").

mod support;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::{rocking_patch, scratch, write, FRICTION_CONTACTS};

/// 16 strands on a head rocking about y with contacts and hair–hair friction, 3 s of 91
/// frames, a checkpoint every 3 frames; about a second and a half on 2 threads.
fn scene() -> String {
    rocking_patch(
        "duration = 3.0",
        &format!("{FRICTION_CONTACTS}\n[output]\ncheckpoint_every = 3\n"),
    )
}

const FORMATS: &str = "json,npy,usda";

/// Kills to make.
const KILLS: usize = 20;

/// A small deterministic generator (64-bit LCG, Knuth's MMIX constants): the kill times.
struct Lcg(u64);

impl Lcg {
    /// Uniform in [lo, hi) milliseconds.
    fn millis(&mut self, lo: u64, hi: u64) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        lo + (self.0 >> 33) % (hi - lo)
    }
}

fn run(scene: &str, dir: &Path, resume: bool) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_superhelix"));
    c.arg("run").arg(scene);
    c.arg(if resume { "--resume" } else { "--out" }).arg(dir);
    c.args(["--format", FORMATS]);
    c.stdout(Stdio::null()).stderr(Stdio::null());
    c
}

/// Copy what a reader opens of `from` into `to`.
fn snapshot(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("{}: {e}", to.display()));
    for name in ["frames.npy", "frames.times.npy", "frames.json", "hair.usda"] {
        let file = from.join(name);
        if file.exists() {
            std::fs::copy(&file, to.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
}

/// Every result file of `b` is byte for byte that of `a`.
fn same_results(a: &Path, b: &Path, kills: usize) {
    for name in [
        "frames.npy",
        "frames.times.npy",
        "frames.index.json",
        "frames.json",
        "hair.usda",
    ] {
        let x = std::fs::read(a.join(name)).unwrap_or_default();
        let y = std::fs::read(b.join(name)).unwrap_or_default();
        assert!(!x.is_empty(), "{name} is empty");
        assert!(x == y, "{name} differs after {kills} kills");
    }
}

#[test]
fn a_run_killed_twenty_times_leaves_readable_outputs_and_resumes_to_the_same_bytes() {
    let started = Instant::now();
    let dir = scratch("kill-resume");
    let scene = write(&dir, "scene.toml", &scene());
    let scene = scene.to_string_lossy();
    let whole = dir.join("whole");
    let status = run(&scene, &whole, false)
        .status()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    assert!(status.success());
    let whole_run = started.elapsed().as_secs_f64();
    let killed = dir.join("killed");
    let mut rng = Lcg(0x5eed_2026);
    let mut snapshots: Vec<PathBuf> = Vec::new();
    let (mut kills, mut finished) = (0, 0);
    while kills < KILLS {
        let mut child = run(&scene, &killed, true)
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
        std::thread::sleep(Duration::from_millis(rng.millis(20, 450)));
        match child.try_wait() {
            Ok(Some(status)) => {
                // it finished first (after the kills since the last start): the same
                // bytes, then start again from t = 0
                assert!(status.success(), "a resumed run failed: {status}");
                same_results(&whole, &killed, kills);
                finished += 1;
                let _ = std::fs::remove_dir_all(&killed);
            }
            _ => {
                // Child::kill sends SIGKILL
                child.kill().unwrap_or_else(|e| panic!("kill: {e}"));
                let _ = child.wait();
                kills += 1;
                if killed.join("frames.npy").exists() {
                    let to = dir.join(format!("snapshot-{kills:02}"));
                    snapshot(&killed, &to);
                    snapshots.push(to);
                }
            }
        }
    }
    // numpy, json and pxr open what every kill left
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/check_outputs.py");
    let out = Command::new("python3")
        .arg(script)
        .args(&snapshots)
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 ({e}): pip install numpy usd-core"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert_ne!(out.status.code(), Some(2), "the check cannot run:\n{text}");
    assert!(out.status.success(), "{text}");
    assert!(
        snapshots.len() >= KILLS / 2,
        "{} snapshots",
        snapshots.len()
    );
    // resumed to the end, the same bytes as the run never killed
    let status = run(&scene, &killed, true)
        .status()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    assert!(status.success());
    same_results(&whole, &killed, kills);
    println!(
        "{kills} kills ({finished} runs finished first), {} snapshots checked; an \
         uninterrupted run {whole_run:.1} s, the test {:.1} s",
        snapshots.len(),
        started.elapsed().as_secs_f64()
    );
}

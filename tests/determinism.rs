//! The same bits on any thread count: every scene kind (contacts with Coulomb friction,
//! hair–hair contact with friction, static electricity through the multipole method,
//! render strands; the embedded and the runtime engine) run by `superhelix run` with
//! `RAYON_NUM_THREADS=1` and `=2` writes byte-identical files (docs/output.md,
//! "Determinism").

mod support;

use std::path::{Path, PathBuf};
use std::process::Command;
use support::{charged_tress, results, rocking_patch, scratch, write, FRICTION_CONTACTS};

/// 20 charged strands: enough particles (8000) for the multipole method.
fn charged() -> String {
    charged_tress(0.2, "", "")
}

/// `superhelix run scene --out dir --format formats` on `threads` worker threads.
fn run(scene: &str, out: &Path, formats: &str, threads: usize) {
    let o = Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args(["run", scene, "--out"])
        .arg(out)
        .args(["--format", formats])
        .env("RAYON_NUM_THREADS", threads.to_string())
        .output()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    assert!(
        o.status.success(),
        "{scene} on {threads} threads:\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// Run `scene` on 1 and on 2 threads and compare every result file byte for byte;
/// returns the folder of the run on one thread.
fn same_bits(name: &str, scene: &str, formats: &str) -> PathBuf {
    let dir = scratch(&format!("determinism-{name}"));
    let path = write(&dir, "scene.toml", scene);
    let path = path.to_string_lossy();
    let (one, two) = (dir.join("one"), dir.join("two"));
    run(&path, &one, formats, 1);
    run(&path, &two, formats, 2);
    let files = results(&one);
    assert!(files.len() >= 2, "{name}: {files:?}");
    for f in files {
        let file = f.file_name().unwrap_or_default();
        let a = std::fs::read(&f).unwrap_or_default();
        let b = std::fs::read(two.join(file)).unwrap_or_default();
        assert!(!a.is_empty(), "{name}: {} is empty", f.display());
        assert!(
            a == b,
            "{name}: {} differs between 1 and 2 threads",
            file.to_string_lossy()
        );
    }
    one
}

#[test]
fn contacts_and_hair_hair_give_the_same_bits_on_one_and_two_threads() {
    let scene = rocking_patch("duration = 0.5\nengine = \"runtime\"", FRICTION_CONTACTS);
    same_bits("contacts", &scene, "json,npy,usda,obj");
}

/// The points of every frame of a `frames.json`, in order.
fn json_points(dir: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(dir.join("frames.json")).unwrap_or_default();
    let doc: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut out = Vec::new();
    for frame in doc["frames"].as_array().into_iter().flatten() {
        for p in frame["points"].as_array().into_iter().flatten() {
            out.extend(
                p.as_array()
                    .into_iter()
                    .flatten()
                    .filter_map(|x| x.as_f64()),
            );
        }
    }
    out
}

/// Both engines, with fixed steps and with a tolerance (error-controlled steps): each the
/// same bits on one and two threads. The two engines take the same steps and agree to
/// round-off, not to the bit: their f64 points (`frames.json`, printed exactly) differ
/// in the last bits (the runtime assembles some sums in another order), so `frames.npy`'s
/// f32 points are the same bits and the f64 points within 1e-14 m of each other.
#[test]
fn both_engines_give_the_same_bits_on_one_and_two_threads_and_agree_to_round_off() {
    for (kind, extra) in [("fixed", ""), ("tolerance", "\ntolerance = 1e-4")] {
        let runs: Vec<PathBuf> = ["embedded", "runtime"]
            .iter()
            .map(|engine| {
                let scene =
                    rocking_patch(&format!("duration = 0.5\nengine = \"{engine}\"{extra}"), "");
                same_bits(&format!("{engine}-{kind}"), &scene, "json,npy")
            })
            .collect();
        let npy = |dir: &Path| std::fs::read(dir.join("frames.npy")).unwrap_or_default();
        assert!(
            npy(&runs[0]) == npy(&runs[1]),
            "{kind}: the engines' f32 points differ"
        );
        let (a, b) = (json_points(&runs[0]), json_points(&runs[1]));
        assert!(
            !a.is_empty() && a.len() == b.len(),
            "{kind}: {} and {} values",
            a.len(),
            b.len()
        );
        let apart = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        eprintln!("{kind}: the engines' f64 points at most {apart:e} m apart");
        assert!(
            apart <= 1e-14,
            "{kind}: the engines' points {apart:e} m apart"
        );
    }
}

#[test]
fn static_electricity_gives_the_same_bits_on_one_and_two_threads() {
    same_bits("charged", &charged(), "json,npy");
}

#[test]
fn render_strands_give_the_same_bits_on_one_and_two_threads() {
    let scene = std::fs::read_to_string(format!(
        "{}/scenes/render-nape.toml",
        env!("CARGO_MANIFEST_DIR")
    ))
    .expect("scenes/render-nape.toml");
    // the scene names its mesh relative to scenes/: run it from there
    let scene = scene.replace(
        "\"data/",
        &format!("\"{}/scenes/data/", env!("CARGO_MANIFEST_DIR")),
    );
    same_bits("render", &scene, "npy,usda");
}

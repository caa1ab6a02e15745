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

#[test]
fn both_engines_give_the_same_bits_on_one_and_two_threads_and_as_each_other() {
    let runs: Vec<PathBuf> = ["embedded", "runtime"]
        .iter()
        .map(|engine| {
            let scene = rocking_patch(&format!("duration = 0.5\nengine = \"{engine}\""), "");
            same_bits(engine, &scene, "json,npy")
        })
        .collect();
    // the embedded step is the runtime's, with the same elementary functions
    let frames = |dir: &Path| std::fs::read(dir.join("frames.npy")).unwrap_or_default();
    assert!(
        frames(&runs[0]) == frames(&runs[1]),
        "the embedded and the runtime engine differ"
    );
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

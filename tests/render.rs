//! `superhelix render`: pictures re-rendered from a frames.npy written by a test run.

mod support;

use std::path::Path;
use std::process::{Command, Output};
use superhelix::runtime::output::preview::group_colour;

fn superhelix(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"))
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

fn decode(path: &Path) -> tiny_skia::Pixmap {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    tiny_skia::Pixmap::decode_png(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Pixels of exactly `rgb` (opaque pictures: premultiplied = straight).
fn count(p: &tiny_skia::Pixmap, rgb: [u8; 3]) -> usize {
    p.data().chunks_exact(4).filter(|px| px[..3] == rgb).count()
}

fn non_white(p: &tiny_skia::Pixmap) -> usize {
    p.data()
        .chunks_exact(4)
        .filter(|px| px[..3] != [255, 255, 255])
        .count()
}

#[test]
fn render_draws_the_strands_with_the_camera_asked_for() {
    let dir = support::scratch("render");
    support::simulate_to_npy(support::SCENE, &dir);
    let out = dir.join("pictures");
    let o = superhelix(&[
        "render",
        &dir.join("frames.npy").to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
        "--width",
        "900",
        "--height",
        "300",
        "--views",
        "front,side,top",
        "--frame",
        "2",
        "--no-gif",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let png = decode(&out.join("preview.png"));
    assert_eq!((png.width(), png.height()), (900, 300));
    assert!(!out.join("preview.gif").exists(), "--no-gif wrote a GIF");
    // three groups, each in its own colour; a 10-20 cm strand is >= 60 px long here
    for g in 0..3 {
        assert!(
            count(&png, group_colour(g)) >= 30,
            "group {g}: {} px",
            count(&png, group_colour(g))
        );
    }
    assert!(
        non_white(&png) > 500,
        "{} non-white pixels",
        non_white(&png)
    );
    let first = decode(&out.join("preview_first.png"));
    assert_eq!((first.width(), first.height()), (900, 300));
    assert_ne!(png.data(), first.data(), "frame 2 drawn like frame 0");

    // from the directory, with the GIF by default
    let o = superhelix(&[
        "render",
        &dir.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        (
            decode(&out.join("preview.png")).width(),
            decode(&out.join("preview.png")).height()
        ),
        (1200, 600)
    );
    let gif = std::fs::read(out.join("preview.gif")).unwrap_or_default();
    assert_eq!(&gif[..6], b"GIF89a");
}

#[test]
fn render_refuses_bad_input_naming_the_option() {
    let dir = support::scratch("render-bad");
    support::simulate_to_npy(support::SCENE, &dir);
    let frames = dir.join("frames.npy").to_string_lossy().to_string();
    let out = dir.join("pictures").to_string_lossy().to_string();
    for (args, needle) in [
        (vec!["--width", "10"], "--width"),
        (vec!["--height", "100000"], "--height"),
        (vec!["--width", "wide"], "--width"),
        (vec!["--views", "front,back"], "--views"),
        (vec!["--views", ""], "--views"),
        (vec!["--frame", "7"], "--frame"),
    ] {
        let mut all = vec!["render", &frames, "--out", &out];
        all.extend(&args);
        let o = superhelix(&all);
        assert!(!o.status.success(), "{args:?} accepted");
        assert!(
            text(&o).contains(needle),
            "{args:?}: {needle} not in {}",
            text(&o)
        );
    }
    let missing = dir.join("nowhere.npy").to_string_lossy().to_string();
    let o = superhelix(&["render", &missing, "--out", &out]);
    assert!(!o.status.success());
    assert!(
        text(&o).contains("FRAMES") && text(&o).contains("nowhere.npy"),
        "{}",
        text(&o)
    );
    assert!(!Path::new(&out).join("preview.png").exists());
}

/// The demo scene's pictures: its one group of strands in its colour, plenty of it.
#[test]
fn the_default_scene_reads_well() {
    let dir = support::scratch("default");
    support::simulate_to_npy(superhelix::DEFAULT_SCENE, &dir);
    let out = dir.join("pictures");
    let o = superhelix(&[
        "render",
        &dir.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    for name in ["preview.png", "preview_first.png"] {
        let png = decode(&out.join(name));
        // 100 guides of 25 cm at ~5 px per cm in a 1200 × 600 picture of two panels
        assert!(
            count(&png, group_colour(0)) >= 5000,
            "{name}: {} px",
            count(&png, group_colour(0))
        );
    }
}

#[test]
fn render_with_the_scene_draws_its_bodies_and_refuses_another_scene() {
    let dir = support::scratch("render-scene");
    // the support scene with a sphere beside its strands, written where --scene reads it
    let scene = format!(
        "{}\n[[bodies]]\nname = \"ball\"\nshape = \"sphere\"\nattached = \"head\"\ncenter = [0.0, 0.12, -0.05]\nradius = 0.04\n",
        support::SCENE
    );
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, &scene).expect("scene file");
    support::simulate_to_npy(&scene, &dir);
    let grey = |out: &std::path::Path| count(&decode(&out.join("preview.png")), [0xdd, 0xdd, 0xdd]);
    let bare = dir.join("bare");
    let o = superhelix(&[
        "render",
        &dir.to_string_lossy(),
        "--out",
        &bare.to_string_lossy(),
        "--no-gif",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    let with = dir.join("with");
    let o = superhelix(&[
        "render",
        &dir.to_string_lossy(),
        "--out",
        &with.to_string_lossy(),
        "--no-gif",
        "--scene",
        &scene_path.to_string_lossy(),
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // a 4 cm ball is over a thousand px in the two 600 × 600 panels of this framing;
    // without the scene only the odd antialiased pixel of the strands is that grey
    let (without_px, with_px) = (grey(&bare), grey(&with));
    eprintln!("body grey: {without_px} px without the scene, {with_px} px with it");
    assert!(
        with_px > without_px + 1000,
        "the ball took only {with_px} px ({without_px} without the scene)"
    );
    // a scene with another number of strands is not the one the frames came from
    let other = dir.join("other.toml");
    std::fs::write(
        &other,
        "[simulation]\ndt = 0.03333333333333333\nduration = 0.2\n[[strands]]\nname = \"one\"\nlength = 0.1\n",
    )
    .expect("scene file");
    let o = superhelix(&[
        "render",
        &dir.to_string_lossy(),
        "--out",
        &dir.join("x").to_string_lossy(),
        "--scene",
        &other.to_string_lossy(),
    ]);
    assert!(
        !o.status.success(),
        "a scene of another strand count was accepted"
    );
    assert!(text(&o).contains("--scene"), "{}", text(&o));
}

/// A run killed outright with JSON output leaves only `frames.json.partial`, perhaps cut
/// in the middle of a frame: `render` reads its complete frames.
#[test]
fn render_reads_the_complete_frames_of_a_killed_json_run() {
    let dir = support::scratch("render_partial");
    let scene = support::write(&dir, "scene.toml", support::SCENE);
    let run = dir.join("run");
    let o = superhelix(&[
        "run",
        &scene.to_string_lossy(),
        "--out",
        &run.to_string_lossy(),
        "--format",
        "json",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // what SIGKILL leaves: the streamed file, never renamed, its last frame cut short
    let full = std::fs::read_to_string(run.join("frames.json")).expect("frames.json");
    let cut = full.len() - full.len() / 10;
    std::fs::remove_file(run.join("frames.json")).expect("remove");
    std::fs::write(run.join("frames.json.partial"), &full[..cut]).expect("write");
    let frames = full.matches("\"index\":").count();
    let pictures = dir.join("pictures");
    let o = superhelix(&[
        "render",
        &run.to_string_lossy(),
        "--out",
        &pictures.to_string_lossy(),
        "--no-gif",
    ]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(pictures.join("preview.png").is_file());
    // the frame cut short is not drawn: asking for it is refused
    let o = superhelix(&[
        "render",
        &run.to_string_lossy(),
        "--out",
        &pictures.to_string_lossy(),
        "--no-gif",
        "--frame",
        &(frames - 1).to_string(),
    ]);
    assert!(!o.status.success(), "the cut frame was read");
    assert!(text(&o).contains("--frame"), "{}", text(&o));
}

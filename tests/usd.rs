//! `hair.usda` read back by a real USD reader (`pxr.Usd` of the `usd-core` Python
//! package, checked by `tests/python/check_usd.py`) against `frames.npy`.

mod support;

use std::path::Path;
use std::process::Command;
use superhelix::runtime::output::frames::FrameStore;
use superhelix::runtime::output::npy::NpyFrameStore;
use superhelix::runtime::output::plan::Formats;
use superhelix::runtime::output::preview::PreviewOptions;
use superhelix::runtime::output::products::write_products;
use superhelix::runtime::output::scenery::Scenery;

/// Run the real-reader check on `dir`; (passed, output).
fn check_usd(dir: &Path) -> (bool, String) {
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/python/check_usd.py");
    let out = match Command::new("python3").arg(script).arg(dir).output() {
        Ok(out) => out,
        Err(e) => {
            panic!("cannot run python3 ({e}): install Python 3, then `pip install usd-core numpy`")
        }
    };
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert_ne!(
        out.status.code(),
        Some(2),
        "the USD check cannot run: `pip install usd-core numpy`\n{text}"
    );
    (out.status.success(), text)
}

fn usda_only() -> Formats {
    Formats {
        json: false,
        npy: true,
        usda: true,
        png: false,
        gif: false,
        obj: false,
    }
}

#[test]
fn pxr_reads_the_points_of_every_group_at_several_times() {
    let dir = support::scratch("usd");
    let layout = support::simulate_to_npy(support::SCENE, &dir);
    assert_eq!(layout.groups(), ["solo", "front", "back"]);
    let mut store = NpyFrameStore::open(&dir).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(store.frame_count(), 7);
    write_products(
        &mut store,
        &usda_only(),
        &dir,
        &PreviewOptions::default(),
        &Scenery::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let (passed, text) = check_usd(&dir);
    assert!(passed, "{text}");
    assert!(
        text.contains("3 BasisCurves prims, 7 frames, time codes [0, 3, 6]"),
        "{text}"
    );

    // the check fails when one coordinate of the middle frame is off by 2e-6 m
    let usda = dir.join("hair.usda");
    let original = std::fs::read_to_string(&usda).unwrap_or_else(|e| panic!("{e}"));
    let mut points = Vec::new();
    store
        .points(3, &mut points)
        .unwrap_or_else(|e| panic!("{e}"));
    let offsets = layout.point_offsets();
    // strand "front_1_0" (index 2) is the second curve of the "front" prim
    let p = points[offsets[2] + 4];
    let fmt = |x: f64| superhelix::runtime::output::usd::format_f32(x as f32);
    let old = format!("({}, {}, {})", fmt(p[0]), fmt(p[1]), fmt(p[2]));
    let new = format!("({}, {}, {})", fmt(p[0]), fmt(p[1]), fmt(p[2] + 2e-6));
    let front = original
        .find("def BasisCurves \"front\"")
        .unwrap_or_else(|| panic!("no front prim"));
    let frame3 = front
        + original[front..]
            .find("            3: [")
            .unwrap_or_else(|| panic!("no frame 3"));
    let at = frame3
        + original[frame3..]
            .find(&old)
            .unwrap_or_else(|| panic!("{old} not in frame 3"));
    let broken = format!("{}{}{}", &original[..at], new, &original[at + old.len()..]);
    std::fs::write(&usda, broken).unwrap_or_else(|e| panic!("{e}"));
    let (passed, text) = check_usd(&dir);
    assert!(!passed, "a point off by 2e-6 m passed:\n{text}");
    assert!(text.contains("at time 3: points differ"), "{text}");
}

/// numpy opens frames.npy of a run that has not finished (as a killed run leaves it)
/// with exactly the frames written.
#[test]
fn numpy_loads_the_frames_of_an_unfinished_run() {
    use superhelix::runtime::output::frames::{FrameLayout, FrameSink, FrameView, StrandInfo};
    use superhelix::runtime::output::npy::NpyFrameSink;
    let dir = support::scratch("numpy");
    let layout = FrameLayout {
        strands: vec![StrandInfo {
            name: "a".into(),
            group: "a".into(),
            radius: 5e-5,
            points: 4,
            coordinates: 3,
        }],
        output_fps: 10.0,
        planned_frames: 10,
        held_tips: Vec::new(),
    };
    let mut sink = NpyFrameSink::create(&dir, &layout).unwrap_or_else(|e| panic!("{e}"));
    for k in 0..3 {
        let points: Vec<[f64; 3]> = (0..4).map(|i| [k as f64, i as f64, 0.25]).collect();
        let view = FrameView {
            index: k,
            time: 0.1 * k as f64,
            state_time: 0.1 * k as f64,
            points: &points,
            q: &[0.0; 3],
            steps: None,
            held: &[],
        };
        sink.write_frame(&view).unwrap_or_else(|e| panic!("{e}"));
    }
    let code = format!(
        "import numpy as np; p = np.load('{0}/frames.npy'); t = np.load('{0}/frames.times.npy'); \
         print(p.shape, p.dtype, t.shape, t.dtype, p[2, 3].tolist(), t[2].tolist())",
        dir.display()
    );
    let out = Command::new("python3")
        .args(["-c", &code])
        .output()
        .unwrap_or_else(|e| panic!("cannot run python3 ({e}): `pip install numpy`"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{text}");
    assert_eq!(
        text.trim(),
        "(3, 4, 3) float32 (3, 2) float64 [2.0, 3.0, 0.25] [0.2, 0.2]"
    );
    drop(sink);
}

/// The render strands of `[render]` are a last prim "render" under /hair that pxr reads
/// back with the points the library generates (`render/frames.npy`), at several times,
/// with the head turning.
#[test]
fn pxr_reads_the_render_strands() {
    use superhelix::runtime::output::frames::{FrameLayout, FrameSink, FrameView, StrandInfo};
    use superhelix::runtime::output::npy::NpyFrameSink;
    use superhelix::runtime::output::render_strands::RenderFrames;
    let dir = support::scratch("usd-render");
    let scene = format!(
        "{}\n[head]\nmotion = {{ kind = \"oscillate\", axis = [0.0, 0.0, 1.0], angle_deg = 20.0, frequency_hz = 2.0 }}\n\n[[bodies]]\nname = \"head\"\nshape = \"sphere\"\nradius = 0.04\ncenter = [0.0, 0.0, 0.05]\n\n[render]\nstrands = 60\nclumping = 0.5\ntip_distance = 0.1\nseed = 4\n",
        support::SCENE
    );
    let setup = superhelix::parse_scene(&scene).unwrap_or_else(|e| panic!("{e}"));
    support::simulate_to_npy(&scene, &dir);
    let scenery = Scenery::from_setup(&setup).unwrap_or_else(|e| panic!("{e}"));
    let source = scenery
        .render
        .clone()
        .unwrap_or_else(|| panic!("no render"));
    let mut store = NpyFrameStore::open(&dir).unwrap_or_else(|e| panic!("{e}"));
    // the render strands as the library generates them, written beside the frames
    let mut render =
        RenderFrames::new(&mut store, &source, &scenery, 1).unwrap_or_else(|e| panic!("{e}"));
    // the guides have 10, 13 and 7 points: render strands take the most
    assert_eq!(
        (render.strand_count(), render.points_per_strand()),
        (60, 13)
    );
    let layout = FrameLayout {
        strands: vec![StrandInfo {
            name: "render".into(),
            group: "render".into(),
            radius: 5e-5,
            points: 60 * 13,
            coordinates: 0,
        }],
        output_fps: 30.0,
        planned_frames: store.frame_count(),
        held_tips: Vec::new(),
    };
    let mut sink =
        NpyFrameSink::create(&dir.join("render"), &layout).unwrap_or_else(|e| panic!("{e}"));
    for k in 0..store.frame_count() {
        let points: Vec<[f64; 3]> = render
            .frame(&mut store, k, &scenery)
            .unwrap_or_else(|e| panic!("{e}"))
            .iter()
            .map(|p| p.map(f64::from))
            .collect();
        let view = FrameView {
            index: k,
            time: store.time(k),
            state_time: store.time(k),
            points: &points,
            q: &[],
            steps: None,
            held: &[],
        };
        sink.write_frame(&view).unwrap_or_else(|e| panic!("{e}"));
    }
    sink.finish().unwrap_or_else(|e| panic!("{e}"));
    let formats = Formats {
        png: true,
        ..usda_only()
    };
    write_products(
        &mut store,
        &formats,
        &dir,
        &PreviewOptions::default(),
        &scenery,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let (passed, text) = check_usd(&dir);
    assert!(passed, "{text}");
    assert!(
        text.contains("3 BasisCurves prims, 7 frames")
            && text.contains("render prim: 60 curves of 13 points"),
        "{text}"
    );

    // the check fails when a render point of the last frame is off by 2e-6 m
    let usda = dir.join("hair.usda");
    let original = std::fs::read_to_string(&usda).unwrap_or_else(|e| panic!("{e}"));
    let prim = original
        .find("def BasisCurves \"render\"")
        .unwrap_or_else(|| panic!("no render prim"));
    let frame6 = prim
        + original[prim..]
            .find("            6: [(")
            .unwrap_or_else(|| panic!("no frame 6"));
    let start = frame6 + "            6: [(".len();
    let end = start + original[start..].find(',').unwrap_or(0);
    let x: f32 = original[start..end]
        .parse()
        .unwrap_or_else(|e| panic!("{e}: {}", &original[start..end]));
    let moved = superhelix::runtime::output::usd::format_f32(x + 2e-6);
    let broken = format!("{}{}{}", &original[..start], moved, &original[end..]);
    std::fs::write(&usda, broken).unwrap_or_else(|e| panic!("{e}"));
    let (passed, text) = check_usd(&dir);
    assert!(!passed, "a render point off by 2e-6 m passed:\n{text}");
    assert!(text.contains("at time 6: render points differ"), "{text}");
}

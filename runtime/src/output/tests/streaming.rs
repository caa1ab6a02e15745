//! The streaming driver, frames.json, the memory store and the output plan.

use super::{config, Fake};
use crate::config::SimulationConfig;
use crate::error::Error;
use crate::output::json::PARTIAL_SUFFIX;
use crate::output::plan::{json_bytes, prepare_out_dir, Bytes, JSON_TO_NPY_BYTES};
use crate::output::*;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("superhelix-output-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    if let Err(e) = std::fs::create_dir_all(&dir) {
        panic!("{}: {e}", dir.display());
    }
    dir
}

/// Run `fake` into a memory sink and a frames.json in `dir`, raising the stop flag
/// after `stop_after` steps if given.
fn run_both(
    fake: &mut Fake,
    cfg: &SimulationConfig,
    dir: &std::path::Path,
    stop_after: Option<usize>,
) -> (RunOutcome, MemoryFrames) {
    let layout = frame_layout(fake, cfg, 2);
    let mut memory = MemoryFrames::new(layout.clone());
    let mut json = match JsonFrameSink::create(&dir.join("frames.json"), &layout) {
        Ok(j) => j,
        Err(e) => panic!("{e}"),
    };
    let stop = AtomicBool::new(false);
    let outcome = run_streaming(
        fake,
        cfg,
        2,
        &mut [&mut memory, &mut json],
        &stop,
        |step, _| {
            if Some(step) == stop_after {
                stop.store(true, Ordering::Relaxed);
            }
        },
    );
    (outcome, memory)
}

fn open(path: &std::path::Path) -> JsonFrameStore {
    match JsonFrameStore::open(path) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

fn assert_same_frames(json: &mut JsonFrameStore, memory: &MemoryFrames) {
    assert_eq!(json.frame_count(), memory.frame_count());
    assert_eq!(json.layout(), memory.layout());
    let mut points = Vec::new();
    for k in 0..memory.frame_count() {
        assert_eq!(json.time(k), memory.time(k));
        assert_eq!(json.state_time(k), memory.state_times[k]);
        json.points(k, &mut points).expect("frame exists");
        // the writer prints shortest round-trip numbers: reading back is exact
        assert_eq!(points, memory.points[k], "frame {k}");
        assert_eq!(json.q(k), Some(memory.q[k].as_slice()), "frame {k}");
    }
}

#[test]
fn frames_json_reads_back_exactly_what_was_streamed() {
    let dir = scratch("roundtrip");
    let cfg = config(0.1, 1.0, 10.0);
    let (outcome, memory) = run_both(&mut Fake::new(3, 0.1), &cfg, &dir, None);
    assert!(
        matches!(outcome.stop, StopReason::Completed),
        "{:?}",
        outcome.stop
    );
    assert_eq!((outcome.frames_written(), outcome.planned_frames), (11, 11));
    assert!(!dir.join(format!("frames.json{PARTIAL_SUFFIX}")).exists());
    let mut store = open(&dir.join("frames.json"));
    assert!(store.is_complete());
    assert_same_frames(&mut store, &memory);
    let layout = store.layout();
    assert_eq!(layout.strands[1].name, "b");
    assert_eq!(layout.strands[1].group, "b");
    assert_eq!(
        (layout.strands[1].points, layout.strands[1].coordinates),
        (5, 6)
    );
    assert_eq!(layout.point_offsets(), vec![0, 5, 10, 15]);
    // the documented structure
    let text = std::fs::read_to_string(dir.join("frames.json")).expect("reads");
    let json: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
    assert_eq!(json["format"], "superhelix-frames");
    assert_eq!(json["version"], 2);
    assert_eq!(json["layout"]["planned_frames"], 11);
    assert_eq!(json["frames"][4]["index"], 4);
    assert_eq!(
        json["frames"][4]["points"].as_array().map(Vec::len),
        Some(15)
    );
    assert_eq!(json["frames"][4]["q"].as_array().map(Vec::len), Some(18));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_file_cut_off_mid_frame_yields_its_complete_frames() {
    let dir = scratch("cut");
    let cfg = config(0.1, 1.0, 10.0);
    let (_, memory) = run_both(&mut Fake::new(2, 0.1), &cfg, &dir, None);
    let bytes = std::fs::read(dir.join("frames.json")).expect("reads");
    let text = String::from_utf8_lossy(&bytes);
    // frame k starts at the k-th "{\"index\"": a cut anywhere inside frame k keeps k
    let starts: Vec<usize> = text.match_indices("{\"index\"").map(|(i, _)| i).collect();
    assert_eq!(starts.len(), 11);
    for (k, &start) in starts.iter().enumerate().skip(1) {
        // just after frame k's closing brace (before ",\n" or the final "\n]}\n")
        let end = starts.get(k + 1).map_or(bytes.len() - 4, |&next| next - 2);
        for (cut, expected) in [
            (start - 1, k),
            (start + 1, k),
            (start + 40, k),
            (end, k + 1),
        ] {
            let store = match JsonFrameStore::from_bytes(&bytes[..cut]) {
                Ok(s) => s,
                Err(e) => panic!("cut at {cut}: {e}"),
            };
            assert!(!store.is_complete());
            assert_eq!(
                store.frame_count(),
                expected,
                "cut at byte {cut} (frame {k} at {start})"
            );
            assert_eq!(
                store.q(expected - 1),
                Some(memory.q[expected - 1].as_slice())
            );
        }
    }
    // a file cut inside the header has no layout
    assert!(JsonFrameStore::from_bytes(&bytes[..30]).is_err());
    // not frames.json at all
    assert!(JsonFrameStore::from_bytes(b"{\"format\": \"other\", \"version\": 2}").is_err());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_stop_flag_ends_the_run_between_steps_and_keeps_the_frames() {
    let dir = scratch("stop");
    let cfg = config(0.1, 2.0, 10.0);
    std::fs::write(dir.join("frames.json"), "previous run").expect("writes");
    let mut fake = Fake::new(2, 0.1);
    let (outcome, memory) = run_both(&mut fake, &cfg, &dir, Some(7));
    assert!(
        matches!(outcome.stop, StopReason::Interrupted),
        "{:?}",
        outcome.stop
    );
    // steps 1..=7 were taken: frames at t = 0, ..., 0.7
    assert_eq!(fake.steps, 7);
    assert_eq!((outcome.frames_written(), outcome.planned_frames), (8, 21));
    assert!((outcome.time - 0.7).abs() < 1e-12);
    // the new file replaced the previous one, complete and readable
    let mut store = open(&dir.join("frames.json"));
    assert!(store.is_complete());
    assert_same_frames(&mut store, &memory);
    assert_eq!(store.layout().planned_frames, 21);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_diverging_run_keeps_its_frames_and_names_strand_and_time() {
    let dir = scratch("nan");
    let cfg = config(0.1, 1.0, 10.0);
    let mut fake = Fake::new(3, 0.1);
    fake.nan_at_step = Some(5);
    let (outcome, memory) = run_both(&mut fake, &cfg, &dir, None);
    match &outcome.stop {
        StopReason::Failed(Error::Diverged { strand, time, .. }) => {
            assert_eq!(strand, "a");
            assert!((time - 0.5).abs() < 1e-12);
        }
        other => panic!("expected Diverged, got {other:?}"),
    }
    assert_eq!(outcome.frames_written(), 5);
    let mut store = open(&dir.join("frames.json"));
    assert_same_frames(&mut store, &memory);
    let finite = memory
        .points
        .iter()
        .flatten()
        .flatten()
        .all(|x| x.is_finite());
    assert!(finite && memory.q.iter().flatten().all(|x| x.is_finite()));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A sink whose disk fills up at frame `fail_at`.
struct FullDisk {
    fail_at: usize,
    written: usize,
    finished: bool,
}

impl FrameSink for FullDisk {
    fn write_frame(&mut self, frame: &FrameView<'_>) -> crate::error::Result<()> {
        if frame.index == self.fail_at {
            return Err(Error::Io {
                path: "disk".into(),
                source: std::io::Error::other("no space left on device"),
            });
        }
        self.written += 1;
        Ok(())
    }
    fn finish(&mut self) -> crate::error::Result<()> {
        self.finished = true;
        Ok(())
    }
}

#[test]
fn a_failing_write_stops_the_run_and_finishes_every_sink() {
    let cfg = config(0.1, 1.0, 10.0);
    let mut fake = Fake::new(1, 0.1);
    let layout = frame_layout(&fake, &cfg, 1);
    let mut memory = MemoryFrames::new(layout);
    let mut disk = FullDisk {
        fail_at: 3,
        written: 0,
        finished: false,
    };
    let never = AtomicBool::new(false);
    let outcome = run_streaming(
        &mut fake,
        &cfg,
        1,
        &mut [&mut memory, &mut disk],
        &never,
        |_, _| {},
    );
    assert!(
        matches!(&outcome.stop, StopReason::Failed(Error::Io { .. })),
        "{:?}",
        outcome.stop
    );
    assert_eq!((outcome.frames_written(), disk.written), (3, 3));
    assert!(disk.finished);
    assert_eq!(fake.steps, 3);
}

#[test]
fn formats_parse_from_names_and_report_unknown_ones() {
    let f = Formats::from_cli(&["json,npy", "preview"]).expect("valid");
    assert_eq!(f.names(), vec!["json", "npy", "png", "gif"]);
    assert_eq!(Formats::DEFAULT.names(), vec!["json", "usda", "png", "gif"]);
    match Formats::from_names("output.formats", &["usda", "vtk", "obj", "pdf"]) {
        Err(problems) => {
            let fields: Vec<&str> = problems.iter().map(|p| p.field.as_str()).collect();
            assert_eq!(fields, vec!["output.formats[1]", "output.formats[3]"]);
            assert!(problems[0]
                .message
                .contains("json, npy, usda, png, gif, obj, preview"));
        }
        Ok(f) => panic!("accepted {f:?}"),
    }
    assert!(Formats::from_names::<&str>("output.formats", &[]).is_err());
    match Formats::from_cli(&["json,"]) {
        Err(Error::Invalid(p)) => assert_eq!(p[0].field, "--format[1]"),
        other => panic!("{other:?}"),
    }
}

fn layout(strands: usize, points: usize, frames: usize) -> FrameLayout {
    FrameLayout {
        strands: (0..strands)
            .map(|i| StrandInfo {
                name: format!("s{i}"),
                group: "g".into(),
                radius: 5e-5,
                points,
                coordinates: 3 * (points - 1) / 4,
            })
            .collect(),
        output_fps: 30.0,
        planned_frames: frames,
        held_tips: Vec::new(),
    }
}

#[test]
fn the_plan_swaps_large_json_for_npy_and_refuses_beyond_the_limit() {
    let dir = std::path::Path::new("out");
    let settings = OutputSettings::default();
    // small: the default formats
    let plan = OutputPlan::new(&layout(16, 33, 61), &settings, None, false, dir);
    assert_eq!(plan.formats, Formats::DEFAULT);
    assert!(plan.note.is_none() && plan.check_limit().is_ok());
    assert!(plan.to_string().starts_with("output: "), "{plan}");
    // 1000 strands x 41 points x 601 frames: frames.json over 64 MB becomes frames.npy
    let big = layout(1000, 41, 601);
    assert!(json_bytes(&big) > JSON_TO_NPY_BYTES);
    let plan = OutputPlan::new(&big, &settings, None, false, dir);
    assert!(plan.formats.npy && !plan.formats.json, "{plan}");
    assert!(plan
        .note
        .as_deref()
        .is_some_and(|n| n.contains("frames.npy")));
    let npy = plan
        .files
        .iter()
        .find(|f| f.name == "frames.npy")
        .map(|f| f.bytes);
    assert_eq!(npy, Some(128 + 601 * 1000 * 41 * 12));
    // asked for explicitly, json stays; 10,000 strands then exceed the 2 GB default
    let json = Formats::from_cli(&["json"]).ok();
    let huge = layout(10_000, 41, 601);
    let plan = OutputPlan::new(&huge, &settings, json, false, dir);
    assert!(plan.formats.json && plan.total_bytes() > 2_000_000_000);
    match plan.check_limit() {
        Err(Error::Invalid(p)) => {
            let m = &p[0].message;
            assert!(m.contains(&Bytes(plan.total_bytes()).to_string()), "{m}");
            assert!(
                m.contains("2.0 GB")
                    && m.contains("max_bytes")
                    && m.contains("--allow-large-output"),
                "{m}"
            );
        }
        other => panic!("{other:?}"),
    }
    assert!(OutputPlan::new(&huge, &settings, json, true, dir)
        .check_limit()
        .is_ok());
    let lifted = OutputSettings {
        max_bytes: Some(100_000_000_000),
        ..settings
    };
    assert!(OutputPlan::new(&huge, &lifted, json, false, dir)
        .check_limit()
        .is_ok());
    let lowered = OutputSettings {
        max_bytes: Some(1_000_000),
        ..settings
    };
    assert!(
        OutputPlan::new(&layout(16, 33, 61), &lowered, None, false, dir)
            .check_limit()
            .is_err()
    );
}

#[test]
fn the_out_dir_is_created_and_a_file_is_refused() {
    let dir = scratch("outdir");
    let nested = dir.join("a").join("b");
    prepare_out_dir(&nested).expect("created");
    assert!(nested.is_dir());
    assert_eq!(std::fs::read_dir(&nested).map(|d| d.count()).ok(), Some(0));
    let file = dir.join("file");
    std::fs::write(&file, "x").expect("writes");
    match prepare_out_dir(&file) {
        Err(Error::Invalid(p)) => {
            assert_eq!(p[0].field, "--out");
            assert!(p[0].message.contains(&format!(
                "{} is a file, expected a directory",
                file.display()
            )));
        }
        other => panic!("{other:?}"),
    }
    let _ = std::fs::remove_dir_all(&dir);
}

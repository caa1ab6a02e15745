//! A hostile pass over the newest fields and commands (docs/hard-cases.md, "A hostile
//! pass"): cases generated from the ranges of docs/scene-format.md — every value outside
//! every numeric field's range and type of `[contacts]`, `[contacts.hair_hair]`,
//! `[output]`, `[simulation] tolerance` and the strands' point loads, bogus choices,
//! bad vectors of held ends, hostile polylines and output times, and command lines with
//! bad `--tolerance`, `--part`, `--format` and `--resume` — each given to `validate`, and
//! to `run` when `validate` accepts it. Each case is classified:
//!
//! - refused clearly: `validate` exits with 1 naming the field (or the option);
//! - ran sensibly: `validate` and `run` succeed and the frames are finite;
//! - refused vaguely: refused without naming the field, or with a panic;
//! - validate passed, run failed;
//! - wrong without a word: a value outside the documented range ran;
//! - hung: no answer within a minute.
//!
//! The test requires at least 200 cases, none of the last four kinds.

mod support;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use support::{scratch, write};

/// One hostile case: a scene (its sections) and extra arguments, and what a clear
/// refusal names (`None`: the case is valid and must run).
struct Case {
    name: String,
    scene: String,
    args: Vec<String>,
    names: Option<String>,
}

/// The scene's sections a case fills in.
#[derive(Default, Clone)]
struct Sections {
    simulation: String,
    contacts: String,
    hair: String,
    output: String,
    strand: String,
    tip: String,
    load: String,
}

impl Sections {
    fn scene(&self) -> String {
        let mut s = format!(
            "[simulation]\nduration = 0.1\n{}\n[[bodies]]\nshape = \"sphere\"\nradius = 0.05\ncenter = [0.0, 0.0, -0.3]\n",
            self.simulation
        );
        s += &format!("[contacts]\n{}\n", self.contacts);
        s += &format!("[contacts.hair_hair]\n{}\n", self.hair);
        s += &format!("[output]\n{}\n", self.output);
        // (a polyline gives the length and the direction itself)
        let shape = if self.strand.contains("polyline") {
            "elements = 5"
        } else {
            "length = 0.2\nelements = 5\ndirection = [0.0, 0.0, -1.0]"
        };
        s += &format!("[[strands]]\n{shape}\n{}\n", self.strand);
        if !self.tip.is_empty() {
            s += &format!("[strands.ends.tip]\n{}\n", self.tip);
        }
        if !self.load.is_empty() {
            s += &format!("[[strands.point_loads]]\n{}\n", self.load);
        }
        s
    }
}

/// Values outside the range and type of every numeric field here (each field's range
/// is non-negative and bounded).
const BAD_NUMBERS: [&str; 8] = [
    "-1.0", "nan", "inf", "-inf", "1e300", "\"x\"", "[1.0]", "true",
];

/// The cases.
fn cases() -> Vec<Case> {
    let mut out = Vec::new();
    let mut add = |name: String, sections: Sections, args: &[&str], names: Option<&str>| {
        out.push(Case {
            name,
            scene: sections.scene(),
            args: args.iter().map(|s| s.to_string()).collect(),
            names: names.map(str::to_string),
        });
    };
    // numeric fields: (section, key, integer)
    let numeric: [(&str, &str, bool); 27] = [
        ("contacts", "radius", false),
        ("contacts", "stiffness", false),
        ("contacts", "damping_ratio", false),
        ("contacts", "max_depth", false),
        ("contacts", "split_depth", false),
        ("contacts", "depenetration_speed", false),
        ("contacts", "friction_coefficient", false),
        ("contacts", "kinetic_friction_coefficient", false),
        ("contacts", "slip_speed", false),
        ("contacts", "tangential_stiffness_ratio", false),
        ("contacts", "anisotropy", false),
        ("contacts", "samples_per_element", true),
        ("contacts.hair_hair", "radius", false),
        ("contacts.hair_hair", "stiffness", false),
        ("contacts.hair_hair", "damping_ratio", false),
        ("contacts.hair_hair", "search_every", true),
        ("contacts.hair_hair", "split_depth", false),
        ("contacts.hair_hair", "self_exclusion", false),
        ("contacts.hair_hair", "friction_coefficient", false),
        ("contacts.hair_hair", "kinetic_friction_coefficient", false),
        ("contacts.hair_hair", "tangential_stiffness_ratio", false),
        ("contacts.hair_hair", "max_pairs_per_sample", true),
        ("output", "nodes", true),
        ("output", "checkpoint_every", true),
        ("output", "max_bytes", false),
        ("simulation", "tolerance", false),
        ("simulation", "max_split_depth", true),
    ];
    for (section, key, integer) in numeric {
        let mut values: Vec<&str> = BAD_NUMBERS.to_vec();
        if integer {
            values.push("1.5");
        }
        for v in values {
            let mut s = Sections::default();
            let line = format!("{key} = {v}");
            match section {
                "contacts" => s.contacts = line,
                "contacts.hair_hair" => s.hair = line,
                "output" => s.output = line,
                _ => s.simulation = line,
            }
            let field = format!("{section}.{key}");
            add(format!("{field} = {v}"), s, &[], Some(&field));
        }
    }
    // point loads
    for v in BAD_NUMBERS {
        let s = Sections {
            load: format!("s = {v}\nforce = [0.0, 0.0, 1.0]"),
            ..Default::default()
        };
        add(
            format!("point_loads.s = {v}"),
            s,
            &[],
            Some("strands[0].point_loads[0].s"),
        );
    }
    for v in [
        "[0.0, 0.0]",
        "[nan, 0.0, 0.0]",
        "[1e300, 0.0, 0.0]",
        "[\"a\", 0.0, 0.0]",
        "1.0",
    ] {
        let s = Sections {
            load: format!("s = 0.1\nforce = {v}"),
            ..Default::default()
        };
        add(
            format!("point_loads.force = {v}"),
            s,
            &[],
            Some("strands[0].point_loads[0].force"),
        );
    }
    // taut: a straight strand's tip held where it starts, at its whole length
    for kind in ["pinned", "clamped"] {
        let s = Sections {
            tip: format!("kind = \"{kind}\""),
            ..Default::default()
        };
        add(
            format!("taut {kind} tip"),
            s,
            &[],
            Some("strands[0].ends.tip"),
        );
    }
    // a straight strand's tip held 1 cm closer to its root: it cannot get there
    let s = Sections {
        tip: "kind = \"pinned\"\nposition = [0.0, 0.0, -0.19]".into(),
        ..Default::default()
    };
    add(
        "straight strand pinned 1 cm short".into(),
        s,
        &[],
        Some("strands[0].ends.tip"),
    );
    // choices
    for (section, key, v, field) in [
        ("contacts", "friction", "\"sticky\"", "contacts.friction"),
        ("contacts", "friction", "3", "contacts.friction"),
        (
            "contacts.hair_hair",
            "friction",
            "\"viscous\"",
            "contacts.hair_hair.friction",
        ),
        (
            "contacts.hair_hair",
            "self_contact",
            "\"yes\"",
            "contacts.hair_hair.self_contact",
        ),
        (
            "contacts.hair_hair",
            "self_contact",
            "1",
            "contacts.hair_hair.self_contact",
        ),
        (
            "strand",
            "ends",
            "{ root = \"glued\" }",
            "strands[0].ends.root",
        ),
        ("strand", "ends", "{ root = 1 }", "strands[0].ends.root"),
        ("tip", "kind", "\"welded\"", "strands[0].ends.tip.kind"),
        ("tip", "kind", "2", "strands[0].ends.tip.kind"),
        (
            "load",
            "follows",
            "\"yes\"",
            "strands[0].point_loads[0].follows",
        ),
    ] {
        let mut s = Sections::default();
        let line = format!("{key} = {v}");
        match section {
            "contacts" => s.contacts = line,
            "contacts.hair_hair" => s.hair = line,
            "strand" => s.strand = line,
            "tip" => s.tip = line,
            _ => s.load = format!("s = 0.1\nforce = [0.0, 0.0, 1.0]\n{line}"),
        }
        add(format!("{field} = {v}"), s, &[], Some(field));
    }
    // held ends' vectors
    for (kind, key) in [
        ("pinned", "position"),
        ("clamped", "direction"),
        ("clamped", "normal"),
        ("sliding", "axis"),
    ] {
        let unit = key != "position";
        let mut values = vec![
            "[1.0, 2.0]",
            "[nan, 0.0, 0.0]",
            "[\"a\", 0.0, 0.0]",
            "\"up\"",
        ];
        if unit {
            values.push("[0.0, 0.0, 0.0]");
        } else {
            values.push("[1e7, 0.0, 0.0]");
        }
        for v in values {
            let s = Sections {
                tip: format!("kind = \"{kind}\"\n{key} = {v}"),
                ..Default::default()
            };
            let field = format!("strands[0].ends.tip.{key}");
            add(format!("{kind} tip {key} = {v}"), s, &[], Some(&field));
        }
    }
    // polylines (the strand's direction goes: a polyline gives it)
    let zigzag: Vec<String> = (0..=20)
        .map(|k| format!("[{}, 0.0, {}]", 0.01 * (k % 2) as f64, -0.01 * k as f64))
        .collect();
    for (name, v, field) in [
        ("empty", "[]".to_string(), "strands[0].polyline"),
        ("one point", "[[0.0, 0.0, 0.0]]".to_string(), "strands[0].polyline"),
        ("a nan", "[[0.0, 0.0, 0.0], [nan, 0.0, -0.1]]".to_string(), "strands[0].polyline[1]"),
        ("3.6 km", "[[0.0, 0.0, 0.0], [0.0, 0.0, -900.0], [900.0, 0.0, -900.0], [900.0, 900.0, -900.0], [0.0, 900.0, -900.0]]".to_string(), "strands[0].polyline"),
        ("200 m", "[[0.0, 0.0, 0.0], [0.0, 0.0, -200.0]]".to_string(), "strands[0].polyline"),
        ("a zig-zag", format!("[{}]", zigzag.join(", ")), "strands[0].polyline"),
        ("back and forth", "[[0.0, 0.0, 0.0], [0.0, 0.0, -0.2], [0.001, 0.0, 0.0], [0.002, 0.0, -0.2]]".to_string(), "strands[0].polyline"),
        ("points as numbers", "[0.0, 0.1, 0.2]".to_string(), "strands[0].polyline"),
        ("a string", "\"[0, 0, 0]\"".to_string(), "strands[0].polyline"),
    ] {
        let s = Sections {
            strand: format!("polyline = {v}"),
            ..Default::default()
        };
        add(format!("polyline: {name}"), s, &[], Some(field));
    }
    // output times
    for (v, extra) in [
        ("[]", ""),
        ("[0.05, 0.02]", ""),
        ("[0.0, 0.5]", ""),
        ("[-0.1, 0.05]", ""),
        ("[0.0, nan]", ""),
        ("\"0.05\"", ""),
        ("[0.0]", "mode = \"static\""),
    ] {
        let s = Sections {
            output: format!("times = {v}"),
            simulation: extra.to_string(),
            ..Default::default()
        };
        add(
            format!("output.times = {v} {extra}"),
            s,
            &[],
            Some("output.times"),
        );
    }
    // static scenes: what they ignore is refused
    let s = Sections {
        simulation: "mode = \"static\"\ntolerance = 1e-4".into(),
        ..Default::default()
    };
    add(
        "static with tolerance".into(),
        s,
        &[],
        Some("simulation.tolerance"),
    );
    let s = Sections {
        simulation: "mode = \"static\"".into(),
        output: "checkpoint_every = 5".into(),
        ..Default::default()
    };
    add(
        "static with checkpoint_every".into(),
        s,
        &[],
        Some("output.checkpoint_every"),
    );
    // command lines
    for v in ["0", "-1", "nan", "0.6", "x", "1e300"] {
        add(
            format!("--tolerance {v}"),
            Sections::default(),
            &["--tolerance", v],
            Some("--tolerance"),
        );
    }
    for v in ["0/1", "2/1", "1/0", "a/b", "1/1000000000", "1-2"] {
        add(
            format!("--part {v}"),
            Sections::default(),
            &["--part", v],
            Some("--part"),
        );
    }
    for v in ["mp4", "", "json,,npy"] {
        add(
            format!("--format {v:?}"),
            Sections::default(),
            &["--format", v],
            Some("--format"),
        );
    }
    // valid values at the documented bounds and choices: these must run
    for (name, s) in [
        ("coulomb contacts, μ_k = μ_s", Sections { contacts: "friction = \"coulomb\"\nfriction_coefficient = 0.4\nkinetic_friction_coefficient = 0.4".into(), ..Default::default() }),
        ("hair friction and self-contact", Sections { hair: "friction = \"coulomb\"\nself_contact = true".into(), ..Default::default() }),
        ("anisotropy 0.99", Sections { contacts: "anisotropy = 0.99".into(), ..Default::default() }),
        ("samples 64", Sections { contacts: "samples_per_element = 64".into(), ..Default::default() }),
        ("pinned root", Sections { strand: "ends = { root = \"pinned\" }".into(), ..Default::default() }),
        ("pinned tip of a wavy strand", Sections { strand: "preset = \"wavy\"".into(), tip: "kind = \"pinned\"".into(), ..Default::default() }),
        ("clamped tip of a wavy strand", Sections { strand: "preset = \"wavy\"".into(), tip: "kind = \"clamped\"".into(), ..Default::default() }),
                ("sliding tip", Sections { tip: "kind = \"sliding\"".into(), ..Default::default() }),
        ("follower load", Sections { load: "s = 0.2\nforce = [0.0, 1e-6, 0.0]\nfollows = true".into(), ..Default::default() }),
        ("output times", Sections { output: "times = [0.0, 0.05, 0.1]".into(), ..Default::default() }),
        ("nodes 2", Sections { output: "nodes = 2".into(), ..Default::default() }),
        ("tolerance 0.5", Sections { simulation: "tolerance = 0.5".into(), ..Default::default() }),
        ("polyline", Sections { strand: "polyline = [[0.0, 0.0, 0.0], [0.0, 0.05, -0.1], [0.0, 0.1, -0.2]]".into(), ..Default::default() }),
    ] {
        add(format!("valid: {name}"), s, &[], None);
    }
    out
}

/// Run the binary with `args`, at most `limit`: (exit code, stdout + stderr), `None`
/// when it did not end in time (it is killed).
fn run_limited(args: &[String], limit: Duration) -> Option<(Option<i32>, String)> {
    let mut child = Command::new(env!("CARGO_BIN_EXE_superhelix"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"));
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => break,
            Ok(None) if start.elapsed() > limit => {
                let _ = child.kill();
                let _ = child.wait();
                return None;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(5)),
            Err(e) => panic!("{e}"),
        }
    }
    let o = child.wait_with_output().unwrap_or_else(|e| panic!("{e}"));
    Some((
        o.status.code(),
        format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ),
    ))
}

/// Whether every value of the `.npy` file at `path` (float32 frames) is finite.
fn finite_frames(path: &Path) -> bool {
    let bytes = std::fs::read(path).unwrap_or_default();
    if bytes.len() < 10 {
        return false;
    }
    let header = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    bytes[header..]
        .chunks_exact(4)
        .all(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]).is_finite())
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Outcome {
    RefusedClearly,
    RanSensibly,
    RefusedVaguely,
    ValidatePassedRunFailed,
    WrongWithoutAWord,
    Hung,
}

#[test]
fn a_hostile_pass_loses_nothing_hangs_nowhere_and_refuses_by_name() {
    let dir = scratch("hostile");
    let cases = cases();
    let limit = Duration::from_secs(60);
    let mut counts = std::collections::BTreeMap::new();
    let mut bad = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let scene = write(&dir, &format!("c{k}.toml"), &case.scene)
            .to_string_lossy()
            .into_owned();
        let mut validate = vec!["validate".to_string(), scene.clone()];
        validate.extend(case.args.iter().cloned());
        let outcome = match run_limited(&validate, limit) {
            None => (Outcome::Hung, String::new()),
            Some((code, said)) => {
                let panicked = said.contains("panicked") || said.contains("RUST_BACKTRACE");
                if code != Some(0) {
                    let named = case.names.as_deref().is_some_and(|f| said.contains(f));
                    // (1: refused; 2: a usage error found by the argument parser)
                    if matches!(code, Some(1) | Some(2)) && named && !panicked {
                        (Outcome::RefusedClearly, said)
                    } else {
                        (Outcome::RefusedVaguely, said)
                    }
                } else {
                    let out = dir.join(format!("out{k}"));
                    let mut run = vec![
                        "run".to_string(),
                        scene.clone(),
                        "--out".to_string(),
                        out.to_string_lossy().into_owned(),
                    ];
                    if !case.args.iter().any(|a| a == "--format") {
                        run.extend(["--format".to_string(), "npy".to_string()]);
                    }
                    run.extend(case.args.iter().cloned());
                    match run_limited(&run, limit) {
                        None => (Outcome::Hung, said),
                        Some((Some(0), ran))
                            if case.names.is_none() && finite_frames(&out.join("frames.npy")) =>
                        {
                            (Outcome::RanSensibly, ran)
                        }
                        Some((Some(0), ran)) => (Outcome::WrongWithoutAWord, ran),
                        Some((_, ran)) => (Outcome::ValidatePassedRunFailed, ran),
                    }
                }
            }
        };
        *counts.entry(outcome.0).or_insert(0usize) += 1;
        // (a valid case refused is refused vaguely: it names no field it should)
        if !matches!(outcome.0, Outcome::RefusedClearly | Outcome::RanSensibly) {
            bad.push(format!(
                "{:?}: {}\n{}",
                outcome.0,
                case.name,
                outcome.1.trim()
            ));
        }
    }
    eprintln!("{} cases: {counts:?}", cases.len());
    assert!(cases.len() >= 200, "{} cases", cases.len());
    assert!(
        bad.is_empty(),
        "{} cases went wrong:\n{}",
        bad.len(),
        bad.join("\n\n")
    );
}

/// The files of folder `dir` and their bytes, sorted by name.
fn snapshot(dir: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out: Vec<(String, Vec<u8>)> = std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter(|e| e.path().is_file())
        .map(|e| {
            (
                e.file_name().to_string_lossy().into_owned(),
                std::fs::read(e.path()).unwrap_or_default(),
            )
        })
        .collect();
    out.sort();
    out
}

/// Copy the files of `from` into `to` (created).
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("{e}"));
    for (name, bytes) in snapshot(from) {
        std::fs::write(to.join(name), bytes).unwrap_or_else(|e| panic!("{e}"));
    }
}

/// The hostile pass of the commands that read a user's earlier output: `merge` and
/// `run --resume` given missing, repeated, changed and damaged folders and files. Each
/// is refused with exit code 1 or 2 naming what is wrong, none hangs, and the parts and
/// the run it read are byte for byte as they were.
#[test]
fn merge_and_resume_refuse_by_name_and_lose_nothing() {
    let dir = scratch("hostile-outputs");
    let scene = write(
        &dir,
        "s.toml",
        "[simulation]\nduration = 0.2\n[output]\ncheckpoint_every = 2\n[[patches]]\ncount = [2, 2]\nsize = [0.02, 0.02]\nlength = 0.1\nelements = 3\n",
    )
    .to_string_lossy()
    .into_owned();
    let path = |p: &Path| p.to_string_lossy().into_owned();
    let (p1, p2, whole) = (dir.join("p1"), dir.join("p2"), dir.join("whole"));
    for (k, out) in [(1, &p1), (2, &p2)] {
        let args: Vec<String> = [
            "run",
            &scene,
            "--part",
            &format!("{k}/2"),
            "--out",
            &path(out),
            "--format",
            "npy",
        ]
        .map(String::from)
        .to_vec();
        let (code, said) = run_limited(&args, Duration::from_secs(60)).expect("the part ran");
        assert_eq!(code, Some(0), "{said}");
    }
    let args: Vec<String> = ["run", &scene, "--out", &path(&whole), "--format", "npy"]
        .map(String::from)
        .to_vec();
    let (code, said) = run_limited(&args, Duration::from_secs(60)).expect("the run ran");
    assert_eq!(code, Some(0), "{said}");
    let kept = [snapshot(&p1), snapshot(&p2), snapshot(&whole)];
    // damaged copies of p2 and of the whole run
    let copy = |name: &str, from: &Path, change: &dyn Fn(&Path)| {
        let to = dir.join(name);
        copy_folder(from, &to);
        change(&to);
        path(&to)
    };
    let set_json = |key: &'static str, value: serde_json::Value| {
        move |d: &Path| {
            let file = d.join("part.json");
            let mut v: serde_json::Value =
                serde_json::from_slice(&std::fs::read(&file).unwrap_or_default())
                    .unwrap_or_default();
            v[key] = value.clone();
            std::fs::write(&file, serde_json::to_vec(&v).unwrap_or_default())
                .unwrap_or_else(|e| panic!("{e}"));
        }
    };
    let garbage = copy("garbage", &p2, &|d| {
        std::fs::write(d.join("part.json"), b"{ not json").unwrap_or_else(|e| panic!("{e}"))
    });
    let format = copy(
        "format",
        &p2,
        &set_json("format", serde_json::json!("superhelix-frames")),
    );
    let huge_p = copy(
        "huge_p",
        &p2,
        &set_json(
            "part",
            serde_json::json!({"index": 2, "count": 1_000_000_000u64}),
        ),
    );
    let huge_total = copy(
        "huge_total",
        &p2,
        &set_json("total_strands", serde_json::json!(1_000_000_000_000u64)),
    );
    let far = copy(
        "far",
        &p2,
        &set_json("strands", serde_json::json!([0, 99_999_999u64])),
    );
    let folder = copy("folder", &p2, &|d| {
        std::fs::remove_file(d.join("part.json")).unwrap_or_else(|e| panic!("{e}"));
        std::fs::create_dir(d.join("part.json")).unwrap_or_else(|e| panic!("{e}"));
    });
    let no_npy = copy("no_npy", &p2, &|d| {
        std::fs::remove_file(d.join("frames.npy")).unwrap_or_else(|e| panic!("{e}"))
    });
    let short = copy("short", &p2, &|d| {
        let b = std::fs::read(d.join("frames.npy")).unwrap_or_default();
        std::fs::write(d.join("frames.npy"), &b[..b.len() / 2]).unwrap_or_else(|e| panic!("{e}"));
    });
    let bad_ck = copy("bad_ck", &whole, &|d| {
        std::fs::write(d.join("checkpoint.bin"), b"SHXCKPT1 garbage")
            .unwrap_or_else(|e| panic!("{e}"))
    });
    let dir_ck = copy("dir_ck", &whole, &|d| {
        std::fs::remove_file(d.join("checkpoint.bin")).unwrap_or_else(|e| panic!("{e}"));
        std::fs::create_dir(d.join("checkpoint.bin")).unwrap_or_else(|e| panic!("{e}"));
    });
    let resume_no_npy = copy("resume_no_npy", &whole, &|d| {
        std::fs::remove_file(d.join("frames.npy")).unwrap_or_else(|e| panic!("{e}"))
    });
    let other = write(&dir, "other.toml", "[simulation]\nduration = 0.3\n[[patches]]\ncount = [2, 2]\nsize = [0.02, 0.02]\nlength = 0.1\nelements = 3\n");
    let other = path(&other);
    let (a, b, w) = (path(&p1), path(&p2), path(&whole));
    let m = path(&dir.join("m"));
    let missing = path(&dir.join("missing"));
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["merge", &missing, &b, "--out", &m], "does not exist"),
        (
            vec!["merge", &scene, &b, "--out", &m],
            "is a file, not a folder",
        ),
        (vec!["merge", &a, "--out", &m], "part 2/2 is given 0 times"),
        (
            vec!["merge", &a, &a, &b, "--out", &m],
            "part 1/2 is given 2 times",
        ),
        (vec!["merge", &a, &b, "--out", &a], "--out"),
        (vec!["merge", &a, &b, "--out", &scene], "--out"),
        (vec!["merge", &a, &garbage, "--out", &m], "is not a part's"),
        (vec!["merge", &a, &format, "--out", &m], "is not a part's"),
        (vec!["merge", &a, &huge_p, "--out", &m], "part 2/1000000000"),
        (
            vec!["merge", &a, &huge_total, "--out", &m],
            "strands, its scene has",
        ),
        (
            vec!["merge", &a, &far, "--out", &m],
            "not those of part 2/2",
        ),
        (
            vec!["merge", &a, &folder, "--out", &m],
            "not a regular file",
        ),
        (
            vec!["merge", &a, &no_npy, "--out", &m],
            "frames.npy (part 2/2) is missing",
        ),
        (
            vec!["merge", &a, &short, "--out", &m],
            "is not the file its run wrote",
        ),
        (
            vec!["run", &scene, "--resume", &scene, "--format", "npy"],
            "is a file, not a folder",
        ),
        (
            vec!["run", &scene, "--resume", &bad_ck, "--format", "npy"],
            "is damaged",
        ),
        (
            vec!["run", &scene, "--resume", &dir_ck, "--format", "npy"],
            "not a regular file",
        ),
        (
            vec!["run", &scene, "--resume", &resume_no_npy, "--format", "npy"],
            "frames.npy is missing",
        ),
        (
            vec!["run", &other, "--resume", &w, "--format", "npy"],
            "is of another run",
        ),
        (
            vec![
                "run", &scene, "--resume", &w, "--out", &m, "--format", "npy",
            ],
            "--out",
        ),
    ];
    let mut bad = Vec::new();
    for (args, expect) in &cases {
        let owned: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        match run_limited(&owned, Duration::from_secs(60)) {
            None => bad.push(format!("hung: {args:?}")),
            Some((code, said)) => {
                let clear = matches!(code, Some(1) | Some(2))
                    && said.contains(expect)
                    && !said.contains("panicked")
                    && !said.contains("os error");
                if !clear {
                    bad.push(format!(
                        "{args:?}: exit {code:?}, expected {expect:?}:\n{}",
                        said.trim()
                    ));
                }
            }
        }
    }
    eprintln!(
        "{} merge and resume cases, {} went wrong",
        cases.len(),
        bad.len()
    );
    assert!(bad.is_empty(), "{}", bad.join("\n\n"));
    // nothing read was changed
    assert!(
        kept == [snapshot(&p1), snapshot(&p2), snapshot(&whole)],
        "a part or the run changed"
    );
}

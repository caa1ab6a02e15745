//! A head split across machines (docs/output.md, "A head split across machines"):
//! `superhelix run SCENE --part K/P` as P = 3 processes at once, then `superhelix merge`,
//! writes byte for byte what one run of the whole scene writes (frames.npy and its
//! companions, frames.json, the node files, the step reports, hair.usda), for a scene of
//! strands of two sizes with body contacts and error-controlled steps; the scenes and
//! part sets that cannot be split or merged are refused, naming why.

mod support;

use std::path::Path;
use std::process::{Command, Stdio};
use support::{rocking_patch, scratch, superhelix, text, write};

/// 16 wavy strands of 6 elements and 6 curly ones of 3 (unequal costs to balance) on a
/// rocking head, touching a ball, with error-controlled steps and nodes.
fn scene() -> String {
    let patch = rocking_patch(
        "duration = 0.5\ntolerance = 1e-4",
        "[contacts]\nfriction = \"coulomb\"\nfriction_coefficient = 0.3\n[output]\nnodes = 5\n",
    );
    format!(
        "{patch}[[patches]]\nname = \"q\"\ncount = [2, 3]\nsize = [0.03, 0.03]\nlength = 0.1\nelements = 3\npreset = \"curly\"\n"
    )
}

const FORMATS: &str = "json,npy,usda";

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

#[test]
fn three_parts_run_as_three_processes_merge_to_the_whole_run_bit_for_bit() {
    let dir = scratch("part-merge");
    let scene = write(&dir, "scene.toml", &scene());
    let scene = scene.to_string_lossy().into_owned();
    let whole = dir.join("whole");
    let o = superhelix(&[
        "run",
        &scene,
        "--out",
        &whole.to_string_lossy(),
        "--format",
        FORMATS,
    ]);
    assert!(o.status.success(), "{}", text(&o));
    // the three parts at once, as a farm would run them
    let parts: Vec<_> = (1..=3).map(|k| dir.join(format!("part{k}"))).collect();
    let children: Vec<_> = parts
        .iter()
        .enumerate()
        .map(|(k, out)| {
            Command::new(env!("CARGO_BIN_EXE_superhelix"))
                .args(["run", &scene, "--part", &format!("{}/3", k + 1), "--out"])
                .arg(out)
                .args(["--format", FORMATS])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap_or_else(|e| panic!("cannot start superhelix: {e}"))
        })
        .collect();
    let mut held = Vec::new();
    for child in children {
        let o = child.wait_with_output().unwrap_or_else(|e| panic!("{e}"));
        let said = text(&o);
        assert!(o.status.success(), "{said}");
        let strands: usize = said
            .lines()
            .find_map(|l| {
                l.strip_prefix("part ")?
                    .split(": ")
                    .nth(1)?
                    .split(' ')
                    .next()?
                    .parse()
                    .ok()
            })
            .unwrap_or_else(|| panic!("no part line in:\n{said}"));
        held.push(strands);
    }
    // every strand in one part; the costs (18² and 9²) balanced to within one strand
    assert_eq!(held.iter().sum::<usize>(), 22, "{held:?}");
    assert!(held.iter().all(|&n| (6..=9).contains(&n)), "{held:?}");
    let merged = dir.join("merged");
    let mut args = vec!["merge".to_string()];
    // in any order
    for p in [&parts[2], &parts[0], &parts[1]] {
        args.push(p.to_string_lossy().into_owned());
    }
    args.extend(["--out".to_string(), merged.to_string_lossy().into_owned()]);
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = superhelix(&args);
    assert!(o.status.success(), "{}", text(&o));
    let names = files(&whole);
    for expected in [
        "frames.npy",
        "frames.json",
        "frames.steps.npy",
        "frames.nodes.npy",
        "hair.usda",
        "strand_steps.npy",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "{expected} not in {names:?}"
        );
    }
    assert_eq!(names, files(&merged));
    for name in names {
        let a = std::fs::read(whole.join(&name)).unwrap_or_default();
        let b = std::fs::read(merged.join(&name)).unwrap_or_default();
        assert!(!a.is_empty(), "{name} is empty");
        assert!(
            a == b,
            "{name} differs between the whole run and the merged parts"
        );
    }
}

#[test]
fn what_cannot_be_split_or_merged_is_refused_by_name() {
    let dir = scratch("part-refusals");
    let refused = |args: &[&str], expect: &[&str]| {
        let o = superhelix(args);
        let said = text(&o);
        assert!(!o.status.success(), "{args:?} succeeded:\n{said}");
        for e in expect {
            assert!(said.contains(e), "{e:?} not in:\n{said}");
        }
    };
    let charged = write(
        &dir,
        "charged.toml",
        "[electrostatics]\ncharge_per_length = -1e-10\n[[patches]]\nname = \"t\"\ncount = [2, 2]\nsize = [0.01, 0.01]\nlength = 0.1\nelements = 3\n",
    );
    let out = dir.join("out").to_string_lossy().into_owned();
    refused(
        &[
            "run",
            &charged.to_string_lossy(),
            "--part",
            "1/2",
            "--out",
            &out,
        ],
        &["--part", "[electrostatics]"],
    );
    let root = env!("CARGO_MANIFEST_DIR");
    let nape = format!("{root}/scenes/render-nape.toml");
    refused(
        &["run", &nape, "--part", "1/2", "--out", &out],
        &["--part", "[render]"],
    );
    let small = write(
        &dir,
        "small.toml",
        &scene()
            .replace("count = [4, 4]", "count = [1, 1]")
            .replace("count = [2, 3]", "count = [1, 1]"),
    );
    let small = small.to_string_lossy().into_owned();
    refused(
        &["run", &small, "--part", "3/3", "--out", &out],
        &["--part", "P is at most the scene's number of strands (2)"],
    );
    // a P that would allocate for a billion parts: refused before the split
    refused(
        &["run", &small, "--part", "1/1000000000", "--out", &out],
        &[
            "--part",
            "1/1000000000",
            "at most the scene's number of strands",
        ],
    );
    for bad in ["0/2", "3/2", "1-2", "a/b"] {
        refused(&["run", &small, "--part", bad, "--out", &out], &["K/P"]);
    }
    // hair–hair: said by validate and by run --part
    let hair = write(
        &dir,
        "hair.toml",
        &scene().replace("[output]", "[contacts.hair_hair]\nradius = 0.002\n[output]"),
    );
    let o = superhelix(&["validate", &hair.to_string_lossy()]);
    assert!(
        o.status.success()
            && text(&o)
                .contains("hair–hair contacts between strands of different parts are not computed"),
        "{}",
        text(&o)
    );
    // merge: a missing part, a part twice, a folder that is not a part
    let p1 = dir.join("p1").to_string_lossy().into_owned();
    let p2 = dir.join("p2").to_string_lossy().into_owned();
    for (k, p) in [(1, &p1), (2, &p2)] {
        let o = superhelix(&[
            "run",
            &small,
            "--part",
            &format!("{k}/2"),
            "--out",
            p,
            "--format",
            "npy",
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let m = dir.join("m").to_string_lossy().into_owned();
    refused(&["merge", &p1, "--out", &m], &["part 2/2 is given 0 times"]);
    refused(
        &["merge", &p1, &p1, &p2, "--out", &m],
        &["part 1/2 is given 2 times"],
    );
    refused(&["merge", &p1, &out, "--out", &m], &["out does not exist"]);
    std::fs::create_dir_all(dir.join("out")).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &["merge", &p1, &out, "--out", &m],
        &[
            "holds no part.json",
            "not the output folder of a run --part",
        ],
    );
    refused(
        &["merge", &p1, &small, "--out", &m],
        &["small.toml is a file, not a folder"],
    );
    // a part that did not finish
    let npy = dir.join("p2").join("frames.npy");
    let o = superhelix(&[
        "run", &small, "--part", "2/2", "--out", &p2, "--format", "npy",
    ]);
    assert!(o.status.success());
    let times = dir.join("p2").join("frames.times.npy");
    assert!(npy.exists() && times.exists());
    let short = dir.join("p2short");
    std::fs::create_dir_all(&short).unwrap_or_else(|e| panic!("{e}"));
    for f in [
        "part.json",
        "frames.index.json",
        "frames.npy",
        "frames.times.npy",
    ] {
        std::fs::copy(dir.join("p2").join(f), short.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    }
    // cut to its first 3 frames: the same header (version 1: 10 bytes, then the dict
    // padded with spaces to its length) with 3 rows
    let bytes = std::fs::read(short.join("frames.npy")).unwrap_or_default();
    let header = 10 + u16::from_le_bytes([bytes[8], bytes[9]]) as usize;
    let dict = String::from_utf8_lossy(&bytes[10..header]).into_owned();
    let frames: usize = dict
        .split("'shape': (")
        .nth(1)
        .and_then(|s| s.split(',').next())
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(0);
    assert!(frames > 3, "{dict}");
    let row = (bytes.len() - header) / frames;
    let mut cut = bytes[..10].to_vec();
    let mut patched = dict.replacen(&format!("({frames},"), "(3,", 1).into_bytes();
    patched.truncate(header - 11);
    patched.resize(header - 11, b' ');
    cut.extend_from_slice(&patched);
    cut.push(b'\n');
    cut.extend_from_slice(&bytes[header..header + 3 * row]);
    std::fs::write(short.join("frames.npy"), &cut).unwrap_or_else(|e| panic!("{e}"));
    // its frames.npy is not the one its run recorded
    refused(
        &["merge", &p1, &short.to_string_lossy(), "--out", &m],
        &["frames.npy", "part 2/2", "is not the file its run wrote"],
    );
}

/// `part.json` with its recorded frame files replaced by `files` (a JSON value).
fn set_recorded_files(part: &Path, files: serde_json::Value) {
    let path = part.join("part.json");
    let mut info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap_or_default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    info["files"] = files;
    std::fs::write(&path, serde_json::to_vec_pretty(&info).unwrap_or_default())
        .unwrap_or_else(|e| panic!("{e}"));
}

/// Copy the files of folder `from` into `to` (created).
fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap_or_else(|e| panic!("{e}"));
    for name in files(from) {
        std::fs::copy(from.join(&name), to.join(&name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    }
}

/// merge never writes into a part, writes its output whole or not at all, and reads only
/// parts whose frame files and strand lists are what their runs left: each defect a
/// user met (a part's frames destroyed by `--out` = a part; a reordered strand list or
/// one flipped byte merged silently) is refused, naming the part and the file.
#[test]
fn merge_never_writes_into_a_part_and_refuses_a_changed_one() {
    let dir = scratch("part-merge-trust");
    let refused = |args: &[&str], expect: &[&str]| {
        let o = superhelix(args);
        let said = text(&o);
        assert!(!o.status.success(), "{args:?} succeeded:\n{said}");
        for e in expect {
            assert!(said.contains(e), "{e:?} not in:\n{said}");
        }
        assert!(!said.contains("invalid scene"), "{said}");
    };
    let small = write(
        &dir,
        "small.toml",
        &scene()
            .replace("count = [4, 4]", "count = [2, 2]")
            .replace("count = [2, 3]", "count = [1, 2]"),
    );
    let small = small.to_string_lossy().into_owned();
    let parts: Vec<_> = (1..=3).map(|k| dir.join(format!("p{k}"))).collect();
    for (k, p) in parts.iter().enumerate() {
        let o = superhelix(&[
            "run",
            &small,
            "--part",
            &format!("{}/3", k + 1),
            "--out",
            &p.to_string_lossy(),
            "--format",
            "npy,json",
        ]);
        assert!(o.status.success(), "{}", text(&o));
    }
    let p: Vec<String> = parts
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let before: Vec<Vec<u8>> = files(&parts[0])
        .iter()
        .map(|n| std::fs::read(parts[0].join(n)).unwrap_or_default())
        .collect();
    // 1. --out = a part (as given, and by another spelling of its path)
    let same = format!("{}/../p1", p[1]);
    for out in [&p[0], &same] {
        refused(
            &["merge", &p[0], &p[1], &p[2], "--out", out],
            &["--out", "is the folder of part 1/3", "never writes into"],
        );
    }
    let after: Vec<Vec<u8>> = files(&parts[0])
        .iter()
        .map(|n| std::fs::read(parts[0].join(n)).unwrap_or_default())
        .collect();
    assert!(before == after, "part 1's files changed");
    // a merge that works, the reference for the refusals below
    let m = dir.join("m");
    let ms = m.to_string_lossy().into_owned();
    let o = superhelix(&["merge", &p[0], &p[1], &p[2], "--out", &ms]);
    assert!(o.status.success(), "{}", text(&o));
    let merged = std::fs::read(m.join("frames.npy")).unwrap_or_default();
    assert!(!merged.is_empty());
    // 2. one byte flipped in a part's frames.npy: refused, the earlier output untouched
    let flipped = dir.join("p2flip");
    copy_folder(&parts[1], &flipped);
    let mut bytes = std::fs::read(flipped.join("frames.npy")).unwrap_or_default();
    let at = bytes.len() - 100;
    bytes[at] ^= 0x40;
    std::fs::write(flipped.join("frames.npy"), &bytes).unwrap_or_else(|e| panic!("{e}"));
    refused(
        &[
            "merge",
            &p[0],
            &flipped.to_string_lossy(),
            &p[2],
            "--out",
            &ms,
        ],
        &[
            "p2flip/frames.npy",
            "part 2/3",
            "CRC-32",
            "changed or damaged",
        ],
    );
    assert!(std::fs::read(m.join("frames.npy")).unwrap_or_default() == merged);
    assert_eq!(
        files(&m)
            .iter()
            .filter(|n| n.starts_with(".superhelix-merge"))
            .count(),
        0,
        "{:?}",
        files(&m)
    );
    // 3. its strand list reordered
    let reordered = dir.join("p2order");
    copy_folder(&parts[1], &reordered);
    let path = reordered.join("part.json");
    let mut info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap_or_default())
            .unwrap_or_else(|e| panic!("{e}"));
    let strands = info["strands"]
        .as_array_mut()
        .unwrap_or_else(|| panic!("part.json without strands"));
    assert!(strands.len() >= 2, "{strands:?}");
    strands.swap(0, 1);
    std::fs::write(&path, serde_json::to_vec(&info).unwrap_or_default())
        .unwrap_or_else(|e| panic!("{e}"));
    refused(
        &[
            "merge",
            &p[0],
            &reordered.to_string_lossy(),
            &p[2],
            "--out",
            &ms,
        ],
        &["p2order/part.json", "not those of part 2/3"],
    );
    // 4. a part whose run did not finish (no digests recorded), and a frame file its
    // run did not write
    let unfinished = dir.join("p2run");
    copy_folder(&parts[1], &unfinished);
    set_recorded_files(&unfinished, serde_json::json!([]));
    refused(
        &[
            "merge",
            &p[0],
            &unfinished.to_string_lossy(),
            &p[2],
            "--out",
            &ms,
        ],
        &["part 2/3", "did not finish", "--resume"],
    );
    let extra = dir.join("p2extra");
    copy_folder(&parts[1], &extra);
    std::fs::write(extra.join("frames.held.npy"), b"not a run's").unwrap_or_else(|e| panic!("{e}"));
    refused(
        &[
            "merge",
            &p[0],
            &extra.to_string_lossy(),
            &p[2],
            "--out",
            &ms,
        ],
        &["frames.held.npy", "not among the files its run recorded"],
    );
    assert!(std::fs::read(m.join("frames.npy")).unwrap_or_default() == merged);
}

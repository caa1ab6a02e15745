//! A head split across machines: `superhelix run SCENE --part K/P` simulates part K of P
//! of the strands, and [`crate::merge`] joins the parts' outputs into those of the whole
//! scene (docs/output.md, "A head split across machines").
//!
//! The split is deterministic and balanced by expected cost: the strands are taken from
//! the most costly down (ties in scene order), each given to the part with the least
//! cost so far (ties to the lower part): the longest-processing-time rule, within 4/3 of
//! the best balance. A strand's cost is that of its step's dense solve, (3N)² for N
//! elements (a held tip or a free root adds its rows). Each part writes `part.json`
//! beside its frames: which strands it holds, the scene and its digest.
//!
//! A part is the whole scene's simulation of its strands only when the strands do not
//! act on each other: a scene with `[electrostatics]` or `[render]` is refused, and
//! hair–hair contacts between strands of different parts are not computed (`validate`
//! and `run --part` say so).

use crate::{Error, Result, SimulationSetup};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Name of the file a part writes beside its frames.
pub const PART_FILE: &str = "part.json";

/// Value of `part.json`'s `format` field.
pub const PART_FORMAT: &str = "superhelix-part";

/// `K/P` of `--part`: part K (1 to P) of P.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Part {
    /// K, from 1.
    pub index: usize,
    /// P.
    pub count: usize,
}

impl std::str::FromStr for Part {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let bad = || format!("{s:?}: expected K/P, part K (1 to P) of P parts, as 2/3");
        let (k, p) = s.split_once('/').ok_or_else(bad)?;
        let (index, count) = (
            k.trim().parse::<usize>().map_err(|_| bad())?,
            p.trim().parse::<usize>().map_err(|_| bad())?,
        );
        if count == 0 || index == 0 || index > count {
            return Err(format!("{s:?}: K must be 1 to P and P at least 1"));
        }
        Ok(Part { index, count })
    }
}

/// The expected cost of a strand's step: (3N)² of its dense solve, with a held tip's
/// rows and a free root's coordinates counted in its coordinates.
fn cost(strand: &crate::runtime::StrandSetup) -> u64 {
    let n = strand.q0.len() as u64 + strand.tip.as_ref().map_or(0, |t| t.kind.rows() as u64);
    n * n
}

/// Which strands (indices in scene order, ascending) each of `count` parts takes.
pub fn split(setup: &SimulationSetup, count: usize) -> Vec<Vec<usize>> {
    let costs: Vec<u64> = setup.strands.iter().map(cost).collect();
    let mut order: Vec<usize> = (0..costs.len()).collect();
    // most costly first, ties in scene order
    order.sort_by(|&a, &b| costs[b].cmp(&costs[a]).then(a.cmp(&b)));
    let mut loads = vec![0u64; count.max(1)];
    let mut parts = vec![Vec::new(); count.max(1)];
    for i in order {
        let lightest = (0..loads.len()).min_by_key(|&p| (loads[p], p)).unwrap_or(0);
        loads[lightest] += costs[i];
        parts[lightest].push(i);
    }
    for p in &mut parts {
        p.sort_unstable();
    }
    parts
}

/// Why a scene cannot be split into parts (`None`: it can).
pub fn refusal(setup: &SimulationSetup) -> Option<Error> {
    if setup.electrostatics.is_some() {
        return Some(Error::invalid(
            "--part",
            "a scene with [electrostatics] cannot be split: every charged strand acts on every other; run it whole",
        ));
    }
    if setup.output.render.is_some() {
        return Some(Error::invalid(
            "--part",
            "a scene with [render] cannot be split: render strands are interpolated between guides of every part; run it whole (or without [render])",
        ));
    }
    None
}

/// What `validate` and `run --part` say of a scene whose strands touch each other.
pub fn hair_hair_note(setup: &SimulationSetup) -> Option<&'static str> {
    setup
        .contacts
        .as_ref()
        .and_then(|c| c.hair_hair.as_ref())
        .map(|_| {
            "note: with run --part, hair–hair contacts between strands of different parts are not computed (contacts within a part are)"
        })
}

/// `setup` reduced to part `part`'s strands (see [`split`]); an error when the scene
/// cannot be split ([`refusal`]) or the part would hold no strand.
pub fn part_setup(setup: &SimulationSetup, part: Part) -> Result<(SimulationSetup, Vec<usize>)> {
    if let Some(e) = refusal(setup) {
        return Err(e);
    }
    // (before the split, which allocates for each of the P parts)
    if part.count > setup.strands.len() {
        return Err(Error::invalid(
            "--part",
            format!(
                "{}/{}: P is at most the scene's number of strands ({}), so that every part holds one",
                part.index,
                part.count,
                setup.strands.len()
            ),
        ));
    }
    let strands = split(setup, part.count)
        .into_iter()
        .nth(part.index - 1)
        .unwrap_or_default();
    if strands.is_empty() {
        return Err(Error::invalid(
            "--part",
            format!(
                "part {}/{} holds no strand: the scene has {} strand(s); use at most that many parts",
                part.index,
                part.count,
                setup.strands.len()
            ),
        ));
    }
    let mut reduced = setup.clone();
    reduced.strands = strands.iter().map(|&i| setup.strands[i].clone()).collect();
    Ok((reduced, strands))
}

/// What `part.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PartInfo {
    /// [`PART_FORMAT`].
    pub format: String,
    /// Which part.
    pub part: Part,
    /// The strands it holds: their indices in the whole scene, ascending.
    pub strands: Vec<usize>,
    /// Strands of the whole scene.
    pub total_strands: usize,
    /// The scene's text.
    pub scene: String,
    /// The folder the scene's relative paths are read from.
    pub scene_dir: String,
    /// The digest of the whole scene's setup (see
    /// [`crate::runtime::output::checkpoint::setup_digest`]), as hex.
    pub digest: String,
    /// The formats the part writes.
    pub formats: Vec<String>,
    /// The frame files (those of [`FRAME_FILES`] the part wrote) as they were when its run
    /// finished, which `merge` checks before it reads them; empty while the run is going
    /// on, and in a part whose run stopped before its last frame.
    #[serde(default)]
    pub files: Vec<FileDigest>,
}

/// The files of a part that `merge` reads: the frames and their companions, the node
/// files and the per-strand step report.
pub const FRAME_FILES: [&str; 9] = [
    crate::runtime::output::npy::NPY_FILE,
    crate::runtime::output::npy::TIMES_FILE,
    crate::runtime::output::npy::INDEX_FILE,
    crate::runtime::output::npy::STEPS_FILE,
    crate::runtime::output::npy::HELD_FILE,
    crate::FRAMES_FILE,
    crate::runtime::output::nodes::NODES_FILE,
    crate::runtime::output::nodes::D1_FILE,
    crate::runtime::output::npy::STRAND_STEPS_FILE,
];

/// One file of a part as its run left it: its length and CRC-32 (which changes with any
/// byte of it, and with any burst of up to 32 bits).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FileDigest {
    /// File name, in the part's folder.
    pub name: String,
    /// Length in bytes.
    pub bytes: u64,
    /// CRC-32 (IEEE) of its bytes, as 8 hex digits.
    pub crc32: String,
}

/// The [`FileDigest`] of `path`, read in blocks.
pub fn file_digest(path: &Path) -> Result<FileDigest> {
    use std::io::Read;
    let io = |e| crate::runtime::output::atomic::io_error(path, e);
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut hasher = crc32fast::Hasher::new();
    let mut buffer = vec![0u8; 1 << 20];
    let mut bytes = 0u64;
    loop {
        let n = file.read(&mut buffer).map_err(io)?;
        if n == 0 {
            break;
        }
        hasher.update(&buffer[..n]);
        bytes += n as u64;
    }
    Ok(FileDigest {
        name: path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        bytes,
        crc32: format!("{:08x}", hasher.finalize()),
    })
}

/// Record in `info` the digests of the frame files in `dir` and write it as
/// `dir/part.json`: what a part's run does when it has written its last frame.
pub fn record_files(dir: &Path, info: &mut PartInfo) -> Result<()> {
    info.files = FRAME_FILES
        .iter()
        .map(|name| dir.join(name))
        .filter(|path| path.is_file())
        .map(|path| file_digest(&path))
        .collect::<Result<Vec<_>>>()?;
    write_info(dir, info)
}

/// Check the frame files of the part in `dir` against the digests its `part.json`
/// records: every recorded file present with its length and CRC-32, and no frame file
/// that was not recorded. The error names the part, the file and what to do.
pub fn check_files(dir: &Path, info: &PartInfo) -> Result<()> {
    let part = format!("part {}/{}", info.part.index, info.part.count);
    let refuse = |why: String| Error::invalid("PART_DIRS", why);
    if info.files.is_empty() {
        return Err(refuse(format!(
            "{} ({part}) records no digest of its frame files: its run did not finish; finish it with run SCENE --part {}/{} --resume {}",
            dir.join(PART_FILE).display(),
            info.part.index,
            info.part.count,
            dir.display()
        )));
    }
    for name in FRAME_FILES {
        let path = dir.join(name);
        let recorded = info.files.iter().find(|f| f.name == name);
        match (recorded, path.exists()) {
            (None, false) => {}
            (None, true) => {
                return Err(refuse(format!(
                    "{} ({part}) is not among the files its run recorded in {PART_FILE}: it was added after the run; remove it or run the part again",
                    path.display()
                )))
            }
            (Some(_), false) => {
                return Err(refuse(format!(
                    "{} ({part}) is missing: its run wrote it; copy the whole part folder, or run the part again",
                    path.display()
                )))
            }
            (Some(expected), true) => {
                let found = file_digest(&path)?;
                if found != *expected {
                    return Err(refuse(format!(
                        "{} ({part}) is not the file its run wrote ({} bytes, CRC-32 {}; found {} bytes, CRC-32 {}): it was changed or damaged; copy it again or run the part again",
                        path.display(),
                        expected.bytes,
                        expected.crc32,
                        found.bytes,
                        found.crc32
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Write `info` as `dir/part.json`.
pub fn write_info(dir: &Path, info: &PartInfo) -> Result<()> {
    let path = dir.join(PART_FILE);
    let json = serde_json::to_vec_pretty(info)
        .map_err(|e| Error::invalid("part.json", format!("{}: {e}", path.display())))?;
    crate::runtime::output::atomic::write_atomically(&path, &json)
}

/// Read `dir/part.json`, naming the file when it is missing or not a part's.
pub fn read_info(dir: &Path) -> Result<PartInfo> {
    let path = dir.join(PART_FILE);
    let refuse = |why: String| Error::invalid("PART_DIRS", why);
    if !dir.exists() {
        return Err(refuse(format!(
            "{} does not exist: give the output folders of run SCENE --part K/P",
            dir.display()
        )));
    }
    if !dir.is_dir() {
        return Err(refuse(format!(
            "{} is a file, not a folder: give the output folders of run SCENE --part K/P",
            dir.display()
        )));
    }
    if !path.exists() {
        return Err(refuse(format!(
            "{} holds no part.json: it is not the output folder of a run --part K/P (give those, one per part)",
            dir.display()
        )));
    }
    // the scene's text and the strand list: bounded as a scene file is, twice over
    let bytes = crate::runtime::input::read_bounded(
        &path,
        2 * crate::runtime::input::TEXT_FILE_LIMIT,
        "part.json written by run --part",
    )
    .map_err(refuse)?;
    let info: PartInfo = serde_json::from_slice(&bytes).map_err(|e| {
        Error::invalid(
            "PART_DIRS",
            format!("{} is not a part's: {e}", path.display()),
        )
    })?;
    if info.format != PART_FORMAT {
        return Err(Error::invalid(
            "PART_DIRS",
            format!(
                "{} is not a part's (format {:?})",
                path.display(),
                info.format
            ),
        ));
    }
    Ok(info)
}

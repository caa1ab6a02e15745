//! `superhelix merge PART_DIRS... --out DIR`: the outputs of the parts of a split run
//! ([`crate::part`]) joined into those of the whole scene: one `frames.npy` (with its
//! times, index, held-tip and step reports), one `frames.json`, the node files, the
//! per-strand step report, and `hair.usda` and the pictures written from the joined
//! frames. For a scene whose strands do not act on each other the result is, byte for
//! byte, what one run of the whole scene writes (`tests/part_merge.rs`).

use crate::part::{read_info, PartInfo};
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use superhelix_runtime::output::atomic::io_error;
use superhelix_runtime::output::frames::{FrameLayout, FrameSink, FrameStore, FrameView};
use superhelix_runtime::output::nodes::{D1_FILE, NODES_FILE};
use superhelix_runtime::output::npy::{
    read_f64, write_f64_rows, NpyFrameSink, NpyFrameStore, HELD_FILE, NPY_FILE, STEPS_FILE,
    STRAND_STEPS_FILE,
};
use superhelix_runtime::output::plan::{prepare_out_dir, setup_layout, Formats};
use superhelix_runtime::output::preview::PreviewOptions;
use superhelix_runtime::output::products::write_products;
use superhelix_runtime::output::scenery::Scenery;
use superhelix_runtime::output::{FrameSteps, HeldEndFrame, JsonFrameSink, JsonFrameStore};

/// One part as merge reads it.
struct PartDir {
    dir: PathBuf,
    info: PartInfo,
}

fn refuse(why: String) -> Error {
    Error::invalid("PART_DIRS", why)
}

/// The parts of `dirs`, checked to be every part of one split run, ordered by K.
fn read_parts(dirs: &[PathBuf]) -> Result<Vec<PartDir>> {
    let mut parts = dirs
        .iter()
        .map(|d| {
            Ok(PartDir {
                dir: d.clone(),
                info: read_info(d)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let Some(first) = parts.first().map(|p| p.info.clone()) else {
        return Err(refuse("no part folder given".into()));
    };
    for p in &parts {
        let i = &p.info;
        if i.digest != first.digest || i.scene != first.scene {
            return Err(refuse(format!(
                "{} is a part of another scene than {}",
                p.dir.display(),
                parts[0].dir.display()
            )));
        }
        if i.part.count != first.part.count || i.formats != first.formats {
            return Err(refuse(format!(
                "{} is part {}/{} with formats {}, {} is part {}/{} with formats {}: parts of one split have the same P and formats",
                p.dir.display(),
                i.part.index,
                i.part.count,
                i.formats.join(","),
                parts[0].dir.display(),
                first.part.index,
                first.part.count,
                first.formats.join(","),
            )));
        }
    }
    parts.sort_by_key(|p| p.info.part.index);
    // the first K (from 1) not given exactly once, without a loop over P (a number read
    // from a file)
    let count = first.part.count;
    let given = |k: usize| parts.iter().filter(|p| p.info.part.index == k).count();
    let mut next = 1;
    for p in &parts {
        let k = p.info.part.index;
        if k != next {
            // k < next: k given again; k > next: next not given
            let wrong = k.min(next);
            return Err(refuse(format!(
                "part {wrong}/{count} is given {} times: give each of the {count} parts once",
                given(wrong)
            )));
        }
        next += 1;
    }
    if next <= count {
        return Err(refuse(format!(
            "part {next}/{count} is given 0 times: give each of the {count} parts once"
        )));
    }
    Ok(parts)
}

/// Where each strand of the whole scene is: (part position, index in the part).
fn placement(parts: &[PartDir], total: usize) -> Vec<(usize, usize)> {
    let mut at = vec![(0, 0); total];
    for (p, part) in parts.iter().enumerate() {
        for (j, &s) in part.info.strands.iter().enumerate() {
            at[s] = (p, j);
        }
    }
    at
}

/// Frames every part holds (refused when they differ: a part not finished).
fn common_frames(parts: &[PartDir], counts: &[usize], file: &str) -> Result<usize> {
    let first = counts.first().copied().unwrap_or(0);
    for (p, &n) in parts.iter().zip(counts) {
        if n != first {
            return Err(refuse(format!(
                "{} holds {n} frames in {file}, {} holds {first}: finish every part first (run --part K/P --resume DIR)",
                p.dir.display(),
                parts[0].dir.display()
            )));
        }
    }
    Ok(first)
}

/// The step reports of the parts at one frame, as one run of all their strands reports
/// it: the largest error and step, the summed counts, the smallest step taken.
fn join_steps(steps: impl Iterator<Item = Option<FrameSteps>>) -> Option<FrameSteps> {
    let mut out: Option<FrameSteps> = None;
    for s in steps.flatten() {
        let o = out.get_or_insert(FrameSteps::default());
        o.largest_error = o.largest_error.max(s.largest_error);
        o.steps += s.steps;
        o.rejected += s.rejected;
        // (0: no step)
        o.smallest_step = if o.smallest_step == 0.0 {
            s.smallest_step
        } else if s.smallest_step == 0.0 {
            o.smallest_step
        } else {
            o.smallest_step.min(s.smallest_step)
        };
        o.largest_step = o.largest_step.max(s.largest_step);
    }
    out
}

/// The held-tip reports of the parts at one frame, in the whole scene's order.
fn join_held(
    layout: &FrameLayout,
    parts: &[PartDir],
    held: &[Vec<HeldEndFrame>],
) -> Vec<HeldEndFrame> {
    let mut all: Vec<HeldEndFrame> = parts
        .iter()
        .zip(held)
        .flat_map(|(p, h)| {
            h.iter().map(|f| HeldEndFrame {
                strand: p.info.strands.get(f.strand).copied().unwrap_or(f.strand),
                ..*f
            })
        })
        .collect();
    all.sort_by_key(|h| h.strand);
    debug_assert_eq!(all.len(), layout.held_tips.len());
    all
}

/// The points of one frame of the whole scene from the parts' frames.
fn join_points(
    at: &[(usize, usize)],
    offsets: &[Vec<usize>],
    frames: &[Vec<[f64; 3]>],
    out: &mut Vec<[f64; 3]>,
) {
    out.clear();
    for &(p, j) in at {
        out.extend_from_slice(&frames[p][offsets[p][j]..offsets[p][j + 1]]);
    }
}

/// Refuse an output folder that is one of the parts' folders: merge reads the parts while
/// it writes, and never writes into its inputs.
fn refuse_input_as_output(parts: &[PartDir], out: &Path) -> Result<()> {
    let Ok(out_real) = out.canonicalize() else {
        // not there yet: no part can be it
        return Ok(());
    };
    for p in parts {
        if p.dir.canonicalize().ok().as_deref() == Some(out_real.as_path()) {
            return Err(Error::invalid(
                "--out",
                format!(
                    "{} is the folder of part {}/{} ({}): merge never writes into the folders it reads; give another --out",
                    out.display(),
                    p.info.part.index,
                    p.info.part.count,
                    p.dir.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Refuse a part whose strand list is not the one the split of `setup` gives it (a
/// changed `part.json` would put its strands' frames in other strands' places).
fn check_strands(parts: &[PartDir], setup: &crate::SimulationSetup) -> Result<()> {
    let count = parts[0].info.part.count;
    let strands = setup.strands.len();
    for p in parts {
        let total = p.info.total_strands;
        if total != strands || count > strands {
            return Err(refuse(format!(
                "{} says part {}/{count} of {total} strands, its scene has {strands}: the file was changed; run the part again",
                p.dir.join(crate::part::PART_FILE).display(),
                p.info.part.index,
            )));
        }
    }
    let expected = crate::part::split(setup, count);
    for p in parts {
        let k = p.info.part.index;
        if expected.get(k - 1) != Some(&p.info.strands) {
            return Err(refuse(format!(
                "{} lists strands that are not those of part {k}/{count} of its scene: the file was changed; run the part again",
                p.dir.join(crate::part::PART_FILE).display()
            )));
        }
    }
    Ok(())
}

/// A hidden folder inside the output folder that the merged files are written to, then
/// moved from into the output folder once every one of them is whole: a merge that
/// fails (a full disk, a damaged part) leaves the output folder as it was. Removed when
/// dropped.
struct Stage {
    dir: PathBuf,
}

impl Stage {
    fn new(out: &Path) -> Result<Stage> {
        let dir = out.join(format!(".superhelix-merge-{}", std::process::id()));
        if dir.exists() {
            std::fs::remove_dir_all(&dir).map_err(|e| io_error(&dir, e))?;
        }
        std::fs::create_dir(&dir).map_err(|e| io_error(&dir, e))?;
        Ok(Stage { dir })
    }

    /// Move the staged `files` into `out` (each a rename: a reader sees the old file or
    /// the new one); returns their new paths.
    fn commit(&self, out: &Path, files: Vec<PathBuf>) -> Result<Vec<PathBuf>> {
        files
            .into_iter()
            .map(|staged| {
                let target = out.join(staged.file_name().unwrap_or_default());
                std::fs::rename(&staged, &target).map_err(|e| io_error(&target, e))?;
                Ok(target)
            })
            .collect()
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Merge the parts in `dirs` into `out`; returns the files written.
///
/// Every part is checked first: its `part.json` (one split of one scene, each part
/// once, the strand list the split gives it) and the digests of its frame files
/// ([`crate::part::check_files`]). The output folder may not be one of the parts'; the
/// merged files are written whole to a hidden folder inside it and moved into it only
/// when all are written.
pub fn merge(dirs: &[PathBuf], out: &Path) -> Result<Vec<PathBuf>> {
    let parts = read_parts(dirs)?;
    refuse_input_as_output(&parts, out)?;
    let info = &parts[0].info;
    let (setup, _) =
        superhelix_runtime::parse_scene_reporting(&info.scene, Path::new(&info.scene_dir))?;
    check_strands(&parts, &setup)?;
    for p in &parts {
        crate::part::check_files(&p.dir, &p.info)?;
    }
    prepare_out_dir(out)?;
    let stage = Stage::new(out)?;
    let files = write_merged(&parts, &setup, &stage.dir)?;
    stage.commit(out, files)
}

/// The merged files of `parts`, written into `out`.
fn write_merged(
    parts: &[PartDir],
    setup: &crate::SimulationSetup,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let info = &parts[0].info;
    let layout = setup_layout(setup);
    let formats = Formats::from_cli(&info.formats)?;
    let at = placement(parts, info.total_strands);
    let mut files = Vec::new();
    if formats.npy {
        files.extend(merge_npy(parts, &layout, &at, out)?);
    }
    if formats.json {
        files.push(merge_json(parts, &layout, &at, out)?);
    }
    for (name, axis) in [(NODES_FILE, 1), (D1_FILE, 1), (STRAND_STEPS_FILE, 0)] {
        if parts[0].dir.join(name).exists() {
            files.push(merge_per_strand(parts, &at, name, axis, out)?);
        }
    }
    let products = Formats {
        json: false,
        npy: false,
        ..formats
    };
    if products != Formats::NONE {
        let scenery = Scenery::from_setup(setup)?;
        let view = PreviewOptions::default();
        let written = if formats.npy {
            let mut store = NpyFrameStore::open(&out.join(NPY_FILE))?;
            write_products(&mut store, &products, out, &view, &scenery)?
        } else {
            let mut store = JsonFrameStore::open(&out.join(crate::FRAMES_FILE))?;
            write_products(&mut store, &products, out, &view, &scenery)?
        };
        files.extend(written);
    }
    Ok(files)
}

/// `frames.npy` and its companions.
fn merge_npy(
    parts: &[PartDir],
    layout: &FrameLayout,
    at: &[(usize, usize)],
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let mut stores = parts
        .iter()
        .map(|p| NpyFrameStore::open(&p.dir.join(NPY_FILE)))
        .collect::<Result<Vec<_>>>()?;
    let counts: Vec<usize> = stores.iter().map(|s| s.frame_count()).collect();
    let frames = common_frames(parts, &counts, NPY_FILE)?;
    let offsets: Vec<Vec<usize>> = stores.iter().map(|s| s.layout().point_offsets()).collect();
    // the per-frame reports, whole
    let read_rows = |p: &PartDir, name: &str| -> Result<Option<(Vec<u64>, Vec<f64>)>> {
        let path = p.dir.join(name);
        match path.exists() {
            true => read_f64(&path).map(Some),
            false => Ok(None),
        }
    };
    let held_rows = parts
        .iter()
        .map(|p| read_rows(p, HELD_FILE))
        .collect::<Result<Vec<_>>>()?;
    let step_rows = parts
        .iter()
        .map(|p| read_rows(p, STEPS_FILE))
        .collect::<Result<Vec<_>>>()?;
    let mut sink = NpyFrameSink::create(out, layout)?;
    let (mut points, mut part_points) = (Vec::new(), vec![Vec::new(); parts.len()]);
    for k in 0..frames {
        for (store, buffer) in stores.iter_mut().zip(part_points.iter_mut()) {
            store.points(k, buffer)?;
        }
        join_points(at, &offsets, &part_points, &mut points);
        let held: Vec<Vec<HeldEndFrame>> = held_rows
            .iter()
            .map(|rows| match rows {
                Some((shape, values)) => {
                    let per = shape.get(1).copied().unwrap_or(0) as usize;
                    (0..per)
                        .map(|h| {
                            let row = &values[(k * per + h) * 7..(k * per + h + 1) * 7];
                            let mut reaction = [0.0; 6];
                            reaction.copy_from_slice(&row[1..7]);
                            HeldEndFrame {
                                strand: h,
                                drift: row[0],
                                reaction,
                            }
                        })
                        .collect()
                }
                None => Vec::new(),
            })
            .collect();
        // (the part's held rows are in its held_tips order: map them to its strands)
        let held: Vec<Vec<HeldEndFrame>> = held
            .into_iter()
            .zip(&stores)
            .map(|(rows, store)| {
                rows.into_iter()
                    .map(|h| HeldEndFrame {
                        strand: store
                            .layout()
                            .held_tips
                            .get(h.strand)
                            .copied()
                            .unwrap_or(h.strand),
                        ..h
                    })
                    .collect()
            })
            .collect();
        let steps = join_steps(step_rows.iter().map(|rows| {
            rows.as_ref().and_then(|(_, v)| {
                let r = v.get(k * 5..k * 5 + 5)?;
                Some(FrameSteps {
                    largest_error: r[0],
                    steps: r[1] as usize,
                    rejected: r[2] as usize,
                    smallest_step: r[3],
                    largest_step: r[4],
                })
            })
        }));
        let held = join_held(layout, parts, &held);
        let frame = FrameView {
            index: k,
            time: stores[0].time(k),
            state_time: stores[0].state_time(k),
            points: &points,
            q: &[],
            steps,
            held: &held,
        };
        sink.write_frame(&frame)?;
    }
    sink.finish()?;
    let mut files = vec![out.join(NPY_FILE)];
    for name in [
        superhelix_runtime::output::npy::TIMES_FILE,
        superhelix_runtime::output::npy::INDEX_FILE,
        STEPS_FILE,
        HELD_FILE,
    ] {
        if out.join(name).exists() {
            files.push(out.join(name));
        }
    }
    Ok(files)
}

/// `frames.json`.
fn merge_json(
    parts: &[PartDir],
    layout: &FrameLayout,
    at: &[(usize, usize)],
    out: &Path,
) -> Result<PathBuf> {
    let stores = parts
        .iter()
        .map(|p| JsonFrameStore::open(&p.dir.join(crate::FRAMES_FILE)))
        .collect::<Result<Vec<_>>>()?;
    let counts: Vec<usize> = stores.iter().map(|s| s.frame_count()).collect();
    let frames = common_frames(parts, &counts, crate::FRAMES_FILE)?;
    let offsets: Vec<Vec<usize>> = stores.iter().map(|s| s.layout().point_offsets()).collect();
    let q_offsets: Vec<Vec<usize>> = stores
        .iter()
        .map(|s| s.layout().coordinate_offsets())
        .collect();
    let path = out.join(crate::FRAMES_FILE);
    let mut sink = JsonFrameSink::create(&path, layout)?;
    let mut points = Vec::new();
    let mut q = Vec::new();
    for k in 0..frames {
        let part_points: Vec<Vec<[f64; 3]>> = stores
            .iter()
            .map(|s| s.frame_points(k).map(<[_]>::to_vec).unwrap_or_default())
            .collect();
        join_points(at, &offsets, &part_points, &mut points);
        q.clear();
        for &(p, j) in at {
            let part_q = stores[p].q(k).unwrap_or(&[]);
            q.extend_from_slice(&part_q[q_offsets[p][j]..q_offsets[p][j + 1]]);
        }
        let held: Vec<Vec<HeldEndFrame>> = stores.iter().map(|s| s.held(k).to_vec()).collect();
        let held = join_held(layout, parts, &held);
        let frame = FrameView {
            index: k,
            time: stores[0].time(k),
            state_time: stores[0].state_time(k),
            points: &points,
            q: &q,
            steps: join_steps(stores.iter().map(|s| s.steps(k))),
            held: &held,
        };
        sink.write_frame(&frame)?;
    }
    sink.finish()?;
    Ok(path)
}

/// A float64 file with one entry per strand along its axis `axis` (1 for the node files
/// of shape [frames, strands, ...], 0 for `strand_steps.npy` of shape [strands, 5]).
fn merge_per_strand(
    parts: &[PartDir],
    at: &[(usize, usize)],
    name: &str,
    axis: usize,
    out: &Path,
) -> Result<PathBuf> {
    let read = parts
        .iter()
        .map(|p| read_f64(&p.dir.join(name)))
        .collect::<Result<Vec<_>>>()?;
    let (shape0, _) = &read[0];
    let axis = axis.min(1);
    // rows before the strand axis (frames, or 1), and values per strand
    let outer = if axis == 1 { shape0[0] as usize } else { 1 };
    let per: usize = shape0[axis + 1..].iter().product::<u64>() as usize;
    let counts: Vec<usize> = read.iter().map(|(s, _)| s[0] as usize).collect();
    if axis == 1 {
        common_frames(parts, &counts, name)?;
    }
    let mut values = Vec::with_capacity(outer * at.len() * per);
    for f in 0..outer {
        for &(p, j) in at {
            let (shape, v) = &read[p];
            let strands = shape[axis] as usize;
            let start = (f * strands + j) * per;
            values.extend_from_slice(&v[start..start + per]);
        }
    }
    let path = out.join(name);
    let (rows, tail): (u64, Vec<u64>) = if axis == 1 {
        let mut tail = vec![at.len() as u64];
        tail.extend_from_slice(&shape0[2..]);
        (outer as u64, tail)
    } else {
        (at.len() as u64, shape0[1..].to_vec())
    };
    write_f64_rows(&path, &tail, rows, &values)?;
    Ok(path)
}

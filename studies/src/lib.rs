//! # superhelix-studies
//!
//! The studies and measurements of Super-Helix hair dynamics, as the library the
//! `superhelix` command, the integration tests and the Python module call: running a scene
//! to its outputs (plan, stream, products, checkpoints; a part of a split scene,
//! [`part`], and joining the parts, [`merge`]), checking a scene, re-rendering pictures
//! ([`render`]), and the measurements of `bench` ([`bench`]), `compare-kernels`
//! ([`compare`]), `quadrature-table` ([`quadrature_table`]), `study` ([`study`]),
//! `stress` ([`stress`]), `coulomb` and `coulomb-scaling` ([`coulomb`],
//! [`coulomb_scaling`]) and `electrostatics` ([`electrostatics_study`]). The runtime
//! (`superhelix-runtime`) and the generated fixed-N kernels of this build
//! (`superhelix-generated`) are re-exported.
#![warn(missing_docs)]

pub mod bench;
pub mod compare;
pub mod coulomb;
pub mod coulomb_scaling;
pub mod cpu_time;
pub mod electrostatics_study;
pub mod merge;
pub mod part;
pub mod quadrature_table;
pub mod render;
pub mod stress;
pub mod stress_ends;
pub mod study;
pub mod study_cost;
pub mod study_plot;
pub mod study_tolerance;

pub use superhelix_generated as generated;
pub use superhelix_runtime as runtime;
pub use superhelix_runtime::{
    parse_scene, validate_scene, Error, FieldError, FrameSource, Frames, HeadMotion, KernelFactory,
    Result, RunSummary, Simulation, SimulationSetup,
};

use runtime::groom::GroomReport;
pub use runtime::output::checkpoint::{Checkpoint, SceneIdentity};
use runtime::output::nodes::{NodesSink, D1_FILE, NODES_FILE};
use runtime::output::npy::{
    NpyFrameSink, NpyFrameStore, HELD_FILE, INDEX_FILE, NPY_FILE, STEPS_FILE, TIMES_FILE,
};
use runtime::output::preview::PreviewOptions;
use runtime::output::products::write_products;
use runtime::output::scenery::Scenery;
use runtime::output::{
    self, FrameSink, JsonFrameSink, JsonFrameStore, MemoryFrames, RunOutcome, StopReason,
};
pub use runtime::output::{Formats, OutputPlan};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// Name of the file `run` writes in its output directory.
pub const FRAMES_FILE: &str = "frames.json";

/// The generated kernels of this build: the generated fixed-N code for the N of
/// `superhelix_runtime::kernels::closed_form::sizes`, the moment assembly on the
/// generated closed forms for every other N (what `kernels = "auto"` uses).
pub fn kernel_factory() -> Option<&'static dyn KernelFactory> {
    Some(superhelix_runtime::kernels::closed_form::kernel_factory())
}

/// A running simulation of `setup` with this build's generated kernels, as the output
/// driver sees it.
pub fn open_simulation(setup: SimulationSetup) -> Result<Box<dyn FrameSource>> {
    Ok(Box::new(Simulation::new(setup, kernel_factory())?))
}

/// How `run` writes its output, besides the scene's `[output]` section.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunOptions {
    /// `--format`: replaces the scene's formats.
    pub formats: Option<Formats>,
    /// `--allow-large-output`: lifts the limit on the planned output size.
    pub allow_large_output: bool,
}

/// `--tolerance` of `run` and `validate` applied to `setup`: in
/// [[`MIN_TOLERANCE`](runtime::config::MIN_TOLERANCE),
/// [`MAX_TOLERANCE`](runtime::config::MAX_TOLERANCE)], on a dynamic scene (a static one
/// takes no time steps). Refused naming `--tolerance`, before anything is written.
pub fn apply_tolerance(setup: &mut SimulationSetup, tolerance: Option<f64>) -> Result<()> {
    let Some(t) = tolerance else {
        return Ok(());
    };
    let (lo, hi) = (
        runtime::config::MIN_TOLERANCE,
        runtime::config::MAX_TOLERANCE,
    );
    if !(lo..=hi).contains(&t) {
        return Err(Error::invalid(
            "--tolerance",
            format!("{t}: must be in [{lo:e}, {hi}] (the local error of a step, relative to the strand's length)"),
        ));
    }
    if setup.config.mode == runtime::config::Mode::Static {
        return Err(Error::invalid(
            "--tolerance",
            "the scene is static (mode = \"static\"): it takes no time steps, so no step tolerance; leave out --tolerance",
        ));
    }
    setup.config.tolerance = Some(t);
    Ok(())
}

/// The output plan of a parsed scene written to `out_dir` (the limit is not checked:
/// see [`OutputPlan::check_limit`]).
pub fn plan_output(setup: &SimulationSetup, out_dir: &Path, options: &RunOptions) -> OutputPlan {
    OutputPlan::new(
        &output::plan::setup_layout(setup),
        &setup.output,
        options.formats,
        options.allow_large_output,
        out_dir,
    )
}

/// What a run did and wrote.
#[derive(Debug)]
pub struct RunReport {
    /// Frames written, why the run stopped, the summary.
    pub outcome: RunOutcome,
    /// Every file written, in order.
    pub files: Vec<PathBuf>,
    /// Why the post-run files (hair.usda, previews, obj) could not all be written.
    pub products_error: Option<Error>,
}

/// Run a parsed scene on `source` and write the files of `plan` into `plan.dir`
/// (which must exist: see [`output::plan::prepare_out_dir`]): the frame files while
/// the run goes, then the post-run files from the frames written, also when the run
/// stops early (the stop flag, a divergence, a failed write). `progress(step, total)`
/// is called after every step. An error means nothing was simulated.
pub fn run_planned<S: FrameSource + ?Sized>(
    setup: &SimulationSetup,
    source: &mut S,
    plan: &OutputPlan,
    stop: &AtomicBool,
    progress: impl FnMut(usize, usize),
) -> Result<RunReport> {
    run_planned_with(setup, source, plan, stop, progress, None)
}

/// The checkpoints of a run ([`run_planned_with`]): what they are of, and the checkpoint
/// a resumed run goes on from.
#[derive(Debug, Clone)]
pub struct RunCheckpoints {
    /// The scene and options of the run.
    pub identity: SceneIdentity,
    /// The checkpoint to go on from (`None`: the run starts at t = 0).
    pub resume: Option<Checkpoint>,
}

impl RunCheckpoints {
    /// The checkpoints of a run of `scene_text` as `setup` (its parse, with the
    /// command-line options applied) under `plan`, going on from the checkpoint in
    /// `plan.dir` when `resume` (refused when it is of another scene, naming what
    /// differs, or damaged, naming the file; without one the run starts at t = 0).
    pub fn new(
        scene_text: &str,
        setup: &SimulationSetup,
        plan: &OutputPlan,
        tolerance: Option<f64>,
        part: Option<(usize, usize)>,
        resume: bool,
    ) -> Result<Self> {
        let identity = SceneIdentity {
            scene: scene_text.to_string(),
            tolerance,
            formats: plan.formats.names().iter().map(|s| s.to_string()).collect(),
            part,
            digest: output::checkpoint::setup_digest(setup),
            dt: None,
            folder: None,
        };
        let resume = match resume {
            true => output::checkpoint::read(&plan.dir)?,
            false => None,
        };
        if let Some(c) = &resume {
            if let Some(differs) = c.identity.difference(&identity) {
                return Err(Error::invalid(
                    "--resume",
                    format!(
                        "the checkpoint in {} is of another run: {differs}",
                        plan.dir.display()
                    ),
                ));
            }
            check_resumed_files(plan, c.point.frames)?;
        }
        Ok(Self { identity, resume })
    }
}

/// The frame files a resumed run appends to, each there and a file: a folder copied
/// without them, or one of them deleted or replaced by a folder, is refused naming the
/// file and what the user can do.
fn check_resumed_files(plan: &OutputPlan, frames: usize) -> Result<()> {
    let dir = &plan.dir;
    let missing = |what: String| {
        Error::invalid(
            "--resume",
            format!(
                "{what}, though the checkpoint in {} counts {frames} frames written: copy the run's folder whole, or remove {} to start again from t = 0",
                dir.display(),
                dir.join(output::checkpoint::CHECKPOINT_FILE).display()
            ),
        )
    };
    let state = |name: &str| {
        let path = dir.join(name);
        match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => None,
            Ok(_) => Some(format!("{} is not a file", path.display())),
            Err(_) => Some(format!("{} is missing", path.display())),
        }
    };
    for file in &plan.files {
        let name = file.name;
        if name == FRAMES_FILE {
            // streamed to frames.json.partial, renamed frames.json at the end
            let partial = format!("{FRAMES_FILE}.partial");
            if state(FRAMES_FILE).is_some() && state(&partial).is_some() {
                return Err(missing(format!(
                    "neither {} nor {} is there as a file",
                    dir.join(FRAMES_FILE).display(),
                    dir.join(&partial).display()
                )));
            }
        } else if [
            output::npy::NPY_FILE,
            output::npy::TIMES_FILE,
            NODES_FILE,
            D1_FILE,
        ]
        .contains(&name)
        {
            if let Some(why) = state(name) {
                return Err(missing(why));
            }
        }
    }
    Ok(())
}

/// [`run_planned`] with checkpoints every `plan.checkpoint_every` frames (none when it
/// is 0 or `checkpoints` is `None`), going on from `checkpoints.resume` when it is set:
/// `source` is restored to its state, the frame files are cut back to where it says they
/// ended and the run writes the frames after them.
pub fn run_planned_with<S: FrameSource + ?Sized>(
    setup: &SimulationSetup,
    source: &mut S,
    plan: &OutputPlan,
    stop: &AtomicBool,
    progress: impl FnMut(usize, usize),
    checkpoints: Option<RunCheckpoints>,
) -> Result<RunReport> {
    let layout = output::frame_layout(source, &setup.config, setup.samples_per_element);
    let formats = plan.formats;
    let json_path = plan.dir.join(FRAMES_FILE);
    let checkpoints = checkpoints.filter(|_| plan.checkpoint_every > 0);
    let (mut checkpoints, resume) = match checkpoints {
        Some(c) => {
            let (point, marks) = match c.resume {
                Some(ck) => {
                    source.restore(&ck.state)?;
                    (Some(ck.point), Some(ck.sinks))
                }
                None => (None, None),
            };
            let run = output::driver::Checkpoints {
                every: plan.checkpoint_every,
                dir: plan.dir.clone(),
                identity: c.identity,
                resume: point,
                written: 0,
            };
            (Some(run), marks)
        }
        None => (None, None),
    };
    // the sinks' marks in the order the sinks are made (json, npy, memory, nodes)
    let mut marks = resume.map(|m| m.into_iter());
    let mut next_mark = || -> Result<Option<Vec<u64>>> {
        match marks.as_mut() {
            Some(m) => m.next().map(Some).ok_or_else(|| {
                Error::invalid(
                    "--resume",
                    "the checkpoint names fewer frame files than the run writes",
                )
            }),
            None => Ok(None),
        }
    };
    let mut json = match formats.json {
        true => Some(match next_mark()? {
            Some(mark) => JsonFrameSink::resume(&json_path, &mark)?,
            None => JsonFrameSink::create(&json_path, &layout)?,
        }),
        false => None,
    };
    let mut npy = match formats.npy {
        true => Some(match next_mark()? {
            Some(mark) => NpyFrameSink::resume(&plan.dir, &layout, &mark)?,
            None => NpyFrameSink::create(&plan.dir, &layout)?,
        }),
        false => None,
    };
    let products = Formats {
        json: false,
        npy: false,
        ..formats
    };
    // the post-run files read the frames back from frames.npy or frames.json; only
    // without either are the frames kept in memory
    let mut memory = (products != Formats::NONE && !formats.json && !formats.npy)
        .then(|| MemoryFrames::new(layout.clone()));
    // each strand at evenly spaced arc length, whatever the formats
    if memory.is_some() {
        next_mark()?;
    }
    let mut nodes = match setup.output.nodes {
        Some(count) => {
            let strands: Vec<_> = setup.strands.iter().map(|s| &s.strand).collect();
            Some(match next_mark()? {
                Some(mark) => NodesSink::resume(&plan.dir, &strands, &setup.head, count, &mark)?,
                None => NodesSink::create(&plan.dir, &strands, &setup.head, count)?,
            })
        }
        None => None,
    };
    let mut sinks: Vec<&mut dyn FrameSink> = Vec::new();
    if let Some(sink) = json.as_mut() {
        sinks.push(sink);
    }
    if let Some(sink) = npy.as_mut() {
        sinks.push(sink);
    }
    if let Some(sink) = memory.as_mut() {
        sinks.push(sink);
    }
    if let Some(sink) = nodes.as_mut() {
        sinks.push(sink);
    }
    let outcome = output::driver::run_checkpointed(
        source,
        &setup.config,
        setup.samples_per_element,
        &mut sinks,
        stop,
        progress,
        checkpoints.as_mut(),
    );
    drop(sinks);
    let mut files = Vec::new();
    if formats.json && json_path.exists() {
        files.push(json_path.clone());
    }
    if formats.npy {
        for name in [NPY_FILE, TIMES_FILE, INDEX_FILE, STEPS_FILE, HELD_FILE] {
            let path = plan.dir.join(name);
            if path.exists() {
                files.push(path);
            }
        }
    }
    if nodes.is_some() {
        files.extend([NODES_FILE, D1_FILE].map(|name| plan.dir.join(name)));
    }
    let checkpoint = plan.dir.join(output::checkpoint::CHECKPOINT_FILE);
    if checkpoints.as_ref().is_some_and(|c| c.written > 0) && checkpoint.exists() {
        files.push(checkpoint);
    }
    let mut products_error = None;
    // a full disk stopped the run: nothing more can be written there (trying would only
    // bury the cause under the products' own "no space left")
    let disk_full = matches!(&outcome.stop, StopReason::Failed(e) if e.is_disk_full());
    // the error-controlled step's report per strand, whatever the formats
    if let Some(rows) = source.strand_steps().filter(|_| !disk_full) {
        match output::npy::write_strand_steps(&plan.dir, &rows) {
            Ok(path) => files.push(path),
            Err(e) => products_error = Some(e),
        }
    }
    if products != Formats::NONE && outcome.frames_written() > 0 && !disk_full {
        let view = PreviewOptions::default();
        let written = Scenery::from_setup(setup).and_then(|scenery| {
            let write = |store: &mut dyn output::FrameStore| {
                write_products(store, &products, &plan.dir, &view, &scenery)
            };
            match memory.as_mut() {
                Some(store) => write(store),
                None if formats.npy => {
                    NpyFrameStore::open(&plan.dir.join(NPY_FILE)).and_then(|mut s| write(&mut s))
                }
                None => JsonFrameStore::open(&json_path).and_then(|mut s| write(&mut s)),
            }
        });
        match written {
            Ok(written) => files.extend(written),
            Err(e) => products_error = Some(e),
        }
    }
    Ok(RunReport {
        outcome,
        files,
        products_error,
    })
}

/// Parse `scene_text`, simulate it and write its output (the scene's formats) into
/// `out_dir`, refusing a plan over the size limit. `progress(step, total)` is called
/// after every step. Returns the summary and the files written; a run that stops early
/// is an error (its frames are kept).
pub fn run_scene(
    scene_text: &str,
    out_dir: &Path,
    progress: impl FnMut(usize, usize),
) -> Result<(RunSummary, Vec<PathBuf>)> {
    let setup = parse_scene(scene_text)?;
    let plan = plan_output(&setup, out_dir, &RunOptions::default());
    plan.check_limit()?;
    output::plan::prepare_out_dir(out_dir)?;
    let mut source = open_simulation(setup.clone())?;
    let never = AtomicBool::new(false);
    let report = run_planned(&setup, source.as_mut(), &plan, &never, progress)?;
    match report.outcome.stop {
        StopReason::Failed(e) => Err(e),
        StopReason::Completed | StopReason::Interrupted => match report.products_error {
            Some(e) => Err(e),
            None => Ok((report.outcome.summary, report.files)),
        },
    }
}

/// The setup of a scene `run` would accept, or every problem found: those of the scene
/// file and those `run` meets before its first step (the simulation is built with this
/// build's generated kernels and every strand's initial state is checked).
pub fn check_scene(scene_text: &str) -> std::result::Result<SimulationSetup, Vec<FieldError>> {
    check_scene_at(scene_text, Path::new(""))
}

/// [`check_scene`] for a scene file in folder `scene_dir`: relative file paths in the
/// scene (a mesh body's `path`) are resolved against that folder.
pub fn check_scene_at(
    scene_text: &str,
    scene_dir: &Path,
) -> std::result::Result<SimulationSetup, Vec<FieldError>> {
    check_scene_reporting(scene_text, scene_dir).map(|(setup, _)| setup)
}

/// [`check_scene_at`], with what the scene's `[[grooms]]` report (each curve's fit
/// error, the roots' spread, the sag-free change), one per groom.
pub fn check_scene_reporting(
    scene_text: &str,
    scene_dir: &Path,
) -> std::result::Result<(SimulationSetup, Vec<GroomReport>), Vec<FieldError>> {
    let parsed = runtime::parse_scene_reporting(scene_text, scene_dir);
    // a scene beyond the machine's memory is refused on its estimate alone, before any
    // simulation is built (listing its other problems would build one)
    if let Ok((setup, _)) = &parsed {
        if let Err(Error::Invalid(errors)) = runtime::check_memory(setup) {
            return Err(errors);
        }
    }
    let built = parsed.and_then(|parsed| {
        build_in_chunks(&parsed.0)?;
        Ok(parsed)
    });
    // the failure path lists every problem, not only the first stage's
    built.map_err(|_| runtime::validate_scene_at(scene_text, scene_dir, kernel_factory()))
}

/// Build the simulation of `setup` as `run` would (after command-line options changed
/// it: `--tolerance`, `--part`), to meet every problem `run` meets before its first
/// step, within the memory [`check_scene_reporting`] allows itself.
pub fn check_setup(setup: &SimulationSetup) -> Result<()> {
    runtime::check_memory(setup)?;
    build_in_chunks(setup)
}

/// Strands built at once by [`check_scene_reporting`] when they do not act on each
/// other, at most: what bounds a validation's memory (a run holds every strand at once).
pub const VALIDATE_CHUNK: usize = 256;

/// The estimated memory of the strands built at once by [`check_scene_reporting`], at
/// most (fewer than [`VALIDATE_CHUNK`] strands of many elements), bytes.
pub const VALIDATE_BYTES: u64 = 256_000_000;

/// Build the simulation of `setup` as `run` would, to meet every problem it meets before
/// its first step, holding at most [`VALIDATE_CHUNK`] strands (and about
/// [`VALIDATE_BYTES`]) at once when they do not act on each other (no electrostatics, no
/// hair–hair contacts): each strand's checks are its own, on the engine the whole scene
/// gets.
fn build_in_chunks(setup: &SimulationSetup) -> Result<()> {
    let interacting = setup.electrostatics.is_some()
        || setup
            .contacts
            .as_ref()
            .is_some_and(|c| c.hair_hair.is_some());
    let (engine, _) = runtime::engine_for(setup);
    let strands = setup.strands.len().max(1) as u64;
    let per_strand = runtime::memory_plan::estimate(setup, engine).bytes / strands;
    let chunk = (VALIDATE_BYTES / per_strand.max(1)).clamp(1, VALIDATE_CHUNK as u64) as usize;
    if interacting || setup.strands.len() <= chunk {
        return Simulation::new(setup.clone(), kernel_factory()).map(|_| ());
    }
    let mut part = SimulationSetup {
        strands: Vec::new(),
        ..setup.clone()
    };
    part.config.engine = engine;
    for strands in setup.strands.chunks(chunk) {
        part.strands = strands.to_vec();
        Simulation::new(part.clone(), kernel_factory())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene of 301 independent strands is validated 256 strands at a time: a problem
    /// that only building the simulation finds (RK4's stability limit at dt) in the last
    /// strand, in the second chunk, is still found and named; without it the scene passes.
    #[test]
    fn validation_in_chunks_finds_a_problem_of_a_later_chunk() {
        let scene = |stiff: &str| {
            format!(
                "[simulation]\nintegrator = \"rk4\"\ndt = 2e-7\nduration = 2e-6\n[output]\nformats = [\"npy\"]\n\
                 [[patches]]\nname = \"soft\"\ncount = [15, 20]\nsize = [0.05, 0.05]\nlength = 0.2\nelements = 3\nyoungs_modulus = 1e6\n\
                 [[patches]]\nname = \"last\"\ncount = [1, 1]\nsize = [0.0, 0.0]\ncenter = [0.1, 0.0, 0.0]\n{stiff}\n"
            )
        };
        let soft = scene("length = 0.2\nelements = 3\nyoungs_modulus = 1e6");
        match check_scene(&soft) {
            Ok(setup) => assert_eq!(setup.strands.len(), 301),
            Err(e) => panic!("{e:?}"),
        }
        let stiff = scene("length = 0.02\nelements = 6\nyoungs_modulus = 1e12");
        let Err(errors) = check_scene(&stiff) else {
            panic!("the stiff last strand was not found");
        };
        assert_eq!(errors.len(), 1, "{errors:?}");
        assert_eq!(errors[0].field, "simulation.dt", "{errors:?}");
        assert!(errors[0].message.contains("strands[300]"), "{errors:?}");
    }

    /// `scenes/cantilever.toml` (incompressible, ν = 0.5) bends as beam theory says:
    /// δ = F L³/(3EI), less the midpoint-rule error 1/(4N²) of N elements of constant
    /// curvature (`runtime/tests/physics.rs`); the load keeps δ/L ≈ 2.7e-3, so geometric
    /// nonlinearity (of order (δ/L)² ≈ 7e-6) is below the 1e-4 tolerance.
    #[test]
    fn the_cantilever_scene_is_incompressible_and_deflects_as_beam_theory() {
        let text = include_str!("../../scenes/cantilever.toml");
        let setup = match parse_scene(text) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let strand = setup.strands[0].strand.clone();
        let m = strand.material;
        assert!(
            (m.stiffness[0] / m.stiffness[1] - 2.0 / 3.0).abs() < 1e-14,
            "G = E/3"
        );
        let length: f64 = strand.geometry.lengths.iter().sum();
        let n = strand.geometry.elements() as f64;
        let force = -strand.point_loads[0].force.z;
        let beam = force * length.powi(3) / (3.0 * m.stiffness[1]);
        let mut sim = match Simulation::new(setup, kernel_factory()) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        };
        let report = match sim.solve_static() {
            Ok(r) => r[0],
            Err(e) => panic!("{e}"),
        };
        assert!(report.converged, "{report:?}");
        let tip = -sim.position_at(0, length).z;
        let expected = beam * (1.0 - 1.0 / (4.0 * n * n));
        assert!(
            (tip / expected - 1.0).abs() < 1e-4,
            "tip {tip:e} vs {expected:e} (beam theory {beam:e})"
        );
    }
}

//! `superhelix run [SCENE] [--out DIR]`: simulate a scene, streaming its frames to DIR,
//! then write the pictures and the USD stage. Ctrl-C stops the run between two steps and
//! keeps every frame written.

use super::common::{
    end_phase, frames_message, phase, progress_bar, read_scene, scene_dir, RunChoices,
};
use clap::Args;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use superhelix_studies::runtime::output::plan::prepare_out_dir;
use superhelix_studies::runtime::output::StopReason;
use superhelix_studies::Error;

/// Arguments of `run`.
#[derive(Args)]
pub struct RunArgs {
    /// Scene file (TOML); without it, the built-in demo scene.
    scene: Option<PathBuf>,
    /// Output directory.
    #[arg(long, value_name = "DIR", default_value = "out")]
    out: PathBuf,
    /// What to simulate and write: --format, --allow-large-output, --tolerance, --part.
    #[command(flatten)]
    choices: RunChoices,
    /// Go on from the checkpoint in the output directory (--out) of an earlier run of the
    /// same scene, appending to its frames (docs/output.md#checkpoints-and-resume); without
    /// a checkpoint there, the run starts at t = 0.
    #[arg(long, value_name = "DIR")]
    resume: Option<PathBuf>,
}

/// Raised by Ctrl-C: the run stops between two steps and keeps its frames.
static STOP: AtomicBool = AtomicBool::new(false);

/// Run `run`.
pub fn run(args: RunArgs) -> Result<ExitCode, Error> {
    let out: &Path = args.resume.as_deref().unwrap_or(&args.out);
    if let Some(dir) = &args.resume {
        if dir.exists() && !dir.is_dir() {
            return Err(Error::invalid(
                "--resume",
                format!(
                    "{} is a file, not a folder: give the output folder of an earlier run of this scene",
                    dir.display()
                ),
            ));
        }
    }
    if args.resume.is_some() && args.out != Path::new("out") && args.out != out {
        return Err(Error::invalid(
            "--out",
            format!(
                "--resume {} writes into the run's own directory; leave out --out {}",
                out.display(),
                args.out.display()
            ),
        ));
    }
    let (text, dir) = match &args.scene {
        Some(path) => (read_scene(path)?, scene_dir(path)),
        None => (superhelix::DEFAULT_SCENE.to_string(), Path::new("")),
    };
    let reading = phase("reading the scene (fitting its grooms, their rest shapes)");
    let parsed = superhelix_studies::runtime::parse_scene_reporting(&text, dir);
    end_phase(reading);
    let (mut setup, grooms) = parsed?;
    superhelix_studies::apply_tolerance(&mut setup, args.choices.tolerance)?;
    // a scene beyond the machine's memory is refused on its estimate before anything
    // scales with it (the digests below format every strand's numbers); a part is
    // checked on its own strands when its simulation is built
    if args.choices.part.is_none() {
        superhelix_studies::runtime::check_memory(&setup)?;
    }
    // the digest of the whole scene, which every part names
    let whole = superhelix_studies::runtime::output::checkpoint::setup_digest(&setup);
    if args.choices.part.is_some() {
        // (validate says it of every scene with hair–hair contacts)
        if let Some(note) = superhelix_studies::part::hair_hair_note(&setup) {
            println!("{note}");
        }
    }
    let part_strands = args.choices.take_part(&mut setup)?;
    for groom in &grooms {
        println!("{groom}");
    }
    let options = args.choices.run_options()?;
    let plan = superhelix_studies::plan_output(&setup, out, &options);
    println!("{plan}");
    if let Some(note) = &plan.note {
        println!("{note}");
    }
    plan.check_limit()?;
    let checkpoints = superhelix_studies::RunCheckpoints::new(
        &text,
        &setup,
        &plan,
        args.choices.tolerance,
        args.choices.part.map(|p| (p.index, p.count)),
        args.resume.is_some(),
    )?;
    match (&checkpoints.resume, args.resume.is_some()) {
        (Some(c), _) => println!(
            "resuming from the checkpoint at frame {} of {} (t = {:.4} s)",
            c.point.frames, plan.frames, c.point.time
        ),
        (None, true) => println!("no checkpoint in {}: starting at t = 0", out.display()),
        (None, false) => {}
    }
    if plan.checkpoint_every > 0 {
        println!(
            "checkpoints: every {} frames ({})",
            plan.checkpoint_every,
            out.join(superhelix_studies::runtime::output::checkpoint::CHECKPOINT_FILE)
                .display()
        );
    }
    prepare_out_dir(out)?;
    // a run from t = 0 leaves no earlier run's checkpoint or part file behind
    let stale = [
        (
            checkpoints.resume.is_none(),
            superhelix_studies::runtime::output::checkpoint::CHECKPOINT_FILE,
        ),
        (part_strands.is_none(), superhelix_studies::part::PART_FILE),
    ];
    for (_, name) in stale.iter().filter(|(stale, _)| *stale) {
        let path = out.join(name);
        if path.exists() {
            std::fs::remove_file(&path)
                .map_err(|e| superhelix_studies::runtime::output::atomic::io_error(&path, e))?;
        }
    }
    // part.json without digests while the run goes on: merge refuses a part until its
    // run has written its last frame and recorded its frame files
    let mut part_info = None;
    if let Some((part, strands, total)) = part_strands {
        let info = superhelix_studies::part::PartInfo {
            format: superhelix_studies::part::PART_FORMAT.to_string(),
            part,
            strands,
            total_strands: total,
            scene: text.clone(),
            scene_dir: std::path::absolute(dir)
                .unwrap_or_else(|_| dir.to_path_buf())
                .to_string_lossy()
                .into_owned(),
            digest: format!("{whole:016x}"),
            formats: plan.formats.names().iter().map(|s| s.to_string()).collect(),
            files: Vec::new(),
        };
        superhelix_studies::part::write_info(out, &info)?;
        part_info = Some(info);
    }
    // A second Ctrl-C ends the process at once (the frames written stay readable).
    let handler = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    if let Err(e) = handler {
        eprintln!("warning: Ctrl-C will not stop the run cleanly: {e}");
    }
    let building = phase("building the simulation");
    let source = superhelix_studies::open_simulation(setup.clone());
    end_phase(building);
    let mut source = source?;
    let bar = progress_bar();
    let started = std::time::Instant::now();
    let frames = plan.frames;
    let report = superhelix_studies::run_planned_with(
        &setup,
        source.as_mut(),
        &plan,
        &STOP,
        |step, total| {
            if let Some(bar) = &bar {
                bar.set_length(total as u64);
                bar.set_position(step as u64);
                if step >= total {
                    bar.set_message("writing the files made from the frames (USD, pictures)");
                } else {
                    let elapsed = started.elapsed().as_secs_f64();
                    bar.set_message(frames_message(step, total, frames, elapsed));
                }
            }
        },
        Some(checkpoints),
    );
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
    let report = report?;
    for file in &report.files {
        println!("wrote {}", file.display());
    }
    if let Some(e) = &report.products_error {
        eprintln!("error: {e}");
    }
    let outcome = &report.outcome;
    let kept = format!(
        "{} of {} frames written to {}",
        outcome.frames_written(),
        outcome.planned_frames,
        out.display()
    );
    // what the run held at its peak against what validate estimated for it
    if let Some(peak) = superhelix_studies::runtime::memory_plan::peak_memory() {
        let (engine, _) = superhelix_studies::runtime::engine_for(&setup);
        let estimate = superhelix_studies::runtime::memory_plan::estimate_with(
            &setup,
            engine,
            plan.formats.usda,
        );
        println!(
            "memory: {:.1} MB at peak (estimated {:.1} MB)",
            peak as f64 / 1e6,
            estimate.bytes as f64 / 1e6
        );
    }
    match &outcome.stop {
        StopReason::Completed => {
            if let Some(info) = &mut part_info {
                superhelix_studies::part::record_files(out, info)?;
            }
            println!("{}", outcome.summary);
            Ok(match report.products_error {
                Some(_) => ExitCode::FAILURE,
                None => ExitCode::SUCCESS,
            })
        }
        StopReason::Interrupted => {
            eprintln!("interrupted at t = {:.3} s: {kept}", outcome.time);
            Ok(ExitCode::from(130))
        }
        StopReason::Failed(e) => {
            eprintln!("error: {e}");
            eprintln!("{kept}");
            Ok(ExitCode::FAILURE)
        }
    }
}

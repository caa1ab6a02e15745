//! Plumbing shared by the commands: reading a scene, the progress bar, parsing the names
//! of options, the worker pool and the error report.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;
use superhelix_studies::runtime::config::{IntegratorKind, KernelChoice};
use superhelix_studies::runtime::model::material::Preset;
use superhelix_studies::Error;

/// The folder of the scene file at `path`: relative file paths in the scene (a mesh
/// body's `path`) are resolved against it.
pub fn scene_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// The text of the scene file at `path` (a regular file of at most
/// [`superhelix_studies::runtime::input::TEXT_FILE_LIMIT`] bytes of UTF-8).
pub fn read_scene(path: &Path) -> Result<String, Error> {
    superhelix_studies::runtime::input::read_text_bounded(
        path,
        superhelix_studies::runtime::input::TEXT_FILE_LIMIT,
        "scene file (TOML)",
    )
    .map_err(|e| Error::invalid("SCENE", e))
}

/// A run's progress bar on stderr, only when stderr is a terminal: the frames done,
/// the time per frame and the time left ([`frames_message`]).
pub fn progress_bar() -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) = ProgressStyle::with_template("{bar:30} {msg}") {
        bar.set_style(style);
    }
    Some(bar)
}

/// What the run's bar says after `step` of `steps` steps, `elapsed` seconds in, for a run
/// of `frames` frames: the frame reached, the time per frame so far and the time left at
/// that rate.
pub fn frames_message(step: usize, steps: usize, frames: usize, elapsed: f64) -> String {
    let steps = steps.max(1);
    let step = step.min(steps);
    // frames are spread evenly over the steps (the first at t = 0)
    let frame = (step * frames.saturating_sub(1)).div_ceil(steps) + 1;
    let frame = frame.min(frames);
    let done = step as f64 / steps as f64;
    let per_frame = if frame > 1 {
        elapsed / (frame - 1) as f64
    } else {
        0.0
    };
    let left = if done > 0.0 {
        elapsed * (1.0 - done) / done
    } else {
        0.0
    };
    format!(
        "frame {frame}/{frames} · {} per frame · {} left",
        seconds(per_frame),
        seconds(left)
    )
}

/// A duration for people: `0.42 s`, `12 s`, `3 min 5 s`, `2 h 4 min`.
fn seconds(s: f64) -> String {
    if s < 10.0 {
        format!("{s:.2} s")
    } else if s < 60.0 {
        format!("{s:.0} s")
    } else if s < 3600.0 {
        format!("{} min {} s", (s / 60.0) as u64, (s % 60.0) as u64)
    } else {
        format!(
            "{} h {} min",
            (s / 3600.0) as u64,
            ((s % 3600.0) / 60.0) as u64
        )
    }
}

/// A spinner on stderr saying what a long phase without steps is doing (reading and
/// fitting a scene, building the simulation, writing the pictures), with the time it has
/// taken; only when stderr is a terminal. Cleared by `finish_and_clear`.
pub fn phase(what: &str) -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let spinner = ProgressBar::new_spinner();
    if let Ok(style) = ProgressStyle::with_template("{spinner} {msg} {elapsed}") {
        spinner.set_style(style);
    }
    spinner.set_message(what.to_string());
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    Some(spinner)
}

/// End a [`phase`].
pub fn end_phase(spinner: Option<ProgressBar>) {
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
}

/// `--integrator NAME`.
pub fn integrator(name: &str) -> Result<IntegratorKind, Error> {
    IntegratorKind::from_name(name).ok_or_else(|| {
        Error::invalid(
            "--integrator",
            "must be linearly-implicit-euler, newton-implicit-euler, bdf2 or rk4",
        )
    })
}

/// `--kernels NAME`.
pub fn kernels(name: &str) -> Result<KernelChoice, Error> {
    KernelChoice::from_name(name)
        .ok_or_else(|| Error::invalid("--kernels", "must be auto, generated, moment or generic"))
}

/// `--preset NAME`.
pub fn preset(name: &str) -> Result<Preset, Error> {
    Preset::from_name(name)
        .ok_or_else(|| Error::invalid("--preset", "must be smooth, wavy, curly or fuzzy"))
}

/// Run `f` on a pool of `threads` workers (`--threads`), or on the global pool.
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> Result<T, Error> + Send,
) -> Result<T, Error> {
    match threads {
        None => f(),
        Some(0) => Err(Error::invalid("--threads", "must be >= 1")),
        Some(t) => rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .map_err(|e| Error::invalid("--threads", format!("cannot start {t} threads: {e}")))?
            .install(f),
    }
}

/// The options of `run` that change what a run simulates or writes, which `validate`
/// takes too and checks as `run` does.
#[derive(clap::Args)]
pub struct RunChoices {
    /// Files to write, replacing the scene's [output] formats: json, npy, usda, png,
    /// gif, obj, preview (= png + gif); repeatable or comma-separated.
    #[arg(long, value_name = "FORMATS")]
    pub format: Vec<String>,
    /// Write the output even when its planned size exceeds the limit (2 GB, or the
    /// scene's [output] max_bytes).
    #[arg(long)]
    pub allow_large_output: bool,
    /// The local error each strand's step may make, relative to its length, replacing the
    /// scene's [simulation] tolerance: error-controlled steps (docs/time-stepping.md).
    #[arg(long, value_name = "TOL", allow_negative_numbers = true)]
    pub tolerance: Option<f64>,
    /// Simulate part K of P of the strands (balanced by their expected cost), for
    /// `superhelix merge` to join (docs/output.md#a-head-split-across-machines).
    #[arg(long, value_name = "K/P")]
    pub part: Option<superhelix_studies::part::Part>,
}

impl RunChoices {
    /// `--part K/P` applied to `setup` (refused as [`superhelix_studies::part::part_setup`]
    /// refuses), with the line that says so: the part, the whole scene's strand indices it
    /// holds and the whole scene's strand count; `None` without `--part`.
    pub fn take_part(
        &self,
        setup: &mut superhelix_studies::SimulationSetup,
    ) -> Result<Option<(superhelix_studies::part::Part, Vec<usize>, usize)>, Error> {
        let Some(part) = self.part else {
            return Ok(None);
        };
        let total = setup.strands.len();
        let (reduced, strands) = superhelix_studies::part::part_setup(setup, part)?;
        println!(
            "part {}/{}: {} of {total} strands",
            part.index,
            part.count,
            strands.len()
        );
        *setup = reduced;
        Ok(Some((part, strands, total)))
    }

    /// `--format` and `--allow-large-output` as the library takes them.
    pub fn run_options(&self) -> Result<superhelix_studies::RunOptions, Error> {
        Ok(superhelix_studies::RunOptions {
            formats: match self.format.is_empty() {
                true => None,
                false => Some(superhelix_studies::Formats::from_cli(&self.format)?),
            },
            allow_large_output: self.allow_large_output,
        })
    }
}

/// Whether an error's field names a scene field (`simulation.dt`, `strands[2].length`)
/// rather than an option (`--out`), a command-line argument (`PART_DIRS`, in capitals)
/// or the output plan (`output`).
fn is_scene_field(field: &str) -> bool {
    !(field.starts_with("--")
        || field == "output"
        || !field.bytes().any(|b| b.is_ascii_lowercase()))
}

/// Print an error on stderr.
pub fn report(e: &Error) {
    match e {
        // options, arguments and the output plan are not scene fields
        Error::Invalid(problems) if problems.iter().all(|p| !is_scene_field(&p.field)) => {
            for p in problems {
                eprintln!("error: {p}");
            }
        }
        Error::Invalid(problems) => {
            eprintln!("error: invalid scene:");
            for p in problems {
                eprintln!("  {p}");
            }
        }
        other => eprintln!("error: {other}"),
    }
}

/// The deepest split of a step named by `--max-split-depth`: 0 to the default (8).
pub fn split_depth(d: usize) -> Result<usize, Error> {
    let max = superhelix_studies::runtime::config::SimulationConfig::default().max_split_depth;
    if d > max {
        return Err(Error::invalid(
            "--max-split-depth",
            format!("{d}: must be in 0..={max}"),
        ));
    }
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bar_says_the_frame_the_time_per_frame_and_the_time_left() {
        // 90 steps, 31 frames (frame 0 and one every 3 steps): 30 steps in 12 s
        assert_eq!(
            frames_message(30, 90, 31, 12.0),
            "frame 11/31 · 1.20 s per frame · 24 s left"
        );
        assert_eq!(
            frames_message(0, 90, 31, 0.0),
            "frame 1/31 · 0.00 s per frame · 0.00 s left"
        );
        assert_eq!(
            frames_message(90, 90, 31, 200.0),
            "frame 31/31 · 6.67 s per frame · 0.00 s left"
        );
        assert_eq!(
            frames_message(1, 2, 1, 4000.0),
            "frame 1/1 · 0.00 s per frame · 1 h 6 min left"
        );
        assert_eq!(seconds(185.0), "3 min 5 s");
    }
}

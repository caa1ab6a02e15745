//! Plumbing shared by the commands: reading a scene, the progress bar, parsing the names
//! of options, the worker pool and the error report.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::Path;
use superhelix::runtime::config::{IntegratorKind, KernelChoice};
use superhelix::runtime::model::material::Preset;
use superhelix::Error;

/// The folder of the scene file at `path`: relative file paths in the scene (a mesh
/// body's `path`) are resolved against it.
pub fn scene_dir(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// The text of the scene file at `path` (a regular file of at most
/// [`superhelix::runtime::input::TEXT_FILE_LIMIT`] bytes of UTF-8).
pub fn read_scene(path: &Path) -> Result<String, Error> {
    superhelix::runtime::input::read_text_bounded(
        path,
        superhelix::runtime::input::TEXT_FILE_LIMIT,
        "scene file (TOML)",
    )
    .map_err(|e| Error::invalid("SCENE", e))
}

/// A progress bar on stderr, only when stderr is a terminal.
pub fn progress_bar() -> Option<ProgressBar> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = ProgressBar::new(0);
    if let Ok(style) =
        ProgressStyle::with_template("{bar:40} {pos}/{len} steps {elapsed} (eta {eta})")
    {
        bar.set_style(style);
    }
    Some(bar)
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
    let max = superhelix::runtime::config::SimulationConfig::default().max_split_depth;
    if d > max {
        return Err(Error::invalid(
            "--max-split-depth",
            format!("{d}: must be in 0..={max}"),
        ));
    }
    Ok(d)
}

//! Scene files: TOML, all SI, read into a [`SimulationSetup`].
//!
//! The text is parsed by the `toml` crate (syntax errors become [`Error::Parse`] with
//! line and column); the resulting table is then read field by field by a path-tracking
//! reader that records every problem — wrong type, value out of range, unknown field,
//! inconsistent fields — with its path (`strands[2].length`) and the allowed range, so a
//! scene with several mistakes reports all of them at once ([`Error::Invalid`]). Nothing
//! here panics on any input.
//!
//! `docs/scene-format.md` documents every field, its unit, default and
//! allowed range.

mod assembly;
mod bodies;
mod contacts;
mod electrostatics;
mod ends;
mod groom;
mod head;
mod reader;
mod render;
mod strands;

/// Gravity, m/s² per component: up to 100 g.
pub const MAX_GRAVITY: f64 = 1e3;

use crate::config::total_steps;
use crate::config::FieldStiffness;
use crate::config::{
    Engine, IntegratorKind, KernelChoice, Mode, SimulationConfig, SimulationSetup,
};
use crate::error::{Error, FieldError, Result};
use crate::forces::environment::Environment;
use crate::groom::GroomReport;
use crate::kernels::generic::QuadratureRule;
use crate::kernels::kernel::KernelFactory;
use crate::model::humidity::{HumidityScaling, MAX_HUMIDITY, MIN_HUMIDITY};
use crate::output::plan::FORMAT_NAMES;
use crate::output::{Formats, OutputSettings};
use crate::simulation::Simulation;
use reader::{Bound, Errors, Node, Range};
use std::path::Path;
use strands::StrandDefaults;
use superhelix_kernels::energy::MAX_SUBSTEP_DEPTH;
use toml::{Table, Value};

pub use assembly::MAX_STRANDS;
pub use strands::{DEFAULT_ELEMENTS, MAX_ELEMENTS, MAX_POINT_LOAD};

/// Largest time step, seconds: beyond it a run is meaningless.
pub const MAX_DT: f64 = 1.0;
/// Most time steps of a run.
pub const MAX_STEPS: f64 = 1e7;
/// Largest output frame rate, frames per second.
pub const MAX_OUTPUT_FPS: f64 = 10_000.0;
/// Most frames of a run.
pub const MAX_FRAMES: f64 = 1e6;
/// Largest Gauss–Legendre order of `quadrature = n`.
pub const MAX_QUADRATURE_ORDER: i64 = 64;
/// Most centreline points written per element.
pub const MAX_SAMPLES_PER_ELEMENT: i64 = 64;
/// Largest `[output] max_bytes` (1 EB).
pub const MAX_OUTPUT_BYTES: f64 = 1e18;
/// Centreline points written per element by default.
pub const DEFAULT_SAMPLES_PER_ELEMENT: usize = 4;

/// Parse and validate a scene. Every problem found is listed in [`Error::Invalid`];
/// a TOML syntax error is [`Error::Parse`]. Relative file paths in the scene (a mesh
/// body's `path`) are taken as they are, i.e. relative to the working directory: a scene
/// read from a file is parsed with [`parse_scene_at`].
pub fn parse_scene(text: &str) -> Result<SimulationSetup> {
    parse_scene_at(text, Path::new(""))
}

/// [`parse_scene`] for a scene file in folder `scene_dir`: relative file paths in it are
/// resolved against that folder.
pub fn parse_scene_at(text: &str, scene_dir: &Path) -> Result<SimulationSetup> {
    parse_scene_reporting(text, scene_dir).map(|(setup, _)| setup)
}

/// [`parse_scene_at`], with what the scene's `[[grooms]]` report (the fit errors of
/// curves, the roots' spread, the sag-free change), one per groom in order.
pub fn parse_scene_reporting(
    text: &str,
    scene_dir: &Path,
) -> Result<(SimulationSetup, Vec<GroomReport>)> {
    let table: Table = text
        .parse()
        .map_err(|e: toml::de::Error| Error::Parse(describe_syntax_error(text, &e)))?;
    let errors = Errors::default();
    let parsed = read_scene(Node::root(&table, Errors::clone(&errors)), scene_dir);
    let errors = errors.take();
    if errors.is_empty() {
        Ok(parsed)
    } else {
        Err(Error::Invalid(errors))
    }
}

/// Every problem of a scene (empty when it is valid), with no generated kernels (see
/// [`validate_scene_with`]). A syntax error is reported as one problem of the field
/// `<toml>`.
pub fn validate_scene(text: &str) -> Vec<FieldError> {
    validate_scene_with(text, None)
}

/// Every problem of a scene (empty when it is valid): those of [`parse_scene`], then
/// those [`Simulation::new`] finds with the kernels of `generated` (a missing generated
/// kernel, an initial state that is not finite, a dt beyond RK4's stability limit), so
/// that a scene this accepts runs its first step. A syntax error is reported as one
/// problem of the field `<toml>`.
pub fn validate_scene_with(text: &str, generated: Option<&dyn KernelFactory>) -> Vec<FieldError> {
    validate_scene_at(text, Path::new(""), generated)
}

/// [`validate_scene_with`] for a scene file in folder `scene_dir` (relative file paths
/// resolved against it, as [`parse_scene_at`] does).
pub fn validate_scene_at(
    text: &str,
    scene_dir: &Path,
    generated: Option<&dyn KernelFactory>,
) -> Vec<FieldError> {
    let problems = |e: Error| match e {
        Error::Invalid(errors) => errors,
        Error::Parse(message) => vec![FieldError::new("<toml>", message)],
        other => vec![FieldError::new("<toml>", other.to_string())],
    };
    match parse_scene_at(text, scene_dir) {
        Ok(setup) => match Simulation::new(setup, generated) {
            Ok(_) => Vec::new(),
            Err(e) => problems(e),
        },
        Err(e) => problems(e),
    }
}

/// Number of time steps a setup will take (0 in static mode).
pub fn step_count(setup: &SimulationSetup) -> usize {
    total_steps(&setup.config)
}

/// `line L, column C: message` from a `toml` error.
fn describe_syntax_error(text: &str, e: &toml::de::Error) -> String {
    let message = e.message().trim();
    let Some(span) = e.span() else {
        return message.to_string();
    };
    let before = text.as_bytes().get(..span.start).unwrap_or(text.as_bytes());
    let line = 1 + before.iter().filter(|&&b| b == b'\n').count();
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let column = 1 + String::from_utf8_lossy(&before[line_start..])
        .chars()
        .count();
    format!("line {line}, column {column}: {message}")
}

fn read_scene(mut root: Node<'_>, scene_dir: &Path) -> (SimulationSetup, Vec<GroomReport>) {
    let mut config = root
        .table("simulation")
        .map(read_simulation)
        .unwrap_or_default();
    let (environment, defaults) = root
        .table("environment")
        .map(read_environment)
        .unwrap_or_default();
    let head = head::read_head(root.table("head"));
    let (samples_per_element, mut output) = root.table("output").map_or(
        (DEFAULT_SAMPLES_PER_ELEMENT, OutputSettings::default()),
        |n| read_output(n, &mut config),
    );
    let bodies = bodies::read_bodies(&mut root, scene_dir);
    output.render = root
        .table("render")
        .and_then(|n| render::read_render(n, &bodies));
    let contacts = root
        .table("contacts")
        .and_then(|n| contacts::read_contacts(n, &bodies));
    let mut grooms = groom::GroomContext {
        bodies: &bodies,
        gravity: environment
            .gravity
            .map(|g| head.state(0.0).rotation.transpose() * g),
        scene_dir,
        reports: Vec::new(),
        clearance: contacts.as_ref().map_or(0.0, |c| c.radius),
        contacts: contacts.as_ref(),
    };
    let strands = assembly::read_strands(&mut root, &defaults, &mut grooms);
    let reports = grooms.reports;
    let electrostatics = match root.table("electrostatics") {
        Some(n) => electrostatics::read_electrostatics(n, &strands, &bodies),
        None => {
            for (i, s) in strands.iter().enumerate() {
                if s.charge_per_length.is_some_and(|l| l != 0.0) {
                    root.error(
                        "electrostatics",
                        format!(
                            "strand '{}' (strands[{i}]) sets charge_per_length: add an [electrostatics] table",
                            s.strand.name
                        ),
                    );
                    break;
                }
            }
            None
        }
    };
    root.finish();
    let setup = SimulationSetup {
        config,
        environment,
        head,
        strands,
        bodies,
        samples_per_element,
        output,
        electrostatics,
        contacts,
    };
    (setup, reports)
}

fn read_simulation(mut n: Node<'_>) -> SimulationConfig {
    let d = SimulationConfig::default();
    let mode = n.optional("mode", d.mode, |n, k| {
        n.choice(k, &["dynamic", "static"], |m| match m {
            "dynamic" => Some(Mode::Dynamic),
            "static" => Some(Mode::Static),
            _ => None,
        })
    });
    let dt = n.optional_f64(
        "dt",
        d.dt,
        Range::new(Bound::Excl(0.0), Bound::Incl(MAX_DT)),
    );
    let duration = n.optional_f64("duration", d.duration, Range::NON_NEGATIVE);
    let fps = n.optional_f64(
        "output_fps",
        d.output_fps,
        Range::new(Bound::Excl(0.0), Bound::Incl(MAX_OUTPUT_FPS)),
    );
    let integrators = IntegratorKind::ALL.map(IntegratorKind::name);
    let integrator = n.optional("integrator", d.integrator, |n, k| {
        n.choice(k, &integrators, IntegratorKind::from_name)
    });
    let kernels = n.optional("kernels", d.kernels, |n, k| {
        n.choice(
            k,
            &["auto", "generic", "generated", "moment"],
            KernelChoice::from_name,
        )
    });
    let quadrature = n.optional("quadrature", d.quadrature, read_quadrature);
    let engine = n.optional("engine", d.engine, |n, k| {
        n.choice(k, &["auto", "runtime", "embedded"], Engine::from_name)
    });
    let max_split_depth = n.optional("max_split_depth", d.max_split_depth, |n, k| {
        n.count(
            k,
            0,
            MAX_SUBSTEP_DEPTH as i64,
            "the deepest split of a step (2^8 substeps)",
        )
    });
    let field_stiffness = n.optional("field_stiffness", d.field_stiffness, |n, k| {
        n.choice(
            k,
            &["projected", "split", "explicit"],
            FieldStiffness::from_name,
        )
    });
    let energy_balance = reader::boolean(&mut n, "energy_balance", d.energy_balance);
    if n.has("tolerance") && mode == Some(Mode::Static) {
        n.error(
            "tolerance",
            "a static scene (mode = \"static\") takes no time steps, so no step tolerance: remove tolerance (or set mode = \"dynamic\")",
        );
    }
    let tolerance = if n.has("tolerance") && mode != Some(Mode::Static) {
        n.optional_f64(
            "tolerance",
            0.0,
            Range::new(
                Bound::Incl(crate::config::MIN_TOLERANCE),
                Bound::Incl(crate::config::MAX_TOLERANCE),
            ),
        )
    } else {
        None
    };
    let config = SimulationConfig {
        mode: mode.unwrap_or(d.mode),
        dt: dt.unwrap_or(d.dt),
        duration: duration.unwrap_or(d.duration),
        output_fps: fps.unwrap_or(d.output_fps),
        integrator: integrator.unwrap_or(d.integrator),
        kernels: kernels.unwrap_or(d.kernels),
        quadrature: quadrature.unwrap_or(d.quadrature),
        engine: engine.unwrap_or(d.engine),
        max_split_depth: max_split_depth.unwrap_or(d.max_split_depth),
        field_stiffness: field_stiffness.unwrap_or(d.field_stiffness),
        energy_balance: energy_balance.unwrap_or(d.energy_balance),
        tolerance,
        output_times: None,
    };
    if dt.is_some() && duration.is_some() && fps.is_some() {
        check_run_size(&n, &config);
    }
    n.finish();
    config
}

/// The caps on steps and frames of a dynamic run.
fn check_run_size(n: &Node<'_>, config: &SimulationConfig) {
    if config.mode == Mode::Static {
        return;
    }
    let steps = config.duration / config.dt;
    if steps > MAX_STEPS {
        n.error(
            "duration",
            format!("duration / dt = {steps:.0} steps, more than the cap of {MAX_STEPS:.0}"),
        );
    }
    let frames = config.duration * config.output_fps;
    if frames > MAX_FRAMES {
        n.error(
            "output_fps",
            format!(
                "duration * output_fps = {frames:.0} frames, more than the cap of {MAX_FRAMES:.0}"
            ),
        );
    }
}

/// `quadrature = "adaptive"` or a Gauss–Legendre order.
fn read_quadrature(n: &mut Node<'_>, key: &'static str) -> Option<QuadratureRule> {
    let cap = "the largest Gauss-Legendre order";
    match n.raw(key)? {
        Value::String(s) if s == "adaptive" => Some(QuadratureRule::Adaptive),
        Value::Integer(_) => n
            .count(key, 1, MAX_QUADRATURE_ORDER, cap)
            .map(QuadratureRule::Fixed),
        other => {
            let msg = format!(
                "expected \"adaptive\" or an integer order in [1, {MAX_QUADRATURE_ORDER}], got {}",
                reader::kind(other)
            );
            n.error(key, msg);
            None
        }
    }
}

/// Gravity, and what strands take from the environment: the scene-wide air drag (unless
/// they set their own) and the relative humidity (which their preset values follow).
fn read_environment(mut n: Node<'_>) -> (Environment, StrandDefaults) {
    let default = Environment::default();
    let gravity = match n.raw("gravity") {
        None => default.gravity,
        Some(Value::String(s)) if s == "none" => None,
        Some(Value::Array(_)) => n
            .vec3_in(
                "gravity",
                Range::new(Bound::Incl(-MAX_GRAVITY), Bound::Incl(MAX_GRAVITY)),
            )
            .or(default.gravity),
        Some(other) => {
            n.error(
                "gravity",
                format!(
                    "expected [gx, gy, gz] in m/s^2 or \"none\", got {}",
                    reader::kind(other)
                ),
            );
            default.gravity
        }
    };
    let air_drag = if n.has("air_drag") {
        n.f64("air_drag", Range::AIR_DRAG)
    } else {
        None
    };
    let humidity = if n.has("relative_humidity") {
        let range = Range::new(Bound::Incl(MIN_HUMIDITY), Bound::Incl(MAX_HUMIDITY));
        n.f64("relative_humidity", range)
            .and_then(HumidityScaling::at)
    } else {
        None
    };
    n.finish();
    let defaults = StrandDefaults {
        air_drag,
        humidity,
        length_from_data: false,
    };
    (Environment { gravity }, defaults)
}

/// `[output]`: the sampling, the formats, the size limit, the nodes and the frame times
/// (set in `config`).
fn read_output(mut n: Node<'_>, config: &mut SimulationConfig) -> (usize, OutputSettings) {
    let cap = "the cap on points per element";
    let samples = n.optional(
        "samples_per_element",
        DEFAULT_SAMPLES_PER_ELEMENT,
        |n, k| n.count(k, 1, MAX_SAMPLES_PER_ELEMENT, cap),
    );
    let formats = read_formats(&mut n);
    let nodes = if n.has("nodes") {
        n.count(
            "nodes",
            crate::output::nodes::MIN_NODES as i64,
            crate::output::nodes::MAX_NODES as i64,
            "the cap on nodes per strand",
        )
    } else {
        None
    };
    if n.has("times") {
        config.output_times = read_output_times(&mut n, config);
    }
    let max_bytes = if n.has("max_bytes") {
        n.f64(
            "max_bytes",
            Range::new(Bound::Excl(0.0), Bound::Incl(MAX_OUTPUT_BYTES)),
        )
        .map(|b| b as u64)
    } else {
        None
    };
    if n.has("checkpoint_every") && config.mode == Mode::Static {
        n.error(
            "checkpoint_every",
            "a static run writes one frame and keeps no checkpoint: remove checkpoint_every (or set [simulation] mode = \"dynamic\")",
        );
    }
    let checkpoint_every = if n.has("checkpoint_every") && config.mode != Mode::Static {
        n.count(
            "checkpoint_every",
            0,
            MAX_FRAMES as i64,
            "the cap on frames",
        )
    } else {
        None
    };
    n.finish();
    let settings = OutputSettings {
        formats,
        max_bytes,
        render: None,
        nodes,
        checkpoint_every,
    };
    (samples.unwrap_or(DEFAULT_SAMPLES_PER_ELEMENT), settings)
}

/// `times = [t0, t1, ...]`: strictly increasing, in [0, duration], at most
/// [`MAX_FRAMES`]; not in static mode (one frame at t = 0).
fn read_output_times(n: &mut Node<'_>, config: &SimulationConfig) -> Option<Vec<f64>> {
    if config.mode == Mode::Static {
        n.error(
            "times",
            "a static run writes one frame, at t = 0: remove times (or set [simulation] mode = \"dynamic\")",
        );
        return None;
    }
    let duration = config.duration;
    let times = n.f64_list("times", Range::new(Bound::Incl(0.0), Bound::Incl(duration)))?;
    if times.is_empty() {
        n.error("times", "an empty list: give at least one time, s");
        return None;
    }
    if times.len() as f64 > MAX_FRAMES {
        n.error(
            "times",
            format!(
                "{} times, more than the cap of {MAX_FRAMES:.0} frames",
                times.len()
            ),
        );
        return None;
    }
    for (i, pair) in times.windows(2).enumerate() {
        if pair[1] <= pair[0] {
            n.error(
                &format!("times[{}]", i + 1),
                format!(
                    "{} s is not after times[{i}] = {} s: the times must be strictly increasing",
                    pair[1], pair[0]
                ),
            );
            return None;
        }
    }
    Some(times)
}

/// `formats = ["json", ...]`: problems name `output.formats[i]` and the allowed names.
fn read_formats(n: &mut Node<'_>) -> Option<Formats> {
    let value = n.raw("formats")?;
    let Value::Array(items) = value else {
        n.error(
            "formats",
            format!(
                "expected a list of format names ({}), got {}",
                FORMAT_NAMES.join(", "),
                reader::kind(value)
            ),
        );
        return None;
    };
    let mut names = Vec::new();
    for (i, item) in items.iter().enumerate() {
        match item {
            Value::String(s) => names.push(s.as_str()),
            other => {
                n.error(
                    &format!("formats[{i}]"),
                    format!(
                        "expected a format name ({}), got {}",
                        FORMAT_NAMES.join(", "),
                        reader::kind(other)
                    ),
                );
                return None;
            }
        }
    }
    match Formats::from_names("formats", &names) {
        Ok(formats) => Some(formats),
        Err(problems) => {
            for p in problems {
                n.error(&p.field, p.message);
            }
            None
        }
    }
}

#[cfg(test)]
mod tests;

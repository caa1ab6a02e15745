//! Checkpoints: the complete state of a running simulation, written next to its frames
//! every `[output] checkpoint_every` frames, from which `superhelix run SCENE --resume
//! DIR` goes on.
//!
//! `checkpoint.bin` holds, after an 8-byte magic (`SHXCKPT1`), the length and CRC-32 of
//! its body and the body itself ([postcard](https://docs.rs/postcard) of [`Checkpoint`]):
//!
//! - the scene as it was given (its TOML text, the command-line options that change the
//!   simulation) and a digest of the simulation it builds (so that a changed mesh or groom
//!   file is noticed too);
//! - where the run was: the steps taken, the frames written, the largest speed and depth
//!   reported so far;
//! - where every frame file ended (`frames.json` in bytes, the `.npy` files in rows);
//! - the simulation's state, as the simulation encodes it (`SimulationState`).
//!
//! It is written atomically (a temporary file, synced, then renamed) after the frame
//! files are synced, so a checkpoint never names a frame that is not on disk. On resume
//! the frame files are cut back to where the checkpoint says they ended (a kill after a
//! checkpoint leaves frames the resumed run writes again, bit for bit) and the run goes
//! on from the checkpoint's step.

use super::atomic::{io_error, write_atomically};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Name of the checkpoint file in a run's output directory.
pub const CHECKPOINT_FILE: &str = "checkpoint.bin";

/// The checkpoint interval of a dynamic run whose scene does not set
/// `[output] checkpoint_every`, in frames (when its formats keep the frames in
/// `frames.npy` or `frames.json`).
pub const DEFAULT_CHECKPOINT_EVERY: usize = 25;

/// The file's first bytes.
const MAGIC: &[u8; 8] = b"SHXCKPT1";

/// Version of the body's layout (a checkpoint of another version is refused).
pub const VERSION: u32 = 7;

/// What identifies the simulation a checkpoint belongs to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SceneIdentity {
    /// The scene file's text (TOML).
    pub scene: String,
    /// `--tolerance`, when given.
    pub tolerance: Option<f64>,
    /// The formats written (`json`, `npy`, ...).
    pub formats: Vec<String>,
    /// `--part K/P`, when given.
    pub part: Option<(usize, usize)>,
    /// A digest of the simulation the scene builds ([`setup_digest`]).
    pub digest: u64,
    /// The step length the simulation was built with, when it replaced the scene's
    /// (`scene.simulation(dt=...)` in Python; `None` from the command line).
    pub dt: Option<f64>,
    /// The folder the scene's relative paths are read from, when the checkpoint is a
    /// saved simulation (`Simulation.save` in Python; `None` from the command line).
    pub folder: Option<String>,
}

impl SceneIdentity {
    /// Why a run of `scene` cannot continue from a checkpoint of `self`, naming the first
    /// difference; `None` when it can.
    pub fn difference(&self, scene: &SceneIdentity) -> Option<String> {
        if self.scene != scene.scene {
            let parse = |text: &str| text.parse::<toml::Table>().ok();
            let differs = match (parse(&self.scene), parse(&scene.scene)) {
                (Some(a), Some(b)) => {
                    first_difference("", &toml::Value::Table(a), &toml::Value::Table(b))
                }
                _ => Some("the scene text".to_string()),
            };
            if let Some(d) = differs {
                return Some(d);
            }
        }
        if self.dt != scene.dt {
            return Some(format!(
                "dt: {} in the checkpoint, {} now",
                show_option(self.dt),
                show_option(scene.dt)
            ));
        }
        if self.tolerance != scene.tolerance {
            return Some(format!(
                "--tolerance: {} in the checkpoint, {} now",
                show_option(self.tolerance),
                show_option(scene.tolerance)
            ));
        }
        if self.part != scene.part {
            let show = |p: Option<(usize, usize)>| match p {
                Some((k, n)) => format!("{k}/{n}"),
                None => "none".to_string(),
            };
            return Some(format!(
                "--part: {} in the checkpoint, {} now",
                show(self.part),
                show(scene.part)
            ));
        }
        if self.formats != scene.formats {
            return Some(format!(
                "the formats: {} in the checkpoint, {} now (--format)",
                self.formats.join(", "),
                scene.formats.join(", ")
            ));
        }
        if self.digest != scene.digest {
            return Some(
                "a file the scene reads (a mesh, a groom's curves) has changed since the checkpoint"
                    .to_string(),
            );
        }
        None
    }
}

fn show_option(x: Option<f64>) -> String {
    x.map_or("none".to_string(), |x| x.to_string())
}

/// The first key whose value differs between two TOML values, as
/// `key.path: A in the checkpoint, B in the scene`.
fn first_difference(path: &str, a: &toml::Value, b: &toml::Value) -> Option<String> {
    let key = |k: &str| match path.is_empty() {
        true => k.to_string(),
        false => format!("{path}.{k}"),
    };
    match (a, b) {
        (toml::Value::Table(ta), toml::Value::Table(tb)) => {
            let mut keys: Vec<&String> = ta.keys().chain(tb.keys()).collect();
            keys.sort();
            keys.dedup();
            keys.into_iter().find_map(|k| match (ta.get(k), tb.get(k)) {
                (Some(va), Some(vb)) => first_difference(&key(k), va, vb),
                (Some(va), None) => Some(format!(
                    "{}: {va} in the checkpoint, absent from the scene",
                    key(k)
                )),
                (None, Some(vb)) => Some(format!(
                    "{}: absent from the checkpoint, {vb} in the scene",
                    key(k)
                )),
                (None, None) => None,
            })
        }
        (toml::Value::Array(xa), toml::Value::Array(xb)) if xa.len() == xb.len() => xa
            .iter()
            .zip(xb)
            .enumerate()
            .find_map(|(i, (va, vb))| first_difference(&format!("{path}[{i}]"), va, vb)),
        _ if a == b => None,
        _ => Some(format!(
            "{}: {a} in the checkpoint, {b} in the scene",
            if path.is_empty() { "the scene" } else { path }
        )),
    }
}

/// A 64-bit digest (FNV-1a) of everything a simulation is built from: the `Debug` text of
/// its setup, which prints every number exactly (shortest round-trip form), meshes and
/// groom curves included. Streamed: nothing the size of the setup is allocated.
pub fn setup_digest(setup: &impl std::fmt::Debug) -> u64 {
    struct Fnv(u64);
    impl std::fmt::Write for Fnv {
        fn write_str(&mut self, s: &str) -> std::fmt::Result {
            for &b in s.as_bytes() {
                self.0 ^= u64::from(b);
                self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
            }
            Ok(())
        }
    }
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    // (writing into Fnv cannot fail)
    let _ = std::fmt::write(&mut h, format_args!("{setup:?}"));
    h.0
}

/// Where a run was when the checkpoint was taken.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RunPoint {
    /// Steps of `dt` completed.
    pub step: usize,
    /// The simulated time reached, s.
    pub time: f64,
    /// Frames written.
    pub frames: usize,
    /// Steps taken (split steps counted), as the summary reports them.
    pub taken: usize,
    /// The largest |q̇| so far.
    pub max_speed: f64,
    /// The deepest point inside a body so far (`None`: no contacts).
    pub deepest: Option<f64>,
    /// The largest held-tip drift of the frames written.
    pub held_drift: Option<f64>,
}

/// The content of `checkpoint.bin` (see the module page).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Layout version ([`VERSION`]).
    pub version: u32,
    /// The scene and options of the run.
    pub identity: SceneIdentity,
    /// Where the run was.
    pub point: RunPoint,
    /// Where each frame sink's files ended ([`super::FrameSink::mark`]), in sink order.
    pub sinks: Vec<Vec<u64>>,
    /// The simulation's state, as its source encoded it
    /// ([`super::FrameSource::state`]; `crate::simulation::SimulationState` for a
    /// simulation).
    pub state: Vec<u8>,
}

/// Write `checkpoint` as `dir/checkpoint.bin`, atomically.
pub fn write(dir: &Path, checkpoint: &Checkpoint) -> Result<()> {
    write_file(&dir.join(CHECKPOINT_FILE), checkpoint)
}

/// Write `checkpoint` as the file `path`, atomically.
pub fn write_file(path: &Path, checkpoint: &Checkpoint) -> Result<()> {
    let path = path.to_path_buf();
    let body = postcard::to_stdvec(checkpoint).map_err(|e| {
        io_error(
            &path,
            std::io::Error::new(std::io::ErrorKind::InvalidData, e.to_string()),
        )
    })?;
    let mut bytes = Vec::with_capacity(body.len() + 20);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(body.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&crc32fast::hash(&body).to_le_bytes());
    bytes.extend_from_slice(&body);
    write_atomically(&path, &bytes)
}

/// The checkpoint in `dir` (`None`: there is none); a damaged one is an error naming the
/// file and what is wrong with it.
pub fn read(dir: &Path) -> Result<Option<Checkpoint>> {
    read_file(&dir.join(CHECKPOINT_FILE), "--resume")
}

/// Whether the file `path` starts as a checkpoint does (a file [`write_file`] may
/// replace).
pub fn is_checkpoint(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok()
        && &head == MAGIC
}

/// The checkpoint in the file `path` (`None`: there is none); a damaged one is an error
/// naming `field`, the file and what is wrong with it.
pub fn read_file(path: &Path, field: &str) -> Result<Option<Checkpoint>> {
    let path = path.to_path_buf();
    let resume = field == "--resume";
    match std::fs::metadata(&path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io_error(&path, e)),
        Ok(_) => {}
    }
    // not a device or a pipe, not longer than memory allows, before it is read
    let bytes = crate::input::read_bounded(&path, u64::MAX, "checkpoint written by a run")
        .map_err(|why| Error::invalid(field, why))?;
    let damaged = |why: &str| {
        Error::invalid(
            field,
            format!(
                "{} is damaged ({why}){}",
                path.display(),
                if resume {
                    ": remove it to start the run again from t = 0"
                } else {
                    ""
                }
            ),
        )
    };
    if bytes.len() < 20 || &bytes[..8] != MAGIC {
        return Err(damaged("not a superhelix checkpoint"));
    }
    let mut len = [0u8; 8];
    len.copy_from_slice(&bytes[8..16]);
    let mut crc = [0u8; 4];
    crc.copy_from_slice(&bytes[16..20]);
    let body = &bytes[20..];
    if u64::from_le_bytes(len) != body.len() as u64 {
        return Err(damaged(&format!(
            "{} bytes of body, the header says {}",
            body.len(),
            u64::from_le_bytes(len)
        )));
    }
    if crc32fast::hash(body) != u32::from_le_bytes(crc) {
        return Err(damaged("its checksum does not match its content"));
    }
    let checkpoint: Checkpoint = postcard::from_bytes(body)
        .map_err(|e| damaged(&format!("its content does not decode: {e}")))?;
    if checkpoint.version != VERSION {
        return Err(Error::invalid(
            field,
            format!(
                "{} is of layout version {}, this build reads version {VERSION}",
                path.display(),
                checkpoint.version
            ),
        ));
    }
    Ok(Some(checkpoint))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn identity(scene: &str) -> SceneIdentity {
        SceneIdentity {
            scene: scene.to_string(),
            tolerance: None,
            formats: vec!["npy".into()],
            part: None,
            digest: 1,
            dt: None,
            folder: None,
        }
    }

    #[test]
    fn a_changed_scene_is_named_by_its_first_differing_key() {
        let a = identity("[simulation]\ndt = 0.001\nduration = 1.0\n");
        let b = identity("# a comment\n[simulation]\nduration = 1.0\ndt = 0.002\n");
        assert_eq!(
            a.difference(&b).as_deref(),
            Some("simulation.dt: 0.001 in the checkpoint, 0.002 in the scene")
        );
        // comments and key order do not count
        let c = identity("[simulation]  # same\nduration = 1.0\ndt = 0.001\n");
        assert_eq!(a.difference(&c), None);
        let d = identity("[simulation]\ndt = 0.001\n");
        assert_eq!(
            a.difference(&d).as_deref(),
            Some("simulation.duration: 1.0 in the checkpoint, absent from the scene")
        );
        let mut e = identity(&a.scene);
        e.digest = 2;
        assert!(a.difference(&e).is_some_and(|m| m.contains("has changed")));
        let mut f = identity(&a.scene);
        f.tolerance = Some(1e-4);
        assert_eq!(
            a.difference(&f).as_deref(),
            Some("--tolerance: none in the checkpoint, 0.0001 now")
        );
    }

    #[test]
    fn the_digest_sees_every_bit_of_a_number() {
        let a = setup_digest(&vec![1.0_f64, 2.0]);
        let b = setup_digest(&vec![1.0_f64, f64::from_bits(2.0_f64.to_bits() + 1)]);
        assert_ne!(a, b);
        assert_eq!(a, setup_digest(&vec![1.0_f64, 2.0]));
    }
}

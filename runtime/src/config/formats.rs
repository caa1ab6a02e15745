//! The scene's `[output]` choices: which files a run writes ([`Formats`]) and the limit
//! on their size ([`OutputSettings`]). Plain data; the output plan
//! (`crate::output::plan`) turns them into files and size estimates.

use crate::error::{Error, FieldError, Result};

/// Which files a run writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Formats {
    /// `frames.json`.
    pub json: bool,
    /// `frames.npy`, `frames.times.npy`, `frames.index.json`.
    pub npy: bool,
    /// `hair.usda`.
    pub usda: bool,
    /// `preview.png` (last frame) and `preview_first.png`.
    pub png: bool,
    /// `preview.gif`.
    pub gif: bool,
    /// `last_frame.obj`.
    pub obj: bool,
}

impl Default for Formats {
    /// [`Formats::DEFAULT`].
    fn default() -> Self {
        Formats::DEFAULT
    }
}

/// Every format name and what it selects.
pub const FORMAT_NAMES: [&str; 7] = ["json", "npy", "usda", "png", "gif", "obj", "preview"];

impl Formats {
    /// No file.
    pub const NONE: Formats = Formats {
        json: false,
        npy: false,
        usda: false,
        png: false,
        gif: false,
        obj: false,
    };

    /// `["json", "usda", "preview"]` (before the json → npy replacement of large runs).
    pub const DEFAULT: Formats = Formats {
        json: true,
        usda: true,
        png: true,
        gif: true,
        ..Formats::NONE
    };

    /// Add the format `name` (one of [`FORMAT_NAMES`]); false for an unknown name.
    pub fn add(&mut self, name: &str) -> bool {
        match name {
            "json" => self.json = true,
            "npy" => self.npy = true,
            "usda" => self.usda = true,
            "png" => self.png = true,
            "gif" => self.gif = true,
            "obj" => self.obj = true,
            "preview" => {
                self.png = true;
                self.gif = true;
            }
            _ => return false,
        }
        true
    }

    /// The formats of a list of names; every unknown name is a problem of
    /// `field[i]` naming the allowed names, and an empty list a problem of `field`.
    pub fn from_names<S: AsRef<str>>(
        field: &str,
        names: &[S],
    ) -> std::result::Result<Formats, Vec<FieldError>> {
        let mut formats = Formats::NONE;
        let mut problems = Vec::new();
        for (i, name) in names.iter().enumerate() {
            if !formats.add(name.as_ref()) {
                problems.push(FieldError::new(
                    format!("{field}[{i}]"),
                    format!(
                        "unknown format \"{}\": expected one of {}",
                        name.as_ref(),
                        FORMAT_NAMES.join(", ")
                    ),
                ));
            }
        }
        if names.is_empty() {
            problems.push(FieldError::new(
                field,
                format!(
                    "no format given: name at least one of {}",
                    FORMAT_NAMES.join(", ")
                ),
            ));
        }
        if problems.is_empty() {
            Ok(formats)
        } else {
            Err(problems)
        }
    }

    /// The formats of `run --format` values, each a name or a comma-separated list.
    pub fn from_cli<S: AsRef<str>>(values: &[S]) -> Result<Formats> {
        let names: Vec<&str> = values
            .iter()
            .flat_map(|v| v.as_ref().split(','))
            .map(str::trim)
            .collect();
        Formats::from_names("--format", &names).map_err(Error::Invalid)
    }

    /// The names of the formats selected (`preview` never: png and gif are listed).
    pub fn names(&self) -> Vec<&'static str> {
        let flags = [
            (self.json, "json"),
            (self.npy, "npy"),
            (self.usda, "usda"),
            (self.png, "png"),
            (self.gif, "gif"),
            (self.obj, "obj"),
        ];
        flags
            .iter()
            .filter(|(on, _)| *on)
            .map(|&(_, name)| name)
            .collect()
    }
}

/// The scene's `[output]` choices besides the sampling, and its `[render]` table.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OutputSettings {
    /// `formats`: the files to write; `None` for the default.
    pub formats: Option<Formats>,
    /// `max_bytes`: the limit on the planned output, bytes; `None` for
    /// `crate::output::plan::DEFAULT_MAX_BYTES`.
    pub max_bytes: Option<u64>,
    /// `[render]`: render strands generated from the strands at every frame for
    /// `hair.usda` and the pictures; `None`: none, nothing built for them.
    pub render: Option<crate::render::RenderSettings>,
    /// `nodes`: write every strand at this many evenly spaced arc lengths, with its d1
    /// director between them (`frames.nodes.npy`, `frames.d1.npy`); `None`: not written.
    pub nodes: Option<usize>,
    /// `checkpoint_every`: frames between two checkpoints (0: none); `None` for the
    /// default ([`crate::output::checkpoint::DEFAULT_CHECKPOINT_EVERY`] for a dynamic run
    /// that writes `frames.npy` or `frames.json`, else none).
    pub checkpoint_every: Option<usize>,
}

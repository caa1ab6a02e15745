//! Which files a run writes.

/// Which files a run writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Formats {
    /// `frames.json`.
    pub json: bool,
    /// `frames.npy`, `frames.times.npy`, `frames.index.json`.
    pub npy: bool,
    /// `hair.usda`.
    pub usda: bool,
    /// `preview.png` and `preview_first.png`.
    pub png: bool,
    /// `preview.gif`.
    pub gif: bool,
    /// `last_frame.obj`.
    pub obj: bool,
}

impl Default for Formats {
    /// `["json", "usda", "preview"]`.
    fn default() -> Self {
        Self {
            json: true,
            npy: false,
            usda: true,
            png: true,
            gif: true,
            obj: false,
        }
    }
}

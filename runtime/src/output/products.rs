//! The files written after the run from the frames written (hair.usda, the previews,
//! last_frame.obj).

use super::frames::FrameStore;
use super::plan::Formats;
use crate::error::Result;
use std::path::{Path, PathBuf};

/// Camera and picture settings of the previews.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PreviewOptions {}

/// Write the post-run files `formats` asks for into `dir` from the frames of `store`.
/// Returns the files written.
pub fn write_products(
    store: &mut dyn FrameStore,
    formats: &Formats,
    dir: &Path,
    view: &PreviewOptions,
) -> Result<Vec<PathBuf>> {
    let _ = (store, formats, dir, view);
    Ok(Vec::new())
}

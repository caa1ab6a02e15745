//! Files that appear whole or not at all: written to `<name>.tmp` beside the target and
//! renamed over it when complete, so a reader (or a run stopped mid-write) sees either the
//! previous file or the whole new one.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// An I/O error on `path`.
pub fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.display().to_string(),
        source,
    }
}

/// `<path>.tmp`, the temporary file renamed over `path`.
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Write `bytes` to `path` through its temporary file and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temporary_path(path);
    std::fs::write(&tmp, bytes).map_err(|e| io_error(&tmp, e))?;
    std::fs::rename(&tmp, path).map_err(|e| io_error(path, e))
}

/// A file being streamed to the temporary file of `path`; [`AtomicFile::commit`] renames
/// it over `path`.
#[derive(Debug)]
pub struct AtomicFile {
    tmp: PathBuf,
    path: PathBuf,
}

impl AtomicFile {
    /// Create the temporary file of `path`; returns it and a buffered writer to it.
    pub fn create(path: &Path) -> Result<(AtomicFile, BufWriter<File>)> {
        let tmp = temporary_path(path);
        let file = File::create(&tmp).map_err(|e| io_error(&tmp, e))?;
        let file_ref = AtomicFile {
            tmp,
            path: path.to_path_buf(),
        };
        Ok((file_ref, BufWriter::new(file)))
    }

    /// An error while writing, naming the temporary file.
    pub fn error(&self, source: std::io::Error) -> Error {
        io_error(&self.tmp, source)
    }

    /// Flush `writer` and rename the temporary file over the target.
    pub fn commit(self, mut writer: BufWriter<File>) -> Result<()> {
        writer.flush().map_err(|e| self.error(e))?;
        drop(writer);
        std::fs::rename(&self.tmp, &self.path).map_err(|e| io_error(&self.path, e))
    }
}

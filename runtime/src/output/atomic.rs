//! Files that appear whole or not at all: written to `<name>.tmp` beside the target,
//! synced to disk, renamed over it when complete, and the folder synced (so that the
//! rename itself survives a power loss): a reader, a run stopped mid-write or a machine
//! that goes down sees either the previous file or the whole new one.

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

/// Write `bytes` to `path` through its temporary file, synced, a rename and a sync of
/// the folder. On failure (a full disk) the temporary file is removed: nothing is left
/// but what was there before.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temporary_path(path);
    let written = (|| {
        let mut file = File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()
    })()
    .map_err(|e| io_error(&tmp, e));
    let result = written.and_then(|()| rename_synced(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Rename the synced temporary file `tmp` over `path`, then sync the folder that holds
/// them (on Unix: the rename is durable only once the folder's entry is).
fn rename_synced(tmp: &Path, path: &Path) -> Result<()> {
    crate::output::test_hooks::before_rename(path);
    std::fs::rename(tmp, path).map_err(|e| io_error(path, e))?;
    sync_folder(path)
}

/// Sync the folder holding `path` (nothing to do where a folder cannot be opened as a
/// file, as on Windows).
pub fn sync_folder(path: &Path) -> Result<()> {
    #[cfg(unix)]
    {
        let folder = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
        File::open(folder)
            .and_then(|f| f.sync_all())
            .map_err(|e| io_error(folder, e))?;
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

/// A file being streamed to the temporary file of `path`; [`AtomicFile::commit`] renames
/// it over `path`. Dropped uncommitted (an error while writing), it removes the
/// temporary file.
#[derive(Debug)]
pub struct AtomicFile {
    tmp: PathBuf,
    path: PathBuf,
    committed: bool,
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl AtomicFile {
    /// Create the temporary file of `path`; returns it and a buffered writer to it.
    pub fn create(path: &Path) -> Result<(AtomicFile, BufWriter<File>)> {
        let tmp = temporary_path(path);
        let file = File::create(&tmp).map_err(|e| io_error(&tmp, e))?;
        let file_ref = AtomicFile {
            tmp,
            path: path.to_path_buf(),
            committed: false,
        };
        Ok((file_ref, BufWriter::new(file)))
    }

    /// An error while writing, naming the temporary file.
    pub fn error(&self, source: std::io::Error) -> Error {
        io_error(&self.tmp, source)
    }

    /// Flush `writer`, sync the temporary file, rename it over the target and sync the
    /// folder.
    pub fn commit(mut self, writer: BufWriter<File>) -> Result<()> {
        let file = writer
            .into_inner()
            .map_err(|e| self.error(e.into_error()))?;
        file.sync_all().map_err(|e| self.error(e))?;
        drop(file);
        rename_synced(&self.tmp, &self.path)?;
        self.committed = true;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failed_write_leaves_no_temporary_file() {
        let dir = std::env::temp_dir().join(format!("superhelix-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        // a directory in the way of the rename: the write succeeds, the rename fails
        let target = dir.join("preview.png");
        std::fs::create_dir_all(target.join("inside")).expect("dir");
        assert!(write_atomically(&target, b"png").is_err());
        assert!(!temporary_path(&target).exists());
        // streamed, dropped before its commit
        let other = dir.join("usd");
        let (file, mut writer) = AtomicFile::create(&other).expect("create");
        writer.write_all(b"abc").expect("write");
        drop(writer);
        drop(file);
        assert!(!temporary_path(&other).exists());
        assert!(!other.exists());
        std::fs::remove_dir_all(&dir).ok();
    }
}

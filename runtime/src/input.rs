//! Reading a user's files with bounded resources: a folder is refused; a file longer than
//! its kind can be or than the memory the machine has free is refused before anything is
//! allocated for it; a pipe or a device (`run <(generate-scene)`) is read up to its kind's
//! limit only, and refused outright where the kind has none (a checkpoint: `/dev/zero`
//! in its place would be read until the machine ran out of memory).

use std::io::Read;
use std::path::Path;

pub mod npy;

/// Largest scene file (TOML), groom or polyline file read whole: 256 MiB.
pub const TEXT_FILE_LIMIT: u64 = 256 << 20;

/// Largest mesh (OBJ) read whole: 1 GiB.
pub const MESH_FILE_LIMIT: u64 = 1 << 30;

/// Read the file at `path` whole, refusing (with a message that names the file and says
/// what is wrong) a path that is not a regular file or a file longer than `limit` bytes
/// or than the machine's available memory. `what` names the kind of file the user was
/// to give (`"scene file"`, `"checkpoint"`).
pub fn read_bounded(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, String> {
    let file =
        std::fs::File::open(path).map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let meta = file
        .metadata()
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    if meta.is_dir() || (!meta.is_file() && limit == u64::MAX) {
        return Err(format!(
            "{} is not a regular file (a folder, a device or a pipe): give a {what}",
            path.display()
        ));
    }
    // how much may be read: a regular file's length (checked first), a stream's limit
    let regular = meta.is_file();
    let bound = if regular {
        let len = meta.len();
        if len > limit {
            return Err(format!(
                "{} is {len} bytes, more than a {what} can be ({limit} bytes)",
                path.display()
            ));
        }
        if let Some(free) = available_memory() {
            if len > free / 2 {
                return Err(format!(
                    "{} is {len} bytes, more than half the memory this machine has free ({free} bytes)",
                    path.display()
                ));
            }
        }
        len
    } else {
        // a pipe or a device (`run <(generate-scene)`): up to the kind's limit
        limit
    };
    // one byte more than the bound shows a file that grew while it was read, or a stream
    // beyond the limit
    let mut bytes = Vec::with_capacity(if regular { bound as usize } else { 0 });
    file.take(bound.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    if bytes.len() as u64 > bound {
        return Err(if regular {
            format!(
                "{} grew while it was read: give a {what} that no program is writing",
                path.display()
            )
        } else {
            format!(
                "{} gave more than a {what} can be ({limit} bytes) and is not a regular file",
                path.display()
            )
        });
    }
    Ok(bytes)
}

/// The machine's available memory, bytes (Linux; `None` elsewhere or when unreadable).
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// [`read_bounded`] as text (UTF-8, named in the error when it is not).
pub fn read_text_bounded(path: &Path, limit: u64, what: &str) -> Result<String, String> {
    let bytes = read_bounded(path, limit, what)?;
    String::from_utf8(bytes)
        .map_err(|e| format!("{} is not UTF-8 text ({e}): give a {what}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_folders_and_long_files_are_refused_before_they_are_read() {
        #[cfg(unix)]
        {
            let e = read_bounded(Path::new("/dev/zero"), u64::MAX, "checkpoint").unwrap_err();
            assert!(e.contains("not a regular file"), "{e}");
            // a stream is read up to the kind's limit, no further
            let e = read_bounded(Path::new("/dev/zero"), 1 << 20, "scene file").unwrap_err();
            assert!(
                e.contains("gave more than a scene file can be (1048576 bytes)"),
                "{e}"
            );
        }
        let dir = std::env::temp_dir().join(format!("superhelix-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let e = read_bounded(&dir, 1 << 20, "scene file").unwrap_err();
        assert!(e.contains("not a regular file"), "{e}");
        let file = dir.join("a.toml");
        std::fs::write(&file, b"0123456789").expect("write");
        let e = read_bounded(&file, 9, "scene file").unwrap_err();
        assert!(
            e.contains("10 bytes, more than a scene file can be (9 bytes)"),
            "{e}"
        );
        assert_eq!(
            read_bounded(&file, 10, "scene file").expect("read"),
            b"0123456789"
        );
        std::fs::write(&file, [0xff, 0xfe]).expect("write");
        let e = read_text_bounded(&file, 10, "scene file").unwrap_err();
        assert!(e.contains("not UTF-8"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}

//! Points where a test can make the process abort, as a kill or a power loss would stop
//! it, to check what such a stop leaves (`tests/checkpoint.rs`). Set by environment
//! variables that only tests set; unset, each hook is one check of a value read once.
//!
//! - `SUPERHELIX_TEST_ABORT_BEFORE_RENAME=NAME[:K]`: abort at the K-th (default first)
//!   atomic write of a file named NAME, its temporary file written and synced, before
//!   the rename ([`super::atomic`]).
//! - `SUPERHELIX_TEST_ABORT_AFTER_FRAMES=F`: abort once a run has written F frames (its
//!   checkpoint, if one is due at that frame, written first).

use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::OnceLock;

/// `SUPERHELIX_TEST_ABORT_BEFORE_RENAME`, parsed: the file name and K.
fn rename_hook() -> &'static Option<(String, usize)> {
    static HOOK: OnceLock<Option<(String, usize)>> = OnceLock::new();
    HOOK.get_or_init(|| {
        let v = std::env::var("SUPERHELIX_TEST_ABORT_BEFORE_RENAME").ok()?;
        Some(match v.rsplit_once(':') {
            Some((name, k)) => (name.to_string(), k.parse().unwrap_or(1)),
            None => (v, 1),
        })
    })
}

/// Called before the rename of every atomic write of `path`.
pub(crate) fn before_rename(path: &Path) {
    let Some((name, k)) = rename_hook() else {
        return;
    };
    static SEEN: AtomicUsize = AtomicUsize::new(0);
    if path
        .file_name()
        .is_some_and(|n| n.to_string_lossy() == name.as_str())
        && SEEN.fetch_add(1, Ordering::SeqCst) + 1 == *k
    {
        std::process::abort();
    }
}

/// Called after each step of a run with the frames written so far.
pub(crate) fn after_frames(written: usize) {
    static HOOK: OnceLock<Option<usize>> = OnceLock::new();
    let hook = HOOK.get_or_init(|| {
        std::env::var("SUPERHELIX_TEST_ABORT_AFTER_FRAMES")
            .ok()
            .and_then(|v| v.parse().ok())
    });
    if hook.is_some_and(|f| written >= f) {
        std::process::abort();
    }
}

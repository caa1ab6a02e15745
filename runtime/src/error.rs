//! Errors: bad input names its field and allowed range; a failed run names the strand,
//! the time and the cause.

use std::fmt;

/// One problem found in user input, with the path of the field (for example
/// `strands[2].length`) and what is allowed there.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    /// Path of the offending field, TOML-style (`simulation.dt`, `strands[0].preset`).
    pub field: String,
    /// What is wrong and what is allowed.
    pub message: String,
}

impl FieldError {
    /// A new field error.
    pub fn new(field: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            field: field.into(),
            message: message.into(),
        }
    }
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

/// Every error of the runtime.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The input (scene, builder arguments) is invalid; every problem found is listed.
    #[error("invalid input:\n{}", .0.iter().map(|e| format!("  - {e}")).collect::<Vec<_>>().join("\n"))]
    Invalid(Vec<FieldError>),
    /// The scene file could not be parsed at all.
    #[error("cannot parse scene: {0}")]
    Parse(String),
    /// A strand's state became non-finite or a solve failed: the run stops here.
    #[error("strand '{strand}' (index {index}) failed at t = {time:.6} s: {cause}")]
    Diverged {
        /// Name of the strand.
        strand: String,
        /// Index of the strand in the simulation.
        index: usize,
        /// Simulated time at which the failure was detected, in seconds.
        time: f64,
        /// What went wrong.
        cause: String,
    },
    /// The requested kernels do not exist (for example `kernels = "generated"` for an N
    /// with no generated kernel).
    #[error("kernels: {0}")]
    Kernel(String),
    /// Reading or writing a file failed (a full disk says so first: "no space left").
    #[error("{}", io_message(path, source))]
    Io {
        /// The file concerned.
        path: String,
        /// The underlying error.
        source: std::io::Error,
    },
}

/// The text of [`Error::Io`]: the file and the OS error, or, for a full disk, that first
/// with what to do.
fn io_message(path: &str, source: &std::io::Error) -> String {
    if source.kind() == std::io::ErrorKind::StorageFull {
        format!(
            "no space left on the disk that holds {path} ({source}): free some space there or write elsewhere"
        )
    } else {
        format!("{path}: {source}")
    }
}

impl Error {
    /// Whether this is a full disk ([`Error::Io`] with no space left): nothing more can be
    /// written there.
    pub fn is_disk_full(&self) -> bool {
        matches!(self, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::StorageFull)
    }

    /// A single-field input error.
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid(vec![FieldError::new(field, message)])
    }
}

/// The runtime's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_full_disk_says_so_first() {
        let full = Error::Io {
            path: "out/frames.npy".into(),
            source: std::io::Error::from(std::io::ErrorKind::StorageFull),
        };
        assert!(full.is_disk_full());
        let text = full.to_string();
        assert!(
            text.starts_with("no space left on the disk that holds out/frames.npy"),
            "{text}"
        );
        let other = Error::Io {
            path: "out/frames.npy".into(),
            source: std::io::Error::from(std::io::ErrorKind::PermissionDenied),
        };
        assert!(!other.is_disk_full());
        assert!(other.to_string().starts_with("out/frames.npy: "), "{other}");
    }
}

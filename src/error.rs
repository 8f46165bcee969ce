//! The crate's error type: every failure names what it is about and maps to an exit code.

use std::path::{Path, PathBuf};

/// Result alias used across the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in detnoise, with the file (and frame) it concerns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A command-line option or configuration value is invalid (exit code 2).
    #[error("invalid option {option}: {message}")]
    Usage {
        /// The option or setting at fault, e.g. `--signal`.
        option: String,
        /// What is wrong with it.
        message: String,
    },
    /// An input file is unreadable or its content is invalid (exit code 2).
    #[error("{}: {message}", path.display())]
    Input {
        /// The file at fault.
        path: PathBuf,
        /// What is wrong, naming the frame where it applies.
        message: String,
    },
    /// An operating-system I/O failure on a file (exit code 1).
    #[error("{}: {source}", path.display())]
    Io {
        /// The file being read or written.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A numerical procedure failed (fit did not converge, bracket not found; exit code 1).
    #[error("{0}")]
    Numeric(String),
}

impl Error {
    /// A usage error for `option`.
    pub fn usage(option: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Usage {
            option: option.into(),
            message: message.into(),
        }
    }

    /// An invalid-input error for the file at `path`.
    pub fn input(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error::Input {
            path: path.as_ref().to_path_buf(),
            message: message.into(),
        }
    }

    /// An I/O error on the file at `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    /// The process exit code for this error: 2 for bad options or input, 1 otherwise.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Usage { .. } | Error::Input { .. } => 2,
            Error::Io { .. } | Error::Numeric(_) => 1,
        }
    }
}

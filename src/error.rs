//! The crate's error type: every failure names what it is about and maps to an exit code.

use std::path::{Path, PathBuf};

/// Exit code of a successful run.
pub const EXIT_OK: i32 = 0;
/// Exit code of bad data or a runtime failure: an unreadable or invalid input file, an I/O
/// failure, a numerical failure.
pub const EXIT_FAILURE: i32 = 1;
/// Exit code of a usage error: a bad option value, a bad or refused output path (clap's own
/// parse errors use it too).
pub const EXIT_USAGE: i32 = 2;
/// Exit code of a run interrupted by Ctrl-C or SIGTERM (128 + SIGINT, the shell convention).
pub const EXIT_INTERRUPTED: i32 = 130;

/// The exit codes as shown at the end of `detnoise --help` and of every subcommand's help.
pub const EXIT_CODES_HELP: &str = "\
Exit status:
  0    success
  1    bad data or runtime failure: an input file unreadable or invalid, an I/O error, a
       numerical failure (e.g. a fit that does not converge)
  2    usage error: a bad option value (the message names the option and its allowed range),
       a bad or refused output path
  130  interrupted by Ctrl-C or SIGTERM";

/// A field as shown in a message: flags (`--out`, `STACK`) as "option ...", library fields
/// in backticks.
fn shown_field(field: &str) -> String {
    if field.starts_with('-') || field.chars().all(|c| c.is_ascii_uppercase()) {
        format!("option {field}")
    } else {
        format!("`{field}`")
    }
}

/// Result alias used across the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// Everything that can go wrong in detnoise, with the file (and frame) it concerns.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A setting is invalid (exit code 2). The library names its own field (`signal_photons`);
    /// the command line replaces it with the option's flag (`--signal`) before printing.
    #[error("invalid {}: {message}", shown_field(field))]
    Usage {
        /// The setting at fault: a library field name, or a flag once the CLI has mapped it.
        field: String,
        /// What is wrong with it; other settings are named as `` `field` `` (backticks).
        message: String,
    },
    /// An input file is unreadable or its content is invalid (exit code 1: bad data).
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
    /// The run was stopped by its driver ([`crate::progress::Observer::cancelled`]; exit code
    /// 130, as for Ctrl-C).
    #[error("interrupted")]
    Interrupted,
}

impl Error {
    /// An invalid setting: `field` is the library's name for it (e.g. `emccd_read_noise_e`).
    pub fn invalid(field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Usage {
            field: field.into(),
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

    /// The process exit code for this error: 2 for a usage error (bad option value or output
    /// path), 1 for bad data or a runtime failure (see [`EXIT_CODES_HELP`]).
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Usage { .. } => EXIT_USAGE,
            Error::Input { .. } | Error::Io { .. } | Error::Numeric(_) => EXIT_FAILURE,
            Error::Interrupted => EXIT_INTERRUPTED,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exit_codes_follow_the_documented_rule() {
        let io = std::io::Error::new(std::io::ErrorKind::PermissionDenied, "denied");
        assert_eq!(Error::invalid("qe", "bad").exit_code(), EXIT_USAGE);
        assert_eq!(Error::input("a.fits", "bad").exit_code(), EXIT_FAILURE);
        assert_eq!(Error::io("a.fits", io).exit_code(), EXIT_FAILURE);
        assert_eq!(Error::Numeric("no fit".into()).exit_code(), EXIT_FAILURE);
        assert_eq!(Error::Interrupted.exit_code(), EXIT_INTERRUPTED);
        for code in [EXIT_OK, EXIT_FAILURE, EXIT_USAGE, EXIT_INTERRUPTED] {
            assert!(EXIT_CODES_HELP.contains(&format!("  {code} ")), "{code}");
        }
    }
}

//! The root crate's error type. Errors caused by what a user supplied (scene files, options, photon or
//! cache files) are `Input` and make the binary exit with status 2; everything else is a runtime failure
//! (status 1).

use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Bad user input, already phrased as one line naming the file and line, key or option.
    #[error("{0}")]
    Input(String),
    #[error("{0}")]
    Runtime(String),
    #[error("interrupted")]
    Interrupted,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    pub fn is_input(&self) -> bool {
        matches!(self, Error::Input(_))
    }
}

/// An input error at `file:line`.
pub(crate) fn at_line(file: &Path, line: usize, msg: impl std::fmt::Display) -> Error {
    Error::Input(format!("{}:{}: {}", file.display(), line, msg))
}

/// An input error about a whole file.
pub(crate) fn in_file(file: &Path, msg: impl std::fmt::Display) -> Error {
    Error::Input(format!("{}: {}", file.display(), msg))
}

/// An input error about a command-line option.
pub fn option(name: &str, msg: impl std::fmt::Display) -> Error {
    Error::Input(format!("option {name}: {msg}"))
}

pub(crate) fn runtime(msg: impl std::fmt::Display) -> Error {
    Error::Runtime(msg.to_string())
}

/// Resolves `rel` against the directory holding `base`.
pub(crate) fn relative_to(base: &Path, rel: &str) -> PathBuf {
    base.parent().unwrap_or(Path::new(".")).join(rel)
}

use std::path::{Path, PathBuf};

/// Everything that can go wrong reading or checking skin data.
///
/// Each variant names the file and the place in it (line, field, taxel) at fault.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The file is not valid JSON (truncated, bad syntax) or does not have the expected shape.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Json {
        /// The file.
        path: PathBuf,
        /// 1-based line of the error.
        line: usize,
        /// 1-based column of the error.
        column: usize,
        /// What the JSON parser said.
        message: String,
    },
    /// The file parses but its content is wrong: `place` names the line, field or taxel.
    #[error("{}: {place}: {message}", path.display())]
    Invalid {
        /// The file (or a description of the input when it did not come from a file).
        path: PathBuf,
        /// The line, field or taxel at fault, e.g. `line 12` or `taxel 83931 field "x"`.
        place: String,
        /// What is wrong with it.
        message: String,
    },
    /// A force model that does not fit the skin it is for (a calibration's curve or gains, or
    /// the areas of the skin's mesh): `place` names the link in the file.
    #[error("{}: {place}: {source}", path.display())]
    Force {
        /// The calibration file.
        path: PathBuf,
        /// The link, e.g. `link "forearm" model`.
        place: String,
        /// What does not fit (boxed: the rare error should not grow every `Result`).
        source: Box<crate::force::ForceError>,
    },
    /// A frame or a buffer does not have the length its taxels need.
    #[error("{what}: {got}, expected {expected}")]
    Length {
        /// What was counted, and against what, e.g. "readings of the frame for the baseline's taxels".
        what: &'static str,
        /// The length given.
        got: usize,
        /// The length needed.
        expected: usize,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_owned(),
            source,
        }
    }

    /// A JSON error of the file at `path`, placed at its line and column.
    pub fn json(path: &Path, e: &serde_json::Error) -> Self {
        // Errors found after parsing (the document's shape) have no position: say so rather
        // than point at line 0, column 0.
        if e.line() == 0 {
            return Error::invalid(path, "the document's structure", e.to_string());
        }
        Error::Json {
            path: path.to_owned(),
            line: e.line(),
            column: e.column(),
            message: e.to_string(),
        }
    }

    /// An [`Error::Invalid`] for `path` at `place`.
    pub fn invalid(path: &Path, place: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid {
            path: path.to_owned(),
            place: place.into(),
            message: message.into(),
        }
    }
}

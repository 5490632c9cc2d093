use std::path::PathBuf;

/// Everything that can go wrong reading CAN traffic, naming the file and line at fault.
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
    /// The file parses but its content is wrong; the message names the bus, module or slot.
    #[error("{}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong, and where.
        message: String,
    },
    /// A line of a log is not a CAN frame in the expected form.
    #[error("{}: line {line}: {message}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// A bus map carries a taxel that the layout does not have.
    #[error(
        "the bus map carries taxel {taxel}, which the layout does not have: is the bus map for this skin?"
    )]
    NotInLayout {
        /// The taxel.
        taxel: skin_core::TaxelId,
    },
    /// A text input that cannot be read as lines (binary, not UTF-8, a line too long, a
    /// damaged compressed file), naming the file and the line.
    #[error(transparent)]
    Text(#[from] skin_core::Error),
    /// A frame or a buffer of the wrong length.
    #[error("{what}: {got}, expected {expected}")]
    Length {
        /// What was counted, and against what.
        what: &'static str,
        /// The length given.
        got: usize,
        /// The length needed.
        expected: usize,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;

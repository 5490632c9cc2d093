//! An input of skin traffic that is either a candump log or a raw recording, told apart by its
//! first line and then read as it goes, in one pass ([`Traffic::open`]).

use crate::candump::CandumpReader;
use skin_core::format::recording::RecordingReader;
use skin_core::text::{Gzip, Input};
use std::io::BufRead as _;
use std::path::{Path, PathBuf};

/// A candump log or a raw recording (Cyskin's ids line, then index, time, counts), of any
/// length, gzip-compressed or not, positioned at its start.
#[derive(Debug)]
pub enum Traffic {
    /// A candump log.
    Log(CandumpReader<Input>),
    /// A raw recording.
    Recording(RecordingReader<Input>),
}

/// Why an input is neither a candump log nor a raw recording.
#[derive(Debug, thiserror::Error)]
pub enum TrafficError {
    /// The file cannot be opened, or is not text of lines (binary, UTF-16, not UTF-8).
    #[error(transparent)]
    Text(#[from] skin_core::Error),
    /// Its start cannot be read.
    #[error("cannot read {}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// Nothing in it.
    #[error("{}: empty file: neither a candump log nor a raw recording", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// Text, but neither form: why, as each.
    #[error("{} is neither a candump log ({log}) nor a raw recording ({recording})", path.display())]
    Neither {
        /// The file.
        path: PathBuf,
        /// Its first line's fault as a candump line (boxed: the two faults together would make
        /// every `Result` of this type large).
        log: Box<crate::Error>,
        /// Its fault as a raw recording.
        recording: Box<skin_core::Error>,
    },
}

impl Traffic {
    /// Opens `path` and looks at its first non-blank line (in what the reader has buffered: a
    /// candump line is far shorter than the buffer), reading nothing away from it.
    pub fn open(path: &Path) -> Result<Traffic, TrafficError> {
        Traffic::from_input(Input::open(path, Gzip::Read)?, path)
    }

    /// As [`Traffic::open`], on an input opened elsewhere (bytes in memory, a pipe); `path`
    /// names it in errors.
    pub fn from_input(mut input: Input, path: &Path) -> Result<Traffic, TrafficError> {
        let head = input.fill_buf().map_err(|source| TrafficError::Read {
            path: path.to_owned(),
            source,
        })?;
        let mut first = CandumpReader::new(head, path);
        let log_error = match first.next_frame() {
            Ok(Some(_)) => return Ok(Traffic::Log(CandumpReader::new(input, path))),
            // Error frames only: a log, which the session names as such.
            Ok(None) if first.error_frames() > 0 => {
                return Ok(Traffic::Log(CandumpReader::new(input, path)));
            }
            Ok(None) => {
                return Err(TrafficError::Empty {
                    path: path.to_owned(),
                });
            }
            Err(e @ crate::Error::Line { .. }) => Some(e),
            Err(_) => None,
        };
        match (RecordingReader::new(input, path), log_error) {
            (Ok(rec), _) => Ok(Traffic::Recording(rec)),
            (Err(recording), Some(log)) => Err(TrafficError::Neither {
                path: path.to_owned(),
                log: Box::new(log),
                recording: Box::new(recording),
            }),
            // Not text of lines at all (binary, UTF-16, not UTF-8): the reader says which.
            (Err(recording), None) => Err(recording.into()),
        }
    }
}

//! # skin-dataset: skin sessions as datasets (LeRobot v3 layout, Parquet)
//!
//! A robot-learning team turns hours of skin traffic into training sets with the tools of that
//! field (LeRobot, HF `datasets`, Ray Data, pyarrow). This crate writes what they read: every
//! frame's raw readings, losslessly, with the skin they come from.
//!
//! ```text
//! input (candump log | raw recording, file or bytes; gzip too)
//!   --Session (one per input: baseline, contacts, touches, decisions)--> Episode (a Sink)
//!     raw_frame  -> data/chunk-CCC/file-FFF.parquet      observation.tactile.<link>: float32
//!                                                          lists, counts as the skin sent them
//!     event      -> events/chunk-CCC/file-FFF.parquet    one row per event, its JSON whole
//!     frame      -> contacts/chunk-CCC/file-FFF.parquet  one row per contact per frame
//!   Dataset::finish -> meta/info.json (features, fps, "skin": layout and calibration),
//!                      meta/episodes/... (source, SHA-256, baselines), meta/tasks.parquet
//! ```
//!
//! The layout is LeRobot's v3 ([`lerobot`]): `load_dataset("parquet", data_files=
//! "DATASET/data/*/*.parquet")`, `ray.data.read_parquet("DATASET/data")` and
//! `pyarrow.parquet.read_table` read the frames; LeRobot's own reader finds them through
//! `meta/`. Each link's readings are in the input's order (the bus map's, as `skin replay -o`
//! writes a log's columns; the layout's for a recording), named by taxel id in `info.json`, the
//! positions and normals beside them; the baseline each episode ended with (offsets and noise,
//! per taxel) is in its row of the episodes table, so nothing of the readings is lost to it.
//!
//! A dataset is written as every output of skin is (`skin_core::output`): its files are built
//! aside and moved into place by [`Dataset::finish`]; an interrupted export leaves the folder as
//! it was. Appending ([`DatasetOptions::append`]) adds episodes to a dataset of the same skin
//! and refuses any other. An input that fails is reported by name and its episode's files are
//! removed; the others are kept ([`export_files`]).
//!
//! Parquet is written by the `parquet` crate's column writers without its Arrow layer (this
//! crate's `table` module): a dataset's tables are a few fixed columns, and the readings go
//! from the frame to the page without an Arrow array per row (and without Arrow's dozen crates
//! in the build).
//!
//! ```
//! use skin_dataset::{DatasetOptions, export_files};
//! use skin_learn::session::{FromConfig, Session, SessionConfig};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! # let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
//! # std::env::set_current_dir(&root)?;
//! let config = SessionConfig::read("fixtures/session/run.toml".as_ref())?;
//! let out = tempfile::tempdir()?;
//! let dataset = out.path().join("dataset");
//! let export = export_files(
//!     &["fixtures/session/session.candump.log".into()],
//!     &mut || Session::from_config(&config),
//!     &dataset,
//!     DatasetOptions::default(),
//! )?;
//! let summary = export.summary.expect("one episode");
//! assert!(export.failed.is_empty());
//! assert_eq!((summary.episodes, summary.fps), (1, 20)); // the session runs at 20 Hz
//! assert!(dataset.join("meta/info.json").is_file());
//! assert!(dataset.join("data/chunk-000/file-000.parquet").is_file());
//! # Ok(()) }
//! ```

mod dataset;
mod episode;
pub mod lerobot;
mod source;
mod table;

pub use dataset::{COMMAND, Dataset, DatasetOptions, DatasetSummary};
pub use episode::{Episode, EpisodeReport};
pub use source::{InputKind, Source, sha256_bytes, sha256_of};
pub use table::TableError;

use skin_can::{Traffic, TrafficError};
use skin_core::output::{Inputs, OutputError};
use skin_runtime::session::{Session, SessionError};
use std::path::{Path, PathBuf};

/// What writing a dataset can fail with; each names the file, input or folder at fault.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file could not be written (or read).
    #[error(transparent)]
    Core(#[from] skin_core::Error),
    /// An input is neither a candump log nor a raw recording, or cannot be read.
    #[error(transparent)]
    Input(#[from] TrafficError),
    /// The output folder refused (not a dataset of skin's, busy, full disk ...).
    #[error(transparent)]
    Output(#[from] OutputError),
    /// The session failed on an input (a corrupt log names its line).
    #[error("{}: {error}", input.display())]
    Session {
        /// The input.
        input: PathBuf,
        /// What the session said (boxed: a session's error is large, and every `Result` of
        /// this crate would carry its size).
        error: Box<SessionError>,
    },
    /// A table could not be written.
    #[error("{}: {source}", path.display())]
    Table {
        /// The file.
        path: PathBuf,
        /// What failed.
        source: TableError,
    },
    /// The folder holds a dataset already and appending was not asked for.
    #[error("{} holds a dataset already ({episodes} episode(s)): append to it (--append), or choose another folder", root.display())]
    Exists {
        /// The folder.
        root: PathBuf,
        /// Its episodes.
        episodes: u64,
    },
    /// `meta/info.json` of the dataset appended to is not one skin wrote.
    #[error("{}: not a dataset of skin's: {why}", path.display())]
    NotSkins {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// An input's skin is not the dataset's.
    #[error("{}: not the skin of the dataset {}: {why}; export it to a dataset of its own", input.display(), root.display())]
    OtherSkin {
        /// The input.
        input: PathBuf,
        /// The dataset.
        root: PathBuf,
        /// How it differs.
        why: String,
    },
    /// An input's frame rate is not the dataset's (a LeRobot dataset has one).
    #[error("{}: frames at {fps:.2} Hz, the dataset's are at {dataset} Hz; export it to a dataset of its own", input.display())]
    Rate {
        /// The input.
        input: PathBuf,
        /// Its rate, Hz.
        fps: f64,
        /// The dataset's, Hz.
        dataset: u32,
    },
    /// `--fps` is not the frame rate of the dataset appended to.
    #[error("{}: the dataset's frames are at {dataset} Hz, not the {asked} Hz asked for (--fps)", root.display())]
    FpsAsked {
        /// The dataset.
        root: PathBuf,
        /// Its rate, Hz.
        dataset: u32,
        /// The rate asked for, Hz.
        asked: u32,
    },
    /// The frame rate cannot be told from the first input (fewer than two frames, or frames
    /// without time between them).
    #[error("{}: its frame rate cannot be told from its stamps; give it (--fps)", input.display())]
    NoRate {
        /// The input.
        input: PathBuf,
    },
    /// An input gave no frame.
    #[error("{}: no frame of the skin in it", input.display())]
    NoFrames {
        /// The input.
        input: PathBuf,
    },
    /// Nothing was exported: a dataset needs an episode.
    #[error("no episode was exported: a dataset needs at least one")]
    NoEpisode,
    /// An event or the metadata could not be written as JSON.
    #[error("JSON: {0}")]
    Json(String),
}

/// An I/O error naming its file.
pub(crate) fn io_error(path: &Path, source: std::io::Error) -> skin_core::Error {
    skin_core::Error::Io {
        path: path.to_owned(),
        source,
    }
}

/// A `Result` with [`DatasetError`].
pub type Result<T, E = DatasetError> = std::result::Result<T, E>;

/// One input through a fresh `session` into the next episode of `dataset`. On failure the
/// episode's files are removed and the dataset is as it was before.
pub fn export_source(dataset: &mut Dataset, session: &mut Session, source: Source) -> Result<EpisodeReport> {
    let kind = source.kind();
    let Source {
        path,
        sha256,
        traffic,
    } = source;
    let mut episode = dataset.episode(session, &path, &sha256, kind.name())?;
    let run = match traffic {
        Traffic::Log(log) => session
            .run_log(log, &path, &mut episode, &mut |_, _| {})
            .map(|_| ()),
        Traffic::Recording(rec) => session.run_recording(rec, &path, &mut episode).map(|_| ()),
    };
    match run {
        Ok(()) => episode.finish(session),
        Err(error) => Err(DatasetError::Session {
            input: path,
            error: Box::new(error),
        }),
    }
}

/// What [`export_files`] did: the dataset (none when no input could be exported), and each
/// input that failed with why.
#[derive(Debug)]
pub struct Export {
    /// The dataset written.
    pub summary: Option<DatasetSummary>,
    /// The inputs left out, each with its error.
    pub failed: Vec<(PathBuf, DatasetError)>,
}

/// Exports `inputs` (candump logs or raw recordings) into the dataset at `root`, an episode
/// each, every input through a fresh session from `session`. An input that fails is left out
/// and reported ([`Export::failed`]); the others are written. Errors of the dataset itself (the
/// folder refused, a file that cannot be written: a full disk) fail the whole export, leaving
/// the folder as it was. The inputs of one dataset are all logs or all recordings: their
/// readings come in different orders (the bus map's, the layout's).
pub fn export_files(
    inputs: &[PathBuf],
    session: &mut dyn FnMut() -> Result<Session, SessionError>,
    root: &Path,
    options: DatasetOptions,
) -> Result<Export> {
    let mut dataset = Dataset::create(root, options, &Inputs::new(inputs))?;
    let mut failed = Vec::new();
    for path in inputs {
        let result = Source::open(path).map_err(DatasetError::from).and_then(|source| {
            let mut s = session().map_err(|error| DatasetError::Session {
                input: path.clone(),
                error: Box::new(error),
            })?;
            export_source(&mut dataset, &mut s, source)
        });
        match result {
            Ok(_) => {}
            // Writing the dataset failed (a full disk): no input would fare better.
            Err(e @ (DatasetError::Output(_) | DatasetError::Table { .. } | DatasetError::Core(_))) => {
                return Err(e);
            }
            Err(e) => failed.push((path.clone(), e)),
        }
    }
    let summary = if dataset.episodes_added() > 0 {
        Some(dataset.finish()?)
    } else {
        None
    };
    Ok(Export { summary, failed })
}

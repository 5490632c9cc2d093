//! The LeRobot v3 layout: where each table lives, and `meta/info.json` as LeRobot (0.4 to 0.6,
//! `codebase_version` "v3.0") writes it, with the skin's own description under its `skin` key.
//!
//! ```text
//! DATASET/meta/info.json                              features, fps, totals, paths; "skin": layout
//! DATASET/meta/tasks.parquet                          task (index) -> task_index
//! DATASET/meta/episodes/chunk-CCC/file-FFF.parquet    one row per episode (input): where its
//!                                                     frames are, its source, its baseline
//! DATASET/data/chunk-CCC/file-FFF.parquet             one row per frame: timestamp, indices,
//!                                                     observation.tactile.<link> (float32 lists)
//! DATASET/events/chunk-CCC/file-FFF.parquet           one row per event (skin's own table)
//! DATASET/contacts/chunk-CCC/file-FFF.parquet         one row per contact per frame (skin's own)
//! ```
//!
//! Episodes, frames, events and contacts are numbered across the whole dataset. Each episode
//! has a data, an events and a contacts file of its own, the three numbered alike: an input
//! that fails midway goes with its files, and LeRobot keeps an episode in one file too
//! (`data_files_size_in_mb` is LeRobot's default, the size past which it starts a new file
//! between episodes; skin starts one at every episode, so its files may be smaller, or, for an
//! episode of hours, larger). An export that appends to a dataset writes files of its own.
//!
//! In the events table, `timestamp` is the event's own time (a release: the touch's last
//! contact), s from the episode's first frame, float64; `frame_index` is the frame it came with
//! (a release: the frame the touch was found gone at; a missing module: the incomplete frame).
//! The frames' `timestamp` is their stamp from the first frame as LeRobot stores it, float32;
//! `time_us` is exact.

use serde::{Deserialize, Serialize};
use serde_json::{Value, json};

/// `codebase_version` of the layout written.
pub const CODEBASE_VERSION: &str = "v3.0";
/// Files per chunk folder (LeRobot's `DEFAULT_CHUNK_SIZE`).
pub const CHUNKS_SIZE: u64 = 1000;
/// A data file is closed for new episodes past this size (LeRobot's default), MB.
pub const DATA_FILES_SIZE_IN_MB: u64 = 100;
/// `info.json`'s `data_path`.
pub const DATA_PATH: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
/// The tables of a dataset, each a folder of chunked files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableKind {
    /// Frames (`data/`).
    Data,
    /// Episodes (`meta/episodes/`).
    Episodes,
    /// Events (`events/`).
    Events,
    /// Contacts (`contacts/`).
    Contacts,
}

impl TableKind {
    /// The table's folder in the dataset.
    pub fn dir(self) -> &'static str {
        match self {
            TableKind::Data => "data",
            TableKind::Episodes => "meta/episodes",
            TableKind::Events => "events",
            TableKind::Contacts => "contacts",
        }
    }

    /// The relative path of file `index` of the table (`chunk-CCC/file-FFF.parquet`, 1,000 files
    /// a chunk).
    pub fn path(self, index: FileIndex) -> String {
        format!(
            "{}/chunk-{:03}/file-{:03}.parquet",
            self.dir(),
            index.chunk,
            index.file
        )
    }
}

/// Where a file is: its chunk folder and its number in it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default)]
pub struct FileIndex {
    /// `chunk-CCC`.
    pub chunk: u64,
    /// `file-FFF`.
    pub file: u64,
}

impl FileIndex {
    /// The next file (a new chunk after 1,000).
    pub fn next(self) -> FileIndex {
        if self.file + 1 >= CHUNKS_SIZE {
            FileIndex {
                chunk: self.chunk + 1,
                file: 0,
            }
        } else {
            FileIndex {
                chunk: self.chunk,
                file: self.file + 1,
            }
        }
    }

    /// The first file after every file of `table` under `root` (the first of all when none).
    pub fn after_existing(root: &std::path::Path, table: TableKind) -> FileIndex {
        let number = |name: &str, prefix: &str, suffix: &str| {
            name.strip_prefix(prefix)?
                .strip_suffix(suffix)?
                .parse::<u64>()
                .ok()
        };
        let mut last: Option<FileIndex> = None;
        let dir = root.join(table.dir());
        for chunk in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let name = chunk.file_name().to_string_lossy().into_owned();
            let Some(c) = number(&name, "chunk-", "") else {
                continue;
            };
            for file in std::fs::read_dir(chunk.path()).into_iter().flatten().flatten() {
                let name = file.file_name().to_string_lossy().into_owned();
                if let Some(f) = number(&name, "file-", ".parquet") {
                    let here = FileIndex { chunk: c, file: f };
                    last = Some(last.map_or(here, |l| l.max(here)));
                }
            }
        }
        last.map_or_else(FileIndex::default, FileIndex::next)
    }
}

/// One link of the skin as the dataset describes it: its readings' column, and each taxel's id,
/// position and normal in the column's order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinkMeta {
    /// The link's name in the layout.
    pub name: String,
    /// The feature holding its readings: `observation.tactile.<name>`.
    pub feature: String,
    /// Taxel ids (as the layout writes them, `module:slot` style or numbers), column order.
    pub taxels: Vec<String>,
    /// Positions in the link frame, metres, column order.
    pub positions: Vec<[f64; 3]>,
    /// Outward normals, column order.
    pub normals: Vec<[f64; 3]>,
}

/// What `info.json`'s `skin` key holds: the skin the readings come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SkinMeta {
    /// `skin-dataset/1`.
    pub format: String,
    /// What the readings are: "counts as the skin sent them" (the baselines are per episode,
    /// in the episodes table).
    pub units: String,
    /// How each link's readings are ordered: "bus map" (the order `skin replay -o` writes a
    /// log's columns in) or "layout".
    pub order: String,
    /// The links, in the layout's order.
    pub links: Vec<LinkMeta>,
    /// The tasks, by task index.
    pub tasks: Vec<String>,
}

/// The feature of a link's readings.
pub fn tactile_feature(link: &str) -> String {
    format!("observation.tactile.{link}")
}

/// A scalar feature as LeRobot describes it.
fn scalar(dtype: &str) -> Value {
    json!({"dtype": dtype, "shape": [1], "names": null})
}

/// `info.json` for a dataset of `skin` with these totals.
pub fn info(skin: &SkinMeta, fps: u32, robot_type: Option<&str>, episodes: u64, frames: u64) -> Value {
    let mut features = serde_json::Map::new();
    for (k, v) in [
        ("timestamp", scalar("float32")),
        ("frame_index", scalar("int64")),
        ("episode_index", scalar("int64")),
        ("index", scalar("int64")),
        ("task_index", scalar("int64")),
        ("time_us", scalar("int64")),
        ("cycle", scalar("int64")),
        ("complete", scalar("bool")),
    ] {
        features.insert(k.to_owned(), v);
    }
    for link in &skin.links {
        features.insert(
            link.feature.clone(),
            json!({"dtype": "float32", "shape": [link.taxels.len()], "names": link.taxels}),
        );
    }
    json!({
        "codebase_version": CODEBASE_VERSION,
        "robot_type": robot_type,
        "total_episodes": episodes,
        "total_frames": frames,
        "total_tasks": skin.tasks.len(),
        "chunks_size": CHUNKS_SIZE,
        "data_files_size_in_mb": DATA_FILES_SIZE_IN_MB,
        "video_files_size_in_mb": 500,
        "fps": fps,
        "splits": {"train": format!("0:{episodes}")},
        "data_path": DATA_PATH,
        "video_path": null,
        "features": features,
        "skin": skin,
    })
}

/// The `pandas` metadata of `meta/tasks.parquet`: its `task` column is the frame's index, as
/// LeRobot writes it (`pd.DataFrame({"task_index": ...}, index=pd.Index(tasks, name="task"))`).
pub fn tasks_pandas_metadata() -> String {
    json!({
        "index_columns": ["task"],
        "column_indexes": [{"name": null, "field_name": null, "pandas_type": "unicode",
            "numpy_type": "object", "metadata": {"encoding": "UTF-8"}}],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64",
                "numpy_type": "int64", "metadata": null},
            {"name": "task", "field_name": "task", "pandas_type": "unicode",
                "numpy_type": "object", "metadata": null}
        ],
        "creator": {"library": "skin", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.3"
    })
    .to_string()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn file_indices_roll_over_into_a_new_chunk_after_a_thousand() {
        let last = FileIndex { chunk: 0, file: 999 };
        assert_eq!(last.next(), FileIndex { chunk: 1, file: 0 });
        assert_eq!(
            TableKind::Data.path(FileIndex { chunk: 1, file: 7 }),
            "data/chunk-001/file-007.parquet"
        );
        assert_eq!(
            TableKind::Episodes.path(FileIndex::default()),
            "meta/episodes/chunk-000/file-000.parquet"
        );
    }

    #[test]
    fn the_next_file_follows_the_last_one_on_disk() {
        let dir = tempfile::tempdir().unwrap();
        assert_eq!(
            FileIndex::after_existing(dir.path(), TableKind::Data),
            FileIndex::default()
        );
        for p in [
            "data/chunk-000/file-000.parquet",
            "data/chunk-000/file-004.parquet",
            "data/chunk-000/notes.txt",
        ] {
            let p = dir.path().join(p);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(p, b"").unwrap();
        }
        assert_eq!(
            FileIndex::after_existing(dir.path(), TableKind::Data),
            FileIndex { chunk: 0, file: 5 }
        );
    }
}

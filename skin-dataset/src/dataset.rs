//! A dataset being written: opened new or for appending, an episode per input, committed whole.

use crate::episode::{Episode, EpisodeReport};
use crate::lerobot::{self, FileIndex, LinkMeta, SkinMeta, TableKind};
use crate::table::{Column, Kind, Table, TableError, Value};
use crate::{DatasetError, Result};
use parquet::file::metadata::KeyValue;
use skin_core::output::{Inputs, OutputDir};
use skin_runtime::session::Session;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The command name a dataset's folder records (its manifest): only a dataset this names is
/// written into again.
pub const COMMAND: &str = "skin export";

/// How a dataset is written.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetOptions {
    /// The task of the episodes (LeRobot's `task`): what was being done.
    pub task: String,
    /// `robot_type` in `info.json` (none: null).
    pub robot_type: Option<String>,
    /// Frames per second (`fps`); none: measured from the first episode's stamps.
    pub fps: Option<u32>,
    /// Add the episodes to the dataset already at the folder (same skin) instead of refusing it.
    pub append: bool,
}

impl Default for DatasetOptions {
    fn default() -> DatasetOptions {
        DatasetOptions {
            task: "skin session".to_owned(),
            robot_type: None,
            fps: None,
            append: false,
        }
    }
}

/// A table file in the staging folder.
pub(crate) type TableFile = Table<BufWriter<File>>;

/// What is in the dataset already (appending).
#[derive(Debug, Clone)]
struct Before {
    skin: SkinMeta,
    fps: u32,
    robot_type: Option<String>,
    episodes: u64,
    frames: u64,
}

/// A dataset being written (see the [crate] page). Dropped without [`Dataset::finish`], it
/// leaves the folder as it was.
pub struct Dataset {
    pub(crate) out: OutputDir,
    root: PathBuf,
    pub(crate) options: DatasetOptions,
    before: Option<Before>,
    /// The skin, fixed by the dataset appended to or by the first episode.
    pub(crate) skin: Option<SkinMeta>,
    pub(crate) fps: Option<u32>,
    pub(crate) next_episode: u64,
    pub(crate) next_index: u64,
    /// Data, events and contacts files of the next episode.
    pub(crate) next_file: FileIndex,
    episodes_file: FileIndex,
    episodes: Option<TableFile>,
    pub(crate) done: Vec<EpisodeReport>,
}

impl std::fmt::Debug for Dataset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dataset")
            .field("root", &self.root)
            .field("episodes", &self.done.len())
            .finish_non_exhaustive()
    }
}

/// What a finished dataset holds.
#[derive(Debug, Clone, PartialEq)]
pub struct DatasetSummary {
    /// Its folder.
    pub root: PathBuf,
    /// Episodes and frames in all (those before an append included).
    pub episodes: u64,
    /// Frames in all.
    pub frames: u64,
    /// Frames per second.
    pub fps: u32,
    /// The episodes this export added.
    pub added: Vec<EpisodeReport>,
}

fn read_before(root: &Path) -> Result<Option<Before>> {
    let path = root.join("meta/info.json");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(crate::io_error(&path, e).into()),
    };
    let bad = |why: String| DatasetError::NotSkins {
        path: path.clone(),
        why,
    };
    let info: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let skin: SkinMeta =
        serde_json::from_value(info["skin"].clone()).map_err(|e| bad(format!("its \"skin\" key: {e}")))?;
    let number = |key: &str| {
        info[key]
            .as_u64()
            .ok_or_else(|| bad(format!("no whole number \"{key}\"")))
    };
    Ok(Some(Before {
        fps: u32::try_from(number("fps")?).map_err(|e| bad(format!("fps: {e}")))?,
        episodes: number("total_episodes")?,
        frames: number("total_frames")?,
        robot_type: info["robot_type"].as_str().map(str::to_owned),
        skin,
    }))
}

impl Dataset {
    /// Opens `root` for a new dataset (created if missing; an existing dataset there is refused
    /// unless `options.append`), naming `inputs` so that none is written over.
    pub fn create(root: &Path, options: DatasetOptions, inputs: &Inputs) -> Result<Dataset> {
        OutputDir::precheck(root, COMMAND, false)?;
        // A commit cut short (its INCOMPLETE marker still there) left no dataset to keep: a new
        // export replaces what it moved in; appending to it is refused.
        let cut_short = root.join("INCOMPLETE").is_file();
        if cut_short && options.append {
            return Err(DatasetError::NotSkins {
                path: root.to_owned(),
                why: "its last export was cut short (INCOMPLETE): files it lists may be missing; \
                      export every input of it again, into a new folder"
                    .to_owned(),
            });
        }
        let before = if cut_short { None } else { read_before(root)? };
        if let Some(b) = &before
            && !options.append
        {
            return Err(DatasetError::Exists {
                root: root.to_owned(),
                episodes: b.episodes,
            });
        }
        if let (Some(b), Some(want)) = (&before, options.fps)
            && b.fps != want
        {
            return Err(DatasetError::FpsAsked {
                root: root.to_owned(),
                dataset: b.fps,
                asked: want,
            });
        }
        let mut out = OutputDir::create(root, COMMAND, false, inputs)?;
        if before.is_some() {
            out.keep_previous();
        }
        let (skin, fps) = match &before {
            Some(b) => (Some(b.skin.clone()), Some(b.fps)),
            None => (None, options.fps),
        };
        Ok(Dataset {
            root: root.to_owned(),
            next_episode: before.as_ref().map_or(0, |b| b.episodes),
            next_index: before.as_ref().map_or(0, |b| b.frames),
            // Files are numbered on after the dataset appended to (a new one starts at 0,
            // replacing what a commit cut short left).
            next_file: if before.is_some() {
                FileIndex::after_existing(root, TableKind::Data)
                    .max(FileIndex::after_existing(root, TableKind::Events))
                    .max(FileIndex::after_existing(root, TableKind::Contacts))
            } else {
                FileIndex::default()
            },
            episodes_file: if before.is_some() {
                FileIndex::after_existing(root, TableKind::Episodes)
            } else {
                FileIndex::default()
            },
            episodes: None,
            out,
            options,
            before,
            skin,
            fps,
            done: Vec::new(),
        })
    }

    /// Episodes this export has added so far.
    pub fn episodes_added(&self) -> usize {
        self.done.len()
    }

    /// The dataset's folder.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Starts the next episode: `session` (fresh, built for this input) is about to run
    /// `source_name` (hashed `sha256`). Its skin must be the dataset's. Hand the returned
    /// [`Episode`] to the session as its sink, then [`Episode::finish`] it (or drop it: its
    /// files go).
    pub fn episode(
        &mut self,
        session: &Session,
        source: &Path,
        sha256: &str,
        kind: &str,
    ) -> Result<Episode<'_>> {
        let skin = skin_of(session, &self.options.task);
        match &mut self.skin {
            Some(known) => {
                if let Some(why) = differs(known, &skin) {
                    return Err(DatasetError::OtherSkin {
                        input: source.to_owned(),
                        root: self.root.clone(),
                        why,
                    });
                }
                if !known.tasks.contains(&self.options.task) {
                    known.tasks.push(self.options.task.clone());
                }
            }
            None => self.skin = Some(skin),
        }
        Episode::start(self, session, source, sha256, kind)
    }

    /// Path in the staging folder of a table's file; its folder is made.
    pub(crate) fn staged(&self, table: TableKind, index: FileIndex) -> Result<PathBuf> {
        let path = self.out.path().join(table.path(index));
        if let Some(dir) = path.parent() {
            let _gate = skin_core::output::writing();
            std::fs::create_dir_all(dir).map_err(|e| crate::io_error(dir, e))?;
        }
        Ok(path)
    }

    /// Creates a table file in the staging folder.
    pub(crate) fn table(
        &self,
        table: TableKind,
        index: FileIndex,
        columns: Vec<Column>,
        meta: Vec<KeyValue>,
    ) -> Result<TableFile> {
        let path = self.staged(table, index)?;
        let _gate = skin_core::output::writing();
        let file = File::create(&path).map_err(|e| crate::io_error(&path, e))?;
        Table::new(BufWriter::with_capacity(1 << 20, file), columns, meta).map_err(|e| table_error(&path, e))
    }

    /// The episodes table of this export, opened on first use.
    pub(crate) fn episodes_table(&mut self) -> Result<&mut TableFile> {
        if self.episodes.is_none() {
            let columns = episode_columns(self.skin.as_ref().map_or(&[][..], |s| &s.links));
            let t = self.table(TableKind::Episodes, self.episodes_file, columns, Vec::new())?;
            self.episodes = Some(t);
        }
        self.episodes.as_mut().ok_or(DatasetError::NoEpisode)
    }

    /// Where the episodes of this export are listed.
    pub(crate) fn episodes_file(&self) -> FileIndex {
        self.episodes_file
    }

    /// Writes `meta/info.json` and `meta/tasks.parquet` and moves everything into place. Fails,
    /// leaving the folder as it was, when no episode was added.
    pub fn finish(mut self) -> Result<DatasetSummary> {
        let (Some(skin), Some(fps), Some(table)) = (self.skin.take(), self.fps, self.episodes.take()) else {
            return Err(DatasetError::NoEpisode);
        };
        let episodes_path = self.out.path().join(TableKind::Episodes.path(self.episodes_file));
        finish_table(table, &episodes_path)?;
        let episodes = self.next_episode;
        let frames = self.next_index;
        let robot_type = self
            .options
            .robot_type
            .clone()
            .or_else(|| self.before.as_ref().and_then(|b| b.robot_type.clone()));
        let info = lerobot::info(&skin, fps, robot_type.as_deref(), episodes, frames);
        let info_path = self.staged_meta("info.json")?;
        let text = serde_json::to_string_pretty(&info).map_err(|e| DatasetError::Json(e.to_string()))?;
        {
            let _gate = skin_core::output::writing();
            std::fs::write(&info_path, text).map_err(|e| crate::io_error(&info_path, e))?;
        }
        self.write_tasks(&skin.tasks)?;
        let root = self.root.clone();
        let added = std::mem::take(&mut self.done);
        self.out.commit()?;
        Ok(DatasetSummary {
            root,
            episodes,
            frames,
            fps,
            added,
        })
    }

    fn staged_meta(&self, name: &str) -> Result<PathBuf> {
        let dir = self.out.path().join("meta");
        let _gate = skin_core::output::writing();
        std::fs::create_dir_all(&dir).map_err(|e| crate::io_error(&dir, e))?;
        Ok(dir.join(name))
    }

    fn write_tasks(&self, tasks: &[String]) -> Result<()> {
        let path = self.staged_meta("tasks.parquet")?;
        let columns = vec![
            Column::new("task_index", Kind::I64),
            Column::new("task", Kind::Str),
        ];
        let meta = vec![KeyValue::new(
            "pandas".to_owned(),
            lerobot::tasks_pandas_metadata(),
        )];
        let file = {
            let _gate = skin_core::output::writing();
            File::create(&path).map_err(|e| crate::io_error(&path, e))?
        };
        let mut t = Table::new(BufWriter::new(file), columns, meta).map_err(|e| table_error(&path, e))?;
        for (i, task) in tasks.iter().enumerate() {
            t.push(&[Value::I64(i as i64), Value::Str(task)])
                .map_err(|e| table_error(&path, e))?;
        }
        finish_table(t, &path)
    }
}

/// Finishes a table file: footer written, flushed (not synced: skin's outputs are whole once
/// renamed into place, as every output of skin_core::output is, without an fsync per file).
pub(crate) fn finish_table(table: TableFile, path: &Path) -> Result<()> {
    let out = table.finish().map_err(|e| table_error(path, e))?;
    out.into_inner()
        .map_err(|e| crate::io_error(path, e.into_error()))?;
    Ok(())
}

pub(crate) fn table_error(path: &Path, e: TableError) -> DatasetError {
    DatasetError::Table {
        path: path.to_owned(),
        source: e,
    }
}

/// The episodes table's columns: LeRobot's, then the skin's (source, hash, baselines).
fn episode_columns(links: &[LinkMeta]) -> Vec<Column> {
    let mut c: Vec<Column> = Column::list(&[
        ("episode_index", Kind::I64),
        ("tasks", Kind::ListStr),
        ("length", Kind::I64),
        ("data/chunk_index", Kind::I64),
        ("data/file_index", Kind::I64),
        ("dataset_from_index", Kind::I64),
        ("dataset_to_index", Kind::I64),
        ("meta/episodes/chunk_index", Kind::I64),
        ("meta/episodes/file_index", Kind::I64),
        ("skin/source", Kind::Str),
        ("skin/sha256", Kind::Str),
        ("skin/input_kind", Kind::Str),
        ("skin/incomplete_frames", Kind::I64),
        ("skin/events", Kind::I64),
        ("skin/contacts", Kind::I64),
    ]);
    for l in links {
        c.push(Column::new(format!("skin/baseline/{}", l.name), Kind::ListF32));
        c.push(Column::new(format!("skin/noise/{}", l.name), Kind::ListF32));
    }
    c
}

/// The skin of a session as the dataset describes it: links, taxels in the input's order.
fn skin_of(session: &Session, task: &str) -> SkinMeta {
    let order = session.wire_order();
    let links = session
        .links()
        .iter()
        .zip(&order)
        .map(|(link, order)| {
            let taxels = order.iter().map(|&i| &link.taxels[i]);
            LinkMeta {
                name: link.name.clone(),
                feature: lerobot::tactile_feature(&link.name),
                taxels: taxels.clone().map(|t| t.id.to_string()).collect(),
                positions: taxels.clone().map(|t| t.position.coords.into()).collect(),
                normals: taxels.map(|t| t.normal.into_inner().into()).collect(),
            }
        })
        .collect();
    SkinMeta {
        format: "skin-dataset/1".to_owned(),
        units: "counts as the skin sent them (no baseline subtracted)".to_owned(),
        order: if session.busmap().is_some() {
            "bus map"
        } else {
            "layout"
        }
        .to_owned(),
        links,
        tasks: vec![task.to_owned()],
    }
}

/// Why `new` is not the skin `known` describes, if it is not.
fn differs(known: &SkinMeta, new: &SkinMeta) -> Option<String> {
    let names = |s: &SkinMeta| s.links.iter().map(|l| l.name.clone()).collect::<Vec<_>>();
    if names(known) != names(new) {
        return Some(format!(
            "links {:?}, the dataset's are {:?}",
            names(new),
            names(known)
        ));
    }
    if known.order != new.order {
        return Some(format!(
            "readings in {} order, the dataset's in {} order",
            new.order, known.order
        ));
    }
    for (k, n) in known.links.iter().zip(&new.links) {
        if k.taxels != n.taxels {
            return Some(format!(
                "link {}: {} taxels, not the dataset's {} (or not in its order)",
                n.name,
                n.taxels.len(),
                k.taxels.len()
            ));
        }
        if k.positions != n.positions || k.normals != n.normals {
            return Some(format!(
                "link {}: taxels placed otherwise (another calibration)",
                n.name
            ));
        }
    }
    None
}

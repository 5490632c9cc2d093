//! One episode: a session's sink that writes every frame's raw readings, its events and its
//! contacts as they come, into files of the episode's own.

use crate::dataset::{Dataset, TableFile, finish_table, table_error};
use crate::lerobot::{FileIndex, TableKind};
use crate::table::{Column, Kind, Value};
use crate::{DatasetError, Result};
use skin_runtime::session::{Event, Flow, ProcessedFrame, RawFrame, Session, Sink};
use std::path::{Path, PathBuf};

/// What one episode added.
#[derive(Debug, Clone, PartialEq)]
pub struct EpisodeReport {
    /// The episode's index in the dataset.
    pub episode: u64,
    /// The input it came from.
    pub source: PathBuf,
    /// The input's SHA-256 (of its bytes as stored), hex.
    pub sha256: String,
    /// Frames (rows of the data table).
    pub frames: u64,
    /// Frames a module was missing from (its taxels held their last readings).
    pub incomplete: u64,
    /// Events, and contacts (one per contact per frame).
    pub events: u64,
    /// Contacts.
    pub contacts: u64,
    /// The frame rate measured from its stamps, Hz (none from fewer than two frames).
    pub rate_hz: Option<f64>,
    /// Its data file, relative to the dataset.
    pub data_file: String,
}

/// Stamps kept to measure an episode's frame rate.
const RATE_STAMPS: usize = 512;

/// An episode being written: the sink of one session's run (see [`Dataset::episode`]). Dropped
/// without [`Episode::finish`], its files are removed.
pub struct Episode<'a> {
    ds: &'a mut Dataset,
    source: PathBuf,
    sha256: String,
    kind: String,
    file: FileIndex,
    paths: [PathBuf; 3],
    data: Option<TableFile>,
    events: Option<TableFile>,
    contacts: Option<TableFile>,
    /// Per link, the layout indices of its readings' columns.
    order: Vec<Vec<usize>>,
    names: Vec<String>,
    /// Per link, the readings of the frame being written, in column order.
    row: Vec<Vec<f32>>,
    episode: u64,
    task_index: i64,
    first_index: u64,
    frames: u64,
    incomplete: u64,
    event_count: u64,
    contact_count: u64,
    stamps: Vec<u64>,
    line: Vec<u8>,
    error: Option<DatasetError>,
}

impl std::fmt::Debug for Episode<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Episode")
            .field("source", &self.source)
            .field("frames", &self.frames)
            .finish_non_exhaustive()
    }
}

fn data_columns(names: &[String]) -> Vec<Column> {
    let mut c: Vec<Column> = Column::list(&[
        ("timestamp", Kind::F32),
        ("frame_index", Kind::I64),
        ("episode_index", Kind::I64),
        ("index", Kind::I64),
        ("task_index", Kind::I64),
        ("time_us", Kind::I64),
        ("cycle", Kind::I64),
        ("complete", Kind::Bool),
    ]);
    c.extend(
        names
            .iter()
            .map(|l| Column::new(crate::lerobot::tactile_feature(l), Kind::ListF32)),
    );
    c
}

fn event_columns() -> Vec<Column> {
    Column::list(&[
        ("episode_index", Kind::I64),
        ("frame_index", Kind::I64),
        ("index", Kind::I64),
        ("timestamp", Kind::F64),
        ("kind", Kind::Str),
        ("link", Kind::OptStr),
        ("touch", Kind::OptI64),
        ("json", Kind::Str),
    ])
}

fn contact_columns() -> Vec<Column> {
    Column::list(&[
        ("episode_index", Kind::I64),
        ("frame_index", Kind::I64),
        ("index", Kind::I64),
        ("timestamp", Kind::F64),
        ("link", Kind::Str),
        ("taxels", Kind::I64),
        ("centroid_x", Kind::F64),
        ("centroid_y", Kind::F64),
        ("centroid_z", Kind::F64),
        ("mean_pressure", Kind::F32),
        ("peak_pressure", Kind::F32),
        ("force_n", Kind::OptF64),
    ])
}

impl<'a> Episode<'a> {
    pub(crate) fn start(
        ds: &'a mut Dataset,
        session: &Session,
        source: &Path,
        sha256: &str,
        kind: &str,
    ) -> Result<Episode<'a>> {
        let names: Vec<String> = session.links().iter().map(|l| l.name.clone()).collect();
        let order = session.wire_order();
        let file = ds.next_file;
        let paths = [TableKind::Data, TableKind::Events, TableKind::Contacts]
            .map(|t| ds.out.path().join(t.path(file)));
        let data = ds.table(TableKind::Data, file, data_columns(&names), Vec::new())?;
        let mut episode = Episode {
            source: source.to_owned(),
            sha256: sha256.to_owned(),
            kind: kind.to_owned(),
            file,
            paths,
            data: Some(data),
            events: None,
            contacts: None,
            row: order.iter().map(|o| vec![0.0; o.len()]).collect(),
            order,
            names,
            episode: ds.next_episode,
            task_index: Self::task_of(ds),
            first_index: ds.next_index,
            frames: 0,
            incomplete: 0,
            event_count: 0,
            contact_count: 0,
            stamps: Vec::with_capacity(RATE_STAMPS),
            line: Vec::with_capacity(512),
            error: None,
            ds,
        };
        episode.events = Some(
            episode
                .ds
                .table(TableKind::Events, file, event_columns(), Vec::new())?,
        );
        episode.contacts = Some(episode.ds.table(
            TableKind::Contacts,
            file,
            contact_columns(),
            Vec::new(),
        )?);
        Ok(episode)
    }

    fn write_frame(&mut self, frame: &RawFrame<'_>) -> Result<()> {
        for ((row, order), readings) in self.row.iter_mut().zip(&self.order).zip(frame.readings) {
            for (dst, &i) in row.iter_mut().zip(order) {
                *dst = readings[i];
            }
        }
        let i = self.frames as i64;
        let head = [
            Value::F32(frame.time as f32),
            Value::I64(i),
            Value::I64(self.episode as i64),
            Value::I64(self.first_index as i64 + i),
            Value::I64(self.task_index),
            Value::I64(i64::try_from(frame.time_us).unwrap_or(i64::MAX)),
            Value::I64(i64::try_from(frame.cycle).unwrap_or(i64::MAX)),
            Value::Bool(frame.complete),
        ];
        // No allocation per frame: the row's values live in a fixed array for up to 8 links.
        let mut values: smallvec_row::Row<'_> = smallvec_row::Row::new(&head);
        for r in &self.row {
            values.push(Value::ListF32(r));
        }
        let data = self.data.as_mut().ok_or(DatasetError::NoEpisode)?;
        data.push(values.as_slice())
            .map_err(|e| table_error(&self.paths[0], e))?;
        self.frames += 1;
        if !frame.complete {
            self.incomplete += 1;
        }
        if self.stamps.len() < RATE_STAMPS {
            self.stamps.push(frame.time_us);
        }
        Ok(())
    }

    /// The task's index in the dataset's tasks (looked up once, at the episode's start).
    fn task_of(ds: &Dataset) -> i64 {
        ds.skin
            .as_ref()
            .and_then(|s| s.tasks.iter().position(|t| *t == ds.options.task))
            .unwrap_or(0) as i64
    }

    fn write_event(&mut self, event: &Event) -> Result<()> {
        self.line.clear();
        event
            .write_json(&mut self.line)
            .map_err(|e| DatasetError::Json(e.to_string()))?;
        let json = std::str::from_utf8(&self.line).map_err(|e| DatasetError::Json(e.to_string()))?;
        let parsed: serde_json::Value =
            serde_json::from_str(json).map_err(|e| DatasetError::Json(e.to_string()))?;
        // An event belongs to the frame it came with: the session's events of a frame follow its
        // raw readings, but a missing module and a counter restart are said of the traffic
        // before the frame is taken, so they belong to the frame that follows.
        let frame = match event {
            Event::Incomplete { .. } | Event::CounterReset { .. } => self.frames,
            _ => self.frames.saturating_sub(1),
        } as i64;
        let row = [
            Value::I64(self.episode as i64),
            Value::I64(frame),
            Value::I64(self.first_index as i64 + frame),
            Value::F64(event.time()),
            Value::Str(event.kind()),
            Value::OptStr(parsed["link"].as_str()),
            Value::OptI64(parsed["touch"].as_i64()),
            Value::Str(json),
        ];
        let t = self.events.as_mut().ok_or(DatasetError::NoEpisode)?;
        t.push(&row).map_err(|e| table_error(&self.paths[1], e))?;
        self.event_count += 1;
        Ok(())
    }

    fn write_contacts(&mut self, frame: &ProcessedFrame<'_>) -> Result<()> {
        let index = self.frames.saturating_sub(1) as i64;
        let t = self.contacts.as_mut().ok_or(DatasetError::NoEpisode)?;
        for (l, name) in self.names.iter().enumerate() {
            for c in frame.contacts(l) {
                let row = [
                    Value::I64(self.episode as i64),
                    Value::I64(index),
                    Value::I64(self.first_index as i64 + index),
                    Value::F64(frame.time),
                    Value::Str(name),
                    Value::I64(c.taxels.len() as i64),
                    Value::F64(c.centroid.x),
                    Value::F64(c.centroid.y),
                    Value::F64(c.centroid.z),
                    Value::F32(c.mean_pressure),
                    Value::F32(c.peak_pressure),
                    Value::OptF64(c.force_n),
                ];
                t.push(&row).map_err(|e| table_error(&self.paths[2], e))?;
                self.contact_count += 1;
            }
        }
        Ok(())
    }

    /// A failure of the sink, kept for [`Episode::finish`] (the session stops at once).
    fn keep(&mut self, result: Result<()>) -> Flow {
        match result {
            Ok(()) => Flow::Continue(()),
            Err(e) => {
                self.error.get_or_insert(e);
                Flow::Break(())
            }
        }
    }

    /// The frame rate of the stamps seen, Hz: from the median interval between frames.
    fn rate(&self) -> Option<f64> {
        let mut gaps: Vec<u64> = self
            .stamps
            .windows(2)
            .map(|w| w[1].saturating_sub(w[0]))
            .collect();
        gaps.sort_unstable();
        let median = *gaps.get(gaps.len() / 2)?;
        (median > 0).then(|| 1e6 / median as f64)
    }

    /// Ends the episode after `session` ran it: its files finished, its row in the episodes
    /// table (with the session's baselines). Fails for a session that failed the sink, an
    /// episode without frames, or a frame rate other than the dataset's.
    pub fn finish(mut self, session: &Session) -> Result<EpisodeReport> {
        if let Some(e) = self.error.take() {
            return Err(e);
        }
        if self.frames == 0 {
            return Err(DatasetError::NoFrames {
                input: self.source.clone(),
            });
        }
        let rate = self.rate();
        self.check_rate(rate)?;
        for (slot, path) in [self.data.take(), self.events.take(), self.contacts.take()]
            .into_iter()
            .zip(self.paths.clone())
        {
            if let Some(t) = slot {
                finish_table(t, &path)?;
            }
        }
        self.write_episode_row(session)?;
        let report = EpisodeReport {
            episode: self.episode,
            source: self.source.clone(),
            sha256: self.sha256.clone(),
            frames: self.frames,
            incomplete: self.incomplete,
            events: self.event_count,
            contacts: self.contact_count,
            rate_hz: rate,
            data_file: TableKind::Data.path(self.file),
        };
        self.ds.next_episode += 1;
        self.ds.next_index += self.frames;
        self.ds.next_file = self.file.next();
        self.ds.done.push(report.clone());
        // Finished: nothing to remove on drop.
        self.paths = Default::default();
        Ok(report)
    }

    fn check_rate(&mut self, rate: Option<f64>) -> Result<()> {
        match (self.ds.fps, rate) {
            (Some(fps), Some(hz)) if (hz / f64::from(fps) - 1.0).abs() > 0.05 => Err(DatasetError::Rate {
                input: self.source.clone(),
                fps: hz,
                dataset: fps,
            }),
            (Some(_), _) => Ok(()),
            (None, Some(hz)) if hz >= 0.5 => {
                self.ds.fps = Some(hz.round() as u32);
                Ok(())
            }
            (None, _) => Err(DatasetError::NoRate {
                input: self.source.clone(),
            }),
        }
    }

    fn write_episode_row(&mut self, session: &Session) -> Result<()> {
        let baselines = session.baselines();
        let reorder = |values: Option<&[f32]>, order: &[usize]| -> Vec<f32> {
            values.map_or_else(Vec::new, |v| order.iter().map(|&i| v[i]).collect())
        };
        let mut lists: Vec<Vec<f32>> = Vec::new();
        for (l, order) in self.order.iter().enumerate() {
            lists.push(reorder(baselines.get(l).map(|b| b.offsets()), order));
            lists.push(reorder(baselines.get(l).map(|b| b.noise()), order));
        }
        let tasks = vec![self.ds.options.task.clone()];
        let meta = self.ds.episodes_file();
        let source = self.source.display().to_string();
        let mut row = vec![
            Value::I64(self.episode as i64),
            Value::ListStr(&tasks),
            Value::I64(self.frames as i64),
            Value::I64(self.file.chunk as i64),
            Value::I64(self.file.file as i64),
            Value::I64(self.first_index as i64),
            Value::I64((self.first_index + self.frames) as i64),
            Value::I64(meta.chunk as i64),
            Value::I64(meta.file as i64),
            Value::Str(&source),
            Value::Str(&self.sha256),
            Value::Str(&self.kind),
            Value::I64(self.incomplete as i64),
            Value::I64(self.event_count as i64),
            Value::I64(self.contact_count as i64),
        ];
        row.extend(lists.iter().map(|v| Value::ListF32(v)));
        let path = self.ds.out.path().join(TableKind::Episodes.path(meta));
        let table = self.ds.episodes_table()?;
        table.push(&row).map_err(|e| table_error(&path, e))
    }
}

impl Drop for Episode<'_> {
    fn drop(&mut self) {
        // Unfinished: the tables are closed and their files removed (the staging folder is the
        // dataset's own; nothing of the user's is there).
        self.data = None;
        self.events = None;
        self.contacts = None;
        for p in &self.paths {
            if !p.as_os_str().is_empty() {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}

impl Sink for Episode<'_> {
    type Error = std::convert::Infallible;

    fn raw_frame(&mut self, frame: &RawFrame<'_>) -> std::result::Result<Flow, Self::Error> {
        let r = self.write_frame(frame);
        Ok(self.keep(r))
    }

    fn event(&mut self, event: &Event) -> std::result::Result<Flow, Self::Error> {
        let r = self.write_event(event);
        Ok(self.keep(r))
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> std::result::Result<Flow, Self::Error> {
        let r = self.write_contacts(frame);
        Ok(self.keep(r))
    }
}

/// A row of values without allocating: the fixed columns, then one list a link.
mod smallvec_row {
    use crate::table::Value;

    /// Up to this many values on the stack; more spill to a vector (a skin of many links).
    const INLINE: usize = 16;

    pub(super) struct Row<'a> {
        inline: [Value<'a>; INLINE],
        len: usize,
        spill: Vec<Value<'a>>,
    }

    impl<'a> Row<'a> {
        pub(super) fn new(head: &[Value<'a>]) -> Row<'a> {
            let mut r = Row {
                inline: [Value::I64(0); INLINE],
                len: 0,
                spill: Vec::new(),
            };
            for v in head {
                r.push(*v);
            }
            r
        }

        pub(super) fn push(&mut self, v: Value<'a>) {
            if self.len < INLINE && self.spill.is_empty() {
                self.inline[self.len] = v;
                self.len += 1;
            } else {
                if self.spill.is_empty() {
                    self.spill.extend_from_slice(&self.inline[..self.len]);
                }
                self.spill.push(v);
            }
        }

        pub(super) fn as_slice(&self) -> &[Value<'a>] {
            if self.spill.is_empty() {
                &self.inline[..self.len]
            } else {
                &self.spill
            }
        }
    }
}

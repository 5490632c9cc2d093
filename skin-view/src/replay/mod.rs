//! Replaying an MCAP file that skin wrote (`skin run --mcap`, `skin convert`) to the page, with
//! pause, seek and speed (feature `mcap`).
//!
//! What the file holds is what the page shows: each link's pressure cloud (`PREFIX/<link>/
//! pressure`: the taxels' positions, ids and pressures), the frame's contacts
//! (`PREFIX/contacts`) and the session's events (`PREFIX/events`, each carrying its events.jsonl
//! line). The tactile maps are made from the first cloud of each link (positions, normals
//! estimated, triangulated and flattened as `skin flatten` does a layout without triangles),
//! so the file needs nothing beside it. Seeking uses the file's chunk index (the mcap crate's
//! indexed reader): a seek reads the chunks around the time asked for, not the file before it.
//!
//! Opening reads the whole file once to check every chunk against its CRC (the mcap crate's
//! linear reader, chunk by chunk). A damaged chunk is named ([`Replay::damaged`]) and the page
//! marks its time span as not to be trusted; its frames are still shown when its records can be
//! read, and left out when they cannot. An intact file plays as if nothing was checked.

mod check;
mod player;
mod read;

pub use check::DamagedChunk;

use crate::ViewError;
use crate::hub::SPEEDS;
use crate::scene::{ReplayInfo, Scene};
use check::{check_chunks, stretches};
use read::{channels_of, links_of, open_skins, read_events, read_summary, topic_of};
use skin_ros::decode::CloudLayout;
use std::collections::HashMap;
use std::fs::File;
use std::path::{Path, PathBuf};

/// The longest record read (a chunk, decompressed): skin's chunks are a few MB.
const MAX_RECORD: usize = 512 * 1024 * 1024;

/// An MCAP file opened for replay.
#[derive(Debug)]
pub struct Replay {
    path: PathBuf,
    file: File,
    summary: mcap::Summary,
    scene: Scene,
    /// Pressure channel id -> link index, and how its messages lay their pressures out.
    clouds: Clouds,
    /// Contacts channel, if the file has one.
    contacts: Option<u16>,
    /// The contacts' schema gives each its force (files written before newtons do not).
    contacts_force: bool,
    /// Taxel id -> layout index, per link; link index by frame id.
    index: Vec<HashMap<u32, usize>>,
    links_by_frame: HashMap<String, usize>,
    origin_ns: u64,
    first_ns: u64,
    last_ns: u64,
    /// Chunks that failed their check, in file order.
    damaged: Vec<DamagedChunk>,
    /// The speed playing starts at.
    speed: f64,
}

/// Per pressure channel: its link and how its clouds lay their pressures out.
type Clouds = HashMap<u16, (usize, CloudLayout)>;

/// A replay's error about its file.
fn err(path: &Path, why: impl Into<String>) -> ViewError {
    ViewError::Replay {
        path: path.to_owned(),
        why: why.into(),
    }
}

/// A ROS time as ns since the epoch (a time before the epoch as 0).
fn stamp_ns(s: skin_ros::messages::Stamp) -> u64 {
    u64::try_from(s.sec).unwrap_or(0) * 1_000_000_000 + u64::from(s.nanosec)
}

impl Replay {
    /// Opens `path`, reads its summary, its events and each link's first cloud, and makes the
    /// links' maps. `threshold` (counts above the baseline) is where the page's colour scale
    /// starts: the run's `[touch] threshold`.
    pub fn open(path: &Path, threshold: f32) -> Result<Replay, ViewError> {
        let mut file = open_skins(path)?;
        let size = file.metadata().map_err(|e| err(path, e.to_string()))?.len();
        let mut summary = read_summary(&mut file, size, path)?;
        let chunks = summary.chunk_indexes.len();
        let bad = check_chunks(&mut file, &summary, size, path)?;
        // A chunk whose records cannot be read is left out of every read from here on.
        summary.chunk_indexes.retain(|c| {
            !bad.iter()
                .any(|b| !b.readable && b.index.chunk_start_offset == c.chunk_start_offset)
        });
        let (pressure, events, contacts) = channels_of(&summary);
        let contacts_force = contacts
            .and_then(|id| summary.channels.get(&id))
            .and_then(|c| c.schema.as_ref())
            .is_some_and(|s| skin_ros::decode::contacts_have_force(&String::from_utf8_lossy(&s.data)));
        if pressure.is_empty() {
            return Err(err(
                path,
                "holds no pressure clouds (PREFIX/<link>/pressure): nothing to show",
            ));
        }
        let (maps, clouds, first_ns) = links_of(&mut file, &summary, &pressure, path)?;
        if maps.is_empty() {
            return Err(err(path, "its pressure topics hold no message: nothing to show"));
        }
        // The events, for the timeline; the first fixes the session's origin.
        let (lines, left_out, origin_ns) = match events {
            Some(id) => read_events(&mut file, &summary, &topic_of(&summary, id), path)?,
            None => (Vec::new(), 0, None),
        };
        let last_ns = summary
            .stats
            .as_ref()
            .map(|s| s.message_end_time)
            .or_else(|| summary.chunk_indexes.iter().map(|c| c.message_end_time).max())
            .unwrap_or(first_ns);
        let origin_ns = origin_ns.unwrap_or(first_ns).min(first_ns);
        let damaged: Vec<DamagedChunk> = bad.into_iter().map(|b| b.placed(origin_ns)).collect();
        let mut scene = Scene::from_maps(&maps, &file_name(path));
        scene.threshold = threshold;
        scene.replay = Some(ReplayInfo {
            duration: last_ns.saturating_sub(origin_ns) as f64 / 1e9,
            events: lines,
            events_left_out: left_out,
            chunks,
            damaged: stretches(&damaged),
        });
        Ok(Replay {
            path: path.to_owned(),
            file,
            summary,
            scene,
            clouds,
            contacts,
            contacts_force,
            index: maps
                .iter()
                .map(|m| m.ids.iter().enumerate().map(|(i, id)| (id.0, i)).collect())
                .collect(),
            links_by_frame: maps
                .iter()
                .enumerate()
                .map(|(k, m)| (m.name.clone(), k))
                .collect(),
            origin_ns,
            first_ns,
            last_ns,
            damaged,
            speed: 1.0,
        })
    }

    /// The chunks of the file that failed their check, in file order (empty: the file is
    /// intact).
    pub fn damaged(&self) -> &[DamagedChunk] {
        &self.damaged
    }

    /// How many chunks the file has.
    pub fn chunks(&self) -> usize {
        self.scene.replay.as_ref().map_or(0, |r| r.chunks)
    }

    /// Plays at `speed` times real time from the start ([`SPEEDS`]; 1 unless set), until a
    /// browser changes it.
    pub fn set_speed(&mut self, speed: f64) -> Result<(), ViewError> {
        if !SPEEDS.contains(&speed) {
            return Err(ViewError::Speed(speed));
        }
        self.speed = speed;
        Ok(())
    }

    /// What the page draws.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// From the session's start to the last message, s.
    pub fn duration(&self) -> f64 {
        self.last_ns.saturating_sub(self.origin_ns) as f64 / 1e9
    }
}

/// A path as the page names its source: the file's name.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

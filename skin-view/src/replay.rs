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

use crate::hub::{Control, SPEEDS};
use crate::scene::{Damage, ReplayInfo, Scene};
use crate::sink::ViewSink;
use crate::{MAX_TIMELINE, ViewError, Viewer};
use mcap::sans_io::indexed_reader::{IndexedReadEvent, IndexedReader, IndexedReaderOptions};
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{FlattenOptions, TactileMap};
use skin_ros::decode::{self, CloudLayout};
use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

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

/// A chunk of a replayed file that failed its check.
#[derive(Debug, Clone, PartialEq)]
pub struct DamagedChunk {
    /// Its number among the file's chunks, from 1, in file order.
    pub number: usize,
    /// Where its record starts in the file, bytes.
    pub offset: u64,
    /// Its record's length, bytes.
    pub length: u64,
    /// Where the time its messages span starts, s from the session's start (as the file's index
    /// says).
    pub from: f64,
    /// Where it ends, s.
    pub to: f64,
    /// Its records can be read (only its CRC fails): its frames are shown, but may be wrong.
    /// Otherwise they are left out of the replay.
    pub readable: bool,
    /// What is wrong.
    pub why: String,
}

impl std::fmt::Display for DamagedChunk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let fate = if self.readable {
            "its frames are shown, but cannot be trusted"
        } else {
            "its frames are left out"
        };
        write!(
            f,
            "chunk {} (bytes {} to {}, {:.2} s to {:.2} s): {}; {fate}",
            self.number,
            self.offset,
            self.offset.saturating_add(self.length),
            self.from,
            self.to,
            self.why
        )
    }
}

/// A chunk that failed its check, before the session's origin is known.
struct BadChunk {
    number: usize,
    index: mcap::records::ChunkIndex,
    readable: bool,
    why: String,
}

fn err(path: &Path, why: impl Into<String>) -> ViewError {
    ViewError::Replay {
        path: path.to_owned(),
        why: why.into(),
    }
}

fn stamp_ns(s: skin_ros::messages::Stamp) -> u64 {
    u64::try_from(s.sec).unwrap_or(0) * 1_000_000_000 + u64::from(s.nanosec)
}

/// Per pressure channel: its link and how its clouds lay their pressures out.
type Clouds = HashMap<u16, (usize, CloudLayout)>;

/// Takes one message (its header and bytes); false stops the reading.
type OnMessage<'a> = dyn FnMut(&mcap::records::MessageHeader, &[u8]) -> Result<bool, ViewError> + 'a;

/// Reads the messages `options` selects, in log-time order, handing each to `f` until it says
/// stop.
fn each_message(
    file: &mut File,
    summary: &mcap::Summary,
    options: IndexedReaderOptions,
    path: &Path,
    f: &mut OnMessage<'_>,
) -> Result<(), ViewError> {
    // A record longer than the file is a lie of the index: refused before it sizes a buffer.
    let size = file.metadata().map_or(0, |m| m.len());
    let limit = usize::try_from(size).unwrap_or(usize::MAX).min(MAX_RECORD);
    let mut reader = IndexedReader::new_with_options(summary, options.with_record_length_limit(limit))
        .map_err(|e| err(path, e.to_string()))?;
    let mut buffer = Vec::new();
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| err(path, e.to_string()))? {
            IndexedReadEvent::ReadChunkRequest { offset, length } => {
                file.seek(SeekFrom::Start(offset))
                    .map_err(|e| err(path, e.to_string()))?;
                buffer.resize(length, 0);
                file.read_exact(&mut buffer)
                    .map_err(|e| err(path, format!("cut short ({e})")))?;
                reader
                    .insert_chunk_record_data(offset, &buffer)
                    .map_err(|e| err(path, e.to_string()))?;
            }
            IndexedReadEvent::Message { header, data } => {
                if !f(&header, data)? {
                    return Ok(());
                }
            }
        }
    }
    Ok(())
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

    /// Plays the file to `viewer` (whose scene is [`Replay::scene`]) from its first frame at
    /// real time, following the browsers' controls, until `stop` is set. At the end it pauses on
    /// the last frame (a seek plays again).
    ///
    /// One replay plays to every browser, so their controls are shared: a pause, seek or speed
    /// from any browser is what all of them see, and each is told which browser changed it. A
    /// replay per browser would read and decode the file once per browser watching, where the
    /// viewer keeps one latest frame for all of them.
    pub fn play(
        &mut self,
        viewer: &Viewer,
        controls: &Receiver<Control>,
        stop: &AtomicBool,
    ) -> Result<(), ViewError> {
        let mut sink = viewer.sink();
        let mut state = PlayState {
            speed: self.speed,
            paused: false,
            frames: 0,
            by_browser: false,
        };
        let hub = &viewer.server.hub;
        // Every browser is told the state, and which browser changed it last: the controls are
        // shared by all who watch.
        let tell = |st: &PlayState| {
            let by = if st.by_browser {
                hub.last_by.load(Ordering::Relaxed).to_string()
            } else {
                "null".to_owned()
            };
            hub.put_status(format!(
                r#"{{"paused":{},"speed":{},"by":{by}}}"#,
                st.paused, st.speed
            ));
        };
        tell(&state);
        let mut from = self.first_ns;
        while !stop.load(Ordering::Relaxed) {
            let mut player = Player {
                replay: self,
                sink: &mut sink,
                controls,
                stop,
                state: &mut state,
                tell: &tell,
                seek: None,
            };
            match player.run(from)? {
                Some(t) => from = t,
                // The end: paused on the last frame until a seek, or play (from the start).
                None => {
                    state.paused = true;
                    state.by_browser = false;
                    tell(&state);
                    match wait_for_seek(controls, stop, &mut state, &tell) {
                        Some(t) => from = self.seek_ns(t),
                        None => return Ok(()),
                    }
                }
            }
            from = from.max(self.first_ns).min(self.last_ns);
        }
        Ok(())
    }

    fn seek_ns(&self, t: f64) -> u64 {
        self.origin_ns.saturating_add((t.max(0.0) * 1e9) as u64)
    }
}

/// Whether a replay advances, how fast, and the frames it has shown.
#[derive(Debug, Clone, Copy)]
struct PlayState {
    speed: f64,
    paused: bool,
    /// Frames shown since the replay began (the frames' cycle numbers).
    frames: u64,
    /// The last change came from a browser's control (not from the replay reaching its end).
    by_browser: bool,
}

/// Waits at the end of a replay for a seek, or play (from the start: 0 s); speed changes are
/// kept. `None` once stopped.
fn wait_for_seek(
    controls: &Receiver<Control>,
    stop: &AtomicBool,
    state: &mut PlayState,
    tell: &dyn Fn(&PlayState),
) -> Option<f64> {
    while !stop.load(Ordering::Relaxed) {
        let got = controls.recv_timeout(Duration::from_millis(50));
        if got.is_ok() {
            state.by_browser = true;
        }
        match got {
            Ok(Control::Seek(t)) => return Some(t),
            Ok(Control::Speed(s)) => state.speed = s,
            Ok(Control::Pause) => state.paused = true,
            Ok(Control::Play) => {
                state.paused = false;
                tell(state);
                return Some(0.0);
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => continue,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
        }
        tell(state);
    }
    None
}

/// One pass of playback, from a time until the end or a seek.
struct Player<'a> {
    replay: &'a mut Replay,
    sink: &'a mut ViewSink,
    controls: &'a Receiver<Control>,
    stop: &'a AtomicBool,
    state: &'a mut PlayState,
    /// Tells the browsers the state once it changed.
    tell: &'a dyn Fn(&PlayState),
    seek: Option<u64>,
}

/// A frame being gathered: every link's cloud of one stamp, and the contacts of that stamp.
struct Gathered {
    stamp: Option<u64>,
    pressures: Vec<Vec<f32>>,
    contacts: Vec<(usize, Vec<usize>, f32, f32)>,
    /// Frames shown in this pass.
    frames: u64,
}

impl Player<'_> {
    /// Plays from `from_ns`; returns the time of a seek (ns), or `None` at the end of the file.
    fn run(&mut self, from_ns: u64) -> Result<Option<u64>, ViewError> {
        let r = &mut *self.replay;
        let mut topics: Vec<String> = r
            .clouds
            .keys()
            .filter_map(|id| r.summary.channels.get(id).map(|c| c.topic.clone()))
            .collect();
        if let Some(id) = r.contacts
            && let Some(c) = r.summary.channels.get(&id)
        {
            topics.push(c.topic.clone());
        }
        let mut g = Gathered {
            stamp: None,
            pressures: r.scene.links.iter().map(|l| vec![0.0; l.ids.len()]).collect(),
            contacts: Vec::new(),
            frames: 0,
        };
        // Wall time and stamp the pace counts from (set again after a pause or a speed change).
        let mut anchor: Option<(Instant, u64)> = None;
        let options = IndexedReaderOptions::new()
            .include_topics(topics)
            .starting_at(from_ns);
        let path = r.path.clone();
        let mut file = r.file.try_clone().map_err(|e| err(&path, e.to_string()))?;
        let summary = std::mem::take(&mut r.summary);
        let span = r.origin_ns..=r.last_ns;
        let result = each_message(&mut file, &summary, options, &path, &mut |h, data| {
            // A stamp outside the file's own span (a damaged chunk's) would stall the pacing
            // for as long as it claims: left out.
            if !span.contains(&h.log_time) {
                return Ok(true);
            }
            if g.stamp.is_some_and(|s| s != h.log_time) && !self.show(&mut g, &mut anchor)? {
                return Ok(false);
            }
            g.stamp = Some(h.log_time);
            self.gather(&mut g, h.channel_id, data);
            Ok(true)
        });
        self.replay.summary = summary;
        result?;
        if self.seek.is_none() && g.stamp.is_some() {
            self.show(&mut g, &mut anchor)?;
        }
        Ok(self.seek)
    }

    fn gather(&mut self, g: &mut Gathered, channel: u16, data: &[u8]) {
        let r = &*self.replay;
        if let Some(&(link, layout)) = r.clouds.get(&channel) {
            if let Some(p) = g.pressures.get_mut(link) {
                // A cloud laid out otherwise than the link's first is not shown (its pressures
                // stay at the last frame's).
                let _ = decode::cloud_pressures(data, &layout, p);
            }
        } else if Some(channel) == r.contacts
            && let Ok((_, list)) = decode::contacts(data)
        {
            for c in list {
                let Some(&link) = r.links_by_frame.get(&c.link) else {
                    continue;
                };
                let taxels = c
                    .taxel_ids
                    .iter()
                    .filter_map(|id| r.index[link].get(id).copied())
                    .collect();
                g.contacts.push((link, taxels, c.mean_pressure, c.peak_pressure));
            }
        }
    }

    /// Waits until the gathered frame is due, then shows it. False when playback must stop
    /// here (a seek, or the viewer stopping).
    fn show(&mut self, g: &mut Gathered, anchor: &mut Option<(Instant, u64)>) -> Result<bool, ViewError> {
        let Some(stamp) = g.stamp else { return Ok(true) };
        loop {
            if self.stop.load(Ordering::Relaxed) {
                return Ok(false);
            }
            while let Ok(c) = self.controls.try_recv() {
                self.state.by_browser = true;
                match c {
                    Control::Pause => self.state.paused = true,
                    Control::Play => {
                        self.state.paused = false;
                        *anchor = None;
                    }
                    Control::Speed(s) => {
                        self.state.speed = s;
                        *anchor = None;
                    }
                    Control::Seek(t) => {
                        self.seek = Some(self.replay.seek_ns(t));
                        return Ok(false);
                    }
                }
                (self.tell)(self.state);
            }
            // Paused, a seek still shows the frame it lands on.
            if self.state.paused && g.frames > 0 {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
            if self.state.paused {
                break;
            }
            let (wall, from) = *anchor.get_or_insert((Instant::now(), stamp));
            let after = stamp.saturating_sub(from) as f64 / 1e9 / self.state.speed;
            let due = Duration::try_from_secs_f64(after)
                .ok()
                .and_then(|d| wall.checked_add(d))
                .unwrap_or(wall);
            let now = Instant::now();
            if due <= now {
                break;
            }
            std::thread::sleep((due - now).min(Duration::from_millis(20)));
        }
        g.frames += 1;
        self.state.frames += 1;
        let time = stamp.saturating_sub(self.replay.origin_ns) as f64 / 1e9;
        let contacts = g.contacts.iter().map(|(l, t, m, p)| (*l, t.as_slice(), *m, *p));
        self.sink
            .publish(time, self.state.frames, &g.pressures, contacts, &[]);
        g.contacts.clear();
        Ok(true)
    }
}

/// A path as the page names its source: the file's name.
fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

impl BadChunk {
    /// The damaged chunk, its times counted from the session's start.
    fn placed(self, origin_ns: u64) -> DamagedChunk {
        let s = |ns: u64| ns.saturating_sub(origin_ns) as f64 / 1e9;
        DamagedChunk {
            number: self.number,
            offset: self.index.chunk_start_offset,
            length: self.index.chunk_length,
            from: s(self.index.message_start_time),
            to: s(self.index.message_end_time),
            readable: self.readable,
            why: self.why,
        }
    }
}

/// The damaged chunks as stretches of the session: consecutive chunks alike (shown, or left
/// out) make one stretch.
fn stretches(damaged: &[DamagedChunk]) -> Vec<Damage> {
    let mut out: Vec<Damage> = Vec::new();
    for d in damaged {
        match out.last_mut() {
            Some(last)
                if last.left_out != d.readable && last.chunks.last().is_some_and(|&n| n + 1 == d.number) =>
            {
                last.chunks.push(d.number);
                last.from = last.from.min(d.from);
                last.to = last.to.max(d.to);
            }
            _ => out.push(Damage {
                from: d.from,
                to: d.to,
                chunks: vec![d.number],
                left_out: !d.readable,
            }),
        }
    }
    out.sort_by(|a, b| a.from.total_cmp(&b.from));
    out
}

/// Opcode of a chunk record (MCAP specification).
const CHUNK_OPCODE: u8 = 0x06;
/// A chunk record's header before its compression's name: opcode, record length, start and
/// end time, uncompressed size, CRC, the name's length.
const CHUNK_HEAD: usize = 1 + 8 + 8 + 8 + 8 + 4 + 4;

/// Every chunk checked against its CRC (and its records read through), in file order: those
/// that fail. Reads the whole file once, a record at a time.
fn check_chunks(
    file: &mut File,
    summary: &mcap::Summary,
    size: u64,
    path: &Path,
) -> Result<Vec<BadChunk>, ViewError> {
    let mut chunks: Vec<&mcap::records::ChunkIndex> = summary.chunk_indexes.iter().collect();
    chunks.sort_by_key(|c| c.chunk_start_offset);
    let limit = usize::try_from(size).unwrap_or(usize::MAX).min(MAX_RECORD);
    let mut bad = Vec::new();
    for (k, index) in chunks.into_iter().enumerate() {
        if let Some((readable, why)) = check_chunk(file, index, size, limit, path)? {
            bad.push(BadChunk {
                number: k + 1,
                index: index.clone(),
                readable,
                why,
            });
        }
    }
    Ok(bad)
}

/// What is wrong with one chunk, if anything: whether its records can still be read, and why
/// it cannot be trusted.
fn check_chunk(
    file: &mut File,
    index: &mcap::records::ChunkIndex,
    size: u64,
    limit: usize,
    path: &Path,
) -> Result<Option<(bool, String)>, ViewError> {
    let start = index.chunk_start_offset;
    let Some(end) = start.checked_add(index.chunk_length).filter(|&e| e <= size) else {
        return Ok(Some((
            false,
            "the index places it past the end of the file".into(),
        )));
    };
    if let Some(why) = chunk_head_disagrees(file, index, path)? {
        return Ok(Some((false, why)));
    }
    // The mcap crate's linear reader over the chunk's bytes alone: it reads every record and
    // compares the chunk's CRC with what it holds.
    let options = LinearReaderOptions::default()
        .with_skip_start_magic(true)
        .with_skip_end_magic(true)
        .with_validate_chunk_crcs(true)
        .with_record_length_limit(limit);
    let mut reader = LinearReader::new_with_options(options);
    file.seek(SeekFrom::Start(start))
        .map_err(|e| err(path, e.to_string()))?;
    let mut left = end - start;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(want)) => {
                let n = usize::try_from(left).unwrap_or(usize::MAX).min(want);
                let got = file
                    .read(reader.insert(n))
                    .map_err(|e| err(path, e.to_string()))?;
                left -= got as u64;
                reader.notify_read(got);
            }
            Ok(LinearReadEvent::Record { .. }) => {}
            Err(mcap::McapError::BadChunkCrc { saved, calculated }) => {
                let why = format!(
                    "its bytes do not match its CRC (the file says {saved:08x}, they give {calculated:08x})"
                );
                return Ok(Some((true, why)));
            }
            Err(e) => return Ok(Some((false, format!("its records cannot be read ({e})")))),
        }
    }
    Ok(None)
}

/// Whether the chunk record's own header disagrees with the index (another record there, or
/// lengths that do not add up); the linear reader is given only a chunk whose lengths agree.
fn chunk_head_disagrees(
    file: &mut File,
    index: &mcap::records::ChunkIndex,
    path: &Path,
) -> Result<Option<String>, ViewError> {
    let mut head = [0u8; CHUNK_HEAD];
    file.seek(SeekFrom::Start(index.chunk_start_offset))
        .map_err(|e| err(path, e.to_string()))?;
    if file.read_exact(&mut head).is_err() {
        return Ok(Some("cut short".into()));
    }
    let u64_at = |at: usize| {
        let mut b = [0u8; 8];
        b.copy_from_slice(&head[at..at + 8]);
        u64::from_le_bytes(b)
    };
    let record = u64_at(1);
    let mut name_len = [0u8; 4];
    name_len.copy_from_slice(&head[CHUNK_HEAD - 4..]);
    let name_len = u64::from(u32::from_le_bytes(name_len));
    let mut compressed = [0u8; 8];
    file.seek(SeekFrom::Current(i64::try_from(name_len).unwrap_or(i64::MAX)))
        .map_err(|e| err(path, e.to_string()))?;
    if file.read_exact(&mut compressed).is_err() {
        return Ok(Some("cut short".into()));
    }
    let compressed = u64::from_le_bytes(compressed);
    // Record = the header after opcode and length, the compression's name, its size, the data.
    let header = (CHUNK_HEAD as u64 - 9) + name_len + 8;
    let agrees = head[0] == CHUNK_OPCODE
        && record.checked_add(9) == Some(index.chunk_length)
        && record.checked_sub(header) == Some(compressed);
    Ok((!agrees).then(|| "its header does not agree with the file's index".to_owned()))
}

/// Each link's map from its first cloud, how its clouds lay their pressures out (by channel),
/// and the first cloud's time (ns).
fn links_of(
    file: &mut File,
    summary: &mcap::Summary,
    pressure: &[u16],
    path: &Path,
) -> Result<(Vec<TactileMap>, Clouds, u64), ViewError> {
    let topic = |id: u16| topic_of(summary, id);
    let mut first: HashMap<u16, (Vec<u8>, u64)> = HashMap::new();
    let topics: Vec<String> = pressure.iter().map(|&id| topic(id)).collect();
    let options = IndexedReaderOptions::new().include_topics(topics);
    each_message(file, summary, options, path, &mut |h, data| {
        first
            .entry(h.channel_id)
            .or_insert_with(|| (data.to_vec(), h.log_time));
        Ok(first.len() < pressure.len())
    })?;
    let mut maps = Vec::new();
    let mut clouds = HashMap::new();
    let mut first_ns = u64::MAX;
    for &id in pressure {
        let Some((bytes, t)) = first.get(&id) else {
            continue;
        };
        let cloud = decode::point_cloud(bytes).map_err(|e| err(path, format!("{}: {e}", topic(id))))?;
        first_ns = first_ns.min(*t);
        clouds.insert(id, (maps.len(), cloud.layout));
        maps.push(map_of(&cloud, path)?);
    }
    Ok((maps, clouds, first_ns))
}

/// Every event of the file (at most [`MAX_TIMELINE`]), how many more there are, and the
/// session's origin (ns) the first one gives.
fn read_events(
    file: &mut File,
    summary: &mcap::Summary,
    topic: &str,
    path: &Path,
) -> Result<(Vec<serde_json::Value>, usize, Option<u64>), ViewError> {
    let mut lines = Vec::new();
    let mut left_out = 0usize;
    let mut origin_ns = None;
    let options = IndexedReaderOptions::new().include_topics([topic]);
    each_message(file, summary, options, path, &mut |_, data| {
        let Ok((stamp, json)) = decode::touch_event_json(data) else {
            return Ok(true);
        };
        let Ok(value) = serde_json::from_str::<serde_json::Value>(&json) else {
            return Ok(true);
        };
        if origin_ns.is_none()
            && let Some(t) = value.get("time").and_then(serde_json::Value::as_f64)
        {
            origin_ns = Some(stamp_ns(stamp).saturating_sub((t * 1e9).round() as u64));
        }
        if lines.len() < MAX_TIMELINE {
            lines.push(value);
        } else {
            left_out += 1;
        }
        Ok(true)
    })?;
    Ok((lines, left_out, origin_ns))
}

/// The topic of channel `id` (empty for a channel the summary lacks).
fn topic_of(summary: &mcap::Summary, id: u16) -> String {
    summary
        .channels
        .get(&id)
        .map(|c| c.topic.clone())
        .unwrap_or_default()
}

/// The channels a replay reads: each link's pressure clouds (channel order, which is the
/// links'), the events and the contacts.
fn channels_of(summary: &mcap::Summary) -> (Vec<u16>, Option<u16>, Option<u16>) {
    let mut channels: Vec<(&u16, &std::sync::Arc<mcap::Channel<'static>>)> =
        summary.channels.iter().collect();
    channels.sort_by_key(|(id, _)| **id);
    let schema = |c: &mcap::Channel<'_>| c.schema.as_ref().map_or("", |s| s.name.as_str()).to_owned();
    let pressure = channels
        .iter()
        .filter(|(_, c)| c.topic.ends_with("/pressure") && schema(c) == "sensor_msgs/msg/PointCloud2")
        .map(|(id, _)| **id)
        .collect();
    let find = |suffix: &str, ty: &str| {
        channels
            .iter()
            .find(|(_, c)| c.topic.ends_with(suffix) && schema(c) == ty)
            .map(|(id, _)| **id)
    };
    (
        pressure,
        find("/events", "skin_msgs/msg/TouchEvent"),
        find("/contacts", "skin_msgs/msg/Contacts"),
    )
}

/// Opens an MCAP file that skin wrote; refuses any other.
fn open_skins(path: &Path) -> Result<File, ViewError> {
    if path.is_dir() {
        return Err(err(path, "a folder, not an MCAP file"));
    }
    let file = File::open(path).map_err(|e| err(path, format!("cannot open it: {e}")))?;
    if !skin_ros::mcap_file_written_by_skin(path) {
        let why = "not an MCAP file that skin wrote (its header names another writer, or it is no MCAP file)";
        return Err(err(path, why));
    }
    Ok(file)
}

fn read_summary(file: &mut File, size: u64, path: &Path) -> Result<mcap::Summary, ViewError> {
    let options = SummaryReaderOptions::default()
        .with_file_size(size)
        .with_record_length_limit(usize::try_from(size).unwrap_or(usize::MAX).min(MAX_RECORD));
    let mut reader = SummaryReader::new_with_options(options);
    let cut = |e: mcap::McapError| {
        err(
            path,
            format!("its summary at the end cannot be read ({e}): a file cut short, or still being written"),
        )
    };
    while let Some(event) = reader.next_event() {
        match event.map_err(cut)? {
            SummaryReadEvent::ReadRequest(need) => {
                let n = file
                    .read(reader.insert(need))
                    .map_err(|e| err(path, e.to_string()))?;
                reader.notify_read(n);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let at = file.seek(to).map_err(|e| err(path, e.to_string()))?;
                reader.notify_seeked(at);
            }
        }
    }
    reader.finish().ok_or_else(|| {
        err(
            path,
            "has no summary section (a file cut short?): it cannot be sought in",
        )
    })
}

/// A link's tactile map from its cloud: taxel positions and ids, normals estimated, triangulated
/// and flattened.
fn map_of(cloud: &decode::Cloud, path: &Path) -> Result<TactileMap, ViewError> {
    let positions: Vec<Point3<f64>> = cloud
        .positions
        .iter()
        .map(|p| Point3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])))
        .collect();
    let normals: Vec<Unit<Vector3<f64>>> = skin_core::normals::estimate_normals(&positions, &[]);
    let taxels = positions
        .iter()
        .zip(&normals)
        .zip(&cloud.ids)
        .map(|((p, n), id)| Taxel {
            id: TaxelId(*id),
            position: *p,
            normal: *n,
        })
        .collect();
    let link = LinkSkin::new(cloud.frame_id.clone(), taxels);
    TactileMap::flatten(&link, &FlattenOptions::default()).map_err(|e| {
        err(
            path,
            format!(
                "link {}: cannot make its map from the cloud's positions: {e}",
                cloud.frame_id
            ),
        )
    })
}

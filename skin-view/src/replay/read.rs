//! What a replay reads out of the file, through the mcap crate's readers: the summary, the
//! channels, each link's first cloud (made into its tactile map), the events for the timeline,
//! and any messages in log-time order.

use super::{Clouds, MAX_RECORD, err, stamp_ns};
use crate::{MAX_TIMELINE, ViewError};
use mcap::sans_io::indexed_reader::{IndexedReadEvent, IndexedReader, IndexedReaderOptions};
use mcap::sans_io::summary_reader::{SummaryReadEvent, SummaryReader, SummaryReaderOptions};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::{FlattenOptions, TactileMap};
use skin_ros::decode;
use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

/// Takes one message (its header and bytes); false stops the reading.
type OnMessage<'a> = dyn FnMut(&mcap::records::MessageHeader, &[u8]) -> Result<bool, ViewError> + 'a;

/// Reads the messages `options` selects, in log-time order, handing each to `f` until it says
/// stop.
pub(super) fn each_message(
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

/// Each link's map from its first cloud, how its clouds lay their pressures out (by channel),
/// and the first cloud's time (ns).
pub(super) fn links_of(
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
pub(super) fn read_events(
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
pub(super) fn topic_of(summary: &mcap::Summary, id: u16) -> String {
    summary
        .channels
        .get(&id)
        .map(|c| c.topic.clone())
        .unwrap_or_default()
}

/// The channels a replay reads: each link's pressure clouds (channel order, which is the
/// links'), the events and the contacts.
pub(super) fn channels_of(summary: &mcap::Summary) -> (Vec<u16>, Option<u16>, Option<u16>) {
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
pub(super) fn open_skins(path: &Path) -> Result<File, ViewError> {
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

pub(super) fn read_summary(file: &mut File, size: u64, path: &Path) -> Result<mcap::Summary, ViewError> {
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

//! A replayed file's chunks checked against their CRCs before anything plays: which are
//! damaged, whether their records can still be read, and the stretches of the session the page
//! marks as not to be trusted.

use super::{MAX_RECORD, err};
use crate::ViewError;
use crate::scene::Damage;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;

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
pub(super) struct BadChunk {
    number: usize,
    pub index: mcap::records::ChunkIndex,
    pub readable: bool,
    why: String,
}

impl BadChunk {
    /// The damaged chunk, its times counted from the session's start.
    pub fn placed(self, origin_ns: u64) -> DamagedChunk {
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
pub(super) fn stretches(damaged: &[DamagedChunk]) -> Vec<Damage> {
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
pub(super) fn check_chunks(
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

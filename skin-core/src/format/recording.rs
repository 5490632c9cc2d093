//! Cyskin raw recordings: a text file, one frame per line.
//!
//! Line 1 lists the taxel ids (Cyskin `module << 4 | channel`). Every following line is
//! `frame_number time value value ...`: the frame number (integer), the time in seconds, then one
//! reading per id, in the order of line 1. Readings are raw counts (integers in Cyskin files; any
//! finite number within [`MAX_READING`] is accepted). Blank lines are skipped.
//!
//! [`RecordingReader`] reads a file of any length one frame at a time (gzip-compressed files too);
//! [`read`] reads a small one whole.

use super::write_text;
use crate::text::{Gzip, Input, Lines};
use crate::{Error, Frame, Recording, Result, TaxelId};
use std::fmt::Write as _;
use std::io::BufRead;
use std::path::Path;

/// The largest reading accepted, in either sign. Readings are counts of a sensor's converter
/// (16 bits on Cyskin, 8 on iCub); a value beyond this is garbage, and squared in a noise
/// estimate it would overflow `f32`.
pub const MAX_READING: f32 = 1e9;

/// Reads a whole recording into memory (small files and tests; [`RecordingReader`] reads one
/// frame at a time). A gzip-compressed file is decompressed as it is read.
pub fn read(path: &Path) -> Result<Recording> {
    RecordingReader::open(path)?.into_recording()
}

/// Parses a recording; `path` is used in error messages.
pub fn parse(text: &str, path: &Path) -> Result<Recording> {
    RecordingReader::new(text.as_bytes(), path)?.into_recording()
}

/// One frame of a recording, borrowed from its reader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordedFrame<'a> {
    /// The frame number as recorded.
    pub number: u64,
    /// Time, seconds.
    pub time: f64,
    /// One reading per taxel of the header, in its order.
    pub values: &'a [f32],
}

/// Frames of a recording, one at a time: a [`RecordingReader`] on a file or any text input, or
/// [`Recording::source`] on one in memory. What `skin_learn`'s session runs.
pub trait RecordingSource {
    /// The taxels of the header, in the order of each frame's values.
    fn taxel_ids(&self) -> &[TaxelId];
    /// The next frame; `None` at the end.
    fn next_frame(&mut self) -> Result<Option<RecordedFrame<'_>>>;
}

impl<T: RecordingSource + ?Sized> RecordingSource for &mut T {
    fn taxel_ids(&self) -> &[TaxelId] {
        (**self).taxel_ids()
    }

    fn next_frame(&mut self) -> Result<Option<RecordedFrame<'_>>> {
        (**self).next_frame()
    }
}

/// What a [`RecordingSource`] can be made from: any source, or a whole [`Recording`] by reference.
pub trait IntoRecordingSource {
    /// The source.
    type Source: RecordingSource;
    /// Makes it.
    fn into_recording_source(self) -> Self::Source;
}

impl<S: RecordingSource> IntoRecordingSource for S {
    type Source = S;

    fn into_recording_source(self) -> S {
        self
    }
}

impl<'a> IntoRecordingSource for &'a Recording {
    type Source = RecordingFrames<'a>;

    fn into_recording_source(self) -> RecordingFrames<'a> {
        self.source()
    }
}

/// The frames of a [`Recording`] in memory, as a [`RecordingSource`].
#[derive(Debug, Clone)]
pub struct RecordingFrames<'a> {
    recording: &'a Recording,
    next: usize,
}

impl Recording {
    /// Its frames as a [`RecordingSource`] (a frame without a recorded number is numbered by
    /// its index).
    pub fn source(&self) -> RecordingFrames<'_> {
        RecordingFrames {
            recording: self,
            next: 0,
        }
    }
}

impl RecordingSource for RecordingFrames<'_> {
    fn taxel_ids(&self) -> &[TaxelId] {
        &self.recording.taxel_ids
    }

    fn next_frame(&mut self) -> Result<Option<RecordedFrame<'_>>> {
        let k = self.next;
        let Some(frame) = self.recording.frames.get(k) else {
            return Ok(None);
        };
        self.next += 1;
        Ok(Some(RecordedFrame {
            number: self.recording.frame_numbers.get(k).copied().unwrap_or(k as u64),
            time: frame.time,
            values: &frame.values,
        }))
    }
}

/// A recording read one frame at a time, with memory for one line and one frame whatever the
/// file's length: the header of taxel ids is read when the reader is made.
#[derive(Debug)]
pub struct RecordingReader<R = Input> {
    lines: Lines<R>,
    taxel_ids: Vec<TaxelId>,
    values: Vec<f32>,
    frames: u64,
}

impl RecordingReader<Input> {
    /// Opens the recording at `path` (decompressed as it is read when gzip-compressed) and reads
    /// its header.
    pub fn open(path: &Path) -> Result<RecordingReader<Input>> {
        RecordingReader::new(Input::open(path, Gzip::Read)?, path)
    }
}

impl<R: BufRead> RecordingReader<R> {
    /// Reads the header of the recording `reader` holds; `path` names it in errors.
    pub fn new(reader: R, path: &Path) -> Result<RecordingReader<R>> {
        let mut lines = Lines::new(reader, path);
        let header_line;
        let header = loop {
            match lines.next_line()? {
                Some(l) if l.trim().is_empty() => continue,
                Some(l) => {
                    header_line = l.number();
                    break l.text();
                }
                None => {
                    return Err(Error::invalid(
                        path,
                        "line 1",
                        "empty file: expected a line of taxel ids",
                    ));
                }
            }
        };
        let mut taxel_ids = Vec::new();
        let mut column: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
        for (k, field) in header.split_whitespace().enumerate() {
            let id: u32 = field.parse().map_err(|_| {
                Error::invalid(
                    path,
                    format!("line {header_line} field {}", k + 1),
                    format!(
                        "taxel id \"{}\" is not a non-negative integer",
                        super::excerpt(field)
                    ),
                )
            })?;
            // A repeated id would make one column silently win over the other.
            if let Some(first) = column.insert(id, k) {
                return Err(Error::invalid(
                    path,
                    format!("line {header_line} field {}", k + 1),
                    format!("taxel id {id} repeats the id of field {}", first + 1),
                ));
            }
            taxel_ids.push(TaxelId(id));
        }
        Ok(RecordingReader {
            values: Vec::with_capacity(taxel_ids.len()),
            lines,
            taxel_ids,
            frames: 0,
        })
    }

    /// The taxels of the header, in the order of each frame's values.
    pub fn taxel_ids(&self) -> &[TaxelId] {
        &self.taxel_ids
    }

    /// Frames read so far.
    pub fn frames_read(&self) -> u64 {
        self.frames
    }

    /// The file, as errors name it.
    pub fn path(&self) -> &Path {
        self.lines.path()
    }

    /// The next frame; `None` at the end of the file. An error names the line and field.
    pub fn next_frame(&mut self) -> Result<Option<RecordedFrame<'_>>> {
        let line = loop {
            match self.lines.next_line()? {
                Some(l) if l.trim().is_empty() => continue,
                Some(l) => break l,
                None => return Ok(None),
            }
        };
        let (number, time) = parse_frame(&line, &self.taxel_ids, &mut self.values).map_err(|e| match e {
            // A last line cut short says so, with the command that keeps the lines before.
            Error::Invalid { path, place, message } => Error::Invalid {
                path,
                place,
                message: line.explain(message),
            },
            e => e,
        })?;
        self.frames += 1;
        Ok(Some(RecordedFrame {
            number,
            time,
            values: &self.values,
        }))
    }

    /// The rest of the recording, read into memory.
    pub fn into_recording(mut self) -> Result<Recording> {
        let mut rec = Recording {
            taxel_ids: self.taxel_ids.clone(),
            frame_numbers: Vec::new(),
            frames: Vec::new(),
        };
        while let Some(f) = self.next_frame()? {
            rec.frame_numbers.push(f.number);
            rec.frames.push(Frame {
                time: f.time,
                values: f.values.to_vec(),
            });
        }
        Ok(rec)
    }
}

/// The frame number, time and readings (into `values`) of one line of a recording of
/// `taxel_ids`; an error names the line and the field.
fn parse_frame(
    line: &crate::text::Line<'_>,
    taxel_ids: &[TaxelId],
    values: &mut Vec<f32>,
) -> Result<(u64, f64)> {
    let n = taxel_ids.len();
    let (lineno, path, line) = (line.number(), line.path(), line.text());
    let count = line.split_whitespace().count();
    if count != n + 2 {
        return Err(Error::invalid(
            path,
            format!("line {lineno}"),
            format!(
                "expected {} values (frame number, time, {n} readings), found {count}",
                n + 2
            ),
        ));
    }
    let mut fields = line.split_whitespace();
    let number_field = fields.next().unwrap_or_default();
    let number: u64 = number_field.parse().map_err(|_| {
        Error::invalid(
            path,
            format!("line {lineno} field 1"),
            format!(
                "frame number \"{}\" is not an integer",
                super::excerpt(number_field)
            ),
        )
    })?;
    let time_field = fields.next().unwrap_or_default();
    let time: f64 = time_field
        .parse()
        .ok()
        .filter(|t: &f64| t.is_finite())
        .ok_or_else(|| {
            Error::invalid(
                path,
                format!("line {lineno} field 2"),
                format!("time \"{}\" is not a finite number", super::excerpt(time_field)),
            )
        })?;
    values.clear();
    for (k, field) in fields.enumerate() {
        let v: f32 = field
            .parse()
            .ok()
            .filter(|v: &f32| v.is_finite() && v.abs() <= MAX_READING)
            .ok_or_else(|| {
                Error::invalid(
                    path,
                    format!("line {lineno} field {} (taxel {})", k + 3, taxel_ids[k]),
                    format!(
                        "reading \"{}\" is not a finite number within ±{MAX_READING:e} counts",
                        super::excerpt(field)
                    ),
                )
            })?;
        values.push(v);
    }
    Ok((number, time))
}

impl<R: BufRead> RecordingSource for RecordingReader<R> {
    fn taxel_ids(&self) -> &[TaxelId] {
        &self.taxel_ids
    }

    fn next_frame(&mut self) -> Result<Option<RecordedFrame<'_>>> {
        RecordingReader::next_frame(self)
    }
}

/// Serialises a recording: readings are written as integers when they are whole numbers.
pub fn to_string(rec: &Recording) -> String {
    let mut out = String::new();
    let ids: Vec<String> = rec.taxel_ids.iter().map(|id| id.0.to_string()).collect();
    out.push_str(&ids.join(" "));
    out.push('\n');
    for (k, frame) in rec.frames.iter().enumerate() {
        let number = rec.frame_numbers.get(k).copied().unwrap_or(k as u64);
        let _ = write!(out, "{number} {:.6}", frame.time);
        for v in &frame.values {
            if v.fract() == 0.0 {
                let _ = write!(out, " {v:.0}");
            } else {
                let _ = write!(out, " {v}");
            }
        }
        out.push('\n');
    }
    out
}

/// Writes a recording.
pub fn write(path: &Path, rec: &Recording) -> Result<()> {
    write_text(path, &to_string(rec))
}

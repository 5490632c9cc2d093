//! Cyskin raw recordings: a text file, one frame per line.
//!
//! Line 1 lists the taxel ids (Cyskin `module << 4 | channel`). Every following line is
//! `frame_number time value value ...`: the frame number (integer), the time in seconds, then one
//! reading per id, in the order of line 1. Readings are raw counts (integers in Cyskin files; any
//! finite number within [`MAX_READING`] is accepted).

use super::{read_text, write_text};
use crate::{Error, Frame, Recording, Result, TaxelId};
use std::fmt::Write as _;
use std::path::Path;

/// The largest reading accepted, in either sign. Readings are counts of a sensor's converter
/// (16 bits on Cyskin, 8 on iCub); a value beyond this is garbage, and squared in a noise
/// estimate it would overflow `f32`.
pub const MAX_READING: f32 = 1e9;

/// Reads a recording.
pub fn read(path: &Path) -> Result<Recording> {
    parse(&read_text(path)?, path)
}

/// Parses a recording; `path` is used in error messages.
pub fn parse(text: &str, path: &Path) -> Result<Recording> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((header_idx, header)) = lines.next() else {
        return Err(Error::invalid(
            path,
            "line 1",
            "empty file: expected a line of taxel ids",
        ));
    };
    let mut taxel_ids = Vec::new();
    let mut column: std::collections::HashMap<u32, usize> = std::collections::HashMap::new();
    for (k, field) in header.split_whitespace().enumerate() {
        let id: u32 = field.parse().map_err(|_| {
            Error::invalid(
                path,
                format!("line {} field {}", header_idx + 1, k + 1),
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
                format!("line {} field {}", header_idx + 1, k + 1),
                format!("taxel id {id} repeats the id of field {}", first + 1),
            ));
        }
        taxel_ids.push(TaxelId(id));
    }
    let n = taxel_ids.len();
    let mut rec = Recording {
        taxel_ids,
        frame_numbers: Vec::new(),
        frames: Vec::new(),
    };
    for (i, line) in lines {
        let lineno = i + 1;
        let mut fields = line.split_whitespace();
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
        let mut values = Vec::with_capacity(n);
        for (k, field) in fields.enumerate() {
            let v: f32 = field
                .parse()
                .ok()
                .filter(|v: &f32| v.is_finite() && v.abs() <= MAX_READING)
                .ok_or_else(|| {
                    Error::invalid(
                        path,
                        format!("line {lineno} field {} (taxel {})", k + 3, rec.taxel_ids[k]),
                        format!(
                            "reading \"{}\" is not a finite number within ±{MAX_READING:e} counts",
                            super::excerpt(field)
                        ),
                    )
                })?;
            values.push(v);
        }
        rec.frame_numbers.push(number);
        rec.frames.push(Frame { time, values });
    }
    Ok(rec)
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

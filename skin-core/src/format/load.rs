//! Known loads on a skin over time, for calibrating its force model: a load cell's samples, or
//! the masses (or forces) a user placed on it and when.
//!
//! Two CSV shapes, told apart by their header line:
//!
//! ```text
//! time_s,force_n[,x_m,y_m,z_m]      a load cell's samples; optionally where it pressed (link frame;
//!                                   left empty where nothing pressed)
//! 0.00,0.0
//! 0.05,1.92,0.031,0.002,0.040
//!
//! start_s,end_s,mass_kg             masses resting on the skin (force = mass * 9.80665 N)
//! 1.0,2.5,0.1                       (or start_s,end_s,force_n)
//! ```
//!
//! Times are seconds on the recording's clock (a candump log's: seconds since the epoch; a
//! Cyskin recording's: its own time column), in increasing order. Between two load-cell samples
//! the force is taken as linear; outside the first and last it is unknown. A list of masses says
//! what rests on the skin during each span and that nothing does between them, from the first
//! span's start to the last one's end. Forces are newtons, never negative; blank lines and lines
//! starting with `#` are skipped.

use crate::text::{Gzip, Input, Lines};
use crate::{Error, Result};
use nalgebra::Point3;
use std::path::{Path, PathBuf};

/// Standard gravity, m/s² (the conventional value, ISO 80000-3): a mass's weight in newtons.
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// A load cell's sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadSample {
    /// Seconds, the recording's clock.
    pub time_s: f64,
    /// Newtons.
    pub force_n: f64,
    /// Where it pressed, metres in the link frame, when the file says.
    pub point: Option<Point3<f64>>,
}

/// A load held on the skin over a span of time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldLoad {
    /// Seconds, the recording's clock.
    pub start_s: f64,
    /// Seconds, after `start_s`.
    pub end_s: f64,
    /// Newtons (a mass's weight with [`STANDARD_GRAVITY`]).
    pub force_n: f64,
}

/// The loads of a file: what pressed the skin, and when.
#[derive(Debug, Clone, PartialEq)]
pub enum Loads {
    /// A load cell's samples, in time order (at least two).
    Cell(Vec<LoadSample>),
    /// Loads held over spans, in time order, not overlapping.
    Held(Vec<HeldLoad>),
}

/// Loads read from a file, with the file's name for errors.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadFile {
    /// The file.
    pub path: PathBuf,
    /// What it holds.
    pub loads: Loads,
}

impl LoadFile {
    /// Reads a load file (either shape; see the [module](self)).
    pub fn read(path: &Path) -> Result<LoadFile> {
        let mut lines = Lines::new(Input::open(path, Gzip::Read)?, path);
        let mut rows: Option<Rows> = None;
        while let Some(line) = lines.next_line()? {
            let text = line.text().trim();
            if text.is_empty() || text.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = text.split(',').map(str::trim).collect();
            let read = match &mut rows {
                None => Shape::of_header(&fields).map(|shape| rows = Some(Rows::new(shape))),
                Some(r) => r.push(&fields),
            };
            read.map_err(|message| {
                Error::invalid(path, format!("line {}", line.number()), line.explain(message))
            })?;
        }
        let loads = match rows {
            None => return Err(Error::invalid(path, "line 1", format!("no header: {HEADERS}"))),
            Some(r) => r
                .finish()
                .map_err(|(place, message)| Error::invalid(path, place, message))?,
        };
        Ok(LoadFile {
            path: path.to_owned(),
            loads,
        })
    }

    /// The span of time the file says the load of, seconds.
    pub fn span(&self) -> (f64, f64) {
        match &self.loads {
            Loads::Cell(s) => (s[0].time_s, s[s.len() - 1].time_s),
            Loads::Held(h) => (h[0].start_s, h[h.len() - 1].end_s),
        }
    }

    /// The load at `time_s`, newtons; none outside the file's span.
    pub fn force_at(&self, time_s: f64) -> Option<f64> {
        let (first, last) = self.span();
        if !(first..=last).contains(&time_s) {
            return None;
        }
        match &self.loads {
            Loads::Cell(s) => {
                let k = s.partition_point(|x| x.time_s <= time_s).clamp(1, s.len() - 1);
                let (a, b) = (s[k - 1], s[k]);
                let u = (time_s - a.time_s) / (b.time_s - a.time_s);
                Some(a.force_n + u.clamp(0.0, 1.0) * (b.force_n - a.force_n))
            }
            Loads::Held(h) => Some(
                h.iter()
                    .find(|l| (l.start_s..=l.end_s).contains(&time_s))
                    .map_or(0.0, |l| l.force_n),
            ),
        }
    }
}

/// The rows read so far, of the header's shape.
struct Rows {
    shape: Shape,
    cell: Vec<LoadSample>,
    held: Vec<HeldLoad>,
}

impl Rows {
    fn new(shape: Shape) -> Rows {
        Rows {
            shape,
            cell: Vec::new(),
            held: Vec::new(),
        }
    }

    /// One row after the header; why it is refused, with the fix.
    fn push(&mut self, fields: &[&str]) -> std::result::Result<(), String> {
        // A sample with nothing pressing has no point: its x_m, y_m, z_m may be left empty.
        let unplaced = matches!(self.shape, Shape::Cell { point: true })
            && fields.len() == 5
            && fields[2..].iter().all(|f| f.is_empty());
        let v = match unplaced {
            true => numbers(&fields[..2], 2)?,
            false => numbers(fields, self.shape.columns())?,
        };
        match self.shape {
            Shape::Cell { point } => {
                let sample = LoadSample {
                    time_s: v[0],
                    force_n: force(v[1])?,
                    point: (point && !unplaced).then(|| Point3::new(v[2], v[3], v[4])),
                };
                if let Some(last) = self.cell.last().map(|l| l.time_s)
                    && sample.time_s <= last
                {
                    return Err(format!(
                        "time {} s is not after the line before's {last} s: sort the samples by time (sort -t, -k1,1g)",
                        sample.time_s
                    ));
                }
                self.cell.push(sample);
            }
            Shape::Held { mass } => {
                let load = HeldLoad {
                    start_s: v[0],
                    end_s: v[1],
                    force_n: force(if mass { v[2] * STANDARD_GRAVITY } else { v[2] })?,
                };
                if load.end_s <= load.start_s {
                    return Err(format!(
                        "the span ends ({} s) before it starts ({} s): give start_s, then end_s",
                        load.end_s, load.start_s
                    ));
                }
                if let Some(last) = self.held.last().map(|l| l.end_s)
                    && load.start_s < last
                {
                    return Err(format!(
                        "the span starts at {} s, before the line before's ends ({last} s): list spans in time order, one load at a time",
                        load.start_s
                    ));
                }
                self.held.push(load);
            }
        }
        Ok(())
    }

    /// The loads, or where and why there are too few.
    fn finish(self) -> std::result::Result<Loads, (&'static str, String)> {
        match self.shape {
            Shape::Cell { .. } if self.cell.len() < 2 => Err((
                "samples",
                format!(
                    "{} sample(s): a load cell's file needs at least two",
                    self.cell.len()
                ),
            )),
            Shape::Cell { .. } => Ok(Loads::Cell(self.cell)),
            Shape::Held { .. } if self.held.is_empty() => {
                Err(("spans", "no load listed after the header".to_owned()))
            }
            Shape::Held { .. } => Ok(Loads::Held(self.held)),
        }
    }
}

/// The headers a load file may start with.
const HEADERS: &str = "the first line must be 'time_s,force_n' (a load cell, optionally ',x_m,y_m,z_m'), 'start_s,end_s,mass_kg' or 'start_s,end_s,force_n'";

#[derive(Debug, Clone, Copy)]
enum Shape {
    Cell { point: bool },
    Held { mass: bool },
}

impl Shape {
    fn of_header(fields: &[&str]) -> std::result::Result<Shape, String> {
        let lower: Vec<String> = fields.iter().map(|f| f.to_ascii_lowercase()).collect();
        let lower: Vec<&str> = lower.iter().map(String::as_str).collect();
        match lower.as_slice() {
            ["time_s", "force_n"] => Ok(Shape::Cell { point: false }),
            ["time_s", "force_n", "x_m", "y_m", "z_m"] => Ok(Shape::Cell { point: true }),
            ["start_s", "end_s", "mass_kg"] => Ok(Shape::Held { mass: true }),
            ["start_s", "end_s", "force_n"] => Ok(Shape::Held { mass: false }),
            _ if fields.first().is_some_and(|f| f.parse::<f64>().is_ok()) => {
                Err(format!("a number where the header belongs: {HEADERS}"))
            }
            _ => Err(format!("header '{}': {HEADERS}", fields.join(","))),
        }
    }

    fn columns(self) -> usize {
        match self {
            Shape::Cell { point: false } => 2,
            Shape::Cell { point: true } => 5,
            Shape::Held { .. } => 3,
        }
    }
}

/// The line's `columns` numbers, each finite.
fn numbers(fields: &[&str], columns: usize) -> std::result::Result<Vec<f64>, String> {
    if fields.len() != columns {
        return Err(format!("{} field(s), the header names {columns}", fields.len()));
    }
    fields
        .iter()
        .enumerate()
        .map(|(k, f)| match f.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(v) => Err(format!(
                "field {} is {v}: every value must be a finite number",
                k + 1
            )),
            Err(_) => Err(format!("field {} ({f:?}) is not a number", k + 1)),
        })
        .collect()
}

/// `n` as a load: newtons, not negative.
fn force(n: f64) -> std::result::Result<f64, String> {
    match n >= 0.0 {
        true => Ok(n),
        false => Err(format!(
            "a load of {n} N: loads press the skin, never pull it; zero the load cell (or subtract its offset) first"
        )),
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;

    fn read(text: &str) -> Result<LoadFile> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("load.csv");
        std::fs::write(&path, text).unwrap();
        LoadFile::read(&path)
    }

    fn error(text: &str) -> String {
        read(text).unwrap_err().to_string()
    }

    #[test]
    fn a_load_cell_is_linear_between_samples() {
        let f = read("# rig 3\ntime_s,force_n\n0,0\n1,2\n\n3,2\n").unwrap();
        assert_eq!(f.span(), (0.0, 3.0));
        assert_eq!(f.force_at(0.5), Some(1.0));
        assert_eq!(f.force_at(2.0), Some(2.0));
        assert_eq!(f.force_at(3.0), Some(2.0));
        assert_eq!(f.force_at(-0.1), None);
        assert_eq!(f.force_at(3.1), None);
        let f = read("time_s,force_n,x_m,y_m,z_m\n0,0,0,0,0\n1,1,0.01,0.02,0.03\n").unwrap();
        let point = match &f.loads {
            Loads::Cell(s) => s[1].point,
            Loads::Held(_) => None,
        };
        assert_eq!(point, Some(Point3::new(0.01, 0.02, 0.03)));
        // Nothing pressing, no point; a point half given is refused.
        let f = read("time_s,force_n,x_m,y_m,z_m\n0,0,,,\n1,1,0.01,0.02,0.03\n").unwrap();
        let points: Vec<_> = match &f.loads {
            Loads::Cell(s) => s.iter().map(|s| s.point.is_some()).collect(),
            Loads::Held(_) => Vec::new(),
        };
        assert_eq!(points, [false, true]);
        let e = error("time_s,force_n,x_m,y_m,z_m\n0,0,0.01,,\n1,1,0.01,0.02,0.03\n");
        assert!(e.contains("line 2") && e.contains("field 4"), "{e}");
    }

    #[test]
    fn masses_rest_in_their_spans_and_nothing_between() {
        let f = read("start_s,end_s,mass_kg\n1,2,0.1\n3,4,0.2\n").unwrap();
        assert!((f.force_at(1.5).unwrap() - 0.980665).abs() < 1e-12);
        assert_eq!(f.force_at(2.5), Some(0.0));
        assert!((f.force_at(4.0).unwrap() - 1.96133).abs() < 1e-12);
        assert_eq!(f.force_at(0.5), None);
        let f = read("start_s,end_s,force_n\n1,2,5\n").unwrap();
        assert_eq!(f.force_at(1.2), Some(5.0));
    }

    #[test]
    fn bad_files_name_the_line_and_the_fix() {
        let e = error("time_s,force_n\n0,0\n2,1\n1,1\n");
        assert!(e.contains("load.csv: line 4:") && e.contains("sort"), "{e}");
        let e = error("time_s,force_n\n0,0\n1,NaN\n");
        assert!(e.contains("line 3") && e.contains("finite"), "{e}");
        let e = error("time_s,force_n\n0,0\n1,-0.5\n");
        assert!(
            e.contains("line 3") && e.contains("never pull") && e.contains("zero the load cell"),
            "{e}"
        );
        let e = error("0,0\n1,1\n");
        assert!(e.contains("line 1") && e.contains("header"), "{e}");
        let e = error("time,force\n");
        assert!(e.contains("line 1") && e.contains("time_s,force_n"), "{e}");
        let e = error("time_s,force_n\n0,0\n1\n");
        assert!(e.contains("line 3") && e.contains("1 field(s)"), "{e}");
        let e = error("time_s,force_n\n0,0\n");
        assert!(e.contains("at least two"), "{e}");
        let e = error("start_s,end_s,mass_kg\n2,1,0.1\n");
        assert!(e.contains("line 2") && e.contains("before it starts"), "{e}");
        let e = error("start_s,end_s,mass_kg\n1,3,0.1\n2,4,0.1\n");
        assert!(e.contains("line 3") && e.contains("time order"), "{e}");
        let e = error("");
        assert!(e.contains("no header"), "{e}");
        let e = error("time_s,force_n\n0,0\n1,x");
        assert!(e.contains("line 3") && e.contains("not a number"), "{e}");
    }
}

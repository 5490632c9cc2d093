//! Probe datasets: where the probe pressed, and what every taxel answered.
//!
//! The CSV form, which other tools write too, is exactly:
//!
//! ```text
//! contact,x_m,y_m,z_m,taxel,response
//! 0,0.0121,-0.0033,0.1002,16,412.5
//! 0,0.0121,-0.0033,0.1002,17,88.0
//! 1,0.0240,0.0051,0.1001,17,530.1
//! ```
//! one row per (contact, responding taxel): the contact's number, its 3D centroid in metres (the
//! same on every row of the contact), the taxel id and the raw response (any unit, as long as it
//! is the same for every contact of a taxel). Taxels that did not answer have no row. Centroids
//! lie within `MAX_POSITION_M` (100 m) and responses within `MAX_READING` (1e9), as positions and
//! readings do in every other file.

use nalgebra::Point3;
use skin_core::format::recording::MAX_READING;
use skin_core::format::{MAX_POSITION_M, excerpt};
use skin_core::text::{Gzip, Input, Lines};
use skin_core::{Error, Result, TaxelId};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::BufRead;
use std::path::Path;

/// The header line of the CSV form.
pub const CSV_HEADER: &str = "contact,x_m,y_m,z_m,taxel,response";

/// Its fields, in order.
const FIELDS: [&str; 6] = ["contact", "x_m", "y_m", "z_m", "taxel", "response"];

/// One press of the probe.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeContact {
    /// Contact centroid (the probe tip), metres, in the frame the taxels are wanted in.
    pub centroid: Point3<f64>,
    /// Force the probe applied, newtons, when known (not part of the CSV form).
    pub force_n: Option<f64>,
    /// Every taxel that answered, with its raw response.
    pub responses: Vec<(TaxelId, f64)>,
}

/// A set of probe contacts.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ProbeDataset {
    /// The contacts, in the order they were made.
    pub contacts: Vec<ProbeContact>,
}

/// One taxel's samples: contact centroids and its responses to them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TaxelSamples {
    /// Contact centroids, metres.
    pub centroids: Vec<Point3<f64>>,
    /// Responses, one per centroid.
    pub responses: Vec<f64>,
}

/// One row of the CSV form, its fields checked.
struct Row {
    contact: u64,
    xyz: [f64; 3],
    taxel: u32,
    response: f64,
}

impl Row {
    /// Line `number` of the file (not the header), split at its commas.
    fn parse(line: &str, number: usize, path: &Path) -> Result<Row> {
        let i = number - 1;
        let place = |field: &str| format!("line {}, field {field}", i + 1);
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != 6 {
            return Err(Error::invalid(
                path,
                format!("line {}", i + 1),
                format!("{} fields, expected 6 ({CSV_HEADER})", cells.len()),
            ));
        }
        let contact: u64 = cells[0].parse().map_err(|_| {
            Error::invalid(
                path,
                place("contact"),
                format!("\"{}\" is not a contact number", excerpt(cells[0])),
            )
        })?;
        // A finite number within `limit` in column `k`, or an error naming the field.
        let finite = |k: usize, limit: f64, what: &str| {
            cells[k]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && v.abs() <= limit)
                .ok_or_else(|| {
                    Error::invalid(
                        path,
                        place(FIELDS[k]),
                        format!("\"{}\" is not {what} within ±{limit:e}", excerpt(cells[k])),
                    )
                })
        };
        let metres = "a finite number of metres";
        let xyz = [
            finite(1, MAX_POSITION_M, metres)?,
            finite(2, MAX_POSITION_M, metres)?,
            finite(3, MAX_POSITION_M, metres)?,
        ];
        let taxel: u32 = cells[4].parse().map_err(|_| {
            Error::invalid(
                path,
                place("taxel"),
                format!("\"{}\" is not a taxel id", excerpt(cells[4])),
            )
        })?;
        let response = finite(5, f64::from(MAX_READING), "a finite number")?;
        Ok(Row {
            contact,
            xyz,
            taxel,
            response,
        })
    }
}

impl ProbeDataset {
    /// Reads the CSV form, line by line (gzip-compressed too).
    pub fn read(path: &Path) -> Result<ProbeDataset> {
        Self::from_reader(Input::open(path, Gzip::Read)?, path)
    }

    /// Parses the CSV form; `path` names the file in errors.
    pub fn parse(text: &str, path: &Path) -> Result<ProbeDataset> {
        Self::from_reader(text.as_bytes(), path)
    }

    /// Reads the CSV form from any text input, line by line; `path` names it in errors.
    pub fn from_reader(reader: impl BufRead, path: &Path) -> Result<ProbeDataset> {
        let mut lines = Lines::new(reader, path);
        let mut dataset = ProbeDataset::default();
        let mut index: BTreeMap<u64, usize> = BTreeMap::new();
        let mut answered: std::collections::HashSet<(u64, u32)> = std::collections::HashSet::new();
        let mut header = false;
        while let Some(line) = lines.next_line()? {
            if line.trim().is_empty() {
                continue;
            }
            let i = line.number() - 1;
            if !header {
                if line.trim() != CSV_HEADER {
                    return Err(Error::invalid(
                        path,
                        format!("line {}", i + 1),
                        format!(
                            "header is \"{}\", expected \"{CSV_HEADER}\"",
                            excerpt(line.trim())
                        ),
                    ));
                }
                header = true;
                continue;
            }
            let place = |field: &str| format!("line {}, field {field}", i + 1);
            let Row {
                contact,
                xyz,
                taxel,
                response,
            } = Row::parse(&line, i + 1, path)?;
            let centroid = Point3::from(xyz);
            let k = *index.entry(contact).or_insert_with(|| {
                dataset.contacts.push(ProbeContact {
                    centroid,
                    force_n: None,
                    responses: Vec::new(),
                });
                dataset.contacts.len() - 1
            });
            let c = &mut dataset.contacts[k];
            if (c.centroid - centroid).norm() > 1e-9 {
                return Err(Error::invalid(
                    path,
                    place("x_m"),
                    format!(
                        "contact {contact} is at ({:.6}, {:.6}, {:.6}) on an earlier line, here at ({:.6}, {:.6}, {:.6})",
                        c.centroid.x, c.centroid.y, c.centroid.z, xyz[0], xyz[1], xyz[2]
                    ),
                ));
            }
            if !answered.insert((contact, taxel)) {
                return Err(Error::invalid(
                    path,
                    place("taxel"),
                    format!("taxel {taxel} answers contact {contact} twice"),
                ));
            }
            c.responses.push((TaxelId(taxel), response));
        }
        if !header {
            return Err(Error::invalid(path, "line 1", "empty file; expected the header"));
        }
        Ok(dataset)
    }

    /// The CSV form (contacts numbered from 0 in order; contacts nobody answered have no row).
    pub fn to_csv(&self) -> String {
        let mut s = String::with_capacity(64 * self.contacts.len() * 8);
        s.push_str(CSV_HEADER);
        s.push('\n');
        for (k, c) in self.contacts.iter().enumerate() {
            for (t, r) in &c.responses {
                let _ = writeln!(
                    s,
                    "{k},{:.7},{:.7},{:.7},{t},{}",
                    c.centroid.x,
                    c.centroid.y,
                    c.centroid.z,
                    round_response(*r)
                );
            }
        }
        s
    }

    /// Writes the CSV form.
    pub fn write(&self, path: &Path) -> Result<()> {
        std::fs::write(path, self.to_csv()).map_err(|source| Error::Io {
            path: path.to_owned(),
            source,
        })
    }

    /// Samples per taxel (responses of exactly zero are not answers, as in Ch. 7.2.4).
    pub fn by_taxel(&self) -> BTreeMap<TaxelId, TaxelSamples> {
        let mut out: BTreeMap<TaxelId, TaxelSamples> = BTreeMap::new();
        for c in &self.contacts {
            for &(t, r) in &c.responses {
                let s = out.entry(t).or_default();
                if r != 0.0 {
                    s.centroids.push(c.centroid);
                    s.responses.push(r);
                }
            }
        }
        out
    }
}

/// Responses are written with 4 significant decimals (shortest form that reads back the same).
fn round_response(r: f64) -> f64 {
    (r * 1e4).round() / 1e4
}

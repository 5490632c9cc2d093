//! Taxels described in a robot's URDF with urdf_tactile (ubi-agni/tactile_toolbox): one skin per
//! link that carries tactile sensors, in the link frame.
//!
//! ```xml
//! <sensor name="palm" update_rate="100">
//!   <parent link="hand"/>
//!   <origin xyz="0 0 0.034" rpy="0 0 0"/>     <!-- the sensor frame in the link frame -->
//!   <tactile>
//!     <array rows="16" cols="16" order="row-major" size="0.005 0.005" spacing="0.005 0.005" offset="0 0"/>
//!   </tactile>
//! </sensor>
//! <sensor name="tip" update_rate="100">
//!   <parent link="finger"/>
//!   <origin xyz="0 0 0" rpy="0 0 0"/>
//!   <tactile channel="tips">
//!     <taxel idx="0" xyz="0.01 0.01 0" rpy="0 0 0"/>   <!-- its normal: the taxel frame's +z -->
//!   </tactile>
//! </sensor>
//! ```
//!
//! An array's taxel `idx` (row-major by default: `idx = row * cols + col`) sits at
//! `x = row * spacing_x - offset_x`, `y = col * spacing_y - offset_y` in the sensor frame, normal
//! +z; spacing defaults to the taxel size (as urdf_tactile reads it). A listed taxel sits at its
//! `xyz`, normal the +z of its `rpy`, both in the sensor frame. Rotations are URDF's roll, pitch,
//! yaw about fixed x, y, z.
//!
//! Taxel ids: the `k`-th tactile sensor of the file (from 0, in file order) numbers its taxels
//! `k << 16 | idx`, so the first sensor's ids are its data indices. Sensors of other kinds are
//! skipped; a sensor with both an array and a list keeps the list (the array is noted, as
//! urdf_tactile warns); a repeated `idx` within a sensor keeps the first taxel (noted).

use super::{Note, Noted, make_taxel, read_text};
use crate::{Error, LinkSkin, Result, TaxelId};
use nalgebra::{Isometry3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};
use quick_xml::events::{BytesStart, Event};
use std::path::Path;

/// The most taxels one array may have (a 1,000 x 1,000 grid).
const MAX_ARRAY_TAXELS: usize = 1_000_000;

/// Reads the tactile sensors of a URDF file.
pub fn read(path: &Path) -> Result<Noted<Vec<LinkSkin>>> {
    parse(&read_text(path)?, path)
}

/// One tactile `<sensor>` element as read.
#[derive(Default)]
struct Sensor {
    name: String,
    line: usize,
    parent: Option<String>,
    origin: Isometry3<f64>,
    tactile: bool,
    array: Option<Array>,
    /// (idx, pose in the sensor frame, line)
    taxels: Vec<(u32, Isometry3<f64>, usize)>,
}

struct Array {
    rows: usize,
    cols: usize,
    column_major: bool,
    spacing: [f64; 2],
    offset: [f64; 2],
}

/// Parses URDF text; `path` names it in errors and notes.
pub fn parse(text: &str, path: &Path) -> Result<Noted<Vec<LinkSkin>>> {
    // Lines counted as the reader moves on (positions only grow): counting from the start at
    // every element would be quadratic in the file's size.
    let (mut counted_to, mut lines_before) = (0usize, 0usize);
    let mut line_at = |pos: u64| {
        let end = usize::try_from(pos).unwrap_or(usize::MAX).min(text.len());
        if end >= counted_to {
            lines_before += text.as_bytes()[counted_to..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count();
            counted_to = end;
            lines_before + 1
        } else {
            text.as_bytes()[..end].iter().filter(|&&b| b == b'\n').count() + 1
        }
    };
    let mut reader = quick_xml::Reader::from_str(text);
    // Names of the open elements, outermost first.
    let mut open: Vec<Vec<u8>> = Vec::new();
    let mut current: Option<Sensor> = None;
    let mut sensors: Vec<Sensor> = Vec::new();
    loop {
        let line = line_at(reader.buffer_position());
        let event = match reader.read_event() {
            Ok(event) => event,
            Err(e) => {
                return Err(Error::invalid(
                    path,
                    format!("line {}", line_at(reader.error_position())),
                    format!("not XML: {e}"),
                ));
            }
        };
        match event {
            Event::Start(e) => {
                element(&e, &open, line, &mut current, path)?;
                open.push(e.local_name().as_ref().to_vec());
            }
            Event::Empty(e) => {
                element(&e, &open, line, &mut current, path)?;
                if open.len() == 1 && e.local_name().as_ref() == b"sensor" {
                    sensors.extend(current.take());
                }
            }
            Event::End(_) => {
                let closed = open.pop();
                if open.len() == 1 && closed.as_deref() == Some(b"sensor") {
                    sensors.extend(current.take());
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    build(sensors, path)
}

/// Takes one element, opened under `open`, into the sensor being read.
fn element(
    e: &BytesStart<'_>,
    open: &[Vec<u8>],
    line: usize,
    current: &mut Option<Sensor>,
    path: &Path,
) -> Result<()> {
    let name = e.local_name();
    let at = |what: &str| format!("line {line} ({what})");
    match (open.len(), name.as_ref()) {
        (1, b"sensor") => {
            *current = Some(Sensor {
                name: attr(e, "name", path, &at("sensor"))?.unwrap_or_default(),
                line,
                origin: Isometry3::identity(),
                ..Sensor::default()
            });
        }
        (2, child) if open[1] == b"sensor" => {
            let Some(s) = current else { return Ok(()) };
            match child {
                b"parent" => s.parent = attr(e, "link", path, &at("parent"))?,
                b"origin" => s.origin = pose(e, path, &at("origin"))?,
                b"tactile" => s.tactile = true,
                _ => {}
            }
        }
        (3, child) if open[1] == b"sensor" && open[2] == b"tactile" => {
            let Some(s) = current else { return Ok(()) };
            match child {
                b"array" => s.array = Some(array(e, path, &at("array"))?),
                b"taxel" => {
                    let place = at("taxel");
                    let idx = attr(e, "idx", path, &place)?
                        .ok_or_else(|| Error::invalid(path, &place, "no idx"))?;
                    let idx: u32 = idx
                        .trim()
                        .parse()
                        .ok()
                        .filter(|&i| i <= u32::from(u16::MAX))
                        .ok_or_else(|| {
                            Error::invalid(
                                path,
                                &place,
                                format!(
                                    "idx \"{}\" is not a data index from 0 to 65535",
                                    super::excerpt(&idx)
                                ),
                            )
                        })?;
                    s.taxels.push((idx, pose(e, path, &place)?, line));
                }
                _ => {}
            }
        }
        _ => {}
    }
    Ok(())
}

/// An attribute's value, if there.
fn attr(e: &BytesStart<'_>, key: &str, path: &Path, place: &str) -> Result<Option<String>> {
    match e.try_get_attribute(key) {
        Ok(Some(a)) => a
            .unescape_value()
            .map(|v| Some(v.into_owned()))
            .map_err(|err| Error::invalid(path, place, format!("attribute {key}: {err}"))),
        Ok(None) => Ok(None),
        Err(err) => Err(Error::invalid(path, place, format!("attribute {key}: {err}"))),
    }
}

/// `N` numbers of attribute `key` (`default` when absent).
fn numbers<const N: usize>(
    e: &BytesStart<'_>,
    key: &str,
    default: [f64; N],
    path: &Path,
    place: &str,
) -> Result<[f64; N]> {
    let Some(text) = attr(e, key, path, place)? else {
        return Ok(default);
    };
    let values: Vec<f64> = text
        .split_whitespace()
        .map(str::parse)
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| {
            Error::invalid(
                path,
                place,
                format!("{key}=\"{}\" is not {N} numbers", super::excerpt(&text)),
            )
        })?;
    let values: [f64; N] = values.try_into().map_err(|_| {
        Error::invalid(
            path,
            place,
            format!("{key}=\"{}\" is not {N} numbers", super::excerpt(&text)),
        )
    })?;
    if values.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            path,
            place,
            format!("{key}=\"{text}\" is not finite"),
        ));
    }
    Ok(values)
}

/// The pose of `xyz` (metres) and `rpy` (radians: roll, pitch, yaw about fixed x, y, z).
fn pose(e: &BytesStart<'_>, path: &Path, place: &str) -> Result<Isometry3<f64>> {
    let [x, y, z] = numbers(e, "xyz", [0.0; 3], path, place)?;
    let [r, p, w] = numbers(e, "rpy", [0.0; 3], path, place)?;
    let rotation = UnitQuaternion::from_rotation_matrix(&Rotation3::from_euler_angles(r, p, w));
    Ok(Isometry3::from_parts(Translation3::new(x, y, z), rotation))
}

fn array(e: &BytesStart<'_>, path: &Path, place: &str) -> Result<Array> {
    let count = |key: &str| -> Result<usize> {
        let v = attr(e, key, path, place)?.ok_or_else(|| Error::invalid(path, place, format!("no {key}")))?;
        v.trim().parse::<usize>().ok().filter(|&n| n > 0).ok_or_else(|| {
            Error::invalid(
                path,
                place,
                format!("{key}=\"{}\" is not a positive count", super::excerpt(&v)),
            )
        })
    };
    let (rows, cols) = (count("rows")?, count("cols")?);
    if rows.saturating_mul(cols) > MAX_ARRAY_TAXELS.min(usize::from(u16::MAX) + 1) {
        return Err(Error::invalid(
            path,
            place,
            format!("{rows} x {cols} taxels: at most 65,536 in one array"),
        ));
    }
    let size: [f64; 2] = numbers(e, "size", [0.0; 2], path, place)?;
    let mut spacing: [f64; 2] = numbers(e, "spacing", [0.0; 2], path, place)?;
    // urdf_tactile: a spacing of zero (or none) is the taxel size.
    for (s, z) in spacing.iter_mut().zip(size) {
        if *s == 0.0 {
            *s = z;
        }
    }
    if spacing.contains(&0.0) {
        return Err(Error::invalid(
            path,
            place,
            "neither spacing nor size gives the distance between taxels",
        ));
    }
    let order = attr(e, "order", path, place)?.unwrap_or_else(|| "row-major".into());
    let column_major = match order.as_str() {
        "row-major" => false,
        "column-major" => true,
        other => {
            return Err(Error::invalid(
                path,
                place,
                format!(
                    "order=\"{}\": expected row-major or column-major",
                    super::excerpt(other)
                ),
            ));
        }
    };
    Ok(Array {
        rows,
        cols,
        column_major,
        spacing,
        offset: numbers(e, "offset", [0.0; 2], path, place)?,
    })
}

/// The skins of the tactile sensors, one per parent link in order of first appearance.
fn build(sensors: Vec<Sensor>, path: &Path) -> Result<Noted<Vec<LinkSkin>>> {
    let mut links: Vec<LinkSkin> = Vec::new();
    let mut notes = Vec::new();
    let tactile: Vec<Sensor> = sensors.into_iter().filter(|s| s.tactile).collect();
    if tactile.is_empty() {
        return Err(Error::invalid(
            path,
            "robot",
            "no tactile sensor (<sensor> with a <tactile> element)",
        ));
    }
    for (k, s) in tactile.iter().enumerate() {
        let place = format!("line {} (sensor \"{}\")", s.line, s.name);
        let link = s
            .parent
            .clone()
            .ok_or_else(|| Error::invalid(path, &place, "no <parent link=...>"))?;
        let k = u32::try_from(k)
            .ok()
            .filter(|&k| k <= u32::from(u16::MAX))
            .ok_or_else(|| Error::invalid(path, &place, "more than 65,536 tactile sensors"))?;
        let poses = sensor_poses(s, &place, path, &mut notes);
        let at = match links.iter().position(|l| l.name == link) {
            Some(i) => i,
            None => {
                links.push(LinkSkin::new(link, Vec::new()));
                links.len() - 1
            }
        };
        for (idx, pose, place) in poses {
            let in_link = s.origin * pose;
            let p: Point3<f64> = in_link * Point3::origin();
            let n: Vector3<f64> = in_link.rotation * Vector3::z();
            let id = TaxelId(k << 16 | idx);
            links[at]
                .taxels
                .push(make_taxel(path, &place, id, p.coords.into(), n.into())?);
        }
    }
    links.retain(|l| !l.taxels.is_empty());
    if links.is_empty() {
        return Err(Error::invalid(path, "robot", "its tactile sensors have no taxel"));
    }
    for l in &links {
        super::check_link(path, l)?;
    }
    Ok(Noted { value: links, notes })
}

/// Each taxel's data index, pose in the sensor frame and place (for errors) of sensor `s`: its
/// taxel list (the first taxel of a repeated idx kept), else its array, else none; what was
/// ignored is said in `notes`.
fn sensor_poses(
    s: &Sensor,
    place: &str,
    path: &Path,
    notes: &mut Vec<Note>,
) -> Vec<(u32, Isometry3<f64>, String)> {
    let mut poses: Vec<(u32, Isometry3<f64>, String)> = Vec::new();
    if !s.taxels.is_empty() {
        if s.array.is_some() {
            notes.push(Note::UrdfTactile {
                path: path.to_owned(),
                sensor: s.name.clone(),
                what: "has both a taxel list and an array: the array is ignored".into(),
            });
        }
        let mut seen = std::collections::HashSet::new();
        let mut repeated = Vec::new();
        for (idx, pose, line) in &s.taxels {
            if seen.insert(*idx) {
                poses.push((
                    *idx,
                    *pose,
                    format!("line {line} (sensor \"{}\" taxel {idx})", s.name),
                ));
            } else {
                repeated.push(*idx);
            }
        }
        if !repeated.is_empty() {
            notes.push(Note::UrdfTactile {
                path: path.to_owned(),
                sensor: s.name.clone(),
                what: format!("repeats taxel idx {repeated:?}: the first taxel of each idx is kept"),
            });
        }
    } else if let Some(a) = &s.array {
        for idx in 0..a.rows * a.cols {
            let (row, col) = if a.column_major {
                (idx % a.rows, idx / a.rows)
            } else {
                (idx / a.cols, idx % a.cols)
            };
            let x = row as f64 * a.spacing[0] - a.offset[0];
            let y = col as f64 * a.spacing[1] - a.offset[1];
            let place = format!("{place} array taxel {idx}");
            poses.push((idx as u32, Isometry3::translation(x, y, 0.0), place));
        }
    } else {
        notes.push(Note::UrdfTactile {
            path: path.to_owned(),
            sensor: s.name.clone(),
            what: "has neither an array nor taxels: no taxel".into(),
        });
    }
    poses
}

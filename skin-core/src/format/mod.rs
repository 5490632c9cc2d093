//! Readers and writers for skin files.
//!
//! | module | format | read | write |
//! |---|---|---|---|
//! | [`native`] | the project's JSON layout (`skin-layout/1`), metres | yes | yes |
//! | [`cyskin`] | Cyskin calibration JSON (`skin`: taxels, faces, parent frame), metres | yes | yes |
//! | [`force_file`] | a skin's force calibration (`skin-force/1`): response curve and gains per link | yes | yes |
//! | [`icub`] | iCub `positions/*.txt` taxel files, metres | yes | no |
//! | [`load`] | known loads over time (a load cell's CSV, or masses held), newtons | yes | no |
//! | [`recording`] | Cyskin raw recordings (ids line, then index, time, counts) | yes | yes |
//! | [`poses`] | link poses over time (`skin-poses/1`), metres | yes | no |
//! | [`urdf_tactile`] | a URDF's tactile sensors (arrays, taxel lists), one skin per link, metres | yes | no |
//!
//! [`load_link`] picks the reader from the file's extension and content.

pub mod cyskin;
pub mod force_file;
pub mod icub;
pub mod load;
pub mod native;
pub mod poses;
pub mod recording;
pub mod urdf_tactile;

use crate::{Error, LinkSkin, Result, Taxel, TaxelId};
use nalgebra::{Point3, Unit, Vector3};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Something a reader did so that a real file could be used: a warning to pass on to the user,
/// naming the file and what was done. Reading never changes data in silence.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Note {
    /// An iCub taxel file: how many slot rows it has, and the all-zero ones (unused slots),
    /// dropped.
    IcubRows {
        /// The file.
        path: PathBuf,
        /// Slot rows in the file.
        rows: usize,
        /// Slots whose row is all zeros, dropped.
        unused: Vec<usize>,
    },
    /// Taxels sharing one position, each group merged into its first taxel.
    MergedDuplicates {
        /// The file.
        path: PathBuf,
        /// The groups.
        groups: Vec<icub::DuplicateGroup>,
    },
    /// Slots with a position that the file's own `taxel2Repr` says are not taxels (thermal
    /// pads, unused slots), dropped.
    NotTaxels {
        /// The file.
        path: PathBuf,
        /// The slots.
        slots: Vec<usize>,
    },
    /// Taxels given with an all-zero normal: each normal estimated from the surface of its
    /// neighbouring taxels and oriented like its neighbours' ([`crate::normals`]).
    EstimatedNormals {
        /// The file.
        path: PathBuf,
        /// How many taxels.
        taxels: usize,
    },
    /// Taxels carrying a placeholder id (a sensor not known, several taxels sharing the id):
    /// each is kept as a vertex of the skin's mesh under an id of its own from
    /// [`TaxelId::placeholder`], and carries no reading (a dead taxel).
    PlaceholderIds {
        /// The file.
        path: PathBuf,
        /// The id the file repeats.
        id: TaxelId,
        /// How many taxels carry it.
        taxels: usize,
    },
    /// Something a URDF's tactile sensor holds that urdf_tactile itself would skip or warn of.
    UrdfTactile {
        /// The file.
        path: PathBuf,
        /// The sensor's name.
        sensor: String,
        /// What was found and done.
        what: String,
    },
    /// A layout given where a tactile map was expected, flattened with the default options.
    Flattened {
        /// The layout file.
        path: PathBuf,
        /// The map's extent, metres (width, height).
        extent_m: (f64, f64),
        /// Mean angle error of the flattening, degrees.
        angle_error_deg: f64,
    },
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Note::IcubRows { path, rows, unused } => write!(
                f,
                "{}: {rows} taxel rows, {} unused (all-zero) rows dropped",
                path.display(),
                unused.len()
            ),
            Note::MergedDuplicates { path, groups } => {
                let merged: usize = groups.iter().map(|g| g.slots.len().saturating_sub(1)).sum();
                write!(
                    f,
                    "{}: duplicated positions: {} groups, {merged} taxels merged into the first of their group:",
                    path.display(),
                    groups.len()
                )?;
                for g in groups {
                    write!(f, "\n  lines {:?} (taxels {:?})", g.lines, g.slots)?;
                }
                Ok(())
            }
            Note::NotTaxels { path, slots } => {
                write!(
                    f,
                    "{}: {} slot(s) with a position are no taxel by the file's taxel2Repr (thermal pads, unused slots), dropped: {:?}",
                    path.display(),
                    slots.len(),
                    &slots[..slots.len().min(12)]
                )?;
                if slots.len() > 12 {
                    write!(f, " and {} more", slots.len() - 12)?;
                }
                Ok(())
            }
            Note::EstimatedNormals { path, taxels } => write!(
                f,
                "{}: {taxels} taxel(s) have an all-zero normal; each was estimated from its neighbours' surface and oriented like them",
                path.display()
            ),
            Note::PlaceholderIds { path, id, taxels } => write!(
                f,
                "{}: {taxels} taxels carry the placeholder id {id} (no known sensor): kept as mesh vertices with ids of their own, no readings (dead taxels)",
                path.display()
            ),
            Note::UrdfTactile { path, sensor, what } => {
                write!(f, "{}: tactile sensor \"{sensor}\" {what}", path.display())
            }
            Note::Flattened {
                path,
                extent_m: (w, h),
                angle_error_deg,
            } => write!(
                f,
                "{}: a layout, flattened to a {:.0} x {:.0} mm tactile map (mean angle error {angle_error_deg:.3} deg); save it with `skin flatten` to skip this step",
                path.display(),
                w * 1e3,
                h * 1e3
            ),
        }
    }
}

/// What a reader read, with the [`Note`]s of what it did to read it.
#[derive(Debug, Clone, PartialEq)]
pub struct Noted<T> {
    /// What was read.
    pub value: T,
    /// What was done to read it, in the order it was done; empty for a clean file.
    pub notes: Vec<Note>,
}

impl<T> Noted<T> {
    /// `value`, with no note.
    pub fn clean(value: T) -> Noted<T> {
        Noted {
            value,
            notes: Vec::new(),
        }
    }

    /// The value changed by `f`, the notes kept.
    pub fn map<U>(self, f: impl FnOnce(T) -> U) -> Noted<U> {
        Noted {
            value: f(self.value),
            notes: self.notes,
        }
    }
}

/// Every link of a layout file: all links of a skin-layout/1 file (an error if it has none),
/// or the one link of a Cyskin calibration or an iCub taxel file ([`load_link`]).
pub fn load_links(path: &Path) -> Result<Noted<Vec<LinkSkin>>> {
    if is_urdf(path) {
        return urdf_tactile::read(path);
    }
    let text = read_text(path)?;
    if text.contains("skin-layout/") {
        let layout = native::read_layout(path)?;
        if layout.links.is_empty() {
            return Err(Error::invalid(path, "field \"links\"", "the layout has no link"));
        }
        return Ok(Noted::clean(layout.links));
    }
    Ok(load_link(path)?.map(|link| vec![link]))
}

/// Reads one link's skin from a project JSON layout (its first link), a Cyskin calibration JSON or
/// an iCub taxel file (duplicated positions merged, see [`icub::Duplicates`]), with the notes of
/// what was done to read it.
pub fn load_link(path: &Path) -> Result<Noted<LinkSkin>> {
    if is_urdf(path) {
        let read = urdf_tactile::read(path)?;
        let Noted { value, notes } = read;
        let link = value
            .into_iter()
            .next()
            .ok_or_else(|| Error::invalid(path, "robot", "no tactile sensor"))?;
        return Ok(Noted { value: link, notes });
    }
    let is_txt = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("txt") || e.eq_ignore_ascii_case("ini"));
    if is_txt {
        let read = icub::read(path, icub::Duplicates::Merge)?;
        let notes = read.notes(path);
        return Ok(Noted {
            value: read.skin,
            notes,
        });
    }
    let text = read_text(path)?;
    let value: serde_json::Value = serde_json::from_str(&text).map_err(|e| Error::json(path, &e))?;
    if value.get("skin").is_some() {
        cyskin::from_value(value, path)
    } else if value.get("links").is_some() {
        let layout = native::from_value(value, path)?;
        layout
            .links
            .into_iter()
            .next()
            .map(Noted::clean)
            .ok_or_else(|| Error::invalid(path, "field \"links\"", "the layout has no link"))
    } else if value.get("tactile_maps").is_some() {
        Err(Error::invalid(
            path,
            "top level",
            "a tactile map (already flat), not a layout: give it where a map is taken (e.g. skin image --map)",
        ))
    } else {
        Err(Error::invalid(
            path,
            "top level",
            "neither a skin layout (\"links\") nor a Cyskin calibration (\"skin\")",
        ))
    }
}

/// A URDF file, by its extension.
fn is_urdf(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("urdf"))
}

/// When a JSON document does not have the expected shape, finds the first element of `items`
/// (a list the document holds) that does not deserialise as `T` and names it with `place(i,
/// item)`; `None` when every element does (the fault is elsewhere).
pub(crate) fn locate<T: serde::de::DeserializeOwned>(
    path: &Path,
    items: Option<&serde_json::Value>,
    place: impl Fn(usize, &serde_json::Value) -> String,
) -> Option<Error> {
    let items = items?.as_array()?;
    items.iter().enumerate().find_map(|(i, item)| {
        serde_json::from_value::<T>(item.clone())
            .err()
            .map(|e| Error::invalid(path, place(i, item), e.to_string()))
    })
}

/// The text of the file at `path`, read whole: refused past
/// [`MAX_DOCUMENT_BYTES`](crate::text::MAX_DOCUMENT_BYTES) before it is read; a byte-order mark
/// skipped; compressed, UTF-16, binary and non-UTF-8 files refused with the line and the fix
/// ([`crate::text::read_document`]). An error names the file.
pub fn read_text(path: &Path) -> Result<String> {
    crate::text::read_document(path, crate::text::MAX_DOCUMENT_BYTES)
}

pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| Error::io(path, e))
}

/// The farthest a taxel may sit from its link's origin, metres. A robot link is a few metres at
/// most; a position beyond this is a unit mistake (millimetres read as metres) or garbage, and
/// would overflow the geometry downstream.
pub const MAX_POSITION_M: f64 = 100.0;

/// At most this many characters of a bad field are quoted in an error message.
const QUOTE_CHARS: usize = 40;

/// A bad field as an error message quotes it: whole if short, else its first characters and the
/// length (a 10 MB line is never echoed).
pub fn excerpt(field: &str) -> String {
    if field.chars().count() <= QUOTE_CHARS {
        return field.to_owned();
    }
    let head: String = field.chars().take(QUOTE_CHARS).collect();
    format!("{head}... ({} bytes)", field.len())
}

/// Builds a taxel after checking that its numbers are finite, its position within
/// [`MAX_POSITION_M`] of the origin and its normal not zero.
pub(crate) fn make_taxel(path: &Path, place: &str, id: TaxelId, x: [f64; 3], n: [f64; 3]) -> Result<Taxel> {
    if x.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(
            path,
            place,
            format!("position {x:?} is not finite"),
        ));
    }
    if x.iter().any(|v| v.abs() > MAX_POSITION_M) {
        return Err(Error::invalid(
            path,
            place,
            format!(
                "position {x:?} m is more than {MAX_POSITION_M} m from the link's origin (positions are in metres)"
            ),
        ));
    }
    if n.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid(path, place, format!("normal {n:?} is not finite")));
    }
    // Some files store normals that are not unit length: normalise them, but a zero normal
    // carries no direction and cannot be repaired. Scaling by the largest component first keeps
    // the length finite for components near f64::MAX and above zero for subnormal ones.
    let largest = n.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let normal = (largest > 0.0)
        .then(|| Unit::try_new(Vector3::from(n) / largest, 0.5))
        .flatten()
        .ok_or_else(|| Error::invalid(path, place, "normal has zero length"))?;
    Ok(Taxel {
        id,
        position: Point3::from(x),
        normal,
    })
}

/// Checks that ids are unique and faces index existing, distinct taxels.
pub(crate) fn check_link(path: &Path, link: &LinkSkin) -> Result<()> {
    let mut seen: HashMap<TaxelId, usize> = HashMap::with_capacity(link.taxels.len());
    for (i, t) in link.taxels.iter().enumerate() {
        if let Some(first) = seen.insert(t.id, i) {
            return Err(Error::invalid(
                path,
                format!("link \"{}\" taxel {} (index {i})", link.name, t.id),
                format!("id already used by the taxel at index {first}"),
            ));
        }
    }
    if let Some(m) = &link.frame_to_parent {
        // The frame places the link on the robot: its translation obeys the taxels' bound.
        let t = m.fixed_view::<3, 1>(0, 3);
        if m.iter().any(|v| !v.is_finite()) || t.iter().any(|v| v.abs() > MAX_POSITION_M) {
            return Err(Error::invalid(
                path,
                format!("link \"{}\" parent frame", link.name),
                format!(
                    "the 4x4 transform must be finite, its translation within {MAX_POSITION_M} m (metres)"
                ),
            ));
        }
    }
    if let Some(faces) = &link.faces {
        let n = link.taxels.len();
        for (f, face) in faces.iter().enumerate() {
            if let Some(&bad) = face.iter().find(|&&v| v >= n) {
                return Err(Error::invalid(
                    path,
                    format!("link \"{}\" face {f}", link.name),
                    format!("index {bad} is out of range (the link has {n} taxels)"),
                ));
            }
            if face[0] == face[1] || face[1] == face[2] || face[0] == face[2] {
                return Err(Error::invalid(
                    path,
                    format!("link \"{}\" face {f}", link.name),
                    format!("face {face:?} repeats a taxel"),
                ));
            }
        }
    }
    Ok(())
}

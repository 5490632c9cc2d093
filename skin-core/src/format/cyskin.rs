//! Cyskin calibration JSON: the `skin` section (taxels with id, position `x` and normal `n` in metres,
//! triangles `faces`, parent frame) and the `tactile_maps` section (a 2D point per taxel).
//!
//! ```json
//! { "info": { "file_version": "2", "type": "rigid_body", "name": "UR10_link2", ... },
//!   "skin": { "n_taxels": 642, "n_faces": 1232,
//!             "parent_frames": [ { "key": 0, "id": 0, "type": "", "name": "", "tf_matrix": [16 floats, column-major] } ],
//!             "taxels": [ { "id": 83931, "x": [x, y, z], "n": [nx, ny, nz], "type": "pressure", "cut": 0 }, ... ],
//!             "faces": [[i, j, k], ...] } }
//! ```

use super::{check_link, make_taxel, read_text, write_text};
use crate::{Error, LinkSkin, Result, TaxelId};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::collections::HashMap;
use std::path::Path;

#[derive(Deserialize)]
struct File {
    #[serde(default)]
    info: Option<Info>,
    skin: Skin,
}

#[derive(Deserialize)]
struct Info {
    #[serde(default)]
    name: String,
}

#[derive(Deserialize)]
struct Skin {
    n_taxels: Option<usize>,
    n_faces: Option<usize>,
    #[serde(default)]
    parent_frames: Vec<ParentFrame>,
    taxels: Vec<TaxelEntry>,
    #[serde(default)]
    faces: Option<Vec<[usize; 3]>>,
}

#[derive(Deserialize)]
struct ParentFrame {
    tf_matrix: [f64; 16],
}

#[derive(Deserialize)]
struct TaxelEntry {
    id: u32,
    x: [f64; 3],
    n: [f64; 3],
    #[serde(default = "pressure", rename = "type")]
    kind: String,
    #[serde(default)]
    cut: u8,
}

fn pressure() -> String {
    "pressure".into()
}

/// Reads the `skin` section of a Cyskin calibration file, with the notes of what was done to
/// read it (placeholder ids).
pub fn read_skin(path: &Path) -> Result<super::Noted<LinkSkin>> {
    parse_skin(&read_text(path)?, path)
}

/// Parses the `skin` section of Cyskin calibration JSON; `path` is used in error messages and
/// notes.
pub fn parse_skin(text: &str, path: &Path) -> Result<super::Noted<LinkSkin>> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
    from_value(value, path)
}

pub(crate) fn from_value(value: serde_json::Value, path: &Path) -> Result<super::Noted<LinkSkin>> {
    let file: File = match serde_json::from_value(value.clone()) {
        Ok(f) => f,
        Err(e) => {
            let taxels = value.get("skin").and_then(|s| s.get("taxels"));
            return Err(super::locate::<TaxelEntry>(path, taxels, |i, t| {
                let id = t.get("id").map_or("?".to_owned(), |v| v.to_string());
                format!("taxel {id} (skin.taxels[{i}])")
            })
            .unwrap_or_else(|| Error::json(path, &e)));
        }
    };
    let skin = file.skin;
    check_counts(&skin, path)?;
    let repeated = repeated_ids(&skin.taxels, path)?;
    let taxels = taxels(&skin.taxels, &repeated, path)?;
    let frame_to_parent = parent_frame(&skin.parent_frames, path)?;
    let link = LinkSkin {
        name: file.info.map(|i| i.name).unwrap_or_default(),
        taxels,
        faces: skin.faces,
        frame_to_parent,
    };
    check_link(path, &link)?;
    let notes = repeated
        .into_iter()
        .map(|(id, taxels)| super::Note::PlaceholderIds {
            path: path.to_owned(),
            id: TaxelId(id),
            taxels,
        })
        .collect();
    Ok(super::Noted { value: link, notes })
}

/// The counts the file states (`n_taxels`, `n_faces`) against its lists: a file whose count
/// disagrees was cut or edited by hand, and which of the two is right cannot be told.
fn check_counts(skin: &Skin, path: &Path) -> Result<()> {
    if let Some(n) = skin.n_taxels
        && n != skin.taxels.len()
    {
        return Err(Error::invalid(
            path,
            "field \"skin.n_taxels\"",
            format!("says {n} taxels but the list has {}", skin.taxels.len()),
        ));
    }
    if let (Some(n), Some(faces)) = (skin.n_faces, &skin.faces)
        && n != faces.len()
    {
        return Err(Error::invalid(
            path,
            "field \"skin.n_faces\"",
            format!("says {n} faces but the list has {}", faces.len()),
        ));
    }
    Ok(())
}

/// The ids the file gives to more than one taxel, with how many, in id order.
///
/// An id the file repeats tells no sensor apart: real Cyskin files give it (0, or 1) to mesh
/// vertices without a known sensor. Each such taxel gets a placeholder id of its own, and
/// placeholder ids are 16-bit.
fn repeated_ids(entries: &[TaxelEntry], path: &Path) -> Result<Vec<(u32, usize)>> {
    let mut count: HashMap<u32, usize> = HashMap::new();
    for t in entries {
        *count.entry(t.id).or_default() += 1;
    }
    let mut repeated: Vec<(u32, usize)> = count.into_iter().filter(|&(_, n)| n > 1).collect();
    repeated.sort_unstable();
    let placeholders: usize = repeated.iter().map(|&(_, n)| n).sum();
    if placeholders > usize::from(u16::MAX) {
        return Err(Error::invalid(
            path,
            "field \"skin.taxels\"",
            format!("{placeholders} taxels share ids with others: too many for placeholder ids"),
        ));
    }
    Ok(repeated)
}

/// The file's taxels, those with a `repeated` id under placeholder ids numbered in file order;
/// cut taxels and other kinds than pressure are refused.
fn taxels(entries: &[TaxelEntry], repeated: &[(u32, usize)], path: &Path) -> Result<Vec<crate::Taxel>> {
    let mut next_placeholder = 0u16;
    let mut taxels = Vec::with_capacity(entries.len());
    for (i, t) in entries.iter().enumerate() {
        let id = if repeated.iter().any(|&(id, _)| id == t.id) {
            next_placeholder += 1;
            TaxelId::placeholder(next_placeholder - 1)
        } else {
            TaxelId(t.id)
        };
        let place = format!("taxel {} (skin.taxels[{i}])", t.id);
        if t.cut != 0 {
            return Err(Error::invalid(
                path,
                place,
                "taxel is marked cut; cut taxels are not supported",
            ));
        }
        if t.kind != "pressure" {
            return Err(Error::invalid(
                path,
                place,
                format!("taxel type \"{}\" is not supported (only \"pressure\")", t.kind),
            ));
        }
        taxels.push(make_taxel(path, &place, id, t.x, t.n)?);
    }
    Ok(taxels)
}

/// The first parent frame's transform (column-major in the file), which must be finite.
fn parent_frame(frames: &[ParentFrame], path: &Path) -> Result<Option<nalgebra::Matrix4<f64>>> {
    let frame_to_parent = frames
        .first()
        .map(|f| nalgebra::Matrix4::from_column_slice(&f.tf_matrix));
    if let Some(m) = &frame_to_parent
        && m.iter().any(|v| !v.is_finite())
    {
        return Err(Error::invalid(
            path,
            "field \"skin.parent_frames[0].tf_matrix\"",
            "not finite",
        ));
    }
    Ok(frame_to_parent)
}

/// Serialises a link as a Cyskin calibration file (`info` + `skin`).
pub fn skin_to_string(link: &LinkSkin) -> String {
    let tf: Vec<f64> = link
        .frame_to_parent
        .unwrap_or_else(nalgebra::Matrix4::identity)
        .as_slice()
        .to_vec();
    let faces = link.faces.clone().unwrap_or_default();
    let value = json!({
        "info": { "file_version": "2", "type": "rigid_body", "name": link.name,
                  "application": "", "description": "" },
        "skin": {
            "n_taxels": link.taxels.len(),
            "n_faces": faces.len(),
            "parent_frames": [ { "key": 0, "id": 0, "type": "", "name": "", "tf_matrix": tf } ],
            "taxels": link.taxels.iter().map(|t| json!({
                "id": t.id.0,
                "x": [t.position.x, t.position.y, t.position.z],
                "n": [t.normal.x, t.normal.y, t.normal.z],
                "type": "pressure",
                "cut": 0,
            })).collect::<Vec<_>>(),
            "faces": faces,
        }
    });
    serde_json::to_string_pretty(&value).unwrap_or_default()
}

/// Writes a link as a Cyskin calibration file.
pub fn write_skin(path: &Path, link: &LinkSkin) -> Result<()> {
    write_text(path, &skin_to_string(link))
}

/// A 2D tactile map in Cyskin's `tactile_maps` form: one point per taxel (metres) and triangles
/// indexing that taxel list.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CyskinTactileMap {
    /// Name of the map.
    pub name: String,
    /// How it was made (`"lscm"`, `"isomap"`, ...).
    pub kind: String,
    /// Taxel ids, in the order of `points`.
    pub ids: Vec<TaxelId>,
    /// 2D position of each taxel on the map, metres.
    pub points: Vec<[f64; 2]>,
    /// Triangles indexing `ids`.
    pub faces: Vec<[usize; 3]>,
}

/// Serialises a tactile map as `{"tactile_maps": {"name", "type", "n_taxels", "n_faces", "taxels":
/// [{"id", "x": [u, v], "type", "cut"}], "faces"}}`, the form Cyskin tools read.
pub fn tactile_map_to_string(map: &CyskinTactileMap) -> String {
    let value = json!({
        "tactile_maps": {
            "key": 0,
            "name": map.name,
            "type": map.kind,
            "description": ["2D tactile map, least-squares conformal flattening, metres"],
            "n_taxels": map.ids.len(),
            "n_faces": map.faces.len(),
            "taxels": map.ids.iter().zip(&map.points).map(|(id, p)| json!({
                "id": id.0, "x": p, "type": "pressure", "cut": 0,
            })).collect::<Vec<_>>(),
            "faces": map.faces,
        }
    });
    serde_json::to_string_pretty(&value).unwrap_or_default()
}

#[derive(Deserialize)]
struct MapFile {
    tactile_maps: MapSection,
}

#[derive(Deserialize)]
struct MapSection {
    #[serde(default)]
    name: String,
    #[serde(rename = "type", default)]
    kind: String,
    taxels: Vec<MapTaxel>,
    faces: Vec<[usize; 3]>,
}

#[derive(Deserialize)]
struct MapTaxel {
    id: u32,
    x: [f64; 2],
}

/// Parses the `tactile_maps` section of a Cyskin file.
pub fn parse_tactile_map(text: &str, path: &Path) -> Result<CyskinTactileMap> {
    let file: MapFile = serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
    let m = file.tactile_maps;
    let n = m.taxels.len();
    for (i, t) in m.taxels.iter().enumerate() {
        if t.x.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid(
                path,
                format!("taxel {} (tactile_maps.taxels[{i}])", t.id),
                "map point is not finite",
            ));
        }
    }
    for (f, face) in m.faces.iter().enumerate() {
        if let Some(bad) = face.iter().find(|&&v| v >= n) {
            return Err(Error::invalid(
                path,
                format!("tactile_maps.faces[{f}]"),
                format!("index {bad} is out of range (the map has {n} taxels)"),
            ));
        }
    }
    Ok(CyskinTactileMap {
        name: m.name,
        kind: m.kind,
        ids: m.taxels.iter().map(|t| TaxelId(t.id)).collect(),
        points: m.taxels.iter().map(|t| t.x).collect(),
        faces: m.faces,
    })
}

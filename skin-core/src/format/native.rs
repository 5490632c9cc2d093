//! The project's own JSON layout, `skin-layout/1`.
//!
//! ```json
//! { "format": "skin-layout/1", "units": "m",
//!   "links": [ { "name": "forearm",
//!                "taxels": [ { "id": 16, "position": [x, y, z], "normal": [nx, ny, nz] }, ... ],
//!                "faces": [[0, 1, 2], ...] } ] }
//! ```
//! Positions are metres in the link frame; `faces` is optional and indexes the link's taxel list.

use super::{check_link, make_taxel, read_text, write_text};
use crate::{Error, LinkSkin, Result, SkinLayout, TaxelId};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format tag written in every layout file.
pub const FORMAT: &str = "skin-layout/1";

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LayoutFile {
    format: String,
    #[serde(default = "metres")]
    units: String,
    links: Vec<LinkFile>,
}

fn metres() -> String {
    "m".into()
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct LinkFile {
    name: String,
    taxels: Vec<TaxelFile>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    faces: Option<Vec<[usize; 3]>>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    frame_to_parent: Option<[f64; 16]>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TaxelFile {
    id: u32,
    position: [f64; 3],
    normal: [f64; 3],
}

/// Reads a layout file.
pub fn read_layout(path: &Path) -> Result<SkinLayout> {
    parse_layout(&read_text(path)?, path)
}

/// Parses layout JSON; `path` is only used in error messages.
pub fn parse_layout(text: &str, path: &Path) -> Result<SkinLayout> {
    let value: serde_json::Value = serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
    from_value(value, path)
}

pub(crate) fn from_value(value: serde_json::Value, path: &Path) -> Result<SkinLayout> {
    let file: LayoutFile = match serde_json::from_value(value.clone()) {
        Ok(f) => f,
        Err(e) => return Err(locate_in_layout(&value, path).unwrap_or_else(|| Error::json(path, &e))),
    };
    if file.format != FORMAT {
        return Err(Error::invalid(
            path,
            "field \"format\"",
            format!("expected \"{FORMAT}\", found \"{}\"", file.format),
        ));
    }
    if file.units != "m" {
        return Err(Error::invalid(
            path,
            "field \"units\"",
            format!("only metres (\"m\") are supported, found \"{}\"", file.units),
        ));
    }
    let mut links = Vec::with_capacity(file.links.len());
    for l in file.links {
        let mut taxels = Vec::with_capacity(l.taxels.len());
        for (i, t) in l.taxels.iter().enumerate() {
            let place = format!("link \"{}\" taxel {} (index {i})", l.name, t.id);
            taxels.push(make_taxel(path, &place, TaxelId(t.id), t.position, t.normal)?);
        }
        let link = LinkSkin {
            name: l.name,
            taxels,
            faces: l.faces,
            frame_to_parent: l
                .frame_to_parent
                .map(|m| nalgebra::Matrix4::from_column_slice(&m)),
        };
        check_link(path, &link)?;
        links.push(link);
    }
    Ok(SkinLayout { links })
}

/// The link or taxel at fault when a layout does not have the expected shape.
fn locate_in_layout(value: &serde_json::Value, path: &Path) -> Option<Error> {
    let links = value.get("links")?.as_array()?;
    links.iter().enumerate().find_map(|(l, link)| {
        let name = link
            .get("name")
            .and_then(|n| n.as_str())
            .unwrap_or("?")
            .to_owned();
        super::locate::<TaxelFile>(path, link.get("taxels"), |i, t| {
            let id = t.get("id").map_or("?".to_owned(), |v| v.to_string());
            format!("link \"{name}\" (links[{l}]) taxel {id} (index {i})")
        })
    })
}

/// Serialises a layout as pretty JSON.
pub fn to_string(layout: &SkinLayout) -> String {
    let file = LayoutFile {
        format: FORMAT.into(),
        units: "m".into(),
        links: layout
            .links
            .iter()
            .map(|l| LinkFile {
                name: l.name.clone(),
                taxels: l
                    .taxels
                    .iter()
                    .map(|t| TaxelFile {
                        id: t.id.0,
                        position: t.position.coords.into(),
                        normal: t.normal.into_inner().into(),
                    })
                    .collect(),
                faces: l.faces.clone(),
                frame_to_parent: l.frame_to_parent.map(|m| {
                    let mut a = [0.0; 16];
                    a.copy_from_slice(m.as_slice());
                    a
                }),
            })
            .collect(),
    };
    // Serialising plain structs of numbers and strings cannot fail.
    serde_json::to_string_pretty(&file).unwrap_or_default()
}

/// Writes a layout file.
pub fn write_layout(path: &Path, layout: &SkinLayout) -> Result<()> {
    write_text(path, &to_string(layout))
}

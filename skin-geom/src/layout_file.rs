//! Any layout file a user has, read by its extension and content: the project's JSON layout, a
//! Cyskin calibration, an iCub taxel file, or a mesh (OBJ, glTF) whose vertices are the taxels;
//! and a tactile map, or a layout flattened where a map is wanted. What a reader did to make a
//! real file usable comes back as [`Note`]s, for the caller to pass on.

use crate::{FlattenOptions, Result, TactileMap, load_mesh_file};
use skin_core::LinkSkin;
use skin_core::format::{self, Note, Noted};
use std::path::Path;

/// The file's extension, lower case ("" without one).
fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default()
}

fn is_mesh(path: &Path) -> bool {
    matches!(extension(path).as_str(), "obj" | "gltf" | "glb")
}

/// Every link of a layout file: all links of a project layout (`skin-layout/1`) or of a URDF's
/// tactile sensors (urdf_tactile), or the one link of a Cyskin calibration, an iCub taxel file
/// or a mesh (named after the file).
pub fn read_layout(path: &Path) -> Result<Noted<Vec<LinkSkin>>> {
    if extension(path) == "urdf" || !is_mesh(path) && format::read_text(path)?.contains("skin-layout/") {
        return Ok(format::load_links(path)?);
    }
    Ok(read_link(path)?.map(|link| vec![link]))
}

/// The link of a layout file (the first link of a project layout or a URDF): `.json` (project
/// layout or Cyskin calibration), `.txt` (iCub), `.urdf` (urdf_tactile sensors), or `.obj` /
/// `.gltf` / `.glb` (a mesh, named after the file).
pub fn read_link(path: &Path) -> Result<Noted<LinkSkin>> {
    if is_mesh(path) {
        let name = path.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
        return Ok(Noted::clean(load_mesh_file(path)?.into_link(name)?));
    }
    match extension(path).as_str() {
        "txt" | "ini" | "json" | "urdf" => Ok(format::load_link(path)?),
        _ => Err(skin_core::Error::invalid(
            path,
            "file name",
            "unknown layout format (expected .json, .txt, .urdf, .obj, .gltf or .glb)",
        )
        .into()),
    }
}

/// A tactile map file, or a layout file (any [`read_link`] reads) flattened with `options`
/// (noted as [`Note::Flattened`]: flattening every time costs what `skin flatten` costs once).
pub fn read_map(path: &Path, options: &FlattenOptions) -> Result<Noted<TactileMap>> {
    let text = format::read_text(path)?;
    if text.contains(crate::MAP_FORMAT) || text.contains("\"tactile_maps\"") {
        return Ok(Noted::clean(TactileMap::read(path)?));
    }
    let Noted {
        value: link,
        mut notes,
    } = read_link(path)?;
    let map = TactileMap::flatten(&link, options).map_err(|e| crate::Error::Layout {
        path: path.to_owned(),
        source: Box::new(e),
    })?;
    notes.push(Note::Flattened {
        path: path.to_owned(),
        extent_m: map.extent(),
        angle_error_deg: map.report.distortion.angle_error_mean_deg,
    });
    Ok(Noted { value: map, notes })
}

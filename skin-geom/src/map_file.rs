//! The project's tactile-map file, `skin-tactile-map/1` (and Cyskin's `tactile_maps`): written,
//! read and checked.

use crate::tactile_map::{FlattenReport, TactileMap};
use crate::{Error, Result};
use nalgebra::{Point2, Point3};
use skin_core::TaxelId;
use skin_core::format::{MAX_POSITION_M, excerpt};
use std::path::Path;

/// The project's own tactile-map file, `skin-tactile-map/1`.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    format: String,
    units: String,
    name: String,
    ids: Vec<TaxelId>,
    #[serde(default)]
    positions: Vec<[f64; 3]>,
    points: Vec<[f64; 2]>,
    faces: Vec<[usize; 3]>,
    #[serde(default)]
    report: FlattenReport,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    zeroed: Vec<TaxelId>,
}

/// Format tag of the project's tactile-map files.
pub const MAP_FORMAT: &str = "skin-tactile-map/1";

impl TactileMap {
    /// The map as the project's JSON (`skin-tactile-map/1`, metres).
    pub fn to_json(&self) -> String {
        let file = MapFile {
            format: MAP_FORMAT.into(),
            units: "m".into(),
            name: self.name.clone(),
            ids: self.ids.clone(),
            positions: self.positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
            points: self.points.iter().map(|p| [p.x, p.y]).collect(),
            faces: self.faces.clone(),
            report: self.report.clone(),
            zeroed: self.zeroed.iter().map(|&i| self.ids[i]).collect(),
        };
        serde_json::to_string_pretty(&file).unwrap_or_default()
    }

    /// Reads a map: the project's JSON or a Cyskin `tactile_maps` file.
    pub fn read(path: &Path) -> Result<TactileMap> {
        TactileMap::parse(&skin_core::format::read_text(path)?, path)
    }

    /// Parses a map (the project's JSON or a Cyskin `tactile_maps` file) and checks it: ids
    /// unique, points and positions finite and within [`MAX_POSITION_M`] metres, faces of three
    /// distinct taxels. `path` is used in error messages.
    pub fn parse(text: &str, path: &Path) -> Result<TactileMap> {
        if text.contains("\"tactile_maps\"") {
            return parse_cyskin(text, path);
        }
        let file: MapFile = serde_json::from_str(text).map_err(|e| skin_core::Error::json(path, &e))?;
        let bad = |place: String, msg: String| Error::Core(skin_core::Error::invalid(path, place, msg));
        file.check_header().map_err(|(place, msg)| bad(place, msg))?;
        let map = TactileMap {
            name: file.name,
            ids: file.ids,
            positions: file
                .positions
                .iter()
                .map(|p| Point3::new(p[0], p[1], p[2]))
                .collect(),
            points: file.points.iter().map(|p| Point2::new(p[0], p[1])).collect(),
            faces: file.faces,
            report: file.report,
            zeroed: Vec::new(),
        };
        map.check(
            |i| format!("taxel {} (index {i})", map.ids[i]),
            |f| format!("faces[{f}]"),
        )
        .map_err(|(place, msg)| bad(place, msg))?;
        let index: std::collections::HashMap<TaxelId, usize> =
            map.ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        let mut zeroed = Vec::with_capacity(file.zeroed.len());
        for id in &file.zeroed {
            match index.get(id) {
                Some(&i) => zeroed.push(i),
                None => {
                    return Err(bad(
                        "field \"zeroed\"".into(),
                        format!("taxel {id} is not among the map's ids"),
                    ));
                }
            }
        }
        zeroed.sort_unstable();
        zeroed.dedup();
        Ok(TactileMap { zeroed, ..map })
    }

    /// What a map read from a file must hold before anything sizes a grid or indexes by it; the
    /// error is (place, message), placed by `taxel(i)` and `face(f)`.
    fn check(
        &self,
        taxel: impl Fn(usize) -> String,
        face: impl Fn(usize) -> String,
    ) -> std::result::Result<(), (String, String)> {
        let mut seen = std::collections::HashMap::with_capacity(self.ids.len());
        for (i, id) in self.ids.iter().enumerate() {
            if let Some(first) = seen.insert(*id, i) {
                return Err((taxel(i), format!("id already used at index {first}")));
            }
        }
        let near = |v: f64| v.is_finite() && v.abs() <= MAX_POSITION_M;
        if let Some(i) = self.points.iter().position(|p| !(near(p.x) && near(p.y))) {
            return Err((
                taxel(i),
                format!(
                    "map point {:?} is not finite metres within {MAX_POSITION_M} m",
                    [self.points[i].x, self.points[i].y]
                ),
            ));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| !p.coords.iter().all(|&v| near(v)))
        {
            return Err((
                taxel(i),
                format!(
                    "position {:?} is not finite metres within {MAX_POSITION_M} m",
                    self.positions[i].coords.as_slice()
                ),
            ));
        }
        let n = self.ids.len();
        for (f, t) in self.faces.iter().enumerate() {
            if let Some(v) = t.iter().find(|&&v| v >= n) {
                return Err((face(f), format!("index {v} is out of range ({n} taxels)")));
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err((face(f), format!("face {t:?} repeats a taxel")));
            }
        }
        Ok(())
    }
}

/// A Cyskin `tactile_maps` file's map, checked.
fn parse_cyskin(text: &str, path: &Path) -> Result<TactileMap> {
    let m = skin_core::format::cyskin::parse_tactile_map(text, path)?;
    let map = TactileMap {
        name: m.name,
        ids: m.ids,
        positions: Vec::new(),
        points: m.points.iter().map(|p| Point2::new(p[0], p[1])).collect(),
        faces: m.faces,
        report: FlattenReport::default(),
        zeroed: Vec::new(),
    };
    map.check(
        |i| format!("taxel {} (tactile_maps.taxels[{i}])", map.ids[i]),
        |f| format!("tactile_maps.faces[{f}]"),
    )
    .map_err(|(place, msg)| Error::Core(skin_core::Error::invalid(path, place, msg)))?;
    Ok(map)
}

impl MapFile {
    /// The format tag, the units and the lengths of the lists; the error is (place, message).
    fn check_header(&self) -> std::result::Result<(), (String, String)> {
        if self.format != MAP_FORMAT {
            return Err((
                "field \"format\"".into(),
                format!("expected \"{MAP_FORMAT}\", found \"{}\"", excerpt(&self.format)),
            ));
        }
        if self.units != "m" {
            return Err((
                "field \"units\"".into(),
                format!("only metres are supported, found \"{}\"", excerpt(&self.units)),
            ));
        }
        let n = self.ids.len();
        if self.points.len() != n || (!self.positions.is_empty() && self.positions.len() != n) {
            return Err((
                "field \"points\"".into(),
                format!(
                    "{} ids but {} points and {} positions",
                    n,
                    self.points.len(),
                    self.positions.len()
                ),
            ));
        }
        Ok(())
    }
}

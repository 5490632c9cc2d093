//! Link poses over time (`skin-poses/1`), for stitching the maps of a chain of links.
//!
//! ```json
//! {
//!   "format": "skin-poses/1",
//!   "links": ["forearm", "wrist"],
//!   "postures": [
//!     {"name": "lower limit", "time_s": 0.0, "poses": [
//!       {"translation": [0.0, 0.0, 0.0], "rotation": [1.0, 0.0, 0.0, 0.0]},
//!       {"translation": [0.0, 0.376, 0.0], "rotation": [0.969, 0.0, -0.247, 0.0]}
//!     ]}
//!   ]
//! }
//! ```
//! One pose per link, in the order of `links`: the link frame in a common frame (translation in
//! metres, rotation a unit quaternion w, x, y, z). A posture holds from its `time_s` (seconds, the
//! recording's clock) until the next one's; postures are listed in time order.

use super::read_text;
use crate::{Error, Result};
use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};
use serde::Deserialize;
use std::path::Path;

/// The format tag.
pub const POSES_FORMAT: &str = "skin-poses/1";

/// One posture: every link's pose from a time on.
#[derive(Debug, Clone, PartialEq)]
pub struct Posture {
    /// A name for reports.
    pub name: String,
    /// When it starts, seconds.
    pub time_s: f64,
    /// One pose per link (link frame to the common frame).
    pub poses: Vec<Isometry3<f64>>,
}

/// Postures of a chain of links.
#[derive(Debug, Clone, PartialEq)]
pub struct Postures {
    /// Link names, in chain order.
    pub links: Vec<String>,
    /// In time order.
    pub postures: Vec<Posture>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePose {
    translation: [f64; 3],
    rotation: [f64; 4],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePosture {
    name: String,
    time_s: f64,
    poses: Vec<FilePose>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePostures {
    format: String,
    links: Vec<String>,
    postures: Vec<FilePosture>,
}

impl Postures {
    /// Reads a poses file.
    pub fn read(path: &Path) -> Result<Postures> {
        Self::parse(&read_text(path)?, path)
    }

    /// Parses a poses file; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Postures> {
        let file: FilePostures = serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
        if file.format != POSES_FORMAT {
            return Err(Error::invalid(
                path,
                "format",
                format!("\"{}\", expected \"{POSES_FORMAT}\"", file.format),
            ));
        }
        if file.postures.is_empty() {
            return Err(Error::invalid(path, "postures", "no posture"));
        }
        let mut postures = Vec::new();
        for (k, p) in file.postures.into_iter().enumerate() {
            let place = |what: &str| format!("postures[{k}] (\"{}\"){what}", p.name);
            if p.poses.len() != file.links.len() {
                return Err(Error::invalid(
                    path,
                    place(".poses"),
                    format!("{} poses for {} links", p.poses.len(), file.links.len()),
                ));
            }
            if !p.time_s.is_finite() || postures.last().is_some_and(|q: &Posture| p.time_s < q.time_s) {
                return Err(Error::invalid(
                    path,
                    place(".time_s"),
                    format!("{} is not a time after the previous posture's", p.time_s),
                ));
            }
            let mut poses = Vec::new();
            for (l, pose) in p.poses.iter().enumerate() {
                let [w, x, y, z] = pose.rotation;
                let q = Quaternion::new(w, x, y, z);
                let finite = pose
                    .translation
                    .iter()
                    .chain(&pose.rotation)
                    .all(|v| v.is_finite());
                let near = pose.translation.iter().all(|v| v.abs() <= super::MAX_POSITION_M);
                if !finite || !near || (q.norm() - 1.0).abs() > 1e-3 {
                    return Err(Error::invalid(
                        path,
                        place(&format!(".poses[{l}] ({})", file.links[l])),
                        format!(
                            "translation must be finite metres within {} m and rotation a unit quaternion [w, x, y, z]",
                            super::MAX_POSITION_M
                        ),
                    ));
                }
                let [tx, ty, tz] = pose.translation;
                poses.push(Isometry3::from_parts(
                    Translation3::new(tx, ty, tz),
                    UnitQuaternion::from_quaternion(q),
                ));
            }
            postures.push(Posture {
                name: p.name.clone(),
                time_s: p.time_s,
                poses,
            });
        }
        Ok(Postures {
            links: file.links,
            postures,
        })
    }

    /// The posture in effect at time `t` (the last one starting at or before it; the first one
    /// before all of them).
    pub fn at(&self, t: f64) -> usize {
        self.postures.iter().rposition(|p| p.time_s <= t).unwrap_or(0)
    }
}

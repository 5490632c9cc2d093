//! A skin's force calibration (`skin-force/1`): per link, the response curve and each taxel's
//! gain, as `skin calibrate-force` fits them (see [`crate::force`]).
//!
//! ```json
//! {
//!   "format": "skin-force/1",
//!   "links": [{
//!     "name": "forearm",
//!     "curve": {"full_scale": 4095.0, "half_scale_kpa": 150.0},
//!     "ids": [16, 17, 18],
//!     "gains": [1.02, 0.97, 1.0],
//!     "fit": {"r_squared": 0.998}
//!   }]
//! }
//! ```
//!
//! `ids` and `gains` are in the layout's taxel order: a calibration belongs to one layout, and
//! a layout whose taxels differ (other ids, another order, more or fewer) is refused by name
//! rather than given gains fitted to other taxels. `fit` is the fit's report, kept for the
//! reader; nothing reads it back. The areas the gains go with are not stored: they come from the
//! layout's mesh, as when the calibration was fitted.

use super::read_text;
use crate::force::{ForceModel, ResponseCurve};
use crate::{Error, LinkSkin, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format tag.
pub const FORCE_FORMAT: &str = "skin-force/1";

/// One link's calibration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkForce {
    /// The link's name in the layout.
    pub name: String,
    /// The shared response curve.
    pub curve: ResponseCurve,
    /// The link's taxel ids, layout order.
    pub ids: Vec<u32>,
    /// Each taxel's gain, layout order.
    pub gains: Vec<f64>,
    /// How the fit came out (for the reader).
    #[serde(default, skip_serializing_if = "serde_json::Value::is_null")]
    pub fit: serde_json::Value,
}

/// A skin's force calibration: some or all of its links.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForceCalibration {
    /// [`FORCE_FORMAT`].
    pub format: String,
    /// The calibrated links.
    pub links: Vec<LinkForce>,
}

impl ForceCalibration {
    /// A calibration of `links`.
    pub fn new(links: Vec<LinkForce>) -> ForceCalibration {
        ForceCalibration {
            format: FORCE_FORMAT.to_owned(),
            links,
        }
    }

    /// Reads a calibration file.
    pub fn read(path: &Path) -> Result<ForceCalibration> {
        Self::parse(&read_text(path)?, path)
    }

    /// Parses a calibration; `path` names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<ForceCalibration> {
        let file: ForceCalibration = serde_json::from_str(text).map_err(|e| Error::json(path, &e))?;
        if file.format != FORCE_FORMAT {
            return Err(Error::invalid(
                path,
                "format",
                format!("\"{}\", expected \"{FORCE_FORMAT}\"", file.format),
            ));
        }
        for (k, l) in file.links.iter().enumerate() {
            let place = |what: &str| format!("links[{k}] (\"{}\").{what}", l.name);
            if l.gains.len() != l.ids.len() {
                return Err(Error::invalid(
                    path,
                    place("gains"),
                    format!("{} gains for {} ids", l.gains.len(), l.ids.len()),
                ));
            }
            if file.links[..k].iter().any(|m| m.name == l.name) {
                return Err(Error::invalid(
                    path,
                    place("name"),
                    "a second calibration of the link",
                ));
            }
        }
        Ok(file)
    }

    /// The calibration as JSON text.
    pub fn to_json(&self) -> String {
        // Plain numbers, strings and arrays: serializing does not fail.
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// The calibration of the link named `name`, if there is one.
    pub fn link(&self, name: &str) -> Option<&LinkForce> {
        self.links.iter().find(|l| l.name == name)
    }

    /// Puts `entry` in: it replaces the entry of the link of its name, or is added after the
    /// others (a skin is calibrated a link at a time; the other links' entries stay).
    pub fn set_link(&mut self, entry: LinkForce) {
        match self.links.iter_mut().find(|l| l.name == entry.name) {
            Some(l) => *l = entry,
            None => self.links.push(entry),
        }
    }
}

impl LinkForce {
    /// The force model of `link` (its taxels must be this calibration's, in its order) with the
    /// areas of its mesh (m², layout order); `path` names the calibration in errors.
    pub fn model(&self, link: &LinkSkin, areas: Vec<f64>, path: &Path) -> Result<ForceModel> {
        let place = |what: &str| format!("link \"{}\" {what}", self.name);
        if self.ids.len() != link.taxels.len() {
            return Err(Error::invalid(
                path,
                place("ids"),
                format!(
                    "{} taxels calibrated, the layout's link has {}: this calibration is of another layout; calibrate this one (skin calibrate-force)",
                    self.ids.len(),
                    link.taxels.len()
                ),
            ));
        }
        if let Some((i, (id, t))) = self
            .ids
            .iter()
            .zip(&link.taxels)
            .enumerate()
            .find(|(_, (id, t))| **id != t.id.0)
        {
            return Err(Error::invalid(
                path,
                place(&format!("ids[{i}]")),
                format!(
                    "taxel {id}, where the layout has taxel {}: this calibration is of another layout (or another order); calibrate this one (skin calibrate-force)",
                    t.id.0
                ),
            ));
        }
        ForceModel::new(self.curve, self.gains.clone(), areas).map_err(|source| Error::Force {
            path: path.to_owned(),
            place: place("model"),
            source: Box::new(source),
        })
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;
    use crate::{Taxel, TaxelId};
    use nalgebra::{Point3, Unit, Vector3};

    fn link(ids: &[u32]) -> LinkSkin {
        let taxels = ids
            .iter()
            .map(|&id| Taxel {
                id: TaxelId(id),
                position: Point3::origin(),
                normal: Unit::new_normalize(Vector3::z()),
            })
            .collect();
        LinkSkin::new("forearm", taxels)
    }

    fn calibration() -> ForceCalibration {
        ForceCalibration::new(vec![LinkForce {
            name: "forearm".into(),
            curve: ResponseCurve {
                full_scale: 4095.0,
                half_scale_kpa: 150.0,
            },
            ids: vec![16, 17],
            gains: vec![1.1, 0.9],
            fit: serde_json::json!({"r_squared": 0.99}),
        }])
    }

    #[test]
    fn a_calibration_round_trips_and_builds_its_layouts_model() {
        let c = calibration();
        let back = ForceCalibration::parse(&c.to_json(), "f.json".as_ref()).unwrap();
        assert_eq!(back, c);
        let model = back
            .link("forearm")
            .unwrap()
            .model(&link(&[16, 17]), vec![1e-5; 2], "f.json".as_ref())
            .unwrap();
        assert_eq!(model.gains(), &[1.1, 0.9]);
        assert!(back.link("wrist").is_none());
    }

    #[test]
    fn another_layout_or_a_bad_file_is_refused_by_name() {
        let c = calibration();
        let f = c.link("forearm").unwrap();
        let e = f
            .model(&link(&[16, 18]), vec![1e-5; 2], "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("f.json") && e.contains("ids[1]") && e.contains("taxel 17") && e.contains("18"),
            "{e}"
        );
        let e = f
            .model(&link(&[16]), vec![1e-5], "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("2 taxels calibrated") && e.contains("has 1"), "{e}");
        let e = f
            .model(&link(&[16, 17]), vec![1e-5, f64::NAN], "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("taxel 1 (layout index)'s area is NaN"), "{e}");
        let text = c.to_json().replace("skin-force/1", "skin-force/9");
        let e = ForceCalibration::parse(&text, "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("format") && e.contains("skin-force/1"), "{e}");
        let text = c.to_json().replace("0.9\n", "0.9, 1.0\n");
        let e = ForceCalibration::parse(&text, "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("3 gains for 2 ids"), "{e}");
        let mut two = c.clone();
        two.links.push(two.links[0].clone());
        let e = ForceCalibration::parse(&two.to_json(), "f.json".as_ref())
            .unwrap_err()
            .to_string();
        assert!(e.contains("links[1]") && e.contains("second calibration"), "{e}");
    }
}

//! What a session's skin is, for a reader that was not there when it was built: every link's
//! taxels (ids, positions, normals, areas, modules), the unit its readings are in, the force
//! calibration they come from and the touch threshold. skin-ros publishes it as
//! `skin_msgs/TactileLayout`; the per-frame readings it describes are
//! [`super::ProcessedFrame::readings`].

use super::Session;

/// The unit of a link's readings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Units {
    /// Sensor counts above the baseline.
    Counts,
    /// Newtons: each taxel's share of the force of the contact it is in (0 outside contacts,
    /// where the noise is no load), from the link's force calibration.
    Newtons,
}

impl Units {
    /// `"counts"` or `"N"`, as messages write it.
    pub fn name(self) -> &'static str {
        match self {
            Units::Counts => "counts",
            Units::Newtons => "N",
        }
    }
}

/// One link's skin, described.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkDescription {
    /// The link's name in the layout.
    pub name: String,
    /// Taxel ids, layout order.
    pub ids: Vec<u32>,
    /// Positions, m, link frame.
    pub positions: Vec<[f64; 3]>,
    /// Outward unit normals, link frame.
    pub normals: Vec<[f64; 3]>,
    /// Skin area each taxel stands for, m² (a third of the area of its map's triangles around
    /// it); zero where the map has no triangle at a taxel.
    pub areas_m2: Vec<f64>,
    /// The module each taxel is on (a Cyskin id's high bits, `id >> 4`).
    pub modules: Vec<u32>,
    /// The unit of the link's readings.
    pub units: Units,
    /// The force calibration behind newtons (its file and the link's digest), empty in counts.
    pub calibration_id: String,
    /// Taxels without a reading (layout indices, increasing).
    pub dead: Vec<usize>,
}

/// A session's skin, described ([`Session::describe`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Description {
    /// Every link, layout order.
    pub links: Vec<LinkDescription>,
    /// The readings come from a simulated skin (a configuration with `[sim]`).
    pub simulated: bool,
    /// What the skin was read from: the configuration file ("frames" for a session built in code).
    pub source: String,
    /// Counts above the baseline that make a touch.
    pub touch_threshold_counts: f32,
}

impl Session {
    /// The skin this session reads, described: what `skin_msgs/TactileLayout` carries.
    pub fn describe(&self) -> Description {
        let links = self
            .setup
            .links
            .iter()
            .enumerate()
            .map(|(l, link)| {
                let force = self.pipeline.force_model(l);
                let areas_m2 = match (force, self.pipeline.map(l)) {
                    (Some((model, _)), _) => model.areas().to_vec(),
                    (None, Some(map)) => skin_core::force::taxel_areas(&map.positions, &map.faces)
                        .unwrap_or_else(|_| vec![0.0; link.taxels.len()]),
                    (None, None) => vec![0.0; link.taxels.len()],
                };
                LinkDescription {
                    name: link.name.clone(),
                    ids: link.taxels.iter().map(|t| t.id.0).collect(),
                    positions: link.taxels.iter().map(|t| t.position.coords.into()).collect(),
                    normals: link.taxels.iter().map(|t| t.normal.into_inner().into()).collect(),
                    areas_m2,
                    modules: link.taxels.iter().map(|t| t.id.module()).collect(),
                    units: if force.is_some() {
                        Units::Newtons
                    } else {
                        Units::Counts
                    },
                    calibration_id: self.setup.calibration_ids.get(l).cloned().unwrap_or_default(),
                    dead: self.pipeline.dead(l).to_vec(),
                }
            })
            .collect();
        Description {
            links,
            simulated: self.setup.simulated,
            source: self.setup.source.display().to_string(),
            touch_threshold_counts: self.pipeline.options().threshold,
        }
    }

    /// Marks the skin as simulated (or not) in its [`Description`]; a session from a
    /// configuration with `[sim]` is.
    pub fn set_simulated(&mut self, simulated: bool) {
        self.setup.simulated = simulated;
    }
}

/// A link's readings in one frame ([`super::ProcessedFrame::readings`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Readings<'a> {
    /// Counts above the baseline, one per taxel (layout order).
    Counts(&'a [f32]),
    /// Newtons per taxel (layout order), zero outside contacts.
    Newtons(&'a [f64]),
}

impl Readings<'_> {
    /// Their unit.
    pub fn units(&self) -> Units {
        match self {
            Readings::Counts(_) => Units::Counts,
            Readings::Newtons(_) => Units::Newtons,
        }
    }
}

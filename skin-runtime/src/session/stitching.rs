//! Links stitched across joints (thesis Ch. 6) in a session: the chain stitched once per posture
//! of a poses file ([`PostureChain`]), contacts searched over the whole chain at the posture of
//! each frame, and the stitched tactile image.

use super::ConfigError;
use skin_core::format::poses::Postures;
use skin_core::image::ImageView;
use skin_geom::{DeadTaxels, PostureChain, StitchOptions, TactileMap};
use std::path::Path;

/// A contact that spans links, in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Spanning {
    /// The links it covers, in chain order.
    pub links: Vec<usize>,
    /// Pressed taxels.
    pub taxels: usize,
    /// Pressure-weighted centroid, metres, in the common frame of the poses.
    pub centroid: [f64; 3],
}

/// The chain's stitching, solved once per posture.
#[derive(Debug)]
pub struct Stitching {
    chain: PostureChain,
    /// A contact spanned a joint in the last frame.
    pub(super) joined: bool,
}

impl Stitching {
    /// Stitches `maps` (chain order) at each posture of `postures`, whose links must be the
    /// maps' links in the same order; `source` names the poses in errors.
    pub fn new(maps: &[TactileMap], postures: Postures, source: &Path) -> Result<Stitching, ConfigError> {
        let names: Vec<&str> = maps.iter().map(|m| m.name.as_str()).collect();
        if postures.links != names {
            return Err(ConfigError::PoseLinks {
                poses: source.to_owned(),
                got: postures.links.clone(),
                layout: names.iter().map(|s| s.to_string()).collect(),
            });
        }
        if postures.postures.is_empty() {
            return Err(ConfigError::NoPosture {
                poses: source.to_owned(),
            });
        }
        let chain = PostureChain::new(maps.to_vec(), postures, StitchOptions::default(), 1.0)
            .and_then(PostureChain::with_contacts)
            .map_err(|e| match e {
                skin_geom::Error::Posture { posture, source: why } => ConfigError::Stitch {
                    poses: source.to_owned(),
                    posture,
                    source: *why,
                },
                e => ConfigError::Geom(e),
            })?;
        Ok(Stitching { chain, joined: false })
    }

    /// Declares the taxels of each link (indices, layout order) that have no readings: the chain
    /// is stitched again without them, so contacts and images bridge them.
    pub fn set_dead(&mut self, dead: &[Vec<usize>]) -> Result<(), skin_geom::Error> {
        let maps = self.chain.stitcher().maps();
        let dead = dead
            .iter()
            .zip(maps)
            .map(|(d, m)| DeadTaxels::new(d, m.ids.len()))
            .collect();
        self.chain.set_dead(dead)
    }

    /// The contacts of this frame (pressures per link, map order) that span links, at the
    /// posture of `time` (s); readings at or below `threshold` count as none.
    pub fn spanning(
        &mut self,
        pressures: &[Vec<f32>],
        threshold: f32,
        time: f64,
        min_taxels: usize,
    ) -> Result<Vec<Spanning>, skin_geom::Error> {
        self.chain.set_frame(time, pressures, threshold)?;
        let (contacts, index) = self.chain.contacts(min_taxels)?;
        Ok(contacts
            .iter()
            .filter(|c| index.spans(c))
            .map(|c| Spanning {
                links: index.links(c),
                taxels: c.taxels.len(),
                centroid: [c.centroid.x, c.centroid.y, c.centroid.z],
            })
            .collect())
    }

    /// Stitches the frames from now on at `poses` (one per link, chain order), the robot's
    /// posture live ([`PostureChain::set_live_posture`]).
    pub fn set_live_posture(&mut self, poses: &[nalgebra::Isometry3<f64>]) -> Result<bool, skin_geom::Error> {
        self.chain.set_live_posture(poses)
    }

    /// Back to the poses' postures (a new input): the live posture is forgotten.
    pub fn clear_live_posture(&mut self) {
        self.chain.clear_live_posture();
        self.joined = false;
    }

    /// Where each link's map lies in the stitched plane at the posture in effect at `time` (s),
    /// links in chain order (the layout's).
    pub fn placements_at(&self, time: f64) -> &[skin_geom::Placement] {
        self.chain.placements_at(time)
    }

    /// Each link's pose in the chain's common frame at `time` (s), chain order: the live posture
    /// once one is set, else the poses' posture then.
    pub fn poses_at(&self, time: f64) -> &[nalgebra::Isometry3<f64>] {
        self.chain.poses_at(time)
    }

    /// The stitched tactile image of the last frame (contact-max grey, 1 mm pixels).
    pub fn image(&mut self) -> Result<ImageView<'_, u8>, skin_geom::Error> {
        self.chain.image()
    }
}

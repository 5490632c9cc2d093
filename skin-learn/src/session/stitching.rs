//! Links stitched across joints (thesis Ch. 6) in a session: the maps stitched once per posture
//! of a poses file, contacts searched over the whole chain at the posture of each frame, and the
//! stitched tactile image.

use super::ConfigError as SessionError;
use skin_core::format::poses::Postures;
use skin_geom::raster::to_grey;
use skin_geom::{ChainContacts, Normalisation, StitchOptions, StitchedRasterizer, Stitcher, TactileMap};
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

/// One posture's placements of the maps and bridge triangles across the joints.
type Solved = (Vec<skin_geom::Placement>, Vec<[(usize, usize); 3]>);

/// The chain's stitching, solved once per posture.
pub struct Stitching {
    postures: Postures,
    placements: Vec<Solved>,
    /// Per posture: contact search over all links, joined by the bridges.
    finders: Vec<ChainContacts>,
    /// The posture of the last frame.
    current: usize,
    raster: StitchedRasterizer,
    placed: Option<usize>,
    image: Vec<f32>,
    grey: Vec<u8>,
    /// A contact spanned a joint in the last frame.
    pub(super) joined: bool,
}

impl std::fmt::Debug for Stitching {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Stitching")
            .field("links", &self.postures.links)
            .field("postures", &self.postures.postures.len())
            .finish_non_exhaustive()
    }
}

impl Stitching {
    /// Stitches `maps` (chain order) at each posture of `postures`, whose links must be the
    /// maps' links in the same order; `source` names the poses in errors.
    pub fn new(maps: &[TactileMap], postures: Postures, source: &Path) -> Result<Stitching, SessionError> {
        let names: Vec<&str> = maps.iter().map(|m| m.name.as_str()).collect();
        if postures.links != names {
            return Err(SessionError::PoseLinks {
                poses: source.to_owned(),
                got: postures.links.clone(),
                layout: names.iter().map(|s| s.to_string()).collect(),
            });
        }
        let at = |posture: &str| {
            let (poses, posture) = (source.to_owned(), posture.to_owned());
            move |source| SessionError::Stitch {
                poses,
                posture,
                source,
            }
        };
        let Some(reference) = postures.postures.get(postures.postures.len() / 2) else {
            return Err(SessionError::NoPosture {
                poses: source.to_owned(),
            });
        };
        let mut stitcher = Stitcher::new(maps.to_vec(), &reference.poses, StitchOptions::default())
            .map_err(at(&reference.name))?;
        let mut placements = Vec::new();
        let mut finders = Vec::new();
        for p in &postures.postures {
            let report = stitcher.reset(&p.poses).map_err(at(&p.name))?;
            finders.push(ChainContacts::new(maps, &p.poses, &report.bridges).map_err(at(&p.name))?);
            placements.push((report.placements, report.bridges));
        }
        Ok(Stitching {
            raster: StitchedRasterizer::new(maps, 1.0)?,
            postures,
            placements,
            finders,
            current: 0,
            placed: None,
            image: Vec::new(),
            grey: Vec::new(),
            joined: false,
        })
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
        self.current = self.postures.at(time);
        let (contacts, index) = self.finders[self.current].find(pressures, threshold, min_taxels)?;
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

    /// The stitched tactile image of the last frame (contact-max grey, 1 mm pixels), and its
    /// size (rows, cols).
    pub fn image(&mut self) -> Result<(&[u8], (usize, usize)), skin_geom::Error> {
        let k = self.current;
        if self.placed != Some(k) {
            let (placements, bridges) = &self.placements[k];
            self.raster.place(placements, bridges)?;
            self.placed = Some(k);
        }
        let views: Vec<&[f32]> = self.finders[k].link_frames().collect();
        self.raster.render(&views, &mut self.image)?;
        self.grey.resize(self.image.len(), 0);
        to_grey(&self.image, Normalisation::ContactMax, &mut self.grey);
        Ok((&self.grey, (self.raster.rows(), self.raster.cols())))
    }
}

//! `skin run` across joints: the links' maps stitched at each posture (thesis Ch. 6), contacts
//! found over the whole chain, and stitched tactile images.

use anyhow::{Context, Result, bail};
use skin_core::format::poses::Postures;
use skin_geom::raster::to_grey;
use skin_geom::{ChainContacts, Normalisation, StitchOptions, StitchedRasterizer, Stitcher, TactileMap};
use std::path::Path;

/// A contact that spans links, in one frame.
pub(crate) struct Spanning {
    /// The links it covers, in chain order.
    pub(crate) links: Vec<usize>,
    /// Pressed taxels.
    pub(crate) taxels: usize,
    /// Pressure-weighted centroid, metres, in the common frame of the poses.
    pub(crate) centroid: [f64; 3],
}

/// One posture's placements of the maps and bridge triangles across the joints.
type Solved = (Vec<skin_geom::Placement>, Vec<[(usize, usize); 3]>);

/// The chain's stitching, solved once per posture of the poses file.
pub(crate) struct Stitching {
    postures: Postures,
    placements: Vec<Solved>,
    /// Per posture: contact search over all links, joined by the bridges.
    finders: Vec<ChainContacts>,
    /// The posture of the loaded frame.
    current: usize,
    raster: StitchedRasterizer,
    placed: Option<usize>,
    image: Vec<f32>,
    grey: Vec<u8>,
    /// A contact spanned a joint in the last frame.
    pub(crate) joined: bool,
}

impl Stitching {
    /// Reads `poses` and stitches `maps` (chain order, as `layout` lists its links) at each of
    /// its postures.
    pub(crate) fn new(poses: &Path, layout: &Path, maps: &[TactileMap]) -> Result<Stitching> {
        let names: Vec<&str> = maps.iter().map(|m| m.name.as_str()).collect();
        let postures = crate::shared::read_postures(poses, layout, &names)?;
        let Some(reference) = postures.postures.get(postures.postures.len() / 2) else {
            bail!("{}: no posture", poses.display());
        };
        let mut stitcher = Stitcher::new(maps.to_vec(), &reference.poses, StitchOptions::default())
            .with_context(|| poses.display().to_string())?;
        let mut placements = Vec::new();
        let mut finders = Vec::new();
        for p in &postures.postures {
            let report = stitcher
                .reset(&p.poses)
                .with_context(|| format!("{}: posture \"{}\"", poses.display(), p.name))?;
            finders.push(
                ChainContacts::new(maps, &p.poses, &report.bridges)
                    .with_context(|| format!("{}: posture \"{}\"", poses.display(), p.name))?,
            );
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

    /// The contacts of this frame (pressures per link, map order) that span links; readings at
    /// or below `threshold` count as none.
    pub(crate) fn spanning(
        &mut self,
        pressures: &[Vec<f32>],
        threshold: f32,
        time: f64,
        min_taxels: usize,
    ) -> Result<Vec<Spanning>> {
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

    /// The stitched tactile image of the loaded frame (contact-max grey, 1 mm pixels), and its
    /// size.
    pub(crate) fn image(&mut self) -> Result<(&[u8], (usize, usize))> {
        let k = self.current;
        if self.placed != Some(k) {
            let (placements, bridges) = &self.placements[k];
            self.raster.place(placements, bridges)?;
            self.placed = Some(k);
        }
        let views: Vec<&[f32]> = self.finders[self.current].link_frames().collect();
        self.raster.render(&views, &mut self.image)?;
        self.grey.resize(self.image.len(), 0);
        to_grey(&self.image, Normalisation::ContactMax, &mut self.grey);
        Ok((&self.grey, (self.raster.rows(), self.raster.cols())))
    }
}

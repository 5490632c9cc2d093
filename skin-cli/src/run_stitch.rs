//! `skin run` across joints: the links' maps stitched at each posture (thesis Ch. 6), contacts
//! found over the whole chain, and stitched tactile images.

use anyhow::{Context, Result, bail};
use skin_core::ContactFinder;
use skin_core::format::poses::Postures;
use skin_geom::raster::to_grey;
use skin_geom::{Normalisation, StitchOptions, StitchedRasterizer, Stitcher, TactileMap};
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
    finders: Vec<ContactFinder>,
    /// First index of each link in the concatenated frame.
    offsets: Vec<usize>,
    raster: StitchedRasterizer,
    placed: Option<usize>,
    all: Vec<f32>,
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
        let postures = crate::stitch_cmd::read_postures(poses, layout, &names)?;
        let Some(reference) = postures.postures.get(postures.postures.len() / 2) else {
            bail!("{}: no posture", poses.display());
        };
        let mut stitcher = Stitcher::new(maps.to_vec(), &reference.poses, StitchOptions::default())
            .with_context(|| poses.display().to_string())?;
        let mut offsets = Vec::with_capacity(maps.len());
        let mut n = 0;
        for m in maps {
            offsets.push(n);
            n += m.ids.len();
        }
        let mut placements = Vec::new();
        let mut finders = Vec::new();
        for p in &postures.postures {
            let report = stitcher
                .reset(&p.poses)
                .with_context(|| format!("{}: posture \"{}\"", poses.display(), p.name))?;
            let mut positions = Vec::with_capacity(n);
            let mut faces = Vec::new();
            for ((m, pose), &o) in maps.iter().zip(&p.poses).zip(&offsets) {
                positions.extend(m.positions.iter().map(|x| pose * x));
                faces.extend(m.faces.iter().map(|f| f.map(|i| o + i)));
            }
            faces.extend(report.bridges.iter().map(|b| b.map(|(l, i)| offsets[l] + i)));
            finders.push(ContactFinder::new(&positions, &[], &faces, poses)?);
            placements.push((report.placements, report.bridges));
        }
        Ok(Stitching {
            raster: StitchedRasterizer::new(maps, 1.0)?,
            postures,
            placements,
            finders,
            offsets,
            placed: None,
            all: vec![0.0; n],
            image: Vec::new(),
            grey: Vec::new(),
            joined: false,
        })
    }

    /// Takes this frame's pressures (per link, map order); readings at or below `threshold`
    /// count as none.
    pub(crate) fn load(&mut self, pressures: &[Vec<f32>], threshold: f32) {
        for (p, &o) in pressures.iter().zip(&self.offsets) {
            for (dst, &v) in self.all[o..o + p.len()].iter_mut().zip(p) {
                *dst = if v > threshold { v } else { 0.0 };
            }
        }
    }

    /// The contacts of the loaded frame that span links.
    pub(crate) fn spanning(&mut self, time: f64, min_taxels: usize) -> Result<Vec<Spanning>> {
        let k = self.postures.at(time);
        let offsets = &self.offsets;
        let link_of = |i: usize| offsets.partition_point(|&o| o <= i) - 1;
        let contacts = self.finders[k].find(&self.all, 0.0, min_taxels)?;
        Ok(contacts
            .iter()
            .filter_map(|c| {
                let (first, last) = (link_of(*c.taxels.first()?), link_of(*c.taxels.last()?));
                (first != last).then(|| Spanning {
                    links: (first..=last)
                        .filter(|&l| c.taxels.iter().any(|&i| link_of(i) == l))
                        .collect(),
                    taxels: c.taxels.len(),
                    centroid: [c.centroid.x, c.centroid.y, c.centroid.z],
                })
            })
            .collect())
    }

    /// The stitched tactile image of the loaded frame (contact-max grey, 1 mm pixels), and its
    /// size.
    pub(crate) fn image(&mut self, time: f64) -> Result<(&[u8], (usize, usize))> {
        let k = self.postures.at(time);
        if self.placed != Some(k) {
            let (placements, bridges) = &self.placements[k];
            self.raster.place(placements, bridges)?;
            self.placed = Some(k);
        }
        let ends: Vec<usize> = self.offsets[1..]
            .iter()
            .copied()
            .chain([self.all.len()])
            .collect();
        let views: Vec<&[f32]> = self
            .offsets
            .iter()
            .zip(&ends)
            .map(|(&a, &b)| &self.all[a..b])
            .collect();
        self.raster.render(&views, &mut self.image)?;
        self.grey.resize(self.image.len(), 0);
        to_grey(&self.image, Normalisation::ContactMax, &mut self.grey);
        Ok((&self.grey, (self.raster.rows(), self.raster.cols())))
    }
}

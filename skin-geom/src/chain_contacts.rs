//! Contacts over a chain of stitched links (thesis Ch. 6): the links' meshes placed by their
//! poses and joined by the bridge triangles across the joints ([`crate::StitchReport`]), searched
//! as one skin, so a hand across the elbow is one contact, not one per link.

use crate::{BridgeTriangle, Error, Result, TactileMap};
use nalgebra::{Isometry3, Point3};
use skin_core::{Contact, ContactFinder};
use std::path::Path;

/// The contact search of a chain at one posture, built once per posture.
#[derive(Debug, Clone)]
pub struct ChainContacts {
    finder: ContactFinder,
    index: ChainIndex,
    /// The frame over the whole chain, thresholded.
    all: Vec<f32>,
}

/// Which link each taxel of the chain's numbering belongs to (links in chain order, each link's
/// taxels in its map's order).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChainIndex {
    /// First index of each link; one more entry, the total.
    offsets: Vec<usize>,
}

impl ChainIndex {
    /// The (link, taxel index in the link) of a chain index.
    pub fn link_of(&self, chain_index: usize) -> (usize, usize) {
        let l = self
            .offsets
            .partition_point(|&o| o <= chain_index)
            .saturating_sub(1);
        (l, chain_index - self.offsets[l])
    }

    /// Whether a contact covers more than one link (its taxels are in ascending order).
    pub fn spans(&self, contact: &Contact) -> bool {
        match (contact.taxels.first(), contact.taxels.last()) {
            (Some(&a), Some(&b)) => self.link_of(a).0 != self.link_of(b).0,
            _ => false,
        }
    }

    /// The links a contact covers, in chain order.
    pub fn links(&self, contact: &Contact) -> Vec<usize> {
        let mut links: Vec<usize> = contact.taxels.iter().map(|&i| self.link_of(i).0).collect();
        links.dedup();
        links
    }
}

impl ChainContacts {
    /// The chain of `maps` (with their taxels' 3D positions) placed by `poses` (link frame to a
    /// common frame, one per map) and joined by `bridges` ((link, taxel) triples).
    pub fn new(
        maps: &[TactileMap],
        poses: &[Isometry3<f64>],
        bridges: &[BridgeTriangle],
    ) -> Result<ChainContacts> {
        if poses.len() != maps.len() {
            return Err(Error::Length {
                what: "poses for the chain's links",
                got: poses.len(),
                expected: maps.len(),
            });
        }
        let mut offsets = Vec::with_capacity(maps.len() + 1);
        let mut positions: Vec<Point3<f64>> = Vec::new();
        let mut faces = Vec::new();
        for (k, (m, pose)) in maps.iter().zip(poses).enumerate() {
            if m.positions.len() != m.ids.len() {
                return Err(Error::Chain(crate::ChainError::NoPositions {
                    index: k,
                    name: m.name.clone(),
                }));
            }
            let o = positions.len();
            offsets.push(o);
            positions.extend(m.positions.iter().map(|x| pose * x));
            faces.extend(m.faces.iter().map(|f| f.map(|i| o + i)));
        }
        offsets.push(positions.len());
        for b in bridges {
            if b.corners
                .iter()
                .any(|c| c.link >= maps.len() || c.taxel >= maps[c.link].ids.len())
            {
                return Err(Error::Chain(crate::ChainError::Bridge(*b)));
            }
            faces.push(b.corners.map(|c| offsets[c.link] + c.taxel));
        }
        let n = positions.len();
        Ok(ChainContacts {
            finder: ContactFinder::new(&positions, &[], &faces, Path::new("the stitched chain"))?,
            index: ChainIndex { offsets },
            all: vec![0.0; n],
        })
    }

    /// The contacts of one frame (one pressure slice per link, in map order); readings at or
    /// below `threshold` count as none, contacts of fewer than `min_taxels` are dropped. A
    /// contact's taxels index the chain, which the [`ChainIndex`] returned with them maps back to
    /// links; its centroid and normal are in the poses' common frame. Allocates nothing once warm.
    pub fn find(
        &mut self,
        pressures: &[impl AsRef<[f32]>],
        threshold: f32,
        min_taxels: usize,
    ) -> Result<(&[Contact], &ChainIndex)> {
        let offsets = &self.index.offsets;
        let links = offsets.len() - 1;
        if pressures.len() != links {
            return Err(Error::Length {
                what: "pressure slices for the chain's links",
                got: pressures.len(),
                expected: links,
            });
        }
        for (l, p) in pressures.iter().enumerate() {
            let (a, b) = (offsets[l], offsets[l + 1]);
            let p = p.as_ref();
            if p.len() != b - a {
                return Err(Error::Length {
                    what: "pressures of a link for its taxels",
                    got: p.len(),
                    expected: b - a,
                });
            }
            for (dst, &v) in self.all[a..b].iter_mut().zip(p) {
                *dst = if v > threshold { v } else { 0.0 };
            }
        }
        Ok((self.finder.find(&self.all, 0.0, min_taxels)?, &self.index))
    }

    /// The chain's numbering of taxels.
    pub fn index(&self) -> &ChainIndex {
        &self.index
    }

    /// The last frame over the whole chain, thresholded, one slice per link (for a stitched
    /// image of it).
    pub fn link_frames(&self) -> impl Iterator<Item = &[f32]> {
        self.index.offsets.windows(2).map(|w| &self.all[w[0]..w[1]])
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::FlattenOptions;
    use nalgebra::{Translation3, Unit, Vector3};
    use skin_core::{LinkSkin, Taxel, TaxelId};

    /// A flat 4 x 4 patch, 8 mm pitch; taxel r * 4 + c at column c, row r.
    fn patch(name: &str) -> TactileMap {
        let taxels = (0..16u32)
            .map(|i| Taxel {
                id: TaxelId(i),
                position: Point3::new(f64::from(i % 4) * 0.008, f64::from(i / 4) * 0.008, 0.0),
                normal: Unit::new_normalize(Vector3::z()),
            })
            .collect();
        TactileMap::flatten(&LinkSkin::new(name, taxels), &FlattenOptions::default()).unwrap()
    }

    #[test]
    fn a_press_across_the_joint_is_one_contact_over_both_links() {
        let maps = [patch("upper"), patch("fore")];
        // The second patch 8 mm past the first's last column: column 3 of one meets column 0 of
        // the other, bridged row by row.
        let poses = [Isometry3::identity(), Translation3::new(0.032, 0.0, 0.0).into()];
        let bridges: Vec<BridgeTriangle> = (0..3)
            .flat_map(|r| {
                [
                    [(0, r * 4 + 3), (1, r * 4), (0, r * 4 + 7)],
                    [(1, r * 4), (1, r * 4 + 4), (0, r * 4 + 7)],
                ]
            })
            .map(BridgeTriangle::new)
            .collect();
        // Pressed: link 0 columns 2-3 and link 1 columns 0-1 of rows 1-2.
        let mut p0 = vec![0.0f32; 16];
        let mut p1 = vec![0.0f32; 16];
        for r in 1..3 {
            p0[r * 4 + 2] = 50.0;
            p0[r * 4 + 3] = 80.0;
            p1[r * 4] = 80.0;
            p1[r * 4 + 1] = 50.0;
        }
        let mut joined = ChainContacts::new(&maps, &poses, &bridges).unwrap();
        let (found, index) = joined.find(&[&p0, &p1], 5.0, 2).unwrap();
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(index.spans(&found[0]));
        assert_eq!(index.links(&found[0]), [0, 1]);
        let found = found.to_vec();
        assert_eq!(found[0].taxels.len(), 8);
        // Symmetric pressures: the centroid is on the joint, 4 mm past column 3, between rows 1 and 2.
        assert!(
            (found[0].centroid - Point3::new(0.028, 0.012, 0.0)).norm() < 1e-9,
            "{}",
            found[0].centroid
        );
        assert_eq!(joined.index().link_of(16 + 5), (1, 5));
        // Without the bridges, two contacts.
        let mut apart = ChainContacts::new(&maps, &poses, &[]).unwrap();
        let (found, index) = apart.find(&[&p0, &p1], 5.0, 2).unwrap();
        assert!(found.len() == 2 && !found.iter().any(|c| index.spans(c)));
        // Frames that do not fit the chain are errors.
        assert!(joined.find(&[&p0], 5.0, 2).is_err());
        assert!(joined.find(&[&p0, &p1[..3]], 5.0, 2).is_err());
        assert!(ChainContacts::new(&maps, &poses, &[BridgeTriangle::new([(0, 0), (2, 0), (1, 1)])]).is_err());
    }
}

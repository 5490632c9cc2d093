//! From assembled frames (bus-map order) to readings per link in layout order, the order the
//! tactile maps and baselines of a skin use.
//!
//! Built once from the bus map and the layout's taxel ids: every column of an
//! [`AssembledFrame`] gets its (link, index), so a frame is placed with one pass and no lookup or
//! allocation. A module that did not answer in a frame follows a [`Missing`] policy; the frame
//! says so ([`AssembledFrame::missing`]), and [`LayoutFrames::place`] returns whether it was
//! complete, so the caller reports it. Layout taxels that no slot of the bus map carries are
//! listed ([`LayoutFrames::uncovered`]): they never get a reading.

use crate::{AssembledFrame, BusMap, Error, Result};
use skin_core::TaxelId;
use std::collections::HashMap;

/// What a taxel of a module that did not answer reads in a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Missing {
    /// Its last reading: a lost CAN frame does not look like a release (what `skin run` does).
    #[default]
    HoldLast,
    /// NaN: downstream a baseline reads it as no pressure and leaves the taxel's offset alone.
    NotANumber,
}

/// Where each column of the assembled frames of one bus map goes in a layout.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LayoutFrames {
    /// Per column of the assembled frame: (link, index in the link).
    slots: Vec<(usize, usize)>,
    /// Taxels of each link.
    sizes: Vec<usize>,
    uncovered: Vec<(usize, usize)>,
    missing: Missing,
}

impl LayoutFrames {
    /// The placement of `map`'s columns into links whose taxels have the ids `links[l]` (layout
    /// order). A taxel of the bus map that no link has is an error naming it: the map is for
    /// another skin.
    pub fn new(map: &BusMap, links: &[Vec<TaxelId>], missing: Missing) -> Result<LayoutFrames> {
        let mut where_is: HashMap<TaxelId, (usize, usize)> = HashMap::new();
        for (l, ids) in links.iter().enumerate() {
            for (i, id) in ids.iter().enumerate() {
                where_is.entry(*id).or_insert((l, i));
            }
        }
        let mut covered: Vec<Vec<bool>> = links.iter().map(|ids| vec![false; ids.len()]).collect();
        let mut slots = Vec::new();
        for id in map.taxel_ids() {
            let &(l, i) = where_is.get(&id).ok_or(Error::NotInLayout { taxel: id })?;
            covered[l][i] = true;
            slots.push((l, i));
        }
        let uncovered = covered
            .iter()
            .enumerate()
            .flat_map(|(l, c)| {
                c.iter()
                    .enumerate()
                    .filter(|(_, c)| !**c)
                    .map(move |(i, _)| (l, i))
            })
            .collect();
        Ok(LayoutFrames {
            slots,
            sizes: links.iter().map(Vec::len).collect(),
            uncovered,
            missing,
        })
    }

    /// Layout taxels (link, index) that no slot of the bus map carries.
    pub fn uncovered(&self) -> &[(usize, usize)] {
        &self.uncovered
    }

    /// Per column of the assembled frames (bus-map order: bus, module, slot): the (link, index
    /// in the link) it is placed at.
    pub fn slots(&self) -> &[(usize, usize)] {
        &self.slots
    }

    /// Taxels of each link.
    pub fn sizes(&self) -> &[usize] {
        &self.sizes
    }

    /// Buffers for [`Self::place`]: one zeroed reading per taxel of each link.
    pub fn buffers(&self) -> Vec<Vec<f32>> {
        self.sizes.iter().map(|&n| vec![0.0; n]).collect()
    }

    /// Writes the readings of `frame` into `raw` (one slice per link, layout order); a missing
    /// module's taxels follow the policy. Returns whether the frame was complete. A frame of
    /// another bus map, or buffers of other links, are an error and change nothing.
    pub fn place(&self, frame: &AssembledFrame, raw: &mut [Vec<f32>]) -> Result<bool> {
        if frame.values.len() != self.slots.len() {
            return Err(Error::Length {
                what: "values of the assembled frame for the bus map's taxels",
                got: frame.values.len(),
                expected: self.slots.len(),
            });
        }
        if raw.len() != self.sizes.len() || raw.iter().zip(&self.sizes).any(|(r, &n)| r.len() != n) {
            return Err(Error::Length {
                what: "reading buffers for the links (see LayoutFrames::buffers)",
                got: raw.len(),
                expected: self.sizes.len(),
            });
        }
        for (&(l, i), value) in self.slots.iter().zip(&frame.values) {
            match (value, self.missing) {
                (Some(v), _) => raw[l][i] = f32::from(*v),
                (None, Missing::HoldLast) => {}
                (None, Missing::NotANumber) => raw[l][i] = f32::NAN,
            }
        }
        Ok(frame.is_complete())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::ModuleRef;
    use std::path::Path;

    const MAP: &str = "format = \"skin16\"\n[[bus]]\ninterface = \"can0\"\n[[bus.module]]\naddress = 0\n\
        taxels = [16, 17, 18, -1, -1, -1, -1, -1, -1, -1, -1, -1]\n[[bus]]\ninterface = \"can1\"\n\
        [[bus.module]]\naddress = 0\ntaxels = [32, 33, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1]\n";

    fn frame(values: Vec<Option<u16>>, missing: Vec<ModuleRef>) -> AssembledFrame {
        AssembledFrame {
            cycle: 0,
            time_us: 0,
            values,
            missing,
            duplicated: Vec::new(),
        }
    }

    #[test]
    fn columns_land_in_layout_order_and_missing_modules_follow_the_policy() {
        let map = BusMap::parse(MAP, Path::new("m.toml")).unwrap();
        // Two links listing the taxels in another order than the bus map, one taxel uncovered.
        let links = vec![
            vec![TaxelId(33), TaxelId(17)],
            vec![TaxelId(18), TaxelId(99), TaxelId(16), TaxelId(32)],
        ];
        let frames = LayoutFrames::new(&map, &links, Missing::HoldLast).unwrap();
        assert_eq!(frames.uncovered(), [(1, 1)]);
        let mut raw = frames.buffers();
        let full = frame(vec![Some(1), Some(2), Some(3), Some(4), Some(5)], vec![]);
        assert!(frames.place(&full, &mut raw).unwrap());
        assert_eq!(raw, [vec![5.0, 2.0], vec![3.0, 0.0, 1.0, 4.0]]);
        // can1's module is lost: its taxels keep their last readings, and the frame says so.
        let lost = ModuleRef { bus: 1, address: 0 };
        let part = frame(vec![Some(10), Some(20), Some(30), None, None], vec![lost]);
        assert!(!frames.place(&part, &mut raw).unwrap());
        assert_eq!(raw, [vec![5.0, 20.0], vec![30.0, 0.0, 10.0, 4.0]]);
        let nan = LayoutFrames::new(&map, &links, Missing::NotANumber).unwrap();
        nan.place(&part, &mut raw).unwrap();
        assert!(raw[0][0].is_nan() && raw[1][3].is_nan() && raw[1][2] == 10.0);
        // Wrong sizes change nothing.
        let before = raw.clone();
        assert!(frames.place(&frame(vec![Some(1)], vec![]), &mut raw).is_err());
        assert!(frames.place(&full, &mut raw[..1]).is_err());
        assert_eq!(format!("{raw:?}"), format!("{before:?}"));
    }

    #[test]
    fn a_bus_map_of_another_skin_is_refused_naming_the_taxel() {
        let map = BusMap::parse(MAP, Path::new("m.toml")).unwrap();
        let e = LayoutFrames::new(
            &map,
            &[vec![TaxelId(16), TaxelId(17), TaxelId(18)]],
            Missing::HoldLast,
        )
        .unwrap_err();
        assert!(matches!(e, Error::NotInLayout { taxel: TaxelId(32) }), "{e}");
        assert!(e.to_string().contains("taxel 32"), "{e}");
    }
}

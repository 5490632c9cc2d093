//! The thesis' full arm, synthetic: three links of 1,165 taxels each (3,495), half-cylinder
//! covers of radius 80 mm on an 8 mm lattice, ids in Cyskin modules of 11, and a whole hand
//! from the generator held on the middle link. What the benches of the session, the ROS 2
//! publisher and the live view measure a full arm's cost on; a robot stack can time its own
//! loop on it the same way.
//!
//! ```
//! use skin_learn::synth::arm;
//!
//! let (session, idle, held) = arm::tracking_session()?;
//! assert_eq!(session.links().len(), 3);
//! assert_eq!(idle.iter().map(Vec::len).sum::<usize>(), 3 * arm::PER_LINK);
//! assert!(held[1].iter().any(|&p| p > arm::IDLE));
//! # Ok::<(), skin_learn::Error>(())
//! ```

use super::{Kind, SynthOptions, Synthesizer};
use crate::model::Models;
use crate::session::{Event, Flow, Session, SessionOptions, Sink};
use crate::touch::{TouchOptions, TouchPipeline};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::TactileMap;
use std::collections::HashMap;

/// One frame of the arm: each link's readings (or pressures), in layout order.
pub type Readings = Vec<Vec<f32>>;

/// Taxels per link.
pub const PER_LINK: usize = 1165;

/// Link `k` (`link0`, `link1`, ...; the arm has three, and ids stay distinct for `k` below
/// 2,000,000).
pub fn link(k: usize) -> LinkSkin {
    let (radius, pitch, around) = (0.08, 0.008, 31);
    let taxels = (0..PER_LINK)
        .map(|i| {
            let (row, col) = (i / around, i % around);
            let phi = (col as f64 + 0.5 * (row % 2) as f64) * pitch / radius - 1.2;
            let n = Vector3::new(phi.sin(), 0.0, phi.cos());
            let module = (k * 110 + i / 11 + 1) as u32;
            Taxel {
                id: TaxelId(module << 4 | (i % 11) as u32),
                position: Point3::new(radius * n.x, row as f64 * pitch * 0.866, radius * n.z),
                normal: Unit::new_normalize(n),
            }
        })
        .collect();
    LinkSkin::new(format!("link{k}"), taxels)
}

/// The three links and their tactile maps (flattened with the default options).
pub fn links_and_maps() -> skin_geom::Result<(Vec<LinkSkin>, Vec<TactileMap>)> {
    let links: Vec<LinkSkin> = (0..3).map(link).collect();
    let maps = links
        .iter()
        .map(|l| TactileMap::flatten(l, &skin_geom::FlattenOptions::default()))
        .collect::<skin_geom::Result<_>>()?;
    Ok((links, maps))
}

/// Why the arm's hand cannot be held on the links given.
#[derive(Debug, thiserror::Error)]
pub enum ArmError {
    /// The middle link, `links[1]` (and its map, `maps[1]`), is missing.
    #[error("the arm needs a middle link: {links} link(s) and {maps} map(s) given")]
    NoMiddleLink {
        /// Links given.
        links: usize,
        /// Maps given.
        maps: usize,
    },
    /// The generator drew no whole hand in `draws` samples on this map (a map too small for one).
    #[error("no whole hand in {draws} samples of the generator on the middle link's map")]
    NoHand {
        /// Samples drawn.
        draws: u32,
    },
    /// A taxel of the middle link's map is not on the middle link (another link's map).
    #[error("taxel {taxel} of the middle link's map is not on the middle link ({link})")]
    NotOnLink {
        /// The taxel's id.
        taxel: TaxelId,
        /// The middle link's name.
        link: String,
    },
    /// The map could not be imaged by the generator.
    #[error(transparent)]
    Geom(#[from] skin_geom::Error),
}

/// Each link's pressures (counts above the baseline, in layout order) with a whole hand from the
/// synthetic-data generator on the middle link (`links[1]`); `middle` is that link's tactile map.
pub fn hand_on_middle_link(links: &[LinkSkin], middle: &TactileMap) -> Result<Readings, ArmError> {
    let mut pressures: Vec<Vec<f32>> = links.iter().map(|l| vec![0.0; l.taxels.len()]).collect();
    let (Some(link), Some(on_link)) = (links.get(1), pressures.get_mut(1)) else {
        return Err(ArmError::NoMiddleLink {
            links: links.len(),
            maps: 1,
        });
    };
    let mut synth = Synthesizer::new(middle, SynthOptions::default())?;
    // The first whole hand the generator draws (one in a few samples is).
    const DRAWS: u32 = 1000;
    let hand = (0..DRAWS)
        .map(|i| synth.sample(3, i, i))
        .find(|s| matches!(s.kind, Kind::Hand(_)) && !s.partial)
        .ok_or(ArmError::NoHand { draws: DRAWS })?;
    let index: HashMap<TaxelId, usize> = link.taxels.iter().enumerate().map(|(i, t)| (t.id, i)).collect();
    for (id, p) in middle.ids.iter().zip(&hand.pressures) {
        let i = index.get(id).ok_or_else(|| ArmError::NotOnLink {
            taxel: *id,
            link: link.name.clone(),
        })?;
        on_link[*i] = *p;
    }
    Ok(pressures)
}

/// The raw reading of an untouched taxel, counts (the benches' idle skin).
pub const IDLE: f32 = 1000.0;

/// The arm's raw frames (layout order): untouched, every taxel at [`IDLE`]; and with the hand of
/// [`hand_on_middle_link`] held on the middle link.
pub fn idle_and_held(links: &[LinkSkin], maps: &[TactileMap]) -> Result<(Readings, Readings), ArmError> {
    let idle: Vec<Vec<f32>> = links.iter().map(|l| vec![IDLE; l.taxels.len()]).collect();
    let middle = maps.get(1).ok_or(ArmError::NoMiddleLink {
        links: links.len(),
        maps: maps.len(),
    })?;
    let held = hand_on_middle_link(links, middle)?
        .into_iter()
        .map(|p| p.into_iter().map(|x| IDLE + x).collect())
        .collect();
    Ok((idle, held))
}

/// A session over the arm that tracks touches (no model) with the fixture session's settings
/// (threshold 5 counts, 2 taxels, decided after 3 frames, released after 2), its baseline
/// learned from 20 idle frames 20 ms apart (the last at 0.38 s, cycle 19); and the idle and
/// hand-held frames.
pub fn tracking_session() -> crate::Result<(Session, Readings, Readings)> {
    let (links, maps) = links_and_maps()?;
    let (idle, held) = idle_and_held(&links, &maps)?;
    let options = TouchOptions {
        threshold: 5.0,
        min_taxels: 2,
        decide_frames: 3,
        release_frames: 2,
        ..TouchOptions::default()
    };
    let pipeline = TouchPipeline::new(maps, Models::none(), options)?;
    let mut session = Session::new(links, pipeline, SessionOptions::default())?;
    for k in 0..20u64 {
        // Discard never stops the session.
        let _: Flow = session.push(k * 20_000, k, &idle, &mut Discard)?;
    }
    Ok((session, idle, held))
}

/// A sink that keeps nothing: a robot stack acting on events, for benches of the session's own
/// cost.
#[derive(Debug, Clone, Copy, Default)]
pub struct Discard;

impl Sink for Discard {
    type Error = std::convert::Infallible;
    fn event(&mut self, _: &Event) -> Result<Flow, Self::Error> {
        Ok(std::ops::ControlFlow::Continue(()))
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_hand_needs_the_middle_link() {
        let (links, maps) = links_and_maps().unwrap();
        let e = hand_on_middle_link(&links[..1], &maps[0]).unwrap_err();
        assert!(matches!(e, ArmError::NoMiddleLink { links: 1, .. }), "{e}");
        let e = idle_and_held(&links, &maps[..1]).unwrap_err();
        assert!(matches!(e, ArmError::NoMiddleLink { maps: 1, .. }), "{e}");
        // The first link's map on the middle link: its taxels are not there.
        let e = hand_on_middle_link(&links, &maps[0]).unwrap_err();
        assert!(matches!(e, ArmError::NotOnLink { .. }), "{e}");
        let held = hand_on_middle_link(&links, &maps[1]).unwrap();
        assert!(held[1].iter().filter(|&&p| p > 0.0).count() > 50);
        assert!(held[0].iter().chain(&held[2]).all(|&p| p == 0.0));
    }
}

//! The thesis' full arm for benches: three links of 1,165 taxels each (3,495), half-cylinder
//! covers of radius 80 mm on an 8 mm lattice, ids in Cyskin modules of 11 (feature `full-arm`).

use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, Taxel, TaxelId};
use skin_geom::TactileMap;
use skin_learn::synth::{Kind, SynthOptions, Synthesizer};

/// Taxels per link.
pub const PER_LINK: usize = 1165;

/// Link `k` (`link0`, `link1`, ...).
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
pub fn links_and_maps() -> (Vec<LinkSkin>, Vec<TactileMap>) {
    let links: Vec<LinkSkin> = (0..3).map(link).collect();
    let maps = links
        .iter()
        .map(|l| TactileMap::flatten(l, &skin_geom::FlattenOptions::default()).unwrap())
        .collect();
    (links, maps)
}

/// Each link's pressures (counts above the baseline, in layout order) with a whole hand from the
/// synthetic-data generator on the middle link; `middle` is that link's tactile map.
pub fn hand_on_middle_link(links: &[LinkSkin], middle: &TactileMap) -> Vec<Vec<f32>> {
    let mut synth = Synthesizer::new(middle, SynthOptions::default()).unwrap();
    let hand = (0..)
        .map(|i| synth.sample(3, i, i))
        .find(|s| matches!(s.kind, Kind::Hand(_)) && !s.partial)
        .unwrap();
    let mut pressures: Vec<Vec<f32>> = links.iter().map(|l| vec![0.0; l.taxels.len()]).collect();
    let index: std::collections::HashMap<TaxelId, usize> = links[1]
        .taxels
        .iter()
        .enumerate()
        .map(|(i, t)| (t.id, i))
        .collect();
    for (id, p) in middle.ids.iter().zip(&hand.pressures) {
        pressures[1][index[id]] = *p;
    }
    pressures
}

/// The raw reading of an untouched taxel, counts (the benches' idle skin).
pub const IDLE: f32 = 1000.0;

/// The arm's raw frames (layout order): untouched, every taxel at [`IDLE`]; and with the hand of
/// [`hand_on_middle_link`] held on the middle link.
pub fn idle_and_held(links: &[LinkSkin], maps: &[TactileMap]) -> (Vec<Vec<f32>>, Vec<Vec<f32>>) {
    let idle: Vec<Vec<f32>> = links.iter().map(|l| vec![IDLE; l.taxels.len()]).collect();
    let held = hand_on_middle_link(links, &maps[1])
        .into_iter()
        .map(|p| p.into_iter().map(|x| IDLE + x).collect())
        .collect();
    (idle, held)
}

/// A session over the arm that tracks touches (no model) with the fixture session's settings
/// (threshold 5 counts, 2 taxels, decided after 3 frames, released after 2), its baseline
/// learned from 20 idle frames 20 ms apart (the last at 0.38 s, cycle 19); and the idle and
/// hand-held frames.
pub fn tracking_session() -> (skin_learn::session::Session, Vec<Vec<f32>>, Vec<Vec<f32>>) {
    use skin_learn::session::{Session, SessionOptions};
    use skin_learn::touch::{TouchOptions, TouchPipeline};
    let (links, maps) = links_and_maps();
    let (idle, held) = idle_and_held(&links, &maps);
    let options = TouchOptions {
        threshold: 5.0,
        min_taxels: 2,
        decide_frames: 3,
        release_frames: 2,
        ..TouchOptions::default()
    };
    let pipeline = TouchPipeline::new(maps, skin_learn::model::Models::none(), options).unwrap();
    let mut session = Session::new(links, pipeline, SessionOptions::default()).unwrap();
    for k in 0..20u64 {
        let _ = session.push(k * 20_000, k, &idle, &mut Discard).unwrap();
    }
    (session, idle, held)
}

/// A sink that keeps nothing: a robot stack acting on events, for benches of the session's own
/// cost.
#[derive(Debug, Clone, Copy, Default)]
pub struct Discard;

impl skin_learn::session::Sink for Discard {
    type Error = std::convert::Infallible;
    fn event(&mut self, _: &skin_learn::session::Event) -> Result<skin_learn::session::Flow, Self::Error> {
        Ok(std::ops::ControlFlow::Continue(()))
    }
}

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

//! What the page draws that does not change from frame to frame: every link's taxels where its
//! tactile map puts them, which taxels never read, the CAN modules (to mark a missing one's
//! taxels), the classes and the gate's actions. Sent once, as JSON, when a browser connects.

use serde::Serialize;
use skin_can::BusMap;
use skin_geom::TactileMap;
use skin_runtime::session::Session;
use std::collections::HashMap;

/// The gate's actions, in the order a frame's `gate` field counts them (1-based).
pub const GATE_ACTIONS: [&str; 4] = ["stop", "comply", "slow", "resume"];

/// The still part of what the page shows.
#[derive(Debug, Clone, Serialize)]
pub struct Scene {
    /// What is shown: the configuration a session was built from, or the file replayed.
    pub source: String,
    /// The links, in the order a frame carries their pressures.
    pub links: Vec<SceneLink>,
    /// The CAN modules (empty without a bus map).
    pub modules: Vec<SceneModule>,
    /// The classifier's class names, in output order (empty: tracking only).
    pub classes: Vec<String>,
    /// The class that is a human hand, if the model card names one.
    pub hand: Option<String>,
    /// The gate's action names (a frame's `gate` is 1 + an index into them).
    pub gate_actions: [&'static str; 4],
    /// Pressure above which a taxel counts as pressed, counts (the colour scale starts there).
    pub threshold: f32,
    /// Links stitched across joints: frames carry each link's placement in the stitched plane,
    /// and the page draws the stitched arm at the current posture.
    pub stitched: bool,
    /// Set for a replay: its length and every event of the file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub replay: Option<ReplayInfo>,
}

/// One link as the page draws it.
#[derive(Debug, Clone, Serialize)]
pub struct SceneLink {
    /// The link's name.
    pub name: String,
    /// Taxel ids, layout order.
    pub ids: Vec<u32>,
    /// Each taxel on the link's tactile map, mm (x right, y up), layout order.
    pub uv_mm: Vec<[f32; 2]>,
    /// Taxels that never read (on no bus, no column of a recording): layout indices.
    pub dead: Vec<usize>,
    /// Typical distance between neighbouring taxels on the map, mm (the median over taxels of
    /// each one's shortest triangle edge): the size each taxel is drawn at.
    pub pitch_mm: f32,
}

/// A CAN module and the taxels it carries.
#[derive(Debug, Clone, Serialize)]
pub struct SceneModule {
    /// Its bus (interface name).
    pub bus: String,
    /// Its address on the bus.
    pub address: u32,
    /// Its taxels, `[link, layout index]`.
    pub taxels: Vec<[u32; 2]>,
}

/// A replay's length and events.
#[derive(Debug, Clone, Serialize)]
pub struct ReplayInfo {
    /// From the first to the last frame, s.
    pub duration: f64,
    /// Every event of the file, each an events.jsonl line (parsed, so the scene stays JSON).
    pub events: Vec<serde_json::Value>,
    /// Events the file holds beyond those listed (a timeline keeps at most [`crate::MAX_TIMELINE`]).
    pub events_left_out: usize,
    /// The file's chunks (the pieces it is written in, each with its own CRC).
    pub chunks: usize,
    /// The parts of the file that cannot be trusted, in time order (empty for an intact file).
    pub damaged: Vec<Damage>,
}

/// A stretch of a replayed file that cannot be trusted: consecutive chunks whose bytes do not
/// match their CRC (shown, but what they show may be wrong), or whose records cannot be read at
/// all (left out of the replay).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Damage {
    /// Where the stretch starts, s from the session's start (as the file's index says).
    pub from: f64,
    /// Where it ends, s.
    pub to: f64,
    /// Its chunks, numbered from 1 in file order.
    pub chunks: Vec<usize>,
    /// Its frames are left out (their records cannot be read), rather than shown.
    pub left_out: bool,
}

impl Scene {
    /// The scene of `maps` (one per link, in frame order), `source` naming it on the page.
    pub fn from_maps(maps: &[TactileMap], source: &str) -> Scene {
        Scene {
            source: source.to_owned(),
            links: maps.iter().map(SceneLink::from_map).collect(),
            modules: Vec::new(),
            classes: Vec::new(),
            hand: None,
            gate_actions: GATE_ACTIONS,
            threshold: 0.0,
            stitched: false,
            replay: None,
        }
    }

    /// The scene of a session: its maps, dead taxels, bus map, classes and threshold.
    pub fn of_session(session: &Session, source: &str) -> Scene {
        let pipeline = session.pipeline();
        let maps: Vec<&TactileMap> = (0..session.links().len())
            .filter_map(|k| pipeline.map(k))
            .collect();
        let mut scene = Scene {
            source: source.to_owned(),
            links: maps.iter().map(|m| SceneLink::from_map(m)).collect(),
            modules: Vec::new(),
            classes: session.classes().iter().map(|c| c.name().to_owned()).collect(),
            hand: session.classes().hand().map(|c| c.name().to_owned()),
            gate_actions: GATE_ACTIONS,
            threshold: pipeline.options().threshold,
            stitched: session.stitched(),
            replay: None,
        };
        for (k, link) in scene.links.iter_mut().enumerate() {
            link.dead = pipeline.dead(k).to_vec();
        }
        if let Some(busmap) = session.busmap() {
            scene.set_modules(busmap);
        }
        scene
    }

    /// The modules of `busmap`, their taxels found in the scene's links by id (a slot whose id
    /// no link has is left out: the session reports such taxels itself).
    pub fn set_modules(&mut self, busmap: &BusMap) {
        let mut index: HashMap<u32, [u32; 2]> = HashMap::new();
        for (l, link) in self.links.iter().enumerate() {
            for (i, id) in link.ids.iter().enumerate() {
                index.insert(*id, [l as u32, i as u32]);
            }
        }
        self.modules = busmap
            .buses
            .iter()
            .flat_map(|bus| {
                bus.modules.iter().map(|m| SceneModule {
                    bus: bus.interface.clone(),
                    address: m.address,
                    taxels: m
                        .taxels
                        .iter()
                        .filter_map(|&id| index.get(&u32::try_from(id).ok()?).copied())
                        .collect(),
                })
            })
            .collect();
    }

    /// Taxels over all links.
    pub fn taxels(&self) -> usize {
        self.links.iter().map(|l| l.ids.len()).sum()
    }
}

impl SceneLink {
    fn from_map(map: &TactileMap) -> SceneLink {
        let uv_mm: Vec<[f32; 2]> = map
            .points
            .iter()
            .map(|p| [(p.x * 1e3) as f32, (p.y * 1e3) as f32])
            .collect();
        SceneLink {
            name: map.name.clone(),
            ids: map.ids.iter().map(|id| id.0).collect(),
            pitch_mm: pitch_mm(&uv_mm, &map.faces),
            uv_mm,
            dead: Vec::new(),
        }
    }
}

/// The median over taxels of each one's shortest triangle edge on the map, mm; 5 mm when the
/// map has no triangles.
fn pitch_mm(uv: &[[f32; 2]], faces: &[[usize; 3]]) -> f32 {
    let mut shortest = vec![f32::INFINITY; uv.len()];
    for f in faces {
        for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            let (Some(p), Some(q)) = (uv.get(a), uv.get(b)) else {
                continue;
            };
            let d = (p[0] - q[0]).hypot(p[1] - q[1]);
            if d > 0.0 {
                shortest[a] = shortest[a].min(d);
                shortest[b] = shortest[b].min(d);
            }
        }
    }
    let mut finite: Vec<f32> = shortest.into_iter().filter(|d| d.is_finite()).collect();
    if finite.is_empty() {
        return 5.0;
    }
    let mid = finite.len() / 2;
    *finite.select_nth_unstable_by(mid, f32::total_cmp).1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pitch_is_the_median_shortest_edge() {
        // A row of taxels 8 mm apart, one pair 2 mm apart: most taxels' shortest edge is 8 mm.
        let uv = [
            [0.0, 0.0],
            [8.0, 0.0],
            [16.0, 0.0],
            [24.0, 0.0],
            [26.0, 0.0],
            [4.0, 7.0],
            [12.0, 7.0],
            [20.0, 7.0],
        ];
        let faces = [[0, 1, 5], [1, 2, 6], [2, 3, 7], [3, 4, 7], [1, 6, 5], [2, 7, 6]];
        assert_eq!(pitch_mm(&uv, &faces), 8.0);
        assert_eq!(pitch_mm(&uv, &[]), 5.0);
    }
}

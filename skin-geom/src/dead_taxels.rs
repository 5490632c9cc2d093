//! Dead taxels: the taxels of a map that give no reading (no column in a recording, no slot on
//! any bus, a placeholder id). They are handled as the thesis' Test B handles removed taxels
//! (Ch. 5.3): the map's triangles are made again without them, so a press over a dead taxel stays
//! one contact and its image has no hole ([`crate::faults`]).

use crate::Result;
use crate::faults::{bridging_dead, without_taxels};
use crate::tactile_map::TactileMap;
use skin_core::Columns;

/// The dead taxels of one map: indices into its taxels, increasing, each once.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash)]
pub struct DeadTaxels(Vec<usize>);

impl DeadTaxels {
    /// The taxels `dead` of a map of `taxels` taxels; indices past the map are ignored, repeats
    /// count once.
    pub fn new(dead: &[usize], taxels: usize) -> DeadTaxels {
        let mut dead: Vec<usize> = dead.iter().copied().filter(|&i| i < taxels).collect();
        dead.sort_unstable();
        dead.dedup();
        DeadTaxels(dead)
    }

    /// The taxels a recording has no column for (`columns`: the recording matched to the map's
    /// taxel ids, [`skin_core::Recording::columns`]).
    pub fn of_columns(columns: &Columns) -> DeadTaxels {
        DeadTaxels(columns.dead())
    }

    /// The dead taxels' indices, increasing.
    pub fn indices(&self) -> &[usize] {
        &self.0
    }

    /// No taxel is dead.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// How many taxels are dead.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// The map of the living taxels alone, re-triangulated where the map had skin
    /// ([`without_taxels`]): its taxels are the survivors, in the map's order
    /// ([`DeadTaxels::survivors`]). The map itself when none is dead.
    pub fn remove_from(&self, map: &TactileMap) -> Result<TactileMap> {
        match self.is_empty() {
            true => Ok(map.clone()),
            false => without_taxels(map, &self.0),
        }
    }

    /// The map with every taxel in its place (same indices) but no triangle on a dead one
    /// ([`bridging_dead`]): readings keep the map's order. The map itself when none is dead.
    pub fn bridge_in(&self, map: &TactileMap) -> Result<TactileMap> {
        match self.is_empty() {
            true => Ok(map.clone()),
            false => bridging_dead(map, &self.0),
        }
    }

    /// The indices of the living taxels of a map of `taxels` taxels, increasing: where each taxel
    /// of [`DeadTaxels::remove_from`]'s map is in the whole map.
    pub fn survivors(&self, taxels: usize) -> Vec<usize> {
        let mut dead = self.0.iter().peekable();
        (0..taxels)
            .filter(|&i| {
                let is_dead = dead.peek() == Some(&&i);
                if is_dead {
                    dead.next();
                }
                !is_dead
            })
            .collect()
    }
}

use crate::TaxelId;
use std::collections::{HashMap, HashSet};

/// One synchronous snapshot of a skin: a timestamp and one value per taxel, in layout order.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Acquisition time, seconds (from the start of the recording, or any fixed epoch).
    pub time: f64,
    /// One reading per taxel, in the order of the taxel list the frame belongs to.
    pub values: Vec<f32>,
}

/// A sequence of frames over a fixed list of taxels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Recording {
    /// The taxels, in the order of each frame's values.
    pub taxel_ids: Vec<TaxelId>,
    /// Frame numbers as recorded (Cyskin recordings count from 0).
    pub frame_numbers: Vec<u64>,
    /// The frames.
    pub frames: Vec<Frame>,
}

/// Where each taxel of a layout finds its reading among a recording's columns
/// ([`Recording::columns`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Columns {
    /// For each taxel, in the layout's order, its column in the recording; `None` where the
    /// recording has no reading for it.
    pub of_taxel: Vec<Option<usize>>,
    /// The layout's taxels that the recording does not cover, in the layout's order.
    pub missing: Vec<TaxelId>,
    /// How many of the recording's columns are not taxels of the layout (they are ignored).
    pub ignored: usize,
}

impl Columns {
    /// The layout indices of the taxels without a column (dead taxels), increasing.
    pub fn dead(&self) -> Vec<usize> {
        (0..self.of_taxel.len())
            .filter(|&i| self.of_taxel[i].is_none())
            .collect()
    }

    /// The readings of one frame's `values` in taxel order, into `out` (one per taxel): readings
    /// at or below `threshold` and taxels without a column read 0. Returns whether any taxel
    /// reads above the threshold. `values` shorter than a column reads 0 there.
    pub fn gather(&self, values: &[f32], threshold: f32, out: &mut [f32]) -> bool {
        let mut any = false;
        for (p, c) in out.iter_mut().zip(&self.of_taxel) {
            let v = c.and_then(|c| values.get(c).copied()).unwrap_or(0.0);
            *p = if v > threshold { v } else { 0.0 };
            any |= *p > 0.0;
        }
        any
    }
}

impl Recording {
    /// Matches the columns of this recording to the taxels `ids` (a layout's or a map's, in its
    /// order) by taxel id.
    pub fn columns(&self, ids: &[TaxelId]) -> Columns {
        let index: HashMap<TaxelId, usize> = self
            .taxel_ids
            .iter()
            .enumerate()
            .map(|(i, id)| (*id, i))
            .collect();
        let of_taxel: Vec<Option<usize>> = ids.iter().map(|id| index.get(id).copied()).collect();
        let missing = ids
            .iter()
            .zip(&of_taxel)
            .filter(|(_, c)| c.is_none())
            .map(|(id, _)| *id)
            .collect();
        let wanted: HashSet<TaxelId> = ids.iter().copied().collect();
        let ignored = self.taxel_ids.iter().filter(|id| !wanted.contains(id)).count();
        Columns {
            of_taxel,
            missing,
            ignored,
        }
    }

    /// A file stem per frame, for one output file each: `frame_<number>` (five digits at
    /// least; a frame without a recorded number is numbered by its index), and
    /// `frame_<number>_dup<k>` for the k-th repeat of a frame number (a recording joined from
    /// two, a counter reset), so no frame's file is written over another's. Also returns how
    /// many frames repeat an earlier number.
    pub fn frame_stems(&self) -> (Vec<String>, usize) {
        let mut seen: HashMap<u64, usize> = HashMap::new();
        let mut repeats = 0;
        let stems = (0..self.frames.len())
            .map(|k| self.frame_numbers.get(k).copied().unwrap_or(k as u64))
            .map(|n| {
                let k = seen.entry(n).or_default();
                *k += 1;
                if *k == 1 {
                    format!("frame_{n:05}")
                } else {
                    repeats += 1;
                    format!("frame_{n:05}_dup{}", *k - 1)
                }
            })
            .collect();
        (stems, repeats)
    }
}

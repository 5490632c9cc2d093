//! Splitting a patch of pressed taxels where its pressure falls between separate peaks, so that
//! fingers pressed side by side are separate contacts (a watershed on the taxel mesh with a
//! prominence rule).
//!
//! The patch's taxels are flooded from the highest pressure down. A taxel with no flooded
//! neighbour starts a basin at its peak; one whose flooded neighbours belong to several basins
//! is a saddle between them. At a saddle, a lower basin stays a contact of its own only when it
//! is prominent: its peak stands at least `min_dip` (a fraction of that peak) above the saddle,
//! and its peak lies at least `min_distance_m` from the higher basin's peak. Otherwise it joins
//! the higher basin. Every taxel ends in exactly one basin, and the saddle taxels go to the
//! highest basin around them.
//!
//! A basin needs no more than its peak taxel above the saddle: at a real skin's pitch (7.3 mm
//! median on the recorded Cyskin patch) a fingertip raises one taxel well above its neighbours,
//! and asking for two taxels above the saddle joined 52 of 100 fingertip pairs drawn 18 mm apart
//! on that patch (`skin-core/tests/contacts_real.rs`). Noise is kept out before: by the
//! baseline's noise threshold, and by the finder's smallest patch.

/// How a patch of pressed, connected taxels becomes contacts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Separation {
    /// Each connected patch is one contact (thesis Ch. 3.2).
    #[default]
    Connected,
    /// A patch is split between prominent pressure peaks (module docs).
    Peaks {
        /// How far the pressure must fall between two peaks, as a fraction of the lower peak
        /// (0 to 1).
        min_dip: f32,
        /// How far apart two peaks must lie, metres on the skin (straight line).
        min_distance_m: f64,
    },
}

impl Separation {
    /// Peaks at least 12 mm apart with the pressure falling by half between them: fingertips
    /// side by side are about 15 to 20 mm apart.
    pub const FINGERS: Separation = Separation::Peaks {
        min_dip: 0.5,
        min_distance_m: 0.012,
    };
}

const NONE: u32 = u32::MAX;

/// The buffers of the flooding, sized once for a skin.
#[derive(Debug, Clone)]
pub(crate) struct Flooding {
    /// Per taxel: its basin in this patch, or `NONE`.
    label: Vec<u32>,
    /// The patch's taxels, highest pressure first.
    order: Vec<usize>,
    /// Per basin: its parent (itself at a root), peak taxel, and (at the end) its contact.
    parent: Vec<u32>,
    peak: Vec<usize>,
    number: Vec<usize>,
    roots: Vec<u32>,
}

impl Flooding {
    pub(crate) fn new(taxels: usize) -> Flooding {
        Flooding {
            label: vec![NONE; taxels],
            order: Vec::new(),
            parent: Vec::new(),
            peak: Vec::new(),
            number: Vec::new(),
            roots: Vec::new(),
        }
    }

    fn root(&mut self, mut b: u32) -> u32 {
        while self.parent[b as usize] != b {
            let up = self.parent[self.parent[b as usize] as usize];
            self.parent[b as usize] = up;
            b = up;
        }
        b
    }

    /// Splits `patch` (taxel indices) of `pressures`; afterwards [`Self::take_basin`] gives each of its
    /// taxels' final basin (0-based, dense) and the count is returned.
    #[allow(clippy::too_many_arguments)] // one call site, all of it the finder's state
    pub(crate) fn split(
        &mut self,
        patch: &[usize],
        pressures: &[f32],
        positions: &[nalgebra::Point3<f64>],
        start: &[usize],
        neighbours: &[usize],
        min_dip: f32,
        min_distance_m: f64,
    ) -> usize {
        self.order.clear();
        self.order.extend_from_slice(patch);
        self.order
            .sort_unstable_by(|&a, &b| pressures[b].total_cmp(&pressures[a]).then(a.cmp(&b)));
        self.parent.clear();
        self.peak.clear();
        self.number.clear();
        for k in 0..self.order.len() {
            let i = self.order[k];
            self.roots.clear();
            for &j in &neighbours[start[i]..start[i + 1]] {
                if self.label[j] != NONE {
                    let r = self.root(self.label[j]);
                    if !self.roots.contains(&r) {
                        self.roots.push(r);
                    }
                }
            }
            let Some(&first) = self.roots.first() else {
                let b = self.parent.len() as u32;
                self.parent.push(b);
                self.peak.push(i);
                self.label[i] = b;
                continue;
            };
            // The highest basin around takes the saddle; each lower one stays apart only if
            // prominent.
            let mut top = first;
            for &r in &self.roots {
                if pressures[self.peak[r as usize]] > pressures[self.peak[top as usize]] {
                    top = r;
                }
            }
            for n in 0..self.roots.len() {
                let r = self.roots[n];
                if r == top {
                    continue;
                }
                let low = pressures[self.peak[r as usize]];
                let dip = (low - pressures[i]) / low;
                let apart = (positions[self.peak[r as usize]] - positions[self.peak[top as usize]]).norm();
                let prominent = dip >= min_dip && apart >= min_distance_m;
                if !prominent {
                    self.parent[r as usize] = top;
                }
            }
            self.label[i] = top;
        }
        // Dense numbers for the final basins, by root.
        let mut count = 0usize;
        self.number.resize(self.parent.len(), 0);
        for b in 0..self.parent.len() as u32 {
            if self.root(b) == b {
                self.number[b as usize] = count;
                count += 1;
            }
        }
        for &i in patch {
            let r = self.root(self.label[i]);
            self.label[i] = self.number[r as usize] as u32;
        }
        count
    }

    /// The final basin of taxel `i` of the last patch split; forgets it.
    pub(crate) fn take_basin(&mut self, i: usize) -> usize {
        std::mem::replace(&mut self.label[i], NONE) as usize
    }
}

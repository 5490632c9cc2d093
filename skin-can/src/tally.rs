//! What a run lost: per-module counts of missing and duplicated data over the assembled frames,
//! and, with the assembler's counts, the report `skin replay` and `skin live` print.

use crate::{AssembledFrame, AssemblyStats, BusMap, ModuleRef};
use std::collections::BTreeMap;
use std::fmt::{self, Display, Formatter};

/// Per-module counts over a run's assembled frames.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ModuleTally {
    /// Frames each module was missing from.
    pub missing: BTreeMap<ModuleRef, u64>,
    /// Frames each module sent twice in.
    pub duplicated: BTreeMap<ModuleRef, u64>,
}

impl ModuleTally {
    /// Counts one frame's missing and duplicated modules.
    pub fn add(&mut self, f: &AssembledFrame) {
        for m in &f.missing {
            *self.missing.entry(*m).or_default() += 1;
        }
        for m in &f.duplicated {
            *self.duplicated.entry(*m).or_default() += 1;
        }
    }

    /// The report of the run: the ten modules most often missing and duplicated (by interface
    /// name from `map`), then every nonzero count of `stats` that says traffic was lost or odd.
    /// One line each, no trailing newline; empty when nothing was lost.
    pub fn report<'a>(&'a self, map: &'a BusMap, stats: &'a AssemblyStats) -> TallyReport<'a> {
        TallyReport {
            tally: self,
            map,
            stats,
        }
    }
}

/// [`ModuleTally::report`], as text.
#[derive(Debug)]
pub struct TallyReport<'a> {
    tally: &'a ModuleTally,
    map: &'a BusMap,
    stats: &'a AssemblyStats,
}

impl Display for TallyReport<'_> {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        let mut lines = Vec::new();
        for (what, counts) in [
            ("missing", &self.tally.missing),
            ("duplicated", &self.tally.duplicated),
        ] {
            let mut worst: Vec<_> = counts.iter().collect();
            worst.sort_by(|a, b| b.1.cmp(a.1).then(a.0.cmp(b.0)));
            if !worst.is_empty() {
                lines.push(format!("modules {what}: {} (most often first)", worst.len()));
            }
            for (m, n) in worst.iter().take(10) {
                let bus = self
                    .map
                    .buses
                    .get(usize::from(m.bus))
                    .map_or("?", |b| b.interface.as_str());
                lines.push(format!("  module {} on {bus} {what} in {n} frame(s)", m.address));
            }
        }
        let s = self.stats;
        let unusable = [
            ("data from modules not in the bus map", s.unknown_module),
            ("data before the first sync of its bus", s.before_first_sync),
            ("data for a cycle already delivered (late)", s.late),
        ];
        for (what, n) in unusable.iter().filter(|(_, n)| *n > 0) {
            lines.push(format!("unused CAN frames: {n} {what}"));
        }
        for (what, n) in &s.malformed {
            lines.push(format!("malformed CAN frames: {n} {what}"));
        }
        let counts = [
            (
                s.ignored,
                "other CAN frames (other protocols or interfaces, not skin data)",
            ),
            (s.skipped, "cycles in which nothing arrived"),
            (
                s.counter_resets,
                "sync counter restarts (recordings joined or a hub reset; the cycles after each are kept, numbered on by time)",
            ),
            (s.remote, "remote requests (no data), skipped"),
            (
                s.time_backwards,
                "CAN frames stamped earlier than the frame before them on their interface (kept in log order)",
            ),
        ];
        for (n, what) in counts.iter().filter(|(n, _)| *n > 0) {
            lines.push(format!("{what}: {n}"));
        }
        f.write_str(&lines.join("\n"))
    }
}

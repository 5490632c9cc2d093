//! Snapshot assembly: CAN frames in, one frame of the whole skin per cycle out.
//!
//! Two ways to cut the traffic into cycles:
//!
//! - **By sync** ([`Assembler::new`], `skin16`): every bus's sync opens a cycle; the module data
//!   that follows on that bus belongs to it. Buses are merged by cycle counter (the master sends the
//!   same counter on every bus), unwrapped past 255 so cycles keep increasing. A cycle is delivered
//!   once every bus that has spoken has moved on to a later one (or at [`Assembler::finish`]). A
//!   lost sync cannot be told apart from a late one: the data of that bus then lands in the
//!   previous cycle, which reports the module as duplicated and the next cycle as missing it.
//! - **By time window** ([`Assembler::windowed`], `icub8`, whose boards free-run without a sync):
//!   window k holds the frames stamped in `[t0 + k P, t0 + (k + 1) P)`, t0 the first frame's time
//!   and P the period. A window is delivered once traffic half a period past its end has been seen,
//!   so frames of several buses interleaved a little out of time order still land in their window.
//!   Boards whose period differs from P drift across window edges: the drift shows up as
//!   duplicated and missing modules, reported, never hidden.
//!
//! Each frame carries its values in bus-map order and a report of the modules that did not send
//! all their data and of data received twice (the first copy is kept). A partial frame is
//! delivered flagged, never dropped; cycles or windows in which nothing at all arrived are counted
//! in [`AssemblyStats::skipped`].

use crate::busmap::{BusMap, SLOTS};
use crate::candump::CanFrame;
use crate::decode::{Decoded, Decoder};
use std::collections::VecDeque;

/// A module named by its bus and address.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModuleRef {
    /// Bus index in the bus map.
    pub bus: u16,
    /// Address on that bus.
    pub address: u32,
}

/// One assembled snapshot of the skin.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AssembledFrame {
    /// Cycle number (the sync counter, unwrapped past 255).
    pub cycle: u64,
    /// Time of the first sync of this cycle, microseconds.
    pub time_us: u64,
    /// One reading per taxel in bus-map order ([`BusMap::taxel_ids`]); `None` where the module's
    /// data did not arrive.
    pub values: Vec<Option<u16>>,
    /// Modules with at least one of their data frames missing.
    pub missing: Vec<ModuleRef>,
    /// Modules that sent some data frame twice in this cycle (the first copy is kept).
    pub duplicated: Vec<ModuleRef>,
}

impl AssembledFrame {
    /// Every module of the map sent all its data.
    pub fn is_complete(&self) -> bool {
        self.missing.is_empty()
    }

    /// Appends the frame as a row of the frames table (`skin replay -o`, `skin live -o`):
    /// `t_us,cycle,complete` (1 or 0), then one value per slot of the bus map, empty when its
    /// module was missing. The header is [`FRAMES_CSV_HEADER`] followed by the slots' taxel ids.
    pub fn csv_row(&self, csv: &mut String) {
        use std::fmt::Write as _;
        let _ = write!(
            csv,
            "{},{},{}",
            self.time_us,
            self.cycle,
            u8::from(self.is_complete())
        );
        for v in &self.values {
            match v {
                Some(v) => {
                    let _ = write!(csv, ",{v}");
                }
                None => csv.push(','),
            }
        }
        csv.push('\n');
    }
}

/// How the frames table ([`AssembledFrame::csv_row`]) starts; a taxel id per column follows.
pub const FRAMES_CSV_HEADER: &str = "t_us,cycle,complete";

/// Counts over everything pushed so far.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AssemblyStats {
    /// Frames delivered.
    pub frames: u64,
    /// Of which complete.
    pub complete: u64,
    /// Data frames from addresses the bus map does not list.
    pub unknown_module: u64,
    /// Data frames on a bus before its first sync (no cycle to put them in).
    pub before_first_sync: u64,
    /// Data frames for a cycle already delivered (arrived too late).
    pub late: u64,
    /// Frames of other protocols, or from interfaces not in the map.
    pub ignored: u64,
    /// Cycles (or windows) between two delivered ones in which nothing arrived at all.
    pub skipped: u64,
    /// Malformed frames, by what was wrong.
    pub malformed: Vec<(&'static str, u64)>,
    /// Sync counters that went back or jumped ahead on a bus faster than time allows (two
    /// recordings joined, a hub reset). The cycles after it are kept, numbered on from the last
    /// one by the time that passed.
    pub counter_resets: u64,
    /// The latest such restart.
    pub last_reset: Option<CounterReset>,
    /// Remote requests (no data: never skin readings), skipped.
    pub remote: u64,
    /// Frames stamped earlier than the frame before them on the same interface (kept, in the
    /// order they came).
    pub time_backwards: u64,
}

/// A sync counter that restarted or jumped on one bus.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CounterReset {
    /// Bus index in the bus map.
    pub bus: u16,
    /// Time of the sync that restarted, microseconds.
    pub time_us: u64,
    /// The bus's counter before, and the one it restarted at.
    pub from: u8,
    /// See `from`.
    pub to: u8,
    /// The cycle number given to the restarted sync.
    pub cycle: u64,
}

/// One bus's latest sync, to tell a restarted counter from lost syncs.
#[derive(Debug, Clone, Copy)]
struct BusSync {
    counter: u8,
    cycle: u64,
    time_us: u64,
    /// The latest interval between two consecutive counters, microseconds.
    period_us: Option<u64>,
}

/// Where one module's slots go.
#[derive(Debug, Clone, Copy)]
struct Slots {
    index: usize,
    columns: [Option<u32>; SLOTS],
}

#[derive(Debug, Clone)]
struct Pending {
    frame: AssembledFrame,
    /// Per module, bit k set when slot k arrived.
    received: Vec<u16>,
    twice: Vec<bool>,
}

/// Time windows of the sync-less mode.
#[derive(Debug, Clone, Copy)]
struct Window {
    period_us: u64,
    /// Start of window 0 (the first frame's time).
    origin: Option<u64>,
    /// Latest timestamp seen.
    latest_us: u64,
}

/// Assembles frames of one bus map from CAN traffic.
#[derive(Debug, Clone)]
pub struct Assembler<D: Decoder> {
    decoder: D,
    window: Option<Window>,
    /// For each log interface, its bus in the map (if any).
    bus_of_interface: Vec<Option<u16>>,
    /// The map's interface names, by bus.
    map_interfaces: Vec<String>,
    /// Per map bus, address -> module slots.
    modules: Vec<Vec<Option<Slots>>>,
    module_refs: Vec<ModuleRef>,
    /// Per module, the slots that carry a taxel (all must arrive for the module to be complete).
    expected: Vec<u16>,
    columns: usize,
    /// Per map bus, the cycle it is in.
    bus_cycle: Vec<Option<u64>>,
    /// Per map bus, its latest sync.
    bus_sync: Vec<Option<BusSync>>,
    /// Per log interface, the latest timestamp.
    last_time: Vec<u64>,
    latest: Option<u64>,
    pending: VecDeque<Pending>,
    spare: Vec<Pending>,
    delivered_up_to: Option<u64>,
    stats: AssemblyStats,
}

/// Default window of sync-less formats: the 50 ms period of iCub skin boards and Cyskin hubs.
pub const DEFAULT_WINDOW_US: u64 = 50_000;

impl Assembler<Box<dyn Decoder + Send>> {
    /// The assembler a bus map's wire format calls for: by sync for `skin16`, by windows of
    /// `window_us` microseconds for `icub8`.
    pub fn for_map(map: &BusMap, interfaces: &[String], window_us: u64) -> Self {
        let decoder = crate::decode::for_format(map.format);
        match map.format {
            crate::WireFormat::Skin16 => Self::new(map, interfaces, decoder),
            crate::WireFormat::Icub8 => Self::windowed(map, interfaces, decoder, window_us),
        }
    }
}

impl<D: Decoder> Assembler<D> {
    /// An assembler for `map` cutting cycles at the sync frames, reading frames whose `bus`
    /// indexes `interfaces` (a log's interface list). Interfaces not in the map are ignored; map
    /// buses absent from the list deliver nothing and their modules are reported missing in every
    /// frame.
    pub fn new(map: &BusMap, interfaces: &[String], decoder: D) -> Self {
        Self::build(map, interfaces, decoder, None)
    }

    /// An assembler for `map` cutting cycles into time windows of `period_us` microseconds (at
    /// least 1), for formats without a sync such as `icub8`; sync frames, if any, are ignored.
    pub fn windowed(map: &BusMap, interfaces: &[String], decoder: D, period_us: u64) -> Self {
        let window = Window {
            period_us: period_us.max(1),
            origin: None,
            latest_us: 0,
        };
        Self::build(map, interfaces, decoder, Some(window))
    }

    fn build(map: &BusMap, interfaces: &[String], decoder: D, window: Option<Window>) -> Self {
        let bus_of_interface = interfaces
            .iter()
            .map(|name| {
                map.buses
                    .iter()
                    .position(|b| &b.interface == name)
                    .map(|b| b as u16)
            })
            .collect();
        let mut modules = Vec::with_capacity(map.buses.len());
        let mut module_refs = Vec::new();
        let mut expected = Vec::new();
        let mut column = 0u32;
        for (b, bus) in map.buses.iter().enumerate() {
            let size = bus
                .modules
                .iter()
                .map(|m| m.address as usize + 1)
                .max()
                .unwrap_or(0);
            let mut table = vec![None; size];
            for m in &bus.modules {
                let mut columns = [None; SLOTS];
                let mut mask = 0u16;
                for (slot, &t) in m.taxels.iter().enumerate().take(SLOTS) {
                    if t >= 0 {
                        columns[slot] = Some(column);
                        column += 1;
                        mask |= 1 << slot;
                    }
                }
                table[m.address as usize] = Some(Slots {
                    index: module_refs.len(),
                    columns,
                });
                module_refs.push(ModuleRef {
                    bus: b as u16,
                    address: m.address,
                });
                expected.push(mask);
            }
            modules.push(table);
        }
        Assembler {
            decoder,
            window,
            bus_of_interface,
            map_interfaces: map.buses.iter().map(|b| b.interface.clone()).collect(),
            modules,
            module_refs,
            expected,
            columns: column as usize,
            bus_cycle: vec![None; map.buses.len()],
            bus_sync: vec![None; map.buses.len()],
            last_time: vec![0; interfaces.len()],
            latest: None,
            pending: VecDeque::new(),
            spare: Vec::new(),
            delivered_up_to: None,
            stats: AssemblyStats::default(),
        }
    }

    /// Names one more interface of the log after those the assembler was made with: frames whose
    /// `bus` is the next index come from it. A log read as a stream names its interfaces as they
    /// appear ([`crate::candump::CanSource::interfaces`]).
    pub fn add_interface(&mut self, name: &str) {
        let bus = self.map_interfaces.iter().position(|b| b == name);
        self.bus_of_interface.push(bus.map(|b| b as u16));
        self.last_time.push(0);
    }

    /// How many of the log's interfaces the assembler knows (made with, and added).
    pub fn interfaces(&self) -> usize {
        self.bus_of_interface.len()
    }

    /// Counts so far.
    pub fn stats(&self) -> &AssemblyStats {
        &self.stats
    }

    /// Feeds one CAN frame; calls `emit` for every frame it completes.
    pub fn push(&mut self, frame: &CanFrame, emit: &mut dyn FnMut(&AssembledFrame)) {
        if let Some(last) = self.last_time.get_mut(usize::from(frame.bus)) {
            if frame.time_us < *last {
                self.stats.time_backwards += 1;
            }
            *last = frame.time_us;
        }
        if frame.remote {
            self.stats.remote += 1;
            return;
        }
        let Some(&Some(bus)) = self.bus_of_interface.get(usize::from(frame.bus)) else {
            self.stats.ignored += 1;
            return;
        };
        match self.decoder.decode(frame) {
            Decoded::Ignored => self.stats.ignored += 1,
            Decoded::Malformed(what) => match self.stats.malformed.iter_mut().find(|(w, _)| *w == what) {
                Some((_, n)) => *n += 1,
                None => self.stats.malformed.push((what, 1)),
            },
            Decoded::Sync { .. } if self.window.is_some() => self.stats.ignored += 1,
            Decoded::Sync { counter } => self.sync(bus, counter, frame.time_us, emit),
            Decoded::Values {
                address,
                first_slot,
                count,
                values,
            } => {
                let values = &values[..usize::from(count.min(8))];
                if self.window.is_some() {
                    self.windowed_values(bus, address, first_slot, values, frame.time_us, emit);
                } else {
                    self.values(bus, address, first_slot, values);
                }
            }
        }
    }

    fn windowed_values(
        &mut self,
        bus: u16,
        address: u32,
        first_slot: u8,
        values: &[u16],
        time_us: u64,
        emit: &mut dyn FnMut(&AssembledFrame),
    ) {
        let Some(w) = self.window.as_mut() else {
            return;
        };
        let origin = *w.origin.get_or_insert(time_us);
        w.latest_us = w.latest_us.max(time_us);
        let Some(since) = time_us.checked_sub(origin) else {
            self.stats.late += 1;
            return;
        };
        let cycle = since / w.period_us;
        let start = origin + cycle * w.period_us;
        self.bus_cycle[usize::from(bus)] = Some(cycle);
        self.open(cycle, start);
        self.values(bus, address, first_slot, values);
        self.deliver(false, emit);
    }

    /// Starts collecting `cycle` unless it is pending or already delivered.
    fn open(&mut self, cycle: u64, time_us: u64) {
        if self.delivered_up_to.is_some_and(|d| cycle <= d)
            || self.pending.iter().any(|p| p.frame.cycle == cycle)
        {
            return;
        }
        let mut p = self.spare.pop().unwrap_or_else(|| Pending {
            frame: AssembledFrame {
                cycle: 0,
                time_us: 0,
                values: vec![None; self.columns],
                missing: Vec::new(),
                duplicated: Vec::new(),
            },
            received: vec![0; self.module_refs.len()],
            twice: vec![false; self.module_refs.len()],
        });
        p.frame.cycle = cycle;
        p.frame.time_us = time_us;
        p.frame.values.fill(None);
        p.received.fill(0);
        p.twice.fill(false);
        let at = self.pending.partition_point(|q| q.frame.cycle < cycle);
        self.pending.insert(at, p);
    }

    fn sync(&mut self, bus: u16, counter: u8, time_us: u64, emit: &mut dyn FnMut(&AssembledFrame)) {
        let b = usize::from(bus);
        let mut period_us = None;
        let cycle = match self.bus_sync[b] {
            // This bus spoke before: its own counter says how many cycles passed, unless the
            // counter went back, or jumped further than the time since its last sync allows.
            Some(last) => {
                period_us = last.period_us;
                let d = i64::from(counter.wrapping_sub(last.counter) as i8);
                let elapsed = time_us.saturating_sub(last.time_us);
                let jumped =
                    matches!(last.period_us, Some(p) if d >= 3 && elapsed.saturating_mul(2) < d as u64 * p);
                if d < 0 || jumped {
                    let steps = last
                        .period_us
                        .filter(|&p| p > 0)
                        .map_or(1, |p| ((elapsed + p / 2) / p).max(1));
                    let cycle = last.cycle + steps;
                    self.stats.counter_resets += 1;
                    self.stats.last_reset = Some(CounterReset {
                        bus,
                        time_us,
                        from: last.counter,
                        to: counter,
                        cycle,
                    });
                    cycle
                } else {
                    if d == 1 && elapsed > 0 {
                        period_us = Some(elapsed);
                    }
                    last.cycle + d as u64
                }
            }
            // A bus's first sync: the cycle number nearest the latest one with this counter
            // modulo 256, so that every bus numbers the same cycle alike.
            None => match self.latest {
                None => u64::from(counter),
                Some(latest) => {
                    let delta = i64::from(counter.wrapping_sub(latest as u8) as i8);
                    latest.saturating_add_signed(delta)
                }
            },
        };
        self.bus_sync[b] = Some(BusSync {
            counter,
            cycle,
            time_us,
            period_us,
        });
        self.latest = Some(self.latest.map_or(cycle, |l| l.max(cycle)));
        self.bus_cycle[usize::from(bus)] = Some(cycle);
        self.open(cycle, time_us);
        self.deliver(false, emit);
    }

    fn values(&mut self, bus: u16, address: u32, first_slot: u8, values: &[u16]) {
        let Some(cycle) = self.bus_cycle[usize::from(bus)] else {
            self.stats.before_first_sync += 1;
            return;
        };
        let Some(Some(slots)) = self.modules[usize::from(bus)].get(address as usize).copied() else {
            self.stats.unknown_module += 1;
            return;
        };
        let Some(p) = self.pending.iter_mut().find(|p| p.frame.cycle == cycle) else {
            self.stats.late += 1;
            return;
        };
        for (k, &v) in values.iter().enumerate() {
            let slot = usize::from(first_slot) + k;
            if slot >= SLOTS {
                break;
            }
            let bit = 1u16 << slot;
            if p.received[slots.index] & bit != 0 {
                p.twice[slots.index] = true;
                continue;
            }
            p.received[slots.index] |= bit;
            if let Some(c) = slots.columns[slot] {
                p.frame.values[c as usize] = Some(v);
            }
        }
    }

    /// Delivers every pending cycle that all active buses have left, or whose window closed half
    /// a period ago (or all, when `all`).
    fn deliver(&mut self, all: bool, emit: &mut dyn FnMut(&AssembledFrame)) {
        let oldest_bus_cycle = self.bus_cycle.iter().flatten().copied().min();
        while let Some(front) = self.pending.front() {
            let closed = match self.window {
                Some(w) => {
                    let end = front.frame.time_us.saturating_add(w.period_us + w.period_us / 2);
                    w.latest_us >= end
                }
                None => oldest_bus_cycle.is_some_and(|c| front.frame.cycle < c),
            };
            let ready = all || closed || self.pending.len() > 8;
            if !ready {
                break;
            }
            let Some(mut p) = self.pending.pop_front() else {
                break;
            };
            p.frame.missing.clear();
            p.frame.duplicated.clear();
            for (m, r) in self.module_refs.iter().enumerate() {
                if p.received[m] & self.expected[m] != self.expected[m] {
                    p.frame.missing.push(*r);
                }
                if p.twice[m] {
                    p.frame.duplicated.push(*r);
                }
            }
            if let Some(d) = self.delivered_up_to {
                self.stats.skipped += p.frame.cycle.saturating_sub(d + 1);
            }
            self.stats.frames += 1;
            if p.frame.is_complete() {
                self.stats.complete += 1;
            }
            self.delivered_up_to = Some(p.frame.cycle);
            emit(&p.frame);
            self.spare.push(p);
        }
    }

    /// Delivers the cycles still pending (end of a log or of a live session). A last cycle that
    /// got its syncs and no data at all is not delivered but counted in
    /// [`AssemblyStats::skipped`]: the input ended between a sync and its cycle's data (a writer
    /// in lock-step sends the next cycle's syncs as soon as a frame's data is out), which loses
    /// no module.
    pub fn finish(&mut self, emit: &mut dyn FnMut(&AssembledFrame)) {
        let unbegun = self.delivered_up_to.is_some()
            && self
                .pending
                .back()
                .is_some_and(|p| p.received.iter().all(|&r| r == 0));
        if unbegun && let Some(p) = self.pending.pop_back() {
            self.stats.skipped += 1;
            self.spare.push(p);
        }
        self.deliver(true, emit);
    }
}

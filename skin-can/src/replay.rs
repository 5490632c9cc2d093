//! A candump log replayed through a bus map, one CAN frame at a time: memory does not grow with
//! the log, and each assembled frame is handed on as it completes ([`replay`]).

use crate::candump::CandumpReader;
use crate::{AssembledFrame, Assembler, AssemblyStats, BusMap, Error, ModuleTally, Result};
use std::io::BufRead;

/// What [`replay`] found in a log.
#[derive(Debug, Clone, Default)]
pub struct Replay {
    /// CAN frames read (error frames not counted).
    pub can_frames: u64,
    /// Seconds from the first CAN frame to the last.
    pub span_s: f64,
    /// CAN error frames, skipped.
    pub error_frames: usize,
    /// The log's interfaces, in order of appearance.
    pub interfaces: Vec<String>,
    /// The bus map's interfaces the log does not have: their modules are missing in every
    /// frame.
    pub missing_buses: Vec<String>,
    /// The assembler's counts.
    pub stats: AssemblyStats,
    /// The modules missing or duplicated, per frame.
    pub tally: ModuleTally,
}

/// Replays `log` through `map` (`window_us`: the time window of sync-less formats), handing
/// every assembled frame to `each`, which returns false to stop (a failed write, say). Reading
/// errors are returned; a log without frames, or without any of the map's buses, is not an
/// error here but in [`Replay::check`], so that the caller may first say why it stopped.
pub fn replay<R: BufRead>(
    log: &mut CandumpReader<R>,
    map: &BusMap,
    window_us: u64,
    each: &mut dyn FnMut(&AssembledFrame) -> bool,
) -> Result<Replay> {
    let mut tally = ModuleTally::default();
    let mut assembler = Assembler::for_map(map, &[], window_us);
    // A cell, as the loop reads the flag while `emit` holds the tally and `each` mutably.
    let go = std::cell::Cell::new(true);
    let mut emit = |f: &AssembledFrame| {
        tally.add(f);
        go.set(go.get() && each(f));
    };
    let (mut count, mut span) = (0u64, None::<(u64, u64)>);
    while let Some(frame) = log.next_frame()? {
        for name in &log.interfaces()[assembler.interfaces()..] {
            assembler.add_interface(name);
        }
        count += 1;
        span = Some(span.map_or((frame.time_us, frame.time_us), |(a, _)| (a, frame.time_us)));
        assembler.push(&frame, &mut emit);
        if !go.get() {
            break;
        }
    }
    assembler.finish(&mut emit);
    let interfaces = log.interfaces().to_vec();
    let missing_buses = map
        .buses
        .iter()
        .filter(|b| !interfaces.contains(&b.interface))
        .map(|b| b.interface.clone())
        .collect();
    Ok(Replay {
        can_frames: count,
        span_s: span.map_or(0.0, |(a, b)| b.saturating_sub(a) as f64 * 1e-6),
        error_frames: log.error_frames(),
        interfaces,
        missing_buses,
        stats: assembler.stats().clone(),
        tally,
    })
}

impl Replay {
    /// Refuses a log of `log_path` that holds no CAN frame, or none of `map`'s buses (a log of
    /// another skin).
    pub fn check(&self, log_path: &std::path::Path, map: &BusMap) -> Result<()> {
        let invalid = |message| Error::Invalid {
            path: log_path.to_owned(),
            message,
        };
        if self.can_frames == 0 {
            return Err(invalid(format!(
                "no CAN frames in it ({})",
                match self.error_frames {
                    0 => "an empty log".to_string(),
                    n => format!("{n} error frame(s): a log of bus errors, without skin traffic"),
                }
            )));
        }
        if self.missing_buses.len() == map.buses.len() {
            let names: Vec<&str> = map.buses.iter().map(|b| b.interface.as_str()).collect();
            return Err(invalid(format!(
                "none of the bus map's interfaces ({}) is in the log (it has {}); is it a log of this skin?",
                names.join(", "),
                self.interfaces.join(", ")
            )));
        }
        Ok(())
    }
}

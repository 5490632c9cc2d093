//! The CAN traffic of a skin frame, as the buses would carry it: what a simulated skin writes so
//! that a session reads it exactly as it reads the real one (a candump log, or a pipe that
//! `skin run --log` reads while it is written).
//!
//! skin16 only: a cycle opens with a sync on every bus, then each module's three data frames,
//! [`MODULE_GAP_US`] apart in bus-map order. A skin16 cycle is complete when the next sync comes
//! ([`crate::Assembler`]), so a writer in lock-step with a reader sends the next cycle's syncs
//! ([`encode_syncs`]) as soon as a frame's data is out.

use crate::candump::CandumpLog;
use crate::decode::skin16::{encode_module, encode_sync};
use crate::{BusMap, ModuleRef, SLOTS, WireFormat};

/// Microseconds between two modules' data on a bus (and between a sync and the first module).
pub const MODULE_GAP_US: u64 = 150;

/// Why a frame cannot be written as CAN traffic.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// The bus map's wire format has no writer here.
    #[error("the bus map's format is {}: only skin16 traffic can be written", .0.name())]
    Format(WireFormat),
    /// Not one value per slot of the bus map.
    #[error("{given} values for a bus map of {slots} slots: give one per slot, in bus-map order")]
    Values {
        /// Values given.
        given: usize,
        /// Slots of the map.
        slots: usize,
    },
    /// A module said missing that the bus map does not have.
    #[error("module {address} on bus {bus} is not in the bus map")]
    UnknownModule {
        /// Bus index.
        bus: u16,
        /// Address on it.
        address: u32,
    },
}

/// The traffic of one frame: when `sync`, every bus's sync for `cycle` at `time_us` (its counter
/// is `cycle` modulo 256), then the data of every module not in `missing`. `values`: one per slot
/// of the map ([`BusMap::taxel_ids`] order).
pub fn encode_frame(
    map: &BusMap,
    values: &[u16],
    cycle: u64,
    time_us: u64,
    missing: &[ModuleRef],
    sync: bool,
) -> Result<CandumpLog, EncodeError> {
    if map.format != WireFormat::Skin16 {
        return Err(EncodeError::Format(map.format));
    }
    let slots = map.slot_count();
    if values.len() != slots {
        return Err(EncodeError::Values {
            given: values.len(),
            slots,
        });
    }
    for m in missing {
        let known = map
            .buses
            .get(usize::from(m.bus))
            .is_some_and(|b| b.modules.iter().any(|x| x.address == m.address));
        if !known {
            return Err(EncodeError::UnknownModule {
                bus: m.bus,
                address: m.address,
            });
        }
    }
    let mut log = if sync {
        encode_syncs(map, cycle, time_us)?
    } else {
        empty(map)
    };
    let mut on_bus = vec![0u64; map.buses.len()];
    for (b, module, range) in map.module_slots() {
        // Bus indices fit: a bus map holds at most MAX_BUSES.
        let bus = u16::try_from(b).unwrap_or(u16::MAX);
        on_bus[b] += 1;
        let gone = missing
            .iter()
            .any(|m| m.bus == bus && m.address == module.address);
        if gone {
            continue;
        }
        let mut readings = [0u16; SLOTS];
        let mut next = range.start;
        for (slot, &taxel) in module.taxels.iter().enumerate().take(SLOTS) {
            if taxel >= 0 {
                readings[slot] = values[next];
                next += 1;
            }
        }
        let t = time_us + MODULE_GAP_US * on_bus[b];
        log.frames
            .extend(encode_module(module.address, &readings, t, bus));
    }
    Ok(log)
}

/// Every bus's sync for `cycle` at `time_us`: what opens a cycle, and completes the one before.
pub fn encode_syncs(map: &BusMap, cycle: u64, time_us: u64) -> Result<CandumpLog, EncodeError> {
    if map.format != WireFormat::Skin16 {
        return Err(EncodeError::Format(map.format));
    }
    let mut log = empty(map);
    for b in 0..map.buses.len() {
        let bus = u16::try_from(b).unwrap_or(u16::MAX);
        log.frames.push(encode_sync((cycle % 256) as u8, time_us, bus));
    }
    Ok(log)
}

fn empty(map: &BusMap) -> CandumpLog {
    CandumpLog {
        interfaces: map.buses.iter().map(|b| b.interface.clone()).collect(),
        ..CandumpLog::default()
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::expect_used, clippy::unwrap_used)]
    use super::*;
    use crate::Assembler;
    use skin_core::TaxelId;

    fn map() -> BusMap {
        let ids: Vec<TaxelId> = (1..=5u32)
            .flat_map(|m| (0..11).map(move |c| TaxelId(m << 4 | c)))
            .collect();
        BusMap::for_taxels(&ids, WireFormat::Skin16, 2).expect("a map")
    }

    #[test]
    fn frames_written_are_the_frames_assembled() {
        // Three frames written in lock-step (data, then the next cycle's syncs) are assembled
        // back to their values, each as soon as its successor's syncs are read.
        let map = map();
        let slots = map.slot_count();
        let buses: Vec<String> = map.buses.iter().map(|b| b.interface.clone()).collect();
        let mut asm = Assembler::for_map(&map, &buses, crate::DEFAULT_WINDOW_US);
        let mut got = Vec::new();
        for k in 0..3u64 {
            let values: Vec<u16> = (0..slots).map(|i| (i as u64 * 7 + k * 1000) as u16).collect();
            let lost = if k == 1 {
                vec![ModuleRef { bus: 1, address: 0 }]
            } else {
                vec![]
            };
            let t = 50_000 * k;
            let mut log = encode_frame(&map, &values, k, t, &lost, k == 0).expect("written");
            log.frames
                .extend(encode_syncs(&map, k + 1, t + 50_000).expect("syncs").frames);
            let text = log.to_text();
            let read = CandumpLog::parse(&text, std::path::Path::new("t.log")).expect("read back");
            let before = got.len();
            for f in &read.frames {
                asm.push(f, &mut |a| got.push(a.clone()));
            }
            assert_eq!(got.len(), before + 1, "frame {k} delivered at once");
            if k == 2 {
                // The input ends after the next syncs: that cycle had not begun, nothing lost.
                asm.finish(&mut |a| got.push(a.clone()));
                assert_eq!(got.len(), before + 1);
                assert_eq!(asm.stats().skipped, 1);
            }
            let a = &got[before];
            assert_eq!((a.cycle, a.time_us), (k, t));
            assert_eq!(a.missing, lost);
            for (i, v) in a.values.iter().enumerate() {
                let lost_slot = k == 1 && v.is_none();
                assert!(lost_slot || *v == Some(values[i]), "frame {k} slot {i}");
            }
        }
    }

    #[test]
    fn bad_frames_are_refused() {
        let map = map();
        let short = encode_frame(&map, &[0; 3], 0, 0, &[], true);
        assert_eq!(short.unwrap_err(), EncodeError::Values { given: 3, slots: 55 });
        let values = vec![0; 55];
        let ghost = ModuleRef { bus: 0, address: 99 };
        assert!(matches!(
            encode_frame(&map, &values, 0, 0, &[ghost], true),
            Err(EncodeError::UnknownModule { address: 99, .. })
        ));
    }
}

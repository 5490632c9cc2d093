//! `skin replay`: a candump log -> assembled skin frames (summary, CSV).

use anyhow::{Context, Result, bail};
use skin_can::candump::CandumpLog;
use skin_can::decode::Skin16;
use skin_can::{Assembler, BusMap, WireFormat};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Replay a candump log through a bus map: assemble one frame of the whole skin per cycle and say
/// what was missing.
///
/// LOG is a candump log (can-utils `candump -l` or python-can). MAP is the bus map (TOML: wire
/// format, buses, modules, taxel ids per slot). Prints frames, complete and partial counts, the
/// modules missing most often, and frames that could not be used, by kind. With -o, writes every
/// frame as CSV: `t_us,cycle,complete,` then one column per taxel id in bus-map order, values as
/// on the wire (no baseline), empty cells where a partial frame lacks a value.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// candump log.
    log: PathBuf,
    /// Bus map (TOML).
    #[arg(long, value_name = "MAP.toml")]
    busmap: PathBuf,
    /// Write the frames as CSV.
    #[arg(short, long, value_name = "frames.csv")]
    output: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let map = BusMap::read(&args.busmap)?;
    if map.format != WireFormat::Skin16 {
        bail!(
            "{}: only the skin16 format can be replayed so far",
            args.busmap.display()
        );
    }
    let log = CandumpLog::read(&args.log)?;
    let unknown: Vec<&str> = map
        .buses
        .iter()
        .filter(|b| !log.interfaces.contains(&b.interface))
        .map(|b| b.interface.as_str())
        .collect();
    if unknown.len() == map.buses.len() {
        bail!(
            "{}: none of the bus map's interfaces ({}) is in the log (it has {}); is it a log of this skin?",
            args.log.display(),
            map.buses
                .iter()
                .map(|b| b.interface.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            log.interfaces.join(", ")
        );
    }
    let ids = map.taxel_ids();
    let mut csv = String::new();
    if args.output.is_some() {
        csv.push_str("t_us,cycle,complete");
        for id in &ids {
            let _ = write!(csv, ",{id}");
        }
        csv.push('\n');
    }
    let mut missing_count: std::collections::BTreeMap<(u16, u32), u64> = Default::default();
    let mut assembler = Assembler::new(&map, &log.interfaces, Skin16);
    let mut emit = |f: &skin_can::AssembledFrame| {
        for m in &f.missing {
            *missing_count.entry((m.bus, m.address)).or_default() += 1;
        }
        if args.output.is_some() {
            let _ = write!(csv, "{},{},{}", f.time_us, f.cycle, u8::from(f.is_complete()));
            for v in &f.values {
                match v {
                    Some(v) => {
                        let _ = write!(csv, ",{v}");
                    }
                    None => csv.push(','),
                }
            }
            csv.push('\n');
        }
    };
    for frame in &log.frames {
        assembler.push(frame, &mut emit);
    }
    assembler.finish(&mut emit);
    let s = assembler.stats();
    let span = match (log.frames.first(), log.frames.last()) {
        (Some(a), Some(b)) => (b.time_us.saturating_sub(a.time_us)) as f64 * 1e-6,
        _ => 0.0,
    };
    crate::say!(
        "{}: {} CAN frames over {span:.2} s on {} bus(es) -> {} skin frames of {} taxels: {} complete, {} partial",
        args.log.display(),
        log.frames.len(),
        map.buses.len(),
        s.frames,
        ids.len(),
        s.complete,
        s.frames - s.complete
    );
    for name in &unknown {
        crate::say!("bus \"{name}\" of the map is not in the log: its modules are missing in every frame");
    }
    let mut worst: Vec<_> = missing_count.into_iter().collect();
    worst.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    for ((bus, address), n) in worst.iter().take(10) {
        crate::say!(
            "  module {address} on {} missing in {n} frame(s)",
            map.buses[usize::from(*bus)].interface
        );
    }
    let unusable = [
        ("data from modules not in the bus map", s.unknown_module),
        ("data before the first sync of its bus", s.before_first_sync),
        ("data for a cycle already delivered (late)", s.late),
    ];
    for (what, n) in unusable.iter().filter(|(_, n)| *n > 0) {
        crate::say!("unused CAN frames: {n} {what}");
    }
    for (what, n) in &s.malformed {
        crate::say!("malformed CAN frames: {n} {what}");
    }
    if let Some(out) = &args.output {
        crate::write_atomic(out, csv.as_bytes()).with_context(|| format!("{}", out.display()))?;
        crate::say!("wrote {}", out.display());
    }
    Ok(())
}

//! `skin replay`: a candump log -> assembled skin frames (summary, CSV).

use crate::output::OutputFile;
use anyhow::{Context, Result, bail};
use skin_can::FRAMES_CSV_HEADER as CSV_HEADER;
use skin_can::candump::CandumpReader;
use skin_can::{BusMap, WireFormat};
use skin_core::TaxelId;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Replay a candump log through a bus map into skin frames; say what was missing.
///
/// One frame of the whole skin is assembled per cycle. LOG is a candump log (can-utils `candump -l` or python-can; gzip-compressed too), of any
/// length: it is read as it goes, the CSV written row by row. MAP is the bus map (TOML: wire
/// format, buses, modules, taxel ids per slot). skin16 traffic is cut into cycles at its sync
/// frames; icub8 traffic, which has no sync, into time windows of --window-ms.
///
/// Prints frames, complete and partial counts, the modules missing or duplicated most often, and
/// frames that could not be used, by kind. With -o, writes every frame as CSV: `t_us,cycle,complete,`
/// then one column per taxel id in bus-map order (bus, module, slot; unused slots skipped), values
/// as on the wire (no baseline, no inversion), empty cells where a partial frame lacks a value.
/// With --layout, checks that every taxel of the bus map is in the layout and says which taxels of
/// the layout no bus carries.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// candump log.
    pub(crate) log: PathBuf,
    /// Bus map (TOML).
    #[arg(long, value_name = "MAP.toml")]
    pub(crate) busmap: PathBuf,
    /// Layout the bus map should cover (any file `skin flatten` reads).
    #[arg(long, value_name = "L.json")]
    pub(crate) layout: Option<PathBuf>,
    /// Time window of sync-less formats (icub8), milliseconds: the boards' period.
    #[arg(long, default_value_t = 50.0, value_name = "MS")]
    pub(crate) window_ms: f64,
    /// Write the frames as CSV.
    #[arg(short, long, value_name = "frames.csv")]
    pub(crate) output: Option<PathBuf>,
}

/// Checks the bus map against a layout: every taxel on the wire must be in the layout.
fn check_layout(map: &BusMap, map_path: &Path, layout: &Path) -> Result<()> {
    let link = crate::shared::load_input(layout)?;
    let in_layout: std::collections::HashSet<_> = link.ids().into_iter().collect();
    let on_bus = map.taxel_ids();
    if let Some(id) = on_bus.iter().find(|id| !in_layout.contains(id)) {
        bail!(
            "{}: taxel {id} is not in the layout {} ({} taxels); is the bus map for this skin?",
            map_path.display(),
            layout.display(),
            in_layout.len()
        );
    }
    let carried: std::collections::HashSet<_> = on_bus.into_iter().collect();
    let mut unmapped: Vec<_> = link
        .ids()
        .into_iter()
        .filter(|id| !carried.contains(id))
        .collect();
    unmapped.sort();
    if unmapped.is_empty() {
        crate::say!(
            "{}: all {} taxels are on a bus",
            layout.display(),
            in_layout.len()
        );
    } else {
        let shown: Vec<String> = unmapped.iter().take(8).map(ToString::to_string).collect();
        crate::say!(
            "{}: {} of {} taxels are on no bus of the map: {}{}",
            layout.display(),
            unmapped.len(),
            in_layout.len(),
            shown.join(", "),
            if unmapped.len() > 8 { ", ..." } else { "" }
        );
    }
    Ok(())
}

/// The frames' CSV, built aside, with its header: time, completeness, then one column a taxel.
fn create_csv(path: &Path, inputs: &crate::output::Inputs, ids: &[TaxelId]) -> Result<OutputFile> {
    let mut file = OutputFile::create(path, inputs)?;
    let mut header = String::from(CSV_HEADER);
    for id in ids {
        let _ = write!(header, ",{id}");
    }
    header.push('\n');
    file.write_all(header.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(file)
}

pub fn run(args: Args) -> Result<()> {
    if !(args.window_ms.is_finite() && args.window_ms >= 0.001) {
        bail!(
            "--window-ms must be a time of at least 1 microsecond, not {}",
            args.window_ms
        );
    }
    let inputs = crate::output::Inputs::new(
        [Some(&args.log), Some(&args.busmap), args.layout.as_ref()]
            .into_iter()
            .flatten(),
    );
    inputs.check_outputs(&[("-o", args.output.as_deref())])?;
    crate::output::replaceable(
        &inputs,
        args.output.as_deref(),
        crate::output::Kind::Table(CSV_HEADER),
    )?;
    let map = BusMap::read(&args.busmap)?;
    if let Some(layout) = &args.layout {
        check_layout(&map, &args.busmap, layout)?;
    }
    // The log is read one frame at a time and each skin frame's row written as it is
    // assembled: memory does not grow with the log. A log of another skin is found at its end;
    // the CSV, built aside, then never appears.
    let mut log = CandumpReader::open(&args.log)?;
    let ids = map.taxel_ids();
    let mut csv = match &args.output {
        Some(path) => Some(create_csv(path, &inputs, &ids)?),
        None => None,
    };
    let window_us = (args.window_ms * 1000.0).round() as u64;
    let mut row = String::new();
    // The first write error stops the rows (and the log).
    let mut failed = None::<std::io::Error>;
    let replay = skin_can::replay(&mut log, &map, window_us, &mut |f| {
        if let Some(file) = csv.as_mut() {
            row.clear();
            f.csv_row(&mut row);
            failed = file.write_all(row.as_bytes()).err();
        }
        failed.is_none()
    })?;
    if let (Some(e), Some(path)) = (failed, &args.output) {
        return Err(anyhow::Error::new(e).context(format!("cannot write {}", path.display())));
    }
    replay.check(&args.log, &map)?;
    let s = &replay.stats;
    let cut = match map.format {
        WireFormat::Skin16 => "one per sync cycle".to_string(),
        WireFormat::Icub8 => format!("one per {} ms window", args.window_ms),
    };
    crate::say!(
        "{}: {} CAN frames over {:.2} s on {} bus(es), {} -> {} skin frames ({cut}) of {} taxels: {} complete, {} partial",
        args.log.display(),
        replay.can_frames,
        replay.span_s,
        map.buses.len(),
        map.format.name(),
        s.frames,
        ids.len(),
        s.complete,
        s.frames - s.complete
    );
    for name in &replay.missing_buses {
        crate::say!("bus \"{name}\" of the map is not in the log: its modules are missing in every frame");
    }
    crate::shared::say_report(&replay.tally, &map, s);
    if replay.error_frames > 0 {
        crate::say!("CAN error frames in the log, skipped: {}", replay.error_frames);
    }
    if let Some(file) = csv {
        let path = file.path().to_owned();
        file.commit()?;
        crate::say!("wrote {}", path.display());
    }
    Ok(())
}

//! `skin live` and `skin record`: CAN interfaces -> assembled frames, a candump recording, or both.

use anyhow::{Context, Result, bail};
use skin_can::BusMap;
use skin_can::live::LiveOptions;
use skin_can::recorder::{Recorder, RecorderNote};
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// Options shared by `skin live` and `skin record`.
#[derive(clap::Args)]
pub struct Common {
    /// Bus map (TOML): wire format, buses, modules, taxel ids per slot.
    #[arg(long, value_name = "MAP.toml")]
    busmap: PathBuf,
    /// SocketCAN interfaces to read, comma-separated (default: the bus map's interfaces).
    #[arg(long, value_delimiter = ',', value_name = "can0,can1")]
    can: Vec<String>,
    /// Act as skin16 bus master: send the sync frame on every interface every --period-ms.
    #[arg(long)]
    master: bool,
    /// Acquisition period, milliseconds: the master's sync period, and the icub8 time window.
    #[arg(long, default_value_t = 50.0, value_name = "MS")]
    period_ms: f64,
    /// Stop after this many seconds (default: at Ctrl-C).
    #[arg(long, value_name = "S")]
    duration: Option<f64>,
}

/// Read skin traffic live from SocketCAN: frames assembled, a status line a second.
///
/// The status line gives the frames, complete and partial, and the modules missing. Linux only (SocketCAN). skin16 skins need a master sending the sync: pass --master unless
/// another node does. An interface that goes down (unplugged adapter, bus-off) is reported and
/// reopened every half second. Stop with Ctrl-C or --duration; the summary is printed then.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct LiveArgs {
    #[command(flatten)]
    common: Common,
    /// Also record every CAN frame to this candump log.
    #[arg(long, value_name = "LOG")]
    record: Option<PathBuf>,
    /// Write the assembled frames as CSV (the form `skin replay -o` writes).
    #[arg(short, long, value_name = "frames.csv")]
    output: Option<PathBuf>,
}

/// Record skin traffic from SocketCAN interfaces to a candump log.
///
/// The log has the form can-utils' `candump -l` and python-can write; replay it with `skin
/// replay`. Linux only (SocketCAN), kernel receive timestamps. With --master, the skin16 sync is sent on
/// every interface every --period-ms and recorded too (marked T). Frames are written as they
/// arrive; a summary of the assembled frames is printed at the end (Ctrl-C or --duration).
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct RecordArgs {
    #[command(flatten)]
    common: Common,
    /// The candump log to write.
    #[arg(short, long, value_name = "LOG")]
    output: PathBuf,
}

pub fn live(args: LiveArgs) -> Result<()> {
    session(&args.common, args.record.as_deref(), args.output.as_deref(), true)
}

pub fn record(args: RecordArgs) -> Result<()> {
    session(&args.common, Some(&args.output), None, false)
}

fn session(common: &Common, record: Option<&Path>, csv: Option<&Path>, status: bool) -> Result<()> {
    let inputs = crate::output::Inputs::new([&common.busmap]);
    inputs.check_outputs(&[("--record", record), ("-o", csv)])?;
    crate::output::replaceable(&inputs, record, crate::output::Kind::CandumpLog)?;
    crate::output::replaceable(
        &inputs,
        csv,
        crate::output::Kind::Table(skin_can::FRAMES_CSV_HEADER),
    )?;
    let map = BusMap::read(&common.busmap)?;
    if !(common.period_ms.is_finite() && common.period_ms >= 0.1) {
        bail!("--period-ms must be at least 0.1, not {}", common.period_ms);
    }
    if let Some(d) = common.duration
        && !(d.is_finite() && d > 0.0)
    {
        bail!("--duration must be a positive number of seconds, not {d}");
    }
    let names = crate::shared::interfaces(&map, &common.can);
    let period = Duration::from_secs_f64(common.period_ms / 1000.0);
    let options = LiveOptions {
        sync_period: common.master.then_some(period),
        ..LiveOptions::default()
    };
    let log = match record {
        Some(path) => Some(crate::output::OutputFile::create(path, &inputs)?),
        None => None,
    };
    let mut recorder = Recorder::new(log, csv.is_some(), &map);
    let ports = skin_can::recorder::open_system_ports(&names)?;
    crate::output::stop_gracefully();
    let stop = crate::output::stop_flag();
    let deadline = common
        .duration
        .map(|d| Instant::now() + Duration::from_secs_f64(d));
    crate::say!(
        "reading {} ({}){}; Ctrl-C stops",
        names.join(", "),
        map.format.name(),
        if common.master {
            format!(", sending the sync every {} ms", common.period_ms)
        } else {
            String::new()
        }
    );
    let done = || stop.load(Ordering::SeqCst) || deadline.is_some_and(|d| Instant::now() >= d);
    let s = recorder
        .run(ports, options, &map, period, done, &mut |n| say_note(n, status))
        .with_context(|| format!("cannot write {}", record.unwrap_or(Path::new("")).display()))?;
    crate::say!(
        "{} CAN frames -> {} skin frames of {} taxels: {} complete, {} partial; {} interface outage(s)",
        recorder.can_frames,
        s.frames,
        map.taxel_ids().len(),
        s.complete,
        s.frames - s.complete,
        recorder.outages
    );
    crate::shared::say_report(&recorder.tally, &map, &s);
    let can_frames = recorder.can_frames;
    // The recording is renamed into place only now, so an interrupted write never leaves a
    // truncated log under the final name.
    let (log, table) = recorder.into_parts();
    if let (Some(out), Some(path)) = (log, record) {
        out.commit()?;
        crate::say!("wrote {} ({can_frames} CAN frames)", path.display());
    }
    if let (Some(table), Some(path)) = (table, csv) {
        crate::output::write_file(path, table.as_bytes(), &inputs)?;
        crate::say!("wrote {}", path.display());
    }
    Ok(())
}

/// Says an outage, or (with `status`) the counts once a second.
fn say_note(note: RecorderNote<'_>, status: bool) {
    match note {
        RecorderNote::Second {
            elapsed_s,
            can_frames,
            stats: s,
        } if status => crate::say!(
            "{elapsed_s:>5.0} s: {can_frames} CAN frames, {} skin frames ({} complete, {} partial)",
            s.frames,
            s.complete,
            s.frames - s.complete
        ),
        RecorderNote::Second { .. } => {}
        RecorderNote::Down { interface, error } => crate::say!("{interface}: {error}; reopening"),
        RecorderNote::Reopened { interface } => crate::say!("{interface}: open again"),
    }
}

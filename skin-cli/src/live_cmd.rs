//! `skin live` and `skin record`: CAN interfaces -> assembled frames, a candump recording, or both.

use anyhow::{Context, Result, bail};
use skin_can::candump::{CanFrame, write_line};
use skin_can::live::{CanPort, Live, LiveOptions};
use skin_can::{AssembledFrame, BusMap};
use std::fmt::Write as _;
use std::io::Write as _;
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

/// Read skin traffic live from SocketCAN interfaces, assemble frames and print a status line
/// every second (frames, complete and partial, modules missing).
///
/// Linux only (SocketCAN). skin16 skins need a master sending the sync: pass --master unless
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

/// Record skin traffic from SocketCAN interfaces to a candump log (the form can-utils'
/// `candump -l` and python-can write; replay it with `skin replay`).
///
/// Linux only (SocketCAN), kernel receive timestamps. With --master, the skin16 sync is sent on
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

/// Where a session's frames go.
struct Sinks {
    /// Candump log being written (moved into place when the session ends).
    log: Option<crate::output::OutputFile>,
    csv: Option<(PathBuf, String)>,
    status: bool,
    /// One candump line, reused for every CAN frame.
    line: String,
}

/// What a session saw.
#[derive(Default)]
struct Summary {
    can_frames: u64,
    outages: Vec<String>,
    tally: skin_can::ModuleTally,
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
    let names: Vec<String> = if common.can.is_empty() {
        map.buses.iter().map(|b| b.interface.clone()).collect()
    } else {
        common.can.clone()
    };
    let period = Duration::from_secs_f64(common.period_ms / 1000.0);
    let options = LiveOptions {
        sync_period: common.master.then_some(period),
        ..LiveOptions::default()
    };
    let mut sinks = Sinks::new(record, csv, &map, status, &inputs)?;
    let ports = crate::shared::open_ports(&names)?;
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
    let summary = run(ports, options, &map, period, &mut sinks, || {
        stop.load(Ordering::SeqCst) || deadline.is_some_and(|d| Instant::now() >= d)
    })?;
    sinks.finish(&summary, &inputs)?;
    Ok(())
}

/// The session loop: CAN frames to the sinks, assembled frames to the tally, until `done`.
fn run<P: CanPort>(
    ports: Vec<P>,
    options: LiveOptions,
    map: &BusMap,
    period: Duration,
    sinks: &mut Sinks,
    done: impl FnMut() -> bool,
) -> Result<Summary> {
    let mut summary = Summary::default();
    let started = Instant::now();
    let mut next_status = Duration::from_secs(1);
    let mut result = Ok(());
    let status = sinks.status;
    let s = crate::shared::acquire(ports, options, map, period, done, &mut |step, interfaces| {
        match step {
            crate::shared::LiveStep::Item(item) => {
                on_item(item, &mut summary, sinks, interfaces, &mut result)
            }
            crate::shared::LiveStep::Polled(s) if status && started.elapsed() >= next_status => {
                next_status += Duration::from_secs(1);
                crate::say!(
                    "{:>5.0} s: {} CAN frames, {} skin frames ({} complete, {} partial)",
                    started.elapsed().as_secs_f64(),
                    summary.can_frames,
                    s.frames,
                    s.complete,
                    s.frames - s.complete
                );
            }
            crate::shared::LiveStep::Polled(_) => {}
        }
        result.is_ok()
    });
    result?;
    crate::say!(
        "{} CAN frames -> {} skin frames of {} taxels: {} complete, {} partial; {} interface outage(s)",
        summary.can_frames,
        s.frames,
        map.taxel_ids().len(),
        s.complete,
        s.frames - s.complete,
        summary.outages.len()
    );
    crate::shared::say_report(&summary.tally, map, &s);
    Ok(summary)
}

/// One item of the acquisition: CAN frames to the recording, skin frames to the tally and the
/// CSV, outages said.
fn on_item(
    item: Live<'_>,
    summary: &mut Summary,
    sinks: &mut Sinks,
    interfaces: &[String],
    result: &mut Result<()>,
) {
    match item {
        Live::Can(f) => {
            summary.can_frames += 1;
            if result.is_ok() {
                *result = sinks.frame(f, interfaces);
            }
        }
        Live::Frame(a) => {
            summary.tally.add(a);
            sinks.assembled(a);
        }
        Live::Down { interface, error } => {
            let line = format!("{interface}: {error}; reopening");
            crate::say!("{line}");
            summary.outages.push(line);
        }
        Live::Reopened { interface } => crate::say!("{interface}: open again"),
    }
}

impl Sinks {
    fn new(
        record: Option<&Path>,
        csv: Option<&Path>,
        map: &BusMap,
        status: bool,
        inputs: &crate::output::Inputs,
    ) -> Result<Sinks> {
        let log = match record {
            Some(path) => Some(crate::output::OutputFile::create(path, inputs)?),
            None => None,
        };
        let csv = csv.map(|p| {
            let mut s = String::from(skin_can::FRAMES_CSV_HEADER);
            for id in map.taxel_ids() {
                let _ = write!(s, ",{id}");
            }
            s.push('\n');
            (p.to_owned(), s)
        });
        Ok(Sinks {
            log,
            csv,
            status,
            line: String::with_capacity(64),
        })
    }

    fn frame(&mut self, f: &CanFrame, interfaces: &[String]) -> Result<()> {
        if let Some(out) = &mut self.log {
            self.line.clear();
            write_line(&mut self.line, f, &interfaces[usize::from(f.bus)]);
            out.write_all(self.line.as_bytes())
                .with_context(|| format!("cannot write {}", out.path().display()))?;
        }
        Ok(())
    }

    fn assembled(&mut self, f: &AssembledFrame) {
        if let Some((_, csv)) = &mut self.csv {
            f.csv_row(csv);
        }
    }

    /// Closes the recording (renamed into place only now, so an interrupted write never leaves a
    /// truncated log under the final name) and writes the CSV.
    fn finish(self, summary: &Summary, inputs: &crate::output::Inputs) -> Result<()> {
        if let Some(out) = self.log {
            let path = out.path().to_owned();
            out.commit()?;
            crate::say!("wrote {} ({} CAN frames)", path.display(), summary.can_frames);
        }
        if let Some((path, csv)) = self.csv {
            crate::output::write_file(&path, csv.as_bytes(), inputs)?;
            crate::say!("wrote {}", path.display());
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

    use super::*;
    use skin_can::candump::Direction;
    use skin_can::decode::skin16::encode_module;
    use std::collections::VecDeque;

    /// A bus whose modules answer every sync sent on it.
    struct Bus {
        name: String,
        modules: Vec<u32>,
        queue: VecDeque<CanFrame>,
    }

    impl CanPort for Bus {
        fn name(&self) -> &str {
            &self.name
        }
        fn open(&mut self) -> std::io::Result<()> {
            Ok(())
        }
        fn close(&mut self) {}
        fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<CanFrame>> {
            if self.queue.is_empty() {
                std::thread::sleep(timeout.min(Duration::from_millis(1)));
            }
            Ok(self.queue.pop_front())
        }
        fn send(&mut self, sync: &CanFrame) -> std::io::Result<()> {
            for &a in &self.modules {
                let readings = std::array::from_fn(|s| u16::from(sync.bytes[0]) + s as u16);
                for mut f in encode_module(a, &readings, sync.time_us + 100, 0) {
                    f.direction = Some(Direction::Received);
                    self.queue.push_back(f);
                }
            }
            Ok(())
        }
    }

    /// A 2 ms sync sent by us, and a bus whose module 2 answers it.
    fn master_and_module_2() -> (Duration, LiveOptions, Bus) {
        let period = Duration::from_millis(2);
        let options = LiveOptions {
            sync_period: Some(period),
            ..LiveOptions::default()
        };
        let bus = Bus {
            name: "can0".into(),
            modules: vec![2],
            queue: VecDeque::new(),
        };
        (period, options, bus)
    }

    #[test]
    fn a_recorded_session_replays_to_the_frames_it_assembled_live() {
        let map = BusMap::parse(
            "format = \"skin16\"\n[[bus]]\ninterface = \"can0\"\n[[bus.module]]\naddress = 2\ntaxels = [16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26, -1]\n",
            Path::new("m.toml"),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let (log, csv) = (dir.path().join("s.log"), dir.path().join("live.csv"));
        let mut sinks = Sinks::new(Some(&log), Some(&csv), &map, false, &Default::default()).unwrap();
        let (period, options, bus) = master_and_module_2();
        let mut calls = 0;
        // Stop after a number of loop turns, not a time: the test must not depend on speed.
        let summary = run(vec![bus], options, &map, period, &mut sinks, || {
            calls += 1;
            calls > 400
        })
        .unwrap();
        assert!(!log.exists(), "the log appears only when complete");
        sinks.finish(&summary, &Default::default()).unwrap();
        let live_csv = std::fs::read_to_string(&csv).unwrap();
        assert!(live_csv.lines().count() > 2, "{live_csv}");
        // The recording replays, offline, to the same frames.
        let recorded = skin_can::candump::CandumpLog::read(&log).unwrap();
        let mut assembler = skin_can::Assembler::for_map(&map, &recorded.interfaces, 50_000);
        let mut replayed = live_csv.lines().next().unwrap().to_string() + "\n";
        for f in &recorded.frames {
            assembler.push(f, &mut |a| a.csv_row(&mut replayed));
        }
        assembler.finish(&mut |a| a.csv_row(&mut replayed));
        assert_eq!(replayed, live_csv);
    }
}

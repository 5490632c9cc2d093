//! Live runs: the one acquisition loop of every live consumer ([`run_live`]), the system's CAN
//! ports ([`open_system_ports`]), and a [`Recorder`] that keeps what a session read (every CAN
//! frame as a candump log, every assembled frame as a CSV row, a tally of the modules).

use crate::candump::{CanFrame, write_line};
use crate::live::{CanPort, Live, LiveFrames, LiveOptions};
use crate::{AssembledFrame, AssemblyStats, BusMap, ModuleTally};
use std::fmt::Write as _;
use std::time::{Duration, Instant};

/// One step of [`run_live`]: an item of the acquisition, or the assembler's counts after a
/// poll.
#[derive(Debug, Clone, Copy)]
pub enum LiveStep<'a> {
    /// A CAN frame, an assembled frame or an interface's outage, in arrival order.
    Item(Live<'a>),
    /// The assembler's counts after a poll (also when nothing came).
    Polled(&'a AssemblyStats),
}

/// Reads `ports` and assembles frames of `map` (`period`: the icub8 time window) until `done`
/// or `each` returns false, handing every step to `each` with the interfaces' names (bus `k` is
/// interface `k`). Returns the assembler's counts at the end; the frame still being assembled
/// is handed on first.
pub fn run_live<P: CanPort>(
    ports: Vec<P>,
    options: LiveOptions,
    map: &BusMap,
    period: Duration,
    mut done: impl FnMut() -> bool,
    each: &mut dyn FnMut(LiveStep<'_>, &[String]) -> bool,
) -> AssemblyStats {
    let mut frames = LiveFrames::start(ports, options, map, period);
    let interfaces = frames.interfaces().to_vec();
    let mut go = true;
    while go && !done() {
        frames.poll(Duration::from_millis(50), &mut |i| {
            go = go && each(LiveStep::Item(i), &interfaces)
        });
        go = go && each(LiveStep::Polled(frames.stats()), &interfaces);
    }
    let s = frames.finish(&mut |i| go = go && each(LiveStep::Item(i), &interfaces));
    if go {
        each(LiveStep::Polled(&s), &interfaces);
    }
    s
}

/// This system's CAN port: Linux SocketCAN with the `socketcan` feature.
#[cfg(all(target_os = "linux", feature = "socketcan"))]
pub type SystemPort = crate::live::socketcan::SocketCanPort;

/// This system's CAN port: none without Linux SocketCAN ([`open_system_ports`] says so).
#[cfg(not(all(target_os = "linux", feature = "socketcan")))]
pub type SystemPort = NoPort;

/// The system's CAN interfaces `names`, each opened once to check it
/// ([`crate::live::socketcan::SocketCanPort::open_all`]); an error on a system without
/// SocketCAN.
pub fn open_system_ports(names: &[String]) -> std::io::Result<Vec<SystemPort>> {
    #[cfg(all(target_os = "linux", feature = "socketcan"))]
    return crate::live::socketcan::SocketCanPort::open_all(names);
    #[cfg(not(all(target_os = "linux", feature = "socketcan")))]
    {
        let _ = names;
        Err(std::io::Error::other(
            "live CAN input needs Linux SocketCAN; this build has none (build skin-cli on Linux)",
        ))
    }
}

/// Stands in for a port type on builds without SocketCAN: it never opens.
#[cfg(not(all(target_os = "linux", feature = "socketcan")))]
#[derive(Debug)]
pub struct NoPort;

#[cfg(not(all(target_os = "linux", feature = "socketcan")))]
impl CanPort for NoPort {
    fn name(&self) -> &str {
        ""
    }
    fn open(&mut self) -> std::io::Result<()> {
        Err(std::io::Error::other("no SocketCAN"))
    }
    fn close(&mut self) {}
    fn recv(&mut self, _: Duration) -> std::io::Result<Option<CanFrame>> {
        Ok(None)
    }
    fn send(&mut self, _: &CanFrame) -> std::io::Result<()> {
        Ok(())
    }
}

/// What a [`Recorder`] tells its caller while it runs.
#[derive(Debug, Clone, Copy)]
pub enum RecorderNote<'a> {
    /// Once a second: the seconds since the start, the CAN frames so far, and the assembler's
    /// counts.
    Second {
        /// Seconds since the start (whole seconds, as they pass).
        elapsed_s: f64,
        /// CAN frames read so far.
        can_frames: u64,
        /// The assembler's counts.
        stats: &'a AssemblyStats,
    },
    /// An interface failed; it is reopened.
    Down {
        /// Its name.
        interface: &'a str,
        /// What the system said.
        error: &'a str,
    },
    /// An interface is open again.
    Reopened {
        /// Its name.
        interface: &'a str,
    },
}

/// Keeps what a live session reads: every CAN frame as a candump line in `W` (a log being
/// written), every assembled frame as a CSV row (the form of [`crate::FRAMES_CSV_HEADER`]),
/// and a tally of the modules each frame lacked.
#[derive(Debug)]
pub struct Recorder<W> {
    log: Option<W>,
    csv: Option<String>,
    /// One candump line, reused for every CAN frame.
    line: String,
    /// CAN frames read.
    pub can_frames: u64,
    /// Interface outages seen.
    pub outages: usize,
    /// The modules missing or duplicated, per frame.
    pub tally: ModuleTally,
}

impl<W: std::io::Write> Recorder<W> {
    /// A recorder writing candump lines to `log` (if any) and, with `csv`, building the table of
    /// the frames of `map` (its header and one column per taxel id).
    pub fn new(log: Option<W>, csv: bool, map: &BusMap) -> Recorder<W> {
        let csv = csv.then(|| {
            let mut s = String::from(crate::FRAMES_CSV_HEADER);
            for id in map.taxel_ids() {
                let _ = write!(s, ",{id}");
            }
            s.push('\n');
            s
        });
        Recorder {
            log,
            csv,
            line: String::with_capacity(64),
            can_frames: 0,
            outages: 0,
            tally: ModuleTally::default(),
        }
    }

    /// Reads `ports` through [`run_live`] until `done`, keeping every item; tells `note` of
    /// outages and, once a second, of the counts. The first write error to the log stops the
    /// run and is returned. Returns the assembler's counts.
    pub fn run<P: CanPort>(
        &mut self,
        ports: Vec<P>,
        options: LiveOptions,
        map: &BusMap,
        period: Duration,
        done: impl FnMut() -> bool,
        note: &mut dyn FnMut(RecorderNote<'_>),
    ) -> std::io::Result<AssemblyStats> {
        let started = Instant::now();
        let mut next_second = Duration::from_secs(1);
        let mut result = Ok(());
        let s = run_live(ports, options, map, period, done, &mut |step, interfaces| {
            match step {
                LiveStep::Item(item) => {
                    if let Err(e) = self.item(item, interfaces, note) {
                        result = Err(e);
                    }
                }
                LiveStep::Polled(stats) if started.elapsed() >= next_second => {
                    next_second += Duration::from_secs(1);
                    let elapsed_s = started.elapsed().as_secs_f64();
                    let can_frames = self.can_frames;
                    note(RecorderNote::Second {
                        elapsed_s,
                        can_frames,
                        stats,
                    });
                }
                LiveStep::Polled(_) => {}
            }
            result.is_ok()
        });
        result.map(|()| s)
    }

    /// One item: a CAN frame to the log, a skin frame to the tally and the table, an outage
    /// told.
    fn item(
        &mut self,
        item: Live<'_>,
        interfaces: &[String],
        note: &mut dyn FnMut(RecorderNote<'_>),
    ) -> std::io::Result<()> {
        match item {
            Live::Can(f) => {
                self.can_frames += 1;
                self.frame(f, interfaces)?;
            }
            Live::Frame(a) => self.assembled(a),
            Live::Down { interface, error } => {
                self.outages += 1;
                note(RecorderNote::Down { interface, error });
            }
            Live::Reopened { interface } => note(RecorderNote::Reopened { interface }),
        }
        Ok(())
    }

    fn frame(&mut self, f: &CanFrame, interfaces: &[String]) -> std::io::Result<()> {
        if let Some(out) = &mut self.log {
            self.line.clear();
            let name = interfaces.get(usize::from(f.bus)).map_or("?", String::as_str);
            write_line(&mut self.line, f, name);
            out.write_all(self.line.as_bytes())?;
        }
        Ok(())
    }

    fn assembled(&mut self, f: &AssembledFrame) {
        self.tally.add(f);
        if let Some(csv) = &mut self.csv {
            f.csv_row(csv);
        }
    }

    /// The log and the table, to be put in place.
    pub fn into_parts(self) -> (Option<W>, Option<String>) {
        (self.log, self.csv)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

    use super::*;
    use crate::candump::Direction;
    use crate::decode::skin16::encode_module;
    use skin_core::output::{Inputs, OutputFile};
    use std::collections::VecDeque;
    use std::path::Path;

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
        let file = OutputFile::create(&log, &Inputs::default()).unwrap();
        let mut recorder = Recorder::new(Some(file), true, &map);
        let (period, options, bus) = master_and_module_2();
        let mut calls = 0;
        // Stop after a number of loop turns, not a time: the test must not depend on speed.
        recorder
            .run(
                vec![bus],
                options,
                &map,
                period,
                || {
                    calls += 1;
                    calls > 400
                },
                &mut |_| {},
            )
            .unwrap();
        assert!(!log.exists(), "the log appears only when complete");
        let (file, table) = recorder.into_parts();
        file.unwrap().commit().unwrap();
        std::fs::write(&csv, table.unwrap()).unwrap();
        let live_csv = std::fs::read_to_string(&csv).unwrap();
        assert!(live_csv.lines().count() > 2, "{live_csv}");
        // The recording replays, offline, to the same frames.
        let recorded = crate::candump::CandumpLog::read(&log).unwrap();
        let mut assembler = crate::Assembler::for_map(&map, &recorded.interfaces, 50_000);
        let mut replayed = live_csv.lines().next().unwrap().to_string() + "\n";
        for f in &recorded.frames {
            assembler.push(f, &mut |a| a.csv_row(&mut replayed));
        }
        assembler.finish(&mut |a| a.csv_row(&mut replayed));
        assert_eq!(replayed, live_csv);
    }
}

//! Inputs: assembled CAN frames, whole candump logs and raw recordings, each through
//! [`Session::push_can`] or [`Session::push`] a frame at a time.

use super::Event;
use super::{Flow, InputError, MissingModule, Session, SessionError, Sink, flow, send};
use skin_can::candump::{CanFrame, CanSource, IntoCanSource};
use skin_can::{AssembledFrame, Assembler, AssemblyStats, BusMap, CounterReset};
use skin_core::format::recording::{IntoRecordingSource, RecordingSource};
use skin_core::{Columns, LinkSkin, Recording};
use std::path::Path;
use std::time::{Duration, Instant};

/// CAN frames read and assembled a batch at a time: reading and assembling each keep their own
/// code and data hot (bounded: this many frames).
const BATCH: usize = 256;

/// A candump log being run: its assembler and what the log has shown so far.
struct LogRun {
    assembler: Assembler<Box<dyn skin_can::decode::Decoder + Send>>,
    /// CAN frames read, and the stamps of the first and the last, µs.
    count: usize,
    first_us: u64,
    last_us: u64,
    /// Time spent inside the session (not assembling).
    inside: Duration,
}

impl Session {
    /// One assembled CAN frame (needs [`Session::with_can`]). [`Flow::Break`] once a sink has
    /// said stop (the frame is then not taken).
    pub fn push_can<S: Sink + ?Sized>(
        &mut self,
        frame: &AssembledFrame,
        sink: &mut S,
    ) -> Result<Flow, SessionError> {
        if self.stopped {
            return Ok(flow(true));
        }
        let time = self.time(frame.time_us, sink)?;
        let Some(can) = &self.setup.can else {
            return Err(InputError::NoBusMap.into());
        };
        can.layout.place(frame, &mut self.raw)?;
        if !frame.is_complete() {
            self.stats.incomplete += 1;
            let missing = frame
                .missing
                .iter()
                .map(|m| MissingModule {
                    bus: can
                        .interfaces
                        .get(usize::from(m.bus))
                        .cloned()
                        .unwrap_or_default(),
                    address: m.address,
                })
                .collect();
            send(&mut self.stopped, sink, |s| {
                s.event(&Event::Incomplete { time, missing })
            })?;
        }
        self.step(frame.time_us, time, frame.cycle, frame.is_complete(), sink)?;
        Ok(flow(self.stopped))
    }

    /// Reports the counter restarts `stats` has seen since the last call ([`Event::CounterReset`]);
    /// call it after pushing each CAN frame to the assembler.
    pub fn note_resets<S: Sink + ?Sized>(
        &mut self,
        stats: &AssemblyStats,
        sink: &mut S,
    ) -> Result<Flow, SessionError> {
        if stats.counter_resets > self.stats.counter_resets
            && let Some(r) = &stats.last_reset
        {
            self.stats.counter_resets = stats.counter_resets;
            self.counter_reset(r, sink)?;
        }
        Ok(flow(self.stopped))
    }

    fn counter_reset<S: Sink + ?Sized>(
        &mut self,
        r: &CounterReset,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let t0 = self.t0_us.unwrap_or(r.time_us);
        let bus = self
            .setup
            .can
            .as_ref()
            .and_then(|c| c.interfaces.get(usize::from(r.bus)))
            .map_or("?", String::as_str);
        let event = Event::CounterReset {
            time: r.time_us.saturating_sub(t0) as f64 * 1e-6,
            bus: bus.to_owned(),
            from: r.from,
            to: r.to,
            cycle: r.cycle,
        };
        send(&mut self.stopped, sink, |s| s.event(&event))
    }

    /// A raw recording (Cyskin's `ids / index time counts...` form; `path` names it in errors)
    /// through the session one frame at a time, then [`Session::finish`]: a
    /// [`RecordingReader`](skin_core::format::recording::RecordingReader) on a file of any
    /// length, or a whole [`Recording`] by reference. Each link reads its taxels' columns by id:
    /// a taxel the recording has no column for reads 0 and is dead (its count, with the columns
    /// that are no taxel of the layout, goes to the summary). Frame times are the recording's;
    /// frames are numbered by the recording's frame numbers. Events reach the sink as the frames
    /// are read: a fault further down the file fails the run after them. A sink that says stop
    /// ends the run at that frame ([`Session::stopped`]; nothing more is read or released).
    /// Returns the recording's span (read so far), seconds.
    pub fn run_recording<S: Sink + ?Sized>(
        &mut self,
        rec: impl IntoRecordingSource,
        path: &Path,
        sink: &mut S,
    ) -> Result<f64, SessionError> {
        let mut rec = rec.into_recording_source();
        let columns = self.recording_columns(rec.taxel_ids(), path)?;
        let mut raw: Vec<Vec<f32>> = self
            .setup
            .links
            .iter()
            .map(|l| vec![0.0; l.taxels.len()])
            .collect();
        let (mut first, mut last) = (None, 0.0);
        while let Some(frame) = rec.next_frame()? {
            for (r, c) in raw.iter_mut().zip(&columns) {
                c.gather(frame.values, f32::NEG_INFINITY, r);
            }
            // Times count from the first frame; a recording's times only go forward.
            let t0 = *first.get_or_insert(frame.time);
            last = frame.time;
            let time_us = ((frame.time - t0).max(0.0) * 1e6).round() as u64;
            if self.push(time_us, frame.number, &raw, sink)?.is_break() {
                break;
            }
        }
        // The run ends here whether or not a sink said stop (a stopped session releases nothing).
        let _ = self.finish(sink)?;
        Ok(first.map_or(0.0, |t0| (last - t0).max(0.0)))
    }

    /// Each link's columns of a recording whose header lists `ids`, its notes for the summary,
    /// and the links' dead taxels declared.
    fn recording_columns(
        &mut self,
        ids: &[skin_core::TaxelId],
        path: &Path,
    ) -> Result<Vec<Columns>, SessionError> {
        // The header is all that matching columns to taxels needs.
        let header = Recording {
            taxel_ids: ids.to_vec(),
            ..Recording::default()
        };
        let links = &self.setup.links;
        let columns: Vec<Columns> = links.iter().map(|l| header.columns(&l.ids())).collect();
        // The whole skin at once: a column of one link is not "ignored" by another.
        let all: Vec<skin_core::TaxelId> = links.iter().flat_map(LinkSkin::ids).collect();
        let whole = header.columns(&all);
        if whole.missing.len() == all.len() {
            return Err(InputError::NotRecorded {
                recording: path.to_owned(),
                taxels: all.len(),
                columns: header.taxel_ids.len(),
            }
            .into());
        }
        self.notes.clear();
        if !whole.missing.is_empty() {
            let placeholders = whole.missing.iter().filter(|id| id.is_placeholder()).count();
            self.notes.push(format!(
                "{} taxel(s) of the layout have no column in the recording ({placeholders} of them placeholders): dead, contacts and images bridge them",
                whole.missing.len()
            ));
        }
        if whole.ignored > 0 {
            self.notes.push(format!(
                "{} column(s) of the recording are no taxel of the layout, ignored",
                whole.ignored
            ));
        }
        // Dead taxels are handled as Test B handles removed ones: each link's triangles are made
        // again without them (and made whole again for a recording that has them all).
        self.set_dead(columns.iter().map(Columns::dead).collect())?;
        Ok(columns)
    }

    /// A candump log (`path` names it in errors) through the session one CAN frame at a time,
    /// then [`Session::finish`]: a [`CandumpReader`](skin_can::candump::CandumpReader) on a file
    /// of any length (memory does not grow with the log), a whole
    /// [`CandumpLog`](skin_can::candump::CandumpLog) by reference, or any other [`CanSource`].
    /// `progress(frames, bytes)` is called every 4,096 CAN frames with the frames read so far and
    /// the bytes of text they took ([`CanSource::bytes_read`]). Events reach the sink as the
    /// frames are read: a fault further down the log fails the run after them. A log that is
    /// empty, that has none of the bus map's interfaces or that gives no frame of this skin is
    /// an error naming it, found when the log ends. A sink that says stop ends the run at that
    /// frame ([`Session::stopped`]; nothing more is read or released, the log is not checked).
    /// Returns the log's span (read so far), seconds.
    pub fn run_log<L: IntoCanSource, S: Sink + ?Sized>(
        &mut self,
        log: L,
        path: &Path,
        sink: &mut S,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<f64, SessionError> {
        let mut log = log.into_can_source();
        let Some(busmap) = self.setup.can.as_ref().map(|c| c.busmap.clone()) else {
            return Err(self.no_busmap(&mut log, path));
        };
        // Interfaces are added to the assembler as the log names them.
        let mut run = LogRun {
            assembler: Assembler::for_map(&busmap, &[], skin_can::DEFAULT_WINDOW_US),
            count: 0,
            first_us: 0,
            last_us: 0,
            inside: Duration::ZERO,
        };
        let started = Instant::now();
        let result = self.read_log(&mut log, &mut run, sink, progress);
        if result.is_ok() && !self.stopped {
            let mut error = None;
            run.assembler.finish(&mut |a| {
                if error.is_none() {
                    error = self.push_can(a, sink).err();
                }
            });
            self.stats.assemble += started.elapsed().saturating_sub(run.inside);
            if let Some(e) = error {
                return Err(e);
            }
        } else {
            self.stats.assemble += started.elapsed().saturating_sub(run.inside);
        }
        result?;
        if !self.stopped {
            self.check_log(&log, &run, &busmap, path)?;
            let _ = self.finish(sink)?;
        }
        Ok(run.last_us.saturating_sub(run.first_us) as f64 * 1e-6)
    }

    /// The log's frames, a batch at a time, through the assembler and the session, until the
    /// log ends, fails, or a sink says stop.
    fn read_log<C: CanSource, S: Sink + ?Sized>(
        &mut self,
        log: &mut C,
        run: &mut LogRun,
        sink: &mut S,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(), SessionError> {
        // A log written while it is read goes a frame at a time: its writer may wait for what
        // a frame gives (a simulation in lock-step with the session) before writing more.
        let size = if log.streams() { 1 } else { BATCH };
        let mut batch: Vec<CanFrame> = Vec::with_capacity(size);
        let mut ended = false;
        while !ended && !self.stopped {
            batch.clear();
            let mut read_error = None;
            while batch.len() < size {
                match log.next_frame() {
                    Ok(Some(frame)) => batch.push(frame),
                    Ok(None) => ended = true,
                    Err(e) => read_error = Some(SessionError::from(e)),
                }
                if ended || read_error.is_some() {
                    ended = true;
                    break;
                }
            }
            let named = log.interfaces();
            if named.len() > run.assembler.interfaces() {
                for name in &named[run.assembler.interfaces()..] {
                    run.assembler.add_interface(name);
                }
            }
            self.assemble(&batch, log, run, sink, progress)?;
            if let Some(e) = read_error {
                return Err(e);
            }
        }
        Ok(())
    }

    /// One batch of CAN frames through the assembler, each assembled frame through the session.
    fn assemble<C: CanSource, S: Sink + ?Sized>(
        &mut self,
        batch: &[CanFrame],
        log: &C,
        run: &mut LogRun,
        sink: &mut S,
        progress: &mut dyn FnMut(u64, u64),
    ) -> Result<(), SessionError> {
        let mut error = None;
        for frame in batch {
            if run.count == 0 {
                run.first_us = frame.time_us;
            }
            run.last_us = frame.time_us;
            let inside = &mut run.inside;
            run.assembler.push(frame, &mut |a| {
                if error.is_none() {
                    let t = Instant::now();
                    error = self.push_can(a, sink).err();
                    *inside += t.elapsed();
                }
            });
            if error.is_none() {
                error = self.note_resets(run.assembler.stats(), sink).err();
            }
            if let Some(e) = error {
                return Err(e);
            }
            if run.count.is_multiple_of(4096) {
                progress(run.count as u64, log.bytes_read());
            }
            run.count += 1;
            if self.stopped {
                break;
            }
        }
        Ok(())
    }

    /// Why a log cannot run on a session without a bus map (an empty log is named as such
    /// first).
    fn no_busmap<C: CanSource>(&self, log: &mut C, path: &Path) -> SessionError {
        match log.next_frame() {
            Err(e) => return e.into(),
            Ok(None) => return empty(log, path),
            Ok(Some(_)) => {}
        }
        let whose = if self.setup.source == Path::new("frames") {
            "the session has none (Session::with_can)".to_string()
        } else {
            format!(
                "{} names none: add busmap = \"FILE.toml\" to it",
                self.setup.source.display()
            )
        };
        skin_can::Error::Invalid {
            path: path.to_owned(),
            message: format!(
                "a candump log needs a bus map (which taxel each CAN slot carries), and {whose}"
            ),
        }
        .into()
    }

    /// After the whole log: an error if it was empty, of other buses or of another skin; the
    /// summary's notes about its traffic.
    fn check_log<C: CanSource>(
        &mut self,
        log: &C,
        run: &LogRun,
        busmap: &BusMap,
        path: &Path,
    ) -> Result<(), SessionError> {
        if run.count == 0 {
            return Err(empty(log, path));
        }
        let in_log = log.interfaces();
        let on_map: Vec<String> = busmap.buses.iter().map(|b| b.interface.clone()).collect();
        if !on_map.iter().any(|i| in_log.contains(i)) {
            return Err(InputError::OtherBuses {
                log: path.to_owned(),
                on_map,
                in_log: in_log.to_vec(),
            }
            .into());
        }
        let s = run.assembler.stats();
        self.notes.clear();
        for (n, what) in [
            (log.error_frames() as u64, "CAN error frames in the log, skipped"),
            (s.remote, "remote requests, skipped"),
            (
                s.time_backwards,
                "CAN frames stamped earlier than the frame before them on their interface (kept in log order)",
            ),
        ] {
            if n > 0 {
                self.notes.push(format!("{n} {what}"));
            }
        }
        let data = s.frames * busmap.buses.iter().map(|b| b.modules.len() as u64).sum::<u64>();
        if s.frames == 0 || s.unknown_module > data.max(1) {
            return Err(InputError::NotThisSkin {
                log: path.to_owned(),
                frames: s.frames,
                can_frames: run.count,
                unknown: s.unknown_module,
                malformed: s.malformed.iter().map(|(_, n)| n).sum(),
                format: busmap.format.name(),
                ignored: s.ignored,
            }
            .into());
        }
        Ok(())
    }
}

/// The error of a log without CAN frames: empty, or bus errors only.
fn empty<C: CanSource>(log: &C, path: &Path) -> SessionError {
    let message = match log.error_frames() {
        0 => "no CAN frames in it (an empty log)".to_string(),
        n => format!("no CAN frames but {n} error frame(s): a log of bus errors, without skin traffic"),
    };
    skin_can::Error::Invalid {
        path: path.to_owned(),
        message,
    }
    .into()
}

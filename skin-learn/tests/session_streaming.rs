//! A session fed from streams: a candump log or a recording of any length read one frame at a
//! time, with the same events as the whole file gives, events reaching the sink before the log is
//! read to its end, and the logs that are no skin's traffic named in one line.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::{CandumpLog, CandumpReader};
use skin_core::format::recording::{self, RecordingReader};
use skin_learn::session::{Event, Flow, FromConfig, Session, SessionConfig, Sink};
use std::io::{BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use skin_test_support::long_log;

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures")
}

/// The fixture forearm's session without its models (no classifier: touches appear and are
/// released, undecided); `busmap` false leaves the bus map out.
fn session(dir: &Path, busmap: bool) -> Session {
    let f = fixtures();
    let mut text = format!("layout = {:?}\n", f.join("forearm/layout.json"));
    if busmap {
        text.push_str(&format!("busmap = {:?}\n", f.join("forearm/busmap.toml")));
    }
    text.push_str("cache = \"cache\"\n[baseline]\nframes = 20\n");
    let path = dir.join("run.toml");
    std::fs::write(&path, text).unwrap();
    Session::from_config(&SessionConfig::read(&path).unwrap()).unwrap()
}

fn session_log() -> PathBuf {
    fixtures().join("session/session.candump.log")
}

#[test]
fn a_log_read_as_a_stream_gives_the_events_of_the_whole_log() {
    let dir = tempfile::tempdir().unwrap();
    let whole = CandumpLog::read(&session_log()).unwrap();
    let mut a = session(dir.path(), true);
    let mut from_whole: Vec<Event> = Vec::new();
    let span_a = a
        .run_log(&whole, &session_log(), &mut from_whole, &mut |_, _| {})
        .unwrap();

    let mut b = session(dir.path(), true);
    let mut streamed: Vec<Event> = Vec::new();
    let mut calls = 0;
    let reader = CandumpReader::open(&session_log()).unwrap();
    let span_b = b
        .run_log(reader, &session_log(), &mut streamed, &mut |_, _| calls += 1)
        .unwrap();
    assert!(from_whole.len() > 20, "{from_whole:?}");
    assert_eq!(streamed, from_whole);
    assert_eq!(span_b, span_a);
    assert_eq!(b.summary(span_b).to_string(), a.summary(span_a).to_string());
    // Every 4,096 CAN frames, from the first.
    assert_eq!(calls, whole.frames.len().div_ceil(4096));
}

/// Records how much of the log had been read when the first event came, then stops the run.
struct FirstEvent {
    served: Arc<AtomicU64>,
    at: Option<u64>,
}

impl Sink for FirstEvent {
    type Error = std::io::Error;

    fn event(&mut self, _: &Event) -> std::io::Result<Flow> {
        self.at = Some(self.served.load(Ordering::Relaxed));
        Err(std::io::Error::other("seen enough"))
    }
}

/// Takes events until the first release, then says stop.
struct UntilReleased(Vec<Event>);

impl Sink for UntilReleased {
    type Error = std::convert::Infallible;

    fn event(&mut self, e: &Event) -> Result<Flow, Self::Error> {
        self.0.push(e.clone());
        Ok(match e {
            Event::Released { .. } => Flow::Break(()),
            _ => Flow::Continue(()),
        })
    }
}

#[test]
fn a_sink_that_says_stop_ends_the_run_cleanly_at_that_event() {
    let dir = tempfile::tempdir().unwrap();
    let mut session = session(dir.path(), true);
    let mut sink = UntilReleased(Vec::new());
    let reader = CandumpReader::open(&session_log()).unwrap();
    let span = session
        .run_log(reader, &session_log(), &mut sink, &mut |_, _| {})
        .unwrap();
    assert!(session.stopped());
    assert!(
        matches!(sink.0.last(), Some(Event::Released { .. })),
        "{:?}",
        sink.0
    );
    assert_eq!(
        sink.0
            .iter()
            .filter(|e| matches!(e, Event::Released { .. }))
            .count(),
        1
    );
    assert_eq!(session.stats().touches, 1);
    assert!(span > 0.0 && span < 60.0, "{span}");
    // Frames after the stop are refused, and nothing more reaches the sink.
    let frame = vec![vec![0.0f32; session.links()[0].taxels.len()]];
    assert!(session.push(0, 0, &frame, &mut sink).unwrap().is_break());
    assert!(session.finish(&mut sink).unwrap().is_break());
    assert_eq!(
        sink.0
            .iter()
            .filter(|e| matches!(e, Event::Released { .. }))
            .count(),
        1
    );
}

#[test]
fn events_reach_the_sink_before_the_log_is_read_to_its_end() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(session_log()).unwrap();
    // 20 copies of the session, 110 MB made as it is read: a reader of the whole file would
    // take all of it before the first event.
    let long = long_log::RepeatedLog::new(&text, 20);
    let len = long.len();
    let mut sink = FirstEvent {
        served: long.served(),
        at: None,
    };
    let log = CandumpReader::new(BufReader::new(long), Path::new("long.log"));
    let e = session(dir.path(), true)
        .run_log(log, Path::new("long.log"), &mut sink, &mut |_, _| {})
        .unwrap_err();
    assert!(e.to_string().contains("seen enough"), "{e}");
    let at = sink.at.unwrap();
    // The first touch is in the first copy's first seconds.
    assert!(
        at < text.len() as u64 / 2,
        "{at} of {len} bytes read at the first event"
    );
    assert!(len > 100_000_000);
}

fn run_log_error(session: &mut Session, text: &str, name: &str) -> String {
    let log = CandumpReader::new(text.as_bytes(), Path::new(name));
    session
        .run_log(log, Path::new(name), &mut Vec::<Event>::new(), &mut |_, _| {})
        .unwrap_err()
        .to_string()
}

#[test]
fn an_empty_log_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    for text in ["", "\n\n", "\u{feff}"] {
        let e = run_log_error(&mut session(dir.path(), true), text, "empty.log");
        assert_eq!(e, "empty.log: no CAN frames in it (an empty log)");
        // Before the missing bus map: the log is what is wrong.
        let e = run_log_error(&mut session(dir.path(), false), text, "empty.log");
        assert_eq!(e, "empty.log: no CAN frames in it (an empty log)");
    }
}

#[test]
fn a_log_of_error_frames_only_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let text = "(1.000000) can0 20000004#0004000000000000\n(1.000100) can0 20000004#0004000000000000\n";
    let e = run_log_error(&mut session(dir.path(), true), text, "errors.log");
    assert_eq!(
        e,
        "errors.log: no CAN frames but 2 error frame(s): a log of bus errors, without skin traffic"
    );
}

#[test]
fn a_log_without_a_bus_map_names_the_log_and_the_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(session_log()).unwrap();
    let e = run_log_error(&mut session(dir.path(), false), &text, "s.log");
    assert!(e.starts_with("s.log: a candump log needs a bus map"), "{e}");
    assert!(
        e.contains("run.toml names none: add busmap = \"FILE.toml\""),
        "{e}"
    );
    assert!(!e.contains("Session::"), "{e}");
}

#[test]
fn a_log_of_other_buses_is_one_line_naming_it_and_nothing_reaches_the_sink() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(session_log())
        .unwrap()
        .replace(" can0 ", " can5 ");
    let mut events: Vec<Event> = Vec::new();
    let log = CandumpReader::new(text.as_bytes(), Path::new("other.log"));
    let e = session(dir.path(), true)
        .run_log(log, Path::new("other.log"), &mut events, &mut |_, _| {})
        .unwrap_err()
        .to_string();
    assert_eq!(
        e,
        "other.log: none of the bus map's interfaces (can0) is in the log (it has can5); is it a log of this skin?"
    );
    assert!(events.is_empty());
}

#[test]
fn a_gzip_log_runs_as_the_plain_one() {
    let dir = tempfile::tempdir().unwrap();
    let gz = dir.path().join("session.candump.log.gz");
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(&std::fs::read(session_log()).unwrap()).unwrap();
    std::fs::write(&gz, e.finish().unwrap()).unwrap();
    let run = |path: &Path| {
        let mut events: Vec<Event> = Vec::new();
        session(dir.path(), true)
            .run_log(
                CandumpReader::open(path).unwrap(),
                path,
                &mut events,
                &mut |_, _| {},
            )
            .unwrap();
        events
    };
    assert_eq!(run(&gz), run(&session_log()));
}

#[test]
fn a_recording_read_as_a_stream_gives_the_events_of_the_whole_recording() {
    let dir = tempfile::tempdir().unwrap();
    let path = fixtures().join("forearm/touches.txt");
    let whole = recording::read(&path).unwrap();
    let mut a: Vec<Event> = Vec::new();
    let span_a = session(dir.path(), false)
        .run_recording(&whole, &path, &mut a)
        .unwrap();
    let mut b: Vec<Event> = Vec::new();
    let mut reader = RecordingReader::open(&path).unwrap();
    let span_b = session(dir.path(), false)
        .run_recording(&mut reader, &path, &mut b)
        .unwrap();
    assert!(!a.is_empty());
    assert_eq!((b, span_b), (a, span_a));
    assert_eq!(reader.frames_read(), whole.frames.len() as u64);
}

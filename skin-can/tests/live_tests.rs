//! The live path against scripted ports (this workplace has no SocketCAN): recovery from an
//! interface that goes down, the master's sync on every bus, and a live session that assembles
//! and records exactly what an offline replay of its recording gives.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::{CanFrame, CandumpLog, Direction, write_line};
use skin_can::decode::Skin16;
use skin_can::decode::skin16::encode_module;
use skin_can::live::{Acquisition, CanPort, Live, LiveEvent, LiveFrames, LiveOptions, now_us};
use skin_can::{AssembledFrame, Assembler};
use std::collections::VecDeque;
use std::io::{Error, ErrorKind};
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

enum Step {
    Frame(CanFrame),
    Fail(ErrorKind),
}

/// A scripted interface: plays `script`, fails to open as often as `open_failures` says, and, when
/// `modules` is not empty, answers every sync it is asked to send with those skin16 modules' data.
struct Scripted {
    name: String,
    script: VecDeque<Step>,
    open_failures: usize,
    opens: Arc<Mutex<usize>>,
    sent: Arc<Mutex<Vec<CanFrame>>>,
    modules: Vec<u32>,
}

impl Scripted {
    fn new(name: &str) -> Scripted {
        Scripted {
            name: name.into(),
            script: VecDeque::new(),
            open_failures: 0,
            opens: Arc::default(),
            sent: Arc::default(),
            modules: Vec::new(),
        }
    }
}

fn reading(counter: u8, address: u32, slot: usize) -> u16 {
    u16::from(counter) * 100 + address as u16 * 12 + slot as u16
}

impl CanPort for Scripted {
    fn name(&self) -> &str {
        &self.name
    }
    fn open(&mut self) -> std::io::Result<()> {
        *self.opens.lock().unwrap() += 1;
        if self.open_failures > 0 {
            self.open_failures -= 1;
            return Err(Error::new(ErrorKind::NotFound, "No such device"));
        }
        Ok(())
    }
    fn close(&mut self) {}
    fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<CanFrame>> {
        match self.script.pop_front() {
            Some(Step::Frame(f)) => Ok(Some(f)),
            Some(Step::Fail(kind)) => Err(Error::new(kind, "Network is down")),
            None => {
                std::thread::sleep(timeout.min(Duration::from_millis(1)));
                Ok(None)
            }
        }
    }
    fn send(&mut self, frame: &CanFrame) -> std::io::Result<()> {
        self.sent.lock().unwrap().push(*frame);
        let counter = frame.bytes[0];
        for &a in &self.modules {
            let readings = std::array::from_fn(|s| reading(counter, a, s));
            for mut f in encode_module(a, &readings, now_us(), 0) {
                f.direction = Some(Direction::Received);
                self.script.push_back(Step::Frame(f));
            }
        }
        Ok(())
    }
}

fn data_frame(k: u8) -> CanFrame {
    CanFrame {
        time_us: 1_000 + u64::from(k),
        bus: 7, // the acquisition sets the bus
        id: 0x123,
        extended: false,
        remote: false,
        len: 1,
        bytes: [k, 0, 0, 0, 0, 0, 0, 0],
        direction: Some(Direction::Received),
    }
}

/// Events until `done` says so; fails the test rather than hang if the ports stop talking.
fn collect(acq: &Acquisition, mut done: impl FnMut(&[LiveEvent]) -> bool) -> Vec<LiveEvent> {
    let mut events = Vec::new();
    let give_up = Instant::now() + Duration::from_secs(30);
    while !done(&events) {
        assert!(Instant::now() < give_up, "no progress; events so far: {events:?}");
        if let Some(e) = acq.recv(Duration::from_millis(100)) {
            events.push(e);
        }
    }
    events
}

#[test]
fn an_interface_that_goes_down_is_reported_reopened_and_read_on() {
    let mut port = Scripted::new("can0");
    for k in 0..5 {
        port.script.push_back(Step::Frame(data_frame(k)));
    }
    port.script.push_back(Step::Fail(ErrorKind::NetworkDown));
    for k in 5..10 {
        port.script.push_back(Step::Frame(data_frame(k)));
    }
    let opens = Arc::clone(&port.opens);
    // The first open works; after the failure two reopen attempts fail before one succeeds.
    struct FailLater(Scripted, usize);
    impl CanPort for FailLater {
        fn name(&self) -> &str {
            self.0.name()
        }
        fn open(&mut self) -> std::io::Result<()> {
            self.1 += 1;
            if self.1 == 2 {
                self.0.open_failures = 2;
            }
            self.0.open()
        }
        fn close(&mut self) {}
        fn recv(&mut self, t: Duration) -> std::io::Result<Option<CanFrame>> {
            self.0.recv(t)
        }
        fn send(&mut self, f: &CanFrame) -> std::io::Result<()> {
            self.0.send(f)
        }
    }
    let options = LiveOptions {
        reopen_after: Duration::from_millis(1),
        ..LiveOptions::default()
    };
    let acq = Acquisition::start(vec![FailLater(port, 0)], options);
    let events = collect(&acq, |e| {
        e.iter().filter(|e| matches!(e, LiveEvent::Frame(_))).count() == 10
    });
    acq.stop();
    let frames: Vec<u8> = events
        .iter()
        .filter_map(|e| match e {
            LiveEvent::Frame(f) => Some(f.bytes[0]),
            _ => None,
        })
        .collect();
    assert_eq!(
        frames,
        (0..10).collect::<Vec<_>>(),
        "nothing lost, nothing reordered"
    );
    let down_at = events
        .iter()
        .position(|e| matches!(e, LiveEvent::Down { bus: 0, .. }))
        .unwrap();
    let up_at = events
        .iter()
        .position(|e| *e == LiveEvent::Reopened { bus: 0 })
        .unwrap();
    assert_eq!((down_at, up_at), (5, 6), "{events:?}");
    assert_eq!(
        events.len(),
        12,
        "one Down and one Reopened per outage: {events:?}"
    );
    assert_eq!(
        *opens.lock().unwrap(),
        4,
        "first open, two failed reopens, one good one"
    );
    match &events[5] {
        LiveEvent::Down { error, .. } => assert!(error.contains("down"), "{error}"),
        e => panic!("{e:?}"),
    }
}

mod common;

#[test]
fn as_master_it_syncs_every_bus_and_a_live_session_replays_to_the_same_frames() {
    let map = common::two_buses();
    let mut can0 = Scripted::new("can0");
    can0.modules = vec![0, 5];
    let mut can1 = Scripted::new("can1");
    can1.modules = vec![1];
    let (sent0, sent1) = (Arc::clone(&can0.sent), Arc::clone(&can1.sent));
    let options = LiveOptions {
        sync_period: Some(Duration::from_millis(5)),
        ..LiveOptions::default()
    };
    let acq = Acquisition::start(vec![can0, can1], options);
    let interfaces = acq.interfaces().to_vec();
    let mut live = Assembler::new(&map, &interfaces, Skin16);
    let mut assembled: Vec<AssembledFrame> = Vec::new();
    let mut recording = String::new();
    let give_up = Instant::now() + Duration::from_secs(30);
    while assembled.iter().filter(|f| f.is_complete()).count() < 10 {
        assert!(Instant::now() < give_up, "no complete frames: {assembled:?}");
        if let Some(LiveEvent::Frame(f)) = acq.recv(Duration::from_millis(100)) {
            write_line(&mut recording, &f, &interfaces[usize::from(f.bus)]);
            live.push(&f, &mut |a| assembled.push(a.clone()));
        }
    }
    acq.stop();
    live.finish(&mut |a| assembled.push(a.clone()));

    // Every sync went out on both buses, with the same counter for the same period.
    let counters = |sent: &Arc<Mutex<Vec<CanFrame>>>| -> Vec<u8> {
        sent.lock().unwrap().iter().map(|f| f.bytes[0]).collect()
    };
    let (c0, c1) = (counters(&sent0), counters(&sent1));
    let common: Vec<u8> = c0.iter().copied().filter(|c| c1.contains(c)).collect();
    assert!(common.len() >= 10, "{c0:?} / {c1:?}");
    assert!(sent0.lock().unwrap().iter().all(|f| f.id == 0x080 && f.len == 1));

    // Complete frames hold exactly what the modules answered to that cycle's sync.
    for f in assembled.iter().filter(|f| f.is_complete()) {
        let counter = f.cycle as u8;
        let mut want = Vec::new();
        for a in [0u32, 5, 1] {
            want.extend((0..11).map(|s| Some(reading(counter, a, s))));
        }
        assert_eq!(f.values, want, "cycle {}", f.cycle);
    }
    // The recording, replayed offline, gives the same frames.
    let log = CandumpLog::parse(&recording, Path::new("live.log")).unwrap();
    assert_eq!(log.to_text(), recording);
    let mut offline = Assembler::new(&map, &log.interfaces, Skin16);
    let mut replayed = Vec::new();
    for f in &log.frames {
        offline.push(f, &mut |a| replayed.push(a.clone()));
    }
    offline.finish(&mut |a| replayed.push(a.clone()));
    assert_eq!(replayed, assembled);
    assert!(
        recording
            .lines()
            .any(|l| l.contains(" 080#") && l.ends_with(" T"))
    );
}

#[test]
fn live_frames_hand_on_can_frames_then_the_skin_frames_they_complete() {
    let map = common::two_buses();
    let mut can0 = Scripted::new("can0");
    can0.modules = vec![0, 5];
    // can1 fails once to open: reported by name, then read on.
    let mut can1 = Scripted::new("can1");
    can1.modules = vec![1];
    can1.open_failures = 1;
    let options = LiveOptions {
        sync_period: Some(Duration::from_millis(5)),
        reopen_after: Duration::from_millis(1),
        ..LiveOptions::default()
    };
    let mut frames = LiveFrames::start(vec![can0, can1], options, &map, Duration::from_millis(5));
    assert_eq!(frames.interfaces(), ["can0", "can1"]);
    let (mut can, mut complete, mut down, mut reopened) = (0usize, Vec::new(), Vec::new(), 0);
    let give_up = Instant::now() + Duration::from_secs(30);
    while complete.len() < 5 {
        assert!(Instant::now() < give_up, "{can} CAN frames, {complete:?}");
        frames.poll(Duration::from_millis(100), &mut |item| match item {
            Live::Can(_) => can += 1,
            Live::Frame(f) if f.is_complete() => complete.push((f.cycle, f.values.clone())),
            Live::Frame(_) => {}
            Live::Down { interface, error } => down.push(format!("{interface}: {error}")),
            Live::Reopened { interface } => {
                assert_eq!(interface, "can1");
                reopened += 1;
            }
        });
    }
    let stats = frames.finish(&mut |_| {});
    assert!(stats.complete >= 5, "{stats:?}");
    assert!(can > 5 * 3, "the CAN frames come out too: {can}");
    assert_eq!((down.len(), reopened), (1, 1), "{down:?}");
    assert!(down[0].starts_with("can1: cannot open"), "{down:?}");
    for (cycle, values) in &complete {
        let counter = *cycle as u8;
        let want: Vec<_> = [0u32, 5, 1]
            .iter()
            .flat_map(|&a| (0..11).map(move |s| Some(reading(counter, a, s))))
            .collect();
        assert_eq!(values, &want, "cycle {cycle}");
    }
}

//! Taring: the baseline learned again on demand. A skin whose rest level moved reads a phantom
//! touch until it is tared; after the tare, a press reads its own pressure again.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_learn::session::{Event, FromConfig, Session, SessionConfig, TareRefused};
use std::path::Path;

/// The fixture forearm's session without models (touches, not decisions).
fn session() -> Session {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let mut config = SessionConfig::read(&root.join("run.toml")).unwrap();
    config.classifier = None;
    config.segmenter = None;
    config.gate = None;
    config.truth = None;
    config.force = None;
    Session::from_config(&config).unwrap()
}

/// One frame: every taxel at `rest` plus a little noise, and `press` counts more on taxels
/// 100..112 (a patch of the forearm).
fn frame(session: &Session, k: u64, rest: f32, press: f32) -> Vec<Vec<f32>> {
    session
        .links()
        .iter()
        .map(|l| {
            (0..l.taxels.len())
                .map(|i| {
                    let noise = ((i as u64 * 7 + k * 13) % 5) as f32 * 0.2;
                    rest + noise + if (100..112).contains(&i) { press } else { 0.0 }
                })
                .collect()
        })
        .collect()
}

fn push(session: &mut Session, k: u64, rest: f32, press: f32, events: &mut Vec<Event>) {
    let f = frame(session, k, rest, press);
    assert!(session.push(k * 50_000, k, &f, events).unwrap().is_continue());
}

fn mean_pressures(events: &[Event]) -> Vec<f32> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Appeared { touch, .. } => Some(touch.footprint.mean_pressure),
            _ => None,
        })
        .collect()
}

#[test]
fn a_tare_relearns_the_baseline_after_the_rest_level_moved() {
    let mut s = session();
    let frames = s.options().baseline_frames as u64;
    let mut events = Vec::new();
    let mut k = 0;
    push(&mut s, k, 200.0, 0.0, &mut events);
    k += 1;
    // While the baseline is learned, a tare would only start it again.
    assert_eq!(s.tare(true), Err(TareRefused::Learning));
    for _ in 1..frames + 5 {
        push(&mut s, k, 200.0, 0.0, &mut events);
        k += 1;
    }
    assert!(events.is_empty(), "{events:?}");
    // The rest level moves up 40 counts under a dozen taxels (a cover pressed flat): a phantom
    // touch that stays.
    for _ in 0..10 {
        push(&mut s, k, 200.0, 40.0, &mut events);
        k += 1;
    }
    assert_eq!(mean_pressures(&events).len(), 1, "{events:?}");
    // Refused while it touches, with the reason; forced, it releases the touch first.
    let refused = s.tare(false);
    assert_eq!(refused, Err(TareRefused::Touching { touches: 1 }));
    assert!(refused.unwrap_err().to_string().contains("force the tare"));
    let started = s.tare(true).unwrap();
    assert_eq!((started.frames, started.releases), (frames as usize, 1));
    events.clear();
    push(&mut s, k, 200.0, 40.0, &mut events);
    k += 1;
    let kinds: Vec<&str> = events.iter().map(Event::kind).collect();
    assert_eq!(kinds, ["released", "tare"], "{events:?}");
    assert!(matches!(
        events[1],
        Event::Tare {
            forced: true,
            released: 1,
            ..
        }
    ));
    // The frames that learn read nothing; then a 30-count press reads 30 counts, not 70.
    events.clear();
    for _ in 1..frames + 3 {
        push(&mut s, k, 200.0, 40.0, &mut events);
        k += 1;
    }
    assert!(events.is_empty(), "{events:?}");
    for _ in 0..5 {
        push(&mut s, k, 200.0, 70.0, &mut events);
        k += 1;
    }
    let found = mean_pressures(&events);
    assert_eq!(found.len(), 1, "{events:?}");
    assert!(
        (found[0] - 30.0).abs() < 2.0,
        "mean pressure {} counts, pressed 30",
        found[0]
    );
    // Untouched again: a plain tare is taken, and the session still finishes.
    for _ in 0..5 {
        push(&mut s, k, 200.0, 40.0, &mut events);
        k += 1;
    }
    assert!(s.tare(false).is_ok());
    push(&mut s, k, 200.0, 40.0, &mut events);
    assert!(s.finish(&mut events).is_ok());
}

#[test]
fn a_tare_asked_from_another_thread_is_carried_out_at_the_next_frame() {
    let mut s = session();
    let handle = s.tare_handle();
    let mut events = Vec::new();
    for k in 0..30 {
        push(&mut s, k, 200.0, 0.0, &mut events);
    }
    let asked = std::thread::spawn(move || handle.tare(false)).join().unwrap();
    assert!(asked.is_ok());
    assert!(events.is_empty());
    push(&mut s, 30, 200.0, 0.0, &mut events);
    assert_eq!(events.iter().map(Event::kind).collect::<Vec<_>>(), ["tare"]);
}

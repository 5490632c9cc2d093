//! The session as a robot stack uses it (`skin_learn::session`): the fixture session's CAN log
//! in, typed events out, without the binary.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::CandumpLog;
use skin_control::hri::{GateAction, TouchClass};
use skin_learn::session::{Event, MissingModule, Session, SessionConfig};
use std::path::{Path, PathBuf};

fn fixture_session() -> (Session, CandumpLog, PathBuf) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let config = SessionConfig::read(&root.join("run.toml")).unwrap();
    let log_path = root.join("session.candump.log");
    let log = CandumpLog::read(&log_path).unwrap();
    (Session::from_config(&config).unwrap(), log, log_path)
}

#[test]
fn the_fixture_session_decides_every_scripted_touch_with_typed_events() {
    let (mut session, log, path) = fixture_session();
    let mut events: Vec<Event> = Vec::new();
    let span = session.run_log(&log, &path, &mut events, &mut |_, _| {}).unwrap();
    let summary = session.summary(span).to_string();
    assert!(
        summary.contains("20 of 20 scripted touches found, 20 with the right class"),
        "{summary}"
    );
    let mut decisions = 0;
    let mut last_kind = None;
    for e in &events {
        match e {
            Event::Classified {
                class, kind, image, ..
            } => {
                decisions += 1;
                // The typed class is the name's, and the image is the model's input.
                assert_eq!(*kind, TouchClass::from_name(class), "{e:?}");
                assert_eq!((image.rows, image.cols, image.pixels.len()), (68, 100, 6800));
                assert!(image.pixels.iter().any(|&p| p > 0), "the image shows the touch");
                last_kind = Some(*kind);
            }
            Event::Released { class, kind, .. } => {
                assert_eq!(*kind, class.as_deref().map(TouchClass::from_name), "{e:?}");
            }
            // The gate follows the run.toml's [gate]: comply with a hand, stop for the rest.
            Event::Gate { action, .. } => match last_kind {
                Some(TouchClass::Hand) => assert!(matches!(action, GateAction::Comply | GateAction::Resume)),
                Some(TouchClass::NonHand) => assert!(matches!(action, GateAction::Stop | GateAction::Resume)),
                None => assert_eq!(*action, GateAction::Resume),
            },
            _ => {}
        }
    }
    assert!(decisions >= 20, "{decisions} decisions");
    assert!(
        events.iter().all(|e| !matches!(e, Event::Incomplete { .. })),
        "a clean log"
    );
    // Events come in time order.
    assert!(events.windows(2).all(|w| w[0].time() <= w[1].time()));
}

#[test]
fn a_module_lost_for_half_a_second_is_reported_frame_by_frame_and_loses_no_touch() {
    let (mut session, mut log, path) = fixture_session();
    // Drop the second of module 0's three CAN frames (id 0x201) from 10.0 s to 10.5 s.
    let t0 = log.frames[0].time_us;
    let lost = |f: &skin_can::candump::CanFrame| {
        let t = f.time_us - t0;
        f.id == 0x201 && (10_000_000..10_500_000).contains(&t)
    };
    let dropped = log.frames.iter().filter(|f| lost(f)).count();
    log.frames.retain(|f| !lost(f));
    let mut events: Vec<Event> = Vec::new();
    let span = session.run_log(&log, &path, &mut events, &mut |_, _| {}).unwrap();
    let incomplete: Vec<&Vec<MissingModule>> = events
        .iter()
        .filter_map(|e| match e {
            Event::Incomplete { missing, .. } => Some(missing),
            _ => None,
        })
        .collect();
    assert_eq!(
        incomplete.len(),
        dropped,
        "one report per frame that lacks the module"
    );
    assert!(
        incomplete
            .iter()
            .all(|m| m.len() == 1 && m[0].address == 0 && m[0].bus == "can0"),
        "{incomplete:?}"
    );
    let summary = session.summary(span).to_string();
    assert!(summary.contains("20 of 20 scripted touches found"), "{summary}");
}

#[test]
fn a_layout_taxel_on_no_bus_is_reported() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let mut config = SessionConfig::read(&root.join("session/run.toml")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    // The fixture bus map with taxel 16's slot left empty (-1).
    let busmap = std::fs::read_to_string(root.join("forearm/busmap.toml")).unwrap();
    assert!(busmap.contains("[16, "));
    let busmap_path = dir.path().join("busmap.toml");
    std::fs::write(&busmap_path, busmap.replacen("[16, ", "[-1, ", 1)).unwrap();
    config.busmap = busmap_path;
    let session = Session::from_config(&config).unwrap();
    assert_eq!(session.uncovered(), [("forearm", skin_core::TaxelId(16))]);
    let (full, _, _) = fixture_session();
    assert!(full.uncovered().is_empty());
}

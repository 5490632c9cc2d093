//! The session as a robot stack uses it (`skin_learn::session`): the fixture session's CAN log
//! in, typed events out, without the binary. The fixture's classes are checked with the shipped
//! models (feature `onnx`); everything else runs with rule-based test models.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::CandumpLog;
#[cfg(feature = "onnx")]
use skin_control::hri::{GateAction, TouchClass};
use skin_learn::session::{Event, FromConfig, MissingModule, Session, SessionConfig};
use std::path::{Path, PathBuf};

mod support;

use skin_test_support::recordings;
use skin_test_support::shared_data;

fn fixture_session() -> (Session, CandumpLog, PathBuf) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let config = SessionConfig::read(&root.join("run.toml")).unwrap();
    let log_path = root.join("session.candump.log");
    let log = CandumpLog::read(&log_path).unwrap();
    (session_of(&config), log, log_path)
}

/// The session of a configuration naming models: the shipped ones with the model runtime,
/// else the rule-based test models.
fn session_of(config: &SessionConfig) -> Session {
    if cfg!(feature = "onnx") {
        Session::from_config(config).unwrap()
    } else {
        Session::from_config_with_models(config, support::rule_models()).unwrap()
    }
}

#[cfg(feature = "onnx")]
#[test]
fn the_fixture_session_decides_every_scripted_touch_with_typed_events() {
    let (mut session, log, path) = fixture_session();
    let mut events: Vec<Event> = Vec::new();
    let span = session.run_log(&log, &path, &mut events, &mut |_, _| {}).unwrap();
    let summary = session.summary(span);
    assert!(
        summary
            .to_string()
            .contains("20 of 20 scripted touches found, 20 with the right class"),
        "{summary}"
    );
    let score = summary.script_score().unwrap();
    assert_eq!((score.scripted, score.found, score.right), (20, 20, 20));
    assert_eq!(session.stats().touches, session.touches().len());
    let mut decisions = 0;
    let mut last_kind = None;
    for e in &events {
        match e {
            Event::Classified { touch, image, .. } => {
                decisions += 1;
                let class = &touch.decision.class;
                // The shipped card's hand class is "hand", and the image is the model's input.
                assert_eq!(class.is_hand(), class.name() == "hand", "{e:?}");
                assert_eq!(
                    (image.size().to_string(), image.pixels().len()),
                    ("68x100".to_owned(), 6800)
                );
                assert!(image.pixels().iter().any(|&p| p > 0), "the image shows the touch");
                // The fixture's border rule: a hand under 0.95 within 15 mm of the border stops.
                let unsure_at_border = touch.decision.probability < 0.95 && touch.decision.border_mm <= 15.0;
                last_kind = Some((class.kind(), unsure_at_border));
            }
            Event::Released { touch, .. } => {
                let class = touch.decision.as_ref().map(|d| &d.class);
                assert!(class.is_none_or(|c| c.is_hand() == (c.name() == "hand")), "{e:?}");
            }
            // The gate follows the run.toml's [gate]: comply with a hand, stop for the rest and
            // for an unsure hand at the skin's border.
            Event::Gate { action, .. } => match last_kind {
                Some((TouchClass::Hand, false)) => {
                    assert!(matches!(action, GateAction::Comply | GateAction::Resume))
                }
                Some((TouchClass::Hand, true)) => {
                    assert!(matches!(action, GateAction::Stop | GateAction::Resume))
                }
                Some((TouchClass::NonHand, _)) => {
                    assert!(matches!(action, GateAction::Stop | GateAction::Resume))
                }
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
    assert_eq!(session.stats().incomplete as usize, dropped);
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
    config.busmap = Some(busmap_path);
    let session = session_of(&config);
    assert_eq!(session.uncovered(), [("forearm", skin_core::TaxelId(16))]);
    let (full, _, _) = fixture_session();
    assert!(full.uncovered().is_empty());
}

/// A configuration naming only `layout` (and 5 baseline frames), in a temporary folder.
fn layout_only(layout: &Path) -> (tempfile::TempDir, SessionConfig) {
    layout_and(layout, "")
}

/// The layout-only configuration with `touch` lines in its `[touch]` table.
fn layout_and(layout: &Path, touch: &str) -> (tempfile::TempDir, SessionConfig) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.toml");
    let text = format!(
        "layout = {:?}\n[baseline]\nframes = 5\n[touch]\n{touch}\n",
        layout.to_str().unwrap()
    );
    std::fs::write(&path, text).unwrap();
    let config = SessionConfig::read(&path).unwrap();
    (dir, config)
}

#[test]
fn a_raw_recording_goes_through_a_session_configured_by_its_layout_alone() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm");
    let (_dir, config) = layout_only(&root.join("layout.json"));
    let rec_path = root.join("touches.txt");
    // Three taxels without a column, and a column that is no taxel.
    let full = skin_core::format::recording::read(&rec_path).unwrap();
    let mut rec = recordings::without_columns(&full, &[10, 11, 12]);
    rec.taxel_ids.push(skin_core::TaxelId(999_999));
    for f in &mut rec.frames {
        f.values.push(5_000.0);
    }
    let mut session = Session::from_config(&config).unwrap();
    let mut events: Vec<Event> = Vec::new();
    let span = session.run_recording(&rec, &rec_path, &mut events).unwrap();
    assert!((span - rec.frames.last().unwrap().time).abs() < 1e-9);
    // The four scripted touches of touches.tsv (fingertip, palm, object edge, two fingertips).
    let released: Vec<(f64, usize)> = events
        .iter()
        .filter_map(|e| match e {
            Event::Released { touch, .. } => Some((touch.time, touch.peak.contacts)),
            _ => None,
        })
        .collect();
    assert_eq!(released.len(), 4, "{events:?}");
    for ((t, contacts), end) in released.iter().zip([1.5, 3.2, 4.7, 6.0]) {
        assert!((t - end).abs() <= 0.15, "a touch ends at {t} s, scripted {end} s");
        assert!(*contacts >= 1);
    }
    let summary = session.summary(span).to_string();
    assert!(
        summary.contains("3 taxel(s) of the layout have no column in the recording")
            && summary.contains("1 column(s) of the recording are no taxel of the layout"),
        "{summary}"
    );
    // A recording of another skin is refused by name.
    let other = skin_core::Recording {
        taxel_ids: vec![skin_core::TaxelId(1)],
        frame_numbers: vec![0],
        frames: vec![skin_core::Frame {
            time: 0.0,
            values: vec![0.0],
        }],
    };
    let e = Session::from_config(&config)
        .unwrap()
        .run_recording(&other, Path::new("other.txt"), &mut events);
    assert!(
        e.unwrap_err()
            .to_string()
            .starts_with("other.txt: none of the layout's")
    );
}

#[test]
fn nobody_touching_the_real_patch_gives_no_touch() {
    let Some(dir) = shared_data::shared("cyskin/recordings/0_finger") else {
        return;
    };
    let Some(layout) = shared_data::shared("cyskin/curved_gesture_patch.json") else {
        return;
    };
    let (_tmp, config) = layout_only(&layout);
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let mut touched = 0;
    for f in &files {
        let rec = skin_core::format::recording::read(f).unwrap();
        let mut events: Vec<Event> = Vec::new();
        Session::from_config(&config)
            .unwrap()
            .run_recording(&rec, f, &mut events)
            .unwrap();
        touched += usize::from(events.iter().any(|e| matches!(e, Event::Appeared { .. })));
    }
    assert!(
        touched * 20 <= files.len(),
        "{touched} of {} recordings of nobody touching gave a touch",
        files.len()
    );
}

#[test]
fn touch_split_is_read_with_its_defaults_and_checked() {
    let path = Path::new("/nowhere/run.toml");
    let config = SessionConfig::parse("layout = \"l.json\"\n[touch.split]\n", path).unwrap();
    let options = config.touch_options();
    assert_eq!(options.separation, skin_core::Separation::FINGERS);
    let plain = SessionConfig::parse("layout = \"l.json\"\n", path).unwrap();
    assert_eq!(plain.touch_options().separation, skin_core::Separation::FINGERS);
    let thesis =
        SessionConfig::parse("layout = \"l.json\"\n[touch]\ncontacts = \"connected\"\n", path).unwrap();
    assert_eq!(
        thesis.touch_options().separation,
        skin_core::Separation::Connected
    );
    let both = "layout = \"l.json\"\n[touch]\ncontacts = \"connected\"\n[touch.split]\n";
    let e = SessionConfig::parse(both, path).unwrap_err().to_string();
    assert!(e.contains("[touch.split]") && e.contains("connected"), "{e}");
    let wider = "layout = \"l.json\"\n[touch.split]\nmin_distance_mm = 20\n";
    assert_eq!(
        SessionConfig::parse(wider, path)
            .unwrap()
            .touch_options()
            .separation,
        skin_core::Separation::Peaks {
            min_dip: 0.5,
            min_distance_m: 0.02
        }
    );
    let e = SessionConfig::parse("layout = \"l.json\"\n[touch.split]\nmin_dip = 2\n", path)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[touch.split] min_dip") && e.contains("from 0 to 1"),
        "{e}"
    );
}

#[test]
fn the_gates_border_rule_is_read_with_its_defaults_and_checked() {
    use skin_control::hri::{BorderRule, GateAction};
    let path = Path::new("/nowhere/run.toml");
    let gate = |extra: &str| {
        format!("layout = \"l.json\"\n[force]\ncalibration = \"f.json\"\n[gate]\nhand = \"comply\"\n{extra}")
    };
    let plain = SessionConfig::parse(&gate(""), path).unwrap();
    assert_eq!(plain.gate.and_then(|g| g.border), None);
    let default = SessionConfig::parse(&gate("border = {}\n"), path).unwrap();
    assert_eq!(default.gate.and_then(|g| g.border), Some(BorderRule::default()));
    let set = SessionConfig::parse(
        &gate("border = { within_mm = 8, hand_below = 0.99, action = \"slow\" }\n"),
        path,
    )
    .unwrap();
    assert_eq!(
        set.gate.and_then(|g| g.border),
        Some(BorderRule {
            within_mm: 8.0,
            hand_below: 0.99,
            action: GateAction::Slow
        })
    );
    for (extra, field) in [
        ("border = { within_mm = -3 }\n", "[gate] border.within_mm"),
        ("border = { hand_below = 1.5 }\n", "[gate] border.hand_below"),
        ("border = { hand_below = nan }\n", "[gate] border.hand_below"),
    ] {
        let e = SessionConfig::parse(&gate(extra), path).unwrap_err().to_string();
        assert!(e.contains(field), "{extra}: {e}");
    }
    let e = SessionConfig::parse(&gate("border = { within = 3 }\n"), path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("within"), "{e}");
    // Force limits, newtons, by class.
    let limits = SessionConfig::parse(&gate("force_n = { hand = 140, non_hand = 65.5 }\n"), path).unwrap();
    let limits = limits.gate.unwrap().force_n;
    assert_eq!((limits["hand"], limits["non_hand"]), (140.0, 65.5));
    for (extra, said) in [
        ("force_n = { hand = -1 }\n", "[gate] force_n.hand = -1"),
        ("force_n = { hand = 0 }\n", "[gate] force_n.hand = 0"),
        ("force_n = { hand = 1e9 }\n", "at most 100000"),
        ("force_n = { hand = \"a lot\" }\n", "force_n"),
    ] {
        let e = SessionConfig::parse(&gate(extra), path).unwrap_err().to_string();
        assert!(e.contains(said), "{extra}: {e}");
    }
    // Limits with nothing to weigh a touch with are refused, not ignored.
    let unweighed = "layout = \"l.json\"\n[gate]\nhand = \"comply\"\nforce_n = { hand = 140 }\n";
    let e = SessionConfig::parse(unweighed, path).unwrap_err().to_string();
    assert!(e.contains("[gate] force_n") && e.contains("[force]"), "{e}");
}

/// The fixture session (its forearm calibrated in newtons) with a force limit on hands: every
/// hand pressing past it stops the arm, the event names the touch, its force and the limit, and
/// the stop holds until that touch is released, however its force goes meanwhile.
#[test]
fn a_hand_pressing_past_its_force_limit_stops_the_arm_until_it_lets_go() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let mut config = SessionConfig::read(&root.join("run.toml")).unwrap();
    let limit = 20.0;
    config.gate.as_mut().unwrap().force_n.insert("hand".into(), limit);
    let log_path = root.join("session.candump.log");
    let log = CandumpLog::read(&log_path).unwrap();
    let mut session = session_of(&config);
    let mut events: Vec<Event> = Vec::new();
    session
        .run_log(&log, &log_path, &mut events, &mut |_, _| {})
        .unwrap();
    let peaks: Vec<(u64, f64, bool)> = events
        .iter()
        .filter_map(|e| match e {
            Event::Released { touch, .. } => Some((
                touch.id,
                touch.peak.force_n.unwrap(),
                touch.decision.as_ref().is_some_and(|d| d.class.is_hand()),
            )),
            _ => None,
        })
        .collect();
    let strong: Vec<u64> = peaks.iter().filter(|p| p.2 && p.1 > limit).map(|p| p.0).collect();
    let weak = peaks.iter().filter(|p| p.2 && p.1 <= limit).count();
    assert!(strong.len() >= 3 && weak >= 3, "{peaks:?}");
    let mut stopped = Vec::new();
    for (k, e) in events.iter().enumerate() {
        if let Event::Gate {
            action,
            over: Some(o),
            ..
        } = e
        {
            assert_eq!(*action, GateAction::Stop);
            assert!(
                o.force_n > limit && o.limit_n == limit && o.link == "forearm",
                "{o:?}"
            );
            stopped.push(o.touch);
            // Stopped until the touch is released: the next gate event comes with its release.
            let next = events[k + 1..]
                .iter()
                .position(|e| matches!(e, Event::Gate { .. }))
                .map(|j| k + 1 + j);
            let released = events[k + 1..]
                .iter()
                .position(|e| matches!(e, Event::Released { touch, .. } if touch.id == o.touch))
                .map(|j| k + 1 + j)
                .unwrap();
            assert!(next.is_none_or(|n| n > released), "{:?}", &events[k..=released]);
            let mut line = Vec::new();
            e.write_json(&mut line).unwrap();
            let line = String::from_utf8(line).unwrap();
            assert!(
                line.contains("\"force_n\"") && line.contains("\"limit_n\":20.0"),
                "{line}"
            );
        }
    }
    // Each hand that pressed past the limit while decided stopped the arm; none under it did.
    assert!(
        !stopped.is_empty() && stopped.iter().all(|t| strong.contains(t)),
        "{stopped:?} {strong:?}"
    );
    // The gate speaks from the first decision on, as without limits (no "resume" before it).
    let first_gate = events.iter().position(|e| matches!(e, Event::Gate { .. }));
    let first_decision = events.iter().position(|e| matches!(e, Event::Classified { .. }));
    assert!(first_gate > first_decision, "{first_gate:?} {first_decision:?}");
    // Every decision is as without the limit; only the gate differs.
    let plain = SessionConfig::read(&root.join("run.toml")).unwrap();
    let mut plain_events: Vec<Event> = Vec::new();
    session_of(&plain)
        .run_log(&log, &log_path, &mut plain_events, &mut |_, _| {})
        .unwrap();
    assert_eq!(not_gate_lines(&events), not_gate_lines(&plain_events));
}

/// The events.jsonl lines of every event but the gate's.
fn not_gate_lines(events: &[Event]) -> Vec<String> {
    events
        .iter()
        .filter(|e| !matches!(e, Event::Gate { .. }))
        .map(|e| {
            let mut line = Vec::new();
            e.write_json(&mut line).unwrap();
            String::from_utf8(line).unwrap()
        })
        .collect()
}

/// Force limits on a skin whose calibration leaves a link out are refused, naming the link: a
/// touch there could never be stopped.
#[test]
fn force_limits_need_every_link_weighed() {
    use skin_control::hri::{ClassGate, GateAction};
    use skin_core::format::force_file::ForceCalibration;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let dir = tempfile::tempdir().unwrap();
    // The fixture forearm's calibration fits the arm's forearm (the same layout); its wrist
    // has none.
    let forearm = ForceCalibration::read(&root.join("forearm/force.json")).unwrap();
    let path = dir.path().join("force.json");
    std::fs::write(&path, forearm.to_json()).unwrap();
    let mut config = SessionConfig::read(&root.join("arm/run.toml")).unwrap();
    config.force = Some(skin_learn::session::ForceConfig { calibration: path });
    let mut gate = ClassGate::new([("hand", GateAction::Comply)]);
    gate.force_n.insert("hand".into(), 140.0);
    config.gate = Some(gate);
    let e = Session::from_config_with_models(&config, support::rule_models())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[gate] force_n") && e.contains("wrist") && !e.contains("forearm,"),
        "{e}"
    );
}

/// A force read past the sensor's saturation is a lower bound: with a limit set, the gate takes
/// it as past the limit, however high the limit, and says so.
#[test]
fn a_saturated_reading_counts_as_past_the_force_limit() {
    use skin_core::format::force_file::ForceCalibration;
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    let dir = tempfile::tempdir().unwrap();
    // The forearm's calibration with a full scale of 60 counts: the session's presses pass it.
    let mut calibration = ForceCalibration::read(&root.join("forearm/force.json")).unwrap();
    calibration.links[0].curve.full_scale = 60.0;
    let low = dir.path().join("force.json");
    std::fs::write(&low, calibration.to_json()).unwrap();
    let mut config = SessionConfig::read(&root.join("session/run.toml")).unwrap();
    config.force.as_mut().unwrap().calibration = low;
    let gate = config.gate.as_mut().unwrap();
    gate.force_n.insert("hand".into(), 99_999.0);
    gate.force_n.insert("non_hand".into(), 99_999.0);
    let log_path = root.join("session/session.candump.log");
    let log = CandumpLog::read(&log_path).unwrap();
    let mut events: Vec<Event> = Vec::new();
    session_of(&config)
        .run_log(&log, &log_path, &mut events, &mut |_, _| {})
        .unwrap();
    let over: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            Event::Gate { over: Some(o), .. } => Some(o),
            _ => None,
        })
        .collect();
    assert!(over.len() >= 10, "{over:?}");
    assert!(
        over.iter().all(|o| o.saturated && o.force_n < o.limit_n),
        "{over:?}"
    );
}

/// Per real recording of `fingers` fingers: the most contacts in one of its touches, with the
/// layout-only configuration plus `extra` lines of `[touch]`.
fn most_contacts(fingers: usize, extra: &str) -> Option<Vec<usize>> {
    let dir = shared_data::shared(&format!("cyskin/recordings/{fingers}_finger"))?;
    let layout = shared_data::shared("cyskin/curved_gesture_patch.json")?;
    let (_tmp, config) = layout_and(&layout, extra);
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    let mut most = Vec::new();
    for f in &files {
        let rec = skin_core::format::recording::read(f).unwrap();
        let mut session = Session::from_config(&config).unwrap();
        session.run_recording(&rec, f, &mut Vec::<Event>::new()).unwrap();
        let most_kept = session.touches().map(|t| t.peak.contacts).max().unwrap_or(0);
        assert_eq!(session.stats().most_contacts, most_kept, "{}", f.display());
        most.push(most_kept);
    }
    Some(most)
}

/// The default rule splits real two-finger presses the thesis' connected rule leaves whole,
/// without turning most one-finger presses into two. The floors are the figures measured on
/// these recordings (README table: 35 of 51 ones, 41 of 70 two or more) less a margin; the
/// issue's own bounds (90% and 70%) are out of reach of any per-frame rule on them (README).
#[test]
fn splitting_finds_the_second_finger_of_real_presses() {
    let Some(one) = most_contacts(1, "") else {
        return;
    };
    let two = most_contacts(2, "").unwrap();
    let two_connected = most_contacts(2, "contacts = \"connected\"").unwrap();
    let ones = one.iter().filter(|&&c| c == 1).count();
    let split = two.iter().filter(|&&c| c >= 2).count();
    let joined = two_connected.iter().filter(|&&c| c >= 2).count();
    assert!(
        ones * 100 >= one.len() * 65,
        "{ones} of {} one-finger recordings gave one contact",
        one.len()
    );
    assert!(
        split * 100 >= two.len() * 50,
        "{split} of {} two-finger recordings gave two or more",
        two.len()
    );
    assert!(
        split >= joined + 20,
        "splitting found {split}, the connected rule {joined}"
    );
    // Splitting only ever adds contacts to what the connected rule finds.
    for (s, c) in two.iter().zip(&two_connected) {
        assert!(s >= c);
    }
}

/// A recording that lacks the most pressed taxel of every touch: the session bridges the hole
/// (Test B), so every touch is still found and the fingertip and the palm stay one contact each.
/// Read as zeros instead, the holes lost a touch and broke the palm in two.
#[test]
fn a_dead_taxel_under_a_press_leaves_the_contact_whole() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm");
    let (_dir, config) = layout_only(&root.join("layout.json"));
    let rec_path = root.join("touches.txt");
    let full = skin_core::format::recording::read(&rec_path).unwrap();
    let contacts = |rec: &skin_core::Recording| {
        let mut events: Vec<Event> = Vec::new();
        Session::from_config(&config)
            .unwrap()
            .run_recording(rec, &rec_path, &mut events)
            .unwrap();
        events
            .iter()
            .filter_map(|e| match e {
                Event::Released { touch, .. } => Some(touch.peak.contacts),
                _ => None,
            })
            .collect::<Vec<usize>>()
    };
    let whole = contacts(&full);
    // The column read highest in each second of the recording (one per scripted touch).
    let mut gone = Vec::new();
    for second in 0..7 {
        let frames = full
            .frames
            .iter()
            .filter(|f| f.time >= f64::from(second) && f.time < f64::from(second + 1));
        let mut best = (0usize, f32::MIN);
        for f in frames {
            for (c, &v) in f.values.iter().enumerate() {
                if v > best.1 {
                    best = (c, v);
                }
            }
        }
        if !gone.contains(&best.0) {
            gone.push(best.0);
        }
    }
    let holed = recordings::without_columns(&full, &gone);
    let holed = contacts(&holed);
    assert_eq!(whole, [1, 1, 2, 2]);
    assert_eq!(
        holed.len(),
        whole.len(),
        "{holed:?}: a touch lost to {} dead taxels",
        gone.len()
    );
    assert_eq!(holed[..2], whole[..2], "{holed:?}");
    // The object's edge loses its highest taxel: its peaks may fall apart once more, no further.
    for (h, w) in holed.iter().zip(&whole) {
        assert!(h.abs_diff(*w) <= 1, "{holed:?} vs {whole:?}");
    }
}

/// The stitched images of the fixture arm's log through a session built in the given order, its
/// bus map less the forearm's first module (11 taxels on no bus, bridged as dead).
fn stitched_images(can_first: bool) -> Vec<Vec<u8>> {
    use skin_geom::{FlattenOptions, TactileMap};
    use skin_learn::model::Models;
    use skin_learn::session::{FrameView, SessionOptions, Sink, Stitching};
    use skin_learn::touch::{TouchOptions, TouchPipeline};

    struct Stitched(Vec<Vec<u8>>);
    impl Sink for Stitched {
        type Error = std::convert::Infallible;
        fn event(&mut self, _: &Event) -> Result<skin_learn::session::Flow, Self::Error> {
            Ok(std::ops::ControlFlow::Continue(()))
        }
        fn frame_image(
            &mut self,
            view: FrameView<'_>,
            _: u64,
            image: skin_core::image::ImageView<'_, u8>,
        ) -> Result<skin_learn::session::Flow, Self::Error> {
            if matches!(view, FrameView::Stitched) {
                self.0.push(image.pixels().to_vec());
            }
            Ok(std::ops::ControlFlow::Continue(()))
        }
    }

    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm");
    let links = skin_geom::read_layout(&dir.join("layout.json")).unwrap().value;
    let mut busmap = skin_can::BusMap::read(&dir.join("busmap.toml")).unwrap();
    busmap.buses[0].modules.remove(0);
    let maps: Vec<TactileMap> = links
        .iter()
        .map(|l| TactileMap::flatten(l, &FlattenOptions::default()).unwrap())
        .collect();
    let postures = skin_core::format::poses::Postures::read(&dir.join("poses.json")).unwrap();
    let stitching = Stitching::new(&maps, postures, &dir.join("poses.json")).unwrap();
    let options = TouchOptions {
        threshold: 10.0,
        ..TouchOptions::default()
    };
    let pipeline = TouchPipeline::new(maps, Models::none(), options).unwrap();
    let session_options = SessionOptions {
        baseline_frames: 8,
        frame_images: true,
        ..SessionOptions::default()
    };
    let session = Session::new(links, pipeline, session_options).unwrap();
    let mut session = if can_first {
        session
            .with_can(&busmap)
            .unwrap()
            .with_stitching(stitching)
            .unwrap()
    } else {
        session
            .with_stitching(stitching)
            .unwrap()
            .with_can(&busmap)
            .unwrap()
    };
    let log = dir.join("touch.candump.log");
    let mut sink = Stitched(Vec::new());
    let whole = CandumpLog::read(&log).unwrap();
    session.run_log(&whole, &log, &mut sink, &mut |_, _| {}).unwrap();
    sink.0
}

/// A robot stack may add the bus map and the stitching in either order: the bus map's dead
/// taxels are bridged on the stitched chain both ways.
#[test]
fn a_bus_maps_dead_taxels_reach_the_stitching_in_either_order() {
    let stitching_first = stitched_images(false);
    assert!(
        !stitching_first.is_empty(),
        "no stitched image: the touch across the joint was not seen"
    );
    assert!(
        stitched_images(true) == stitching_first,
        "the stitched images depend on the order"
    );
}

/// A long session keeps its last touches only, yet counts and scores every one: a scripted
/// touch long gone from the table is still found, and every other touch is extra.
#[test]
fn a_long_session_keeps_its_last_touches_and_scores_them_all() {
    use skin_learn::script::Script;
    use skin_learn::session::TOUCH_HISTORY;
    use support::memory::{Count, Presses, forearm_session};
    let dir = tempfile::tempdir().unwrap();
    let session = forearm_session(dir.path(), false);
    let mut presses = Presses::new(&session, 50);
    // Touch k starts 2 + 2k s into the run (40 frames of rest, then 40 frames a touch).
    let script = Script::parse(
        "0\t2.0\t2.3\thand\tpoke\n1\t2.0\t2.3\tnon_hand\tball\n2\t3000.0\t3000.3\thand\tgrasp\n",
        Path::new("s.tsv"),
    )
    .unwrap();
    let mut session = session.with_script(script);
    let mut sink = Count::default();
    presses.rest(&mut session, 40, &mut sink);
    let touches = TOUCH_HISTORY + 500;
    for _ in 0..touches {
        presses.touch(&mut session, 35, &mut sink);
    }
    assert_eq!(session.stats().touches, touches);
    assert_eq!(session.touches().len(), TOUCH_HISTORY);
    let first = session.touches().next().unwrap();
    assert!((first.start - (2.0 + 2.0 * 500.0)).abs() < 0.2, "{first:?}");
    let summary = session.summary(0.0);
    let score = summary.script_score().unwrap();
    // Touch 0 matches both scripted touches at 2 s; the one at 1,499 touches' time is found.
    assert_eq!((score.scripted, score.found, score.right), (3, 3, 0));
    assert_eq!(score.extra, touches - 2);
    let text = summary.to_string();
    assert!(text.contains(&format!("{touches} touch(es):")), "{text}");
    assert!(
        text.contains(&format!("the last {TOUCH_HISTORY} listed")),
        "{text}"
    );
    assert!(
        text.contains("scripted touch 0 (hand poke) taken for -"),
        "{text}"
    );
    let rows = text.lines().filter(|l| l.contains("(not scripted)")).count();
    assert_eq!(rows, TOUCH_HISTORY - 1, "one kept row is scripted touch 2's");
    // Started again: the same script, nothing found yet.
    let session = session.restarted().unwrap();
    let score = session.summary(0.0).script_score().unwrap();
    assert_eq!((score.scripted, score.found, score.extra), (3, 0, 0));
    assert_eq!((session.stats().touches, session.touches().len()), (0, 0));
}

/// A classifier that says "hand" at 70% whatever it sees: unsure everywhere.
struct UnsureHand;

impl skin_learn::model::HandClassifier for UnsureHand {
    fn input_size(&self) -> skin_core::image::ImageSize {
        skin_core::image::ImageSize::MODEL_DEFAULT
    }

    fn classify(
        &mut self,
        _: skin_core::image::ImageView<'_, u8>,
    ) -> Result<Vec<f32>, skin_learn::model::ModelError> {
        Ok(vec![0.7, 0.3])
    }
}

/// The gate's actions and the decisions' distances from the border when the bundled forearm is
/// pressed around the taxel `centre` (layout index) by an unsure classifier, with the border
/// rule's defaults.
fn gate_for_press_at(centre: usize) -> (Vec<skin_control::hri::GateAction>, Vec<f32>) {
    use skin_control::hri::{BorderRule, ClassGate, GateAction};
    use skin_learn::model::{Classes, Models};
    use skin_learn::session::SessionOptions;
    use skin_learn::touch::{TouchOptions, TouchPipeline};
    let map = support::forearm();
    let link = skin_core::format::load_link(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json"),
    )
    .unwrap()
    .value;
    let near: Vec<usize> = (0..map.points.len())
        .filter(|&i| (map.points[i] - map.points[centre]).norm() < 0.012)
        .collect();
    let models = Models::new(UnsureHand, Classes::new(["hand", "non_hand"], Some(0)));
    let pipeline = TouchPipeline::new(vec![map], models, TouchOptions::default()).unwrap();
    let options = SessionOptions {
        gate: Some(ClassGate {
            border: Some(BorderRule::default()),
            ..ClassGate::new([("hand", GateAction::Comply), ("non_hand", GateAction::Stop)])
        }),
        ..SessionOptions::default()
    };
    let mut session = Session::new(vec![link], pipeline, options).unwrap();
    let mut events: Vec<Event> = Vec::new();
    for k in 0..40u64 {
        let mut frame = vec![100.0f32; 715];
        if (20..32).contains(&k) {
            for &i in &near {
                frame[i] = 400.0;
            }
        }
        assert!(
            session
                .push(k * 20_000, k, &[frame], &mut events)
                .unwrap()
                .is_continue()
        );
    }
    let gates = events
        .iter()
        .filter_map(|e| match e {
            Event::Gate { action, .. } => Some(*action),
            _ => None,
        })
        .collect();
    let borders = events
        .iter()
        .filter_map(|e| match e {
            Event::Classified { touch, .. } => Some(touch.decision.border_mm),
            _ => None,
        })
        .collect();
    (gates, borders)
}

/// An object overhanging the skin's edge leaves part of its print, so a hand decided there with
/// little confidence is stopped for, where the same decision in the middle of the skin complies.
#[test]
fn an_unsure_hand_at_the_skins_border_stops_the_arm_and_complies_in_the_middle() {
    use skin_control::hri::GateAction;
    let map = support::forearm();
    let border = map.border_distances();
    let edge = (0..border.len()).find(|&i| border[i] == 0.0).unwrap();
    let middle = (0..border.len())
        .max_by(|&a, &b| border[a].total_cmp(&border[b]))
        .unwrap();
    let (gates, borders) = gate_for_press_at(edge);
    assert_eq!(gates, [GateAction::Stop, GateAction::Resume], "at the border");
    assert_eq!(borders, [0.0], "at the border");
    let (gates, borders) = gate_for_press_at(middle);
    assert_eq!(gates, [GateAction::Comply, GateAction::Resume], "in the middle");
    assert!(borders[0] > 30.0, "in the middle: {borders:?}");
}

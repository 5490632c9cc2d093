//! A session can start at any moment: during a touch, or while someone leans on the skin. The
//! baseline it learns first must not take the touch for the skin's rest or its noise.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::CandumpLog;
use skin_learn::session::{Event, FromConfig, Session, SessionConfig};
use std::path::Path;

/// The fixture session's scripted touches: (start s, end s) from its first frame.
fn script() -> Vec<(f64, f64)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    std::fs::read_to_string(root.join("session.tsv"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split('\t').collect();
            (f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect()
}

/// The touches a session found in `log`: (start, end) on the log's clock, s from `t0_us`.
fn touches(log: &CandumpLog, t0_us: u64) -> (Vec<(f64, f64)>, Vec<Event>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let mut config = SessionConfig::read(&root.join("run.toml")).unwrap();
    // Touches, not decisions: no models needed.
    config.classifier = None;
    config.segmenter = None;
    config.gate = None;
    config.truth = None;
    let mut session = Session::from_config(&config).unwrap();
    let mut events: Vec<Event> = Vec::new();
    session
        .run_log(log, Path::new("cut.log"), &mut events, &mut |_, _| {})
        .unwrap();
    let first = (log.frames[0].time_us - t0_us) as f64 * 1e-6;
    let found = events
        .iter()
        .filter_map(|e| match e {
            Event::Released { touch, .. } => Some((first + touch.time - touch.duration, first + touch.time)),
            _ => None,
        })
        .collect();
    (found, events)
}

#[test]
fn a_log_that_starts_inside_a_touch_finds_every_later_touch_and_the_one_in_progress_at_most_once() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/session");
    let full = CandumpLog::read(&root.join("session.candump.log")).unwrap();
    let t0 = full.frames[0].time_us;
    let script = script();
    // Inside touches early, midway and late in the session, at their start, middle and end.
    for k in [0, 7, 13, 18] {
        let (start, end) = script[k];
        for at in [0.1, 0.5, 0.9] {
            let cut = start + at * (end - start);
            let mut log = full.clone();
            log.frames
                .retain(|f| f.time_us >= t0 + (cut * 1e6).round() as u64);
            let (found, events) = touches(&log, t0);
            let overlaps = |(s, e): (f64, f64)| found.iter().filter(|(a, b)| *a < e && *b > s).count();
            for (j, &(s, e)) in script.iter().enumerate().filter(|(_, t)| t.0 > cut) {
                assert_eq!(
                    overlaps((s, e)),
                    1,
                    "log cut at {cut:.2} s (inside touch {k}): touch {j} ({s}-{e} s) found {} times: {found:?}",
                    overlaps((s, e))
                );
            }
            assert!(
                overlaps((start, end)) <= 1,
                "cut at {cut:.2} s: touch {k} found twice"
            );
            // Nothing is found that was not pressed.
            for &(a, b) in &found {
                assert!(
                    script.iter().any(|&(s, e)| a < e + 0.1 && b > s - 0.1),
                    "cut at {cut:.2} s: a touch from {a:.2} to {b:.2} s that nobody made: {events:?}"
                );
            }
        }
    }
}

/// A press of `counts` on the taxels within `radius` m of taxel `centre` (layout order).
fn press(link: &skin_core::LinkSkin, centre: usize, radius: f64, counts: f32) -> Vec<f32> {
    let c = link.taxels[centre].position;
    link.taxels
        .iter()
        .map(|t| {
            if (t.position - c).norm() < radius {
                counts
            } else {
                0.0
            }
        })
        .collect()
}

#[test]
fn a_session_switched_on_while_someone_leans_on_the_skin_corrects_its_baseline_when_they_let_go() {
    let layout = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/forearm/layout.json");
    let dir = tempfile::tempdir().unwrap();
    let config_path = dir.path().join("run.toml");
    std::fs::write(
        &config_path,
        format!(
            "layout = {:?}\n[baseline]\nframes = 20\n",
            layout.to_str().unwrap()
        ),
    )
    .unwrap();
    let config = SessionConfig::read(&config_path).unwrap();
    let mut session = Session::from_config(&config).unwrap();
    let link = session.links()[0].clone();
    let n = link.taxels.len();
    // Raw counts: 200 to 400 at rest, a +-1 count wobble. Someone leans on the skin (+400
    // counts, steady) from before the session starts until 3 s; the same place is pressed
    // again, lightly (+60), from 5 to 6 s, and another place from 7 to 8 s.
    let lean = press(&link, 100, 0.03, 400.0);
    let light = press(&link, 100, 0.03, 60.0);
    let other = press(&link, 500, 0.03, 200.0);
    let pressed = lean.iter().filter(|&&p| p > 0.0).count();
    assert!(pressed >= 10, "{pressed} taxels under the lean");
    let mut events: Vec<Event> = Vec::new();
    for k in 0..200u64 {
        let t = k as f64 * 0.05;
        let load: &[f32] = match t {
            t if t < 3.0 => &lean,
            t if (5.0..6.0).contains(&t) => &light,
            t if (7.0..8.0).contains(&t) => &other,
            _ => &[],
        };
        let raw: Vec<f32> = (0..n)
            .map(|i| {
                let wobble = [-1.0, 0.0, 1.0][(k as usize * 7 + i * 3) % 3];
                200.0 + (i % 200) as f32 + wobble + load.get(i).copied().unwrap_or(0.0)
            })
            .collect();
        assert!(
            session
                .push(k * 50_000, k, &[raw], &mut events)
                .unwrap()
                .is_continue()
        );
    }
    assert!(session.finish(&mut events).unwrap().is_continue());
    let corrected: Vec<_> = events
        .iter()
        .filter_map(|e| match e {
            Event::BaselineCorrected { since, taxels, .. } => Some((*since, *taxels)),
            _ => None,
        })
        .collect();
    assert_eq!(corrected.len(), 1, "{corrected:?}");
    let (since, taxels) = corrected[0];
    assert!((3.0..3.2).contains(&since), "corrected at {since} s");
    assert_eq!(taxels, pressed);
    let released: Vec<(f64, f64, f32)> = events
        .iter()
        .filter_map(|e| match e {
            Event::Released { touch, .. } => {
                Some((touch.time - touch.duration, touch.time, touch.peak.mean_pressure))
            }
            _ => None,
        })
        .collect();
    // The lean itself was never seen (the baseline took it for rest); the light press at the
    // same place reads its 60 counts, and the other press is found too.
    assert_eq!(released.len(), 2, "{released:?}");
    assert!(
        (released[0].0 - 5.0).abs() < 0.11 && (released[0].2 - 60.0).abs() < 5.0,
        "{released:?}"
    );
    assert!((released[1].0 - 7.0).abs() < 0.11, "{released:?}");
    let summary = session.summary(10.0).to_string();
    assert!(
        summary.contains(&format!(
            "baseline corrected 1 time(s), {pressed} taxel offset(s) reset"
        )),
        "{summary}"
    );
    assert_eq!(session.stats().baseline_corrections, (1, pressed as u64));
}

//! The stitched session placed by the robot's joint states (`[stitch] urdf`, a
//! [`PostureFeed`]) instead of a poses file: the same postures give the same events and the
//! same stitched images, pixel for pixel; faulty joint states are events, and the run goes on.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_can::candump::CandumpLog;
use skin_learn::session::{Event, FrameView, FromConfig, PostureFeed, Session, SessionConfig, Sink};
use std::path::{Path, PathBuf};

fn arm() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm")
}

/// The fixture arm's session, touches only (no models), making stitched images; `live`: with
/// its URDF only (no poses file), so that only joint states can place the wrist.
fn session_of(live: bool) -> Session {
    let mut config = SessionConfig::read(&arm().join("run.toml")).unwrap();
    config.classifier = None;
    if live {
        config.stitch.as_mut().unwrap().poses = None;
    }
    let mut s = Session::from_config(&config).unwrap();
    s.set_frame_images(true);
    s
}

/// Events (JSON lines) and stitched images of a run.
#[derive(Default)]
struct Run {
    events: Vec<String>,
    images: Vec<(u64, Vec<u8>)>,
}

impl Sink for Run {
    type Error = std::convert::Infallible;
    fn event(&mut self, e: &Event) -> Result<skin_learn::session::Flow, Self::Error> {
        let mut line = Vec::new();
        e.write_json(&mut line).unwrap();
        self.events.push(String::from_utf8(line).unwrap());
        Ok(std::ops::ControlFlow::Continue(()))
    }
    fn frame_image(
        &mut self,
        view: FrameView<'_>,
        cycle: u64,
        image: skin_core::image::ImageView<'_, u8>,
    ) -> Result<skin_learn::session::Flow, Self::Error> {
        if matches!(view, FrameView::Stitched) {
            self.images.push((cycle, image.pixels().to_vec()));
        }
        Ok(std::ops::ControlFlow::Continue(()))
    }
}

fn session() -> Session {
    session_of(false)
}

fn run(mut session: Session) -> Run {
    let log = arm().join("touch.candump.log");
    let mut out = Run::default();
    session
        .run_log(&CandumpLog::read(&log).unwrap(), &log, &mut out, &mut |_, _| {})
        .unwrap();
    out
}

/// The log's clock: its first frame, ns since the epoch.
const T0_NS: i128 = 1_700_000_000 * 1_000_000_000;

/// The wrist's roll at `t` s into the log, as poses.json has it: -0.5 rad, 0, then +0.5 rad
/// from 2 s and 4 s.
fn roll(t: f64) -> f64 {
    if t < 2.0 {
        -0.5
    } else if t < 4.0 {
        0.0
    } else {
        0.5
    }
}

/// Joint states every 10 ms over the log (and a second past it), as a robot publishes them.
fn publish(feed: &PostureFeed, names: &[&str], mut position: impl FnMut(f64) -> Vec<f64>) {
    for k in 0..700 {
        let t = k as f64 * 0.01;
        feed.push(T0_NS + k * 10_000_000, names.iter().copied(), &position(t));
    }
}

#[test]
fn joint_states_give_the_events_and_images_of_the_recorded_postures() {
    let recorded = run(session());
    assert!(
        recorded
            .events
            .iter()
            .filter(|e| e.contains("\"across_joint\""))
            .count()
            >= 3,
        "{:?}",
        recorded.events
    );
    let mut live = session_of(true);
    let feed = live.joint_state_feed(None, false).unwrap();
    assert_eq!(feed.joints(), ["wrist_roll"]);
    // With a gripper's joint in the message too, as a whole robot's joint states have.
    publish(&feed, &["gripper", "wrist_roll"], |t| vec![0.01, roll(t)]);
    let live = run(live);
    assert_eq!(live.events, recorded.events);
    assert_eq!(live.images.len(), recorded.images.len());
    for ((c, a), (_, b)) in live.images.iter().zip(&recorded.images) {
        assert!(a == b, "frame {c}: the stitched images differ");
    }
    assert_eq!(feed.counts().taken, 700);
}

#[test]
fn faulty_joint_states_are_one_event_each_and_the_run_goes_on() {
    let mut s = session_of(true);
    let feed = s.joint_state_feed(None, false).unwrap();
    // Good until 1 s; then a NaN, the joint missing, another robot, a stamp from the past;
    // then nothing from 3 s on (stale).
    for k in 0..300 {
        let t = k as f64 * 0.01;
        let stamp = T0_NS + k * 10_000_000;
        match k {
            0..100 => feed.push(stamp, ["wrist_roll"], &[roll(t)]),
            100..120 => feed.push(stamp, ["wrist_roll"], &[f64::NAN]),
            120..140 => feed.push(stamp, ["elbow"], &[0.1]),
            140..160 => feed.push(stamp, ["head_pan", "head_tilt"], &[0.0, 0.0]),
            160..170 => feed.push(T0_NS, ["wrist_roll"], &[0.0]),
            _ => feed.push(stamp, ["wrist_roll"], &[roll(t)]),
        }
    }
    let out = run(s);
    let faults: Vec<serde_json::Value> = out
        .events
        .iter()
        .map(|e| serde_json::from_str::<serde_json::Value>(e).unwrap())
        .filter(|e| e["event"] == "joint_states")
        .collect();
    let problems: Vec<&str> = faults.iter().map(|e| e["problem"].as_str().unwrap()).collect();
    // Each fault once, however many messages had it ("elbow" alone, without the chain's only
    // joint, is another robot's as the head's are). Stale twice: the good posture of 0.99 s
    // grows old under the faulty messages, and again when the joint states stop at 3 s.
    for p in ["not_finite", "other_robot", "out_of_order"] {
        assert_eq!(
            problems.iter().filter(|q| **q == p).count(),
            1,
            "{p}: {problems:?}"
        );
    }
    // (A stale posture is said again only a second after it was last: the second time, 2 s of
    // log later, is within that second of the run's time here, or not.)
    let stale = problems.iter().filter(|q| **q == "stale").count();
    assert!((1..=2).contains(&stale), "{problems:?}");
    let other = faults.iter().find(|e| e["problem"] == "other_robot").unwrap();
    assert_eq!(other["joints"], serde_json::json!(["elbow"]));
    // A touch while the posture is stale (the joint states stopped at 3 s, 0.5 s old by 3.5 s)
    // is not placed in the base frame: that posture is not where the robot is now.
    let parsed: Vec<serde_json::Value> = (out.events.iter())
        .map(|e| serde_json::from_str(e).unwrap())
        .collect();
    let late: Vec<&serde_json::Value> = (parsed.iter())
        .filter(|e| e["event"] == "appeared" && e["time"].as_f64().unwrap() > 3.6)
        .collect();
    assert!(!late.is_empty(), "{:?}", out.events);
    assert!(late.iter().all(|e| e.get("centroid_base").is_none()), "{late:?}");
    // Every touch is still tracked to its end.
    let appeared = out.events.iter().filter(|e| e.contains("\"appeared\"")).count();
    let released = out.events.iter().filter(|e| e.contains("\"released\"")).count();
    assert!(appeared > 0 && appeared == released, "{:?}", out.events);
}

/// `centroid_base` of an event's JSON, and its link-frame `centroid`.
fn centroids(e: &serde_json::Value) -> Option<(nalgebra::Point3<f64>, nalgebra::Point3<f64>)> {
    let p = |v: &serde_json::Value| {
        let c: Vec<f64> = serde_json::from_value(v.clone()).ok()?;
        Some(nalgebra::Point3::new(c[0], c[1], c[2]))
    };
    Some((p(&e["centroid"])?, p(e.get("centroid_base")?)?))
}

#[test]
fn joint_states_place_every_touch_in_the_base_frame() {
    // The fixture arm: the forearm is the chain's base, the wrist rolls about y at 0.342 m.
    let mut s = session_of(true);
    let feed = s.joint_state_feed(None, false).unwrap();
    publish(&feed, &["wrist_roll"], |t| vec![roll(t)]);
    let out = run(s);
    let mut placed = 0;
    for e in out
        .events
        .iter()
        .map(|e| serde_json::from_str::<serde_json::Value>(e).unwrap())
    {
        if e["event"] != "appeared" {
            continue;
        }
        let (c, base) = centroids(&e).expect("every touch placed");
        let pose = match e["link"].as_str().unwrap() {
            "forearm" => nalgebra::Isometry3::identity(),
            _ => {
                let t = e["time"].as_f64().unwrap();
                nalgebra::Isometry3::new(
                    nalgebra::Vector3::new(0.0, 0.342, 0.0),
                    nalgebra::Vector3::y() * roll(t),
                )
            }
        };
        // Both rounded to 0.1 mm in JSON.
        assert!((pose * c - base).norm() < 2e-4, "{e}");
        placed += usize::from(e["link"] == "wrist");
    }
    assert!(placed > 0, "no touch on the wrist: {:?}", out.events);
    // Without joint states, stitched only at the middle of the joint's limits (no poses file):
    // no posture is the robot's, so no touch is placed.
    let unplaced = run(session_of(true));
    assert!(unplaced.events.iter().all(|e| !e.contains("centroid_base")));
}

#[test]
fn a_single_link_is_placed_by_the_joint_states_of_its_urdf() {
    // The fixture forearm (one link, nothing to stitch) on an elbow 0.3 m out along x, turning
    // about z: its touches are given in the base frame at the elbow's angle.
    let dir = tempfile::tempdir().unwrap();
    let fixtures = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures");
    std::fs::write(
        dir.path().join("arm.urdf"),
        r#"<robot name="one"><link name="base"/><link name="forearm"/>
        <joint name="elbow" type="revolute"><parent link="base"/><child link="forearm"/>
        <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint></robot>"#,
    )
    .unwrap();
    let config = dir.path().join("run.toml");
    std::fs::write(
        &config,
        format!(
            "layout = {:?}\nbusmap = {:?}\ncache = {:?}\n[stitch]\nurdf = \"arm.urdf\"\nbase = \"base\"\n",
            fixtures.join("forearm/layout.json"),
            fixtures.join("forearm/busmap.toml"),
            fixtures.join("../target/skin-cache"),
        ),
    )
    .unwrap();
    let mut s = Session::from_config(&SessionConfig::read(&config).unwrap()).unwrap();
    let feed = s.joint_state_feed(None, false).unwrap();
    // Without `base`, the one link would be its own base: no joint to place it by, said so.
    let text = std::fs::read_to_string(&config).unwrap();
    let baseless = dir.path().join("baseless.toml");
    std::fs::write(&baseless, text.replace("base = \"base\"\n", "")).unwrap();
    let refused = Session::from_config(&SessionConfig::read(&baseless).unwrap()).unwrap_err();
    assert!(refused.to_string().contains("set [stitch] base"), "{refused}");
    let angle = |t: f64| 0.8 * (t / 5.0).sin();
    for k in 0..3200 {
        feed.push(T0_NS + k * 10_000_000, ["elbow"], &[angle(k as f64 * 0.01)]);
    }
    let log = fixtures.join("session/session.candump.log");
    let mut out = Run::default();
    s.run_log(&CandumpLog::read(&log).unwrap(), &log, &mut out, &mut |_, _| {})
        .unwrap();
    let appeared: Vec<serde_json::Value> = (out.events.iter())
        .map(|e| serde_json::from_str::<serde_json::Value>(e).unwrap())
        .filter(|e| e["event"] == "appeared")
        .collect();
    assert!(appeared.len() >= 5, "{:?}", out.events);
    for e in &appeared {
        let (c, base) = centroids(e).expect("placed");
        let t = e["time"].as_f64().unwrap();
        let pose = nalgebra::Isometry3::new(
            nalgebra::Vector3::new(0.3, 0.0, 0.0),
            nalgebra::Vector3::z() * angle(t),
        );
        assert!((pose * c - base).norm() < 2e-4, "{e}");
    }
}

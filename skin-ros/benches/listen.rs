//! The per-frame cost of a stitched session that listens to the robot's joint states
//! (`--joint-states`), with nobody publishing and with a peer flooding the topic: 10,000 samples
//! a second on loopback (Zenoh), each decoded and rejected on Zenoh's threads while the frames
//! go on. The fixture arm (forearm and wrist, 990 taxels, a palm across the joint) through
//! `Session::push`, one frame an iteration, its recording replayed over and over.
//!
//! Three cases, same run: no subscription; the subscription with nobody publishing; flooded.
//! The acceptance: flooded within 10% of none.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use skin_learn::session::{Event, FromConfig, Session, SessionConfig};
use skin_ros::{ZenohOptions, ZenohOutlet};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};
use zenoh::Wait;

fn session() -> Session {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm");
    let mut config = SessionConfig::read(&dir.join("run.toml")).unwrap();
    config.classifier = None;
    Session::from_config(&config).unwrap()
}

/// The fixture arm's recording as readings per link (layout order), frame by frame.
fn frames(session: &Session) -> Vec<Vec<Vec<f32>>> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm");
    let rec = skin_core::format::recording::read(&dir.join("touch.txt")).unwrap();
    let index: std::collections::HashMap<u32, usize> = rec
        .taxel_ids
        .iter()
        .enumerate()
        .map(|(i, id)| (id.0, i))
        .collect();
    rec.frames
        .iter()
        .map(|f| {
            session
                .links()
                .iter()
                .map(|l| l.taxels.iter().map(|t| f.values[index[&t.id.0]]).collect())
                .collect()
        })
        .collect()
}

/// Pushes frame after frame, the recording over and over at 20 Hz.
fn bench_frames(
    b: &mut criterion::Bencher<'_>,
    session: &mut Session,
    frames: &[Vec<Vec<f32>>],
    k: &mut u64,
) {
    let mut events: Vec<Event> = Vec::new();
    b.iter(|| {
        let f = &frames[(*k as usize) % frames.len()];
        let _ = session.push(*k * 50_000, *k, f, &mut events).unwrap();
        events.clear();
        *k += 1;
    });
}

/// A peer publishing `rate` samples a second on the joint-state topic until `stop`: a third
/// garbage CDR, a third another type hash, a third a JointState of another robot.
fn flood(port: u16, rate: u64, stop: Arc<AtomicBool>, sent: Arc<AtomicU64>) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut config = zenoh::Config::default();
        for (k, v) in [
            ("mode", "\"peer\"".to_owned()),
            ("scouting/multicast/enabled", "false".to_owned()),
            ("connect/endpoints", format!("[\"tcp/127.0.0.1:{port}\"]")),
            ("listen/endpoints", "[]".to_owned()),
        ] {
            config.insert_json5(k, &v).unwrap();
        }
        let session = zenoh::open(config).wait().unwrap();
        let hash = skin_ros::interfaces::Interfaces::skin()
            .unwrap()
            .type_hash(skin_ros::JOINT_STATE)
            .unwrap();
        let dds = "sensor_msgs::msg::dds_::JointState_";
        let right = session
            .declare_publisher(format!("0/joint_states/{dds}/{hash}"))
            .wait()
            .unwrap();
        let wrong = session
            .declare_publisher(format!("0/joint_states/{dds}/RIHS01_{}", "0".repeat(64)))
            .wait()
            .unwrap();
        let mut w = skin_ros::cdr::CdrWriter::new();
        w.start();
        w.i32(1)
            .u32(0)
            .string("")
            .seq_len(2)
            .string("head_pan")
            .string("head_tilt");
        w.seq_len(2).f64(0.0).f64(0.0).seq_len(0).seq_len(0);
        let other = w.bytes().to_vec();
        let garbage = [0u8, 1, 0, 0, 0xff, 0xff, 0xff, 0x7f, 1, 2, 3];
        let mut attachment = [0u8; 33];
        attachment[16] = 16;
        let start = Instant::now();
        let mut n = 0u64;
        while !stop.load(Ordering::Relaxed) {
            attachment[..8].copy_from_slice(&(n as i64 + 1).to_le_bytes());
            let (publisher, payload): (_, &[u8]) = match n % 3 {
                0 => (&right, &garbage),
                1 => (&wrong, &other),
                _ => (&right, &other),
            };
            let _ = publisher.put(payload).attachment(attachment.as_slice()).wait();
            n += 1;
            sent.store(n, Ordering::Relaxed);
            // Paced to `rate` a second.
            let due = Duration::from_secs_f64(n as f64 / rate as f64);
            if let Some(ahead) = due.checked_sub(start.elapsed()) {
                std::thread::sleep(ahead);
            }
        }
        let _ = session.close().wait();
    })
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("frame path, fixture arm stitched, joint states");
    let mut plain = session();
    let frames = frames(&plain);
    let mut k = 0;
    group.bench_function("no subscription", |b| {
        bench_frames(b, &mut plain, &frames, &mut k)
    });

    let mut listening = session();
    let feed = listening.joint_state_feed(None, false).unwrap();
    let port = {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        l.local_addr().unwrap().port()
    };
    let topics = skin_ros::RosOptions::default().topics(listening.links()).unwrap();
    let options = ZenohOptions {
        listen: vec![format!("tcp/127.0.0.1:{port}")],
        ..ZenohOptions::default()
    };
    let mut outlet = ZenohOutlet::open(&topics, &options).unwrap();
    outlet.listen_joint_states("/joint_states", feed.clone()).unwrap();
    let mut k = 0;
    group.bench_function("subscribed, nobody publishing", |b| {
        bench_frames(b, &mut listening, &frames, &mut k)
    });

    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let flooder = flood(port, 10_000, stop.clone(), sent.clone());
    assert!(
        outlet.wait_for_peer(Duration::from_secs(10)),
        "the flooding peer did not connect"
    );
    let start = Instant::now();
    let before = feed.counts().received;
    group.bench_function("subscribed, flooded at 10,000 samples a second", |b| {
        bench_frames(b, &mut listening, &frames, &mut k)
    });
    let seconds = start.elapsed().as_secs_f64();
    stop.store(true, Ordering::Relaxed);
    flooder.join().unwrap();
    let counts = outlet.listen_counts();
    eprintln!(
        "flood: {} samples sent, {:.0} a second received by the subscription over {seconds:.1} s; {} reached the feed (another robot's joints), {:?}",
        sent.load(Ordering::Relaxed),
        counts[0].1[0] as f64 / seconds,
        feed.counts().received - before,
        counts
    );
    group.finish();
    let _ = outlet.close(Duration::from_secs(1));
}

criterion_group!(benches, bench);
criterion_main!(benches);

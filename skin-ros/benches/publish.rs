//! The per-frame cost of the ROS 2 outputs on the thesis' full arm: 3,495 taxels on three links
//! (half-cylinder covers, 8 mm pitch, 1,165 taxels each) with a whole hand on the middle link,
//! through `RosSink::frame`: a PointCloud2 per link, the frame's contacts (skin_msgs/Contacts)
//! and their RViz arrows (MarkerArray), each encoded as CDR and handed to an outlet:
//!
//! - `encode`: an outlet that keeps nothing (the encoding alone);
//! - `mcap`: an MCAP file being written (feature mcap);
//! - `zenoh`: the live outlet with no peer (the frame path's copy into the queue; feature zenoh).
//!
//! The budget of the whole per-frame path is 5 ms (SPEC: 200 Hz).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the bench

use criterion::{Criterion, criterion_group, criterion_main};
use skin_learn::model::Models;
use skin_learn::session::{ProcessedFrame, Sink};
use skin_learn::touch::{TouchOptions, TouchPipeline};
use skin_ros::{Outlet, RosOptions, RosSink};

use skin_learn::synth::arm::{hand_on_middle_link, links_and_maps};

/// Keeps nothing.
struct Discard(usize);

impl Outlet for Discard {
    fn publish(&mut self, _topic: usize, _stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        self.0 += cdr.len();
        Ok(())
    }
}

fn bench(c: &mut Criterion) {
    let (links, maps) = links_and_maps().unwrap();
    let pressures = hand_on_middle_link(&links, &maps[1]).unwrap();
    // The threshold BENCHMARKS.md's figures were measured at.
    let options = TouchOptions {
        threshold: 10.0,
        ..TouchOptions::default()
    };
    let mut pipeline = TouchPipeline::new(maps, Models::none(), options).unwrap();
    pipeline.process(1.0, &pressures, &mut Vec::new()).unwrap();
    let contacts = pipeline.contacts(1).len();
    assert!(contacts > 0, "the hand makes no contact");
    let options = RosOptions::default();
    let topics = options.topics(&links).unwrap();
    let frame = ProcessedFrame::new(1_700_000_000_000_000, 1.0, 20, &pressures, &pipeline);
    eprintln!(
        "{} taxels, {contacts} contacts on the middle link",
        links.iter().map(|l| l.taxels.len()).sum::<usize>()
    );

    let mut group = c.benchmark_group("ros2 per frame, 3495 taxels");
    let mut sink = RosSink::new(&links, topics.clone(), Discard(0));
    group.bench_function("encode", |b| b.iter(|| sink.frame(&frame).unwrap()));

    #[cfg(feature = "mcap")]
    {
        // A fresh file every 1,000 frames (opened and dropped outside the timing): one file for
        // all of criterion's iterations would grow to gigabytes (210 kB a frame).
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bench.mcap");
        let inputs = skin_core::output::Inputs::default();
        group.bench_function("mcap", |b| {
            b.iter_custom(|iters| {
                let mut spent = std::time::Duration::ZERO;
                let mut left = iters;
                while left > 0 {
                    let outlet = skin_ros::McapOutlet::create(&path, &topics, &inputs).unwrap();
                    let mut sink = RosSink::new(&links, topics.clone(), outlet);
                    let n = left.min(1000);
                    let start = std::time::Instant::now();
                    for _ in 0..n {
                        let _ = sink.frame(&frame).unwrap();
                    }
                    spent += start.elapsed();
                    left -= n;
                }
                spent
            })
        });
    }
    #[cfg(feature = "zenoh")]
    {
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .unwrap()
            .local_addr()
            .unwrap()
            .port();
        let z = skin_ros::ZenohOptions {
            listen: vec![format!("tcp/127.0.0.1:{port}")],
            ..skin_ros::ZenohOptions::default()
        };
        let outlet = skin_ros::ZenohOutlet::open(&topics, &z).unwrap();
        let mut sink = RosSink::new(&links, topics.clone(), outlet);
        group.bench_function("zenoh", |b| b.iter(|| sink.frame(&frame).unwrap()));
        let report = sink.into_outlet().close(std::time::Duration::from_secs(5));
        let (given, dropped) = report
            .topics
            .iter()
            .fold((0, 0), |(g, d), t| (g + t.given, d + t.dropped));
        eprintln!("zenoh: {given} messages, {dropped} dropped (no peer)");
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

//! The live outlet under load, against a Zenoh subscriber of its own in this process (no
//! Python): a subscriber that takes 10 ms a sample in Zenoh's receiving thread, flooded with
//! clouds, still receives every event, in order, and the outlet's counts say what became of
//! each topic's messages.

#![cfg(feature = "zenoh")]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use skin_ros::topics::Topics;
use skin_ros::{Outlet, ZenohOptions, ZenohOutlet};
use skin_test_support::cli::free_port;
use std::sync::{Arc, Mutex};
use std::time::Duration;
use zenoh::Wait;

/// What a subscriber received: (key expression, payload), in order.
type Received = Arc<Mutex<Vec<(String, Vec<u8>)>>>;

/// A Zenoh peer listening on `port`, subscribed to `key`, `delay` a sample: what it received.
fn slow_subscriber(port: u16, key: &str, delay: Duration) -> (zenoh::Session, Received) {
    let mut config = zenoh::Config::default();
    for (k, v) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", format!("[\"tcp/127.0.0.1:{port}\"]")),
    ] {
        config.insert_json5(k, &v).unwrap();
    }
    let session = zenoh::open(config).wait().unwrap();
    let got = Arc::new(Mutex::new(Vec::new()));
    let g = got.clone();
    session
        .declare_subscriber(key.to_owned())
        .callback(move |s| {
            std::thread::sleep(delay);
            g.lock()
                .unwrap()
                .push((s.key_expr().to_string(), s.payload().to_bytes().to_vec()));
        })
        .background()
        .wait()
        .unwrap();
    (session, got)
}

/// The events `got` holds, in order, once it holds `count` of them or `timeout` has passed.
fn events_received(got: &Received, count: usize, timeout: Duration) -> Vec<String> {
    let start = std::time::Instant::now();
    loop {
        let events: Vec<String> = got
            .lock()
            .unwrap()
            .iter()
            .filter(|(key, _)| key.starts_with("0/skin/events/"))
            .map(|(_, p)| String::from_utf8_lossy(p).into_owned())
            .collect();
        if events.len() >= count || start.elapsed() >= timeout {
            return events;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn outlet(port: u16, topics: &Topics) -> ZenohOutlet {
    let options = ZenohOptions {
        connect: vec![format!("tcp/127.0.0.1:{port}")],
        ..ZenohOptions::default()
    };
    ZenohOutlet::open(topics, &options).unwrap()
}

#[test]
fn a_slow_subscriber_flooded_with_clouds_receives_every_event() {
    let topics = Topics::new("/skin", &["forearm"], false).unwrap();
    let port = free_port();
    let (subscriber, got) = slow_subscriber(port, "0/**", Duration::from_millis(10));
    let mut outlet = outlet(port, &topics);
    assert!(outlet.wait_for_peer(Duration::from_secs(30)));
    assert!(outlet.wait_for_subscribers(Duration::from_secs(30)));
    assert!(outlet.subscribed().iter().all(|s| *s));
    let cloud = vec![7u8; 14_000];
    let pressure = topics.links[0].pressure;
    for k in 0..100u32 {
        for _ in 0..10 {
            outlet.publish(pressure, 0, &cloud).unwrap();
        }
        outlet
            .publish(topics.events, 0, format!("event {k}").as_bytes())
            .unwrap();
    }
    let report = outlet.close(Duration::from_secs(120));
    // `close` returns once the subscriber's process has read every byte from its socket; the
    // subscriber may still be handing the last batch it read (up to 64 KiB, dozens of events)
    // to its 10 ms callback. Its own pace is not the outlet's to wait for: wait for it here.
    let events = events_received(&got, 100, Duration::from_secs(60));
    let want: Vec<String> = (0..100).map(|k| format!("event {k}")).collect();
    // The report says whether the outlet saw its bytes taken (`in_flight`) should this fail.
    assert_eq!(events, want, "{report:?}");
    let e = &report.topics[topics.events];
    assert!(e.reliable);
    assert_eq!(
        (e.given, e.sent, e.unmatched, e.dropped, e.undelivered),
        (100, 100, 0, 0, 0)
    );
    let c = &report.topics[pressure];
    assert_eq!(c.given, 1000);
    assert_eq!(c.sent + c.unmatched + c.dropped + c.undelivered, c.given, "{c:?}");
    assert!(!report.timed_out, "{report:?}");
    if let Some(f) = report.in_flight {
        assert_eq!(f.bytes, 0, "{report:?}");
        assert!(f.local >= 1, "{report:?}");
    }
    subscriber.close().wait().unwrap();
}

/// Messages published with no subscriber are counted as such, never as handed over.
#[test]
fn messages_without_a_subscriber_are_not_counted_as_sent() {
    let topics = Topics::new("/skin", &["forearm"], false).unwrap();
    let port = free_port();
    // A peer that subscribes to nothing of ours.
    let (subscriber, got) = slow_subscriber(port, "elsewhere/**", Duration::ZERO);
    let mut outlet = outlet(port, &topics);
    assert!(outlet.wait_for_peer(Duration::from_secs(30)));
    assert!(!outlet.wait_for_subscribers(Duration::from_millis(300)));
    for _ in 0..10 {
        outlet.publish(topics.events, 0, b"event").unwrap();
        outlet.publish(topics.contacts, 0, b"contacts").unwrap();
    }
    let report = outlet.close(Duration::from_secs(30));
    for topic in [topics.events, topics.contacts] {
        let t = &report.topics[topic];
        assert_eq!((t.given, t.sent, t.unmatched), (10, 0, 10), "{t:?}");
    }
    assert_eq!(report.peers, 1);
    assert!(got.lock().unwrap().is_empty());
    subscriber.close().wait().unwrap();
}

//! The publishing threads: one puts the events (blocking, at a higher priority), one the frame
//! messages (dropping); what each did with each topic's messages is counted for the report.

use super::config::zenoh_error;
use crate::RosError;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use zenoh::Wait;
use zenoh::qos::{CongestionControl, Priority};

/// A message on its way to a publishing thread.
pub(super) struct Outgoing {
    pub topic: usize,
    pub attachment: [u8; 33],
    pub payload: Vec<u8>,
    /// Messages handed to the events' thread before this one: a frame message is put only once
    /// they are ([`EVENTS_FIRST`]).
    pub after_events: u64,
}

/// How long a frame message waits, at most, for the events queued before it to be put. Events
/// and frames go out on two threads (events must never be dropped, frames may be), yet a
/// subscriber of both (a controller in lock-step with the skin) must see a frame's events before
/// the frame's own messages, as the session gave them. Events are rare and put at once, so the
/// wait is nearly always none; past this bound (a network that blocks the events) the frame goes
/// anyway, and so do the frames after it until newer events are due; the frame path itself never
/// waits.
pub(super) const EVENTS_FIRST: std::time::Duration = std::time::Duration::from_millis(200);

/// What a publishing thread did with each topic's messages.
#[derive(Debug, Default)]
pub(super) struct Counts {
    pub sent: AtomicU64,
    pub unmatched: AtomicU64,
    pub failed: AtomicU64,
}

/// What a publishing thread shares with the outlet.
pub(super) struct Shared {
    pub session: zenoh::Session,
    /// Every peer and router seen connected (their ids).
    pub peers_seen: std::sync::Mutex<std::collections::BTreeSet<String>>,
    pub publishers: Vec<zenoh::pubsub::Publisher<'static>>,
    /// Per topic: a subscriber matches now (kept by Zenoh's matching listeners).
    pub matching: Vec<Arc<AtomicBool>>,
    pub counts: Vec<Counts>,
    /// The transient-local topic (the layout) and its publisher with a cache, which late
    /// subscribers query, as rmw_zenoh's transient-local publishers are.
    pub latched: Option<(usize, zenoh_ext::AdvancedPublisher<'static>)>,
    /// Messages the events' thread has put (or failed to), in order.
    pub events_put: AtomicU64,
}

impl Shared {
    /// The peers and routers connected now, noted among those seen.
    pub fn peers(&self) -> Vec<String> {
        let info = self.session.info();
        let now: Vec<String> = info
            .peers_zid()
            .wait()
            .chain(info.routers_zid().wait())
            .map(|z| z.to_string())
            .collect();
        if let Ok(mut seen) = self.peers_seen.lock() {
            seen.extend(now.iter().cloned());
        }
        now
    }
}

/// What [`declare_publishers`] declared, in topic order.
pub(super) struct Declared {
    pub publishers: Vec<zenoh::pubsub::Publisher<'static>>,
    /// Per topic: a subscriber matches now.
    pub matching: Vec<Arc<AtomicBool>>,
    /// What keeps `matching` up to date (dropped with the outlet).
    pub listeners: Vec<zenoh::matching::MatchingListener<()>>,
}

/// The transient-local publisher of `key` (the layout), as rmw_zenoh declares one: a cache of
/// its last sample that late subscribers query, detectable by them, with sporadic heartbeats so
/// that a reliable subscriber notices a missed sample.
pub(super) fn declare_latched(
    session: &zenoh::Session,
    key: &str,
) -> Result<zenoh_ext::AdvancedPublisher<'static>, RosError> {
    use zenoh_ext::{AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};
    session
        .declare_publisher(key.to_owned())
        .congestion_control(CongestionControl::Block)
        .advanced()
        .cache(CacheConfig::default().max_samples(1))
        .publisher_detection()
        .sample_miss_detection(
            MissDetectionConfig::default().sporadic_heartbeat(std::time::Duration::from_secs(1)),
        )
        .wait()
        .map_err(zenoh_error)
}

/// Publishers, one per key, each with its flag of a matching subscriber (kept by the returned
/// listeners). The events topic (index `events`) blocks rather than drops, at a higher priority.
pub(super) fn declare_publishers(
    session: &zenoh::Session,
    keys: &[String],
    events: usize,
) -> Result<Declared, RosError> {
    let mut publishers = Vec::new();
    let mut matching = Vec::new();
    let mut listeners = Vec::new();
    for (k, key) in keys.iter().enumerate() {
        let (congestion, priority) = if k == events {
            (CongestionControl::Block, Priority::DataHigh)
        } else {
            (CongestionControl::Drop, Priority::Data)
        };
        let publisher = session
            .declare_publisher(key.clone())
            .congestion_control(congestion)
            .priority(priority)
            .wait()
            .map_err(zenoh_error)?;
        let flag = Arc::new(AtomicBool::new(false));
        let f = flag.clone();
        listeners.push(
            publisher
                .matching_listener()
                .callback(move |s| f.store(s.matching(), Ordering::Relaxed))
                .wait()
                .map_err(zenoh_error)?,
        );
        if let Ok(s) = publisher.matching_status().wait() {
            flag.fetch_or(s.matching(), Ordering::Relaxed);
        }
        publishers.push(publisher);
        matching.push(flag);
    }
    Ok(Declared {
        publishers,
        matching,
        listeners,
    })
}

/// Which publishing thread.
#[derive(Clone, Copy)]
enum Kind {
    Events,
    Frames,
}

/// A publishing thread's queue: the events' (blocking puts, unbounded) or the frames'
/// (dropping puts, bounded).
pub(super) enum Queue {
    Events(Receiver<Outgoing>),
    Frames(Receiver<Outgoing>),
}

impl Queue {
    /// Puts every message of the queue until the outlet lets go of it, counting each.
    pub fn publish(self, shared: &Shared, give_back: &Sender<Vec<u8>>) {
        let (self_kind, queue) = match self {
            Queue::Events(q) => (Kind::Events, q),
            Queue::Frames(q) => (Kind::Frames, q),
        };
        // Events the frames stopped waiting for (see the wait below).
        let mut gave_up = 0u64;
        for m in queue {
            let (Some(publisher), Some(counts), Some(matching)) = (
                shared.publishers.get(m.topic),
                shared.counts.get(m.topic),
                shared.matching.get(m.topic),
            ) else {
                continue;
            };
            if matches!(self_kind, Kind::Frames) && m.after_events > gave_up {
                let since = std::time::Instant::now();
                while shared.events_put.load(Ordering::Acquire) < m.after_events {
                    if since.elapsed() >= EVENTS_FIRST {
                        // The events are held up (a blocked link, their thread gone): the frames
                        // go on without them, not 200 ms late each, until newer events are due.
                        gave_up = m.after_events;
                        break;
                    }
                    std::thread::sleep(std::time::Duration::from_micros(50));
                }
            }
            let matched = matching.load(Ordering::Relaxed);
            // Blocking here (events) holds only this thread; the frame path never waits.
            let put = match &shared.latched {
                Some((k, latched)) if *k == m.topic => latched
                    .put(m.payload.as_slice())
                    .attachment(m.attachment.as_slice())
                    .wait(),
                _ => publisher
                    .put(m.payload.as_slice())
                    .attachment(m.attachment.as_slice())
                    .wait(),
            };
            let count = match (put, matched) {
                (Err(_), _) => &counts.failed,
                (Ok(()), true) => &counts.sent,
                (Ok(()), false) => &counts.unmatched,
            };
            count.fetch_add(1, Ordering::Relaxed);
            if matches!(self_kind, Kind::Events) {
                shared.events_put.fetch_add(1, Ordering::Release);
                // Rare enough to note who is there each time (a peer that leaves is said).
                let _ = shared.peers();
            }
            let _ = give_back.send(m.payload);
        }
    }
}

//! Live publishing as rmw_zenoh does (feature `zenoh`): ROS 2 nodes on Zenoh (Jazzy and later)
//! see a node `skin` and its publishers, and subscribe to its topics as to any other.
//!
//! - One Zenoh session, peer mode, multicast scouting off, TCP only: it connects to the
//!   endpoints given (an rmw_zenoh router is `tcp/127.0.0.1:7447`) and/or listens on others.
//!   An endpoint that does not answer is retried in the background (Zenoh's own retry) while
//!   frames go on; [`ZenohOutlet::peers`] tells whether anyone is connected.
//! - Data key expression of a topic: `<domain>/<topic without its leading />/<DDS type>/<RIHS01
//!   hash>`, the DDS type of `pkg/msg/Name` being `pkg::msg::dds_::Name_`. The payload is the
//!   CDR message with its encapsulation header. Each sample carries a 33-byte attachment: the
//!   publisher's sequence number (i64 LE, from 1), the source time (i64 LE, ns since the epoch),
//!   the byte 16 and the publisher's 16-byte GID.
//! - Liveliness tokens, which `ros2 node list` and `ros2 topic list` read: the node,
//!   `@ros2_lv/<domain>/<zid>/0/0/NN/%/<namespace>/<node>`, and one per publisher,
//!   `@ros2_lv/<domain>/<zid>/0/<id>/MP/%/<namespace>/<node>/<topic>/<DDS type>/<hash>/<qos>`,
//!   where a `/` inside a name is written `%`.
//!
//! Under load, as ROS 2 reliable topics are (rmw_zenoh maps a reliable keep-all publisher to
//! Zenoh's blocking congestion control, everything else to dropping):
//!
//! - **Events** (`/skin/events`, offered reliable and keep-all) are never dropped: a thread of
//!   their own puts them with [`CongestionControl::Block`] at a priority above the frames', so
//!   they never wait behind a frame message here or in Zenoh's queues, only behind the frame
//!   bytes already in the connection's system buffer (kept to 256 kB here). Their queue grows
//!   with the touches (one event a line of events.jsonl), not with the frames.
//! - **Frame messages** (clouds, images, contacts, markers, offered reliable and keep-last as
//!   rmw_zenoh's default publishers are, and sent as those are) are best effort: another
//!   thread puts them with [`CongestionControl::Drop`], and when more than
//!   [`ZenohOptions::queue`] of them wait, new ones are dropped here and counted. Zenoh too
//!   may drop one on a congested link, without a count. Dropped messages leave gaps in the
//!   sequence numbers a subscriber sees.
//! - **Order**: a frame message is put only after the events queued before it (waiting at
//!   most [`publish::EVENTS_FIRST`], on its thread), so a subscriber of both hears a frame's
//!   events before the frame's `tactile_state`, as the session gave them: what lets a
//!   simulation run in lock-step with the skin (`skin.sim.zenoh`).
//! - [`Outlet::publish`] never waits for the network: it copies the message into a buffer
//!   taken from a pool and queues it. Memory stays bounded by the frame queue and the events.
//! - A peer that reads slowly is waited for, not cut off: Zenoh closes a link on which a
//!   blocking message has waited [`BLOCK_BEFORE_CLOSE`] (5 s by Zenoh's default, too short
//!   for a subscriber taking 50 ms a sample behind a buffer of clouds); a peer that stops
//!   answering altogether is dropped by Zenoh's lease (10 s) instead, and what was in flight
//!   to it is lost ([`ZenohReport::peers_left`]).
//!
//! [`ZenohOutlet::close`] waits, bounded, until the events are handed to Zenoh and every byte
//! written is taken by the other end of its connection, then says per topic what became of
//! the messages ([`ZenohReport`]). Zenoh reports no receipt by a subscriber, so "taken" is read
//! from the system's socket tables (Linux): a receiver on this machine (a router or node on
//! localhost, a test's peer) has read the bytes into its Zenoh, which hands every sample in
//! them to its subscribers even if the connection then closes; another machine has
//! acknowledged them (TCP), which is less: a receiving Zenoh that tears the connection down
//! before reading its buffer (it does when this session is gone) loses what it had not read.
//!
//! The files: `config` (options, endpoints, the session's configuration), `names` (rmw_zenoh's
//! key expressions, tokens and GIDs), `publish` (the publishing threads and their counts),
//! `in_flight` (the socket tables read at the end); the outlet itself here.
//!
//! [`CongestionControl::Block`]: zenoh::qos::CongestionControl::Block
//! [`CongestionControl::Drop`]: zenoh::qos::CongestionControl::Drop
//! [`BLOCK_BEFORE_CLOSE`]: config::BLOCK_BEFORE_CLOSE

mod config;
mod in_flight;
mod listen;
mod names;
mod publish;
mod services;

pub use config::{MAX_DOMAIN, ZenohOptions, check_endpoint, check_endpoints};
pub use in_flight::InFlight;
pub use listen::{JOINT_STATE, ListenCounts};
pub use services::{ServiceCounts, Services};

use crate::RosError;
use crate::bridge::Outlet;
use crate::interfaces::Interfaces;
use crate::topics::Topics;
use config::{check_listeners, check_options, session_config, zenoh_error};
use in_flight::in_flight;
use names::Names;
use publish::{Counts, Outgoing, Queue, Shared, declare_latched, declare_publishers};
use skin_runtime::session::PostureFeed;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// What became of one topic's messages.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TopicCounts {
    /// The topic, `/skin/events`.
    pub topic: String,
    /// Reliable (the events): never dropped, waited for at the end.
    pub reliable: bool,
    /// Messages the session gave the outlet.
    pub given: u64,
    /// Handed to Zenoh while a subscriber matched (in its queue for each; not a receipt).
    pub sent: u64,
    /// Handed to Zenoh while no subscriber matched: nobody received them.
    pub unmatched: u64,
    /// Dropped here because the frame queue was full (never an event).
    pub dropped: u64,
    /// Not handed to Zenoh: still queued when the wait at the end ran out, or refused by
    /// Zenoh (the session closing under them).
    pub undelivered: u64,
}

/// What [`ZenohOutlet::close`] found.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ZenohReport {
    /// Per topic, in [`Topics::list`] order.
    pub topics: Vec<TopicCounts>,
    /// Where the bytes written stood when the session closed: 0 bytes when every receiver on
    /// this machine had read them and every other machine had acknowledged them (TCP); `None`
    /// where the system does not tell (only Linux does).
    pub in_flight: Option<InFlight>,
    /// Zenoh peers and routers connected at the end.
    pub peers: usize,
    /// Peers and routers seen during the run and gone at the end: what was in flight to them
    /// when they left is lost (they may have left after receiving everything, too).
    pub peers_left: usize,
    /// The wait ran out before everything was handed over and acknowledged.
    pub timed_out: bool,
    /// How long the end waited.
    pub waited: Duration,
    /// What each service served ([`ZenohOutlet::serve`]), as (service, served, refused,
    /// malformed).
    pub services: Vec<(String, u64, u64, u64)>,
    /// What each subscription did with its samples ([`ZenohOutlet::listen_counts`]).
    pub listened: Vec<(String, [u64; 5])>,
}

impl ZenohReport {
    /// Events (reliable messages) not handed to Zenoh.
    pub fn undelivered_events(&self) -> u64 {
        self.topics
            .iter()
            .filter(|t| t.reliable)
            .map(|t| t.undelivered)
            .sum()
    }
}

/// The live outlet: a Zenoh peer publishing as rmw_zenoh does.
pub struct ZenohOutlet {
    frames: Option<SyncSender<Outgoing>>,
    events: Option<Sender<Outgoing>>,
    pool: Receiver<Vec<u8>>,
    give_back: Sender<Vec<u8>>,
    threads: Vec<std::thread::JoinHandle<()>>,
    session: zenoh::Session,
    shared: Arc<Shared>,
    given: Vec<u64>,
    dropped: Vec<u64>,
    sequence: Vec<i64>,
    /// Messages handed to the events' thread so far (frame messages wait for them).
    events_queued: u64,
    gids: Vec<[u8; 16]>,
    events_topic: usize,
    layout_topic: usize,
    names: Vec<String>,
    options: ZenohOptions,
    served: Option<services::Served>,
    listening: Vec<listen::Listening>,
    keys: Vec<String>,
    tokens: Vec<String>,
    _matching: Vec<zenoh::matching::MatchingListener<()>>,
    _liveliness: Vec<zenoh::liveliness::LivelinessToken>,
}

impl std::fmt::Debug for ZenohOutlet {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ZenohOutlet")
            .field("keys", &self.keys)
            .field("dropped", &self.dropped)
            .finish_non_exhaustive()
    }
}

impl ZenohOutlet {
    /// Opens the session and declares the node, a publisher per topic and their tokens.
    pub fn open(topics: &Topics, options: &ZenohOptions) -> Result<ZenohOutlet, RosError> {
        check_options(options)?;
        check_listeners(&options.listen)?;
        let interfaces = Interfaces::skin()?;
        let session = zenoh::open(session_config(options)?)
            .wait()
            .map_err(zenoh_error)?;
        let names = Names::new(topics, &interfaces, &session.zid().to_string(), options)?;
        let declared = declare_publishers(&session, &names.keys, topics.events)?;
        let mut liveliness = Vec::new();
        for t in &names.tokens {
            liveliness.push(
                session
                    .liveliness()
                    .declare_token(t.clone())
                    .wait()
                    .map_err(zenoh_error)?,
            );
        }
        let shared = Arc::new(Shared {
            session: session.clone(),
            peers_seen: std::sync::Mutex::default(),
            publishers: declared.publishers,
            matching: declared.matching,
            counts: (0..names.keys.len()).map(|_| Counts::default()).collect(),
            latched: match names.keys.get(topics.layout) {
                Some(key) => Some((topics.layout, declare_latched(&session, key)?)),
                None => None,
            },
            events_put: AtomicU64::new(0),
        });
        let (give_back, pool) = mpsc::channel::<Vec<u8>>();
        let (frames, frames_queue) = mpsc::sync_channel::<Outgoing>(options.queue.max(1));
        let (events, events_queue) = mpsc::channel::<Outgoing>();
        let mut threads = Vec::new();
        for (name, queue) in [
            ("skin-zenoh-events", Queue::Events(events_queue)),
            ("skin-zenoh-frames", Queue::Frames(frames_queue)),
        ] {
            let shared = shared.clone();
            let give_back = give_back.clone();
            threads.push(
                std::thread::Builder::new()
                    .name(name.into())
                    .spawn(move || queue.publish(&shared, &give_back))
                    .map_err(|e| RosError::Zenoh(format!("cannot start a publishing thread: {e}")))?,
            );
        }
        let n = names.keys.len();
        Ok(ZenohOutlet {
            frames: Some(frames),
            events: Some(events),
            pool,
            give_back,
            threads,
            session,
            shared,
            given: vec![0; n],
            dropped: vec![0; n],
            sequence: vec![0; n],
            events_queued: 0,
            gids: names.gids,
            events_topic: topics.events,
            layout_topic: topics.layout,
            names: topics.list.iter().map(|t| t.name.clone()).collect(),
            options: options.clone(),
            served: None,
            listening: Vec::new(),
            keys: names.keys,
            tokens: names.tokens,
            _matching: declared.listeners,
            _liveliness: liveliness,
        })
    }

    /// Serves `services` under `topics.prefix` (the topics it was opened with), as an rmw_zenoh
    /// node serves its services: `PREFIX/tare`, `PREFIX/tare_forced`, `PREFIX/describe`. Calls
    /// are answered on Zenoh's threads, never the frame path's.
    pub fn serve(&mut self, topics: &Topics, services: Services) -> Result<(), RosError> {
        let zid = self.session.zid().to_string();
        let first_id = self.tokens.len() + 1;
        let served = services::serve(&self.session, topics, services, &self.place(&zid), first_id)?;
        self.served = Some(served);
        Ok(())
    }

    /// Subscribes to `topic` (`/joint_states`) as an rmw_zenoh node would, handing each
    /// `sensor_msgs/JointState` to `feed` (on Zenoh's threads).
    pub fn listen_joint_states(&mut self, topic: &str, feed: PostureFeed) -> Result<(), RosError> {
        let zid = self.session.zid().to_string();
        // After the publishers and the services (three at most).
        let id = self.tokens.len() + 4 + self.listening.len();
        let listening = listen::joint_states(&self.session, topic, feed, &self.place(&zid), id)?;
        self.listening.push(listening);
        Ok(())
    }

    /// Where this node is, for its entities' tokens.
    fn place<'a>(&'a self, zid: &'a str) -> names::Place<'a> {
        names::Place {
            domain: self.options.domain,
            zid,
            namespace: &self.options.namespace,
            node: &self.options.node,
        }
    }

    /// What each subscription did with its samples so far: (topic, received, fed, of another
    /// type, without attachment, malformed).
    pub fn listen_counts(&self) -> Vec<(String, [u64; 5])> {
        self.listening
            .iter()
            .map(|l| {
                let c = &l.counts;
                let n = |a: &std::sync::atomic::AtomicU64| a.load(Ordering::Relaxed);
                (
                    c.topic.clone(),
                    [
                        n(&c.received),
                        n(&c.fed),
                        n(&c.other_type),
                        n(&c.no_attachment),
                        n(&c.malformed),
                    ],
                )
            })
            .collect()
    }

    /// What each service served so far: (service, served, refused, malformed).
    pub fn service_counts(&self) -> Vec<(String, u64, u64, u64)> {
        self.served.as_ref().map_or_else(Vec::new, |s| {
            s.counts
                .iter()
                .map(|c| {
                    (
                        c.name.clone(),
                        c.served.load(Ordering::Relaxed),
                        c.refused.load(Ordering::Relaxed),
                        c.malformed.load(Ordering::Relaxed),
                    )
                })
                .collect()
        })
    }

    /// The data key expression of each topic (in [`Topics::list`] order).
    pub fn keys(&self) -> &[String] {
        &self.keys
    }

    /// The liveliness tokens declared: the node's, then each publisher's.
    pub fn tokens(&self) -> &[String] {
        &self.tokens
    }

    /// Zenoh peers and routers connected now.
    pub fn peers(&self) -> usize {
        self.shared.peers().len()
    }

    /// Waits up to `timeout` for a peer or router to connect; true if one did.
    pub fn wait_for_peer(&self, timeout: Duration) -> bool {
        wait_until(timeout, || self.peers() > 0)
    }

    /// Per topic (in [`Topics::list`] order): a subscriber somewhere matches it now (a ROS
    /// node subscribed to it, a recorder of everything).
    pub fn subscribed(&self) -> Vec<bool> {
        self.shared
            .publishers
            .iter()
            .zip(&self.shared.matching)
            .map(|(p, flag)| {
                p.matching_status()
                    .wait()
                    .map_or(flag.load(Ordering::Relaxed), |m| m.matching())
            })
            .collect()
    }

    /// Waits up to `timeout` until a subscriber somewhere matches any of the topics; true if
    /// one does. Zenoh sends a sample only to the subscribers it knows of: a run that starts
    /// publishing the moment it connects would lose its first messages to a subscriber still
    /// being announced. [`ZenohOutlet::subscribed`] then says which topics have one.
    pub fn wait_for_subscribers(&self, timeout: Duration) -> bool {
        wait_until(timeout, || self.subscribed().contains(&true))
    }

    /// Per topic, what became of its messages so far.
    pub fn counts(&self) -> Vec<TopicCounts> {
        (0..self.names.len())
            .map(|k| {
                let c = &self.shared.counts[k];
                let (sent, unmatched, failed) = (
                    c.sent.load(Ordering::Relaxed),
                    c.unmatched.load(Ordering::Relaxed),
                    c.failed.load(Ordering::Relaxed),
                );
                let done = sent + unmatched + self.dropped[k];
                TopicCounts {
                    topic: self.names[k].clone(),
                    reliable: k == self.events_topic,
                    given: self.given[k],
                    sent,
                    unmatched,
                    dropped: self.dropped[k],
                    // Failed or still queued.
                    undelivered: self.given[k].saturating_sub(done).max(failed),
                }
            })
            .collect()
    }

    /// Ends the session: waits up to `wait` until every queued message is handed to Zenoh and
    /// every byte written is acknowledged by the other end of its connection, then withdraws
    /// the publishers and tokens and closes the session (Zenoh's close, bounded at 10 s,
    /// flushes its own queues). The report says what became of each topic's messages.
    pub fn close(mut self, wait: Duration) -> ZenohReport {
        let start = Instant::now();
        self.frames = None;
        self.events = None;
        let handed = wait_until(wait, || self.threads.iter().all(|t| t.is_finished()));
        let mut flight = in_flight();
        let mut taken = flight.is_some_and(|f| f.bytes == 0);
        if handed && flight.is_some() {
            // Nothing in flight three times running: Zenoh's own queue is empty too (it
            // writes within a millisecond whenever the connection has room).
            let mut zeros = 0;
            taken = wait_until(wait.saturating_sub(start.elapsed()), || {
                flight = in_flight();
                zeros = if flight.is_some_and(|f| f.bytes == 0) {
                    zeros + 1
                } else {
                    0
                };
                if zeros < 3 {
                    std::thread::sleep(Duration::from_millis(20));
                }
                zeros >= 3
            });
        }
        let peers = self.shared.peers();
        let peers_left = self
            .shared
            .peers_seen
            .lock()
            .map_or(0, |seen| seen.iter().filter(|p| !peers.contains(p)).count());
        let report = ZenohReport {
            topics: self.counts(),
            in_flight: flight,
            peers: peers.len(),
            peers_left,
            timed_out: !handed || (flight.is_some() && !taken),
            waited: start.elapsed(),
            services: self.service_counts(),
            listened: self.listen_counts(),
        };
        for t in std::mem::take(&mut self.threads) {
            if t.is_finished() {
                let _ = t.join();
            }
        }
        // Closing undeclares the publishers, matching listeners and tokens with it; a thread
        // still blocked on a peer gets an error and ends.
        let _ = self.session.close().wait();
        report
    }
}

/// Polls `done` every 20 ms for up to `timeout`; true once it holds.
fn wait_until(timeout: Duration, mut done: impl FnMut() -> bool) -> bool {
    let start = Instant::now();
    loop {
        if done() {
            return true;
        }
        if start.elapsed() >= timeout {
            return false;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

impl Outlet for ZenohOutlet {
    fn publish(&mut self, topic: usize, _stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        let Some(seq) = self.sequence.get_mut(topic) else {
            return Err(std::io::Error::other(format!("no topic {topic}")));
        };
        *seq += 1;
        self.given[topic] += 1;
        let attachment = names::attachment(*seq, &self.gids[topic]);
        let mut payload = self.pool.try_recv().unwrap_or_default();
        payload.clear();
        payload.extend_from_slice(cdr);
        let m = Outgoing {
            topic,
            attachment,
            payload,
            after_events: self.events_queued,
        };
        if topic == self.events_topic || topic == self.layout_topic {
            if let Some(events) = &self.events {
                // A send fails only when the thread is gone: counted as undelivered, and
                // not waited for by the frames.
                if events.send(m).is_ok() {
                    self.events_queued += 1;
                }
            }
            return Ok(());
        }
        let Some(frames) = &self.frames else {
            return Ok(());
        };
        match frames.try_send(m) {
            Ok(()) => {}
            Err(TrySendError::Full(m) | TrySendError::Disconnected(m)) => {
                self.dropped[topic] += 1;
                let _ = self.give_back.send(m.payload);
            }
        }
        Ok(())
    }
}

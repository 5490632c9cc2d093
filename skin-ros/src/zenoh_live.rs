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

use crate::RosError;
use crate::bridge::Outlet;
use crate::interfaces::Interfaces;
use crate::topics::{QOS_DEPTH, Topics};
use sha2::{Digest, Sha256};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender, TrySendError};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use zenoh::Wait;
use zenoh::qos::{CongestionControl, Priority};

/// How long a blocking message (an event) may wait for room on a link before Zenoh closes
/// that link: far above what a slow subscriber needs, while a peer that stops answering is
/// dropped by the lease (10 s) whatever this says.
pub const BLOCK_BEFORE_CLOSE: Duration = Duration::from_secs(60);

/// The kernel's send buffer of each connection: bytes of frame messages that can sit in it
/// ahead of an event (a slow subscriber reads them first).
const SEND_BUFFER: u32 = 256 * 1024;

/// How to join the Zenoh network, and as what node.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ZenohOptions {
    /// Endpoints to connect to, `tcp/HOST:PORT`.
    pub connect: Vec<String>,
    /// Endpoints to listen on, `tcp/HOST:PORT`.
    pub listen: Vec<String>,
    /// ROS domain id (`ROS_DOMAIN_ID`), 0 to 232.
    pub domain: u32,
    /// Node name.
    pub node: String,
    /// Node namespace, `/` or `/robot1` ...
    pub namespace: String,
    /// Frame messages (all but events) that may wait for the network before new ones are
    /// dropped.
    pub queue: usize,
}

impl Default for ZenohOptions {
    fn default() -> Self {
        ZenohOptions {
            connect: Vec::new(),
            listen: Vec::new(),
            domain: 0,
            node: "skin".into(),
            namespace: "/".into(),
            queue: 256,
        }
    }
}

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

/// Checks an endpoint: `tcp/HOST:PORT` (TCP is the only transport built in).
pub fn check_endpoint(endpoint: &str) -> Result<(), RosError> {
    let bad = |why: &str| RosError::Endpoint {
        endpoint: endpoint.to_owned(),
        why: why.to_owned(),
    };
    let Some(address) = endpoint.strip_prefix("tcp/") else {
        return Err(bad(
            "only tcp/HOST:PORT endpoints are supported (e.g. tcp/127.0.0.1:7447)",
        ));
    };
    let Some((host, port)) = address.rsplit_once(':') else {
        return Err(bad("it needs a port (tcp/HOST:PORT)"));
    };
    if host.is_empty() {
        return Err(bad("it needs a host (tcp/HOST:PORT)"));
    }
    if port.parse::<u16>().is_err() {
        return Err(bad("the port is not a number from 0 to 65535"));
    }
    Ok(())
}

/// Checks a set of endpoints: each valid ([`check_endpoint`]), none given twice, none both
/// connected to and listened on (the session would connect to itself).
pub fn check_endpoints(connect: &[String], listen: &[String]) -> Result<(), RosError> {
    for e in connect.iter().chain(listen) {
        check_endpoint(e)?;
    }
    let twice = |list: &[String], what: &str| {
        for (k, e) in list.iter().enumerate() {
            if list[..k].contains(e) {
                return Err(RosError::Endpoint {
                    endpoint: e.clone(),
                    why: format!("given twice to {what}: give each endpoint once"),
                });
            }
        }
        Ok(())
    };
    twice(connect, "connect to")?;
    twice(listen, "listen on")?;
    if let Some(e) = connect.iter().find(|e| listen.contains(e)) {
        return Err(RosError::Endpoint {
            endpoint: e.clone(),
            why: "both connected to and listened on: the session would connect to itself".into(),
        });
    }
    Ok(())
}

/// The largest ROS domain id (`ROS_DOMAIN_ID`).
pub const MAX_DOMAIN: u32 = 232;

/// `pkg/msg/Name` -> `pkg::msg::dds_::Name_`.
pub fn dds_type(name: &str) -> String {
    let mut parts: Vec<&str> = name.split('/').collect();
    let last = parts.pop().unwrap_or_default();
    format!("{}::dds_::{last}_", parts.join("::"))
}

/// A name with every `/` written `%`, an empty one written `%`.
fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".into()
    } else {
        name.replace('/', "%")
    }
}

/// The rmw_zenoh QoS string of the offered QoS: reliable, volatile, keep all (the events) or
/// keep last 10, default deadline, lifespan and liveliness.
fn qos_string(keep_all: bool) -> String {
    if keep_all {
        "1:2:2,0:,:,:,,".to_owned()
    } else {
        format!("1:2:1,{QOS_DEPTH}:,:,:,,")
    }
}

/// A message on its way to a publishing thread.
struct Outgoing {
    topic: usize,
    attachment: [u8; 33],
    payload: Vec<u8>,
}

/// What a publishing thread did with each topic's messages.
#[derive(Debug, Default)]
struct Counts {
    sent: AtomicU64,
    unmatched: AtomicU64,
    failed: AtomicU64,
}

/// What a publishing thread shares with the outlet.
struct Shared {
    session: zenoh::Session,
    /// Every peer and router seen connected (their ids).
    peers_seen: std::sync::Mutex<std::collections::BTreeSet<String>>,
    publishers: Vec<zenoh::pubsub::Publisher<'static>>,
    /// Per topic: a subscriber matches now (kept by Zenoh's matching listeners).
    matching: Vec<Arc<AtomicBool>>,
    counts: Vec<Counts>,
}

impl Shared {
    /// The peers and routers connected now, noted among those seen.
    fn peers(&self) -> Vec<String> {
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

/// The live outlet (see the [module](self)).
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
    gids: Vec<[u8; 16]>,
    events_topic: usize,
    names: Vec<String>,
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

/// A Zenoh error as one line: without the source file and line Zenoh appends (a path inside
/// the build machine's crate registry means nothing to a user).
fn zenoh_error(e: impl std::fmt::Display) -> RosError {
    RosError::Zenoh(without_source(&e.to_string()))
}

/// `text` without its ` at /path/file.rs:123.` parts, on one line.
fn without_source(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(k) = rest.find(" at ") {
        let after = &rest[k + 4..];
        let token_end = after.find(char::is_whitespace).unwrap_or(after.len());
        let token = &after[..token_end];
        out.push_str(&rest[..k]);
        if token.contains(".rs:") {
            rest = &after[token_end..];
        } else {
            out.push_str(" at ");
            rest = after;
        }
    }
    out.push_str(rest);
    out.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The endpoints (at least one), and the domain.
fn check_options(options: &ZenohOptions) -> Result<(), RosError> {
    check_endpoints(&options.connect, &options.listen)?;
    if options.connect.is_empty() && options.listen.is_empty() {
        return Err(RosError::Endpoint {
            endpoint: String::new(),
            why: "give an endpoint to connect to or to listen on".into(),
        });
    }
    if options.domain > MAX_DOMAIN {
        return Err(RosError::Domain(options.domain));
    }
    Ok(())
}

/// Every endpoint to listen on can be had.
///
/// A listener that cannot be had (an address not of this machine, a port in use, two endpoints
/// on one port) is said plainly here; Zenoh's own error names its source files. All are held at
/// once, so that two endpoints on one port are found, and let go before Zenoh takes them.
fn check_listeners(listen: &[String]) -> Result<(), RosError> {
    let mut held: Vec<(std::net::TcpListener, &String)> = Vec::new();
    for e in listen {
        let address = e.strip_prefix("tcp/").unwrap_or(e);
        match std::net::TcpListener::bind(address) {
            Ok(l) => held.push((l, e)),
            Err(err) => {
                let port = address.rsplit_once(':').map(|(_, p)| p.parse::<u16>().ok());
                let same = held.iter().find(|(l, _)| {
                    port.flatten()
                        .is_some_and(|p| l.local_addr().is_ok_and(|a| a.port() == p))
                });
                return Err(RosError::Endpoint {
                    endpoint: e.clone(),
                    why: match same {
                        Some((_, other)) => format!(
                            "cannot listen there: {other} already listens on that port (give it once)"
                        ),
                        None => format!("cannot listen there: {err}"),
                    },
                });
            }
        }
    }
    drop(held);
    Ok(())
}

/// The Zenoh configuration of a peer as rmw_zenoh's nodes are: no multicast scouting, the
/// endpoints given, blocking publishers' wait bounded, the socket's send buffer set.
fn session_config(options: &ZenohOptions) -> Result<zenoh::Config, RosError> {
    let mut config = zenoh::Config::default();
    let json = |v: &[String]| serde_json::to_string(v).unwrap_or_else(|_| "[]".into());
    for (key, value) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("connect/endpoints", json(&options.connect)),
        ("listen/endpoints", json(&options.listen)),
        // Keep trying an endpoint that does not answer, without failing the open.
        ("connect/exit_on_failure", "false".to_owned()),
        ("connect/timeout_ms", "0".to_owned()),
        ("listen/exit_on_failure", "true".to_owned()),
        (
            "transport/link/tx/queue/congestion_control/block/wait_before_close",
            BLOCK_BEFORE_CLOSE.as_micros().to_string(),
        ),
        ("transport/link/tcp/so_sndbuf", SEND_BUFFER.to_string()),
    ] {
        config.insert_json5(key, &value).map_err(zenoh_error)?;
    }
    Ok(config)
}

/// What rmw_zenoh names for a node and its publishers: per topic the data key expression and
/// the publisher's gid; the liveliness tokens, the node's first.
struct Names {
    keys: Vec<String>,
    tokens: Vec<String>,
    gids: Vec<[u8; 16]>,
}

impl Names {
    fn new(
        topics: &Topics,
        interfaces: &Interfaces,
        zid: &str,
        options: &ZenohOptions,
    ) -> Result<Names, RosError> {
        let domain = options.domain;
        let namespace = mangle(options.namespace.trim_end_matches('/'));
        let node = &options.node;
        let mut tokens = vec![format!("@ros2_lv/{domain}/{zid}/0/0/NN/%/{namespace}/{node}")];
        let mut keys = Vec::new();
        let mut gids = Vec::new();
        for (k, topic) in topics.list.iter().enumerate() {
            let hash = interfaces
                .type_hash(topic.type_name)
                .ok_or(RosError::UnknownType(topic.type_name))?;
            let dds = dds_type(topic.type_name);
            keys.push(format!(
                "{domain}/{}/{dds}/{hash}",
                topic.name.trim_start_matches('/')
            ));
            let id = k + 1;
            tokens.push(format!(
                "@ros2_lv/{domain}/{zid}/0/{id}/MP/%/{namespace}/{node}/{}/{dds}/{hash}/{}",
                mangle(&topic.name),
                qos_string(k == topics.events)
            ));
            let digest = Sha256::digest(format!("{zid}/{id}").as_bytes());
            let mut gid = [0u8; 16];
            gid.copy_from_slice(&digest[..16]);
            gids.push(gid);
        }
        Ok(Names { keys, tokens, gids })
    }
}

/// Publishers, one per key, each with its flag of a matching subscriber (kept by the returned
/// listeners). The events topic (index `events`) blocks rather than drops, at a higher priority.
#[allow(clippy::type_complexity)] // the three lists ZenohOutlet keeps, in topic order
fn declare_publishers(
    session: &zenoh::Session,
    keys: &[String],
    events: usize,
) -> Result<
    (
        Vec<zenoh::pubsub::Publisher<'static>>,
        Vec<Arc<AtomicBool>>,
        Vec<zenoh::matching::MatchingListener<()>>,
    ),
    RosError,
> {
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
    Ok((publishers, matching, listeners))
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
        let (publishers, matching, listeners) = declare_publishers(&session, &names.keys, topics.events)?;
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
            publishers,
            matching,
            counts: (0..names.keys.len()).map(|_| Counts::default()).collect(),
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
            gids: names.gids,
            events_topic: topics.events,
            names: topics.list.iter().map(|t| t.name.clone()).collect(),
            keys: names.keys,
            tokens: names.tokens,
            _matching: listeners,
            _liveliness: liveliness,
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

/// Which publishing thread.
#[derive(Clone, Copy)]
enum Kind {
    Events,
    Frames,
}

/// A publishing thread's queue: the events' (blocking puts, unbounded) or the frames'
/// (dropping puts, bounded).
enum Queue {
    Events(Receiver<Outgoing>),
    Frames(Receiver<Outgoing>),
}

impl Queue {
    /// Puts every message of the queue until the outlet lets go of it, counting each.
    fn publish(self, shared: &Shared, give_back: &Sender<Vec<u8>>) {
        let (self_kind, queue) = match self {
            Queue::Events(q) => (Kind::Events, q),
            Queue::Frames(q) => (Kind::Frames, q),
        };
        for m in queue {
            let (Some(publisher), Some(counts), Some(matching)) = (
                shared.publishers.get(m.topic),
                shared.counts.get(m.topic),
                shared.matching.get(m.topic),
            ) else {
                continue;
            };
            let matched = matching.load(Ordering::Relaxed);
            // Blocking here (events) holds only this thread; the frame path never waits.
            let put = publisher
                .put(m.payload.as_slice())
                .attachment(m.attachment.as_slice())
                .wait();
            let count = match (put, matched) {
                (Err(_), _) => &counts.failed,
                (Ok(()), true) => &counts.sent,
                (Ok(()), false) => &counts.unmatched,
            };
            count.fetch_add(1, Ordering::Relaxed);
            if matches!(self_kind, Kind::Events) {
                // Rare enough to note who is there each time (a peer that leaves is said).
                let _ = shared.peers();
            }
            let _ = give_back.send(m.payload);
        }
    }
}

/// Where the bytes written to the network stand (see [`in_flight`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct InFlight {
    /// Bytes written and not yet taken: on a connection to a process of this machine, not yet
    /// read by that process; on one to another machine, not yet acknowledged by it.
    pub bytes: u64,
    /// Connections to a process of this machine (a router or node on localhost).
    pub local: usize,
    /// Connections to other machines.
    pub remote: usize,
}

/// Where the bytes this process wrote to its TCP connections stand, read from Linux's socket
/// tables (`/proc/self/net/tcp{,6}`): for each established connection of this process, the
/// bytes the other end has not acknowledged (`tx_queue`) and, where the other end is a process
/// of this machine (its row is in the same table), the bytes that process has not read yet
/// (its `rx_queue`). `None` where the system does not say.
fn in_flight() -> Option<InFlight> {
    #[cfg(target_os = "linux")]
    {
        let mut sockets = std::collections::HashSet::new();
        for entry in std::fs::read_dir("/proc/self/fd").ok()?.flatten() {
            let Ok(target) = std::fs::read_link(entry.path()) else {
                continue;
            };
            if let Some(inode) = target
                .to_string_lossy()
                .strip_prefix("socket:[")
                .and_then(|t| t.strip_suffix(']'))
                .and_then(|t| t.parse::<u64>().ok())
            {
                sockets.insert(inode);
            }
        }
        let mut found = InFlight::default();
        let mut read_any = false;
        for table in ["/proc/self/net/tcp", "/proc/self/net/tcp6"] {
            let Ok(text) = std::fs::read_to_string(table) else {
                continue;
            };
            read_any = true;
            // sl local rem st tx_queue:rx_queue tr:when retrnsmt uid timeout inode ...
            let rows: Vec<Vec<&str>> = text
                .lines()
                .skip(1)
                .map(|l| l.split_whitespace().take(10).collect::<Vec<&str>>())
                .filter(|f| f.len() == 10 && f[3] == "01")
                .collect();
            let queue = |f: &[&str], k: usize| {
                f[4].split(':')
                    .nth(k)
                    .and_then(|q| u64::from_str_radix(q, 16).ok())
                    .unwrap_or(0)
            };
            for ours in rows
                .iter()
                .filter(|f| f[9].parse::<u64>().is_ok_and(|i| sockets.contains(&i)))
            {
                found.bytes += queue(ours, 0);
                match rows.iter().find(|f| f[1] == ours[2] && f[2] == ours[1]) {
                    Some(theirs) => {
                        found.local += 1;
                        found.bytes += queue(theirs, 1);
                    }
                    None => found.remote += 1,
                }
            }
        }
        read_any.then_some(found)
    }
    #[cfg(not(target_os = "linux"))]
    None
}

impl Outlet for ZenohOutlet {
    fn publish(&mut self, topic: usize, _stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        let Some(seq) = self.sequence.get_mut(topic) else {
            return Err(std::io::Error::other(format!("no topic {topic}")));
        };
        *seq += 1;
        self.given[topic] += 1;
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
        let mut attachment = [0u8; 33];
        attachment[..8].copy_from_slice(&seq.to_le_bytes());
        attachment[8..16].copy_from_slice(&now.to_le_bytes());
        attachment[16] = 16;
        attachment[17..].copy_from_slice(&self.gids[topic]);
        let mut payload = self.pool.try_recv().unwrap_or_default();
        payload.clear();
        payload.extend_from_slice(cdr);
        let m = Outgoing {
            topic,
            attachment,
            payload,
        };
        if topic == self.events_topic {
            if let Some(events) = &self.events {
                // A send fails only when the thread is gone: counted as undelivered.
                let _ = events.send(m);
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names_and_endpoints() {
        assert_eq!(
            dds_type("sensor_msgs/msg/Image"),
            "sensor_msgs::msg::dds_::Image_"
        );
        assert_eq!(mangle("/skin/events"), "%skin%events");
        assert!(check_endpoint("tcp/127.0.0.1:7447").is_ok());
        assert!(check_endpoint("tcp/[::1]:7447").is_ok());
        let zenoh_said = "Can not create a new TCP listener bound to tcp/127.0.0.1:7448: [127.0.0.1:7448: Address already in use (os error 98) at /root/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/zenoh-link-commons-1.10.2/src/tcp.rs:61.] at /root/.cargo/registry/src/x/zenoh-1.10.2/src/net/runtime/orchestrator.rs:412.";
        assert_eq!(
            without_source(zenoh_said),
            "Can not create a new TCP listener bound to tcp/127.0.0.1:7448: [127.0.0.1:7448: Address already in use (os error 98)"
        );
        assert_eq!(without_source("look at this"), "look at this");
        let twice = vec!["tcp/127.0.0.1:7448".to_owned(); 2];
        assert!(check_endpoints(&[], &twice).is_err());
        assert!(check_endpoints(&twice[..1], &twice[..1]).is_err());
        assert!(check_endpoints(&twice[..1], &[]).is_ok());
        for bad in [
            "127.0.0.1:7447",
            "udp/1.2.3.4:7447",
            "tcp/host",
            "tcp/:7447",
            "tcp/h:99999",
        ] {
            assert!(check_endpoint(bad).is_err(), "{bad}");
        }
    }
}

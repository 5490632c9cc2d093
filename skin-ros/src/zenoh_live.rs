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
//! The frame path never waits for the network: [`Outlet::publish`] copies the message into a
//! buffer taken from a pool and queues it for a thread that owns the session. When more than
//! [`ZenohOptions::queue`] messages wait (a slow link, a slow subscriber), further messages are
//! dropped and counted ([`ZenohStats`]); events (`/skin/events`) are never dropped. Dropped
//! messages leave gaps in the sequence numbers a subscriber sees.

use crate::RosError;
use crate::bridge::Outlet;
use crate::interfaces::Interfaces;
use crate::topics::{QOS_DEPTH, Topics};
use sha2::{Digest, Sha256};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};
use zenoh::Wait;
use zenoh::qos::CongestionControl;

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
    /// Messages (other than events) that may wait for the network before new ones are dropped.
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

/// Counts of a live outlet.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ZenohStats {
    /// Messages handed to Zenoh.
    pub published: u64,
    /// Messages dropped because the queue was full.
    pub dropped: u64,
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

/// The rmw_zenoh QoS string of the offered QoS: reliable, volatile, keep last 10, default
/// deadline, lifespan and liveliness.
fn qos_string() -> String {
    format!("1:2:1,{QOS_DEPTH}:,:,:,,")
}

/// A message on its way to the publishing thread.
struct Outgoing {
    topic: usize,
    attachment: [u8; 33],
    payload: Vec<u8>,
    counted: bool,
}

/// The live outlet (see the [module](self)).
pub struct ZenohOutlet {
    send: Option<Sender<Outgoing>>,
    pool: Receiver<Vec<u8>>,
    thread: Option<std::thread::JoinHandle<()>>,
    session: zenoh::Session,
    publishers: Arc<Vec<zenoh::pubsub::Publisher<'static>>>,
    waiting: Arc<AtomicUsize>,
    published: Arc<AtomicU64>,
    dropped: u64,
    sequence: Vec<i64>,
    gids: Vec<[u8; 16]>,
    events: usize,
    queue: usize,
    keys: Vec<String>,
    tokens: Vec<String>,
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

fn zenoh_error(e: impl std::fmt::Display) -> RosError {
    RosError::Zenoh(e.to_string())
}

impl ZenohOutlet {
    /// Opens the session and declares the node, a publisher per topic and their tokens.
    pub fn open(topics: &Topics, options: &ZenohOptions) -> Result<ZenohOutlet, RosError> {
        for e in options.connect.iter().chain(&options.listen) {
            check_endpoint(e)?;
        }
        if options.connect.is_empty() && options.listen.is_empty() {
            return Err(RosError::Endpoint {
                endpoint: String::new(),
                why: "give an endpoint to connect to or to listen on".into(),
            });
        }
        if options.domain > 232 {
            return Err(RosError::Endpoint {
                endpoint: String::new(),
                why: format!("ROS domain {} is past 232", options.domain),
            });
        }
        // A listener that cannot be had (an address not of this machine, a port in use) is
        // said plainly here; Zenoh's own error names its source files.
        for e in &options.listen {
            let address = e.strip_prefix("tcp/").unwrap_or(e);
            if let Err(err) = std::net::TcpListener::bind(address) {
                return Err(RosError::Endpoint {
                    endpoint: e.clone(),
                    why: format!("cannot listen there: {err}"),
                });
            }
        }
        let interfaces = Interfaces::skin()?;
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
        ] {
            config.insert_json5(key, &value).map_err(zenoh_error)?;
        }
        let session = zenoh::open(config).wait().map_err(zenoh_error)?;
        let zid = session.zid().to_string();
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
                qos_string()
            ));
            let digest = Sha256::digest(format!("{zid}/{id}").as_bytes());
            let mut gid = [0u8; 16];
            gid.copy_from_slice(&digest[..16]);
            gids.push(gid);
        }
        let mut publishers = Vec::new();
        for key in &keys {
            publishers.push(
                session
                    .declare_publisher(key.clone())
                    .congestion_control(CongestionControl::Block)
                    .wait()
                    .map_err(zenoh_error)?,
            );
        }
        let mut liveliness = Vec::new();
        for t in &tokens {
            liveliness.push(
                session
                    .liveliness()
                    .declare_token(t.clone())
                    .wait()
                    .map_err(zenoh_error)?,
            );
        }
        let publishers = Arc::new(publishers);
        let shared = publishers.clone();
        let (send, take) = mpsc::channel::<Outgoing>();
        let (give_back, pool) = mpsc::channel::<Vec<u8>>();
        let waiting = Arc::new(AtomicUsize::new(0));
        let published = Arc::new(AtomicU64::new(0));
        let (w, p) = (waiting.clone(), published.clone());
        let thread = std::thread::Builder::new()
            .name("skin-zenoh".into())
            .spawn(move || {
                for m in take {
                    if let Some(publisher) = shared.get(m.topic) {
                        // Blocking here holds only this thread; the frame path drops instead.
                        let sent = publisher
                            .put(m.payload.as_slice())
                            .attachment(m.attachment.as_slice())
                            .wait();
                        if sent.is_ok() {
                            p.fetch_add(1, Ordering::Relaxed);
                        }
                    }
                    if m.counted {
                        w.fetch_sub(1, Ordering::Relaxed);
                    }
                    let _ = give_back.send(m.payload);
                }
            })
            .map_err(|e| RosError::Zenoh(format!("cannot start the publishing thread: {e}")))?;
        Ok(ZenohOutlet {
            send: Some(send),
            pool,
            thread: Some(thread),
            session,
            publishers,
            waiting,
            published,
            dropped: 0,
            sequence: vec![0; keys.len()],
            gids,
            events: topics.events,
            queue: options.queue.max(1),
            keys,
            tokens,
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
        let info = self.session.info();
        info.peers_zid().wait().count() + info.routers_zid().wait().count()
    }

    /// Waits up to `timeout` for a peer or router to connect; true if one did.
    pub fn wait_for_peer(&self, timeout: Duration) -> bool {
        let start = Instant::now();
        loop {
            if self.peers() > 0 {
                return true;
            }
            if start.elapsed() >= timeout {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Waits up to `timeout` until a subscriber somewhere matches the events topic (a ROS node
    /// subscribed to it, a recorder of everything); true if one does. Zenoh sends a sample only
    /// to the subscribers it knows of: a run that starts publishing the moment it connects
    /// would lose its first messages to a subscriber still being announced.
    pub fn wait_for_subscribers(&self, timeout: Duration) -> bool {
        let start = Instant::now();
        loop {
            let matching = self
                .publishers
                .get(self.events)
                .and_then(|p| p.matching_status().wait().ok())
                .is_some_and(|m| m.matching());
            if matching {
                return true;
            }
            if start.elapsed() >= timeout {
                return false;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Messages published and dropped so far.
    pub fn stats(&self) -> ZenohStats {
        ZenohStats {
            published: self.published.load(Ordering::Relaxed),
            dropped: self.dropped,
        }
    }

    /// Sends what is queued (waiting at most `timeout`), withdraws the publishers and tokens,
    /// and closes the session.
    pub fn close(mut self, timeout: Duration) -> ZenohStats {
        self.send = None;
        let start = Instant::now();
        if let Some(t) = self.thread.take() {
            while !t.is_finished() && start.elapsed() < timeout {
                std::thread::sleep(Duration::from_millis(5));
            }
            if t.is_finished() {
                let _ = t.join();
            }
        }
        let stats = self.stats();
        if let Some(publishers) = Arc::into_inner(std::mem::take(&mut self.publishers)) {
            for publisher in publishers {
                let _ = publisher.undeclare().wait();
            }
        }
        for token in std::mem::take(&mut self._liveliness) {
            let _ = token.undeclare().wait();
        }
        let _ = self.session.close().wait();
        stats
    }
}

impl Outlet for ZenohOutlet {
    fn publish(&mut self, topic: usize, _stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        let Some(send) = &self.send else {
            return Ok(());
        };
        let Some(seq) = self.sequence.get_mut(topic) else {
            return Err(std::io::Error::other(format!("no topic {topic}")));
        };
        *seq += 1;
        let counted = topic != self.events;
        if counted && self.waiting.load(Ordering::Relaxed) >= self.queue {
            self.dropped += 1;
            return Ok(());
        }
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
        if counted {
            self.waiting.fetch_add(1, Ordering::Relaxed);
        }
        if send
            .send(Outgoing {
                topic,
                attachment,
                payload,
                counted,
            })
            .is_err()
        {
            // The thread is gone (the session closed under it): count, do not stop the frames.
            self.dropped += 1;
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

//! The server: a listening socket, a thread that accepts, and a thread per connection. It serves
//! two things and nothing else: the page (`GET /`) and its stream (`GET /stream`, a WebSocket).
//! Any other path is 404, any other method 405; no file is ever read for a request, so there is
//! no path to traverse and no folder to list. The HTTP itself (reading a head, answering) is
//! [`http`](crate::http); a browser's stream, once let in, is [`browser`](crate::browser).
//!
//! Idle and slow clients cannot lock browsers out: accepting never waits on a connection, a
//! request head must arrive whole within [`HEAD_TIMEOUT`], and connections still waiting for
//! their head are given up first, their own address's oldest before anyone else's
//! ([`limits`](crate::limits)). An answer refusing a request (400, 408, 431, 503) is read to its
//! end by the client: the server stops writing, then reads what the client still sends for a
//! moment before closing, so the client is not cut off by a reset before it has read why.
//!
//! The accepting thread blocks in `accept`; the viewer, when dropped, wakes it with a
//! connection of its own and it ends.

use crate::browser::handshake_and_stream;
use crate::http::{Answer, HEAD_TIMEOUT, Head, key_ok, read_head, reason};
use crate::hub::Hub;
use crate::limits::{Admit, Limits, MAX_STREAMS, MAX_STREAMS_PER_ADDRESS, StreamRefused, client_of};
use http::{Method, StatusCode};
use std::collections::HashMap;
use std::net::{IpAddr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration;

/// The page, with its script and style inline.
const PAGE: &str = include_str!("page/index.html");

/// A browser that takes no bytes for this long is dropped (it skips frames until then).
const WRITE_TIMEOUT: Duration = Duration::from_secs(20);
/// After a failed `accept` (out of descriptors for a moment), the pause before the next.
const ACCEPT_PAUSE: Duration = Duration::from_millis(10);
/// How long the viewer, when dropped, tries to reach its own port to wake the accepting thread.
const WAKE_TIMEOUT: Duration = Duration::from_secs(1);

/// Why the viewer cannot serve.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    /// The address cannot be listened on.
    #[error("cannot serve the viewer on {addr}: {why}")]
    Bind {
        /// The address asked for.
        addr: SocketAddr,
        /// What the system said, in plain words.
        why: String,
    },
    /// A play speed out of [`SPEEDS`](crate::SPEEDS).
    #[error("a speed of {0} times real time: must be from 0.01 to 100")]
    Speed(f64),
    /// A replay's file cannot be read or is not one skin wrote.
    #[error("{path}: {why}")]
    Replay {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        why: String,
    },
}

fn bind_error(addr: SocketAddr, e: &std::io::Error) -> ViewError {
    let why = match e.kind() {
        std::io::ErrorKind::AddrInUse => format!(
            "port {} is in use (another viewer, or another program, serves there): choose another port, or 0 for any free one",
            addr.port()
        ),
        std::io::ErrorKind::AddrNotAvailable => format!("{} is not an address of this machine", addr.ip()),
        std::io::ErrorKind::PermissionDenied => {
            format!(
                "not allowed to listen on port {} (ports below 1024 need privileges)",
                addr.port()
            )
        }
        _ => e.to_string(),
    };
    ViewError::Bind { addr, why }
}

/// What the viewer has done so far.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ViewStats {
    /// Browsers connected now.
    pub browsers: usize,
    /// Frames sent, over all browsers.
    pub frames_sent: u64,
    /// Frames browsers were not sent because a newer one was ready by the time they could take
    /// one, over all browsers.
    pub frames_skipped: u64,
    /// Browsers dropped: sent something other than a replay's controls, took nothing for 20 s,
    /// answered no ping for 30 s, or lost their connection (a browser that closes its page is
    /// not counted).
    pub dropped: u64,
}

/// Serves the page; the hub is filled by a [`ViewSink`](crate::ViewSink) or a replay.
pub(crate) struct Server {
    pub hub: Arc<Hub>,
    pub addr: SocketAddr,
    acceptor: Option<JoinHandle<()>>,
}

impl Server {
    pub fn bind(addr: SocketAddr, hub: Arc<Hub>) -> Result<Server, ViewError> {
        let listener = TcpListener::bind(addr).map_err(|e| bind_error(addr, &e))?;
        let local = listener.local_addr().map_err(|e| bind_error(addr, &e))?;
        let h = hub.clone();
        let acceptor = std::thread::Builder::new()
            .name("skin-view accept".into())
            .spawn(move || accept(&listener, &h, local))
            .map_err(|e| bind_error(addr, &e))?;
        Ok(Server {
            hub,
            addr: local,
            acceptor: Some(acceptor),
        })
    }

    pub fn stats(&self) -> ViewStats {
        ViewStats {
            browsers: self.hub.clients.load(Ordering::Relaxed),
            frames_sent: self.hub.sent.load(Ordering::Relaxed),
            frames_skipped: self.hub.skipped.load(Ordering::Relaxed),
            dropped: self.hub.dropped.load(Ordering::Relaxed),
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.hub.closing.store(true, Ordering::SeqCst);
        self.hub.notify();
        if let Some(t) = self.acceptor.take() {
            // The accepting thread blocks in `accept`: a connection of our own wakes it, it sees
            // the viewer closing and ends, and the port is free once this returns. If the port
            // cannot be reached (no loopback route, a full backlog), the thread is left to end
            // at its next connection rather than holding the caller here.
            if wake(self.addr) {
                let _ = t.join();
            }
        }
    }
}

/// Connects to the viewer's own port (through loopback when it listens on every interface);
/// says whether a connection was made.
fn wake(addr: SocketAddr) -> bool {
    let port = addr.port();
    let targets: Vec<SocketAddr> = match addr.ip() {
        IpAddr::V4(ip) if ip.is_unspecified() => vec![(std::net::Ipv4Addr::LOCALHOST, port).into()],
        // `::` takes IPv4 too on most systems: the IPv4 loopback if the IPv6 one is missing.
        IpAddr::V6(ip) if ip.is_unspecified() => vec![
            (std::net::Ipv6Addr::LOCALHOST, port).into(),
            (std::net::Ipv4Addr::LOCALHOST, port).into(),
        ],
        _ => vec![addr],
    };
    targets
        .iter()
        .any(|a| TcpStream::connect_timeout(a, WAKE_TIMEOUT).is_ok())
}

/// The limits, and the sockets of the connections still waiting for their head (to close one
/// given up for a newer one).
#[derive(Default)]
struct Gate {
    limits: Limits,
    waiting: HashMap<u64, TcpStream>,
}

/// One connection as the limits know it.
#[derive(Clone, Copy)]
struct Conn {
    ticket: u64,
    client: IpAddr,
}

type SharedGate = Arc<Mutex<Gate>>;

fn lock(gate: &Mutex<Gate>) -> MutexGuard<'_, Gate> {
    gate.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// The accepting thread: blocks until a connection comes, and ends at the first one that
/// comes once the viewer is closing (the viewer's own, made to wake it).
fn accept(listener: &TcpListener, hub: &Arc<Hub>, local: SocketAddr) {
    let gate = SharedGate::default();
    loop {
        let accepted = listener.accept();
        if hub.closing.load(Ordering::SeqCst) {
            return;
        }
        match accepted {
            Ok((stream, peer)) => admit(stream, peer, hub, &gate, local),
            // A connection reset before it was accepted, or out of descriptors for a moment: a
            // pause, so that a lasting error does not spin.
            Err(_) => std::thread::sleep(ACCEPT_PAUSE),
        }
    }
}

/// Gives a connection just accepted its thread, closing the waiting connection it replaces;
/// never blocks (the accept loop goes on at once).
fn admit(stream: TcpStream, peer: SocketAddr, hub: &Arc<Hub>, gate: &SharedGate, local: SocketAddr) {
    let client = client_of(peer.ip());
    let mut g = lock(gate);
    let ticket = match g.limits.accept(client) {
        Admit::Wait { ticket, evict } => {
            if let Some(old) = evict.and_then(|t| g.waiting.remove(&t)) {
                // Its thread's read ends at once; it answers nothing.
                let _ = old.shutdown(Shutdown::Both);
            }
            ticket
        }
        Admit::Full => {
            drop(g);
            // Every connection is being answered or streaming: the one answer that cannot
            // block this thread (a fresh socket's buffer takes it).
            let _ = stream.set_nonblocking(true);
            let _ = Answer::text(StatusCode::SERVICE_UNAVAILABLE, b"too many connections\n").send(&stream);
            let _ = stream.shutdown(Shutdown::Write);
            return;
        }
    };
    if let Ok(clone) = stream.try_clone() {
        g.waiting.insert(ticket, clone);
    }
    drop(g);
    let conn = Conn { ticket, client };
    let (hub, gate2) = (hub.clone(), gate.clone());
    let spawned = std::thread::Builder::new()
        .name("skin-view browser".into())
        .spawn(move || {
            serve(stream, conn, &hub, &gate2, local);
            let mut g = lock(&gate2);
            g.limits.closed(ticket);
            g.waiting.remove(&ticket);
        });
    if spawned.is_err() {
        let mut g = lock(gate);
        g.limits.closed(ticket);
        g.waiting.remove(&ticket);
    }
}

/// The page's own policy: its inline script (by its SHA-256, so no other script runs, injected
/// or not) and style, its stream, images it makes itself; nothing fetched from anywhere else,
/// and no framing by another site.
static CSP: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    use sha2::Digest as _;
    let script = PAGE
        .split_once("<script>")
        .and_then(|(_, rest)| rest.split_once("</script>"))
        .map_or("", |(script, _)| script);
    let hash = data_encoding::BASE64.encode(&sha2::Sha256::digest(script.as_bytes()));
    format!(
        "default-src 'none'; script-src 'sha256-{hash}'; style-src 'unsafe-inline'; connect-src 'self'; img-src data: blob:; frame-ancestors 'none'"
    )
});

/// The host part of a `Host` value or of an `Origin`'s authority (port dropped, brackets kept
/// off an IPv6 address).
fn host_of(value: &str) -> &str {
    let v = authority_of(value);
    if let Some(rest) = v.strip_prefix('[') {
        return rest.split(']').next().unwrap_or(rest);
    }
    v.rsplit_once(':').map_or(v, |(h, _)| h)
}

/// `host:port` of an `Origin` (`http://host:port`) or a `Host` value as it is.
fn authority_of(value: &str) -> &str {
    let v = value.trim();
    let v = v.split_once("://").map_or(v, |(_, rest)| rest);
    v.split('/').next().unwrap_or(v)
}

/// This machine's name (Linux), which a browser on the network may use to reach the viewer;
/// read once.
fn machine_name() -> Option<&'static str> {
    static NAME: std::sync::LazyLock<Option<String>> = std::sync::LazyLock::new(|| {
        std::fs::read_to_string("/proc/sys/kernel/hostname")
            .ok()
            .map(|n| n.trim().to_ascii_lowercase())
            .filter(|n| !n.is_empty())
    });
    NAME.as_deref()
}

/// Whether a request may be served. The `Host` must name this machine by an address, as
/// `localhost` or by its own name (on loopback: `localhost` or a loopback address), so a web page
/// elsewhere cannot reach the viewer through a name it controls (DNS rebinding); a WebSocket's
/// `Origin`, when the browser sends one, must be the page's own host and port.
fn allowed(head: &Head, local: SocketAddr) -> bool {
    let Some(host_value) = head.host.as_deref() else {
        return false;
    };
    let host = host_of(host_value).to_ascii_lowercase();
    let ip = host.parse::<IpAddr>().ok();
    let named = if local.ip().is_loopback() {
        host == "localhost" || ip.is_some_and(|ip| ip.is_loopback())
    } else {
        host == "localhost"
            || ip.is_some()
            || machine_name().is_some_and(|n| n == host || format!("{n}.local") == host)
    };
    named
        && head
            .origin
            .as_deref()
            .is_none_or(|o| authority_of(o).eq_ignore_ascii_case(authority_of(host_value)))
}

/// One connection: its head read (within [`HEAD_TIMEOUT`]), then the page, the stream, or a
/// refusal.
fn serve(mut stream: TcpStream, conn: Conn, hub: &Arc<Hub>, gate: &SharedGate, local: SocketAddr) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(HEAD_TIMEOUT));
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let read = read_head(&mut stream);
    {
        let mut g = lock(gate);
        g.waiting.remove(&conn.ticket);
        if !g.limits.head_arrived(conn.ticket) {
            // Given up for a newer connection: closed already, nothing to answer.
            return;
        }
    }
    let (head, rest) = match read {
        Ok(h) => h,
        // Too slow: answered, and closed without waiting for more of it.
        Err(StatusCode::REQUEST_TIMEOUT) => {
            let _ = Answer::text(StatusCode::REQUEST_TIMEOUT, b"the request took too long\n").send(&stream);
            return;
        }
        Err(status) => return Answer::text(status, reason(status).as_bytes()).refuse(stream),
    };
    if head.method != Method::GET && head.method != Method::HEAD {
        return Answer::text(StatusCode::METHOD_NOT_ALLOWED, b"only GET\n")
            .with(&[("Allow", "GET, HEAD")])
            .refuse(stream);
    }
    if !allowed(&head, local) {
        return Answer::text(StatusCode::FORBIDDEN, b"forbidden host or origin\n").refuse(stream);
    }
    match head.path.as_str() {
        "/" | "/index.html" => {
            let body = if head.method == Method::HEAD {
                &b""[..]
            } else {
                PAGE.as_bytes()
            };
            let page = Answer {
                status: StatusCode::OK,
                kind: "text/html; charset=utf-8",
                body,
                length: PAGE.len(),
                extra: &[("Content-Security-Policy", CSP.as_str())],
            };
            let _ = page.send(&stream);
        }
        "/stream" => open_stream(stream, &head, rest, conn, hub, gate),
        _ => Answer::text(StatusCode::NOT_FOUND, b"not found\n").refuse(stream),
    }
}

/// `GET /stream`: the WebSocket handshake, then the stream, within the limits on streams.
fn open_stream(stream: TcpStream, head: &Head, rest: Vec<u8>, conn: Conn, hub: &Arc<Hub>, gate: &SharedGate) {
    let Some(key) = head
        .key
        .as_deref()
        .filter(|_| head.upgrade && head.version_13 && head.method == Method::GET)
    else {
        return Answer::text(StatusCode::UPGRADE_REQUIRED, b"a WebSocket stream\n")
            .with(&[("Upgrade", "websocket")])
            .refuse(stream);
    };
    if !key_ok(key) {
        let why = b"Sec-WebSocket-Key must be 16 bytes in base64\n";
        return Answer::text(StatusCode::BAD_REQUEST, why).refuse(stream);
    }
    if let Err(why) = lock(gate).limits.open_stream(conn.client) {
        let body = match why {
            StreamRefused::Full => format!("too many browsers watching ({MAX_STREAMS})\n"),
            StreamRefused::FromThisAddress => {
                format!("too many browsers watching from this address ({MAX_STREAMS_PER_ADDRESS})\n")
            }
        };
        return Answer::text(StatusCode::SERVICE_UNAVAILABLE, body.as_bytes()).refuse(stream);
    }
    handshake_and_stream(stream, key, rest, hub);
    lock(gate).limits.stream_closed(conn.client);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_matches_only_event_kinds_the_session_names() {
        // Every `kind === "…"` / `event === "…"` the page's script compares with.
        let mut seen = 0;
        for key in ["kind === \"", "event === \""] {
            for (at, _) in PAGE.match_indices(key) {
                let rest = &PAGE[at + key.len()..];
                let kind = &rest[..rest.find('"').unwrap_or(0)];
                assert!(
                    skin_runtime::session::Event::KINDS.contains(&kind),
                    "the page compares with {kind:?}, which is no event kind"
                );
                seen += 1;
            }
        }
        assert!(seen >= 6, "the page's comparisons were not found ({seen})");
    }

    #[test]
    fn hosts_are_read_from_host_and_origin_values() {
        assert_eq!(host_of("localhost:8080"), "localhost");
        assert_eq!(host_of("http://127.0.0.1:8080"), "127.0.0.1");
        assert_eq!(host_of("[::1]:80"), "::1");
        assert_eq!(host_of("http://[::1]:80/x"), "::1");
        assert_eq!(host_of("evil.example"), "evil.example");
    }
}

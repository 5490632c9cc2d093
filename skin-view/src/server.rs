//! The server: a listening socket, a thread that accepts, and a thread per connection. It serves
//! two things and nothing else: the page (`GET /`) and its stream (`GET /stream`, a WebSocket).
//! Any other path is 404, any other method 405; no file is ever read for a request, so there is
//! no path to traverse and no folder to list.
//!
//! A browser's thread waits on the [hub](crate::hub) for something new, sends it, and checks
//! whether the browser said something (only a replay listens: pause, play, seek, speed). A
//! control with a value out of range is refused with a message and the stream goes on; a
//! browser that sends anything else, or more than 4 KiB at once, is dropped; the others go on.
//!
//! Idle and slow clients cannot lock browsers out: accepting never waits on a connection, a
//! request head must arrive whole within [`HEAD_TIMEOUT`], and connections still waiting for
//! their head are given up first, their own address's oldest before anyone else's
//! ([`limits`](crate::limits)). An answer refusing a request (400, 408, 431, 503) is read to its
//! end by the client: the server stops writing, then reads what the client still sends for a
//! moment before closing, so the client is not cut off by a reset before it has read why.

use crate::hub::{Control, Hub, SPEEDS};
use crate::limits::{Admit, Limits, MAX_STREAMS, MAX_STREAMS_PER_ADDRESS, StreamRefused, client_of};
use crate::wire::SKIPPED_AT;
use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{IpAddr, Shutdown, SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// The page, with its script and style inline.
const PAGE: &str = include_str!("page/index.html");

/// How often a browser is pinged; one that has answered nothing for [`SILENT_LIMIT`] is dropped
/// (a browser reads its stream and answers pings by itself; a client that stopped reading does
/// not, and gives its place back).
const PING_EVERY: Duration = Duration::from_secs(5);
/// See [`PING_EVERY`].
const SILENT_LIMIT: Duration = Duration::from_secs(30);
/// The longest request head read.
const MAX_HEAD: usize = 8 * 1024;
/// The longest message a browser may send.
const MAX_MESSAGE: usize = 4 * 1024;
/// How long a whole request head may take to arrive from the moment its connection is accepted
/// (a browser sends it at once; an idle socket is closed then, if not pushed out before).
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(2);
/// After a refusal, how long and how much of what the client still sends is read (and thrown
/// away) before closing, so that it gets the answer instead of a reset.
const LINGER: Duration = Duration::from_secs(1);
/// See [`LINGER`].
const LINGER_BYTES: usize = 1024 * 1024;
/// A browser that takes no bytes for this long is dropped (it skips frames until then).
const WRITE_TIMEOUT: Duration = Duration::from_secs(20);
/// How often a browser's thread looks for what the browser sent, when nothing new is to be sent.
const POLL: Duration = Duration::from_millis(50);

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
        // Polled, so that dropping the viewer ends the thread without a connection to wake it.
        listener.set_nonblocking(true).map_err(|e| bind_error(addr, &e))?;
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
        self.hub.closing.store(true, Ordering::Relaxed);
        self.hub.notify();
        if let Some(t) = self.acceptor.take() {
            let _ = t.join();
        }
    }
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

fn accept(listener: &TcpListener, hub: &Arc<Hub>, local: SocketAddr) {
    let gate = SharedGate::default();
    while !hub.closing.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, peer)) => admit(stream, peer, hub, &gate, local),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(10))
            }
            // A connection reset before it was accepted, or out of descriptors for a moment.
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
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
            let _ = respond(&stream, 503, "text/plain", b"too many connections\n", &[]);
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

/// A request head as far as the server cares.
struct Head {
    method: String,
    path: String,
    host: Option<String>,
    origin: Option<String>,
    upgrade: bool,
    key: Option<String>,
    version_13: bool,
}

/// Reads a request head (at most [`MAX_HEAD`] bytes); what came after it (a browser sends
/// nothing before the handshake's answer, but a client may) is returned too.
fn read_head(stream: &mut TcpStream) -> Result<(Head, Vec<u8>), u16> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    // The whole head within HEAD_TIMEOUT, not each read: a byte every few seconds does not
    // hold a connection.
    let deadline = std::time::Instant::now() + HEAD_TIMEOUT;
    loop {
        let left = deadline
            .checked_duration_since(std::time::Instant::now())
            .filter(|d| !d.is_zero())
            .ok_or(408u16)?;
        stream.set_read_timeout(Some(left)).map_err(|_| 408u16)?;
        let n = stream.read(&mut chunk).map_err(|_| 408u16)?;
        if n == 0 {
            return Err(400);
        }
        buf.extend_from_slice(&chunk[..n]);
        let mut headers = [httparse::EMPTY_HEADER; 32];
        let mut req = httparse::Request::new(&mut headers);
        match req.parse(&buf) {
            Ok(httparse::Status::Complete(len)) => {
                let header = |name: &str| {
                    req.headers
                        .iter()
                        .find(|h| h.name.eq_ignore_ascii_case(name))
                        .and_then(|h| std::str::from_utf8(h.value).ok())
                        .map(str::to_owned)
                };
                let has = |name: &str, token: &str| {
                    header(name).is_some_and(|v| v.split(',').any(|t| t.trim().eq_ignore_ascii_case(token)))
                };
                let head = Head {
                    method: req.method.unwrap_or("").to_owned(),
                    path: req.path.unwrap_or("").to_owned(),
                    host: header("host"),
                    origin: header("origin"),
                    upgrade: has("upgrade", "websocket") && has("connection", "upgrade"),
                    key: header("sec-websocket-key"),
                    version_13: header("sec-websocket-version").is_some_and(|v| v.trim() == "13"),
                };
                return Ok((head, buf[len..].to_vec()));
            }
            Ok(httparse::Status::Partial) if buf.len() < MAX_HEAD => {}
            Ok(httparse::Status::Partial) => return Err(431),
            Err(httparse::Error::TooManyHeaders) => return Err(431),
            Err(_) => return Err(400),
        }
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        403 => "Forbidden",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        426 => "Upgrade Required",
        431 => "Request Header Fields Too Large",
        503 => "Service Unavailable",
        _ => "Error",
    }
}

fn respond(
    stream: &TcpStream,
    status: u16,
    kind: &str,
    body: &[u8],
    extra: &[(&str, &str)],
) -> std::io::Result<()> {
    respond_head(stream, status, kind, body, body.len(), extra)
}

/// Answers with `body` after a head that says `length` (a HEAD request's answer says the
/// page's length and sends no body).
fn respond_head(
    mut stream: &TcpStream,
    status: u16,
    kind: &str,
    body: &[u8],
    length: usize,
    extra: &[(&str, &str)],
) -> std::io::Result<()> {
    let mut head = format!(
        "HTTP/1.1 {status} {}\r\nContent-Type: {kind}\r\nContent-Length: {length}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n",
        reason(status),
    );
    for (k, v) in extra {
        head.push_str(&format!("{k}: {v}\r\n"));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes())?;
    stream.write_all(body)?;
    stream.flush()
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

/// Answers a refusal, then reads what the client still sends (at most [`LINGER_BYTES`], for at
/// most [`LINGER`]) before closing: closing with unread bytes would reset the connection, and
/// the client could lose the answer before reading it.
fn refuse_request(mut stream: TcpStream, status: u16, body: &[u8], extra: &[(&str, &str)]) {
    let _ = respond(&stream, status, "text/plain", body, extra);
    linger(&mut stream);
}

/// Stops writing, then reads what the client still sends (at most [`LINGER_BYTES`], for at
/// most [`LINGER`]): what was written reaches it before the connection closes.
fn linger(stream: &mut TcpStream) {
    let _ = stream.shutdown(Shutdown::Write);
    let deadline = Instant::now() + LINGER;
    let mut sink = [0u8; 4096];
    let mut read = 0usize;
    while read < LINGER_BYTES {
        let Some(left) = deadline
            .checked_duration_since(Instant::now())
            .filter(|d| !d.is_zero())
        else {
            break;
        };
        if stream.set_read_timeout(Some(left)).is_err() {
            break;
        }
        match stream.read(&mut sink) {
            Ok(0) | Err(_) => break,
            Ok(n) => read += n,
        }
    }
}

/// Why a WebSocket key is refused: it must be 16 bytes in base64 (RFC 6455, 4.1 and 4.2.1).
fn key_ok(key: &str) -> bool {
    data_encoding::BASE64
        .decode(key.trim().as_bytes())
        .is_ok_and(|k| k.len() == 16)
}

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
        Err(408) => {
            let _ = respond(&stream, 408, "text/plain", b"the request took too long\n", &[]);
            return;
        }
        Err(status) => return refuse_request(stream, status, reason(status).as_bytes(), &[]),
    };
    let path = head.path.split(['?', '#']).next().unwrap_or("");
    if head.method != "GET" && head.method != "HEAD" {
        return refuse_request(stream, 405, b"only GET\n", &[("Allow", "GET, HEAD")]);
    }
    if !allowed(&head, local) {
        return refuse_request(stream, 403, b"forbidden host or origin\n", &[]);
    }
    match path {
        "/" | "/index.html" => {
            let body = if head.method == "HEAD" {
                &b""[..]
            } else {
                PAGE.as_bytes()
            };
            let _ = respond_head(
                &stream,
                200,
                "text/html; charset=utf-8",
                body,
                PAGE.len(),
                &[("Content-Security-Policy", CSP.as_str())],
            );
        }
        "/stream" => open_stream(stream, &head, rest, conn, hub, gate),
        _ => refuse_request(stream, 404, b"not found\n", &[]),
    }
}

/// `GET /stream`: the WebSocket handshake, then the stream, within the limits on streams.
fn open_stream(stream: TcpStream, head: &Head, rest: Vec<u8>, conn: Conn, hub: &Arc<Hub>, gate: &SharedGate) {
    let Some(key) = head
        .key
        .as_deref()
        .filter(|_| head.upgrade && head.version_13 && head.method == "GET")
    else {
        return refuse_request(stream, 426, b"a WebSocket stream\n", &[("Upgrade", "websocket")]);
    };
    if !key_ok(key) {
        return refuse_request(
            stream,
            400,
            b"Sec-WebSocket-Key must be 16 bytes in base64\n",
            &[],
        );
    }
    if let Err(why) = lock(gate).limits.open_stream(conn.client) {
        let body = match why {
            StreamRefused::Full => format!("too many browsers watching ({MAX_STREAMS})\n"),
            StreamRefused::FromThisAddress => {
                format!("too many browsers watching from this address ({MAX_STREAMS_PER_ADDRESS})\n")
            }
        };
        return refuse_request(stream, 503, body.as_bytes(), &[]);
    }
    handshake_and_stream(stream, key, rest, hub);
    lock(gate).limits.stream_closed(conn.client);
}

fn handshake_and_stream(mut stream: TcpStream, key: &str, rest: Vec<u8>, hub: &Arc<Hub>) {
    let accept = tungstenite::handshake::derive_accept_key(key.trim().as_bytes());
    let answer = format!(
        "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n\r\n"
    );
    if stream.write_all(answer.as_bytes()).is_err() {
        return;
    }
    let config = WebSocketConfig::default()
        .max_message_size(Some(MAX_MESSAGE))
        .max_frame_size(Some(MAX_MESSAGE));
    let ws = WebSocket::from_partially_read(stream, rest, Role::Server, Some(config));
    hub.clients.fetch_add(1, Ordering::Relaxed);
    let ended = stream_to(ws, hub);
    hub.clients.fetch_sub(1, Ordering::Relaxed);
    if ended == Ended::Dropped {
        hub.dropped.fetch_add(1, Ordering::Relaxed);
    }
}

#[derive(Debug, PartialEq, Eq)]
enum Ended {
    /// The browser closed, or the viewer did.
    Closed,
    /// The browser was dropped (garbage, too slow, broken connection).
    Dropped,
}

/// What one browser has been sent.
struct Seen {
    epoch: Option<u64>,
    status: u64,
    frame: u64,
    images: Vec<u64>,
    next_event: u64,
    skipped: u32,
}

/// Copies of what is new for one browser, taken under the lock and sent after it.
#[derive(Default)]
struct Outbox {
    scene: Option<Arc<str>>,
    status: Option<Arc<str>>,
    events: Vec<Arc<str>>,
    lost_events: u64,
    images: Vec<Arc<Vec<u8>>>,
    /// The frame, and the skipped count to stamp on this browser's copy of it.
    frame: Option<(Arc<Vec<u8>>, u32)>,
}

fn stream_to(mut ws: WebSocket<TcpStream>, hub: &Arc<Hub>) -> Ended {
    let _ = ws.get_mut().set_read_timeout(Some(Duration::from_millis(1)));
    // This browser's number: a replay's state names the browser whose control changed it.
    let me = hub.next_browser.fetch_add(1, Ordering::Relaxed) + 1;
    let mut told = false;
    let mut seen = Seen {
        epoch: None,
        status: 0,
        frame: 0,
        images: Vec::new(),
        next_event: 1,
        skipped: 0,
    };
    let (mut pinged, mut heard) = (Instant::now(), Instant::now());
    loop {
        if hub.closing.load(Ordering::Relaxed) {
            let _ = ws.close(None);
            let _ = ws.flush();
            return Ended::Closed;
        }
        let out = collect(hub, &mut seen);
        if let Err(ended) = send(&mut ws, hub, out) {
            return ended;
        }
        if !told {
            // After the scene, which always comes first.
            told = true;
            if ws
                .send(Message::Text(format!("{{\"you\":{me}}}").into()))
                .is_err()
            {
                return Ended::Dropped;
            }
        }
        match listen(&mut ws, hub, me) {
            Ok(true) => heard = Instant::now(),
            Ok(false) => {}
            Err(ended) => return ended,
        }
        if heard.elapsed() > SILENT_LIMIT {
            return Ended::Dropped;
        }
        if pinged.elapsed() > PING_EVERY {
            pinged = Instant::now();
            if ws.send(Message::Ping(Vec::new().into())).is_err() {
                return Ended::Dropped;
            }
        }
    }
}

/// Waits (at most [`POLL`]) for something new and copies it out.
fn collect(hub: &Hub, seen: &mut Seen) -> Outbox {
    let mut s = hub.lock();
    let fresh = |s: &crate::hub::Shared, seen: &Seen| {
        seen.epoch != Some(s.epoch)
            || s.status.0 != seen.status
            || s.frame.seq != seen.frame
            || s.next_event != seen.next_event
            || s.images.iter().zip(&seen.images).any(|(i, &k)| i.seq != k)
    };
    if !fresh(&s, seen) {
        s = hub.wait(s, POLL);
    }
    let mut out = Outbox::default();
    if seen.epoch != Some(s.epoch) {
        seen.epoch = Some(s.epoch);
        seen.images = vec![0; s.images.len()];
        out.scene = Some(s.scene.clone());
    }
    if s.status.0 != seen.status {
        seen.status = s.status.0;
        out.status = Some(s.status.1.clone());
    }
    if s.next_event != seen.next_event {
        let first = s.events.front().map_or(s.next_event, |e| e.0);
        out.lost_events = first.saturating_sub(seen.next_event);
        out.events = s
            .events
            .iter()
            .filter(|(n, _)| *n >= seen.next_event)
            .map(|(_, l)| l.clone())
            .collect();
        seen.next_event = s.next_event;
    }
    for (slot, k) in s.images.iter().zip(seen.images.iter_mut()) {
        if slot.seq != *k {
            *k = slot.seq;
            out.images.push(slot.bytes.clone());
        }
    }
    if s.frame.seq != seen.frame {
        if seen.frame != 0 {
            let behind = s.frame.seq.saturating_sub(seen.frame + 1);
            seen.skipped = seen
                .skipped
                .saturating_add(u32::try_from(behind).unwrap_or(u32::MAX));
            hub.skipped.fetch_add(behind, Ordering::Relaxed);
        }
        seen.frame = s.frame.seq;
        out.frame = Some((s.frame.bytes.clone(), seen.skipped));
    }
    out
}

fn send(ws: &mut WebSocket<TcpStream>, hub: &Hub, out: Outbox) -> Result<(), Ended> {
    let text = |t: String| Message::Text(t.into());
    let result = (|| {
        if let Some(scene) = out.scene {
            ws.write(text(format!("{{\"scene\":{scene}}}")))?;
        }
        if let Some(status) = out.status.filter(|s| !s.is_empty()) {
            ws.write(text(format!("{{\"status\":{status}}}")))?;
        }
        if out.lost_events > 0 {
            ws.write(text(format!("{{\"lost_events\":{}}}", out.lost_events)))?;
        }
        for e in out.events {
            ws.write(text(format!("{{\"event\":{e}}}")))?;
        }
        for i in out.images {
            let bytes = i.as_slice().to_vec();
            // The shared buffer goes back before a write that may block.
            drop(i);
            ws.write(Message::Binary(bytes.into()))?;
        }
        let frame = out.frame.is_some();
        if let Some((f, skipped)) = out.frame {
            // This browser's copy, with its own skipped count; the shared buffer goes back
            // before a write that may block, for the session to write over.
            let mut bytes = f.as_slice().to_vec();
            drop(f);
            if let Some(at) = bytes.get_mut(SKIPPED_AT..SKIPPED_AT + 4) {
                at.copy_from_slice(&skipped.to_le_bytes());
            }
            ws.write(Message::Binary(bytes.into()))?;
        }
        ws.flush()?;
        if frame {
            hub.sent.fetch_add(1, Ordering::Relaxed);
        }
        Ok::<(), tungstenite::Error>(())
    })();
    result.map_err(|_| Ended::Dropped)
}

/// Messages read from a browser between two sends: one that keeps sending (pings, controls)
/// still gets its frames.
const READS_PER_TURN: usize = 16;

/// Reads what the browser sent, if anything: a replay's controls and pongs. A control whose
/// value is out of range is answered `{"refused": why}` and the stream goes on; anything else
/// drops the browser. Says whether the browser was heard from.
fn listen(ws: &mut WebSocket<TcpStream>, hub: &Hub, me: u64) -> Result<bool, Ended> {
    let mut heard = false;
    for _ in 0..READS_PER_TURN {
        match ws.read() {
            Ok(Message::Text(t)) if hub.controllable() => match control(t.as_str()) {
                Ok(c) => {
                    heard = true;
                    hub.send_control(c, me);
                }
                Err(Some(why)) => {
                    heard = true;
                    let answer = serde_json::json!({ "refused": why }).to_string();
                    ws.send(Message::Text(answer.into()))
                        .map_err(|_| Ended::Dropped)?;
                }
                Err(None) => return Err(refuse(ws, "not a request this viewer takes")),
            },
            Ok(Message::Text(_)) => return Err(refuse(ws, "not a request this viewer takes")),
            Ok(Message::Binary(_)) => return Err(refuse(ws, "binary messages are not taken")),
            Ok(Message::Close(_)) => {
                let _ = ws.flush();
                return Err(Ended::Closed);
            }
            Ok(_) => heard = true,
            Err(tungstenite::Error::Io(e))
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) =>
            {
                return Ok(heard);
            }
            Err(tungstenite::Error::ConnectionClosed) => return Err(Ended::Closed),
            Err(
                tungstenite::Error::Capacity(_)
                | tungstenite::Error::Protocol(_)
                | tungstenite::Error::Utf8(_),
            ) => {
                return Err(refuse(ws, "malformed or oversized message"));
            }
            Err(_) => return Err(Ended::Dropped),
        }
    }
    Ok(heard)
}

/// Closes a browser's stream with "policy violation" and the reason.
fn refuse(ws: &mut WebSocket<TcpStream>, why: &'static str) -> Ended {
    let _ = ws.close(Some(CloseFrame {
        code: CloseCode::Policy,
        reason: why.into(),
    }));
    let _ = ws.flush();
    // What it sent beyond what was read (an oversized message's rest) must not reset the
    // connection before it reads the close.
    linger(ws.get_mut());
    Ended::Dropped
}

/// A replay control: `{"cmd":"pause"}`, `{"cmd":"play"}`, `{"cmd":"seek","time":S}` (S from
/// 0 s; past the end shows the last frame), `{"cmd":"speed","value":X}` (X in [`SPEEDS`]).
/// `Err(Some(why))`: a control with a value missing or out of range, refused with `why`;
/// `Err(None)`: not a control at all.
fn control(text: &str) -> Result<Control, Option<String>> {
    let v: serde_json::Value = serde_json::from_str(text).map_err(|_| None)?;
    let cmd = v.get("cmd").and_then(serde_json::Value::as_str).ok_or(None)?;
    let number = |k: &str| {
        v.get(k)
            .and_then(serde_json::Value::as_f64)
            .filter(|x| x.is_finite())
    };
    let shown = |k: &str| v.get(k).map_or_else(|| "nothing".to_owned(), ToString::to_string);
    match cmd {
        "pause" => Ok(Control::Pause),
        "play" => Ok(Control::Play),
        "seek" => number("time")
            .filter(|t| *t >= 0.0)
            .map(Control::Seek)
            .ok_or_else(|| {
                Some(format!(
                    "seek: the time must be a number of seconds from 0 (got {})",
                    shown("time")
                ))
            }),
        "speed" => number("value")
            .filter(|x| SPEEDS.contains(x))
            .map(Control::Speed)
            .ok_or_else(|| {
                Some(format!(
                    "speed: must be from {} to {} times real time (got {})",
                    SPEEDS.start(),
                    SPEEDS.end(),
                    shown("value")
                ))
            }),
        _ => Err(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_are_read_and_anything_else_is_not() {
        assert_eq!(control(r#"{"cmd":"pause"}"#), Ok(Control::Pause));
        assert_eq!(control(r#"{"cmd":"seek","time":1.5}"#), Ok(Control::Seek(1.5)));
        assert_eq!(control(r#"{"cmd":"speed","value":2}"#), Ok(Control::Speed(2.0)));
        for bad in ["", "pause", r#"{"cmd":"rm -rf"}"#, r#"[1,2]"#, r#"{"seek":1}"#] {
            assert_eq!(control(bad), Err(None), "{bad}");
        }
        // A control with a bad value is refused with a reason naming it, not dropped.
        for (bad, names) in [
            (r#"{"cmd":"seek"}"#, "got nothing"),
            (r#"{"cmd":"seek","time":-1}"#, "got -1"),
            (r#"{"cmd":"seek","time":"5"}"#, r#"got "5""#),
            (r#"{"cmd":"speed","value":0}"#, "got 0"),
            (r#"{"cmd":"speed","value":1e9}"#, "got 1000000000"),
        ] {
            let got = control(bad);
            assert!(
                matches!(&got, Err(Some(why)) if why.contains(names)),
                "{bad}: {got:?}"
            );
        }
    }

    #[test]
    fn a_websocket_key_must_be_16_bytes_in_base64() {
        assert!(key_ok("dGhlIHNhbXBsZSBub25jZQ=="));
        assert!(key_ok(" dGhlIHNhbXBsZSBub25jZQ== "));
        for bad in [
            "",
            "not base64 at all!",
            "dGhlIHNhbXBsZQ==",
            "dGhlIHNhbXBsZSBub25jZSBsb25n",
        ] {
            assert!(!key_ok(bad), "{bad}");
        }
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

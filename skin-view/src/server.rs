//! The server: a listening socket, a thread that accepts, and a thread per connection. It serves
//! two things and nothing else: the page (`GET /`) and its stream (`GET /stream`, a WebSocket).
//! Any other path is 404, any other method 405; no file is ever read for a request, so there is
//! no path to traverse and no folder to list.
//!
//! A browser's thread waits on the [hub](crate::hub) for something new, sends it, and checks
//! whether the browser said something (only a replay listens: pause, play, seek, speed). A
//! browser that sends anything else, or more than 4 KiB at once, is dropped; the others go on.

use crate::hub::{Control, Hub};
use crate::wire::SKIPPED_AT;
use std::io::{Read, Write};
use std::net::{IpAddr, SocketAddr, TcpListener, TcpStream};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// The page, with its script and style inline.
const PAGE: &str = include_str!("page/index.html");

/// Connections served at once (browsers and page loads); more are answered 503.
pub const MAX_CONNECTIONS: usize = 64;
/// Streams (browsers) served at once, fewer than [`MAX_CONNECTIONS`]: the page itself can still
/// be loaded when every stream is taken, and says so.
pub const MAX_STREAMS: usize = 48;
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
/// How long a request head may take to arrive.
const HEAD_TIMEOUT: Duration = Duration::from_secs(5);
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

fn accept(listener: &TcpListener, hub: &Arc<Hub>, local: SocketAddr) {
    let connections = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    while !hub.closing.load(Ordering::Relaxed) {
        match listener.accept() {
            Ok((stream, _)) => {
                if connections.load(Ordering::Relaxed) >= MAX_CONNECTIONS {
                    let _ = stream.set_write_timeout(Some(HEAD_TIMEOUT));
                    let _ = respond(&stream, 503, "text/plain", b"too many connections\n", &[]);
                    continue;
                }
                connections.fetch_add(1, Ordering::Relaxed);
                let (hub, count) = (hub.clone(), connections.clone());
                let spawned = std::thread::Builder::new()
                    .name("skin-view browser".into())
                    .spawn(move || {
                        serve(stream, &hub, local);
                        count.fetch_sub(1, Ordering::Relaxed);
                    });
                if spawned.is_err() {
                    connections.fetch_sub(1, Ordering::Relaxed);
                }
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                std::thread::sleep(Duration::from_millis(10))
            }
            // A connection reset before it was accepted, or out of descriptors for a moment.
            Err(_) => std::thread::sleep(Duration::from_millis(10)),
        }
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

fn serve(mut stream: TcpStream, hub: &Arc<Hub>, local: SocketAddr) {
    let _ = stream.set_nonblocking(false);
    let _ = stream.set_read_timeout(Some(HEAD_TIMEOUT));
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let (head, rest) = match read_head(&mut stream) {
        Ok(h) => h,
        Err(status) => {
            let _ = respond(&stream, status, "text/plain", b"bad request\n", &[]);
            return;
        }
    };
    let path = head.path.split(['?', '#']).next().unwrap_or("");
    if head.method != "GET" && head.method != "HEAD" {
        let _ = respond(
            &stream,
            405,
            "text/plain",
            b"only GET\n",
            &[("Allow", "GET, HEAD")],
        );
        return;
    }
    if !allowed(&head, local) {
        let _ = respond(&stream, 403, "text/plain", b"forbidden host or origin\n", &[]);
        return;
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
        "/stream" => match (&head.key, head.upgrade && head.version_13 && head.method == "GET") {
            (Some(_), true) if hub.clients.load(Ordering::Relaxed) >= MAX_STREAMS => {
                let _ = respond(&stream, 503, "text/plain", b"too many browsers watching\n", &[]);
            }
            (Some(key), true) => {
                let accept = tungstenite::handshake::derive_accept_key(key.trim().as_bytes());
                let answer = format!(
                    "HTTP/1.1 101 Switching Protocols\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n\r\n"
                );
                if stream.write_all(answer.as_bytes()).is_ok() {
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
            }
            _ => {
                let _ = respond(
                    &stream,
                    426,
                    "text/plain",
                    b"a WebSocket stream\n",
                    &[("Upgrade", "websocket")],
                );
            }
        },
        _ => {
            let _ = respond(&stream, 404, "text/plain", b"not found\n", &[]);
        }
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
        match listen(&mut ws, hub) {
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

/// Reads what the browser sent, if anything: a replay's controls and pongs; anything else
/// drops it. Says whether the browser was heard from.
fn listen(ws: &mut WebSocket<TcpStream>, hub: &Hub) -> Result<bool, Ended> {
    let mut heard = false;
    for _ in 0..READS_PER_TURN {
        match ws.read() {
            Ok(Message::Text(t)) => match control(t.as_str()) {
                Some(c) if hub.controllable() => {
                    heard = true;
                    hub.send_control(c);
                }
                _ => return Err(refuse(ws, "not a request this viewer takes")),
            },
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
    Ended::Dropped
}

/// A replay control: `{"cmd":"pause"}`, `{"cmd":"play"}`, `{"cmd":"seek","time":S}`,
/// `{"cmd":"speed","value":X}` (X in 0.01..=100).
fn control(text: &str) -> Option<Control> {
    let v: serde_json::Value = serde_json::from_str(text).ok()?;
    let number = |k: &str| v.get(k)?.as_f64().filter(|x| x.is_finite());
    match v.get("cmd")?.as_str()? {
        "pause" => Some(Control::Pause),
        "play" => Some(Control::Play),
        "seek" => number("time").filter(|t| *t >= 0.0).map(Control::Seek),
        "speed" => number("value")
            .filter(|x| (0.01..=100.0).contains(x))
            .map(Control::Speed),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controls_are_read_and_anything_else_is_not() {
        assert_eq!(control(r#"{"cmd":"pause"}"#), Some(Control::Pause));
        assert_eq!(control(r#"{"cmd":"seek","time":1.5}"#), Some(Control::Seek(1.5)));
        assert_eq!(control(r#"{"cmd":"speed","value":2}"#), Some(Control::Speed(2.0)));
        for bad in [
            "",
            "pause",
            r#"{"cmd":"seek"}"#,
            r#"{"cmd":"seek","time":-1}"#,
            r#"{"cmd":"speed","value":0}"#,
            r#"{"cmd":"speed","value":1e9}"#,
            r#"{"cmd":"rm -rf"}"#,
            r#"[1,2]"#,
        ] {
            assert_eq!(control(bad), None, "{bad}");
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

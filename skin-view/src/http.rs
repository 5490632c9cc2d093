//! The HTTP the viewer speaks, and nothing of what it serves: a request head read whole within
//! [`HEAD_TIMEOUT`] and at most [`MAX_HEAD`] bytes, answers with a status and a body, and the
//! refusal that lets the client read why before the connection closes. Statuses and methods are
//! the `http` crate's types; the server decides what to answer ([`server`](crate::server)).

use http::{Method, StatusCode};
use std::io::{Read, Write};
use std::net::{Shutdown, TcpStream};
use std::time::{Duration, Instant};

/// The longest request head read.
const MAX_HEAD: usize = 8 * 1024;
/// How long a whole request head may take to arrive from the moment its connection is accepted
/// (a browser sends it at once; an idle socket is closed then, if not pushed out before).
pub const HEAD_TIMEOUT: Duration = Duration::from_secs(2);
/// After a refusal, how long and how much of what the client still sends is read (and thrown
/// away) before closing, so that it gets the answer instead of a reset.
const LINGER: Duration = Duration::from_secs(1);
/// See [`LINGER`].
const LINGER_BYTES: usize = 1024 * 1024;

/// A request head as far as the server cares.
pub(crate) struct Head {
    pub method: Method,
    /// The request target without its query or fragment.
    pub path: String,
    pub host: Option<String>,
    pub origin: Option<String>,
    /// `Upgrade: websocket` with `Connection: upgrade`.
    pub upgrade: bool,
    pub key: Option<String>,
    /// `Sec-WebSocket-Version: 13`.
    pub version_13: bool,
}

/// Reads a request head (at most [`MAX_HEAD`] bytes, all of it within [`HEAD_TIMEOUT`]); what
/// came after it (a browser sends nothing before the handshake's answer, but a client may) is
/// returned too. The error is the status to answer with.
pub(crate) fn read_head(stream: &mut TcpStream) -> Result<(Head, Vec<u8>), StatusCode> {
    let mut buf = Vec::with_capacity(1024);
    let mut chunk = [0u8; 1024];
    // The whole head within HEAD_TIMEOUT, not each read: a byte every few seconds does not
    // hold a connection.
    let deadline = Instant::now() + HEAD_TIMEOUT;
    loop {
        let left = deadline
            .checked_duration_since(Instant::now())
            .filter(|d| !d.is_zero())
            .ok_or(StatusCode::REQUEST_TIMEOUT)?;
        stream
            .set_read_timeout(Some(left))
            .map_err(|_| StatusCode::REQUEST_TIMEOUT)?;
        let n = stream.read(&mut chunk).map_err(|_| StatusCode::REQUEST_TIMEOUT)?;
        if n == 0 {
            return Err(StatusCode::BAD_REQUEST);
        }
        buf.extend_from_slice(&chunk[..n]);
        let mut headers = [httparse::EMPTY_HEADER; 32];
        let mut req = httparse::Request::new(&mut headers);
        match req.parse(&buf) {
            Ok(httparse::Status::Complete(len)) => return Ok((head_of(&req)?, buf[len..].to_vec())),
            Ok(httparse::Status::Partial) if buf.len() < MAX_HEAD => {}
            Ok(httparse::Status::Partial) | Err(httparse::Error::TooManyHeaders) => {
                return Err(StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE);
            }
            Err(_) => return Err(StatusCode::BAD_REQUEST),
        }
    }
}

/// What the server reads of a parsed request.
fn head_of(req: &httparse::Request<'_, '_>) -> Result<Head, StatusCode> {
    use http::header::{
        CONNECTION, HOST, HeaderName, ORIGIN, SEC_WEBSOCKET_KEY, SEC_WEBSOCKET_VERSION, UPGRADE,
    };
    let header = |name: &HeaderName| {
        req.headers
            .iter()
            .find(|h| h.name.eq_ignore_ascii_case(name.as_str()))
            .and_then(|h| std::str::from_utf8(h.value).ok())
            .map(str::to_owned)
    };
    let has = |name: &HeaderName, token: &str| {
        header(name).is_some_and(|v| v.split(',').any(|t| t.trim().eq_ignore_ascii_case(token)))
    };
    // httparse has checked the method is a token, which `Method` takes as it is.
    let method =
        Method::from_bytes(req.method.unwrap_or("").as_bytes()).map_err(|_| StatusCode::BAD_REQUEST)?;
    let target = req.path.unwrap_or("");
    Ok(Head {
        method,
        path: target.split(['?', '#']).next().unwrap_or("").to_owned(),
        host: header(&HOST),
        origin: header(&ORIGIN),
        upgrade: has(&UPGRADE, "websocket") && has(&CONNECTION, "upgrade"),
        key: header(&SEC_WEBSOCKET_KEY),
        version_13: header(&SEC_WEBSOCKET_VERSION).is_some_and(|v| v.trim() == "13"),
    })
}

/// An answer: its status, the type and bytes of its body, and headers beyond those every
/// answer has (`Content-Type`, `Content-Length`, `Cache-Control: no-store`,
/// `X-Content-Type-Options: nosniff`, `Connection: close`).
pub(crate) struct Answer<'a> {
    pub status: StatusCode,
    pub kind: &'a str,
    pub body: &'a [u8],
    /// The length the head says: the body's, or the page's for a `HEAD` request (which is sent
    /// no body).
    pub length: usize,
    pub extra: &'a [(&'a str, &'a str)],
}

impl<'a> Answer<'a> {
    /// `status` with a plain-text `body`.
    pub fn text(status: StatusCode, body: &'a [u8]) -> Answer<'a> {
        Answer {
            status,
            kind: "text/plain",
            body,
            length: body.len(),
            extra: &[],
        }
    }

    /// The same answer with `extra` headers.
    pub fn with(self, extra: &'a [(&'a str, &'a str)]) -> Answer<'a> {
        Answer { extra, ..self }
    }

    /// Writes the answer (head and body) and flushes it.
    pub fn send(&self, mut stream: &TcpStream) -> std::io::Result<()> {
        let mut head = format!(
            "HTTP/1.1 {} {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n",
            self.status.as_u16(),
            reason(self.status),
            self.kind,
            self.length,
        );
        for (k, v) in self.extra {
            head.push_str(&format!("{k}: {v}\r\n"));
        }
        head.push_str("\r\n");
        stream.write_all(head.as_bytes())?;
        stream.write_all(self.body)?;
        stream.flush()
    }

    /// Answers a refusal, then reads what the client still sends (at most [`LINGER_BYTES`],
    /// for at most [`LINGER`]) before closing: closing with unread bytes would reset the
    /// connection, and the client could lose the answer before reading it.
    pub fn refuse(&self, mut stream: TcpStream) {
        let _ = self.send(&stream);
        linger(&mut stream);
    }
}

/// Answers a WebSocket handshake whose key (`Sec-WebSocket-Key`) the server has checked: the
/// connection is the stream's from now on.
pub(crate) fn switching_protocols(stream: &mut TcpStream, key: &str) -> std::io::Result<()> {
    let accept = tungstenite::handshake::derive_accept_key(key.trim().as_bytes());
    let status = StatusCode::SWITCHING_PROTOCOLS;
    let answer = format!(
        "HTTP/1.1 {} {}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Accept: {accept}\r\n\r\n",
        status.as_u16(),
        reason(status),
    );
    stream.write_all(answer.as_bytes())
}

/// Whether a WebSocket key (`Sec-WebSocket-Key`) may be answered: it must be 16 bytes in
/// base64 (RFC 6455, 4.1 and 4.2.1).
pub(crate) fn key_ok(key: &str) -> bool {
    data_encoding::BASE64
        .decode(key.trim().as_bytes())
        .is_ok_and(|k| k.len() == 16)
}

/// A status's reason phrase (`Not Found`).
pub(crate) fn reason(status: StatusCode) -> &'static str {
    status.canonical_reason().unwrap_or("Error")
}

/// Stops writing, then reads what the client still sends (at most [`LINGER_BYTES`], for at
/// most [`LINGER`]): what was written reaches it before the connection closes.
pub(crate) fn linger(stream: &mut TcpStream) {
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

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;

    #[test]
    fn every_status_the_server_answers_has_its_reason_phrase() {
        for (status, phrase) in [
            (StatusCode::SWITCHING_PROTOCOLS, "Switching Protocols"),
            (StatusCode::OK, "OK"),
            (StatusCode::BAD_REQUEST, "Bad Request"),
            (StatusCode::FORBIDDEN, "Forbidden"),
            (StatusCode::NOT_FOUND, "Not Found"),
            (StatusCode::METHOD_NOT_ALLOWED, "Method Not Allowed"),
            (StatusCode::REQUEST_TIMEOUT, "Request Timeout"),
            (StatusCode::UPGRADE_REQUIRED, "Upgrade Required"),
            (
                StatusCode::REQUEST_HEADER_FIELDS_TOO_LARGE,
                "Request Header Fields Too Large",
            ),
            (StatusCode::SERVICE_UNAVAILABLE, "Service Unavailable"),
        ] {
            assert_eq!(reason(status), phrase);
        }
    }

    #[test]
    fn a_head_is_read_with_its_method_path_and_websocket_headers() {
        let mut headers = [httparse::EMPTY_HEADER; 8];
        let mut req = httparse::Request::new(&mut headers);
        let text = b"GET /stream?x=1 HTTP/1.1\r\nhost: a:1\r\nUpgrade: WebSocket\r\nConnection: keep-alive, Upgrade\r\nSec-WebSocket-Version: 13\r\n\r\n";
        assert!(matches!(req.parse(text), Ok(httparse::Status::Complete(_))));
        let head = head_of(&req).unwrap();
        assert_eq!(head.method, Method::GET);
        assert_eq!(head.path, "/stream");
        assert_eq!(head.host.as_deref(), Some("a:1"));
        assert!(head.upgrade && head.version_13 && head.key.is_none() && head.origin.is_none());
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
}

//! One browser's stream: the WebSocket handshake's answer, then a loop that waits on the
//! [hub](crate::hub) for something new, sends it, and checks whether the browser said something
//! (only a replay listens: pause, play, seek, speed). A control with a value out of range is
//! refused with a message and the stream goes on; a browser that sends anything else, or more
//! than 4 KiB at once, is dropped; the others go on. A browser is pinged, and one that takes
//! nothing or answers nothing for too long is dropped and gives its place back.

use crate::http::{linger, switching_protocols};
use crate::hub::{Control, Hub, SPEEDS};
use crate::wire::SKIPPED_AT;
use std::net::TcpStream;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use tungstenite::protocol::frame::CloseFrame;
use tungstenite::protocol::frame::coding::CloseCode;
use tungstenite::protocol::{Role, WebSocketConfig};
use tungstenite::{Message, WebSocket};

/// How often a browser is pinged; one that has answered nothing for [`SILENT_LIMIT`] is dropped
/// (a browser reads its stream and answers pings by itself; a client that stopped reading does
/// not, and gives its place back).
const PING_EVERY: Duration = Duration::from_secs(5);
/// See [`PING_EVERY`].
const SILENT_LIMIT: Duration = Duration::from_secs(30);
/// The longest message a browser may send.
const MAX_MESSAGE: usize = 4 * 1024;
/// How often a browser's thread looks for what the browser sent, when nothing new is to be sent.
const POLL: Duration = Duration::from_millis(50);

/// Answers the handshake of a stream the server has let in (its key checked), then streams to
/// the browser until it closes, is dropped, or the viewer closes; counted in the hub's stats.
/// `rest`: what the browser sent after its request head.
pub(crate) fn handshake_and_stream(mut stream: TcpStream, key: &str, rest: Vec<u8>, hub: &Arc<Hub>) {
    if switching_protocols(&mut stream, key).is_err() {
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
}

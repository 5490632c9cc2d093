//! The viewer's server from the outside, as browsers and hostile clients reach it: what it
//! serves and refuses, the stream's messages, a client sending garbage, a client that stops
//! reading, a port in use.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;
use common::{browser, next_frame};

use skin_learn::session::Session;
use skin_learn::synth::arm::{hand_on_middle_link, links_and_maps, tracking_session};

use skin_view::{Scene, Viewer};
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};
use tungstenite::Message;

/// The full arm's session (tracking only), its baseline learned, and the idle and hand-held
/// frames.
fn arm() -> (Session, Vec<Vec<f32>>, Vec<Vec<f32>>) {
    tracking_session().unwrap()
}

fn serve(session: &Session) -> Viewer {
    Viewer::bind(
        "127.0.0.1:0".parse().unwrap(),
        Scene::of_session(session, "full arm"),
    )
    .unwrap()
}

/// A raw request, and the status line of the answer.
fn status(viewer: &Viewer, request: &str) -> String {
    let mut s = TcpStream::connect(viewer.addr()).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    s.write_all(request.as_bytes()).unwrap();
    let mut answer = Vec::new();
    let _ = s.read_to_end(&mut answer);
    String::from_utf8_lossy(&answer)
        .lines()
        .next()
        .unwrap_or("")
        .to_owned()
}

#[test]
fn only_the_page_and_its_stream_are_served() {
    let (session, ..) = arm();
    let viewer = serve(&session);
    let host = viewer.addr();
    let get = |path: &str| status(&viewer, &format!("GET {path} HTTP/1.1\r\nHost: {host}\r\n\r\n"));
    assert!(get("/").contains("200"), "{}", get("/"));
    // HEAD: the page's length, no body.
    let mut s = TcpStream::connect(viewer.addr()).unwrap();
    write!(s, "HEAD / HTTP/1.1\r\nHost: {host}\r\n\r\n").unwrap();
    let mut answer = String::new();
    s.read_to_string(&mut answer).unwrap();
    let length: usize = answer
        .lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .unwrap()
        .parse()
        .unwrap();
    assert!(length > 10_000 && answer.ends_with("\r\n\r\n"), "{answer}");
    assert!(get("/index.html").contains("200"));
    for path in [
        "/favicon.ico",
        "/../../../../etc/passwd",
        "/%2e%2e/%2e%2e/etc/passwd",
        "/..%2f..%2fetc%2fpasswd",
        "//etc/passwd",
        "/fixtures/",
        "/src/",
        "/stream/../index.html",
        "*",
    ] {
        assert!(get(path).contains("404"), "{path}: {}", get(path));
    }
    assert!(
        get("/stream").contains("426"),
        "a plain GET of the stream is not a WebSocket"
    );
    let post = status(
        &viewer,
        &format!("POST / HTTP/1.1\r\nHost: {host}\r\nContent-Length: 0\r\n\r\n"),
    );
    assert!(post.contains("405"), "{post}");
    // Another site's name for this machine (DNS rebinding), another origin's WebSocket.
    assert!(status(&viewer, "GET / HTTP/1.1\r\nHost: evil.example\r\n\r\n").contains("403"));
    let foreign = format!(
        "GET /stream HTTP/1.1\r\nHost: {host}\r\nOrigin: http://evil.example\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
    );
    assert!(status(&viewer, &foreign).contains("403"));
    // Garbage and a head too large are refused, not served.
    assert!(status(&viewer, "\x00\x01garbage\r\n\r\n").contains("400"));
    for size in [20_000, 64 * 1024] {
        let answer = head_in_pieces(&viewer, size);
        assert!(
            answer.contains("431 Request Header Fields Too Large"),
            "{size}: {answer:?}"
        );
    }
}

/// Sends a request whose head is `size` bytes long in 4 KiB pieces, as a client over a network
/// does (the server answers before it has all of it), and returns the status line of the answer:
/// the client reads why it was refused, not a reset.
fn head_in_pieces(viewer: &Viewer, size: usize) -> String {
    let host = viewer.addr();
    let head = format!(
        "GET / HTTP/1.1\r\nHost: {host}\r\nX: {}\r\n\r\n",
        "a".repeat(size)
    );
    let mut s = TcpStream::connect(host).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    for piece in head.as_bytes().chunks(4096) {
        if let Err(e) = s.write_all(piece) {
            return format!("cut off while sending: {e}");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let mut answer = Vec::new();
    if let Err(e) = s.read_to_end(&mut answer) {
        return format!("cut off while reading: {e}");
    }
    String::from_utf8_lossy(&answer)
        .lines()
        .next()
        .unwrap_or("")
        .to_owned()
}

/// A WebSocket handshake with `key`, and the status line of the answer (read alone: a stream
/// that opens stays open).
fn handshake(viewer: &Viewer, key: &str) -> String {
    let host = viewer.addr();
    let mut s = TcpStream::connect(host).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    write!(
        s,
        "GET /stream HTTP/1.1\r\nHost: {host}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
    )
    .unwrap();
    let mut line = Vec::new();
    let mut byte = [0u8; 1];
    while !line.ends_with(b"\r\n") && s.read(&mut byte).unwrap_or(0) == 1 {
        line.push(byte[0]);
    }
    String::from_utf8_lossy(&line).trim_end().to_owned()
}

#[test]
fn a_websocket_key_that_is_not_16_bytes_in_base64_is_refused() {
    let (session, ..) = arm();
    let viewer = serve(&session);
    for bad in [
        "x",
        "not base64!!",
        "dGhlIHNhbXBsZQ==",
        "AAAAAAAAAAAAAAAAAAAAAAAAAAAA",
    ] {
        let answer = handshake(&viewer, bad);
        assert!(answer.contains("400"), "{bad}: {answer}");
    }
    assert!(handshake(&viewer, "dGhlIHNhbXBsZSBub25jZQ==").contains("101"));
}

#[test]
fn a_browser_gets_the_scene_then_each_frame_as_the_session_had_it() {
    let (mut session, idle, held) = arm();
    let viewer = serve(&session);
    let mut sink = viewer.sink();
    let mut ws = browser(&viewer);
    let Message::Text(scene) = ws.read().unwrap() else {
        panic!("the scene comes first")
    };
    let scene: serde_json::Value = serde_json::from_str(scene.as_str()).unwrap();
    assert_eq!(scene["scene"]["links"].as_array().unwrap().len(), 3);
    assert_eq!(
        scene["scene"]["links"][1]["uv_mm"].as_array().unwrap().len(),
        1165
    );
    let _ = session.push(10_000_000, 500, &held, &mut sink).unwrap();
    let f = next_frame(&mut ws);
    assert_eq!(f.head.cycle, 500);
    assert_eq!(f.pressures.len(), 3495);
    // The pressures are the session's: zero on the idle links, the hand's on the middle one.
    let offset = 1165;
    let hand = {
        let (links, maps) = links_and_maps().unwrap();
        hand_on_middle_link(&links, &maps[1]).unwrap()
    };
    for (i, want) in hand[1].iter().enumerate() {
        assert!((f.pressures[offset + i] - want).abs() < 1e-3, "taxel {i}");
    }
    assert!(f.pressures[..offset].iter().all(|p| p.abs() < 1e-3));
    // Each contact is drawn where its taxels are on the middle link's map.
    assert!(!f.contacts.is_empty());
    assert!(f.contacts.iter().all(|c| c.link == 1 && c.taxels > 0));
    let _ = session.push(10_020_000, 501, &idle, &mut sink).unwrap();
    assert_eq!(next_frame(&mut ws).head.cycle, 501);
}

#[test]
fn a_client_sending_garbage_is_dropped_and_the_others_go_on() {
    let (mut session, idle, _) = arm();
    let viewer = serve(&session);
    let mut sink = viewer.sink();
    let mut good = browser(&viewer);
    let mut bad = browser(&viewer);
    let mut big = browser(&viewer);
    bad.send(Message::Text("garbage".into())).unwrap();
    big.send(Message::Binary(vec![7u8; 100_000].into())).unwrap_or(());
    // The live viewer takes no controls either: a well-formed one is refused all the same.
    let mut control = browser(&viewer);
    control.send(Message::Text(r#"{"cmd":"pause"}"#.into())).unwrap();
    for (name, ws) in [
        ("garbage", &mut bad),
        ("oversized", &mut big),
        ("control", &mut control),
    ] {
        // Told why: a close with "policy violation" (not merely a broken connection).
        let closed = (0..100).any(|_| match ws.read() {
            Ok(Message::Close(Some(f))) => f.code == tungstenite::protocol::frame::coding::CloseCode::Policy,
            Ok(_) => false,
            Err(e) => panic!("the {name} client's connection broke before it was told why: {e}"),
        });
        assert!(closed, "the {name} client was not dropped");
    }
    for k in 0..3u64 {
        let _ = session
            .push(20_000_000 + k * 20_000, 900 + k, &idle, &mut sink)
            .unwrap();
        assert_eq!(next_frame(&mut good).head.cycle, 900 + k);
    }
    let deadline = Instant::now() + Duration::from_secs(10);
    while viewer.stats().dropped < 3 && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(viewer.stats().dropped >= 3, "{:?}", viewer.stats());
}

#[test]
fn a_port_in_use_is_one_clear_line() {
    let (session, ..) = arm();
    let first = serve(&session);
    let Err(e) = Viewer::bind(first.addr(), Scene::of_session(&session, "x")) else {
        panic!("a second viewer bound the same port")
    };
    let text = e.to_string();
    assert!(
        text.contains(&first.addr().to_string()) && text.contains("in use"),
        "{text}"
    );
    assert!(!text.contains('\n'), "{text}");
}

#[test]
fn on_the_network_a_foreign_name_or_origin_is_refused() {
    let (session, ..) = arm();
    let viewer = Viewer::bind("0.0.0.0:0".parse().unwrap(), Scene::of_session(&session, "arm")).unwrap();
    let port = viewer.addr().port();
    let ask = |host: &str, origin: Option<&str>| {
        let origin = origin.map_or(String::new(), |o| format!("Origin: {o}\r\n"));
        let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
        s.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
        write!(
            s,
            "GET /stream HTTP/1.1\r\nHost: {host}\r\n{origin}Upgrade: websocket\r\nConnection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n"
        )
        .unwrap();
        let mut head = [0u8; 12];
        s.read_exact(&mut head).unwrap();
        String::from_utf8_lossy(&head).into_owned()
    };
    // By address: served, from the page's own origin.
    let own = format!("127.0.0.1:{port}");
    assert!(ask(&own, Some(&format!("http://{own}"))).contains("101"));
    assert!(ask(&format!("192.168.1.20:{port}"), None).contains("101"));
    // A name an attacker's DNS points here (rebinding), another site's page, another port's.
    assert!(ask(&format!("evil.example:{port}"), None).contains("403"));
    assert!(ask(&own, Some("http://evil.example")).contains("403"));
    assert!(ask(&own, Some("http://127.0.0.1:3000")).contains("403"));
}

#[test]
fn browsers_beyond_the_limit_are_refused_and_the_page_still_loads() {
    let (session, ..) = arm();
    let viewer = serve(&session);
    // All from this machine's one address: the limit per address is reached first (the limit
    // over all addresses is the limits' own unit test).
    let streams: Vec<_> = (0..skin_view::MAX_STREAMS_PER_ADDRESS)
        .map(|_| browser(&viewer))
        .collect();
    let deadline = Instant::now() + Duration::from_secs(10);
    while viewer.stats().browsers < streams.len() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(10));
    }
    let one_more = handshake(&viewer, "dGhlIHNhbXBsZSBub25jZQ==");
    assert!(one_more.contains("503"), "{one_more}");
    let host = viewer.addr();
    assert!(status(&viewer, &format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n")).contains("200"));
    drop(streams);
}

/// Loads the page as a browser does: the whole answer, within `within` (the client gives up
/// then).
fn load_page(viewer: &Viewer, within: Duration) -> Result<Vec<u8>, String> {
    let host = viewer.addr();
    let mut s = TcpStream::connect(host).map_err(|e| format!("connect: {e}"))?;
    s.set_read_timeout(Some(within)).unwrap();
    s.write_all(format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n").as_bytes())
        .map_err(|e| format!("send: {e}"))?;
    let mut answer = Vec::new();
    s.read_to_end(&mut answer).map_err(|e| format!("read: {e}"))?;
    Ok(answer)
}

#[test]
fn idle_sockets_do_not_lock_browsers_out_of_the_page() {
    let (session, ..) = arm();
    let viewer = serve(&session);
    let host = viewer.addr();
    let page_length = |answer: &[u8]| {
        let text = String::from_utf8_lossy(answer);
        let (head, body) = text.split_once("\r\n\r\n").unwrap_or((&text, ""));
        (head.lines().next().unwrap_or("").to_owned(), body.len())
    };
    let (_, full) = page_length(&load_page(&viewer, Duration::from_secs(10)).unwrap());
    // 200 idle sockets, held open from this machine's one address, as the real client's: half
    // send nothing, half the start of a head and then nothing (slowloris).
    let idle: Vec<TcpStream> = (0..200)
        .map(|k| {
            let mut s = TcpStream::connect(host).unwrap();
            if k % 2 == 1 {
                s.write_all(format!("GET / HTTP/1.1\r\nHost: {host}\r\n").as_bytes())
                    .unwrap();
            }
            s
        })
        .collect();
    // The page loads every time while they are held. The client waits at most 5 s, a generous
    // margin over the 1 s a browser must get it within; without the limits it got a 503 or a
    // reset at once, or waited for the idle sockets to time out.
    for k in 0..10 {
        let started = Instant::now();
        let answer = load_page(&viewer, Duration::from_secs(5));
        let took = started.elapsed();
        let (status, body) = page_length(&answer.unwrap_or_else(|e| panic!("load {k}: {e}")));
        assert!(status.contains("200"), "load {k}: {status}");
        assert_eq!(body, full, "load {k}: the page cut short");
        eprintln!("load {k}: {} ms", took.as_millis());
    }
    // Held to the end: the loads above were made with all 200 open on this side.
    assert_eq!(idle.len(), 200);
    drop(idle);
}

#[test]
fn a_viewer_dropped_stops_accepting_and_frees_its_port() {
    // The accepting thread blocks in `accept`: dropping the viewer must wake it and wait for it
    // to end, on loopback and on every interface (woken through loopback). Without the wake,
    // the drop never returns; with a thread left running, the port stays taken.
    let (session, ..) = arm();
    for addr in ["127.0.0.1:0", "0.0.0.0:0"] {
        let viewer = Viewer::bind(addr.parse().unwrap(), Scene::of_session(&session, "arm")).unwrap();
        let served = viewer.addr();
        let host = format!("127.0.0.1:{}", served.port());
        let page = status(&viewer, &format!("GET / HTTP/1.1\r\nHost: {host}\r\n\r\n"));
        assert!(page.contains("200"), "{addr}: {page}");
        drop(viewer);
        let again = std::net::TcpListener::bind(served);
        assert!(
            again.is_ok(),
            "{addr}: port {} still taken: {again:?}",
            served.port()
        );
    }
}

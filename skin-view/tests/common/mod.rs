//! What the viewer's integration tests share: a browser's stream, read as a browser does.

#![allow(clippy::unwrap_used, dead_code)]

use skin_view::Viewer;
use skin_view::wire::{DecodedFrame, decode_frame};
use std::net::TcpStream;
use std::time::Duration;
use tungstenite::{Message, WebSocket};

/// A client on the viewer's stream (its reads time out after 10 s).
pub fn browser(viewer: &Viewer) -> WebSocket<TcpStream> {
    let stream = TcpStream::connect(viewer.addr()).unwrap();
    stream.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
    let url = format!("ws://{}/stream", viewer.addr());
    tungstenite::client::client(url, stream).unwrap().0
}

/// The next frame the browser gets (text messages before it are skipped).
pub fn next_frame(ws: &mut WebSocket<TcpStream>) -> DecodedFrame {
    loop {
        if let Message::Binary(b) = ws.read().unwrap()
            && let Some(f) = decode_frame(&b)
        {
            return f;
        }
    }
}

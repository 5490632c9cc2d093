//! See a robot skin live, in a browser, with nothing to install: a [`Viewer`] serves a read-only
//! page that draws every link's tactile map with each taxel coloured by its pressure, the
//! contacts over it, the touches on a timeline with their decisions, the gate's action, and the
//! health of the input (frames per second, incomplete frames, missing modules, counter resets).
//!
//! ```text
//!  Session ──frame, events, images──▶ ViewSink ──latest frame, last events──▶ hub
//!                                                                              │  one thread
//!  Replay (an MCAP file skin wrote, feature `mcap`) ──────────────────────────▶│  per browser
//!                                                                              ▼
//!                         GET /  (the page)      GET /stream  (WebSocket: scene, events as
//!                                                JSON; frames and images binary, see `wire`)
//! ```
//!
//! - [`scene`]: what does not change (maps, dead taxels, modules, classes), sent once as JSON.
//! - [`wire`]: the binary frame and image formats (a full-arm frame is 14 KB of float32).
//! - `hub`: only the latest frame and image and the last 4,096 events are kept. A browser that
//!   is slow or stalls is sent the newest frame when it can take one and skips the others
//!   (counted, and shown on its page): the session never waits for a browser and the viewer's
//!   memory does not grow with one.
//! - `server`: `GET /` and `GET /stream`, nothing else (404; no file is read for a request);
//!   loopback unless another address is asked for. It speaks HTTP through `http` (request heads,
//!   answers, refusals; the `http` crate's statuses and methods) and hands each browser's stream
//!   to `browser`, whose loop sends what is new and drops a browser sending garbage.
//! - `limits`: idle sockets cannot lock browsers out. A request head must arrive within
//!   [`HEAD_TIMEOUT`]; connections still waiting for theirs are given up first, each address's
//!   oldest once it holds [`MAX_WAITING_PER_ADDRESS`], the busiest address's past
//!   [`MAX_WAITING`]; at most [`MAX_STREAMS`] browsers watch, [`MAX_STREAMS_PER_ADDRESS`] from
//!   one address, and the page is served when no stream is left.
//!
//! ```no_run
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use skin_can::candump::CandumpLog;
//! use skin_learn::session::{FromConfig, Session, SessionConfig};
//! use skin_view::{Scene, Viewer};
//! use std::path::Path;
//!
//! let config = SessionConfig::read(Path::new("fixtures/session/run.toml"))?;
//! let mut session = Session::from_config(&config)?;
//! // Port 0: any free port; `viewer.url()` says which.
//! let viewer = Viewer::bind("127.0.0.1:0".parse()?, Scene::of_session(&session, "run.toml"))?;
//! println!("open {}", viewer.url());
//! // The session's frames and events reach the page (beside any other sink: a tuple of sinks
//! // is a sink).
//! let path = Path::new("fixtures/session/session.candump.log");
//! let log = CandumpLog::read(path)?;
//! session.run_log(&log, path, &mut viewer.sink(), &mut |_, _| {})?;
//! # Ok(()) }
//! ```

mod browser;
mod http;
mod hub;
mod limits;
pub mod scene;
mod server;
mod sink;
pub mod wire;

#[cfg(feature = "mcap")]
pub mod replay;

pub use crate::http::HEAD_TIMEOUT;
pub use hub::{Control, SPEEDS};
pub use limits::{
    MAX_CONNECTIONS, MAX_STREAMS, MAX_STREAMS_PER_ADDRESS, MAX_WAITING, MAX_WAITING_PER_ADDRESS,
};
pub use scene::Scene;
pub use server::{ViewError, ViewStats};
pub use sink::ViewSink;

use std::net::SocketAddr;
use std::sync::Arc;

/// Events a replay's timeline lists at most.
pub const MAX_TIMELINE: usize = 100_000;

/// The viewer: a page and its stream, served until dropped.
pub struct Viewer {
    server: server::Server,
    geometry: Arc<sink::Geometry>,
}

impl std::fmt::Debug for Viewer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Viewer")
            .field("addr", &self.server.addr)
            .finish_non_exhaustive()
    }
}

impl Viewer {
    /// Serves `scene` on `addr` (port 0: any free port; [`Viewer::addr`] says which). Give a
    /// loopback address unless other machines should see the skin: the page is read-only, but
    /// anyone who can reach the port can watch.
    pub fn bind(addr: SocketAddr, scene: Scene) -> Result<Viewer, ViewError> {
        let views = scene.links.len() + 1;
        let json = serde_json::to_string(&scene).unwrap_or_else(|_| "{}".into());
        let hub = Arc::new(hub::Hub::new(json, views));
        Ok(Viewer {
            server: server::Server::bind(addr, hub)?,
            geometry: Arc::new(sink::Geometry::of(&scene)),
        })
    }

    /// The address served (with the port chosen when 0 was asked for).
    pub fn addr(&self) -> SocketAddr {
        self.server.addr
    }

    /// The page's address, `http://127.0.0.1:8080/`; for a viewer on every interface
    /// (`0.0.0.0`, `::`), its address on this machine (other machines use one of its network
    /// addresses, or its name, with the same port).
    pub fn url(&self) -> String {
        let mut addr = self.server.addr;
        if addr.ip().is_unspecified() {
            addr.set_ip(match addr {
                SocketAddr::V4(_) => std::net::Ipv4Addr::LOCALHOST.into(),
                SocketAddr::V6(_) => std::net::Ipv6Addr::LOCALHOST.into(),
            });
        }
        format!("http://{addr}/")
    }

    /// Tells the pages the session is over (they say so, and stop counting frames and
    /// latency); the last frame stays shown.
    pub fn finished(&self) {
        self.server.hub.put_status(r#"{"ended":true}"#.to_owned());
    }

    /// A sink for the session whose scene this is. Several may exist; frames from all of them
    /// reach the page, so use one per session.
    pub fn sink(&self) -> ViewSink {
        ViewSink::new(self.server.hub.clone(), self.geometry.clone())
    }

    /// What has been sent and skipped so far.
    pub fn stats(&self) -> ViewStats {
        self.server.stats()
    }

    /// Takes the browsers' replay controls (pause, play, seek, speed) from now on; until this is
    /// called, a browser that sends one is dropped, as for any other message.
    pub fn controls(&self) -> std::sync::mpsc::Receiver<Control> {
        self.server.hub.controls()
    }

    /// Replaces the scene (browsers connected get it again and start over).
    pub fn set_scene(&mut self, scene: &Scene) {
        self.geometry = Arc::new(sink::Geometry::of(scene));
        let json = serde_json::to_string(scene).unwrap_or_else(|_| "{}".into());
        self.server.hub.put_scene(json, scene.links.len() + 1);
    }
}

//! The viewer from the command line: `skin run ... --view ADDR` serves the session as it runs,
//! `skin view FILE.mcap --view ADDR` replays an MCAP file skin wrote. The server is skin-view's;
//! this parses the address, paces a file's frames to real time, and keeps the page up after a
//! run until Ctrl-C.

use anyhow::Result;
use skin_learn::session::{Event, Flow, ProcessedFrame, Session, Sink};
use skin_view::{Scene, ViewSink, Viewer};
use std::net::{IpAddr, Ipv4Addr, SocketAddr, ToSocketAddrs};
use std::path::Path;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// The viewer's flags of `skin run`.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ViewArgs {
    /// Serve a live view of the session to a browser: every link's tactile map coloured by
    /// pressure, contacts, touches with their decisions, the gate, missing modules. ADDR is a
    /// port (8080: this machine only), or HOST:PORT; port 0 picks a free one. Only an address
    /// given explicitly other than loopback (0.0.0.0:8080) serves other machines. A log or
    /// recording plays at its own pace (see --speed); after it the page stays until Ctrl-C.
    #[arg(long, value_name = "ADDR", value_parser = parse_addr)]
    pub view: Option<SocketAddr>,
    /// With --view and a log or recording: play it at this many times its own pace (0: as fast
    /// as it can be processed).
    // A negative number is taken as the value it is, so that it is refused as a speed (not
    // read as an unknown flag, with clap's tip to pass it after `--`).
    #[arg(long, value_name = "X", default_value_t = 1.0, requires = "view", value_parser = speed, allow_negative_numbers = true)]
    pub speed: f64,
}

/// A play speed: 0 (as fast as it goes), or one the page's replay controls take too
/// (`skin_view::SPEEDS`, times the input's own pace).
fn speed(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(x) if x == 0.0 => Ok(x),
        _ => in_speeds(text).ok_or_else(|| format!("must be 0 (as fast as it goes) or {}", speeds())),
    }
}

/// A replay's speed: what the page's replay controls take (`skin_view::SPEEDS`).
#[cfg(feature = "mcap")]
fn replay_speed(text: &str) -> Result<f64, String> {
    in_speeds(text).ok_or_else(|| format!("must be {}", speeds()))
}

fn in_speeds(text: &str) -> Option<f64> {
    text.trim()
        .parse::<f64>()
        .ok()
        .filter(|x| skin_view::SPEEDS.contains(x))
}

/// The speeds the page takes, in words.
fn speeds() -> String {
    let range = skin_view::SPEEDS;
    format!("from {} to {} (times real time)", range.start(), range.end())
}

/// A viewer's address: `PORT` on loopback, or `HOST:PORT` (checked by clap, before any work).
pub fn parse_addr(text: &str) -> Result<SocketAddr, String> {
    let text = text.trim();
    if let Ok(port) = text.parse::<u16>() {
        return Ok(SocketAddr::new(IpAddr::V4(Ipv4Addr::LOCALHOST), port));
    }
    if let Ok(a) = text.parse::<SocketAddr>() {
        return Ok(a);
    }
    let bad = || "not a port (8080) or HOST:PORT (127.0.0.1:8080, [::1]:8080, localhost:8080)".to_owned();
    if !text
        .rsplit_once(':')
        .is_some_and(|(h, p)| !h.is_empty() && p.parse::<u16>().is_ok())
    {
        return Err(bad());
    }
    text.to_socket_addrs()
        .map_err(|e| format!("{}: {e}", bad()))?
        .next()
        .ok_or_else(bad)
}

/// Serves `scene` at `addr`, saying where (and warning when other machines can reach it).
pub fn serve(addr: SocketAddr, scene: Scene) -> Result<Viewer> {
    let viewer = Viewer::bind(addr, scene)?;
    say_where(&viewer);
    Ok(viewer)
}

/// Where the page is; a warning when other machines can reach it.
fn say_where(viewer: &Viewer) {
    eprintln!("view the skin at {}", viewer.url());
    let ip = viewer.addr().ip();
    if !ip.is_loopback() {
        let on = if ip.is_unspecified() {
            format!(
                "every interface (other machines: this machine's address or name, port {})",
                viewer.addr().port()
            )
        } else {
            ip.to_string()
        };
        eprintln!(
            "warning: the viewer listens on {on}, not loopback only: anyone who can reach this port can watch the skin (read-only)"
        );
    }
}

/// The viewer of `--view`, if asked for, bound before the session is built (a port in use
/// fails at once); its scene comes with [`show`].
pub fn bind(args: &ViewArgs, config: &Path) -> Result<Option<Viewer>> {
    args.view
        .map(|addr| serve(addr, Scene::from_maps(&[], &name(config))))
        .transpose()
}

/// Shows `session` (built from `config`) on the viewer, if any.
pub fn show(viewer: Option<&mut Viewer>, session: &Session, config: &Path) {
    if let Some(v) = viewer {
        v.set_scene(&Scene::of_session(session, &name(config)));
    }
}

/// A path as the page names its source: the file's name.
fn name(path: &Path) -> String {
    path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}

/// Keeps the page (if any) up after the run until Ctrl-C.
pub fn hold(viewer: Option<&Viewer>) {
    let Some(viewer) = viewer else { return };
    viewer.finished();
    crate::output::stop_gracefully();
    let stop = crate::output::stop_flag();
    if stop.load(Ordering::SeqCst) {
        return;
    }
    eprintln!("the run is over; the page stays at {} until Ctrl-C", viewer.url());
    while !stop.load(Ordering::SeqCst) {
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The viewer's sink and, for a file, its pacing.
pub struct View {
    sink: ViewSink,
    pace: Option<Pace>,
}

impl View {
    /// The sink of `viewer`; a file's frames paced to `speed` times their own pace (none: live,
    /// or `speed` 0).
    pub fn new(viewer: &Viewer, speed: Option<f64>) -> View {
        View {
            sink: viewer.sink(),
            pace: speed
                .filter(|s| *s > 0.0)
                .map(|speed| Pace { speed, anchor: None }),
        }
    }
}

impl View {
    /// The next input starts (a batch's next recording): its frames are paced from its own
    /// first one.
    pub fn restart(&mut self) {
        if let Some(p) = &mut self.pace {
            p.anchor = None;
        }
    }
}

/// Holds each frame back until its time has come, counted from the first frame shown.
struct Pace {
    speed: f64,
    anchor: Option<(Instant, u64)>,
}

impl Pace {
    fn wait(&mut self, time_us: u64) {
        let (wall, t0) = *self.anchor.get_or_insert((Instant::now(), time_us));
        let after = Duration::try_from_secs_f64(time_us.saturating_sub(t0) as f64 / 1e6 / self.speed);
        let Some(due) = after.ok().and_then(|d| wall.checked_add(d)) else {
            return;
        };
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
    }
}

/// The viewer's sink, paced: it never fails.
impl Sink for View {
    type Error = std::convert::Infallible;

    fn event(&mut self, event: &Event) -> Result<Flow, Self::Error> {
        self.sink.event(event)
    }

    fn frame_image(
        &mut self,
        view: skin_learn::session::FrameView<'_>,
        cycle: u64,
        image: skin_core::image::ImageView<'_, u8>,
    ) -> Result<Flow, Self::Error> {
        self.sink.frame_image(view, cycle, image)
    }

    fn frame(&mut self, frame: &ProcessedFrame<'_>) -> Result<Flow, Self::Error> {
        if let Some(p) = &mut self.pace {
            p.wait(frame.time_us);
        }
        self.sink.frame(frame)
    }
}

/// Replay an MCAP file that skin wrote to a browser, with pause, seek and speed (feature
/// `mcap`).
#[cfg(feature = "mcap")]
pub use replay::{Args, run};

#[cfg(feature = "mcap")]
mod replay {
    use super::{SocketAddr, parse_addr, replay_speed, serve};
    use anyhow::Result;
    use skin_view::replay::Replay;
    use std::path::PathBuf;

    /// Replay an MCAP file that skin wrote to a browser, with pause, seek and speed.
    ///
    /// The page shows what the file holds: each link's pressures (its tactile map is made from the
    /// taxel positions the file's pressure clouds carry), the contacts, and every event of the run
    /// on the timeline. Play, pause, seek and speed are on the page; Ctrl-C ends the replay.
    #[derive(clap::Args)]
    pub struct Args {
        /// An MCAP file written by `skin run --mcap` or `skin convert`.
        #[arg(value_name = "FILE.mcap")]
        file: PathBuf,
        /// Where to serve the page: a port (8080: this machine only), or HOST:PORT; 0 picks a
        /// free port. Only an address given explicitly other than loopback serves other machines.
        #[arg(long, value_name = "ADDR", default_value = "8080", value_parser = parse_addr)]
        view: SocketAddr,
        /// Counts above the baseline from which a taxel is drawn as pressed (the run's
        /// `[touch] threshold`).
        #[arg(long, value_name = "COUNTS", default_value_t = 5.0, value_parser = crate::numbers::within(0.0, 1e6))]
        threshold: f64,
        /// Play at this many times real time from the start (0.01 to 100; the page changes it
        /// while playing).
        #[arg(long, value_name = "X", default_value_t = 1.0, value_parser = replay_speed, allow_negative_numbers = true)]
        speed: f64,
    }

    /// Damaged chunks named one a line, at most this many (then how many more).
    const DAMAGED_LINES: usize = 10;

    /// Names the file's damaged chunks, if any, before it is served.
    fn say_damage(replay: &Replay, file: &std::path::Path) {
        let damaged = replay.damaged();
        if damaged.is_empty() {
            return;
        }
        let spans: Vec<String> = replay
            .scene()
            .replay
            .iter()
            .flat_map(|r| &r.damaged)
            .map(|d| format!("{:.2} s to {:.2} s", d.from, d.to))
            .collect();
        eprintln!(
            "warning: {}: {} of {} chunks are damaged: what the page shows from {} cannot be trusted",
            file.display(),
            damaged.len(),
            replay.chunks(),
            spans.join(", ")
        );
        for d in damaged.iter().take(DAMAGED_LINES) {
            eprintln!("  {d}");
        }
        if damaged.len() > DAMAGED_LINES {
            eprintln!("  and {} more", damaged.len() - DAMAGED_LINES);
        }
    }

    pub fn run(args: Args) -> Result<()> {
        let mut replay = Replay::open(&args.file, args.threshold as f32)?;
        replay.set_speed(args.speed)?;
        say_damage(&replay, &args.file);
        let viewer = serve(args.view, replay.scene().clone())?;
        eprintln!(
            "replaying {} ({:.1} s, {} link{}): Ctrl-C ends",
            args.file.display(),
            replay.duration(),
            replay.scene().links.len(),
            if replay.scene().links.len() == 1 { "" } else { "s" }
        );
        crate::output::stop_gracefully();
        let controls = viewer.controls();
        replay.play(&viewer, &controls, crate::output::stop_flag())?;
        Ok(())
    }
}

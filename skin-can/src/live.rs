//! Live acquisition: one reader thread per CAN interface, the `skin16` sync when this side is the
//! bus master, recovery from an interface that goes down, and every frame handed on in arrival
//! order (to an [`Assembler`](crate::Assembler), a [`candump`](crate::candump) recorder, or both).
//!
//! The hardware side is the [`CanPort`] trait. On Linux with the `socketcan` feature,
//! [`socketcan::SocketCanPort`] implements it over SocketCAN with kernel receive timestamps; tests
//! and other transports implement it themselves. (The workplace this crate is developed in has no
//! SocketCAN in its kernel: the live path is tested against scripted ports and recorded logs.)
//!
//! ```
//! use skin_can::live::{Acquisition, CanPort, LiveEvent, LiveOptions};
//! use skin_can::candump::CanFrame;
//! use std::time::Duration;
//!
//! /// A port that answers nothing: enough to watch the master's syncs go out.
//! struct Quiet(String);
//! impl CanPort for Quiet {
//!     fn name(&self) -> &str { &self.0 }
//!     fn open(&mut self) -> std::io::Result<()> { Ok(()) }
//!     fn close(&mut self) {}
//!     fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<CanFrame>> {
//!         std::thread::sleep(timeout);
//!         Ok(None)
//!     }
//!     fn send(&mut self, _: &CanFrame) -> std::io::Result<()> { Ok(()) }
//! }
//!
//! let options = LiveOptions { sync_period: Some(Duration::from_millis(2)), ..LiveOptions::default() };
//! let mut acq = Acquisition::start(vec![Quiet("can0".into())], options);
//! let mut syncs = 0;
//! while syncs < 3 {
//!     if let Some(LiveEvent::Frame(f)) = acq.recv(Duration::from_secs(1)) {
//!         assert_eq!(f.id, 0x080); // skin16 sync, counter in byte 0
//!         syncs += 1;
//!     }
//! }
//! acq.stop();
//! ```

use crate::candump::{CanFrame, Direction};
use crate::decode::skin16::encode_sync;
use crate::{AssembledFrame, Assembler, AssemblyStats, BusMap};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// One CAN interface, as the live path needs it.
///
/// Frames returned by [`recv`](CanPort::recv) carry their receive time in `time_us`
/// (microseconds since the Unix epoch; kernel timestamps where the transport has them); their
/// `bus` is filled in by the [`Acquisition`].
pub trait CanPort: Send + 'static {
    /// Interface name (`can0`, ...), as in bus maps and candump logs.
    fn name(&self) -> &str;
    /// Opens the interface, or reopens it after an error.
    fn open(&mut self) -> std::io::Result<()>;
    /// Releases the interface after an error (it is opened again before the next read).
    fn close(&mut self);
    /// Waits at most `timeout` for one frame; `Ok(None)` when none came. An error means the
    /// interface is unusable until reopened (down, bus-off, removed).
    fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<CanFrame>>;
    /// Sends one frame.
    fn send(&mut self, frame: &CanFrame) -> std::io::Result<()>;
}

/// How to run an acquisition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LiveOptions {
    /// Act as `skin16` bus master: send a sync on every interface every period (cycle counters
    /// agree across interfaces: they count periods since the start). `None` listens only.
    pub sync_period: Option<Duration>,
    /// Wait between attempts to reopen an interface that failed.
    pub reopen_after: Duration,
    /// Longest a reader blocks before checking whether it should stop.
    pub poll: Duration,
}

impl Default for LiveOptions {
    fn default() -> Self {
        LiveOptions {
            sync_period: None,
            reopen_after: Duration::from_millis(500),
            poll: Duration::from_millis(20),
        }
    }
}

/// What an [`Acquisition`] reports, in arrival order.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LiveEvent {
    /// A frame received, or a sync this side sent (`direction` = transmitted).
    Frame(CanFrame),
    /// An interface failed (read, write or open error); it will be reopened.
    Down {
        /// Index of the interface in the list given to [`Acquisition::start`].
        bus: u16,
        /// What the system said.
        error: String,
    },
    /// An interface is open again after a failure.
    Reopened {
        /// Index of the interface.
        bus: u16,
    },
}

/// A running acquisition: reader threads for every interface, events on one channel.
#[derive(Debug)]
pub struct Acquisition {
    events: Receiver<LiveEvent>,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    interfaces: Vec<String>,
}

impl Acquisition {
    /// Starts one reader thread per port. Interface `k` of the list is bus `k` of every frame
    /// (use [`Acquisition::interfaces`] as the interface list of an
    /// [`Assembler`](crate::Assembler) or a candump log).
    pub fn start<P: CanPort>(ports: Vec<P>, options: LiveOptions) -> Acquisition {
        let (tx, events) = channel();
        let stop = Arc::new(AtomicBool::new(false));
        let start = Instant::now();
        let interfaces = ports.iter().map(|p| p.name().to_string()).collect();
        let threads = ports
            .into_iter()
            .enumerate()
            .map(|(bus, port)| {
                let reader = Reader {
                    port,
                    bus: bus as u16,
                    tx: tx.clone(),
                    stop: Arc::clone(&stop),
                    options,
                    start,
                };
                std::thread::spawn(move || reader.run())
            })
            .collect();
        Acquisition {
            events,
            stop,
            threads,
            interfaces,
        }
    }

    /// Interface names, in bus order.
    pub fn interfaces(&self) -> &[String] {
        &self.interfaces
    }

    /// The next event, waiting at most `timeout`; `None` if none came (or every reader ended).
    pub fn recv(&self, timeout: Duration) -> Option<LiveEvent> {
        self.events.recv_timeout(timeout).ok()
    }

    /// Stops the readers and waits for them.
    pub fn stop(mut self) {
        self.halt();
    }

    fn halt(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Drop for Acquisition {
    fn drop(&mut self) {
        self.halt();
    }
}

/// What [`LiveFrames::poll`] hands on, in arrival order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Live<'a> {
    /// A CAN frame received, or a sync this side sent (to record it).
    Can(&'a CanFrame),
    /// A skin frame the assembler completed.
    Frame(&'a AssembledFrame),
    /// An interface failed; it will be reopened.
    Down {
        /// Its name.
        interface: &'a str,
        /// What the system said.
        error: &'a str,
    },
    /// An interface is open again after a failure.
    Reopened {
        /// Its name.
        interface: &'a str,
    },
}

/// Live skin frames: an [`Acquisition`] feeding an [`Assembler`], the one acquisition loop of
/// every live consumer (`skin live`, `skin record`, `skin run --can`, a robot stack).
///
/// ```no_run
/// # #[cfg(all(feature = "socketcan", target_os = "linux"))] {
/// use skin_can::live::{Live, LiveFrames, LiveOptions, socketcan::SocketCanPort};
/// use std::time::Duration;
///
/// let map = skin_can::BusMap::read("busmap.toml".as_ref())?;
/// let ports = map.buses.iter().map(|b| SocketCanPort::new(&b.interface)).collect();
/// let mut frames = LiveFrames::start(ports, LiveOptions::default(), &map, Duration::from_millis(50));
/// loop {
///     frames.poll(Duration::from_millis(50), &mut |item| {
///         if let Live::Frame(f) = item {
///             println!("cycle {}: {} modules missing", f.cycle, f.missing.len());
///         }
///     });
/// }
/// # }
/// # Ok::<(), skin_can::Error>(())
/// ```
pub struct LiveFrames {
    acquisition: Acquisition,
    assembler: Assembler<Box<dyn crate::decode::Decoder + Send>>,
}

impl std::fmt::Debug for LiveFrames {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LiveFrames")
            .field("interfaces", &self.acquisition.interfaces())
            .field("stats", self.assembler.stats())
            .finish()
    }
}

impl LiveFrames {
    /// Starts reading `ports` (interface `k` is bus `k`: name them as the bus map does) and
    /// assembling frames of `map`; `window` is the acquisition period (the icub8 time window).
    pub fn start<P: CanPort>(
        ports: Vec<P>,
        options: LiveOptions,
        map: &BusMap,
        window: Duration,
    ) -> LiveFrames {
        let acquisition = Acquisition::start(ports, options);
        let assembler = Assembler::for_map(map, acquisition.interfaces(), window.as_micros() as u64);
        LiveFrames {
            acquisition,
            assembler,
        }
    }

    /// Interface names, in bus order.
    pub fn interfaces(&self) -> &[String] {
        self.acquisition.interfaces()
    }

    /// The assembler's counts so far.
    pub fn stats(&self) -> &AssemblyStats {
        self.assembler.stats()
    }

    /// Waits at most `timeout` for the next event of the acquisition and hands it to `each`: a
    /// CAN frame first, then the skin frame it completed, if any. False when nothing came.
    pub fn poll(&mut self, timeout: Duration, each: &mut dyn FnMut(Live<'_>)) -> bool {
        let Some(event) = self.acquisition.recv(timeout) else {
            return false;
        };
        let name = |bus: u16| {
            self.acquisition
                .interfaces()
                .get(usize::from(bus))
                .map_or("?", String::as_str)
        };
        match &event {
            LiveEvent::Frame(f) => {
                each(Live::Can(f));
                self.assembler.push(f, &mut |a| each(Live::Frame(a)));
            }
            LiveEvent::Down { bus, error } => each(Live::Down {
                interface: name(*bus),
                error,
            }),
            LiveEvent::Reopened { bus } => each(Live::Reopened {
                interface: name(*bus),
            }),
        }
        true
    }

    /// Stops the readers and hands on the frame still being assembled.
    pub fn finish(self, each: &mut dyn FnMut(Live<'_>)) -> AssemblyStats {
        let LiveFrames {
            acquisition,
            mut assembler,
        } = self;
        acquisition.stop();
        assembler.finish(&mut |a| each(Live::Frame(a)));
        assembler.stats().clone()
    }
}

/// Microseconds since the Unix epoch, now.
pub fn now_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_micros() as u64)
}

struct Reader<P: CanPort> {
    port: P,
    bus: u16,
    tx: Sender<LiveEvent>,
    stop: Arc<AtomicBool>,
    options: LiveOptions,
    start: Instant,
}

impl<P: CanPort> Reader<P> {
    fn run(mut self) {
        let mut open = false;
        let mut failed = false;
        let mut next_sync = 0u64; // period number of the next sync to send
        while !self.stop.load(Ordering::Relaxed) {
            if !open {
                match self.port.open() {
                    Ok(()) => {
                        open = true;
                        if std::mem::take(&mut failed)
                            && self.tx.send(LiveEvent::Reopened { bus: self.bus }).is_err()
                        {
                            return;
                        }
                    }
                    Err(e) => {
                        if !self.down(&mut failed, format!("cannot open: {e}")) {
                            return;
                        }
                        self.pause(self.options.reopen_after);
                        continue;
                    }
                }
            }
            let mut wait = self.options.poll;
            if let Some(period) = self.options.sync_period.filter(|p| !p.is_zero()) {
                let elapsed = self.start.elapsed();
                let due = (elapsed.as_nanos() / period.as_nanos()) as u64;
                if due >= next_sync {
                    // A late reader skips the periods it missed: counters stay time-based, so
                    // every bus sends the same counter for the same period.
                    next_sync = due + 1;
                    let mut sync = encode_sync(due as u8, now_us(), self.bus);
                    sync.direction = Some(Direction::Transmitted);
                    if let Err(e) = self.port.send(&sync) {
                        self.port.close();
                        open = false;
                        if !self.down(&mut failed, format!("cannot send the sync: {e}")) {
                            return;
                        }
                        continue;
                    }
                    if self.tx.send(LiveEvent::Frame(sync)).is_err() {
                        return;
                    }
                }
                let next = period.saturating_mul(next_sync as u32);
                wait = wait.min(next.saturating_sub(self.start.elapsed()));
            }
            match self.port.recv(wait) {
                Ok(Some(mut f)) => {
                    f.bus = self.bus;
                    if self.tx.send(LiveEvent::Frame(f)).is_err() {
                        return;
                    }
                }
                Ok(None) => {}
                Err(e) => {
                    self.port.close();
                    open = false;
                    if !self.down(&mut failed, e.to_string()) {
                        return;
                    }
                    self.pause(self.options.reopen_after);
                }
            }
        }
    }

    /// Reports a failure, once per outage (until the port is open again); false when nobody
    /// listens any more.
    fn down(&self, failed: &mut bool, error: String) -> bool {
        if std::mem::replace(failed, true) {
            return true; // still down: said already
        }
        self.tx.send(LiveEvent::Down { bus: self.bus, error }).is_ok()
    }

    /// Sleeps up to `d`, waking early to stop.
    fn pause(&self, d: Duration) {
        let until = Instant::now() + d;
        while !self.stop.load(Ordering::Relaxed) {
            let left = until.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::sleep(left.min(self.options.poll));
        }
    }
}

/// Linux SocketCAN ports (feature `socketcan`).
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod socketcan {
    use super::{CanPort, Duration};
    use crate::candump::{CanFrame, Direction};
    use socketcan::{
        CanFrame as SocketFrame, CanSocket, EmbeddedFrame, ExtendedId, Id, Socket, SocketOptions, StandardId,
    };
    use std::io::{Error, ErrorKind};
    use std::time::UNIX_EPOCH;

    /// One SocketCAN interface, with kernel receive timestamps and error frames enabled (a bus-off
    /// error frame is reported as an error, so the interface is reopened).
    #[derive(Debug)]
    pub struct SocketCanPort {
        name: String,
        socket: Option<CanSocket>,
    }

    impl SocketCanPort {
        /// A port for interface `name` (opened by the acquisition).
        pub fn new(name: &str) -> SocketCanPort {
            SocketCanPort {
                name: name.to_string(),
                socket: None,
            }
        }

        /// Ports for `names`, each opened once to check it: a first open that fails is a typo
        /// or a missing driver, not an outage to wait out, and the error says which (with what
        /// to try). The ports are closed again; the acquisition opens them.
        pub fn open_all(names: &[String]) -> Result<Vec<SocketCanPort>, Error> {
            let mut ports = Vec::new();
            for name in names {
                let mut port = SocketCanPort::new(name);
                if let Err(e) = port.open() {
                    let hint = match e.raw_os_error() {
                        Some(97) => "this kernel has no SocketCAN: load the can and can_raw modules",
                        Some(19) => {
                            "no such interface: `ip link` lists them; a CAN adapter needs its driver loaded"
                        }
                        _ => "is the interface up? `ip link set NAME up type can bitrate 1000000`",
                    };
                    return Err(Error::new(e.kind(), format!("{name}: cannot open: {e} ({hint})")));
                }
                port.close();
                ports.push(port);
            }
            Ok(ports)
        }
    }

    fn not_open() -> Error {
        Error::new(ErrorKind::NotConnected, "interface not open")
    }

    impl CanPort for SocketCanPort {
        fn name(&self) -> &str {
            &self.name
        }

        fn open(&mut self) -> std::io::Result<()> {
            let socket = CanSocket::open(&self.name)?;
            socket.set_recv_timestamp(true)?;
            socket.set_error_filter_accept_all()?;
            self.socket = Some(socket);
            Ok(())
        }

        fn close(&mut self) {
            self.socket = None;
        }

        fn recv(&mut self, timeout: Duration) -> std::io::Result<Option<CanFrame>> {
            let socket = self.socket.as_ref().ok_or_else(not_open)?;
            socket.set_read_timeout(timeout.max(Duration::from_micros(1)))?;
            let (frame, stamp) = match socket.read_frame_with_timestamp() {
                Ok(x) => x,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => return Ok(None),
                Err(e) => return Err(e),
            };
            let time_us = stamp
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_micros() as u64);
            let mut f = CanFrame {
                time_us,
                bus: 0,
                id: 0,
                extended: false,
                remote: false,
                len: 0,
                bytes: [0; 8],
                direction: Some(Direction::Received),
            };
            match frame {
                SocketFrame::Error(e) => {
                    let what = format!("error class {:08X}", e.error_bits());
                    // Bus-off (class 0x40) or controller problems: reopen; others are noise.
                    if e.error_bits() & 0x40 != 0 {
                        return Err(Error::other(format!("bus-off ({what})")));
                    }
                    return Ok(None);
                }
                SocketFrame::Remote(r) => {
                    f.remote = true;
                    (f.id, f.extended) = id_of(r.id());
                    f.len = r.dlc().min(8) as u8;
                }
                SocketFrame::Data(d) => {
                    (f.id, f.extended) = id_of(d.id());
                    let data = d.data();
                    f.len = data.len().min(8) as u8;
                    f.bytes[..usize::from(f.len)].copy_from_slice(&data[..usize::from(f.len)]);
                }
            }
            Ok(Some(f))
        }

        fn send(&mut self, frame: &CanFrame) -> std::io::Result<()> {
            let socket = self.socket.as_ref().ok_or_else(not_open)?;
            let id: Id = if frame.extended {
                ExtendedId::new(frame.id).map(Id::Extended)
            } else {
                u16::try_from(frame.id)
                    .ok()
                    .and_then(StandardId::new)
                    .map(Id::Standard)
            }
            .ok_or_else(|| Error::new(ErrorKind::InvalidInput, format!("bad CAN id {:X}", frame.id)))?;
            let out = if frame.remote {
                SocketFrame::new_remote(id, usize::from(frame.len))
            } else {
                SocketFrame::new(id, frame.data())
            }
            .ok_or_else(|| Error::new(ErrorKind::InvalidInput, "bad CAN frame"))?;
            socket.write_frame(&out)
        }
    }

    fn id_of(id: Id) -> (u32, bool) {
        match id {
            Id::Standard(s) => (u32::from(s.as_raw()), false),
            Id::Extended(e) => (e.as_raw(), true),
        }
    }
}

//! Taring: the baseline learned again on demand, as an operator re-zeroes a skin (iCub
//! skinManager's `calibrate`, tactile_toolbox's bias reset). The next
//! [`SessionOptions::baseline_frames`](super::SessionOptions) frames learn it as the first ones
//! did; the skin reads no pressure until they are in. A tare is refused while a touch is on
//! the skin, whose pressure would be learned as the skin at rest, unless forced: a forced tare
//! first releases the touches open.
//!
//! The request is taken at once (the answer says whether it will happen) and carried out at
//! the start of the next frame, so another thread (a ROS service, a UI) may ask through a
//! [`TareHandle`] while the frames go on: the frame path only reads one atomic flag.

use super::{Event, Session, SessionError, Sink, send};
use skin_core::{BaselineLearner, BaselineOptions};
use std::sync::Arc;
use std::sync::atomic::{AtomicU8, AtomicUsize, Ordering};

/// A tare that will happen: the frames that learn the baseline again.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TareStarted {
    /// Frames that learn it, from the next one.
    pub frames: usize,
    /// The touches open now are released first (a forced tare while touching).
    pub releases: usize,
}

impl std::fmt::Display for TareStarted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the baseline is learned again over the next {} frames (the skin reads no pressure until then)",
            self.frames
        )?;
        if self.releases > 0 {
            write!(f, "; {} touch(es) on the skin released first", self.releases)?;
        }
        Ok(())
    }
}

/// Why a tare was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TareRefused {
    /// Touches are on the skin: their pressure would be learned as the skin at rest.
    #[error(
        "{touches} touch(es) on the skin now: their pressure would be learned as the skin at rest; tare when nothing touches it, or force the tare"
    )]
    Touching {
        /// Touches open.
        touches: usize,
    },
    /// The session has ended (a sink said stop).
    #[error("the session has stopped: it takes no more frames")]
    Stopped,
}

/// No request / a tare / a forced tare, in [`Shared::request`].
const NONE: u8 = 0;
const TARE: u8 = 1;
const FORCED: u8 = 2;
/// [`Shared::request`] once the session has stopped: requests are refused.
const STOPPED: u8 = 3;

#[derive(Debug, Default)]
struct Shared {
    request: AtomicU8,
    /// Touches open after the last frame.
    touches: AtomicUsize,
    frames: usize,
}

/// Asks a session for a tare from any thread ([`Session::tare_handle`]); cheap to clone.
#[derive(Debug, Clone)]
pub struct TareHandle(Arc<Shared>);

impl TareHandle {
    /// Asks for a tare at the next frame; refused while a touch is on the skin (as of the last
    /// frame) unless `force`.
    pub fn tare(&self, force: bool) -> Result<TareStarted, TareRefused> {
        let s = &self.0;
        if s.request.load(Ordering::Acquire) == STOPPED {
            return Err(TareRefused::Stopped);
        }
        let touches = s.touches.load(Ordering::Acquire);
        if touches > 0 && !force {
            return Err(TareRefused::Touching { touches });
        }
        let want = if force { FORCED } else { TARE };
        // A forced request is not weakened by a plain one made after it.
        let _ = s
            .request
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |r| match r {
                STOPPED => None,
                r => Some(r.max(want)),
            })
            .map_err(|_| TareRefused::Stopped)?;
        Ok(TareStarted {
            frames: s.frames,
            releases: if force { touches } else { 0 },
        })
    }
}

/// The session's side of its [`TareHandle`]s.
#[derive(Debug)]
pub(super) struct Tares(Arc<Shared>);

impl Tares {
    pub(super) fn new(frames: usize) -> Tares {
        Tares(Arc::new(Shared {
            frames,
            ..Shared::default()
        }))
    }

    /// The request made since the last frame: none, or whether it is forced.
    fn take(&self) -> Option<bool> {
        match self
            .0
            .request
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |r| {
                (r == TARE || r == FORCED).then_some(NONE)
            }) {
            Ok(r) => Some(r == FORCED),
            Err(_) => None,
        }
    }

    /// After a frame: the touches open now.
    pub(super) fn set_touches(&self, touches: usize) {
        self.0.touches.store(touches, Ordering::Release);
    }

    /// The session stopped: requests from now on are refused.
    pub(super) fn stop(&self) {
        self.0.request.store(STOPPED, Ordering::Release);
    }
}

impl Session {
    /// Tares the skin: the baseline is learned again from the next frame
    /// ([`SessionOptions::baseline_frames`](super::SessionOptions) of them), as an operator
    /// re-zeroes a skin whose rest level moved. Refused while a touch is on the skin unless
    /// `force` (the touches open are then released first). An [`Event::Tare`] says when it
    /// starts.
    ///
    /// ```
    /// # use skin_runtime::session::{Session, TareRefused};
    /// # fn tare(session: &mut Session) {
    /// match session.tare(false) {
    ///     Ok(started) => println!("{started}"),
    ///     Err(TareRefused::Touching { touches }) => println!("{touches} touch(es): not now"),
    ///     Err(e) => println!("{e}"),
    /// }
    /// # }
    /// ```
    pub fn tare(&mut self, force: bool) -> Result<TareStarted, TareRefused> {
        self.tare_handle().tare(force)
    }

    /// A handle that asks this session for a tare from another thread (a ROS 2 service, a
    /// UI): the request is answered at once and carried out at the next frame.
    pub fn tare_handle(&self) -> TareHandle {
        TareHandle(self.tares.0.clone())
    }

    /// At the start of a frame: a tare asked for since the last one begins (the touches open
    /// released, if forced; the baseline learned again from this frame on).
    pub(super) fn start_tare<S: Sink + ?Sized>(
        &mut self,
        time: f64,
        sink: &mut S,
    ) -> Result<(), SessionError> {
        let Some(forced) = self.tares.take() else {
            return Ok(());
        };
        let open = (0..self.setup.links.len())
            .filter(|&l| self.pipeline.touching(l))
            .count();
        if open > 0 {
            self.touch_events.clear();
            self.pipeline.finish(time, &mut self.touch_events)?;
            self.emit(sink)?;
        }
        let sizes: Vec<usize> = self.setup.links.iter().map(|l| l.taxels.len()).collect();
        let options = BaselineOptions {
            polarity: self.setup.options.polarity,
            ..BaselineOptions::default()
        };
        let b = &mut self.base;
        b.learner = BaselineLearner::new(&sizes, self.setup.options.baseline_frames, options)?;
        b.baselines.clear();
        b.health.clear();
        b.correcting.iter_mut().for_each(|c| *c = Default::default());
        self.pressures.iter_mut().for_each(|p| p.fill(0.0));
        self.tares.set_touches(0);
        let event = Event::Tare {
            time,
            frames: self.setup.options.baseline_frames,
            forced,
            released: open,
        };
        send(&mut self.stopped, sink, |s| s.event(&event))
    }
}

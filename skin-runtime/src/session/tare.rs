//! Taring: the baseline learned again on demand, as an operator re-zeroes a skin (iCub
//! skinManager's `calibrate`, tactile_toolbox's bias reset). The next
//! [`SessionOptions::baseline_frames`](super::SessionOptions) frames learn it as the first ones
//! did; the skin reads no pressure until they are in. A tare is refused while a touch is on
//! the skin, whose pressure would be learned as the skin at rest, unless forced: a forced tare
//! first releases the touches open. Even forced, it is refused while the gate stops the arm for
//! a touch (releasing it would let the arm go on while the touch is still there), and while the
//! baseline is being learned (a tare would only start that again). A plain tare answered yes
//! whose frame finds a touch begun meanwhile waits for a frame without one.
//!
//! The request is taken at once (the answer says whether it will happen) and carried out at
//! the start of the next frame, so another thread (a ROS service, a UI) may ask through a
//! [`TareHandle`] while the frames go on: the frame path only reads one atomic flag.

use super::{Event, Session, SessionError, Sink, send};
use skin_core::{BaselineLearner, BaselineOptions};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, AtomicUsize, Ordering};

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
    /// The gate stops the arm for a touch now: a forced tare would release the touch, and the
    /// gate with it, while the touch is still there (and learn it as the skin at rest).
    #[error(
        "the gate stops the arm for a touch on the skin now: a tare would release it while it still presses; tare once the touch is gone"
    )]
    GateStops,
    /// The baseline is being learned (at the start, or after a tare): a tare now would only
    /// start it again.
    #[error("the baseline is being learned now (the skin reads no pressure until it is): tare once it is")]
    Learning,
    /// The session has ended (a sink said stop, an error, or the end of its input).
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
    /// After the last frame: the gate stops the arm / the baseline is being learned.
    gate_stops: AtomicBool,
    learning: AtomicBool,
    frames: usize,
}

/// Asks a session for a tare from any thread ([`Session::tare_handle`]); cheap to clone.
#[derive(Debug, Clone)]
pub struct TareHandle(Arc<Shared>);

impl TareHandle {
    /// Asks for a tare at the next frame; refused (as of the last frame) while a touch is on
    /// the skin unless `force`, and even forced while the gate stops the arm for a touch or
    /// the baseline is being learned.
    pub fn tare(&self, force: bool) -> Result<TareStarted, TareRefused> {
        let s = &self.0;
        if s.request.load(Ordering::Acquire) == STOPPED {
            return Err(TareRefused::Stopped);
        }
        if s.learning.load(Ordering::Acquire) {
            return Err(TareRefused::Learning);
        }
        let touches = s.touches.load(Ordering::Acquire);
        if touches > 0 && !force {
            return Err(TareRefused::Touching { touches });
        }
        if touches > 0 && s.gate_stops.load(Ordering::Acquire) {
            return Err(TareRefused::GateStops);
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
            // A session starts by learning its baseline.
            learning: AtomicBool::new(true),
            ..Shared::default()
        }))
    }

    /// After a frame: whether the gate stops the arm, and whether the baseline is being learned.
    pub(super) fn set_state(&self, gate_stops: bool, learning: bool) {
        self.0.gate_stops.store(gate_stops, Ordering::Release);
        self.0.learning.store(learning, Ordering::Release);
    }

    /// A plain request found touches at its frame (one began after it was answered): it waits
    /// for a frame without one.
    fn defer(&self) {
        let _ = self
            .0
            .request
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |r| {
                (r == NONE).then_some(TARE)
            });
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
        let open = self.pipeline.open_touches();
        let stops = self.gate == Some(skin_control::hri::GateAction::Stop);
        if open > 0 && (!forced || stops) {
            // A touch began after the request was answered: a plain tare waits for a frame
            // without one; a forced one is not taken while the gate stops the arm for it.
            if !forced {
                self.tares.defer();
            }
            return Ok(());
        }
        // A correction going on ends (its event, its counts) before the offsets are learned anew.
        self.end_corrections(time, 0, sink)?;
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
        for c in &mut b.correcting {
            c.since = None;
            c.quiet = 0;
        }
        self.pressures.iter_mut().for_each(|p| p.fill(0.0));
        self.tares.set_touches(0);
        self.tares.set_state(false, true);
        let event = Event::Tare {
            time,
            frames: self.setup.options.baseline_frames,
            forced,
            released: open,
        };
        send(&mut self.stopped, sink, |s| s.event(&event))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tare_is_refused_while_learning_and_forced_while_the_gate_stops_for_a_touch() {
        let tares = Tares::new(20);
        let handle = TareHandle(tares.0.clone());
        assert_eq!(handle.tare(true), Err(TareRefused::Learning));
        tares.set_state(true, false);
        tares.set_touches(1);
        assert_eq!(handle.tare(false), Err(TareRefused::Touching { touches: 1 }));
        assert_eq!(handle.tare(true), Err(TareRefused::GateStops));
        tares.set_state(false, false);
        assert_eq!(
            handle.tare(true),
            Ok(TareStarted {
                frames: 20,
                releases: 1
            })
        );
        // A plain request after a forced one does not weaken it.
        tares.set_touches(0);
        assert!(handle.tare(false).is_ok());
        assert_eq!(tares.take(), Some(true));
        assert_eq!(tares.take(), None);
        tares.stop();
        assert_eq!(handle.tare(false), Err(TareRefused::Stopped));
    }
}

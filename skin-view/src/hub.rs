//! Where the session (or a replay) leaves what the browsers are sent, and where each browser's
//! thread picks it up. Only the latest frame and the latest image of each view are kept, and
//! the last [`MAX_EVENTS`] events: a browser that cannot keep up gets the newest frame when it is
//! ready again and skips the rest (counted), so the session never waits for a browser and the
//! memory the viewer holds does not grow with a slow one.
//!
//! Frames and images are shared, not copied, under the lock: a browser's thread takes a
//! reference to the latest buffer and copies it (to stamp its own skipped count) after letting
//! go. The sink encodes each frame into the buffer of the frame before last, which no browser
//! holds by then in the steady state: no allocation per frame.

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};

/// Events kept for browsers that are behind or connect later.
pub const MAX_EVENTS: usize = 4096;

/// The play speeds a replay takes, times real time (the page's control and `skin view
/// --speed`).
pub const SPEEDS: std::ops::RangeInclusive<f64> = 0.01..=100.0;

/// A browser's request to a replay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Control {
    /// Stop advancing.
    Pause,
    /// Advance again.
    Play,
    /// Show the frame at this time (s from the session's start), then go on as before.
    Seek(f64),
    /// Play at this many times real time.
    Speed(f64),
}

/// The latest of something, numbered.
#[derive(Debug, Default)]
pub(crate) struct Latest {
    /// 0: none yet.
    pub seq: u64,
    pub bytes: Arc<Vec<u8>>,
}

impl Latest {
    /// Puts `bytes` in as the latest, giving back the buffer it replaces.
    fn put(&mut self, bytes: &mut Arc<Vec<u8>>) {
        std::mem::swap(&mut self.bytes, bytes);
        self.seq += 1;
    }
}

/// What the browsers are sent, behind one lock.
#[derive(Debug, Default)]
pub(crate) struct Shared {
    pub frame: Latest,
    /// Per view: the links', then the stitched arm's.
    pub images: Vec<Latest>,
    /// `(number, JSON line)`; numbers count from 1 without gaps.
    pub events: VecDeque<(u64, Arc<str>)>,
    pub next_event: u64,
    pub scene: Arc<str>,
    /// Bumped with each new scene: browsers get it and start over.
    pub epoch: u64,
    /// A replay's state (JSON: paused, speed), numbered like [`Latest`].
    pub status: (u64, Arc<str>),
}

/// The hub: shared state, its wake-up, the counters and a replay's control queue.
#[derive(Debug)]
pub(crate) struct Hub {
    shared: Mutex<Shared>,
    changed: Condvar,
    pub closing: AtomicBool,
    pub clients: AtomicUsize,
    pub sent: AtomicU64,
    pub skipped: AtomicU64,
    pub dropped: AtomicU64,
    /// Browsers numbered as they connect, from 1.
    pub next_browser: AtomicU64,
    /// The browser whose control was passed on last (0: none yet).
    pub last_by: AtomicU64,
    control: Mutex<Option<SyncSender<Control>>>,
}

/// A buffer to encode the next frame or image into: `spare` itself when no browser still holds
/// it (the steady state), else a new one.
pub(crate) fn writable(spare: &mut Arc<Vec<u8>>) -> &mut Vec<u8> {
    if Arc::get_mut(spare).is_none() {
        *spare = Arc::new(Vec::with_capacity(spare.capacity()));
    }
    Arc::make_mut(spare)
}

impl Hub {
    pub fn new(scene: String, views: usize) -> Hub {
        Hub {
            shared: Mutex::new(Shared {
                images: (0..views).map(|_| Latest::default()).collect(),
                next_event: 1,
                scene: scene.into(),
                status: (0, Arc::from("")),
                ..Shared::default()
            }),
            changed: Condvar::new(),
            closing: AtomicBool::new(false),
            clients: AtomicUsize::new(0),
            sent: AtomicU64::new(0),
            skipped: AtomicU64::new(0),
            dropped: AtomicU64::new(0),
            next_browser: AtomicU64::new(0),
            last_by: AtomicU64::new(0),
            control: Mutex::new(None),
        }
    }

    /// The lock (a thread that panicked while holding it left plain bytes: still usable).
    pub fn lock(&self) -> MutexGuard<'_, Shared> {
        self.shared
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// Wakes every browser's thread.
    pub fn notify(&self) {
        self.changed.notify_all();
    }

    /// Waits for a change or `timeout`.
    pub fn wait<'a>(
        &self,
        guard: MutexGuard<'a, Shared>,
        timeout: std::time::Duration,
    ) -> MutexGuard<'a, Shared> {
        match self.changed.wait_timeout(guard, timeout) {
            Ok((g, _)) => g,
            Err(poisoned) => poisoned.into_inner().0,
        }
    }

    /// Swaps `bytes` in as the latest frame; the frame it replaces comes back in `bytes`, to be
    /// written over next time ([`writable`]).
    pub fn put_frame(&self, bytes: &mut Arc<Vec<u8>>) {
        self.lock().frame.put(bytes);
        self.notify();
    }

    /// Swaps `bytes` in as the latest image of `view` (ignored for a view the scene lacks).
    pub fn put_image(&self, view: usize, bytes: &mut Arc<Vec<u8>>) {
        {
            let mut s = self.lock();
            let Some(slot) = s.images.get_mut(view) else {
                return;
            };
            slot.put(bytes);
        }
        self.notify();
    }

    /// Adds an event (a JSON line); the oldest goes once [`MAX_EVENTS`] are kept.
    pub fn put_event(&self, line: Arc<str>) {
        {
            let mut s = self.lock();
            let n = s.next_event;
            s.next_event += 1;
            if s.events.len() == MAX_EVENTS {
                s.events.pop_front();
            }
            s.events.push_back((n, line));
        }
        self.notify();
    }

    /// Replaces the scene (with `views` image views: its links and the stitched arm), and tells
    /// browsers to start over.
    pub fn put_scene(&self, scene: String, views: usize) {
        {
            let mut s = self.lock();
            s.scene = scene.into();
            s.images.resize_with(views, Latest::default);
            s.epoch += 1;
        }
        self.notify();
    }

    /// Sets a replay's state (JSON), sent to every browser.
    pub fn put_status(&self, json: String) {
        {
            let mut s = self.lock();
            s.status = (s.status.0 + 1, json.into());
        }
        self.notify();
    }

    /// Takes browsers' replay controls from now on.
    pub fn controls(&self) -> Receiver<Control> {
        let (tx, rx) = std::sync::mpsc::sync_channel(64);
        *self
            .control
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner) = Some(tx);
        rx
    }

    /// Whether browsers may control what is shown (a replay).
    pub fn controllable(&self) -> bool {
        self.control
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .is_some()
    }

    /// Passes browser `by`'s control on; a full queue drops it (a browser sending faster than a
    /// replay reads is not waited for).
    pub fn send_control(&self, c: Control, by: u64) {
        if let Some(tx) = &*self
            .control
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
        {
            // Before the replay can take it and tell its new state.
            self.last_by.store(by, Ordering::Relaxed);
            let _ = tx.try_send(c);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_buffer_is_reused_once_no_browser_holds_it() {
        let hub = Hub::new(String::new(), 1);
        let mut spare = Arc::new(Vec::new());
        writable(&mut spare).extend_from_slice(&[1u8; 1000]);
        hub.put_frame(&mut spare);
        writable(&mut spare).extend_from_slice(&[2u8; 1000]);
        hub.put_frame(&mut spare);
        // The first frame's buffer came back and no browser holds it: written over in place.
        let before = Arc::as_ptr(&spare);
        writable(&mut spare).clear();
        assert_eq!(Arc::as_ptr(&spare), before);
        // A browser still holding the latest frame's buffer gets to keep it untouched.
        let held = hub.lock().frame.bytes.clone();
        let mut other = held.clone();
        writable(&mut other).clear();
        assert_eq!(held.len(), 1000);
        assert!(held.iter().all(|&b| b == 2));
    }
}

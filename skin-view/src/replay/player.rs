//! Playing a replay: frames gathered from the file by stamp and shown at their pace, the
//! browsers' controls (pause, play, seek, speed) followed between frames.

use super::Replay;
use super::err;
use super::read::each_message;
use crate::ViewError;
use crate::Viewer;
use crate::hub::Control;
use crate::sink::ViewSink;
use mcap::sans_io::indexed_reader::IndexedReaderOptions;
use skin_ros::decode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

impl Replay {
    /// Plays the file to `viewer` (whose scene is [`Replay::scene`]) from its first frame at
    /// real time, following the browsers' controls, until `stop` is set. At the end it pauses on
    /// the last frame (a seek plays again).
    ///
    /// One replay plays to every browser, so their controls are shared: a pause, seek or speed
    /// from any browser is what all of them see, and each is told which browser changed it. A
    /// replay per browser would read and decode the file once per browser watching, where the
    /// viewer keeps one latest frame for all of them.
    pub fn play(
        &mut self,
        viewer: &Viewer,
        controls: &Receiver<Control>,
        stop: &AtomicBool,
    ) -> Result<(), ViewError> {
        let mut sink = viewer.sink();
        let mut state = PlayState {
            speed: self.speed,
            paused: false,
            frames: 0,
            by_browser: false,
        };
        let hub = &viewer.server.hub;
        // Every browser is told the state, and which browser changed it last: the controls are
        // shared by all who watch.
        let tell = |st: &PlayState| {
            let by = if st.by_browser {
                hub.last_by.load(Ordering::Relaxed).to_string()
            } else {
                "null".to_owned()
            };
            hub.put_status(format!(
                r#"{{"paused":{},"speed":{},"by":{by}}}"#,
                st.paused, st.speed
            ));
        };
        tell(&state);
        let mut from = self.first_ns;
        while !stop.load(Ordering::Relaxed) {
            let mut player = Player {
                replay: self,
                sink: &mut sink,
                controls,
                stop,
                state: &mut state,
                tell: &tell,
                seek: None,
            };
            match player.run(from)? {
                Some(t) => from = t,
                // The end: paused on the last frame until a seek, or play (from the start).
                None => {
                    state.paused = true;
                    state.by_browser = false;
                    tell(&state);
                    match wait_for_seek(controls, stop, &mut state, &tell) {
                        Some(t) => from = self.seek_ns(t),
                        None => return Ok(()),
                    }
                }
            }
            from = from.max(self.first_ns).min(self.last_ns);
        }
        Ok(())
    }

    fn seek_ns(&self, t: f64) -> u64 {
        self.origin_ns.saturating_add((t.max(0.0) * 1e9) as u64)
    }
}

/// Whether a replay advances, how fast, and the frames it has shown.
#[derive(Debug, Clone, Copy)]
struct PlayState {
    speed: f64,
    paused: bool,
    /// Frames shown since the replay began (the frames' cycle numbers).
    frames: u64,
    /// The last change came from a browser's control (not from the replay reaching its end).
    by_browser: bool,
}

/// Waits at the end of a replay for a seek, or play (from the start: 0 s); speed changes are
/// kept. `None` once stopped.
fn wait_for_seek(
    controls: &Receiver<Control>,
    stop: &AtomicBool,
    state: &mut PlayState,
    tell: &dyn Fn(&PlayState),
) -> Option<f64> {
    while !stop.load(Ordering::Relaxed) {
        let got = controls.recv_timeout(Duration::from_millis(50));
        if got.is_ok() {
            state.by_browser = true;
        }
        match got {
            Ok(Control::Seek(t)) => return Some(t),
            Ok(Control::Speed(s)) => state.speed = s,
            Ok(Control::Pause) => state.paused = true,
            Ok(Control::Play) => {
                state.paused = false;
                tell(state);
                return Some(0.0);
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => continue,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return None,
        }
        tell(state);
    }
    None
}

/// One pass of playback, from a time until the end or a seek.
struct Player<'a> {
    replay: &'a mut Replay,
    sink: &'a mut ViewSink,
    controls: &'a Receiver<Control>,
    stop: &'a AtomicBool,
    state: &'a mut PlayState,
    /// Tells the browsers the state once it changed.
    tell: &'a dyn Fn(&PlayState),
    seek: Option<u64>,
}

/// A frame being gathered: every link's cloud of one stamp, and the contacts of that stamp.
struct Gathered {
    stamp: Option<u64>,
    pressures: Vec<Vec<f32>>,
    contacts: Vec<(usize, Vec<usize>, f32, f32, f32)>,
    /// Frames shown in this pass.
    frames: u64,
}

impl Player<'_> {
    /// Plays from `from_ns`; returns the time of a seek (ns), or `None` at the end of the file.
    fn run(&mut self, from_ns: u64) -> Result<Option<u64>, ViewError> {
        let r = &mut *self.replay;
        let mut topics: Vec<String> = r
            .clouds
            .keys()
            .filter_map(|id| r.summary.channels.get(id).map(|c| c.topic.clone()))
            .collect();
        if let Some(id) = r.contacts
            && let Some(c) = r.summary.channels.get(&id)
        {
            topics.push(c.topic.clone());
        }
        let mut g = Gathered {
            stamp: None,
            pressures: r.scene.links.iter().map(|l| vec![0.0; l.ids.len()]).collect(),
            contacts: Vec::new(),
            frames: 0,
        };
        // Wall time and stamp the pace counts from (set again after a pause or a speed change).
        let mut anchor: Option<(Instant, u64)> = None;
        let options = IndexedReaderOptions::new()
            .include_topics(topics)
            .starting_at(from_ns);
        let path = r.path.clone();
        let mut file = r.file.try_clone().map_err(|e| err(&path, e.to_string()))?;
        let summary = std::mem::take(&mut r.summary);
        let span = r.origin_ns..=r.last_ns;
        let result = each_message(&mut file, &summary, options, &path, &mut |h, data| {
            // A stamp outside the file's own span (a damaged chunk's) would stall the pacing
            // for as long as it claims: left out.
            if !span.contains(&h.log_time) {
                return Ok(true);
            }
            if g.stamp.is_some_and(|s| s != h.log_time) && !self.show(&mut g, &mut anchor)? {
                return Ok(false);
            }
            g.stamp = Some(h.log_time);
            self.gather(&mut g, h.channel_id, data);
            Ok(true)
        });
        self.replay.summary = summary;
        result?;
        if self.seek.is_none() && g.stamp.is_some() {
            self.show(&mut g, &mut anchor)?;
        }
        Ok(self.seek)
    }

    fn gather(&mut self, g: &mut Gathered, channel: u16, data: &[u8]) {
        let r = &*self.replay;
        if let Some(&(link, layout)) = r.clouds.get(&channel) {
            if let Some(p) = g.pressures.get_mut(link) {
                // A cloud laid out otherwise than the link's first is not shown (its pressures
                // stay at the last frame's).
                let _ = decode::cloud_pressures(data, &layout, p);
            }
        } else if Some(channel) == r.contacts
            && let Ok((_, list)) = decode::contacts(data, r.contacts_force)
        {
            for c in list {
                let Some(&link) = r.links_by_frame.get(&c.link) else {
                    continue;
                };
                let taxels = c
                    .taxel_ids
                    .iter()
                    .filter_map(|id| r.index[link].get(id).copied())
                    .collect();
                let force = c.force.map_or(f32::NAN, |f| f as f32);
                g.contacts
                    .push((link, taxels, c.mean_pressure, c.peak_pressure, force));
            }
        }
    }

    /// Waits until the gathered frame is due, then shows it. False when playback must stop
    /// here (a seek, or the viewer stopping).
    fn show(&mut self, g: &mut Gathered, anchor: &mut Option<(Instant, u64)>) -> Result<bool, ViewError> {
        let Some(stamp) = g.stamp else { return Ok(true) };
        loop {
            if self.stop.load(Ordering::Relaxed) {
                return Ok(false);
            }
            while let Ok(c) = self.controls.try_recv() {
                self.state.by_browser = true;
                match c {
                    Control::Pause => self.state.paused = true,
                    Control::Play => {
                        self.state.paused = false;
                        *anchor = None;
                    }
                    Control::Speed(s) => {
                        self.state.speed = s;
                        *anchor = None;
                    }
                    Control::Seek(t) => {
                        self.seek = Some(self.replay.seek_ns(t));
                        return Ok(false);
                    }
                }
                (self.tell)(self.state);
            }
            // Paused, a seek still shows the frame it lands on.
            if self.state.paused && g.frames > 0 {
                std::thread::sleep(Duration::from_millis(20));
                continue;
            }
            if self.state.paused {
                break;
            }
            let (wall, from) = *anchor.get_or_insert((Instant::now(), stamp));
            let after = stamp.saturating_sub(from) as f64 / 1e9 / self.state.speed;
            let due = Duration::try_from_secs_f64(after)
                .ok()
                .and_then(|d| wall.checked_add(d))
                .unwrap_or(wall);
            let now = Instant::now();
            if due <= now {
                break;
            }
            std::thread::sleep((due - now).min(Duration::from_millis(20)));
        }
        g.frames += 1;
        self.state.frames += 1;
        let time = stamp.saturating_sub(self.replay.origin_ns) as f64 / 1e9;
        let contacts = g
            .contacts
            .iter()
            .map(|(l, t, m, p, f)| (*l, t.as_slice(), *m, *p, *f));
        self.sink
            .publish(time, self.state.frames, &g.pressures, contacts, &[]);
        g.contacts.clear();
        Ok(true)
    }
}

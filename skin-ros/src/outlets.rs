//! One run's ROS 2 outlets together: an MCAP file (feature `mcap`) and a live Zenoh publisher
//! (feature `zenoh`), opened from one [`OutletOptions`], fed by one [`crate::RosSink`], and
//! closed in the order a run needs: the file first (it may move into place with an output
//! folder), the network last (its wait may take seconds, and no file waits on it).
//!
//! Nothing here prints: what a run should tell its user while it waits (for a subscriber at the
//! start, for the network at the end) goes to a `note` callback, one line at a time, worded for
//! the `skin` command's flags (`--zenoh-wait`, `--zenoh-drain`).

use crate::topics::Topics;
use crate::{Outlet, RosError};
use skin_core::output::{Inputs, Staged};
use std::path::PathBuf;

/// How long a run waits at the end, by default, for its events to reach the network, seconds.
pub const DEFAULT_DRAIN_S: f64 = 30.0;

/// Which outlets a run opens, and how it waits for the network.
#[derive(Debug, Clone, PartialEq)]
pub struct OutletOptions {
    /// Record the messages in this MCAP file (needs the `mcap` feature).
    pub mcap: Option<PathBuf>,
    /// Zenoh endpoints to connect to, `tcp/HOST:PORT` (needs the `zenoh` feature).
    pub connect: Vec<String>,
    /// Zenoh endpoints to listen on, `tcp/HOST:PORT` (needs the `zenoh` feature).
    pub listen: Vec<String>,
    /// ROS domain id (`ROS_DOMAIN_ID`) of the Zenoh topics, 0 to 232.
    pub domain: u32,
    /// Before the first message, wait up to this many seconds for a subscriber to any topic.
    /// `None`: up to 2 s for the `connect` endpoints and 1 s for their subscribers, and no wait
    /// when only listening.
    pub wait_s: Option<f64>,
    /// At the end, wait up to this many seconds for the events to reach the network.
    pub drain_s: f64,
}

impl Default for OutletOptions {
    fn default() -> Self {
        OutletOptions {
            mcap: None,
            connect: Vec::new(),
            listen: Vec::new(),
            domain: 0,
            wait_s: None,
            drain_s: DEFAULT_DRAIN_S,
        }
    }
}

impl OutletOptions {
    /// Whether messages are published live (any Zenoh endpoint).
    pub fn live(&self) -> bool {
        !self.connect.is_empty() || !self.listen.is_empty()
    }

    /// Whether any outlet is asked for.
    pub fn any(&self) -> bool {
        self.mcap.is_some() || self.live()
    }

    /// Checks before any work: the endpoints, and that the MCAP file may be written (not one of
    /// the `inputs`, not a folder, not a user's other file, not being written by another run).
    pub fn check(&self, inputs: &Inputs) -> Result<(), RosError> {
        #[cfg(feature = "zenoh")]
        crate::zenoh_live::check_endpoints(&self.connect, &self.listen)?;
        if let Some(p) = &self.mcap {
            inputs.check(p)?;
            if p.is_dir() {
                return Err(skin_core::output::OutputError::IsFolder { path: p.to_owned() }.into());
            }
            #[cfg(feature = "mcap")]
            skin_core::output::check_replaceable(
                p,
                "an MCAP file that skin wrote",
                crate::mcap_file::written_by_skin,
            )?;
            skin_core::output::check_free(p)?;
        }
        Ok(())
    }
}

/// The outlets of one run: every message goes to each of them.
#[derive(Debug, Default)]
pub struct Outlets {
    #[cfg(feature = "mcap")]
    mcap: Option<crate::McapOutlet>,
    #[cfg(feature = "zenoh")]
    zenoh: Option<crate::ZenohOutlet>,
    /// How long [`Outlets::drain`] waits for the live publisher, seconds.
    #[cfg(feature = "zenoh")]
    drain_s: f64,
}

impl Outlets {
    /// Opens the outlets `options` ask for, with a channel for each of `topics`; an outlet this
    /// build lacks the feature for is an error. When live, waits for the network as
    /// [`OutletOptions::wait_s`] says, telling `note` what it waits for and what it found.
    pub fn open(
        options: &OutletOptions,
        topics: &Topics,
        inputs: &Inputs,
        note: &mut dyn FnMut(String),
    ) -> Result<Outlets, RosError> {
        // A build with neither outlet neither sets nor changes a field.
        #[cfg_attr(not(feature = "zenoh"), allow(clippy::needless_update))]
        #[cfg_attr(not(any(feature = "mcap", feature = "zenoh")), allow(unused_mut))]
        let mut outlets = Outlets {
            #[cfg(feature = "zenoh")]
            drain_s: options.drain_s,
            ..Outlets::default()
        };
        if let Some(p) = &options.mcap {
            #[cfg(feature = "mcap")]
            {
                outlets.mcap = Some(crate::McapOutlet::create(p, topics, inputs)?);
            }
            #[cfg(not(feature = "mcap"))]
            return Err(RosError::Mcap {
                path: p.clone(),
                why: "this build writes no MCAP files (feature mcap)".into(),
            });
        }
        if options.live() {
            #[cfg(feature = "zenoh")]
            {
                outlets.zenoh = Some(live::open(options, topics, note)?);
            }
            #[cfg(not(feature = "zenoh"))]
            return Err(RosError::Zenoh(
                "this build does not publish live (feature zenoh)".into(),
            ));
        }
        let _ = (topics, inputs, note);
        Ok(outlets)
    }

    /// Serves `services` on the live outlet (none without one): see
    /// [`crate::ZenohOutlet::serve`]. `topics` are those the outlets were opened with.
    #[cfg(feature = "zenoh")]
    pub fn serve(&mut self, topics: &Topics, services: crate::Services) -> Result<(), RosError> {
        match &mut self.zenoh {
            Some(z) => z.serve(topics, services),
            None => Ok(()),
        }
    }

    /// Hands the joint states on `topic` to `feed` (the live outlet's subscription; an error
    /// without one): see [`crate::ZenohOutlet::listen_joint_states`].
    #[cfg(feature = "zenoh")]
    pub fn listen_joint_states(
        &mut self,
        topic: &str,
        feed: skin_runtime::session::PostureFeed,
    ) -> Result<(), RosError> {
        match &mut self.zenoh {
            Some(z) => z.listen_joint_states(topic, feed),
            None => Err(RosError::Zenoh(format!(
                "joint states on {topic} need a live node (--zenoh or --zenoh-listen)"
            ))),
        }
    }

    /// Finishes the MCAP file without putting it in place (it moves with an output folder, see
    /// [`skin_core::output::OutputDir::commit_with`]), with how many messages it holds; `None`
    /// without one. The live outlet goes on.
    pub fn stage_mcap(&mut self) -> Result<Option<(Staged, u64)>, RosError> {
        #[cfg(feature = "mcap")]
        if let Some(m) = self.mcap.take() {
            return m.stage().map(Some);
        }
        Ok(None)
    }

    /// Finishes the MCAP file and puts it in place; how many messages it holds (`None` without
    /// one). The live outlet goes on.
    pub fn finish_mcap(&mut self) -> Result<Option<u64>, RosError> {
        #[cfg(feature = "mcap")]
        if let Some(m) = self.mcap.take() {
            return m.finish().map(Some);
        }
        Ok(None)
    }

    /// Waits, bounded by [`OutletOptions::drain_s`], until the events are handed to the network
    /// and acknowledged, closes the Zenoh session (if any), and tells `note` what became of the
    /// messages, a line per topic and one for the whole.
    pub fn drain(&mut self, note: &mut dyn FnMut(String)) {
        #[cfg(feature = "zenoh")]
        if let Some(z) = self.zenoh.take() {
            live::drain(z, self.drain_s, note);
        }
        let _ = note;
    }
}

impl Outlet for Outlets {
    fn publish(&mut self, topic: usize, stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        #[cfg(feature = "mcap")]
        if let Some(m) = &mut self.mcap {
            m.publish(topic, stamp_ns, cdr)?;
        }
        #[cfg(feature = "zenoh")]
        if let Some(z) = &mut self.zenoh {
            z.publish(topic, stamp_ns, cdr)?;
        }
        let _ = (topic, stamp_ns, cdr);
        Ok(())
    }
}

/// The live outlet's waits at the start and the end, and what it says of them.
#[cfg(feature = "zenoh")]
mod live {
    use super::OutletOptions;
    use crate::topics::Topics;
    use crate::{RosError, ZenohOptions, ZenohOutlet, ZenohReport};
    use std::time::{Duration, Instant};

    /// Opens the Zenoh outlet and waits for the network as `options` say.
    pub(super) fn open(
        options: &OutletOptions,
        topics: &Topics,
        note: &mut dyn FnMut(String),
    ) -> Result<ZenohOutlet, RosError> {
        let z = ZenohOptions {
            connect: options.connect.clone(),
            listen: options.listen.clone(),
            domain: options.domain,
            ..ZenohOptions::default()
        };
        let outlet = ZenohOutlet::open(topics, &z)?;
        if let Some(s) = options.wait_s {
            let n = topics.list.len();
            note(format!(
                "zenoh: waiting up to {s} s for a subscriber to any of the {n} topics (--zenoh-wait)"
            ));
            let wait = Duration::from_secs_f64(s);
            let start = Instant::now();
            let found = outlet.wait_for_peer(wait)
                && outlet.wait_for_subscribers(wait.saturating_sub(start.elapsed()));
            if found {
                // A peer declares its subscriptions together: give the rest a moment.
                std::thread::sleep(Duration::from_millis(300));
                note(unsubscribed(&outlet, topics));
            } else {
                note(format!(
                    "zenoh: no subscriber to any topic within {s} s; the frames go on"
                ));
            }
        } else if !options.connect.is_empty() {
            // A first look, so that a wrong address is said at once; Zenoh keeps retrying.
            if outlet.wait_for_peer(Duration::from_secs(2)) {
                // Give the peers' subscriptions a moment to reach us (not an error if none).
                outlet.wait_for_subscribers(Duration::from_secs(1));
            } else {
                note(format!(
                    "zenoh: nothing answers at {} yet; retrying in the background while frames go on",
                    options.connect.join(", ")
                ));
            }
        }
        Ok(outlet)
    }

    /// After a wait found a subscriber: the topics that have none, by name.
    fn unsubscribed(outlet: &ZenohOutlet, topics: &Topics) -> String {
        let subscribed = outlet.subscribed();
        let none: Vec<&str> = topics
            .list
            .iter()
            .zip(&subscribed)
            .filter(|(_, s)| !**s)
            .map(|(t, _)| t.name.as_str())
            .collect();
        if none.is_empty() {
            "zenoh: every topic has a subscriber".to_owned()
        } else {
            format!(
                "zenoh: a subscriber is there; none yet on {} (their messages reach only subscribers that come later)",
                none.join(", ")
            )
        }
    }

    /// Waits up to `drain_s` for the events, closes the session, and says what became of the
    /// messages.
    pub(super) fn drain(z: ZenohOutlet, drain_s: f64, note: &mut dyn FnMut(String)) {
        let pending: u64 = z
            .counts()
            .iter()
            .filter(|t| t.reliable)
            .map(|t| t.undelivered)
            .sum();
        if pending > 0 {
            note(format!(
                "zenoh: waiting up to {drain_s} s for {pending} event(s) to reach the network (--zenoh-drain)"
            ));
        }
        let report = z.close(Duration::from_secs_f64(drain_s));
        for line in report.lines(drain_s) {
            note(line);
        }
    }

    impl ZenohReport {
        /// What became of the live messages, a line per topic that had any and one for the
        /// whole, after a wait at the end of `drain_s` seconds: "handed to the network" is what
        /// Zenoh took for a subscriber it knew of; "read by the receiving process" (on this
        /// machine) and "acknowledged by the receiving machine" (TCP) what the system's socket
        /// tables showed at the end. Zenoh reports no receipt by a subscriber.
        pub fn lines(&self, drain_s: f64) -> Vec<String> {
            let mut lines: Vec<String> = self
                .topics
                .iter()
                .filter(|t| t.given > 0)
                .map(|t| topic_line(t, drain_s))
                .collect();
            for (name, served, refused, malformed) in &self.services {
                let mut line = format!("zenoh: service {name}: {served} call(s) answered");
                if *refused > 0 {
                    line.push_str(&format!(" ({refused} refused, with the reason)"));
                }
                if *malformed > 0 {
                    line.push_str(&format!(
                        ", {malformed} query(ies) that were not rmw_zenoh requests answered with an error"
                    ));
                }
                lines.push(line);
            }
            for (topic, [received, fed, other, bare, malformed]) in &self.listened {
                let mut line =
                    format!("zenoh: subscription {topic}: {received} sample(s) received, {fed} read");
                for (n, what) in [
                    (other, "of another type or type hash"),
                    (bare, "without rmw_zenoh's attachment"),
                    (malformed, "not a readable message"),
                ] {
                    if *n > 0 {
                        line.push_str(&format!(", {n} dropped {what}"));
                    }
                }
                lines.push(line);
            }
            lines.push(self.end_line(drain_s));
            lines
        }

        /// The line for the whole: where the bytes written stood at the end, and the peers.
        fn end_line(&self, drain_s: f64) -> String {
            let mut peers = format!("{} peer(s) connected at the end", self.peers);
            if self.peers_left > 0 {
                peers.push_str(&format!(
                    ", {} left during the run (what was in flight to them then is lost)",
                    self.peers_left
                ));
            }
            let within = format!("within {:.1} s", self.waited.as_secs_f64());
            match self.in_flight {
                Some(f) if f.bytes == 0 && !self.timed_out => {
                    let taken = match (f.local, f.remote) {
                        (0, 0) => "no connection was open at the end".to_owned(),
                        (_, 0) => "every byte written was read by the receiving process (on this machine)".to_owned(),
                        (0, _) => "every byte written was acknowledged by the receiving machine (TCP; not yet read there, perhaps)".to_owned(),
                        (l, r) => format!(
                            "every byte written was read by the receiving process ({l} connection(s) on this machine) or acknowledged by the receiving machine ({r} to other machines, TCP)"
                        ),
                    };
                    if f.local + f.remote == 0 {
                        format!("zenoh: {taken}; {peers}")
                    } else {
                        format!("zenoh: {taken} {within}; {peers}")
                    }
                }
                Some(f) if f.bytes > 0 => format!(
                    "zenoh: {} byte(s) written were not yet taken by their receivers when the wait of {drain_s} s ran out: the last messages may not arrive (give a longer --zenoh-drain); {peers}",
                    f.bytes
                ),
                _ if self.timed_out => format!(
                    "zenoh: the wait of {drain_s} s ran out before everything was handed to the network; {peers}"
                ),
                _ => format!(
                    "zenoh: handed to the network; this system does not tell whether the receivers took it; {peers}"
                ),
            }
        }
    }

    /// One topic's line: its messages handed over, dropped, unmatched and undelivered.
    fn topic_line(t: &crate::TopicCounts, drain_s: f64) -> String {
        let (what, how) = if t.reliable {
            ("event(s)", "reliable: Zenoh waits for room, never drops")
        } else {
            (
                "message(s)",
                "best effort: a congested link drops more there, uncounted",
            )
        };
        let mut parts = Vec::new();
        if t.sent > 0 || t.given == t.dropped {
            parts.push(format!(
                "{} handed to the network for subscribers ({how})",
                t.sent
            ));
        }
        if t.dropped > 0 {
            parts.push(format!(
                "{} dropped here (the network could not keep up)",
                t.dropped
            ));
        }
        if t.unmatched > 0 {
            parts.push(format!(
                "{} with no subscriber there (nobody received them)",
                t.unmatched
            ));
        }
        if t.undelivered > 0 {
            parts.push(format!(
                "{} undelivered (still queued when the wait of {drain_s} s ran out: give a longer --zenoh-drain)",
                t.undelivered
            ));
        }
        format!("zenoh: {}: {} {what}: {}", t.topic, t.given, parts.join(", "))
    }
}

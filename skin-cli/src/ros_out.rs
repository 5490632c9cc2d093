//! The ROS 2 outputs of `skin run` and `skin convert`: an MCAP file (`--mcap`) and a live
//! Zenoh publisher (`--zenoh`), both fed by skin-ros's `RosSink`.

use crate::output::Inputs;
use anyhow::{Context, Result};
use skin_core::LinkSkin;
use skin_ros::{Outlet, RosOptions, RosSink, RosTime};
use std::path::{Path, PathBuf};

/// How long a run waits at the end, by default, for its events to reach the network.
#[cfg(feature = "zenoh")]
const DRAIN_S: f64 = 30.0;

/// What the ROS stamps count from (`--ros-time`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum RosTimeArg {
    /// The input's clock (a candump log's time since 1970); refused past 2038-01-19, where
    /// ROS 2 time ends.
    #[default]
    Input,
    /// From 0 at the first frame: the same input always gives the same stamps.
    Rebase,
}

/// ROS 2 outputs (see "Use it from ROS 2" in the README for the topics and messages).
#[derive(clap::Args, Debug, Clone, Default)]
pub struct RosArgs {
    /// Also record the session as ROS 2 messages in an MCAP file (rosbag2's format: `ros2 bag
    /// play FILE`, Foxglove). It appears only when complete (with the output folder, when
    /// there is one); an existing file there is replaced only if skin wrote it; one run at a
    /// time writes a path.
    #[cfg(feature = "mcap")]
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Also publish live on Zenoh as a ROS 2 node would with rmw_zenoh, connecting to this
    /// endpoint (an rmw_zenoh router: tcp/127.0.0.1:7447; repeat for more). One that does not
    /// answer is retried in the background; frames never wait for the network (frame messages
    /// that cannot keep up are dropped and counted), and events are never dropped.
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "tcp/HOST:PORT")]
    pub zenoh: Vec<String>,
    /// Publish on Zenoh listening on this endpoint (peers connect to us), e.g. tcp/0.0.0.0:7448.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "tcp/HOST:PORT")]
    pub zenoh_listen: Vec<String>,
    /// Before the first frame, wait up to this many seconds for a subscriber to any of the
    /// topics (a peer that connects to --zenoh-listen, a node behind the --zenoh router), so
    /// that a replay is seen from its start, and say which topics have none; then go on
    /// whatever happened. Without it a run waits up to 2 s for its --zenoh endpoints and 1 s
    /// for their subscribers, and a run that only listens does not wait.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "SECONDS", value_parser = parse_wait)]
    pub zenoh_wait: Option<f64>,
    /// At the end, wait up to this many seconds (default 30) until every event is handed to
    /// the network and acknowledged by the receiving ends, then say per topic what was
    /// handed over, dropped or left undelivered.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "SECONDS", value_parser = parse_wait)]
    pub zenoh_drain: Option<f64>,
    /// ROS domain id of the Zenoh topics (ROS_DOMAIN_ID), 0 to 232; 0 unless given.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "N")]
    pub ros_domain: Option<u32>,
    /// What the message stamps count from: the input's clock (refused past 2038-01-19, where
    /// ROS 2 time ends), or 0 at the first frame.
    #[arg(long, value_name = "CLOCK", value_enum, default_value_t = RosTimeArg::Input)]
    pub ros_time: RosTimeArg,
    /// Prefix of every topic: PREFIX/<link>/pressure, PREFIX/events ...
    #[arg(long, value_name = "PREFIX", default_value = "/skin")]
    pub ros_prefix: String,
    /// Also publish each decision's pressure image (32FC1, counts) on PREFIX/<link>/pressure_image.
    #[arg(long)]
    pub pressure_images: bool,
}

impl RosArgs {
    /// The MCAP file asked for.
    pub fn mcap_path(&self) -> Option<&Path> {
        #[cfg(feature = "mcap")]
        return self.mcap.as_deref();
        #[cfg(not(feature = "mcap"))]
        None
    }

    fn live(&self) -> bool {
        #[cfg(feature = "zenoh")]
        return !self.zenoh.is_empty() || !self.zenoh_listen.is_empty();
        #[cfg(not(feature = "zenoh"))]
        false
    }

    /// Any ROS output asked for.
    pub fn any(&self) -> bool {
        self.mcap_path().is_some() || self.live()
    }

    /// Checks before any work: the prefix, the endpoints, the live options without a live
    /// output, and that the MCAP file may be written (not an input, not a user's other file).
    pub fn precheck(&self, inputs: &Inputs) -> Result<()> {
        skin_ros::topics::check_prefix(&self.ros_prefix)?;
        #[cfg(feature = "zenoh")]
        {
            skin_ros::zenoh_live::check_endpoints(&self.zenoh, &self.zenoh_listen)?;
            for (flag, given) in [
                ("--zenoh-wait", self.zenoh_wait.is_some()),
                ("--zenoh-drain", self.zenoh_drain.is_some()),
                ("--ros-domain", self.ros_domain.is_some()),
            ] {
                anyhow::ensure!(
                    !given || self.live(),
                    "{flag} needs --zenoh or --zenoh-listen: it is for the live topics, and there are none"
                );
            }
            if let Some(d) = self.ros_domain {
                anyhow::ensure!(
                    d <= skin_ros::zenoh_live::MAX_DOMAIN,
                    "--ros-domain {d}: a ROS domain id (ROS_DOMAIN_ID) is 0 to 232; give one of those"
                );
            }
        }
        if let Some(p) = self.mcap_path() {
            inputs.check(p)?;
            if p.is_dir() {
                return Err(skin_core::output::OutputError::IsFolder { path: p.to_owned() }.into());
            }
            skin_core::output::check_replaceable(
                p,
                "an MCAP file that skin wrote",
                skin_ros::mcap_file::written_by_skin,
            )?;
            skin_core::output::check_free(p)?;
        }
        Ok(())
    }

    /// Opens the outputs asked for, for a skin of `links` (none: no sink).
    pub fn open(&self, links: &[LinkSkin], inputs: &Inputs) -> Result<Option<RosSink<Outlets>>> {
        if !self.any() {
            return Ok(None);
        }
        let options = RosOptions {
            prefix: self.ros_prefix.clone(),
            pressure_images: self.pressure_images,
        };
        let topics = options.topics(links)?;
        let mut outlets = Outlets::default();
        #[cfg(feature = "mcap")]
        if let Some(p) = &self.mcap {
            outlets.mcap = Some(skin_ros::McapOutlet::create(p, &topics, inputs)?);
        }
        #[cfg(feature = "zenoh")]
        if self.live() {
            let z = skin_ros::ZenohOptions {
                connect: self.zenoh.clone(),
                listen: self.zenoh_listen.clone(),
                domain: self.ros_domain.unwrap_or(0),
                ..skin_ros::ZenohOptions::default()
            };
            let outlet = skin_ros::ZenohOutlet::open(&topics, &z)?;
            if let Some(s) = self.zenoh_wait {
                let n = topics.list.len();
                eprintln!(
                    "zenoh: waiting up to {s} s for a subscriber to any of the {n} topics (--zenoh-wait)"
                );
                let wait = std::time::Duration::from_secs_f64(s);
                let start = std::time::Instant::now();
                let found = outlet.wait_for_peer(wait)
                    && outlet.wait_for_subscribers(wait.saturating_sub(start.elapsed()));
                if found {
                    // A peer declares its subscriptions together: give the rest a moment.
                    std::thread::sleep(std::time::Duration::from_millis(300));
                    say_unsubscribed(&outlet, &topics);
                } else {
                    eprintln!("zenoh: no subscriber to any topic within {s} s; the frames go on");
                }
            } else if !self.zenoh.is_empty() {
                // A first look, so that a wrong address is said at once; Zenoh keeps retrying.
                if outlet.wait_for_peer(std::time::Duration::from_secs(2)) {
                    // Give the peers' subscriptions a moment to reach us (not an error if none).
                    outlet.wait_for_subscribers(std::time::Duration::from_secs(1));
                } else {
                    eprintln!(
                        "zenoh: nothing answers at {} yet; retrying in the background while frames go on",
                        self.zenoh.join(", ")
                    );
                }
            }
            outlets.zenoh = Some(outlet);
            outlets.drain_s = self.zenoh_drain.unwrap_or(DRAIN_S);
        }
        let _ = inputs;
        let time = match self.ros_time {
            RosTimeArg::Input => RosTime::Input,
            RosTimeArg::Rebase => RosTime::Rebase,
        };
        Ok(Some(RosSink::new(links, topics, outlets).ros_time(time)))
    }
}

/// After --zenoh-wait found a subscriber: the topics that have none, by name.
#[cfg(feature = "zenoh")]
fn say_unsubscribed(outlet: &skin_ros::ZenohOutlet, topics: &skin_ros::topics::Topics) {
    let subscribed = outlet.subscribed();
    let none: Vec<&str> = topics
        .list
        .iter()
        .zip(&subscribed)
        .filter(|(_, s)| !**s)
        .map(|(t, _)| t.name.as_str())
        .collect();
    if none.is_empty() {
        eprintln!("zenoh: every topic has a subscriber");
    } else {
        eprintln!(
            "zenoh: a subscriber is there; none yet on {} (their messages reach only subscribers that come later)",
            none.join(", ")
        );
    }
}

/// `--zenoh-wait`, `--zenoh-drain`: seconds, 0 to 3600.
#[cfg(feature = "zenoh")]
fn parse_wait(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=3600.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?} is not a number of seconds from 0 to 3600")),
    }
}

/// The outlets of one run.
#[derive(Debug, Default)]
pub struct Outlets {
    #[cfg(feature = "mcap")]
    mcap: Option<skin_ros::McapOutlet>,
    #[cfg(feature = "zenoh")]
    zenoh: Option<skin_ros::ZenohOutlet>,
    /// `--zenoh-drain`, seconds.
    #[cfg(feature = "zenoh")]
    drain_s: f64,
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

impl Outlets {
    /// Finishes the MCAP file without putting it in place (it moves with the output folder),
    /// and says how many messages it holds; none without --mcap. The Zenoh session goes on.
    #[cfg(feature = "mcap")]
    pub fn stage_mcap(&mut self) -> Result<Option<(skin_core::output::Staged, u64)>> {
        self.mcap.take().map(|m| Ok(m.stage()?)).transpose()
    }

    /// Puts the MCAP file in place, then waits (bounded by --zenoh-drain) for the events to
    /// reach the network and closes the Zenoh session, saying what each did. A caller that
    /// commits other files calls [`Outlets::finish_mcap`], commits, then
    /// [`Outlets::drain_network`], so that nothing waits on the network but the network.
    pub fn finish(mut self, mcap_path: Option<&Path>) -> Result<()> {
        self.finish_mcap(mcap_path)?;
        self.drain_network();
        Ok(())
    }

    /// Puts the MCAP file in place (if any), saying so.
    pub fn finish_mcap(&mut self, mcap_path: Option<&Path>) -> Result<()> {
        #[cfg(feature = "mcap")]
        if let Some(m) = self.mcap.take() {
            let n = m.finish().with_context(|| {
                format!(
                    "cannot finish {}",
                    mcap_path.map_or(String::new(), |p| p.display().to_string())
                )
            })?;
            if let Some(p) = mcap_path {
                crate::say!("wrote {} ({n} ROS 2 messages)", p.display());
            }
        }
        let _ = mcap_path;
        Ok(())
    }

    /// Waits, bounded by --zenoh-drain, until the events are handed to the network and
    /// acknowledged, closes the Zenoh session (if any), and says per topic what became of the
    /// messages (on standard error: standard output carries the events when live).
    pub fn drain_network(&mut self) {
        #[cfg(feature = "zenoh")]
        if let Some(z) = self.zenoh.take() {
            let pending: u64 = z
                .counts()
                .iter()
                .filter(|t| t.reliable)
                .map(|t| t.undelivered)
                .sum();
            if pending > 0 {
                eprintln!(
                    "zenoh: waiting up to {} s for {pending} event(s) to reach the network (--zenoh-drain)",
                    self.drain_s
                );
            }
            let report = z.close(std::time::Duration::from_secs_f64(self.drain_s));
            for line in report_lines(&report, self.drain_s) {
                eprintln!("{line}");
            }
        }
    }
}

/// What became of the live messages, a line per topic that had any and one for the whole:
/// "handed to the network" is what Zenoh took for a subscriber it knew of; "read by the
/// receiving process" (on this machine) and "acknowledged by the receiving machine" (TCP) what
/// the system's socket tables showed at the end. Zenoh reports no receipt by a subscriber.
#[cfg(feature = "zenoh")]
fn report_lines(report: &skin_ros::ZenohReport, drain_s: f64) -> Vec<String> {
    let mut lines = Vec::new();
    for t in report.topics.iter().filter(|t| t.given > 0) {
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
        lines.push(format!(
            "zenoh: {}: {} {what}: {}",
            t.topic,
            t.given,
            parts.join(", ")
        ));
    }
    let mut peers = format!("{} peer(s) connected at the end", report.peers);
    if report.peers_left > 0 {
        peers.push_str(&format!(
            ", {} left during the run (what was in flight to them then is lost)",
            report.peers_left
        ));
    }
    let within = format!("within {:.1} s", report.waited.as_secs_f64());
    lines.push(match report.in_flight {
        Some(f) if f.bytes == 0 && !report.timed_out => {
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
        _ if report.timed_out => format!(
            "zenoh: the wait of {drain_s} s ran out before everything was handed to the network; {peers}"
        ),
        _ => format!(
            "zenoh: handed to the network; this system does not tell whether the receivers took it; {peers}"
        ),
    });
    lines
}

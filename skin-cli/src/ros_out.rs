//! The ROS 2 outputs of `skin run` and `skin convert`: an MCAP file (`--mcap`) and a live
//! Zenoh publisher (`--zenoh`), both fed by skin-ros's `RosSink`.

use crate::output::Inputs;
use anyhow::{Context, Result};
use skin_core::LinkSkin;
use skin_ros::{Outlet, RosOptions, RosSink, RosTime};
use std::path::{Path, PathBuf};

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
    /// play FILE`, Foxglove). It appears only when complete; an existing file there is
    /// replaced only if it is an MCAP file.
    #[cfg(feature = "mcap")]
    #[arg(long, value_name = "FILE.mcap")]
    pub mcap: Option<PathBuf>,
    /// Also publish live on Zenoh as a ROS 2 node would with rmw_zenoh, connecting to this
    /// endpoint (an rmw_zenoh router: tcp/127.0.0.1:7447; repeat for more). One that does not
    /// answer is retried in the background; frames never wait for the network (messages that
    /// cannot keep up are dropped and counted, events never).
    #[cfg(feature = "zenoh")]
    #[arg(long = "zenoh", value_name = "tcp/HOST:PORT")]
    pub zenoh: Vec<String>,
    /// Publish on Zenoh listening on this endpoint (peers connect to us), e.g. tcp/0.0.0.0:7448.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "tcp/HOST:PORT")]
    pub zenoh_listen: Vec<String>,
    /// Before the first frame, wait up to this many seconds for a subscriber (a peer that
    /// connects to --zenoh-listen, a node behind the --zenoh router), so that a replay is seen
    /// from its start; then go on whatever happened. Without it a run waits up to 2 s for its
    /// --zenoh endpoints and 1 s for their subscribers, and a run that only listens does not wait.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "SECONDS", value_parser = parse_wait)]
    pub zenoh_wait: Option<f64>,
    /// ROS domain id of the Zenoh topics (ROS_DOMAIN_ID).
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub ros_domain: u32,
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

    /// Checks before any work: the prefix, the endpoints, and that the MCAP file may be written
    /// (not an input, not a user's other file).
    pub fn precheck(&self, inputs: &Inputs) -> Result<()> {
        skin_ros::topics::check_prefix(&self.ros_prefix)?;
        #[cfg(feature = "zenoh")]
        for e in self.zenoh.iter().chain(&self.zenoh_listen) {
            skin_ros::zenoh_live::check_endpoint(e)?;
        }
        #[cfg(feature = "zenoh")]
        if self.zenoh_wait.is_some() && !self.live() {
            anyhow::bail!("--zenoh-wait needs --zenoh or --zenoh-listen: there is nothing to wait for");
        }
        if let Some(p) = self.mcap_path() {
            inputs.check(p)?;
            skin_core::output::check_replaceable(p, "an MCAP file", skin_ros::mcap_file::is_mcap)?;
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
                domain: self.ros_domain,
                ..skin_ros::ZenohOptions::default()
            };
            let outlet = skin_ros::ZenohOutlet::open(&topics, &z)?;
            if let Some(s) = self.zenoh_wait {
                let wait = std::time::Duration::from_secs_f64(s);
                let start = std::time::Instant::now();
                let found = outlet.wait_for_peer(wait)
                    && outlet.wait_for_subscribers(wait.saturating_sub(start.elapsed()));
                if !found {
                    eprintln!("zenoh: no subscriber within {s} s; the frames go on");
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
        }
        let _ = inputs;
        let time = match self.ros_time {
            RosTimeArg::Input => RosTime::Input,
            RosTimeArg::Rebase => RosTime::Rebase,
        };
        Ok(Some(RosSink::new(links, topics, outlets).ros_time(time)))
    }
}

/// `--zenoh-wait`: seconds, 0 to 3600.
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
    /// Puts the MCAP file in place and closes the Zenoh session (sending what is queued, for
    /// up to 10 s), saying what each did.
    pub fn finish(self, mcap_path: Option<&Path>) -> Result<()> {
        #[cfg(feature = "zenoh")]
        if let Some(z) = self.zenoh {
            let peers = z.peers();
            let s = z.close(std::time::Duration::from_secs(10));
            let dropped = if s.dropped > 0 {
                format!(", {} dropped (the network could not keep up)", s.dropped)
            } else {
                String::new()
            };
            eprintln!(
                "zenoh: {} messages published{dropped}; {peers} peer(s) connected at the end",
                s.published
            );
        }
        #[cfg(feature = "mcap")]
        if let Some(m) = self.mcap {
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
}

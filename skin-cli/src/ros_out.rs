//! The ROS 2 flags of `skin run` and `skin convert`: an MCAP file (`--mcap`) and a live Zenoh
//! publisher (`--zenoh`), opened as skin-ros's `Outlets` and fed by its `RosSink`.

use crate::output::Inputs;
use anyhow::{Context, Result};
use skin_core::LinkSkin;
use skin_learn::session::{Description, Session, TareHandle};
use skin_ros::{Outlet, OutletOptions, RosOptions, RosSink, RosTime};
use std::path::Path;

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
    pub mcap: Option<std::path::PathBuf>,
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
    /// Stitch at the robot's posture live: subscribe to sensor_msgs/JointState on this topic
    /// (e.g. /joint_states) as a ROS 2 node on rmw_zenoh does, joints matched by name to the
    /// configuration's [stitch] urdf. Replaying a log or recording, each frame waits (up to 2
    /// s) for the joint state of its time; live, never. Faults (a joint missing or NaN, a stale
    /// or out-of-order message, another robot's) are events; the last good posture holds.
    /// Needs --zenoh or --zenoh-listen.
    #[cfg(feature = "zenoh")]
    #[arg(long, value_name = "TOPIC")]
    pub joint_states: Option<String>,
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

    /// The outlets asked for, as skin-ros takes them.
    // The update fills the fields a build without zenoh lacks; with zenoh every field is set.
    #[cfg_attr(feature = "zenoh", allow(clippy::needless_update))]
    fn outlets(&self) -> OutletOptions {
        OutletOptions {
            mcap: self.mcap_path().map(Path::to_owned),
            #[cfg(feature = "zenoh")]
            connect: self.zenoh.clone(),
            #[cfg(feature = "zenoh")]
            listen: self.zenoh_listen.clone(),
            #[cfg(feature = "zenoh")]
            domain: self.ros_domain.unwrap_or(0),
            #[cfg(feature = "zenoh")]
            wait_s: self.zenoh_wait,
            #[cfg(feature = "zenoh")]
            drain_s: self.zenoh_drain.unwrap_or(skin_ros::DEFAULT_DRAIN_S),
            ..OutletOptions::default()
        }
    }

    /// Any ROS output asked for.
    pub fn any(&self) -> bool {
        self.outlets().any()
    }

    /// Checks before any work: the prefix, the live options without a live output, then the
    /// endpoints and that the MCAP file may be written ([`OutletOptions::check`]).
    pub fn precheck(&self, inputs: &Inputs) -> Result<()> {
        skin_ros::topics::check_prefix(&self.ros_prefix)?;
        #[cfg(feature = "zenoh")]
        {
            let live = self.outlets().live();
            for (flag, given) in [
                ("--zenoh-wait", self.zenoh_wait.is_some()),
                ("--zenoh-drain", self.zenoh_drain.is_some()),
                ("--ros-domain", self.ros_domain.is_some()),
                ("--joint-states", self.joint_states.is_some()),
            ] {
                anyhow::ensure!(
                    !given || live,
                    "{flag} needs --zenoh or --zenoh-listen: it is for the live topics, and there are none"
                );
            }
            if let Some(t) = &self.joint_states {
                skin_ros::topics::check_prefix(t)
                    .map_err(|e| anyhow::anyhow!("--joint-states {t}: {}", e.why))?;
            }
            if let Some(d) = self.ros_domain {
                anyhow::ensure!(
                    d <= skin_ros::MAX_DOMAIN,
                    "--ros-domain {d}: a ROS domain id (ROS_DOMAIN_ID) is 0 to 232; give one of those"
                );
            }
        }
        Ok(self.outlets().check(inputs)?)
    }

    /// [`RosArgs::open`] for `session`'s skin, described as it describes itself; `tare` serves
    /// its tare (`skin run`; not `skin convert`, which converts a file). With --joint-states,
    /// the session is given the robot's posture live (`offline`: a replay, whose frames wait
    /// for the joint state of their time).
    pub fn open_session(
        &self,
        session: &mut Session,
        tare: bool,
        offline: bool,
        inputs: &Inputs,
    ) -> Result<Option<RosSink<Outlets>>> {
        #[cfg(feature = "zenoh")]
        let joint_states = match &self.joint_states {
            Some(topic) => {
                let wait = offline.then(|| std::time::Duration::from_secs(2));
                let feed = session.joint_state_feed(wait, self.ros_time == RosTimeArg::Rebase)?;
                Some((topic.clone(), feed))
            }
            None => None,
        };
        #[cfg(not(feature = "zenoh"))]
        let _ = offline;
        let serving = Serving {
            description: session.describe(),
            tare: tare.then(|| session.tare_handle()),
            #[cfg(feature = "zenoh")]
            joint_states,
        };
        self.open(session.links(), &session.weighed(), serving, inputs)
    }

    /// Opens the outputs asked for, for a skin of `links` (none: no sink), with a wrench topic
    /// for each link `weighed` says has a force model, serving what `serving` says (the layout
    /// it describes, its tare, the joint states it listens to). What the live outlet waits for
    /// goes to standard error (standard output carries the events when live).
    pub fn open(
        &self,
        links: &[LinkSkin],
        weighed: &[bool],
        serving: Serving,
        inputs: &Inputs,
    ) -> Result<Option<RosSink<Outlets>>> {
        let Serving {
            description,
            tare,
            #[cfg(feature = "zenoh")]
            joint_states,
        } = serving;
        let options = self.outlets();
        if !options.any() {
            return Ok(None);
        }
        let topics = RosOptions {
            prefix: self.ros_prefix.clone(),
            pressure_images: self.pressure_images,
        }
        .topics(links)?
        .with_wrenches(weighed);
        #[cfg_attr(not(feature = "zenoh"), allow(unused_mut))]
        let mut outlets = skin_ros::Outlets::open(&options, &topics, inputs, &mut |l| eprintln!("{l}"))?;
        #[cfg(feature = "zenoh")]
        outlets.serve(
            &topics,
            skin_ros::Services {
                tare,
                description: Some(description.clone()),
            },
        )?;
        #[cfg(feature = "zenoh")]
        if let Some((topic, feed)) = joint_states {
            outlets.listen_joint_states(&topic, feed)?;
        }
        #[cfg(not(feature = "zenoh"))]
        let _ = tare;
        let time = match self.ros_time {
            RosTimeArg::Input => RosTime::Input,
            RosTimeArg::Rebase => RosTime::Rebase,
        };
        Ok(Some(
            RosSink::new(links, topics, Outlets(outlets))
                .ros_time(time)
                .describing(description),
        ))
    }
}

/// What a run's live node serves and listens to, beside its topics.
pub struct Serving {
    /// The skin, for PREFIX/layout and PREFIX/describe.
    pub description: Description,
    /// The session's tare, for PREFIX/tare.
    pub tare: Option<TareHandle>,
    /// The joint-state topic and the session's feed.
    #[cfg(feature = "zenoh")]
    pub joint_states: Option<(String, skin_learn::session::PostureFeed)>,
}

/// `--zenoh-wait`, `--zenoh-drain`: seconds, 0 to 3600.
#[cfg(feature = "zenoh")]
fn parse_wait(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=3600.0).contains(&v) => Ok(v),
        _ => Err(format!("{s:?} is not a number of seconds from 0 to 3600")),
    }
}

/// The outlets of one run, closed as the commands say it.
#[derive(Debug)]
pub struct Outlets(skin_ros::Outlets);

impl Outlet for Outlets {
    fn publish(&mut self, topic: usize, stamp_ns: u64, cdr: &[u8]) -> std::io::Result<()> {
        self.0.publish(topic, stamp_ns, cdr)
    }
}

impl Outlets {
    /// Finishes the MCAP file without putting it in place (it moves with the output folder),
    /// and says how many messages it holds; none without --mcap. The Zenoh session goes on.
    #[cfg(feature = "mcap")]
    pub fn stage_mcap(&mut self) -> Result<Option<(skin_core::output::Staged, u64)>> {
        Ok(self.0.stage_mcap()?)
    }

    /// Puts the MCAP file in place (saying so), then waits (bounded by --zenoh-drain) for the
    /// events to reach the network and closes the Zenoh session, saying on standard error what
    /// became of the messages.
    pub fn finish(mut self, mcap_path: Option<&Path>) -> Result<()> {
        let shown = mcap_path.map_or(String::new(), |p| p.display().to_string());
        let n = self
            .0
            .finish_mcap()
            .with_context(|| format!("cannot finish {shown}"))?;
        if let (Some(p), Some(n)) = (mcap_path, n) {
            crate::say!("wrote {} ({n} ROS 2 messages)", p.display());
        }
        self.0.drain(&mut |line| eprintln!("{line}"));
        Ok(())
    }
}

//! ROS 2 without ROS: a skin session's frames and events as ROS 2 messages, written to an MCAP
//! file that `ros2 bag play` and Foxglove open, or published live on Zenoh as rmw_zenoh (the
//! Zenoh middleware of ROS 2 Jazzy) does, with nothing of ROS installed. It is the last step of a
//! frame's path (ARCHITECTURE.md at the repository's root): a `Sink` of skin-runtime's session.
//!
//! ```text
//! Session --Sink--> RosSink --CDR messages--> Outlet: McapOutlet  (feature mcap: a rosbag2 file)
//!   (frames: pressures, contacts;       (topics)          ZenohOutlet (feature zenoh: live)
//!    events: appeared, classified ...)                     Vec<(topic, stamp, bytes)> (tests)
//! ```
//!
//! - [`cdr`]: the CDR writer. [`messages`]: `PointCloud2`, `Image`, `MarkerArray`,
//!   `skin_msgs/Contacts` and `skin_msgs/TouchEvent` encoded with it.
//! - [`interfaces`]: the `.msg` definitions (standard ones, and the repository's `skin_msgs`
//!   package), their `ros2msg` schemas; [`type_hash`]: their RIHS01 hashes (REP-2016).
//! - [`topics`]: topic names (`/skin/<link>/pressure` ...), link names made into topic tokens
//!   and frame ids; `clock`: the stamps, checked against the end of ROS 2 time.
//! - `bridge`: [`RosSink`], the session sink, and the [`Outlet`] trait; [`Outlets`]: one run's
//!   MCAP file and live publisher together.
//!
//! Live, it also listens and serves as a ROS 2 node does: `sensor_msgs/JointState` for a
//! session's [`PostureFeed`](skin_runtime::session::PostureFeed) (`ZenohOutlet::listen_joint_states`),
//! and the services `PREFIX/tare`, `PREFIX/tare_forced` and `PREFIX/describe`
//! (`ZenohOutlet::serve`). The skin's own description (`skin_msgs/TactileLayout`, transient
//! local) and per-frame readings (`skin_msgs/TactileState`) ride on [`RosSink`].
//!
//! Without features the crate encodes and hashes only; `mcap` adds [`McapOutlet`] and `zenoh`
//! adds [`ZenohOutlet`] (a Zenoh peer, TCP only). Neither needs ROS installed, and the crate
//! never loads a model: it depends on skin-runtime alone (no calibration, synthesis or tract).
//!
//! ```
//! use skin_ros::{Outlet, RosOptions, RosSink, messages::Stamp};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // Two taxels on a link "palm", published to memory.
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use nalgebra::{Point3, Vector3, Unit};
//! let taxel = |id, x| Taxel { id: TaxelId(id), position: Point3::new(x, 0.0, 0.0), normal: Unit::new_normalize(Vector3::z()) };
//! let links = vec![LinkSkin::new("palm", vec![taxel(1, 0.0), taxel(2, 0.005)])];
//! let topics = RosOptions::default().topics(&links)?;
//! assert_eq!(topics.list[0].name, "/skin/palm/pressure");
//! let interfaces = skin_ros::interfaces::Interfaces::skin()?;
//! assert!(interfaces.type_hash("sensor_msgs/msg/PointCloud2").is_some_and(|h| h.starts_with("RIHS01_")));
//! # Ok(()) }
//! ```

mod bridge;
pub mod cdr;
mod clock;
pub mod decode;
pub mod interfaces;
#[cfg(feature = "mcap")]
mod mcap_file;
pub mod messages;
mod outlets;
pub mod rmw_zenoh;
pub mod topics;
pub mod type_hash;
#[cfg(feature = "zenoh")]
mod zenoh_live;

pub use bridge::{Outlet, RosOptions, RosSink};
pub use clock::{ROS_TIME_END_NS, RosTime, StampError};
#[cfg(feature = "mcap")]
pub use mcap_file::{McapOutlet, written_by_skin as mcap_file_written_by_skin};
pub use outlets::{DEFAULT_DRAIN_S, OutletOptions, Outlets};
#[cfg(feature = "zenoh")]
pub use zenoh_live::{
    InFlight, JOINT_STATE, ListenCounts, MAX_DOMAIN, ServiceCounts, Services, TopicCounts, ZenohOptions,
    ZenohOutlet, ZenohReport, check_endpoint, check_endpoints,
};

/// What can go wrong publishing a skin to ROS 2.
#[derive(Debug, thiserror::Error)]
pub enum RosError {
    /// A message definition cannot be read.
    #[error(transparent)]
    Definition(#[from] interfaces::DefinitionError),
    /// A topic prefix is not a ROS name.
    #[error(transparent)]
    Prefix(#[from] topics::PrefixError),
    /// A topic's type has no definition.
    #[error("no definition of {0}")]
    UnknownType(&'static str),
    /// The output file (data-safety rules).
    #[error(transparent)]
    Output(#[from] skin_core::output::OutputError),
    /// Writing the MCAP file.
    #[error("{}: {why}", path.display())]
    Mcap {
        /// The file.
        path: std::path::PathBuf,
        /// What failed.
        why: String,
    },
    /// An endpoint that cannot be used.
    #[error("zenoh endpoint \"{endpoint}\": {why}")]
    Endpoint {
        /// The endpoint given.
        endpoint: String,
        /// What is wrong.
        why: String,
    },
    /// A ROS domain id past 232.
    #[error("ROS domain {0}: a domain id (ROS_DOMAIN_ID) is 0 to 232")]
    Domain(u32),
    /// The Zenoh session.
    #[error("zenoh: {0}")]
    Zenoh(String),
}

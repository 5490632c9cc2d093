//! Subscriptions, as an rmw_zenoh node subscribes: `sensor_msgs/msg/JointState` on a topic
//! (`/joint_states`), fed to a session's [`PostureFeed`].
//!
//! A subscription is a Zenoh subscriber on `<domain>/<topic>/*/*` (any type, to count what is
//! not a JointState rather than miss it silently) and an `MS` liveliness token. As rmw_zenoh's
//! subscriptions do, a sample without the 33-byte attachment is dropped. A sample of another
//! type or type hash, one that is not a JointState's CDR, or one naming more than
//! [`crate::decode::MAX_JOINTS`] joints is counted and dropped; the rest go to the feed, which
//! says what is wrong with their joints. Everything runs on Zenoh's threads: the frame path
//! only reads the feed.

use super::config::zenoh_error;
use super::names::{Place, dds_type};
use crate::RosError;
use crate::interfaces::Interfaces;
use skin_runtime::session::PostureFeed;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use zenoh::Wait;

/// `sensor_msgs/msg/JointState`.
pub const JOINT_STATE: &str = "sensor_msgs/msg/JointState";

/// What a subscription did with the samples it got.
#[derive(Debug, Default)]
pub struct ListenCounts {
    /// The topic, `/joint_states`.
    pub topic: String,
    /// Samples received.
    pub received: AtomicU64,
    /// Handed to the feed (which may still find their joints wrong: its events say).
    pub fed: AtomicU64,
    /// Of another type, or of this type with another hash (another ROS distribution's).
    pub other_type: AtomicU64,
    /// Without rmw_zenoh's attachment (dropped, as rmw_zenoh's subscriptions drop them).
    pub no_attachment: AtomicU64,
    /// Not a JointState's CDR (cut short, lengths that lie, too many joints).
    pub malformed: AtomicU64,
}

/// A subscription being served.
pub(super) struct Listening {
    pub counts: Arc<ListenCounts>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
    _token: zenoh::liveliness::LivelinessToken,
}

/// Subscribes to `topic` (a ROS name, `/joint_states`) for `feed`.
pub(super) fn joint_states(
    session: &zenoh::Session,
    topic: &str,
    feed: PostureFeed,
    place: &Place<'_>,
    id: usize,
) -> Result<Listening, RosError> {
    let name = crate::topics::check_prefix(topic)?;
    let hash = Interfaces::skin()?
        .type_hash(JOINT_STATE)
        .ok_or(RosError::UnknownType(JOINT_STATE))?;
    let dds = dds_type(JOINT_STATE);
    let counts = Arc::new(ListenCounts {
        topic: name.clone(),
        ..ListenCounts::default()
    });
    let c = counts.clone();
    let want = (dds.clone(), hash.clone());
    let key = format!("{}/{}/*/*", place.domain, name.trim_start_matches('/'));
    let subscriber = session
        .declare_subscriber(key)
        .callback(move |sample| take(&sample, &want, &feed, &c))
        .wait()
        .map_err(zenoh_error)?;
    // Reliable, volatile, keep last 10: rclcpp's default subscription.
    let token = place.token(id, "MS", &name, &dds, &hash, "1:2:1,10:,:,:,,");
    let token = session
        .liveliness()
        .declare_token(token)
        .wait()
        .map_err(zenoh_error)?;
    Ok(Listening {
        counts,
        _subscriber: subscriber,
        _token: token,
    })
}

/// One sample: checked, read, handed to the feed.
fn take(
    sample: &zenoh::sample::Sample,
    (dds, hash): &(String, String),
    feed: &PostureFeed,
    c: &ListenCounts,
) {
    c.received.fetch_add(1, Ordering::Relaxed);
    let key = sample.key_expr().as_str();
    let mut chunks = key.rsplitn(3, '/');
    let (Some(their_hash), Some(their_type)) = (chunks.next(), chunks.next()) else {
        c.other_type.fetch_add(1, Ordering::Relaxed);
        return;
    };
    if their_type != dds || their_hash != hash {
        c.other_type.fetch_add(1, Ordering::Relaxed);
        return;
    }
    if sample.attachment().is_none_or(|a| a.len() != 33) {
        c.no_attachment.fetch_add(1, Ordering::Relaxed);
        return;
    }
    let payload = sample.payload().to_bytes();
    let Ok(js) = crate::decode::joint_state(&payload) else {
        c.malformed.fetch_add(1, Ordering::Relaxed);
        return;
    };
    let stamp_ns = i128::from(js.stamp.sec) * 1_000_000_000 + i128::from(js.stamp.nanosec);
    feed.push(stamp_ns, js.names.iter().copied(), &js.positions);
    c.fed.fetch_add(1, Ordering::Relaxed);
}

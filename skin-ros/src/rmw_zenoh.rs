//! What rmw_zenoh calls things, as pure functions any client can use (no Zenoh needed): the DDS
//! type of a message, the data key expression of a topic, the liveliness tokens of a node and its
//! entities, each entity's GID, and the attachment every sample, query and reply carries. The
//! live publisher (`zenoh` feature) names its topics with them; the Python package's Zenoh
//! clients (`skin.sim.zenoh`) name theirs with the same.

use crate::topics::{QOS_DEPTH, Qos};
use sha2::{Digest, Sha256};

/// `pkg/msg/Name` -> `pkg::msg::dds_::Name_`.
pub fn dds_type(name: &str) -> String {
    let mut parts: Vec<&str> = name.split('/').collect();
    let last = parts.pop().unwrap_or_default();
    format!("{}::dds_::{last}_", parts.join("::"))
}

/// A name with every `/` written `%`, an empty one written `%`.
pub fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".into()
    } else {
        name.replace('/', "%")
    }
}

/// The rmw_zenoh QoS string of the offered QoS (`reliability:durability:history,depth:` then
/// default deadline, lifespan and liveliness): reliable, and volatile keep all (the events),
/// volatile keep last 10 (frames) or transient local keep last 1 (the layout).
pub fn qos_string(qos: Qos) -> String {
    match qos {
        Qos::Events => "1:2:2,0:,:,:,,".to_owned(),
        Qos::Frames => format!("1:2:1,{QOS_DEPTH}:,:,:,,"),
        Qos::Latched => "1:1:1,1:,:,:,,".to_owned(),
    }
}

/// Where a node is on the network, for its entities' liveliness tokens.
pub struct Place<'a> {
    /// The ROS domain id.
    pub domain: u32,
    /// The Zenoh session's id, as Zenoh writes it (hex).
    pub zid: &'a str,
    /// The node's namespace, `/` for none.
    pub namespace: &'a str,
    /// The node's name.
    pub node: &'a str,
}

impl Place<'_> {
    /// The liveliness token of the node's entity `id` of `kind` (`MP` publisher, `MS`
    /// subscription, `SS` service server) on the topic or service `name`:
    /// `@ros2_lv/<domain>/<zid>/0/<id>/<kind>/%/<namespace>/<node>/<name>/<DDS type>/<hash>/<qos>`.
    pub fn token(&self, id: usize, kind: &str, name: &str, dds: &str, hash: &str, qos: &str) -> String {
        format!(
            "@ros2_lv/{}/{}/0/{id}/{kind}/%/{}/{}/{}/{dds}/{hash}/{qos}",
            self.domain,
            self.zid,
            mangle(self.namespace.trim_end_matches('/')),
            self.node,
            mangle(name)
        )
    }
}

/// rmw_zenoh's attachment of a sample, a query or a reply: the sequence number (i64 LE), the
/// source time (i64 LE, ns since the epoch: now), the byte 16 and the 16-byte GID.
pub fn attachment(seq: i64, gid: &[u8; 16]) -> [u8; 33] {
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX));
    let mut a = [0u8; 33];
    a[..8].copy_from_slice(&seq.to_le_bytes());
    a[8..16].copy_from_slice(&now.to_le_bytes());
    a[16] = 16;
    a[17..].copy_from_slice(gid);
    a
}

/// The sequence number and GID of an rmw_zenoh attachment; none for other bytes.
pub fn sender_of(attachment: &[u8]) -> Option<(i64, [u8; 16])> {
    if attachment.len() != 33 || attachment[16] != 16 {
        return None;
    }
    let mut seq = [0u8; 8];
    seq.copy_from_slice(&attachment[..8]);
    let mut gid = [0u8; 16];
    gid.copy_from_slice(&attachment[17..]);
    Some((i64::from_le_bytes(seq), gid))
}

/// The data key expression of `topic` (`/joint_states`) of type `type_name` with type hash
/// `hash` in `domain`: `<domain>/<topic without its leading />/<DDS type>/<hash>`.
pub fn data_key(domain: u32, topic: &str, type_name: &str, hash: &str) -> String {
    format!(
        "{domain}/{}/{}/{hash}",
        topic.trim_start_matches('/'),
        dds_type(type_name)
    )
}

/// The liveliness token of the node itself (`NN`), which its entities' tokens follow.
pub fn node_token(place: &Place<'_>) -> String {
    format!(
        "@ros2_lv/{}/{}/0/0/NN/%/{}/{}",
        place.domain,
        place.zid,
        mangle(place.namespace.trim_end_matches('/')),
        place.node
    )
}

/// The GID of the node's entity `id` on the session `zid`: the first 16 bytes of
/// SHA-256(`<zid>/<id>`), unique per entity and the same at every run.
pub fn gid(zid: &str, id: usize) -> [u8; 16] {
    let digest = Sha256::digest(format!("{zid}/{id}").as_bytes());
    let mut gid = [0u8; 16];
    gid.copy_from_slice(&digest[..16]);
    gid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names() {
        assert_eq!(
            dds_type("sensor_msgs/msg/Image"),
            "sensor_msgs::msg::dds_::Image_"
        );
        assert_eq!(mangle("/skin/events"), "%skin%events");
        assert_eq!(
            data_key(0, "/joint_states", "sensor_msgs/msg/JointState", "RIHS01_x"),
            "0/joint_states/sensor_msgs::msg::dds_::JointState_/RIHS01_x"
        );
    }
}

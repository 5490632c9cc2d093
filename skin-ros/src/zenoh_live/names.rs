//! What rmw_zenoh calls things: the DDS type of a message, the data key expression of a
//! topic, the liveliness tokens of a node and its publishers, and each publisher's GID.

use super::ZenohOptions;
use crate::RosError;
use crate::interfaces::Interfaces;
use crate::topics::{QOS_DEPTH, Qos, Topics};
use sha2::{Digest, Sha256};

/// `pkg/msg/Name` -> `pkg::msg::dds_::Name_`.
pub fn dds_type(name: &str) -> String {
    let mut parts: Vec<&str> = name.split('/').collect();
    let last = parts.pop().unwrap_or_default();
    format!("{}::dds_::{last}_", parts.join("::"))
}

/// A name with every `/` written `%`, an empty one written `%`.
fn mangle(name: &str) -> String {
    if name.is_empty() {
        "%".into()
    } else {
        name.replace('/', "%")
    }
}

/// The rmw_zenoh QoS string of the offered QoS (`reliability:durability:history,depth:` then
/// default deadline, lifespan and liveliness): reliable, and volatile keep all (the events),
/// volatile keep last 10 (frames) or transient local keep last 1 (the layout).
fn qos_string(qos: Qos) -> String {
    match qos {
        Qos::Events => "1:2:2,0:,:,:,,".to_owned(),
        Qos::Frames => format!("1:2:1,{QOS_DEPTH}:,:,:,,"),
        Qos::Latched => "1:1:1,1:,:,:,,".to_owned(),
    }
}

/// Where a node is on the network, for its entities' liveliness tokens.
pub(super) struct Place<'a> {
    pub domain: u32,
    pub zid: &'a str,
    pub namespace: &'a str,
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
pub(super) fn attachment(seq: i64, gid: &[u8; 16]) -> [u8; 33] {
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
pub(super) fn sender_of(attachment: &[u8]) -> Option<(i64, [u8; 16])> {
    if attachment.len() != 33 || attachment[16] != 16 {
        return None;
    }
    let mut seq = [0u8; 8];
    seq.copy_from_slice(&attachment[..8]);
    let mut gid = [0u8; 16];
    gid.copy_from_slice(&attachment[17..]);
    Some((i64::from_le_bytes(seq), gid))
}

/// What rmw_zenoh names for a node and its publishers: per topic the data key expression and
/// the publisher's gid; the liveliness tokens, the node's first.
pub(super) struct Names {
    pub keys: Vec<String>,
    pub tokens: Vec<String>,
    pub gids: Vec<[u8; 16]>,
}

impl Names {
    pub fn new(
        topics: &Topics,
        interfaces: &Interfaces,
        zid: &str,
        options: &ZenohOptions,
    ) -> Result<Names, RosError> {
        let domain = options.domain;
        let place = Place {
            domain,
            zid,
            namespace: &options.namespace,
            node: &options.node,
        };
        let namespace = mangle(options.namespace.trim_end_matches('/'));
        let node = &options.node;
        let mut tokens = vec![format!("@ros2_lv/{domain}/{zid}/0/0/NN/%/{namespace}/{node}")];
        let mut keys = Vec::new();
        let mut gids = Vec::new();
        for (k, topic) in topics.list.iter().enumerate() {
            let hash = interfaces
                .type_hash(topic.type_name)
                .ok_or(RosError::UnknownType(topic.type_name))?;
            let dds = dds_type(topic.type_name);
            keys.push(format!(
                "{domain}/{}/{dds}/{hash}",
                topic.name.trim_start_matches('/')
            ));
            let id = k + 1;
            tokens.push(place.token(id, "MP", &topic.name, &dds, &hash, &qos_string(topics.qos(k))));
            let digest = Sha256::digest(format!("{zid}/{id}").as_bytes());
            let mut gid = [0u8; 16];
            gid.copy_from_slice(&digest[..16]);
            gids.push(gid);
        }
        Ok(Names { keys, tokens, gids })
    }
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
    }
}

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
pub(super) fn mangle(name: &str) -> String {
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
            tokens.push(format!(
                "@ros2_lv/{domain}/{zid}/0/{id}/MP/%/{namespace}/{node}/{}/{dds}/{hash}/{}",
                mangle(&topic.name),
                qos_string(topics.qos(k))
            ));
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

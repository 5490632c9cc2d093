//! The names of skin's own node and publishers (the rules: [`crate::rmw_zenoh`]).

use super::ZenohOptions;
use crate::RosError;
use crate::interfaces::Interfaces;
pub(super) use crate::rmw_zenoh::{Place, attachment, dds_type, sender_of};
use crate::rmw_zenoh::{data_key, gid, node_token, qos_string};
use crate::topics::Topics;

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
        let mut tokens = vec![node_token(&place)];
        let mut keys = Vec::new();
        let mut gids = Vec::new();
        for (k, topic) in topics.list.iter().enumerate() {
            let hash = interfaces
                .type_hash(topic.type_name)
                .ok_or(RosError::UnknownType(topic.type_name))?;
            let dds = dds_type(topic.type_name);
            keys.push(data_key(domain, &topic.name, topic.type_name, &hash));
            let id = k + 1;
            tokens.push(place.token(id, "MP", &topic.name, &dds, &hash, &qos_string(topics.qos(k))));
            gids.push(gid(zid, id));
        }
        Ok(Names { keys, tokens, gids })
    }
}

//! RIHS01 type hashes (REP-2016), which rmw_zenoh puts in every key expression: a subscriber
//! matches a publisher only when both hash the type alike.
//!
//! The hash is SHA-256 over a JSON text of the type description: `{"type_description": T,
//! "referenced_type_descriptions": [R...]}`, where T and each R is `{"type_name": ..., "fields":
//! [{"name": ..., "type": {"type_id": ..., "capacity": ..., "string_capacity": ...,
//! "nested_type_name": ...}}]}`, the references being every type T nests (directly or not)
//! sorted by name, default values left out, keys in that order, written as Python's
//! `json.dumps` writes them (`", "` between items, `": "` after keys). A type without fields
//! gets one, `uint8 structure_needs_at_least_one_member`. Constants are not hashed.

use crate::interfaces::{Arity, BaseType, Definition, Interfaces};
use sha2::{Digest, Sha256};
use std::fmt::Write;

/// `type_description_interfaces/msg/FieldType` ids of the primitives. A `.msg` `char` is
/// rosidl's `uint8` (the IDL rosidl makes of a `.msg` writes it so): `std_srvs/srv/Trigger`'s
/// published hash, over `service_msgs/ServiceEventInfo`'s `char[16] client_gid`, holds only so.
fn primitive_id(name: &str) -> u8 {
    match name {
        "int8" => 2,
        "uint8" | "char" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        "wstring" => 18,
        _ => 0,
    }
}

impl Interfaces {
    /// The RIHS01 hash of `name` (REP-2016), `RIHS01_` and 64 hex digits; none when `name` is
    /// not defined.
    pub fn type_hash(&self, name: &str) -> Option<String> {
        rihs01(self, name)
    }
}

/// The hash of `name`, or none when it is not defined.
fn rihs01(all: &Interfaces, name: &str) -> Option<String> {
    let def = all.get(name)?;
    let mut json = String::from("{\"type_description\": ");
    describe(def, &mut json);
    json.push_str(", \"referenced_type_descriptions\": [");
    let mut nested = all.nested(name);
    nested.sort_by(|a, b| a.name.cmp(&b.name));
    for (k, d) in nested.iter().enumerate() {
        if k > 0 {
            json.push_str(", ");
        }
        describe(d, &mut json);
    }
    json.push_str("]}");
    let digest = Sha256::digest(json.as_bytes());
    let mut out = String::from("RIHS01_");
    for b in digest {
        let _ = write!(out, "{b:02x}");
    }
    Some(out)
}

fn describe(def: &Definition, json: &mut String) {
    let _ = write!(json, "{{\"type_name\": {}, \"fields\": [", quoted(&def.name));
    if def.fields.is_empty() {
        json.push_str(
            "{\"name\": \"structure_needs_at_least_one_member\", \"type\": {\"type_id\": 3, \"capacity\": 0, \"string_capacity\": 0, \"nested_type_name\": \"\"}}",
        );
    }
    for (k, f) in def.fields.iter().enumerate() {
        if k > 0 {
            json.push_str(", ");
        }
        let (id, string_capacity, nested) = match &f.base {
            BaseType::Primitive(p) => (primitive_id(p), 0, ""),
            BaseType::BoundedString(n) => (21, *n, ""),
            BaseType::Message(m) => (1, 0, m.as_str()),
        };
        let (offset, capacity) = match f.arity {
            Arity::Single => (0, 0),
            Arity::Array(n) => (48, n),
            Arity::Bounded(n) => (96, n),
            Arity::Sequence => (144, 0),
        };
        let _ = write!(
            json,
            "{{\"name\": {}, \"type\": {{\"type_id\": {}, \"capacity\": {capacity}, \"string_capacity\": {string_capacity}, \"nested_type_name\": {}}}}}",
            quoted(&f.name),
            u16::from(id) + offset,
            quoted(nested)
        );
    }
    json.push_str("]}");
}

/// A JSON string as Python writes it with `ensure_ascii` (names are ASCII: quotes and
/// backslashes are all there is to escape).
fn quoted(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_ascii() && !c.is_ascii_control() => out.push(c),
            c => {
                let mut units = [0u16; 2];
                for u in c.encode_utf16(&mut units) {
                    let _ = write!(out, "\\u{u:04x}");
                }
            }
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published with ROS 2 Jazzy (`ros2 interface show --hash`-style values, as rosbags and
    /// the rosidl generators compute them): a fixed point that does not depend on this code.
    #[test]
    fn known_hashes_of_standard_types() -> Result<(), crate::interfaces::DefinitionError> {
        let all = Interfaces::skin()?;
        assert_eq!(
            all.type_hash("builtin_interfaces/msg/Time").as_deref(),
            Some("RIHS01_b106235e25a4c5ed35098aa0a61a3ee9c9b18d197f398b0e4206cea9acf9c197")
        );
        // A service's hash covers its request, response and event types (rmw_zenoh's
        // service key expressions carry it); rmw_zenoh's design document gives Trigger's.
        assert_eq!(
            all.type_hash("std_srvs/srv/Trigger").as_deref(),
            Some("RIHS01_eeff2cd6fa5ad9d27cdf4dec64818317839b62f212a91e6b5304b634b2062c5f")
        );
        assert_eq!(
            all.type_hash("sensor_msgs/msg/JointState").as_deref(),
            Some("RIHS01_a13ee3a330e346c9d87b5aa18d24e11690752bd33a0350f11c5882bc9179260e")
        );
        Ok(())
    }
}

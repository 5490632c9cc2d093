//! ROS 2 over Zenoh for the package's Zenoh clients (`skin.sim.zenoh`): rmw_zenoh's names and
//! attachments and the CDR of the messages they send and read, each from skin-ros, the crate
//! `skin run` publishes with, so a Python peer and the skin agree by construction.

use crate::errors::{self, Kind, arg};
use crate::event::Event;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use skin_ros::cdr::CdrWriter;
use skin_ros::interfaces::Interfaces;
use skin_ros::messages::{self, Stamp};
use skin_ros::rmw_zenoh::{self, Place};
use skin_ros::topics::Qos;

/// The RIHS01 type hash of a message type skin knows (`sensor_msgs/msg/JointState`,
/// `skin_msgs/msg/TouchEvent`, ...).
#[pyfunction]
pub(crate) fn _ros_type_hash(type_name: &str) -> PyResult<String> {
    let all = Interfaces::skin().map_err(|e| errors::error(Kind::Input, e))?;
    all.type_hash(type_name).ok_or_else(|| {
        arg(
            "type_name",
            format!("{type_name:?} is not a message type skin knows"),
        )
    })
}

/// A `sensor_msgs/msg/JointState` at `time` (s on the robot's clock) as CDR: names, positions
/// (rad or m) and velocities (empty, or one per joint).
#[pyfunction]
#[pyo3(signature = (time, names, positions, velocities = Vec::new(), frame_id = ""))]
pub(crate) fn _ros_joint_state<'py>(
    py: Python<'py>,
    time: f64,
    names: Vec<String>,
    positions: Vec<f64>,
    velocities: Vec<f64>,
    frame_id: &str,
) -> PyResult<Bound<'py, PyBytes>> {
    let us = crate::session::seconds("time", time)?;
    let stamp = Stamp::from_ns(us.saturating_mul(1000))
        .ok_or_else(|| arg("time", "past the end of ROS 2 time (2038)"))?;
    if positions.len() != names.len() {
        return Err(arg(
            "positions",
            format!("{} for {} joints", positions.len(), names.len()),
        ));
    }
    if !velocities.is_empty() && velocities.len() != names.len() {
        return Err(arg(
            "velocities",
            format!("{} for {} joints", velocities.len(), names.len()),
        ));
    }
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let mut w = CdrWriter::new();
    messages::joint_state(&mut w, stamp, frame_id, &names, &positions, &velocities, &[]);
    Ok(PyBytes::new(py, w.bytes()))
}

/// The event a `skin_msgs/msg/TouchEvent` carries, as the session gave it (no image: decision
/// images travel on their own topic).
#[pyfunction]
pub(crate) fn _ros_event(cdr: &[u8]) -> PyResult<Event> {
    let (_, json) = skin_ros::decode::touch_event_json(cdr).map_err(|e| errors::error(Kind::Input, e))?;
    let mut fields = match serde_json::from_str(&json) {
        Ok(serde_json::Value::Object(fields)) => fields,
        _ => {
            return Err(errors::error(
                Kind::Input,
                "a TouchEvent whose json is not an event",
            ));
        }
    };
    let kind = match fields.remove("event") {
        Some(serde_json::Value::String(kind)) => kind,
        _ => {
            return Err(errors::error(
                Kind::Input,
                "a TouchEvent whose json names no event",
            ));
        }
    };
    Ok(Event::from_fields(kind, fields))
}

/// What rmw_zenoh names for entity `id` of `kind` (`MP` publisher, `MS` subscription) of a node
/// on `topic` of `type_name` with the `qos` skin offers ("events", "frames" or "latched"):
/// (data key expression, the node's liveliness token, the entity's, the entity's GID).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub(crate) fn _rmw_zenoh_entity<'py>(
    py: Python<'py>,
    domain: u32,
    zid: &str,
    namespace: &str,
    node: &str,
    id: usize,
    kind: &str,
    topic: &str,
    type_name: &str,
    qos: &str,
) -> PyResult<(String, String, String, Bound<'py, PyBytes>)> {
    if !matches!(kind, "MP" | "MS") {
        return Err(arg(
            "kind",
            format!("{kind:?}: MP (publisher) or MS (subscription)"),
        ));
    }
    let qos = match qos {
        "events" => Qos::Events,
        "frames" => Qos::Frames,
        "latched" => Qos::Latched,
        other => return Err(arg("qos", format!("{other:?}: events, frames or latched"))),
    };
    let topic = skin_ros::topics::check_prefix(topic).map_err(|e| arg("topic", e))?;
    let hash = _ros_type_hash(type_name)?;
    let place = Place {
        domain,
        zid,
        namespace,
        node,
    };
    let dds = rmw_zenoh::dds_type(type_name);
    let token = place.token(id, kind, &topic, &dds, &hash, &rmw_zenoh::qos_string(qos));
    Ok((
        rmw_zenoh::data_key(domain, &topic, type_name, &hash),
        rmw_zenoh::node_token(&place),
        token,
        PyBytes::new(py, &rmw_zenoh::gid(zid, id)),
    ))
}

/// rmw_zenoh's attachment of a sample: `seq`, the time now and the publisher's 16-byte `gid`.
#[pyfunction]
pub(crate) fn _rmw_zenoh_attachment<'py>(
    py: Python<'py>,
    seq: i64,
    gid: &[u8],
) -> PyResult<Bound<'py, PyBytes>> {
    let gid: [u8; 16] = gid
        .try_into()
        .map_err(|_| arg("gid", format!("{} bytes, a GID has 16", gid.len())))?;
    Ok(PyBytes::new(py, &rmw_zenoh::attachment(seq, &gid)))
}

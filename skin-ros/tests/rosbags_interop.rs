//! The messages and type hashes of skin-ros against rosbags, an independent ROS 2 reader
//! (`tests/rosbags_check.py`): each message's CDR bytes must equal rosbags' serialisation of the
//! same values, and each RIHS01 hash rosbags' `hash_rihs01`, standard types and `skin_msgs`
//! alike (registered from the repository's `.msg` files).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

skin_test_support::python_checks!(); // mod python: python_with, run

use serde_json::{Value, json};
use skin_ros::cdr::CdrWriter;
use skin_ros::interfaces::Interfaces;
use skin_ros::messages::{
    self, Arrow, ContactMsg, EventKind, FootprintMsg, HandPartMsg, PointCloud, Stamp, TouchEventMsg,
};
use skin_runtime::session::{Description, LinkDescription, Units};

const STAMP: Stamp = Stamp {
    sec: 1_700_000_123,
    nanosec: 456_789_000,
};

fn header(frame_id: &str) -> Value {
    json!({"stamp": {"sec": STAMP.sec, "nanosec": STAMP.nanosec}, "frame_id": frame_id})
}

fn xyz(p: [f64; 3]) -> Value {
    json!({"x": p[0], "y": p[1], "z": p[2]})
}

fn case(name: &str, ty: &str, value: Value, cdr: &[u8]) -> Value {
    let hex: String = cdr.iter().map(|b| format!("{b:02x}")).collect();
    json!({"name": name, "type": ty, "value": value, "cdr": hex})
}

fn image(encoding: &str, rows: u32, cols: u32, step: u32, data: Vec<u8>) -> Value {
    json!({"header": header("forearm"), "height": rows, "width": cols, "encoding": encoding,
           "is_bigendian": 0, "step": step, "data": data})
}

fn marker(frame: &str, id: i32, action: i32, points: &[[f64; 3]], scale: [f64; 3], color: [f32; 4]) -> Value {
    let empty_header = json!({"stamp": {"sec": 0, "nanosec": 0}, "frame_id": ""});
    json!({
        "header": header(frame), "ns": messages::MARKER_NS, "id": id, "type": 0, "action": action,
        "pose": {"position": xyz([0.0; 3]), "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
        "scale": xyz(scale), "color": {"r": color[0], "g": color[1], "b": color[2], "a": color[3]},
        "lifetime": {"sec": 0, "nanosec": 500_000_000}, "frame_locked": false,
        "points": points.iter().map(|p| xyz(*p)).collect::<Vec<_>>(), "colors": [],
        "texture_resource": "", "texture": {"header": empty_header, "format": "", "data": []},
        "uv_coordinates": [], "text": "", "mesh_resource": "",
        "mesh_file": {"filename": "", "data": []}, "mesh_use_embedded_materials": false,
    })
}

/// A link's cloud: positions, pressures and ids of three taxels.
fn cloud_case(out: &mut Vec<Value>) {
    let positions = [[0.01f32, -0.02, 0.3], [0.0, 0.0, 0.0], [-1.5, 2.25, 1e-3]];
    let ids = [17u32, 18, 4095];
    let pressures = [0.0f32, 123.5, 4096.25];
    let mut cloud = PointCloud::new("forearm", &positions, &ids);
    let bytes = cloud.fill(STAMP, &pressures).to_vec();
    let mut data = Vec::new();
    for ((p, id), v) in positions.iter().zip(ids).zip(pressures) {
        for c in p {
            data.extend_from_slice(&c.to_le_bytes());
        }
        data.extend_from_slice(&v.to_le_bytes());
        data.extend_from_slice(&id.to_le_bytes());
    }
    let field = |name: &str, offset: u32, datatype: u8| json!({"name": name, "offset": offset, "datatype": datatype, "count": 1});
    out.push(case(
        "pressure cloud",
        "sensor_msgs/msg/PointCloud2",
        json!({"header": header("forearm"), "height": 1, "width": 3,
               "fields": [field("x", 0, 7), field("y", 4, 7), field("z", 8, 7), field("pressure", 12, 7), field("id", 16, 6)],
               "is_bigendian": false, "point_step": 20, "row_step": 60, "data": data, "is_dense": true}),
        &bytes,
    ));
}

/// A decision image (mono8) and a pressure image (32FC1).
fn image_cases(w: &mut CdrWriter, out: &mut Vec<Value>) {
    let pixels: Vec<u8> = (0..12).map(|k| (k * 21) as u8).collect();
    messages::image_mono8(w, STAMP, "forearm", 3, 4, &pixels);
    out.push(case(
        "decision image",
        "sensor_msgs/msg/Image",
        image("mono8", 3, 4, 4, pixels.clone()),
        w.bytes(),
    ));

    let values = [0.0f32, 1.5, -2.0, 1e6, 3.25, 7.0];
    messages::image_32fc1(w, STAMP, "forearm", 2, 3, &values);
    let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    out.push(case(
        "pressure image",
        "sensor_msgs/msg/Image",
        image("32FC1", 2, 3, 12, raw),
        w.bytes(),
    ));
}

/// Two contact arrows after the DELETEALL marker.
fn arrow_case(w: &mut CdrWriter, out: &mut Vec<Value>) {
    let arrows = [
        Arrow {
            frame_id: "forearm",
            id: 0,
            start: [0.1, 0.2, 0.33],
            end: [0.1, 0.2, 0.3],
            color: [1.0, 0.25, 0.125, 1.0],
        },
        Arrow {
            frame_id: "upper arm",
            id: 1,
            start: [-0.5, 0.0, 0.0],
            end: [-0.47, 0.0, 0.0],
            color: [1.0, 0.25, 0.125, 1.0],
        },
    ];
    messages::arrows(w, STAMP, arrows.iter().copied());
    let mut markers = vec![marker("", 0, 3, &[], [0.0; 3], [0.0; 4])];
    for a in &arrows {
        markers.push(marker(
            a.frame_id,
            a.id,
            0,
            &[a.start, a.end],
            [0.004, 0.008, 0.006],
            a.color,
        ));
    }
    out.push(case(
        "contact arrows",
        "visualization_msgs/msg/MarkerArray",
        json!({"markers": markers}),
        w.bytes(),
    ));
}

/// Two contacts on two links.
fn contacts_case(w: &mut CdrWriter, out: &mut Vec<Value>) {
    let link_ids = [100u32, 101, 102, 103];
    let contacts = [
        ContactMsg {
            link: "forearm",
            position: [0.01, 0.02, 0.03],
            normal: [0.0, 0.6, 0.8],
            mean_pressure: 250.5,
            peak_pressure: 900.0,
            area: 2.5e-4,
            taxels: &[0, 2, 3],
            ids: &link_ids,
            force: 12.75,
        },
        ContactMsg {
            link: "palm",
            position: [-0.1, 0.0, 0.25],
            normal: [0.0; 3],
            mean_pressure: 12.0,
            peak_pressure: 12.0,
            area: 1e-5,
            taxels: &[1],
            ids: &link_ids,
            force: 0.0625,
        },
    ];
    messages::contacts(w, STAMP, contacts.iter().copied());
    let contact_values: Vec<Value> = contacts
        .iter()
        .map(|c| {
            json!({"header": header(c.link), "position": xyz(c.position), "normal": xyz(c.normal),
                   "mean_pressure": c.mean_pressure, "peak_pressure": c.peak_pressure, "area": c.area,
                   "taxels": c.taxels.iter().map(|&t| link_ids[t]).collect::<Vec<_>>(), "force": c.force})
        })
        .collect();
    out.push(case(
        "contacts",
        "skin_msgs/msg/Contacts",
        json!({"header": header(""), "contacts": contact_values}),
        w.bytes(),
    ));
}

/// A link's wrench.
fn wrench_case(w: &mut CdrWriter, out: &mut Vec<Value>) {
    let (force, torque) = ([0.5, -1.25, -9.75], [0.125, 0.0, -0.0625]);
    messages::wrench_stamped(w, STAMP, "upper arm", force, torque);
    out.push(case(
        "wrench",
        "geometry_msgs/msg/WrenchStamped",
        json!({"header": header("upper arm"), "wrench": {"force": xyz(force), "torque": xyz(torque)}}),
        w.bytes(),
    ));
}

/// A link's readings with a dead taxel (NaN there), and a two-link layout.
fn tactile_cases(w: &mut CdrWriter, out: &mut Vec<Value>) {
    messages::tactile_state(
        w,
        STAMP,
        ("upper_arm", "upper arm", "N"),
        [0.25f32, 7.5, 1.0].into_iter(),
        &[1],
    );
    out.push(case(
        "tactile_state",
        "skin_msgs/msg/TactileState",
        json!({"header": header("upper_arm"), "link": "upper arm", "units": "N",
               "readings": [0.25, f64::NAN, 1.0], "dead": [1]}),
        w.bytes(),
    ));
    let link = |name: &str, units| LinkDescription {
        name: name.into(),
        ids: vec![16, 17, 33],
        positions: vec![[0.01, 0.02, 0.03], [-0.5, 0.0, 1e-6], [0.0; 3]],
        normals: vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0; 3]],
        areas_m2: vec![1.25e-4, 0.5e-4, 0.0],
        modules: vec![1, 1, 2],
        units,
        calibration_id: if units == Units::Newtons {
            "force.json#forearm sha256:0011".into()
        } else {
            String::new()
        },
        dead: vec![2],
    };
    let d = Description {
        links: vec![link("forearm", Units::Newtons), link("upper arm", Units::Counts)],
        simulated: true,
        source: "run.toml".into(),
        touch_threshold_counts: 5.0,
    };
    messages::tactile_layout(w, STAMP, &d, &["forearm".into(), "upper_arm".into()]);
    let links: Vec<Value> = d
        .links
        .iter()
        .zip(["forearm", "upper_arm"])
        .map(|(l, frame)| {
            json!({"link": l.name, "frame_id": frame, "taxel_ids": l.ids,
                   "positions": l.positions.iter().map(|p| xyz(*p)).collect::<Vec<_>>(),
                   "normals": l.normals.iter().map(|p| xyz(*p)).collect::<Vec<_>>(),
                   "areas": l.areas_m2, "modules": l.modules, "units": l.units.name(),
                   "calibration_id": l.calibration_id, "touch_threshold_counts": 5.0})
        })
        .collect();
    out.push(case(
        "tactile_layout",
        "skin_msgs/msg/TactileLayout",
        json!({"header": header(""), "simulated": true, "source": "run.toml", "links": links}),
        w.bytes(),
    ));
}

/// A classified touch event with every field set.
fn event_case(w: &mut CdrWriter, out: &mut Vec<Value>) {
    let event = TouchEventMsg {
        kind: EventKind::Classified,
        touch: 7,
        link: "forearm",
        frame_id: "forearm",
        touch_class: "hand",
        probability: 0.875,
        revised: true,
        parts: vec![
            HandPartMsg {
                part: "thumb",
                taxels: 5,
                mean_pressure: 80.5,
                centroid: Some([0.01, 0.0, 0.2]),
            },
            HandPartMsg {
                part: "palm",
                taxels: 30,
                mean_pressure: 40.0,
                centroid: None,
            },
        ],
        footprint: FootprintMsg {
            contacts: 2,
            taxels: 35,
            area: 1.75e-3,
            mean_pressure: 45.25,
            centroid: [0.0, 0.01, 0.2],
        },
        duration: 1.25,
        frames: 62,
        action: "slow",
        links: vec!["forearm", "upper_arm"],
        missing: vec![("can0", 3), ("can1", 12)],
        bus: "can0",
        cycle: 1 << 40,
        json: "{\"event\":\"classified\",\"class\":\"hand\"}",
    };
    messages::touch_event(w, STAMP, &event);
    let parts: Vec<Value> = event
        .parts
        .iter()
        .map(|p| {
            json!({"part": p.part, "taxels": p.taxels, "mean_pressure": p.mean_pressure,
                   "has_centroid": p.centroid.is_some(), "centroid": xyz(p.centroid.unwrap_or_default())})
        })
        .collect();
    let f = event.footprint;
    out.push(case(
        "touch event",
        "skin_msgs/msg/TouchEvent",
        json!({"header": header("forearm"), "kind": 3, "touch": 7, "link": "forearm", "touch_class": "hand",
               "probability": 0.875, "revised": true, "parts": parts,
               "footprint": {"contacts": f.contacts, "taxels": f.taxels, "area": f.area, "mean_pressure": f.mean_pressure, "centroid": xyz(f.centroid)},
               "duration": 1.25, "frames": 62, "action": "slow", "links": ["forearm", "upper_arm"],
               "missing": [{"bus": "can0", "address": 3}, {"bus": "can1", "address": 12}],
               "bus": "can0", "cycle": 1u64 << 40, "json": event.json}),
        w.bytes(),
    ));
}

fn cases() -> Value {
    let mut w = CdrWriter::new();
    let mut out = Vec::new();
    cloud_case(&mut out);
    image_cases(&mut w, &mut out);
    arrow_case(&mut w, &mut out);
    contacts_case(&mut w, &mut out);
    wrench_case(&mut w, &mut out);
    event_case(&mut w, &mut out);
    tactile_cases(&mut w, &mut out);
    let all = Interfaces::skin().expect("definitions");
    let hashes: serde_json::Map<String, Value> = all
        .names()
        .map(|n| (n.to_owned(), Value::from(all.type_hash(n).unwrap_or_default())))
        .collect();
    json!({"messages": out, "hashes": hashes})
}

#[test]
fn cdr_bytes_and_type_hashes_equal_rosbags() {
    let cases = cases();
    let Some(python) = python::python_with("rosbags, numpy") else {
        return;
    };
    let dir = tempfile::tempdir().expect("temporary folder");
    let file = dir.path().join("cases.json");
    std::fs::write(&file, serde_json::to_vec(&cases).expect("json")).expect("write");
    let msgs = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../skin_msgs/msg");
    let out = python::run(&python, "rosbags_check.py", &[file.as_os_str(), msgs.as_os_str()]);
    eprintln!("{out}");
    assert!(out.contains("hashes checked"));
}

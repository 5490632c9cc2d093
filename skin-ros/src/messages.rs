//! The messages the skin publishes, written as CDR: `sensor_msgs/msg/PointCloud2` (a link's
//! taxels and their pressures), `sensor_msgs/msg/Image` (`mono8` decision images, `32FC1`
//! pressure images), `visualization_msgs/msg/MarkerArray` (contacts as arrows),
//! `skin_msgs/msg/Contacts` and `skin_msgs/msg/TouchEvent`. Every message starts with a
//! `std_msgs/msg/Header`: a [`Stamp`] and a frame id.
//!
//! Each encoder fills a reused [`CdrWriter`]; the point cloud of a link, whose layout never
//! changes, is written once ([`PointCloud`]) and only its stamp and pressures are patched per
//! frame.

use crate::cdr::CdrWriter;

/// A `builtin_interfaces/msg/Time`: seconds and nanoseconds since the epoch (or since whatever
/// origin the input's clock has).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Stamp {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds, below 1e9.
    pub nanosec: u32,
}

impl Stamp {
    /// From nanoseconds, exactly; `None` past the end of ROS 2 time (`i32::MAX` seconds, in
    /// 2038). The session sink ([`crate::RosSink`]) stamps a session's messages with it.
    pub fn from_ns(ns: u64) -> Option<Stamp> {
        Some(Stamp {
            sec: i32::try_from(ns / 1_000_000_000).ok()?,
            nanosec: (ns % 1_000_000_000) as u32,
        })
    }
}

fn header(w: &mut CdrWriter, stamp: Stamp, frame_id: &str) {
    w.i32(stamp.sec).u32(stamp.nanosec).string(frame_id);
}

fn point(w: &mut CdrWriter, p: [f64; 3]) {
    w.f64(p[0]).f64(p[1]).f64(p[2]);
}

/// An Image's fields before its data: header, size, encoding, little-endian, bytes a row.
fn image_head(
    w: &mut CdrWriter,
    stamp: Stamp,
    frame_id: &str,
    (rows, cols): (usize, usize),
    encoding: &str,
    pixel_bytes: usize,
) {
    w.start();
    header(w, stamp, frame_id);
    w.u32(rows as u32)
        .u32(cols as u32)
        .string(encoding)
        .u8(0)
        .u32((cols * pixel_bytes) as u32);
}

/// `sensor_msgs/msg/Image`, `mono8`: `rows * cols` grey pixels, row-major.
pub fn image_mono8(w: &mut CdrWriter, stamp: Stamp, frame_id: &str, rows: usize, cols: usize, pixels: &[u8]) {
    image_head(w, stamp, frame_id, (rows, cols), "mono8", 1);
    w.bytes_seq(pixels);
}

/// `sensor_msgs/msg/Image`, `32FC1` (little-endian floats): `rows * cols` values, row-major.
pub fn image_32fc1(
    w: &mut CdrWriter,
    stamp: Stamp,
    frame_id: &str,
    rows: usize,
    cols: usize,
    values: &[f32],
) {
    image_head(w, stamp, frame_id, (rows, cols), "32FC1", 4);
    w.seq_len(values.len() * 4);
    for v in values {
        w.raw(&v.to_le_bytes());
    }
}

/// `sensor_msgs/msg/PointCloud2` of one link: one point per taxel with fields `x y z`
/// (float32, m, link frame), `pressure` (float32, counts above the baseline) and `id` (uint32,
/// the taxel's id); 20 bytes a point, unorganised (height 1), dense. Written once; each frame
/// patches the stamp and the pressures in place.
#[derive(Debug, Clone)]
pub struct PointCloud {
    bytes: Vec<u8>,
    /// Where the stamp's 8 bytes are.
    stamp_at: usize,
    /// Where the first point's pressure is.
    pressure_at: usize,
    points: usize,
}

/// Bytes per point of a [`PointCloud`].
pub const POINT_STEP: usize = 20;

impl PointCloud {
    /// The cloud of taxels at `positions` (m) with ids `ids` (same length), in frame `frame_id`.
    pub fn new(frame_id: &str, positions: &[[f32; 3]], ids: &[u32]) -> PointCloud {
        let n = positions.len().min(ids.len());
        let mut w = CdrWriter::new();
        w.start();
        let stamp_at = w.bytes().len();
        header(&mut w, Stamp::default(), frame_id);
        w.u32(1).u32(n as u32);
        w.seq_len(5);
        // sensor_msgs/PointField: name, offset, datatype (FLOAT32 = 7, UINT32 = 6), count.
        for (name, offset, datatype) in [
            ("x", 0, 7),
            ("y", 4, 7),
            ("z", 8, 7),
            ("pressure", 12, 7),
            ("id", 16, 6),
        ] {
            w.string(name).u32(offset).u8(datatype).u32(1);
        }
        w.bool(false).u32(POINT_STEP as u32).u32((POINT_STEP * n) as u32);
        w.seq_len(POINT_STEP * n);
        let data_at = w.bytes().len();
        for (p, id) in positions.iter().zip(ids) {
            for c in p {
                w.raw(&c.to_le_bytes());
            }
            w.raw(&0f32.to_le_bytes()).raw(&id.to_le_bytes());
        }
        w.bool(true);
        PointCloud {
            bytes: w.bytes().to_vec(),
            stamp_at,
            pressure_at: data_at + 12,
            points: n,
        }
    }

    /// The message with `stamp` and `pressures` (one per taxel; missing ones read 0). Allocates
    /// nothing.
    pub fn fill(&mut self, stamp: Stamp, pressures: &[f32]) -> &[u8] {
        self.bytes[self.stamp_at..self.stamp_at + 4].copy_from_slice(&stamp.sec.to_le_bytes());
        self.bytes[self.stamp_at + 4..self.stamp_at + 8].copy_from_slice(&stamp.nanosec.to_le_bytes());
        for k in 0..self.points {
            let at = self.pressure_at + k * POINT_STEP;
            let p = pressures.get(k).copied().unwrap_or(0.0);
            self.bytes[at..at + 4].copy_from_slice(&p.to_le_bytes());
        }
        &self.bytes
    }

    /// Points (taxels).
    pub fn len(&self) -> usize {
        self.points
    }

    /// True for a link without taxels.
    pub fn is_empty(&self) -> bool {
        self.points == 0
    }
}

/// One `skin_msgs/msg/Contact`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactMsg<'a> {
    /// The link's frame id.
    pub link: &'a str,
    /// Pressure-weighted centroid, m, link frame.
    pub position: [f64; 3],
    /// Outward unit normal, or zero.
    pub normal: [f64; 3],
    /// Mean pressure, counts above the baseline.
    pub mean_pressure: f32,
    /// Largest pressure, counts above the baseline.
    pub peak_pressure: f32,
    /// Area, m².
    pub area: f32,
    /// Layout indices of its taxels (into `ids`).
    pub taxels: &'a [usize],
    /// The link's taxel ids, layout order.
    pub ids: &'a [u32],
    /// Force, N; NaN on a link without a force calibration.
    pub force: f64,
}

/// `skin_msgs/msg/Contacts`: the frame's contacts (frame id empty: each names its link).
pub fn contacts<'a>(
    w: &mut CdrWriter,
    stamp: Stamp,
    contacts: impl ExactSizeIterator<Item = ContactMsg<'a>>,
) {
    w.start();
    header(w, stamp, "");
    w.seq_len(contacts.len());
    for c in contacts {
        header(w, stamp, c.link);
        point(w, c.position);
        point(w, c.normal);
        w.f32(c.mean_pressure).f32(c.peak_pressure).f32(c.area);
        w.seq_len(c.taxels.len());
        for &t in c.taxels {
            w.u32(c.ids.get(t).copied().unwrap_or(u32::MAX));
        }
        w.f64(c.force);
    }
}

/// `geometry_msgs/msg/WrenchStamped`: the load on a link (its contacts' force and torque about
/// its frame's origin, N and N m) in the link's frame.
pub fn wrench_stamped(w: &mut CdrWriter, stamp: Stamp, frame_id: &str, force: [f64; 3], torque: [f64; 3]) {
    w.start();
    header(w, stamp, frame_id);
    point(w, force);
    point(w, torque);
}

/// An RViz arrow from `start` to `end`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arrow<'a> {
    /// The frame the points are in.
    pub frame_id: &'a str,
    /// Marker id, unique within the array's namespace.
    pub id: i32,
    /// Tail, m.
    pub start: [f64; 3],
    /// Head, m.
    pub end: [f64; 3],
    /// Colour, RGBA in 0..1.
    pub color: [f32; 4],
}

/// The namespace of the contact arrows.
pub const MARKER_NS: &str = "skin_contacts";

/// `visualization_msgs/msg/MarkerArray`: a DELETEALL marker (earlier arrows go), then an ARROW
/// per contact (shaft 4 mm, head 8 mm wide and 6 mm long), kept 0.5 s unless replaced.
pub fn arrows<'a>(w: &mut CdrWriter, stamp: Stamp, arrows: impl ExactSizeIterator<Item = Arrow<'a>>) {
    w.start();
    w.seq_len(arrows.len() + 1);
    // DELETEALL (action 3) of the namespace.
    marker(w, stamp, "", 0, 0, 3, None, [0.0; 4]);
    for a in arrows {
        marker(w, stamp, a.frame_id, a.id, 0, 0, Some((a.start, a.end)), a.color);
    }
}

#[allow(clippy::too_many_arguments)]
fn marker(
    w: &mut CdrWriter,
    stamp: Stamp,
    frame_id: &str,
    id: i32,
    kind: i32,
    action: i32,
    points: Option<([f64; 3], [f64; 3])>,
    color: [f32; 4],
) {
    header(w, stamp, frame_id);
    w.string(MARKER_NS).i32(id).i32(kind).i32(action);
    // pose: position 0, orientation identity
    point(w, [0.0; 3]);
    w.f64(0.0).f64(0.0).f64(0.0).f64(1.0);
    // scale: shaft diameter, head diameter, head length
    if points.is_some() {
        point(w, [0.004, 0.008, 0.006]);
    } else {
        point(w, [0.0; 3]);
    }
    for c in color {
        w.f32(c);
    }
    // lifetime 0.5 s, frame_locked
    w.i32(0).u32(500_000_000).bool(false);
    match points {
        Some((a, b)) => {
            w.seq_len(2);
            point(w, a);
            point(w, b);
        }
        None => {
            w.seq_len(0);
        }
    }
    // colors, texture_resource, texture (CompressedImage: header, format, data), uv_coordinates,
    // text, mesh_resource, mesh_file (filename, data), mesh_use_embedded_materials
    w.seq_len(0).string("");
    header(w, Stamp::default(), "");
    w.string("").seq_len(0).seq_len(0).string("").string("");
    w.string("").seq_len(0).bool(false);
}

/// A hand part of a `skin_msgs/msg/TouchEvent`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandPartMsg<'a> {
    /// thumb, index, middle, ring, little or palm.
    pub part: &'a str,
    /// Taxels it presses.
    pub taxels: u32,
    /// Mean pressure, counts.
    pub mean_pressure: f32,
    /// Centroid, m, link frame.
    pub centroid: Option<[f64; 3]>,
}

/// A `skin_msgs/msg/Footprint`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FootprintMsg {
    /// Separate contacts.
    pub contacts: u32,
    /// Pressed taxels.
    pub taxels: u32,
    /// Area, m².
    pub area: f32,
    /// Mean pressure, counts.
    pub mean_pressure: f32,
    /// Centroid, m, link frame.
    pub centroid: [f64; 3],
}

/// Which event a `skin_msgs/msg/TouchEvent` is (its constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum EventKind {
    /// `INCOMPLETE`.
    Incomplete = 0,
    /// `COUNTER_RESET`.
    CounterReset = 1,
    /// `APPEARED`.
    Appeared = 2,
    /// `CLASSIFIED`.
    Classified = 3,
    /// `RELEASED`.
    Released = 4,
    /// `GATE`.
    Gate = 5,
    /// `ACROSS_JOINT`.
    AcrossJoint = 6,
    /// `ACROSS_JOINT_END`.
    AcrossJointEnd = 7,
    /// `BASELINE_CORRECTED`.
    BaselineCorrected = 8,
    /// `TARE`.
    Tare = 9,
    /// `JOINT_STATES`.
    JointStates = 10,
}

/// A `skin_msgs/msg/TouchEvent` (fields a kind does not use stay empty or zero).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchEventMsg<'a> {
    /// Which event.
    pub kind: EventKind,
    /// Touch number.
    pub touch: u64,
    /// The link, as events.jsonl names it.
    pub link: &'a str,
    /// The header's frame id: the link's ([`crate::topics::Topics::frame_ids`]), empty for an
    /// event of no link.
    pub frame_id: &'a str,
    /// Class name.
    pub touch_class: &'a str,
    /// Class probability, NaN when none.
    pub probability: f32,
    /// The class changed.
    pub revised: bool,
    /// Hand parts.
    pub parts: Vec<HandPartMsg<'a>>,
    /// Footprint.
    pub footprint: FootprintMsg,
    /// Duration, s.
    pub duration: f64,
    /// Frames of contact.
    pub frames: u32,
    /// Gate action.
    pub action: &'a str,
    /// Links of a contact across joints.
    pub links: Vec<&'a str>,
    /// Missing modules (bus, address).
    pub missing: Vec<(&'a str, u32)>,
    /// Bus of a counter restart.
    pub bus: &'a str,
    /// Cycle after a counter restart.
    pub cycle: u64,
    /// The events.jsonl line.
    pub json: &'a str,
}

impl Default for TouchEventMsg<'_> {
    fn default() -> Self {
        TouchEventMsg {
            kind: EventKind::Appeared,
            touch: 0,
            link: "",
            frame_id: "",
            touch_class: "",
            probability: f32::NAN,
            revised: false,
            parts: Vec::new(),
            footprint: FootprintMsg::default(),
            duration: 0.0,
            frames: 0,
            action: "",
            links: Vec::new(),
            missing: Vec::new(),
            bus: "",
            cycle: 0,
            json: "",
        }
    }
}

/// `skin_msgs/msg/TouchEvent`.
pub fn touch_event(w: &mut CdrWriter, stamp: Stamp, e: &TouchEventMsg<'_>) {
    w.start();
    header(w, stamp, e.frame_id);
    w.u8(e.kind as u8)
        .u64(e.touch)
        .string(e.link)
        .string(e.touch_class);
    w.f32(e.probability).bool(e.revised);
    w.seq_len(e.parts.len());
    for p in &e.parts {
        w.string(p.part).u32(p.taxels).f32(p.mean_pressure);
        w.bool(p.centroid.is_some());
        point(w, p.centroid.unwrap_or_default());
    }
    let f = &e.footprint;
    w.u32(f.contacts).u32(f.taxels).f32(f.area).f32(f.mean_pressure);
    point(w, f.centroid);
    w.f64(e.duration).u32(e.frames).string(e.action);
    w.seq_len(e.links.len());
    for l in &e.links {
        w.string(l);
    }
    w.seq_len(e.missing.len());
    for (bus, address) in &e.missing {
        w.string(bus).u32(*address);
    }
    w.string(e.bus).u64(e.cycle).string(e.json);
}

/// `skin_msgs/msg/TactileState`: one link's readings in one frame, in `units`, one per taxel;
/// a taxel of `dead` (increasing layout indices) reads NaN.
pub fn tactile_state(
    w: &mut CdrWriter,
    stamp: Stamp,
    (frame_id, link, units): (&str, &str, &str),
    readings: impl ExactSizeIterator<Item = f32>,
    dead: &[usize],
) {
    w.start();
    header(w, stamp, frame_id);
    w.string(link).string(units);
    w.seq_len(readings.len());
    let mut next_dead = dead.iter().copied().peekable();
    for (i, v) in readings.enumerate() {
        let v = if next_dead.next_if_eq(&i).is_some() {
            f32::NAN
        } else {
            v
        };
        w.f32(v);
    }
    w.seq_len(dead.len());
    for &d in dead {
        w.u32(u32::try_from(d).unwrap_or(u32::MAX));
    }
}

/// `skin_msgs/msg/TactileLayout`: the skin described ([`skin_runtime::session::Description`]),
/// each link in the frame `frame_ids` gives it.
pub fn tactile_layout(
    w: &mut CdrWriter,
    stamp: Stamp,
    d: &skin_runtime::session::Description,
    frame_ids: &[String],
) {
    w.start();
    header(w, stamp, "");
    w.bool(d.simulated).string(&d.source);
    w.seq_len(d.links.len());
    for (l, link) in d.links.iter().enumerate() {
        w.string(&link.name)
            .string(frame_ids.get(l).map_or(link.name.as_str(), String::as_str));
        w.seq_len(link.ids.len());
        for &id in &link.ids {
            w.u32(id);
        }
        w.seq_len(link.positions.len());
        for &p in &link.positions {
            point(w, p);
        }
        w.seq_len(link.normals.len());
        for &n in &link.normals {
            point(w, n);
        }
        w.seq_len(link.areas_m2.len());
        for &a in &link.areas_m2 {
            w.f32(a as f32);
        }
        w.seq_len(link.modules.len());
        for &m in &link.modules {
            w.u32(m);
        }
        w.string(link.units.name())
            .string(&link.calibration_id)
            .f32(d.touch_threshold_counts);
    }
}

/// `sensor_msgs/msg/JointState`: joint `names` with their `positions` (rad or m), and
/// `velocities` and `efforts` (each empty, or one per joint), as a robot driver publishes them
/// (skin reads them back with [`crate::decode::joint_state`]).
pub fn joint_state(
    w: &mut CdrWriter,
    stamp: Stamp,
    frame_id: &str,
    names: &[&str],
    positions: &[f64],
    velocities: &[f64],
    efforts: &[f64],
) {
    w.start();
    header(w, stamp, frame_id);
    w.seq_len(names.len());
    for n in names {
        w.string(n);
    }
    for values in [positions, velocities, efforts] {
        w.seq_len(values.len());
        for &v in values {
            w.f64(v);
        }
    }
}

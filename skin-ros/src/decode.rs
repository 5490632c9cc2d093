//! Reading back the messages skin writes (for a replay of its MCAP files: `skin view`): the
//! point cloud of a link's pressures, the frame's contacts, and the events.jsonl line a touch
//! event carries. Every length is checked against the bytes there are before it sizes
//! anything; a message that is not what skin writes is an error, never a panic.

use crate::cdr::CDR_LE;
use crate::messages::Stamp;

/// A message that cannot be read as the type it was taken for.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what}: {why} (at byte {at})")]
pub struct DecodeError {
    /// The message type.
    pub what: &'static str,
    /// What is wrong.
    pub why: String,
    /// Where, counting from the message's first byte.
    pub at: usize,
}

/// Reads plain little-endian CDR, each field aligned to its size from the end of the
/// encapsulation header.
#[derive(Debug)]
pub struct CdrReader<'a> {
    bytes: &'a [u8],
    at: usize,
    what: &'static str,
}

impl<'a> CdrReader<'a> {
    /// A message of type `what` (named in errors); checks its encapsulation header.
    pub fn new(bytes: &'a [u8], what: &'static str) -> Result<CdrReader<'a>, DecodeError> {
        let r = CdrReader { bytes, at: 4, what };
        if bytes.get(..4) != Some(&CDR_LE[..]) {
            return Err(r.error("not little-endian plain CDR"));
        }
        Ok(r)
    }

    fn error(&self, why: impl Into<String>) -> DecodeError {
        DecodeError {
            what: self.what,
            why: why.into(),
            at: self.at,
        }
    }

    fn take(&mut self, n: usize, align: usize) -> Result<&'a [u8], DecodeError> {
        let pad = (align - (self.at - 4) % align) % align;
        let start = self.at + pad;
        let end = start
            .checked_add(n)
            .ok_or_else(|| self.error("length overflows"))?;
        let out = self
            .bytes
            .get(start..end)
            .ok_or_else(|| self.error("cut short"))?;
        self.at = end;
        Ok(out)
    }

    /// A `u8`.
    pub fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1, 1)?[0])
    }

    /// A `u32`.
    pub fn u32(&mut self) -> Result<u32, DecodeError> {
        let b = self.take(4, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// An `i32`.
    pub fn i32(&mut self) -> Result<i32, DecodeError> {
        self.u32().map(|v| v as i32)
    }

    /// An `f32`.
    pub fn f32(&mut self) -> Result<f32, DecodeError> {
        self.u32().map(f32::from_bits)
    }

    /// A `u64`.
    pub fn u64(&mut self) -> Result<u64, DecodeError> {
        let b = self.take(8, 8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(u64::from_le_bytes(a))
    }

    /// An `f64`.
    pub fn f64(&mut self) -> Result<f64, DecodeError> {
        self.u64().map(f64::from_bits)
    }

    /// A sequence's length, checked against the bytes left (`each` bytes an element at least).
    pub fn seq_len(&mut self, each: usize) -> Result<usize, DecodeError> {
        let n = self.u32()? as usize;
        let left = self.bytes.len().saturating_sub(self.at);
        if n.saturating_mul(each.max(1)) > left {
            return Err(self.error(format!("a sequence of {n} elements in {left} bytes")));
        }
        Ok(n)
    }

    /// A string (its length counts the terminating NUL).
    pub fn string(&mut self) -> Result<&'a str, DecodeError> {
        let n = self.seq_len(1)?;
        let b = self.take(n, 1)?;
        let b = b
            .strip_suffix(&[0])
            .ok_or_else(|| self.error("a string without its NUL"))?;
        std::str::from_utf8(b).map_err(|_| self.error("a string that is not UTF-8"))
    }

    /// Raw bytes.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        self.take(n, 1)
    }

    /// A `std_msgs/Header`: stamp and frame id.
    pub fn header(&mut self) -> Result<(Stamp, &'a str), DecodeError> {
        let sec = self.i32()?;
        let nanosec = self.u32()?;
        Ok((Stamp { sec, nanosec }, self.string()?))
    }

    /// Three `f64`.
    pub fn point(&mut self) -> Result<[f64; 3], DecodeError> {
        Ok([self.f64()?, self.f64()?, self.f64()?])
    }
}

/// Joints a `sensor_msgs/JointState` may name (a humanoid has under a hundred): a longer
/// message is refused before anything is sized by it.
pub const MAX_JOINTS: usize = 4096;

/// A `sensor_msgs/msg/JointState`, read: its stamp, joint names and positions (velocities
/// and efforts are checked, not kept).
#[derive(Debug, Clone, PartialEq)]
pub struct JointStateRead<'a> {
    /// The header's stamp.
    pub stamp: Stamp,
    /// Joint names.
    pub names: Vec<&'a str>,
    /// Positions, rad or m (as many as the names in a well-formed message).
    pub positions: Vec<f64>,
}

/// Reads a `sensor_msgs/msg/JointState` from anyone (rmw_zenoh, a bag): every length checked
/// against the bytes there are and against [`MAX_JOINTS`].
pub fn joint_state(bytes: &[u8]) -> Result<JointStateRead<'_>, DecodeError> {
    let mut r = CdrReader::new(bytes, "sensor_msgs/msg/JointState")?;
    let (stamp, _frame_id) = r.header()?;
    let joints = |r: &mut CdrReader<'_>, each| {
        let n = r.seq_len(each)?;
        if n > MAX_JOINTS {
            return Err(r.error(format!("{n} joints, more than {MAX_JOINTS}")));
        }
        Ok(n)
    };
    let n = joints(&mut r, 5)?;
    let names = (0..n).map(|_| r.string()).collect::<Result<Vec<_>, _>>()?;
    let n = joints(&mut r, 8)?;
    let positions = (0..n).map(|_| r.f64()).collect::<Result<Vec<_>, _>>()?;
    for _ in 0..2 {
        let n = joints(&mut r, 8)?;
        for _ in 0..n {
            r.f64()?;
        }
    }
    Ok(JointStateRead {
        stamp,
        names,
        positions,
    })
}

/// A link's point cloud as skin writes it ([`crate::messages::PointCloud`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Cloud {
    /// The header's stamp.
    pub stamp: Stamp,
    /// The header's frame id (the link).
    pub frame_id: String,
    /// Each point's `x y z`, m.
    pub positions: Vec<[f32; 3]>,
    /// Each point's `pressure`, counts above the baseline.
    pub pressures: Vec<f32>,
    /// Each point's `id`.
    pub ids: Vec<u32>,
    /// Where the message keeps its pressures (for [`cloud_pressures`] on the link's next ones).
    pub layout: CloudLayout,
}

/// Reads a `sensor_msgs/msg/PointCloud2` with float32 fields `x y z pressure` and a uint32
/// field `id` (skin's own clouds; the fields may be in any order).
pub fn point_cloud(bytes: &[u8]) -> Result<Cloud, DecodeError> {
    let mut r = CdrReader::new(bytes, "sensor_msgs/msg/PointCloud2")?;
    let (stamp, frame_id) = r.header()?;
    let (height, width) = (r.u32()? as usize, r.u32()? as usize);
    let fields = r.seq_len(13)?;
    let mut offsets = [None; 5];
    for _ in 0..fields {
        let name = r.string()?;
        let offset = r.u32()? as usize;
        let datatype = r.u8()?;
        let _count = r.u32()?;
        let (slot, want) = match name {
            "x" => (0, 7),
            "y" => (1, 7),
            "z" => (2, 7),
            "pressure" => (3, 7),
            "id" => (4, 6),
            _ => continue,
        };
        if datatype != want {
            return Err(r.error(format!("field {name} has datatype {datatype}, not {want}")));
        }
        offsets[slot] = Some(offset);
    }
    let _big_endian = r.u8()?;
    let step = r.u32()? as usize;
    let _row_step = r.u32()?;
    let len = r.seq_len(1)?;
    let data_at = r.at;
    let data = r.bytes(len)?;
    let _dense = r.u8()?;
    let points = height
        .checked_mul(width)
        .filter(|&n| step.checked_mul(n) == Some(len))
        .ok_or_else(|| {
            r.error(format!(
                "{height} x {width} points of {step} bytes are not {len} bytes"
            ))
        })?;
    let mut at = [0usize; 5];
    for (k, o) in offsets.iter().enumerate() {
        let name = ["x", "y", "z", "pressure", "id"][k];
        at[k] = o
            .filter(|&o| o.checked_add(4).is_some_and(|e| e <= step))
            .ok_or_else(|| r.error(format!("no field {name} within a point")))?;
    }
    let word = |p: usize, k: usize| {
        let s = p * step + at[k];
        u32::from_le_bytes([data[s], data[s + 1], data[s + 2], data[s + 3]])
    };
    Ok(Cloud {
        stamp,
        frame_id: frame_id.to_owned(),
        positions: (0..points)
            .map(|p| [0, 1, 2].map(|k| f32::from_bits(word(p, k))))
            .collect(),
        pressures: (0..points).map(|p| f32::from_bits(word(p, 3))).collect(),
        ids: (0..points).map(|p| word(p, 4)).collect(),
        layout: CloudLayout {
            data_at,
            step,
            pressure_at: at[3],
            points,
            len: bytes.len(),
        },
    })
}

/// Writes the pressures of a cloud with the layout of `like` into `out` (one per point) without
/// reading anything else again: a replay's per-frame read. Fails if the message is not laid out
/// as `like` (another number of points, or other offsets).
pub fn cloud_pressures(bytes: &[u8], layout: &CloudLayout, out: &mut [f32]) -> Result<Stamp, DecodeError> {
    let mut r = CdrReader::new(bytes, "sensor_msgs/msg/PointCloud2")?;
    let (stamp, _) = r.header()?;
    // The same length, and the same length of data where the first cloud had it: the same
    // frame id, points and fields, so the pressures are where they were.
    let data_len = layout.step.checked_mul(layout.points);
    let declared = layout
        .data_at
        .checked_sub(4)
        .and_then(|at| bytes.get(at..at + 4))
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
    if bytes.len() != layout.len || out.len() != layout.points || declared != data_len {
        return Err(r.error("not laid out as the link's first cloud"));
    }
    for (k, p) in out.iter_mut().enumerate() {
        let s = layout.data_at + k * layout.step + layout.pressure_at;
        let b = bytes.get(s..s + 4).ok_or_else(|| r.error("cut short"))?;
        *p = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
    }
    Ok(stamp)
}

/// Where a link's cloud keeps its pressures (the same in every message of the link: only the
/// stamp and the pressures change).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CloudLayout {
    /// Byte of the first point.
    pub data_at: usize,
    /// Bytes a point.
    pub step: usize,
    /// The pressure's byte within a point.
    pub pressure_at: usize,
    /// Points.
    pub points: usize,
    /// The whole message's length.
    pub len: usize,
}

impl CloudLayout {
    /// The layout of a cloud message of skin's; checks it by reading it whole.
    pub fn of(bytes: &[u8]) -> Result<CloudLayout, DecodeError> {
        point_cloud(bytes).map(|c| c.layout)
    }
}

/// One contact of a `skin_msgs/msg/Contacts`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactRead {
    /// The link's frame id.
    pub link: String,
    /// Pressure-weighted centroid, m, link frame.
    pub position: [f64; 3],
    /// Mean pressure, counts.
    pub mean_pressure: f32,
    /// Largest pressure, counts.
    pub peak_pressure: f32,
    /// Its taxels' ids.
    pub taxel_ids: Vec<u32>,
    /// Its force, N; none on a link without a force calibration, or in a file written before
    /// contacts carried force.
    pub force: Option<f64>,
}

/// Whether a `skin_msgs/msg/Contacts` schema (its `ros2msg` text, as an MCAP file carries it)
/// gives each contact its force: files written before newtons do not.
pub fn contacts_have_force(schema: &str) -> bool {
    schema.lines().any(|l| l.trim() == "float64 force")
}

/// Reads a `skin_msgs/msg/Contacts`; `with_force`: its contacts end with their force
/// ([`contacts_have_force`] of its schema; every message this version writes).
pub fn contacts(bytes: &[u8], with_force: bool) -> Result<(Stamp, Vec<ContactRead>), DecodeError> {
    let mut r = CdrReader::new(bytes, "skin_msgs/msg/Contacts")?;
    let (stamp, _) = r.header()?;
    let n = r.seq_len(70)?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let (_, link) = r.header()?;
        let position = r.point()?;
        let _normal = r.point()?;
        let mean_pressure = r.f32()?;
        let peak_pressure = r.f32()?;
        let _area = r.f32()?;
        let k = r.seq_len(4)?;
        let taxel_ids = (0..k).map(|_| r.u32()).collect::<Result<_, _>>()?;
        let force = match with_force {
            true => Some(r.f64()?).filter(|f| f.is_finite()),
            false => None,
        };
        out.push(ContactRead {
            link: link.to_owned(),
            position,
            mean_pressure,
            peak_pressure,
            taxel_ids,
            force,
        });
    }
    Ok((stamp, out))
}

/// Reads a `skin_msgs/msg/TouchEvent` as far as its stamp and its last field, the events.jsonl
/// line it was made from.
pub fn touch_event_json(bytes: &[u8]) -> Result<(Stamp, String), DecodeError> {
    let mut r = CdrReader::new(bytes, "skin_msgs/msg/TouchEvent")?;
    let (stamp, _) = r.header()?;
    r.u8()?;
    r.u64()?;
    r.string()?;
    r.string()?;
    r.f32()?;
    r.u8()?;
    for _ in 0..r.seq_len(20)? {
        r.string()?;
        r.u32()?;
        r.f32()?;
        r.u8()?;
        r.point()?;
    }
    r.u32()?;
    r.u32()?;
    r.f32()?;
    r.f32()?;
    r.point()?;
    r.f64()?;
    r.u32()?;
    r.string()?;
    for _ in 0..r.seq_len(5)? {
        r.string()?;
    }
    for _ in 0..r.seq_len(9)? {
        r.string()?;
        r.u32()?;
    }
    r.string()?;
    r.u64()?;
    let json = r.string()?.to_owned();
    Ok((stamp, json))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use crate::cdr::CdrWriter;
    use crate::messages::{self, ContactMsg, EventKind, PointCloud, TouchEventMsg};

    /// A JointState as a robot driver writes it ([`messages::joint_state`]; rosbags' serialisation
    /// is checked against it in the Python package's Zenoh test).
    fn joint_state_cdr(names: &[&str], positions: &[f64], velocities: usize) -> Vec<u8> {
        let mut w = CdrWriter::new();
        let stamp = Stamp {
            sec: 1_700_000_001,
            nanosec: 500,
        };
        messages::joint_state(
            &mut w,
            stamp,
            "base",
            names,
            positions,
            &vec![0.25; velocities],
            &[],
        );
        w.bytes().to_vec()
    }

    #[test]
    fn a_joint_state_is_written_field_by_field() {
        // CDR by hand: encapsulation, header (sec, nanosec, "base"), one name, one position,
        // no velocities, no efforts.
        let mut want = crate::cdr::CDR_LE.to_vec();
        want.extend(1_700_000_001i32.to_le_bytes());
        want.extend(500u32.to_le_bytes());
        want.extend(5u32.to_le_bytes());
        want.extend(b"base\0");
        want.extend([0, 0, 0]);
        want.extend(1u32.to_le_bytes());
        want.extend(2u32.to_le_bytes());
        want.extend(b"j\0");
        want.extend([0, 0]);
        want.extend(1u32.to_le_bytes());
        want.extend([0, 0, 0, 0]);
        want.extend(0.5f64.to_le_bytes());
        want.extend(0u32.to_le_bytes());
        want.extend(0u32.to_le_bytes());
        assert_eq!(joint_state_cdr(&["j"], &[0.5], 0), want);
    }

    #[test]
    fn joint_states_read_back_and_lies_about_lengths_are_refused() {
        let bytes = joint_state_cdr(&["wrist_roll", "j2"], &[0.5, -1.0], 2);
        let back = joint_state(&bytes).unwrap();
        assert_eq!(
            back.stamp,
            Stamp {
                sec: 1_700_000_001,
                nanosec: 500
            }
        );
        assert_eq!(back.names, ["wrist_roll", "j2"]);
        assert_eq!(back.positions, [0.5, -1.0]);
        // A name count that claims more than the bytes: refused before any allocation.
        let mut lie = bytes.clone();
        let at = 4 + 8 + 4 + 5 + 3;
        lie[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(joint_state(&lie).is_err());
        for cut in 0..bytes.len() {
            assert!(joint_state(&bytes[..cut]).is_err(), "cut at {cut}");
        }
    }

    proptest::proptest! {
        #[test]
        fn any_bytes_read_as_a_joint_state_never_panic(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..256)) {
            let mut framed = crate::cdr::CDR_LE.to_vec();
            framed.extend_from_slice(&bytes);
            let _ = joint_state(&framed);
            let _ = joint_state(&bytes);
        }
    }

    #[test]
    fn a_cloud_reads_back_what_was_written() {
        let mut cloud = PointCloud::new("forearm", &[[0.1, 0.2, 0.3], [-1.0, 0.5, 2.0]], &[17, 42]);
        let stamp = Stamp {
            sec: 12,
            nanosec: 345,
        };
        let bytes = cloud.fill(stamp, &[3.5, -1.25]).to_vec();
        let back = point_cloud(&bytes).unwrap();
        assert_eq!(back.stamp, stamp);
        assert_eq!(back.frame_id, "forearm");
        assert_eq!(back.positions, [[0.1, 0.2, 0.3], [-1.0, 0.5, 2.0]]);
        assert_eq!(back.pressures, [3.5, -1.25]);
        assert_eq!(back.ids, [17, 42]);
        let layout = CloudLayout::of(&bytes).unwrap();
        let mut p = [0.0; 2];
        let again = cloud.fill(Stamp { sec: 13, nanosec: 0 }, &[7.0, 8.0]).to_vec();
        assert_eq!(cloud_pressures(&again, &layout, &mut p).unwrap().sec, 13);
        assert_eq!(p, [7.0, 8.0]);
        // Every cut of the message is an error, not a panic.
        for n in 0..bytes.len() {
            assert!(point_cloud(&bytes[..n]).is_err(), "cut at {n}");
            assert!(
                cloud_pressures(&bytes[..n], &layout, &mut p).is_err()
                    || n >= layout.data_at + 2 * layout.step
            );
        }
    }

    #[test]
    fn contacts_and_events_read_back() {
        let mut w = CdrWriter::new();
        let stamp = Stamp { sec: 1, nanosec: 2 };
        let c = ContactMsg {
            link: "forearm",
            position: [0.01, 0.02, 0.03],
            normal: [0.0, 0.0, 1.0],
            mean_pressure: 20.0,
            peak_pressure: 40.0,
            area: 1e-4,
            taxels: &[1, 0],
            ids: &[100, 101],
            force: 2.5,
        };
        messages::contacts(
            &mut w,
            stamp,
            [c, ContactMsg { force: f64::NAN, ..c }].into_iter(),
        );
        let (s, back) = contacts(w.bytes(), true).unwrap();
        assert_eq!((back[0].force, back[1].force), (Some(2.5), None));
        assert_eq!(s, stamp);
        assert_eq!(back[0].link, "forearm");
        assert_eq!(back[0].taxel_ids, [101, 100]);
        assert_eq!((back[0].mean_pressure, back[0].peak_pressure), (20.0, 40.0));

        let line = r#"{"event":"gate","action":"stop","time":1.5}"#;
        let e = TouchEventMsg {
            kind: EventKind::Gate,
            action: "stop",
            links: vec!["a", "b"],
            missing: vec![("can0", 3)],
            json: line,
            ..TouchEventMsg::default()
        };
        messages::touch_event(&mut w, stamp, &e);
        let (s, json) = touch_event_json(w.bytes()).unwrap();
        assert_eq!((s, json.as_str()), (stamp, line));
        let bytes = w.bytes().to_vec();
        for n in 0..bytes.len() {
            assert!(touch_event_json(&bytes[..n]).is_err());
        }
    }

    #[test]
    fn a_length_past_the_message_sizes_nothing() {
        let mut w = CdrWriter::new();
        w.start().i32(0).u32(0).u32(u32::MAX);
        assert!(
            point_cloud(w.bytes())
                .unwrap_err()
                .why
                .contains("sequence of 4294967295")
        );
        let mut w = CdrWriter::new();
        w.start().i32(0).u32(0).string("x").u32(1).u32(1).u32(u32::MAX);
        assert!(
            point_cloud(w.bytes())
                .unwrap_err()
                .why
                .contains("sequence of 4294967295")
        );
    }
}

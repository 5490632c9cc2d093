//! What goes down the page's WebSocket. Text messages are JSON objects with one key: `scene`
//! (first, and again when it changes: [`crate::Scene`]), `event` (the session's events, each
//! the line `events.jsonl` would hold; incomplete frames are counted in the frames instead),
//! `lost_events` (how many events before these are no longer kept), `status` (a replay's
//! `paused` and `speed`, or `ended` once a run is over). The page sends nothing, but to a
//! replay: `{"cmd": "pause" | "play"}`, `{"cmd": "seek", "time": S}`, `{"cmd": "speed",
//! "value": X}` (X from 0.01 to 100).
//! Binary messages carry what changes every frame, little-endian, so that a frame of the full arm
//! (3,495 taxels) is 14 KB of float32 pressures instead of 60 KB of JSON text:
//!
//! A frame (`SKF1`), one per session frame the browser is sent:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `u32` | magic `0x31464B53` (`"SKF1"`) |
//! | 4 | `u32` | frame number, counting every frame the viewer was handed |
//! | 8 | `f64` | session time, s |
//! | 16 | `f64` | when the session handed the frame over: ms since the Unix epoch (the page's latency) |
//! | 24 | `u64` | the frame's cycle (CAN cycle or recording frame number) |
//! | 32 | `u32` | frames this browser was not sent because a newer one was ready (skipped) |
//! | 36 | `u32` | frames handed to the viewer so far |
//! | 40 | `u32` | incomplete frames so far (a module's readings missing) |
//! | 44 | `u32` | counter resets so far |
//! | 48 | `u32` | the gate's action: 0 none yet, else 1 + its index in the scene's `gate_actions` |
//! | 52 | `u32` | M: modules missing from this frame |
//! | 56 | `u32` | C: contacts in this frame |
//! | 60 | `u32` | N: taxels (the scene's links, in order) |
//! | 64 | `u32` | P: placements (links stitched across joints: one per link; else 0) |
//! | 68 | `M x u32` | the missing modules, indices into the scene's `modules` |
//! | then | `C x 28 B` | each contact: link `u32`, centroid on the map `u`, `v` (`f32`, mm), taxels `u32`, mean and peak pressure (`f32`, counts), force (`f32`, N; NaN on a link without a force calibration) |
//! | then | `P x 12 B` | each link's map in the stitched plane at this frame's posture: angle (`f32`, rad, counter-clockwise) and offset `u`, `v` (`f32`, mm): `p' = R(angle) p + offset` |
//! | then | `N x f32` | pressures, counts above the baseline, links one after another |
//!
//! An image (`SKI1`), the latest tactile image of a link or of the stitched arm:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `u32` | magic `0x31494B53` (`"SKI1"`) |
//! | 4 | `u32` | link index, or `0xFFFF_FFFF` for the stitched arm |
//! | 8 | `u32` | 0: the frame's image; 1: the image a decision was made on |
//! | 12 | `u32` | rows |
//! | 16 | `u32` | columns |
//! | 20 | `u32` | unused (0) |
//! | 24 | `f64` | session time, s |
//! | 32 | `rows x cols` bytes | grey pixels, row-major, 0 = no pressure |

/// First four bytes of a frame.
pub const FRAME_MAGIC: u32 = u32::from_le_bytes(*b"SKF1");
/// First four bytes of an image.
pub const IMAGE_MAGIC: u32 = u32::from_le_bytes(*b"SKI1");
/// Bytes before a frame's missing modules.
pub const FRAME_HEAD: usize = 68;
/// Bytes before an image's pixels.
pub const IMAGE_HEAD: usize = 32;
/// Bytes per contact of a frame.
pub const CONTACT_BYTES: usize = 28;
/// Bytes per placement of a frame.
pub const PLACEMENT_BYTES: usize = 12;
/// Where a frame's skipped count sits (patched per browser).
pub const SKIPPED_AT: usize = 32;
/// The image's view for the stitched arm.
pub const STITCHED: u32 = u32::MAX;

/// The counts every frame carries.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FrameHead {
    /// Frame number (every frame handed over).
    pub number: u32,
    /// Session time, s.
    pub time: f64,
    /// When the session handed it over, ms since the Unix epoch.
    pub handed_ms: f64,
    /// The frame's cycle.
    pub cycle: u64,
    /// Frames handed over so far.
    pub frames: u32,
    /// Incomplete frames so far.
    pub incomplete: u32,
    /// Counter resets so far.
    pub resets: u32,
    /// 0, or 1 + the gate action's index.
    pub gate: u32,
}

/// A contact as the page draws it.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WireContact {
    /// Link index.
    pub link: u32,
    /// Pressure-weighted centroid on the link's map, mm.
    pub uv_mm: [f32; 2],
    /// Pressed taxels.
    pub taxels: u32,
    /// Mean pressure, counts.
    pub mean: f32,
    /// Peak pressure, counts.
    pub peak: f32,
    /// Force, N; NaN on a link without a force calibration.
    pub force_n: f32,
}

/// A link's map in the stitched plane: `p' = R(angle) p + offset`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WirePlacement {
    /// Rotation, radians, counter-clockwise.
    pub angle: f32,
    /// Translation, mm.
    pub offset_mm: [f32; 2],
}

fn u32_at(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn f32_at(out: &mut Vec<u8>, v: f32) {
    out.extend_from_slice(&v.to_le_bytes());
}

/// Writes a frame into `out` (cleared first; its capacity is reused, so a frame of the same
/// size allocates nothing). `pressures` are the links' in scene order.
pub fn encode_frame<'a>(
    out: &mut Vec<u8>,
    head: &FrameHead,
    missing: &[u32],
    contacts: &[WireContact],
    placements: &[WirePlacement],
    pressures: impl Iterator<Item = &'a [f32]> + Clone,
) {
    out.clear();
    let n: usize = pressures.clone().map(<[f32]>::len).sum();
    u32_at(out, FRAME_MAGIC);
    u32_at(out, head.number);
    out.extend_from_slice(&head.time.to_le_bytes());
    out.extend_from_slice(&head.handed_ms.to_le_bytes());
    out.extend_from_slice(&head.cycle.to_le_bytes());
    u32_at(out, 0);
    u32_at(out, head.frames);
    u32_at(out, head.incomplete);
    u32_at(out, head.resets);
    u32_at(out, head.gate);
    u32_at(out, count(missing.len()));
    u32_at(out, count(contacts.len()));
    u32_at(out, count(n));
    u32_at(out, count(placements.len()));
    for &m in missing {
        u32_at(out, m);
    }
    for c in contacts {
        u32_at(out, c.link);
        f32_at(out, c.uv_mm[0]);
        f32_at(out, c.uv_mm[1]);
        u32_at(out, c.taxels);
        f32_at(out, c.mean);
        f32_at(out, c.peak);
        f32_at(out, c.force_n);
    }
    for p in placements {
        f32_at(out, p.angle);
        f32_at(out, p.offset_mm[0]);
        f32_at(out, p.offset_mm[1]);
    }
    out.reserve(4 * n);
    for link in pressures {
        // Whole chunks of little-endian floats: the compiler turns this into a copy.
        out.extend(link.iter().flat_map(|p| p.to_le_bytes()));
    }
}

/// Writes an image into `out` (cleared first, capacity reused).
pub fn encode_image(
    out: &mut Vec<u8>,
    view: u32,
    decision: bool,
    time: f64,
    rows: usize,
    cols: usize,
    pixels: &[u8],
) {
    out.clear();
    u32_at(out, IMAGE_MAGIC);
    u32_at(out, view);
    u32_at(out, u32::from(decision));
    u32_at(out, count(rows));
    u32_at(out, count(cols));
    u32_at(out, 0);
    out.extend_from_slice(&time.to_le_bytes());
    out.extend_from_slice(pixels);
}

/// A length as the wire's `u32` (a skin of four billion taxels is not one this viewer draws:
/// saturated rather than wrapped).
fn count(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

/// A frame read back (tests, and anyone writing their own client in Rust).
#[derive(Debug, Clone, PartialEq)]
pub struct DecodedFrame {
    /// The counts.
    pub head: FrameHead,
    /// Frames this browser was not sent.
    pub skipped: u32,
    /// Missing modules.
    pub missing: Vec<u32>,
    /// Contacts.
    pub contacts: Vec<WireContact>,
    /// The links' placements in the stitched plane (none without stitching).
    pub placements: Vec<WirePlacement>,
    /// Pressures, all links one after another.
    pub pressures: Vec<f32>,
}

/// Reads a frame; `None` when `bytes` is not a whole one.
pub fn decode_frame(bytes: &[u8]) -> Option<DecodedFrame> {
    let u32_ = |at: usize| Some(u32::from_le_bytes(bytes.get(at..at + 4)?.try_into().ok()?));
    let f32_ = |at: usize| u32_(at).map(f32::from_bits);
    let f64_ = |at: usize| Some(f64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?));
    if u32_(0)? != FRAME_MAGIC {
        return None;
    }
    let (m, c, n, p) = (
        u32_(52)? as usize,
        u32_(56)? as usize,
        u32_(60)? as usize,
        u32_(64)? as usize,
    );
    let contacts_at = FRAME_HEAD.checked_add(m.checked_mul(4)?)?;
    let placements_at = contacts_at.checked_add(c.checked_mul(CONTACT_BYTES)?)?;
    let pressures_at = placements_at.checked_add(p.checked_mul(PLACEMENT_BYTES)?)?;
    if bytes.len() != pressures_at.checked_add(n.checked_mul(4)?)? {
        return None;
    }
    Some(DecodedFrame {
        head: FrameHead {
            number: u32_(4)?,
            time: f64_(8)?,
            handed_ms: f64_(16)?,
            cycle: u64::from_le_bytes(bytes.get(24..32)?.try_into().ok()?),
            frames: u32_(36)?,
            incomplete: u32_(40)?,
            resets: u32_(44)?,
            gate: u32_(48)?,
        },
        skipped: u32_(SKIPPED_AT)?,
        missing: (0..m).map(|k| u32_(FRAME_HEAD + 4 * k)).collect::<Option<_>>()?,
        contacts: (0..c)
            .map(|k| {
                let at = contacts_at + CONTACT_BYTES * k;
                Some(WireContact {
                    link: u32_(at)?,
                    uv_mm: [f32_(at + 4)?, f32_(at + 8)?],
                    taxels: u32_(at + 12)?,
                    mean: f32_(at + 16)?,
                    peak: f32_(at + 20)?,
                    force_n: f32_(at + 24)?,
                })
            })
            .collect::<Option<_>>()?,
        placements: (0..p)
            .map(|k| {
                let at = placements_at + PLACEMENT_BYTES * k;
                Some(WirePlacement {
                    angle: f32_(at)?,
                    offset_mm: [f32_(at + 4)?, f32_(at + 8)?],
                })
            })
            .collect::<Option<_>>()?,
        pressures: (0..n)
            .map(|k| f32_(pressures_at + 4 * k))
            .collect::<Option<_>>()?,
    })
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;

    #[test]
    fn a_frame_reads_back_field_for_field() {
        let head = FrameHead {
            number: 7,
            time: 1.25,
            handed_ms: 1.7e12,
            cycle: u64::MAX - 3,
            frames: 9,
            incomplete: 2,
            resets: 1,
            gate: 3,
        };
        let contacts = [WireContact {
            link: 1,
            uv_mm: [12.5, -3.0],
            taxels: 14,
            mean: 30.5,
            peak: 80.0,
            force_n: 4.5,
        }];
        let a = [1.0f32, -2.0];
        let b = [3.5f32];
        let mut out = Vec::new();
        let placements = [
            WirePlacement::default(),
            WirePlacement {
                angle: 0.5,
                offset_mm: [100.0, -20.0],
            },
        ];
        encode_frame(
            &mut out,
            &head,
            &[4, 5],
            &contacts,
            &placements,
            [&a[..], &b[..]].into_iter(),
        );
        assert_eq!(
            out.len(),
            FRAME_HEAD + 8 + CONTACT_BYTES + 2 * PLACEMENT_BYTES + 12
        );
        let back = decode_frame(&out).unwrap();
        assert_eq!(back.head, head);
        assert_eq!(back.missing, [4, 5]);
        assert_eq!(back.contacts, contacts);
        assert_eq!(back.placements, placements);
        assert_eq!(back.pressures, [1.0, -2.0, 3.5]);
        // The pressures start 4-byte aligned: the page reads them as a Float32Array in place.
        assert_eq!((out.len() - 12) % 4, 0);
        // One byte more or less is not a frame.
        assert!(decode_frame(&out[..out.len() - 1]).is_none());
        out.push(0);
        assert!(decode_frame(&out).is_none());
    }

    #[test]
    fn a_second_frame_of_the_same_size_reuses_the_buffer() {
        let p = vec![0.5f32; 3495];
        let mut out = Vec::new();
        let encode = |out: &mut Vec<u8>| {
            encode_frame(out, &FrameHead::default(), &[], &[], &[], std::iter::once(&p[..]));
        };
        encode(&mut out);
        let (ptr, cap) = (out.as_ptr(), out.capacity());
        encode(&mut out);
        assert_eq!((out.as_ptr(), out.capacity()), (ptr, cap));
    }
}

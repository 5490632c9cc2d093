//! What a [`Session`](super::Session) reports: one schema for every consumer. A robot stack
//! matches on [`Event`]; `skin run` writes each one as a line of `events.jsonl` with
//! [`JsonLines`](super::JsonLines) (the field names below, `"event"` holding the variant's name in
//! snake case, keys sorted) and the decision images with [`PngImages`](super::PngImages).
//!
//! Units: times in seconds from the session's first frame, centroids in metres (in the link's
//! frame, or the poses' common frame for a contact across joints; a footprint's
//! `centroid_base` in that common frame, the chain's base, where the link's pose is known), areas in cm², pressures in
//! counts above the baseline. In JSON, times are rounded to 1 ms, centroids to 0.1 mm, areas to
//! 0.01 cm², pressures to 0.1 count and probabilities to 1e-4; the events themselves carry the
//! full values.

use crate::parts::PartContact;
use crate::touch::{self, Footprint};
use serde::ser::SerializeMap;
use serde::{Serialize, Serializer};
use skin_control::hri::GateAction;
use skin_core::image::{Image, ImageView};

/// Something that happened in a session, as it happened.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// A frame came with modules missing: their taxels keep their last readings (so a lost CAN
    /// frame is not taken for a release) and the frame is still processed.
    Incomplete {
        /// Frame time, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// The modules whose readings did not arrive.
        missing: Vec<MissingModule>,
    },
    /// A bus's sync counter restarted (recordings joined, a hub reset): the frames after it are
    /// kept, numbered on by time.
    CounterReset {
        /// When, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// The bus (interface name).
        bus: String,
        /// Counter before the restart.
        from: u8,
        /// Counter after it.
        to: u8,
        /// The cycle the frame after the restart was given.
        cycle: u64,
    },
    /// A touch began on a link. In JSON: `time`, `link`, `touch` and the footprint's fields.
    Appeared {
        /// The link's name.
        link: String,
        /// The touch (its link index, number, time and footprint).
        #[serde(flatten)]
        touch: touch::Appeared,
    },
    /// A touch was classified, on the image of the touch at its fullest so far; `revised` when
    /// the class changed since the touch's last decision. In JSON: `time`, `link`, `touch`,
    /// `revised`, `class` (its name), `probability`, `border_mm` (how near its taxels come to the
    /// skin's border, millimetres on the map) and the `parts` pressing (a hand, with a
    /// segmenter), thumb to palm.
    Classified {
        /// The link's name.
        link: String,
        /// The touch and its decision.
        #[serde(flatten)]
        touch: touch::Classified,
        /// The tactile image the decision was made on (model input size); not in JSON
        /// ([`PngImages`](super::PngImages) writes it).
        #[serde(skip)]
        image: Image<u8>,
    },
    /// A touch ended (or the session did, with the touch still open). In JSON: `time` (its last
    /// frame of contact), `link`, `touch`, `duration`, `frames`, the `peak` footprint and, once
    /// decided, the final `class` and its `probability`.
    Released {
        /// The link's name.
        link: String,
        /// The touch, from its first to its last frame of contact, and its final decision.
        #[serde(flatten)]
        touch: touch::Released,
    },
    /// What the robot should do changed (with a `[gate]`): the action of the most severe touch in
    /// progress, `resume` when none is.
    Gate {
        /// When, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// The action.
        #[serde(serialize_with = "action_name")]
        action: GateAction,
        /// What pressed past its class's force limit, when that is why the gate stops
        /// (`[gate] force_n`).
        #[serde(flatten)]
        over: Option<OverForce>,
    },
    /// A contact spans a joint (with stitched links); one event per such contact, when the first
    /// one begins.
    AcrossJoint {
        /// Frame time, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// The links it covers, in chain order.
        links: Vec<String>,
        /// Pressed taxels.
        taxels: usize,
        /// Pressure-weighted centroid, m, in the poses' common frame.
        #[serde(serialize_with = "point")]
        centroid: [f64; 3],
    },
    /// No contact spans a joint any more.
    AcrossJointEnd {
        /// Frame time, s.
        #[serde(serialize_with = "ms")]
        time: f64,
    },
    /// Taxels of a link read below their baseline, against the way pressure moves a reading and
    /// beyond their noise, for two frames in a row: their no-contact offsets had been learned
    /// (or had drifted) under pressure, and were reset to the readings when the pressure went.
    /// They read pressure right from then on. One event per correction, when it is over.
    BaselineCorrected {
        /// The frame the correction was over, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// The frame of its first reset, s.
        #[serde(serialize_with = "ms")]
        since: f64,
        /// The link's name.
        link: String,
        /// Taxels whose offset was reset.
        taxels: usize,
    },
    /// The skin was tared ([`Session::tare`](super::Session::tare)): the baseline is learned
    /// again over the next `frames` frames, which read no pressure. A forced tare released the
    /// touches open first (their `released` events come before this one).
    Tare {
        /// The frame it began at, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// Frames that learn the baseline again.
        frames: usize,
        /// Asked for while a touch was on the skin.
        forced: bool,
        /// Touches it released.
        released: usize,
    },
    /// The joint states that place the stitched links went wrong (once when a fault begins, not
    /// per message): a joint missing, not finite, a message out of order or of another robot's
    /// joints, a posture older than `[stitch] max_age_s`, or one the chain cannot be stitched
    /// at. The last good posture holds; the run goes on.
    JointStates {
        /// The frame it was found at, s.
        #[serde(serialize_with = "ms")]
        time: f64,
        /// What is wrong.
        problem: super::JointProblem,
        /// The joints at fault (missing, not finite), or a message's first names (another
        /// robot's).
        joints: Vec<String>,
        /// In words.
        detail: String,
    },
}

impl Event {
    /// Every kind's name, as `"event"` holds it in JSON, in the order the variants are declared:
    /// what a binding or a consumer of events.jsonl matches on (Python's `skin.events.EventKind`
    /// is held to this list).
    pub const KINDS: [&'static str; 11] = [
        "incomplete",
        "counter_reset",
        "appeared",
        "classified",
        "released",
        "gate",
        "across_joint",
        "across_joint_end",
        "baseline_corrected",
        "tare",
        "joint_states",
    ];

    /// This event's kind, one of [`Event::KINDS`] (its `"event"` in JSON).
    pub fn kind(&self) -> &'static str {
        let k = match self {
            Event::Incomplete { .. } => 0,
            Event::CounterReset { .. } => 1,
            Event::Appeared { .. } => 2,
            Event::Classified { .. } => 3,
            Event::Released { .. } => 4,
            Event::Gate { .. } => 5,
            Event::AcrossJoint { .. } => 6,
            Event::AcrossJointEnd { .. } => 7,
            Event::BaselineCorrected { .. } => 8,
            Event::Tare { .. } => 9,
            Event::JointStates { .. } => 10,
        };
        Event::KINDS[k]
    }

    /// The event's time, seconds from the session's first frame.
    pub fn time(&self) -> f64 {
        match self {
            Event::Incomplete { time, .. }
            | Event::CounterReset { time, .. }
            | Event::Gate { time, .. }
            | Event::AcrossJoint { time, .. }
            | Event::AcrossJointEnd { time }
            | Event::BaselineCorrected { time, .. }
            | Event::Tare { time, .. }
            | Event::JointStates { time, .. } => *time,
            Event::Appeared { touch, .. } => touch.time,
            Event::Classified { touch, .. } => touch.time,
            Event::Released { touch, .. } => touch.time,
        }
    }

    /// Appends the event as a line of events.jsonl, without the newline: keys sorted
    /// (through a `Value`, whose maps sort them), so every line lists its fields in the same
    /// order whatever the variant.
    pub fn write_json(&self, out: &mut Vec<u8>) -> serde_json::Result<()> {
        let value = serde_json::to_value(self)?;
        serde_json::to_writer(out, &value)
    }
}

/// A module whose readings a frame lacks.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct MissingModule {
    /// Its bus (interface name).
    pub bus: String,
    /// Its address on the bus.
    pub address: u32,
}

/// One frame after the baseline, as the session processed it ([`Sink::frame`](super::Sink)):
/// each link's pressures and contacts. Borrowed from the session; nothing is copied.
#[derive(Clone, Copy)]
pub struct ProcessedFrame<'a> {
    /// The frame's stamp on the input's clock, µs (a candump log's or the live bus's time since
    /// the epoch; a recording's time since its first frame).
    pub time_us: u64,
    /// Seconds from the session's first frame (the times of [`Event`]s).
    pub time: f64,
    /// The frame's number (CAN cycle, or the recording's frame number).
    pub cycle: u64,
    /// Pressures per link (layout order), counts above the baseline.
    pub pressures: &'a [Vec<f32>],
    pub(super) pipeline: &'a crate::touch::TouchPipeline,
    pub(super) stitched: &'a [skin_geom::Placement],
}

impl<'a> ProcessedFrame<'a> {
    /// A frame that `pipeline` has just processed, for a stack that drives a
    /// [`TouchPipeline`](crate::touch::TouchPipeline) without a session and still hands its
    /// frames to a [`Sink`](super::Sink) (a ROS 2 publisher, say).
    pub fn new(
        time_us: u64,
        time: f64,
        cycle: u64,
        pressures: &'a [Vec<f32>],
        pipeline: &'a crate::touch::TouchPipeline,
    ) -> ProcessedFrame<'a> {
        ProcessedFrame {
            time_us,
            time,
            cycle,
            pressures,
            pipeline,
            stitched: &[],
        }
    }

    /// With links stitched across joints: where each link's map lies in the stitched plane at
    /// this frame's posture (one per link, layout order); empty otherwise.
    pub fn stitched_placements(&self) -> &'a [skin_geom::Placement] {
        self.stitched
    }

    /// The contacts of `link` in this frame (see [`TouchPipeline::contacts`](crate::touch::TouchPipeline::contacts)).
    pub fn contacts(&self, link: usize) -> &'a [skin_core::Contact] {
        self.pipeline.contacts(link)
    }

    /// The load on `link` in this frame (its contacts' force and torque about its origin, in its
    /// frame); none on a link without a force model.
    pub fn wrench(&self, link: usize) -> Option<skin_core::force::Wrench> {
        self.pipeline.wrench(link).map(|(w, _)| w)
    }

    /// Link `link`'s readings in this frame in its unit: counts above the baseline, or newtons
    /// per taxel on a link with a force calibration ([`super::Units`]).
    pub fn readings(&self, link: usize) -> Option<super::Readings<'a>> {
        match self.pipeline.taxel_forces(link) {
            Some(forces) => Some(super::Readings::Newtons(forces)),
            None => self
                .pressures
                .get(link)
                .map(|p| super::Readings::Counts(p.as_slice())),
        }
    }

    /// Skin area per taxel of `link`, cm².
    pub fn taxel_area_cm2(&self, link: usize) -> Option<f64> {
        self.pipeline.taxel_area_cm2(link)
    }

    /// The pressure image a decision of this frame on `link` was made from
    /// ([`TouchPipeline::last_pressure_image`](crate::touch::TouchPipeline::last_pressure_image)).
    pub fn decision_pressure_image(&self, link: usize) -> Option<ImageView<'a, f32>> {
        self.pipeline.last_pressure_image(link)
    }
}

impl std::fmt::Debug for ProcessedFrame<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ProcessedFrame")
            .field("time_us", &self.time_us)
            .field("cycle", &self.cycle)
            .field("links", &self.pressures.len())
            .finish_non_exhaustive()
    }
}

/// A frame as it came in, before the baseline or anything else touched it: each link's
/// readings as the skin sent them (counts on the wire, or a recording's values), layout order.
/// What a dataset keeps losslessly ([`Sink::raw_frame`](super::Sink::raw_frame)).
#[derive(Debug, Clone, Copy)]
pub struct RawFrame<'a> {
    /// The frame's stamp on the input's clock, µs (as [`ProcessedFrame::time_us`]).
    pub time_us: u64,
    /// Seconds from the session's first frame.
    pub time: f64,
    /// The frame's number (CAN cycle, or the recording's frame number).
    pub cycle: u64,
    /// Every module answered (a missing module's taxels hold their last readings, and an
    /// [`Event::Incomplete`] names it).
    pub complete: bool,
    /// Readings per link, layout order.
    pub readings: &'a [Vec<f32>],
}

/// Where a frame image belongs (with [`SessionOptions::frame_images`](super::SessionOptions)).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameView<'a> {
    /// One link's map.
    Link(&'a str),
    /// The stitched maps of all links.
    Stitched,
}

/// A touch pressing past its class's force limit (`[gate] force_n`): in events.jsonl,
/// `"link"`, `"touch"`, `"force_n"` and `"limit_n"` beside the gate's `"action": "stop"`
/// (and `"saturated": true` where a reading past saturation made the force a lower bound).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OverForce {
    /// The link pressed.
    pub link: String,
    /// The touch.
    pub touch: u64,
    /// Its force when it crossed the limit, N.
    #[serde(serialize_with = "micro")]
    pub force_n: f64,
    /// Its class's limit, N.
    pub limit_n: f64,
    /// A taxel of it read past saturation: `force_n` is a lower bound, taken as past the limit.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub saturated: bool,
}

fn micro<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(round(*x, 6))
}

fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

fn ms<S: Serializer>(t: &f64, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(round(*t, 3))
}

fn action_name<S: Serializer>(a: &GateAction, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(a.name())
}

fn point<S: Serializer>(c: &[f64; 3], s: S) -> Result<S::Ok, S::Error> {
    c.map(|x| round(x, 4)).serialize(s)
}

fn pressure(p: f32) -> f64 {
    round(f64::from(p), 1)
}

impl Serialize for Footprint {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        self.entries(&mut m)?;
        m.end()
    }
}

impl Footprint {
    /// Its fields as entries of `m` (an event's own, or the footprint's).
    fn entries<M: SerializeMap>(&self, m: &mut M) -> Result<(), M::Error> {
        m.serialize_entry("area_cm2", &round(self.area_cm2, 2))?;
        m.serialize_entry(
            "centroid",
            &[self.centroid.x, self.centroid.y, self.centroid.z].map(|x| round(x, 4)),
        )?;
        // Only where the link's pose is known: never a guessed posture.
        if let Some(c) = self.centroid_base {
            m.serialize_entry("centroid_base", &[c.x, c.y, c.z].map(|x| round(x, 4)))?;
        }
        m.serialize_entry("contacts", &self.contacts)?;
        // Newtons only where the link has a force model: never a guess (to micronewtons: what
        // a message elsewhere carries can be held to the event to 1e-6 N).
        if let Some(f) = self.force_n {
            m.serialize_entry("force_n", &round(f, 6))?;
        }
        m.serialize_entry("mean_pressure", &pressure(self.mean_pressure))?;
        m.serialize_entry("taxels", &self.taxels)
    }
}

/// JSON of a touch's events: the link's name is the event's, the link index is not written.
impl Serialize for touch::Appeared {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("time", &round(self.time, 3))?;
        m.serialize_entry("touch", &self.id)?;
        self.footprint.entries(&mut m)?;
        m.end()
    }
}

impl Serialize for touch::Classified {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let d = &self.decision;
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("time", &round(self.time, 3))?;
        m.serialize_entry("touch", &self.id)?;
        m.serialize_entry("revised", &self.revised)?;
        m.serialize_entry("class", &d.class)?;
        m.serialize_entry("probability", &round(f64::from(d.probability), 4))?;
        if d.border_mm.is_finite() {
            m.serialize_entry("border_mm", &round(f64::from(d.border_mm), 1))?;
        }
        if !d.parts.is_empty() {
            m.serialize_entry("parts", &Parts(&d.parts))?;
        }
        m.end()
    }
}

impl Serialize for touch::Released {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("time", &round(self.time, 3))?;
        m.serialize_entry("touch", &self.id)?;
        m.serialize_entry("duration", &round(self.duration, 3))?;
        m.serialize_entry("frames", &self.frames)?;
        m.serialize_entry("peak", &self.peak)?;
        if let Some(d) = &self.decision {
            m.serialize_entry("class", &d.class)?;
            m.serialize_entry("probability", &round(f64::from(d.probability), 4))?;
        }
        m.end()
    }
}

/// The hand parts of a decision, thumb to palm.
struct Parts<'a>(&'a [PartContact]);

impl Serialize for Parts<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        part_list(self.0, s)
    }
}

fn part_list<S: Serializer>(parts: &[PartContact], s: S) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeSeq;
    struct One<'a>(&'a PartContact);
    impl Serialize for One<'_> {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            let p = self.0;
            let mut m = s.serialize_map(None)?;
            if let Some(c) = p.centroid {
                m.serialize_entry("centroid", &[c.x, c.y, c.z].map(|x| round(x, 4)))?;
            }
            m.serialize_entry("mean_pressure", &pressure(p.mean_pressure))?;
            m.serialize_entry("part", p.part.name())?;
            m.serialize_entry("taxels", &p.taxels)?;
            m.end()
        }
    }
    let mut seq = s.serialize_seq(Some(parts.len()))?;
    for p in parts {
        seq.serialize_element(&One(p))?;
    }
    seq.end()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]
    use super::*;
    use nalgebra::Point3;

    /// One event of every kind, in the order the variants are declared.
    fn over_force(link: &str) -> OverForce {
        OverForce {
            link: link.to_owned(),
            touch: 0,
            force_n: 150.5,
            limit_n: 140.0,
            saturated: false,
        }
    }

    fn one_of_each() -> Vec<Event> {
        let footprint = touch::Footprint {
            contacts: 1,
            taxels: 4,
            area_cm2: 1.0,
            mean_pressure: 50.0,
            force_n: None,
            centroid: Point3::new(0.0, 0.1, 0.2),
            centroid_base: None,
        };
        let decision = touch::Decision {
            class: crate::model::Classes::hand_or_not().get(0).unwrap().clone(),
            probability: 0.9,
            parts: Vec::new(),
            border_mm: 3.0,
        };
        let link = String::from("forearm");
        vec![
            Event::Incomplete {
                time: 0.0,
                missing: Vec::new(),
            },
            Event::CounterReset {
                time: 0.0,
                bus: "can0".into(),
                from: 7,
                to: 0,
                cycle: 8,
            },
            Event::Appeared {
                link: link.clone(),
                touch: touch::Appeared {
                    link: 0,
                    id: 0,
                    time: 0.0,
                    footprint: touch::Footprint {
                        centroid_base: Some(Point3::new(0.31234, -0.05, 0.2)),
                        ..footprint
                    },
                },
            },
            Event::Classified {
                link: link.clone(),
                touch: touch::Classified {
                    link: 0,
                    id: 0,
                    time: 0.0,
                    decision: decision.clone(),
                    revised: false,
                },
                image: Image::default(),
            },
            Event::Released {
                link: link.clone(),
                touch: touch::Released {
                    link: 0,
                    id: 0,
                    start: 0.0,
                    time: 0.0,
                    duration: 0.0,
                    frames: 1,
                    peak: footprint,
                    decision: Some(decision),
                },
            },
            Event::Gate {
                time: 0.0,
                action: GateAction::Stop,
                over: Some(over_force(&link)),
            },
            Event::AcrossJoint {
                time: 0.0,
                links: vec![link],
                taxels: 3,
                centroid: [0.0; 3],
            },
        ]
        .into_iter()
        .chain(the_robots_events())
        .collect()
    }

    /// The end of a contact across joints, a baseline correction, and the events of taring and
    /// of the robot's joint states.
    fn the_robots_events() -> [Event; 4] {
        [
            Event::AcrossJointEnd { time: 0.0 },
            Event::BaselineCorrected {
                time: 0.0,
                since: 0.0,
                link: "forearm".into(),
                taxels: 2,
            },
            Event::Tare {
                time: 0.0,
                frames: 20,
                forced: true,
                released: 1,
            },
            Event::JointStates {
                time: 0.0,
                problem: super::super::JointProblem::Missing,
                joints: vec!["wrist_roll".into()],
                detail: "the last good posture holds".into(),
            },
        ]
    }

    #[test]
    fn every_kind_is_named_as_its_json_says_in_declaration_order() {
        let events = one_of_each();
        assert_eq!(events.len(), Event::KINDS.len());
        for (event, kind) in events.iter().zip(Event::KINDS) {
            let json = serde_json::to_value(event).unwrap();
            assert_eq!(json["event"], kind);
            assert_eq!(event.kind(), kind);
        }
    }

    #[test]
    fn a_centroid_in_the_base_frame_is_written_only_where_it_is_known() {
        let events = one_of_each();
        let appeared = serde_json::to_value(&events[2]).unwrap();
        assert_eq!(appeared["centroid_base"], serde_json::json!([0.3123, -0.05, 0.2]));
        assert_eq!(appeared["centroid"], serde_json::json!([0.0, 0.1, 0.2]));
        let released = serde_json::to_value(&events[4]).unwrap();
        assert!(released.get("centroid_base").is_none(), "{released}");
    }
}

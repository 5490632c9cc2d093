//! What the touch pipeline says of a touch: its footprint in a frame, its decision, the events
//! of its life (appeared, classified, released) and the time each stage took. The
//! [`TouchPipeline`](super::TouchPipeline) that tracks and decides touches is `touch.rs`.

use crate::model::Class;
use crate::parts::PartContact;
use nalgebra::Point3;
use std::time::Duration;

/// Where and how hard a link is pressed in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// Separate contacts.
    pub contacts: usize,
    /// Pressed taxels.
    pub taxels: usize,
    /// Area: pressed taxels times the skin area per taxel, cm².
    pub area_cm2: f64,
    /// Mean pressure over the pressed taxels (frame units).
    pub mean_pressure: f32,
    /// The contacts' force, newtons; none on a link without a force model.
    pub force_n: Option<f64>,
    /// Pressure-weighted centroid of the pressed taxels, metres in the link frame.
    pub centroid: Point3<f64>,
    /// The same centroid in the chain's base frame (the common frame of the links' poses), at
    /// the posture of the footprint's frame: where the robot was touched. None when the link's
    /// pose then is not known (no chain, or no joint state yet): never a guessed posture.
    pub centroid_base: Option<Point3<f64>>,
}

/// A decision on a touch.
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// The most probable class.
    pub class: Class,
    /// Its probability.
    pub probability: f32,
    /// The hand parts pressing, when the class is the hand class and there is a segmenter.
    pub parts: Vec<PartContact>,
    /// How near the image's taxels come to the skin's border, millimetres on the tactile map
    /// (0: on it): a touch cut by the border is seen only in part (see
    /// [`BorderRule`](skin_control::hri::BorderRule)).
    pub border_mm: f32,
}

impl Decision {
    /// What the gate weighs of it: the class (and whether it is the hand), its probability, its
    /// distance from the border.
    pub fn gate_touch(&self) -> skin_control::hri::GateTouch<'_> {
        skin_control::hri::GateTouch {
            class: self.class.name(),
            hand: self.class.is_hand(),
            probability: f64::from(self.probability),
            border_mm: f64::from(self.border_mm),
            force_n: None,
        }
    }
}

/// A touch began on a link.
#[derive(Debug, Clone, PartialEq)]
pub struct Appeared {
    /// Link index (layout order).
    pub link: usize,
    /// Touch number, unique over the run.
    pub id: u64,
    /// Frame time, seconds.
    pub time: f64,
    /// The first frame's footprint.
    pub footprint: Footprint,
}

/// A touch was classified, on the image of the touch at its fullest so far.
#[derive(Debug, Clone, PartialEq)]
pub struct Classified {
    /// Link index (layout order).
    pub link: usize,
    /// Touch number.
    pub id: u64,
    /// Frame time, seconds.
    pub time: f64,
    /// The decision.
    pub decision: Decision,
    /// The class changed since the touch's last decision.
    pub revised: bool,
}

/// A touch ended (or the input did, with the touch still open).
#[derive(Debug, Clone, PartialEq)]
pub struct Released {
    /// Link index (layout order).
    pub link: usize,
    /// Touch number.
    pub id: u64,
    /// Time of its first frame of contact, seconds.
    pub start: f64,
    /// Time of its last frame of contact, seconds.
    pub time: f64,
    /// From first to last frame of contact, seconds.
    pub duration: f64,
    /// Frames of contact.
    pub frames: usize,
    /// The footprint at its largest total pressure.
    pub peak: Footprint,
    /// The final decision (none without a classifier).
    pub decision: Option<Decision>,
}

/// What happened on a link: the touch types that a session's [`Event`](crate::session::Event)s
/// carry on, and a ROS 2 bridge publishes.
#[derive(Debug, Clone, PartialEq)]
pub enum TouchEvent {
    /// A touch began.
    Appeared(Appeared),
    /// A touch was classified (`revised`: again, with another class than before).
    Classified(Classified),
    /// A touch ended.
    Released(Released),
}

/// Time spent in each stage, summed over the frames processed.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageTimes {
    /// Frames processed.
    pub frames: u64,
    /// Contact search (all links).
    pub contacts: Duration,
    /// Tactile images (of the frames classified).
    pub image: Duration,
    /// Classifier runs.
    pub classify: Duration,
    /// Segmenter runs and per-part contacts.
    pub segment: Duration,
    /// Model runs: classifications, segmentations.
    pub runs: (u64, u64),
    /// The slowest frame, whole path.
    pub worst_frame: Duration,
    /// All frames, whole path.
    pub total: Duration,
}

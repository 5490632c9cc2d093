//! Contacts that are not a hand (thesis Ch. 4.5, Fig. 4.3): objects of different shape, size and
//! softness, and other body parts (large, diffuse areas). About 35% of the thesis' non-hand
//! images came from body parts, the rest from objects; the same mix is drawn here.
//!
//! Those prints are drawn flat on the map, as large as the object. A rigid object pressed on a
//! curved, soft link prints much less of itself: a ball of 15-30 mm radius pressed with 3-20 N
//! leaves a dome 1-2.5 cm across (Hertz: the contact radius grows as the cube root of force
//! times radius), and a bar across a link of 6-8 cm radius a stroke 2-7 cm long, its length
//! bounded by the link's curvature, not the bar's. [`ObjectKind::SMALL`] draws those prints
//! (a knob and a rod), the smallest contacts a skin feels and the ones an edge cuts smaller
//! still; [`SynthOptions::small_objects`](super::SynthOptions::small_objects) mixes them in.

use super::Placement;
use super::shapes::{Patch, Shape};
use nalgebra::{Point2, Rotation2, Vector2};
use rand::Rng;

/// What touched the skin, when it was not a hand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ObjectKind {
    /// A ball or rounded knob, 2-12 cm across.
    Ball,
    /// The edge of a table or a sheet: a long thin line.
    Edge,
    /// A bar, tube or handle, 1.5-5 cm wide.
    Bar,
    /// A flat plate or box face.
    Plate,
    /// The corner of a box: two edges meeting.
    Corner,
    /// A tool: a handle with a head (hammer, wrench, screwdriver).
    Tool,
    /// A forearm laid on the skin.
    Forearm,
    /// An upper arm.
    Arm,
    /// A shoulder.
    Shoulder,
    /// A torso.
    Torso,
    /// A back.
    Back,
    /// A small rigid ball or knob as it prints on a curved, soft link: a dome 0.8-2.8 cm across.
    Knob,
    /// A rigid bar or rod pressed across a curved link: a stroke 2-7 cm long and 0.5-1.6 cm wide
    /// (the link's curvature, not the bar, bounds its length).
    Rod,
}

impl ObjectKind {
    /// Objects, then body parts, then the small rigid prints of [`ObjectKind::SMALL`] (drawn only
    /// when asked for, so a dataset without them is what it always was).
    pub const ALL: [ObjectKind; 13] = [
        ObjectKind::Ball,
        ObjectKind::Edge,
        ObjectKind::Bar,
        ObjectKind::Plate,
        ObjectKind::Corner,
        ObjectKind::Tool,
        ObjectKind::Forearm,
        ObjectKind::Arm,
        ObjectKind::Shoulder,
        ObjectKind::Torso,
        ObjectKind::Back,
        ObjectKind::Knob,
        ObjectKind::Rod,
    ];

    /// The small rigid prints: a knob and a rod.
    pub const SMALL: [ObjectKind; 2] = [ObjectKind::Knob, ObjectKind::Rod];

    /// The name used in dataset files.
    pub fn name(self) -> &'static str {
        match self {
            ObjectKind::Ball => "ball",
            ObjectKind::Edge => "edge",
            ObjectKind::Bar => "bar",
            ObjectKind::Plate => "plate",
            ObjectKind::Corner => "corner",
            ObjectKind::Tool => "tool",
            ObjectKind::Forearm => "forearm",
            ObjectKind::Arm => "arm",
            ObjectKind::Shoulder => "shoulder",
            ObjectKind::Torso => "torso",
            ObjectKind::Back => "back",
            ObjectKind::Knob => "knob",
            ObjectKind::Rod => "rod",
        }
    }

    /// A body part rather than an object.
    pub fn is_body_part(self) -> bool {
        matches!(
            self,
            ObjectKind::Forearm
                | ObjectKind::Arm
                | ObjectKind::Shoulder
                | ObjectKind::Torso
                | ObjectKind::Back
        )
    }

    /// A small rigid print ([`ObjectKind::SMALL`]).
    pub fn is_small(self) -> bool {
        matches!(self, ObjectKind::Knob | ObjectKind::Rod)
    }

    /// A share `small` of the small rigid prints (a knob or a rod, even odds), the rest 65%
    /// objects and 35% body parts, uniform within each. With `small` 0 no extra number is drawn,
    /// so the samples are those of a generator without small prints.
    pub(crate) fn sample<R: Rng>(rng: &mut R, small: f64) -> ObjectKind {
        if small > 0.0 && rng.random_bool(small.min(1.0)) {
            ObjectKind::SMALL[rng.random_range(0..ObjectKind::SMALL.len())]
        } else if rng.random_bool(0.35) {
            ObjectKind::ALL[6 + rng.random_range(0..5)]
        } else {
            ObjectKind::ALL[rng.random_range(0..6)]
        }
    }
}

/// The patches of `contact` placed by `at` (all labelled 0: no hand part). `body_scale` sizes
/// body parts with the subject (1 for a 18.5 cm hand).
pub(crate) fn object<R: Rng>(
    contact: ObjectKind,
    at: &Placement,
    body_scale: f64,
    rng: &mut R,
) -> Vec<Patch> {
    let mut patches = match contact {
        ObjectKind::Ball => vec![ball(rng)],
        ObjectKind::Knob => vec![knob(rng)],
        ObjectKind::Rod => {
            let half = rng.random_range(0.8..3.0) * CM;
            vec![capsule(rng, half, 0.25..0.8, (0.3, 0.6))]
        }
        ObjectKind::Edge => {
            let half = rng.random_range(5.0..25.0) * CM;
            vec![capsule(rng, half, 0.4..1.2, (0.3, 0.8))]
        }
        ObjectKind::Bar => {
            let half = rng.random_range(5.0..20.0) * CM;
            vec![capsule(rng, half, 0.75..2.5, (0.3, 0.9))]
        }
        ObjectKind::Plate => vec![plate(rng)],
        ObjectKind::Corner => corner(rng),
        ObjectKind::Tool => tool(rng),
        ObjectKind::Forearm
        | ObjectKind::Arm
        | ObjectKind::Shoulder
        | ObjectKind::Torso
        | ObjectKind::Back => body_part(contact, body_scale, rng),
    };
    // An object seldom presses evenly: tilt its load.
    let tilt = Vector2::new(rng.random_range(-8.0..8.0), rng.random_range(-8.0..8.0));
    let rot = Rotation2::new(at.angle);
    for patch in &mut patches {
        patch.shape = patch.shape.moved(&rot, at.centre.coords);
        patch.origin = at.centre;
        patch.gradient = rot * tilt;
    }
    patches
}

/// Centimetres, in metres.
const CM: f64 = 0.01;

/// Softness: a rigid object is a dome (0.5) or flat (0.2), a soft one spreads (0.8-1).
fn gamma<R: Rng>(rng: &mut R, lo: f64, hi: f64) -> f64 {
    rng.random_range(lo..hi)
}

/// A ball's print: a disc of 1-6 cm radius, a little squashed.
fn ball<R: Rng>(rng: &mut R) -> Patch {
    let r = rng.random_range(1.0..6.0) * CM;
    let squash = rng.random_range(0.85..1.0);
    Patch::new(
        Shape::Ellipse {
            c: Point2::origin(),
            dir: Vector2::x(),
            u: r,
            v: r * squash,
        },
        1.0,
        gamma(rng, 0.3, 1.0),
        0,
    )
}

/// A knob's or small ball's print on a curved link: a rigid dome (a Hertz-like profile, gamma
/// 0.3-0.6) of 0.4-1.4 cm radius, a little squashed by the link's curvature. HandsNet's stage 4
/// was fine-tuned on prints of exactly this range (its card in fixtures/models/handsnet.md).
fn knob<R: Rng>(rng: &mut R) -> Patch {
    let r = rng.random_range(0.4..1.4) * CM;
    let squash = rng.random_range(0.7..1.0);
    Patch::new(
        Shape::Ellipse {
            c: Point2::origin(),
            dir: Vector2::x(),
            u: r,
            v: r * squash,
        },
        1.0,
        gamma(rng, 0.3, 0.6),
        0,
    )
}

/// A long thin capsule of half-length `half` (m) and a radius in `r_cm` (cm), pressed with a
/// softness in `soft`: an edge or a bar.
fn capsule<R: Rng>(rng: &mut R, half: f64, r_cm: std::ops::Range<f64>, soft: (f64, f64)) -> Patch {
    Patch::new(
        Shape::Capsule {
            a: Point2::new(-half, 0.0),
            b: Point2::new(half, 0.0),
            r: rng.random_range(r_cm) * CM,
        },
        1.0,
        gamma(rng, soft.0, soft.1),
        0,
    )
}

/// A plate pressed flat: a rectangle of 2.5-12 by 2.5-10 cm (half sides).
fn plate<R: Rng>(rng: &mut R) -> Patch {
    Patch::new(
        Shape::Rect {
            c: Point2::origin(),
            dir: Vector2::x(),
            u: rng.random_range(2.5..12.0) * CM,
            v: rng.random_range(2.5..10.0) * CM,
        },
        1.0,
        gamma(rng, 0.1, 0.4),
        0,
    )
}

/// A box's corner: two capsules from one point.
fn corner<R: Rng>(rng: &mut R) -> Vec<Patch> {
    let (cm, x) = (CM, Vector2::x());
    // Two edges of a box meeting at the origin, at 60-120 degrees; the load peaks at the
    // corner when the box is tilted onto it.
    let angle = rng.random_range(60.0f64..120.0).to_radians();
    let r = rng.random_range(0.4..1.0) * cm;
    let (la, lb) = (rng.random_range(4.0..15.0) * cm, rng.random_range(4.0..15.0) * cm);
    let tip = Point2::new(0.0, 0.0);
    let b = Rotation2::new(angle) * Vector2::x();
    vec![
        Patch::new(
            Shape::Capsule {
                a: tip,
                b: tip + x * la,
                r,
            },
            1.0,
            0.5,
            0,
        ),
        Patch::new(
            Shape::Capsule {
                a: tip,
                b: tip + b * lb,
                r,
            },
            1.0,
            0.5,
            0,
        ),
    ]
}

/// A tool: a grip (capsule) and a head (rectangle) at its end.
fn tool<R: Rng>(rng: &mut R) -> Vec<Patch> {
    let (cm, x) = (CM, Vector2::x());
    let half = rng.random_range(6.0..14.0) * cm;
    let grip = rng.random_range(1.0..1.8) * cm;
    let head_u = rng.random_range(1.0..3.5) * cm;
    let head_v = rng.random_range(0.8..5.0) * cm;
    vec![
        Patch::new(
            Shape::Capsule {
                a: Point2::new(-half, 0.0),
                b: Point2::new(half, 0.0),
                r: grip,
            },
            rng.random_range(0.5..1.0),
            0.5,
            0,
        ),
        Patch::new(
            Shape::Rect {
                c: Point2::new(half + head_u, 0.0),
                dir: x,
                u: head_u,
                v: head_v,
            },
            1.0,
            0.3,
            0,
        ),
    ]
}

/// A body part other than a hand (forearm, arm, shoulder, torso, back), sized by `body_scale`.
fn body_part<R: Rng>(contact: ObjectKind, body_scale: f64, rng: &mut R) -> Vec<Patch> {
    let (cm, x, o) = (CM, Vector2::x(), Point2::origin());
    let (u, v) = match contact {
        ObjectKind::Forearm => (rng.random_range(9.0..14.0), rng.random_range(2.5..4.5)),
        ObjectKind::Arm => (rng.random_range(11.0..17.0), rng.random_range(3.5..6.0)),
        ObjectKind::Shoulder => (rng.random_range(5.0..9.0), rng.random_range(4.0..7.0)),
        _ => (rng.random_range(12.0..25.0), rng.random_range(9.0..18.0)),
    };
    let (u, v) = (u * cm * body_scale, v * cm * body_scale);
    // Soft tissue over bone: a broad load with a few firmer spots (elbow, ribs, spine).
    let mut p = vec![Patch::new(
        Shape::Ellipse { c: o, dir: x, u, v },
        rng.random_range(0.5..0.8),
        gamma(rng, 0.6, 1.0),
        0,
    )];
    for _ in 0..rng.random_range(0..3) {
        let c = Point2::new(rng.random_range(-0.6..0.6) * u, rng.random_range(-0.5..0.5) * v);
        let s = rng.random_range(0.2..0.45) * v;
        p.push(Patch::new(
            Shape::Ellipse {
                c,
                dir: x,
                u: s * rng.random_range(1.0..2.0),
                v: s,
            },
            1.0,
            0.8,
            0,
        ));
    }
    p
}

//! Human hands pressing the skin (thesis Ch. 4.2 and 4.5).
//!
//! A hand is drawn in its own frame (metres; origin at the wrist, +y towards the middle fingertip,
//! +x towards the thumb of a right hand), then mirrored for a left hand, rotated and placed on
//! the map. Proportions follow adult hand anthropometry, scaled by the hand length L (wrist to
//! middle fingertip, 15-22 cm as in Table 4.2): palm length 0.57 L, palm width 0.44 L, fingers of
//! three phalanges (thumb: two) with their own widths. A finger's flexion shortens its imprint and
//! moves the load to the fingertip; a fully bent finger leaves its distal pad only.

use super::shapes::{Patch, Shape};
use super::{Part, Placement};
use nalgebra::{Point2, Rotation2, Vector2};
use rand::Rng;
use rand_distr::{Distribution, Normal};

/// How a subject touches: fixed per subject seed, so a test set of unseen subjects is unseen
/// hands and habits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Subject {
    /// Hand length, wrist to middle fingertip, metres.
    pub hand_length: f64,
    /// Palm width relative to the average proportion (0.9-1.1).
    pub breadth: f64,
    /// Right-handed (the thesis' subjects: 78% right).
    pub right_handed: bool,
    /// How far the fingers usually spread, 0-1.
    pub splay: f64,
    /// How much the fingers usually bend, 0-1.
    pub flex: f64,
    /// Load on the fingers relative to the palm (0.6-1.6).
    pub finger_load: f64,
}

impl Subject {
    /// A random subject.
    pub fn sample<R: Rng>(rng: &mut R) -> Subject {
        // Table 4.2: 15 to 22 cm, mean 18 cm; adult hand lengths spread about 1.7 cm.
        let length = Normal::new(0.185f64, 0.017).map_or(0.185, |n| n.sample(rng));
        Subject {
            hand_length: length.clamp(0.15, 0.22),
            breadth: rng.random_range(0.9..1.1),
            right_handed: rng.random_bool(0.78),
            splay: rng.random_range(0.0..1.0),
            flex: rng.random_range(0.0..0.6),
            finger_load: rng.random_range(0.6..1.6),
        }
    }
}

/// The actions of the thesis' data collection (Ch. 4.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Interaction {
    /// Grasp the link.
    Grasp,
    /// Grasp and twist clockwise about the link axis.
    TwistCw,
    /// Grasp and twist counter-clockwise.
    TwistCcw,
    /// Push the link to the left.
    PushLeft,
    /// Push the link to the right.
    PushRight,
    /// Push the link away.
    PushAway,
    /// Pull the link.
    Pull,
}

impl Interaction {
    /// All interactions, in the thesis' order.
    pub const ALL: [Interaction; 7] = [
        Interaction::Grasp,
        Interaction::TwistCw,
        Interaction::TwistCcw,
        Interaction::PushLeft,
        Interaction::PushRight,
        Interaction::PushAway,
        Interaction::Pull,
    ];

    /// The name used in dataset files.
    pub fn name(self) -> &'static str {
        match self {
            Interaction::Grasp => "grasp",
            Interaction::TwistCw => "twist_cw",
            Interaction::TwistCcw => "twist_ccw",
            Interaction::PushLeft => "push_left",
            Interaction::PushRight => "push_right",
            Interaction::PushAway => "push_away",
            Interaction::Pull => "pull",
        }
    }

    /// (probability the palm touches, probability the thumb touches, flexion range of the
    /// fingers): pulling is done with the fingertips, pushing away with the whole hand.
    fn habits(self) -> (f64, f64, (f64, f64)) {
        match self {
            Interaction::Grasp => (0.9, 0.7, (0.0, 0.5)),
            Interaction::TwistCw | Interaction::TwistCcw => (0.9, 0.7, (0.1, 0.5)),
            Interaction::PushLeft | Interaction::PushRight => (0.85, 0.5, (0.0, 0.3)),
            Interaction::PushAway => (0.95, 0.6, (0.0, 0.4)),
            Interaction::Pull => (0.25, 0.4, (0.5, 1.0)),
        }
    }
}

/// The five digits, thumb first: (part, base x / palm width, base y / L, length / L,
/// width / L, splay direction in degrees per unit of splay).
const DIGITS: [(Part, f64, f64, f64, f64, f64); 5] = [
    (Part::Thumb, 0.50, 0.22, 0.34, 0.115, 55.0),
    (Part::Index, 0.36, 0.555, 0.38, 0.098, 10.0),
    (Part::Middle, 0.12, 0.57, 0.43, 0.100, 0.0),
    (Part::Ring, -0.12, 0.555, 0.40, 0.094, -8.0),
    (Part::Pinkie, -0.36, 0.51, 0.31, 0.082, -18.0),
];

/// Phalanx lengths as fractions of the finger (proximal, middle, distal); the thumb uses the
/// last two.
const PHALANGES: [f64; 3] = [0.45, 0.30, 0.25];

/// One hand imprint: its patches in map coordinates, and whether only fingertips touch.
pub(crate) struct HandContact {
    pub(crate) patches: Vec<Patch>,
    pub(crate) fingertips_only: bool,
}

/// A hand of `subject` doing `action`, placed by `at`.
pub(crate) fn hand<R: Rng>(
    subject: &Subject,
    action: Interaction,
    at: &Placement,
    rng: &mut R,
) -> HandContact {
    let l = subject.hand_length;
    let w = 0.44 * l * subject.breadth;
    let (p_palm, p_thumb, flex_range) = action.habits();
    // Ch. 4.2: some touches leave the fingertips only, whatever the action.
    let fingertips_only = action == Interaction::Pull && rng.random_bool(0.3) || rng.random_bool(0.08);
    let palm = !fingertips_only && rng.random_bool(p_palm);
    let mut patches = Vec::with_capacity(16);

    let (skew, gradient) = shear(action, l, rng);

    if palm {
        palm_pads(l, w, rng, &mut patches);
    }

    let (fmin, fmax) = flex_range;
    for (i, &(part, bx, by, len, width, splay_deg)) in DIGITS.iter().enumerate() {
        let thumb = i == 0;
        let missing = if thumb {
            !rng.random_bool(p_thumb)
        } else {
            // Ch. 4.2: fingers lifted or off the skin; the pinkie most often.
            rng.random_bool(if part == Part::Pinkie { 0.15 } else { 0.07 })
        };
        if missing {
            continue;
        }
        let flex = if fingertips_only {
            rng.random_range(0.75..1.0)
        } else {
            (rng.random_range(fmin..=fmax) + subject.flex * 0.3).min(1.0)
        };
        let digit = Digit {
            part,
            base: (bx, by),
            len,
            width,
            splay_deg,
            thumb,
        };
        let shape = HandShape {
            subject,
            l,
            w,
            skew,
            palm,
        };
        digit.press(&shape, flex, rng, &mut patches);
    }

    let centre = Vector2::new(0.0, 0.4 * l);
    let rot = Rotation2::new(at.angle);
    let shift = at.centre.coords - rot * centre;
    for patch in &mut patches {
        if !subject.right_handed {
            patch.shape = patch.shape.mirrored();
        }
        patch.shape = patch.shape.moved(&rot, shift);
        let g = if subject.right_handed {
            gradient
        } else {
            Vector2::new(-gradient.x, gradient.y)
        };
        patch.gradient = rot * g;
        patch.origin = at.centre;
    }
    HandContact {
        patches,
        fingertips_only,
    }
}

/// How the action shears and loads the hand: the fingers' sideways skew (rad) and the load's
/// gradient across the hand (per metre, `l` the hand's length).
fn shear<R: Rng>(action: Interaction, l: f64, rng: &mut R) -> (f64, Vector2<f64>) {
    // Twisting shears the fingers sideways; pushing loads one side of the hand.
    let skew = match action {
        Interaction::TwistCw => rng.random_range(5.0f64..15.0).to_radians(),
        Interaction::TwistCcw => -rng.random_range(5.0f64..15.0).to_radians(),
        _ => rng.random_range(-4.0f64..4.0).to_radians(),
    };
    let side = rng.random_range(3.0..8.0) / l;
    let gradient = match action {
        Interaction::PushLeft => Vector2::new(side, 0.0),
        Interaction::PushRight => Vector2::new(-side, 0.0),
        Interaction::PushAway => Vector2::new(0.0, -side * 0.6),
        Interaction::TwistCw => Vector2::new(side * 0.5, side * 0.3),
        Interaction::TwistCcw => Vector2::new(-side * 0.5, side * 0.3),
        Interaction::Grasp | Interaction::Pull => {
            Vector2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0)) / l
        }
    };
    (skew, gradient)
}

/// The palm's pads of a hand of length `l` and palm width `w`, added to `patches`.
fn palm_pads<R: Rng>(l: f64, w: f64, rng: &mut R, patches: &mut Vec<Patch>) {
    // Three pads (Fig. 4.2): the ball under the finger bases, the thenar eminence at the
    // thumb and the hypothenar at the outer edge. The hollow in between presses less.
    let load = rng.random_range(0.6..1.0);
    let gamma = rng.random_range(0.3..0.8);
    let pads = [
        (Point2::new(0.0, 0.49 * l), (0.5 * w, 0.085 * l), 1.0),
        (Point2::new(0.24 * w, 0.2 * l), (0.24 * w, 0.17 * l), 0.9),
        (Point2::new(-0.27 * w, 0.22 * l), (0.2 * w, 0.18 * l), 0.8),
        (Point2::new(0.0, 0.33 * l), (0.38 * w, 0.17 * l), 0.45),
    ];
    for (c, (u, v), k) in pads {
        // A person leaning in with the heel of the hand lifts the palm's top, and vice versa.
        let k = k * rng.random_range(0.7..1.3);
        patches.push(Patch::new(
            Shape::Ellipse {
                c,
                dir: Vector2::x(),
                u,
                v,
            },
            load * k,
            gamma,
            Part::Palm as u8,
        ));
    }
}

/// What the digits of one hand share: its subject, length `l` and palm width `w` (m), the
/// fingers' skew (rad), and whether the palm touches.
#[derive(Clone, Copy)]
struct HandShape<'a> {
    subject: &'a Subject,
    l: f64,
    w: f64,
    skew: f64,
    palm: bool,
}

/// One digit of [`DIGITS`]: its part, base (x / palm width, y / L), length, width, splay.
#[derive(Clone, Copy)]
struct Digit {
    part: Part,
    base: (f64, f64),
    len: f64,
    width: f64,
    splay_deg: f64,
    thumb: bool,
}

impl Digit {
    /// The digit's phalanges that touch, bent by `flex` (0 straight, 1 curled), on `hand`;
    /// added to `patches`.
    fn press<R: Rng>(&self, hand: &HandShape<'_>, flex: f64, rng: &mut R, patches: &mut Vec<Patch>) {
        let Digit {
            part,
            base: (bx, by),
            len,
            width,
            splay_deg,
            thumb,
        } = *self;
        let HandShape {
            subject,
            l,
            w,
            skew,
            palm,
        } = *hand;
        let angle = (splay_deg * (0.3 + subject.splay) + rng.random_range(-4.0..4.0)).to_radians()
            + if thumb { 0.0 } else { skew };
        let dir = Rotation2::new(angle) * Vector2::y();
        let radius = 0.5 * width * l * rng.random_range(0.9..1.1);
        let length = len * l * rng.random_range(0.95..1.05);
        let mut p = Point2::new(bx * w, by * l);
        if thumb && palm {
            // The thumb's first segment is inside the thenar pad; start its imprint further out.
            p += dir * 0.15 * length;
        }
        let load = subject.finger_load * rng.random_range(0.7..1.2);
        let segments: &[f64] = if thumb { &PHALANGES[1..] } else { &PHALANGES };
        let scale = if thumb { 1.0 / 0.55 } else { 1.0 };
        let n = segments.len();
        for (k, &frac) in segments.iter().enumerate() {
            let distal = k + 1 == n;
            // A bent finger projects shorter, and its proximal phalanges lift off first.
            let rise = flex * (n - k) as f64 / n as f64;
            let seg = frac * scale * length * (1.0 - 0.6 * rise);
            let q = p + dir * seg;
            let touches = distal || rise < 0.55;
            if touches {
                let peak = load * if distal { 1.0 } else { 1.0 - 0.8 * rise };
                patches.push(Patch::new(
                    Shape::Capsule {
                        a: p + dir * (0.1 * seg),
                        b: q - dir * if distal { 0.35 * radius } else { 0.1 * seg },
                        r: radius,
                    },
                    peak,
                    0.5,
                    part as u8,
                ));
            }
            p = q;
        }
    }
}

//! Physical human-robot interaction tasks triggered by skin contacts (thesis Ch. 9.2), and the
//! gate that decides whether a contact may trigger them (so a hand classifier can veto a bump).
//!
//! Three tasks, mutually exclusive, with binary activations, checked in this order:
//!
//! 3. **Bend a joint**: both links next to a joint are touched. The joint between them moves with
//!    speed proportional to the torque the contacts on the child link exert about its axis.
//! 2. **Turn a link**: one link is held by two hands from opposite sides (the contact normals
//!    cancel: ||sum of the unit normals|| < zeta). Its joint moves with speed proportional to the
//!    torque about its axis.
//! 1. **Move along the push**: a single touched link. Its contact centroid moves along the mean
//!    contact normal, inwards (yielding to the push), at
//!    `V_max (p_mean - p_min) / (p_max - p_min)` (saturated to 0..V_max): rho_1 = -v [k; 0].
//!
//! The result is one [`Task`] for the [`crate::TaskStack`], activation 1.

use crate::contact_tasks::Contact;
use crate::controller::LinkContacts;
use crate::kinematics::{Chain, KinematicsError};
use crate::task_stack::Task;
use nalgebra::{DMatrix, DVector, Point3, Vector3};

/// Decides whether a link's contacts may trigger an interaction task (for instance: only if the
/// classifier says a human hand made them).
pub trait ContactGate {
    /// True to let the contacts on `link` trigger a task.
    fn allows(&mut self, link: &str, contacts: &[Contact]) -> bool;
}

/// What the robot does while a touch of some class is in progress (a configuration's `[gate]`
/// maps each class to one, e.g. hand -> comply, non_hand -> stop). Written as configuration
/// files and events write it: `stop`, `comply`, `slow`, `resume` ([`GateAction::name`]; text is
/// read with [`str::parse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GateAction {
    /// Stop the motion (the most severe: it wins over any other touch in progress).
    Stop,
    /// Yield to the contact (compliance).
    Comply,
    /// Go on more slowly.
    Slow,
    /// Go on as before.
    Resume,
}

skin_core::by_name!(GateAction, UnknownAction, "stop, comply, slow or resume", {
    Stop => "stop",
    Comply => "comply",
    Slow => "slow",
    Resume => "resume",
});

/// A touch's class as the gate sees it: a human hand, or anything else (HandsNet's two classes;
/// a model card's other classes are not a hand).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TouchClass {
    /// A human hand.
    Hand,
    /// Anything else: an object, a bump, another body part.
    NonHand,
}

/// What the robot does for each class of touch in progress, by the class's name (a
/// configuration's `[gate]`: e.g. hand -> comply, non_hand -> stop, for as many classes as the
/// classifier has). A class without an action leaves the decision to the others. Which class is
/// the hand is the classifier's to say ([`GateTouch::hand`]), not the gate's.
///
/// A touch near the skin's border is seen only in part (an object overhanging the edge prints
/// only its inner side), so its class is less certain there. With a [`BorderRule`], a touch
/// decided to be the hand with a probability under the rule's bar whose taxels come within its
/// distance of the border gets the rule's action (by default `stop`) instead of its class's.
///
/// ```
/// use skin_control::hri::{BorderRule, ClassGate, GateAction, GateTouch};
///
/// let gate = ClassGate::new([("hand", GateAction::Comply), ("non_hand", GateAction::Stop)]);
/// assert_eq!(gate.decide(["hand"]), GateAction::Comply);
/// // A bump while a hand guides the arm: stop wins over anything.
/// assert_eq!(gate.decide(["non_hand", "hand"]), GateAction::Stop);
/// assert_eq!(gate.decide([] as [&str; 0]), GateAction::Resume);
/// // Interaction tasks may follow the contacts only while the gate complies.
/// use skin_control::hri::ContactGate;
/// assert!(!gate.decide(["non_hand"]).allows("forearm", &[]));
///
/// // A hand at 70% 5 mm from the border: stopped, where a sure one complies.
/// let gate = ClassGate { border: Some(BorderRule::default()), ..gate };
/// let unsure = GateTouch { class: "hand", hand: true, probability: 0.7, border_mm: 5.0, force_n: None };
/// assert_eq!(gate.decide([unsure]), GateAction::Stop);
/// assert_eq!(gate.decide([GateTouch { probability: 0.999, ..unsure }]), GateAction::Comply);
/// assert_eq!(gate.decide([GateTouch { border_mm: 40.0, ..unsure }]), GateAction::Comply);
///
/// // A force limit per class (ISO/TS 15066's quasi-static limits are per body region): a
/// // hand pressing 150 N is stopped, one pressing 40 N guides the arm.
/// let mut gate = ClassGate::new([("hand", GateAction::Comply), ("non_hand", GateAction::Stop)]);
/// gate.force_n.insert("hand".into(), 140.0);
/// let hand = GateTouch { class: "hand", hand: true, probability: 1.0, border_mm: 40.0, force_n: Some(150.0) };
/// assert_eq!(gate.decide([hand]), GateAction::Stop);
/// assert_eq!(gate.force_crossed(&hand), Some(140.0));
/// assert_eq!(gate.decide([GateTouch { force_n: Some(40.0), ..hand }]), GateAction::Comply);
/// // A touch the skin cannot weigh (no force calibration) is judged by its class alone.
/// assert_eq!(gate.decide([GateTouch { force_n: None, ..hand }]), GateAction::Comply);
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClassGate {
    /// Each class's action, by the class's name.
    pub actions: std::collections::BTreeMap<String, GateAction>,
    /// What a hand decided with little confidence near the skin's border gets instead (none:
    /// a hand is a hand wherever it touches).
    pub border: Option<BorderRule>,
    /// Each class's force limit, newtons, by the class's name (`[gate] force_n = { hand = 140 }`):
    /// a touch of the class pressing harder gets `stop`, whatever its class's action. A class
    /// without one, or a touch the skin cannot weigh (no force calibration), has no limit.
    pub force_n: std::collections::BTreeMap<String, f64>,
}

/// The largest force limit a gate takes, newtons: far beyond any body region's limit, and a
/// number in a file is checked before it is trusted.
pub const MAX_FORCE_LIMIT_N: f64 = 1e5;

/// The gate's rule for a touch at the skin's border (`[gate] border = { ... }`): a touch decided
/// to be the hand with a probability under `hand_below`, some of whose taxels lie within
/// `within_mm` of the skin's border, gets `action` instead of its class's action.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Deserialize, serde::Serialize),
    serde(default, deny_unknown_fields)
)]
pub struct BorderRule {
    /// How close to the border a touch's taxels come, millimetres on the tactile map (15).
    pub within_mm: f64,
    /// A hand decision at least this probable keeps the hand's action (0.95).
    pub hand_below: f64,
    /// The action for the others (stop).
    pub action: GateAction,
}

impl Default for BorderRule {
    fn default() -> Self {
        BorderRule {
            within_mm: 15.0,
            hand_below: 0.95,
            action: GateAction::Stop,
        }
    }
}

impl BorderRule {
    /// The rule's numbers against their bounds (a distance from 0 to 1000 mm, a probability from
    /// 0 to 1): the first out of them as (its key as a run configuration spells it, its value,
    /// what it takes).
    pub fn check(&self) -> Result<(), (&'static str, f64, &'static str)> {
        if !(0.0..=1000.0).contains(&self.within_mm) {
            return Err((
                "[gate] border.within_mm",
                self.within_mm,
                "millimetres from 0 to 1000",
            ));
        }
        if !(0.0..=1.0).contains(&self.hand_below) {
            return Err((
                "[gate] border.hand_below",
                self.hand_below,
                "a probability from 0 to 1",
            ));
        }
        Ok(())
    }
}

/// What the gate knows of a decided touch in progress: its class's name, whether that class is
/// the hand, the class's probability and how far its taxels come to the skin's border
/// (millimetres on the tactile map; infinite when unknown). A bare class name is a sure touch
/// away from the border.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GateTouch<'a> {
    /// The class's name.
    pub class: &'a str,
    /// The class is the hand (the classifier's classes say which).
    pub hand: bool,
    /// Its probability, 0 to 1.
    pub probability: f64,
    /// The least distance of the touch's taxels from the skin's border, millimetres.
    pub border_mm: f64,
    /// The force it presses with now, newtons; none where the skin has no force calibration.
    pub force_n: Option<f64>,
}

impl<'a> From<&'a str> for GateTouch<'a> {
    fn from(class: &'a str) -> GateTouch<'a> {
        GateTouch {
            class,
            hand: false,
            probability: 1.0,
            border_mm: f64::INFINITY,
            force_n: None,
        }
    }
}

impl ClassGate {
    /// A gate of `actions`, one per class name, without a border rule.
    pub fn new<S: Into<String>>(actions: impl IntoIterator<Item = (S, GateAction)>) -> ClassGate {
        ClassGate {
            actions: actions.into_iter().map(|(c, a)| (c.into(), a)).collect(),
            border: None,
            force_n: Default::default(),
        }
    }

    /// The force limit `touch` presses beyond, newtons, if it does: its class's, when the
    /// class has one and the touch is weighed.
    pub fn force_crossed(&self, touch: &GateTouch<'_>) -> Option<f64> {
        let limit = *self.force_n.get(touch.class)?;
        (touch.force_n? > limit).then_some(limit)
    }

    /// The force limits against their bounds (more than 0 and at most [`MAX_FORCE_LIMIT_N`]
    /// newtons): the first out of them as (its class, its value, what it takes).
    pub fn check_force(&self) -> Result<(), (&str, f64, &'static str)> {
        match self
            .force_n
            .iter()
            .find(|&(_, &n)| !(n > 0.0 && n <= MAX_FORCE_LIMIT_N))
        {
            Some((class, &n)) => Err((class, n, "newtons, more than 0 and at most 100000")),
            None => Ok(()),
        }
    }

    /// The action for one class, if it has one.
    pub fn action(&self, class: &str) -> Option<GateAction> {
        self.actions.get(class).copied()
    }

    /// The action for one touch: `stop` past its class's force limit, else its class's, or the
    /// border rule's for an unsure hand at the border.
    pub fn action_for(&self, touch: &GateTouch<'_>) -> Option<GateAction> {
        if self.force_crossed(touch).is_some() {
            return Some(GateAction::Stop);
        }
        match self.border {
            Some(rule)
                if touch.hand
                    && touch.border_mm <= rule.within_mm
                    && !(touch.probability >= rule.hand_below) =>
            {
                Some(rule.action)
            }
            _ => self.action(touch.class),
        }
    }

    /// The action for the touches in progress (oldest first): stop if any asks to stop, else
    /// the action of the latest touch that has one; resume when none has.
    pub fn decide<'a, T: Into<GateTouch<'a>>>(&self, open: impl IntoIterator<Item = T>) -> GateAction {
        open.into_iter()
            .fold(None::<GateAction>, |acc, touch| {
                match (acc, self.action_for(&touch.into())) {
                    (Some(GateAction::Stop), _) => Some(GateAction::Stop),
                    (_, Some(a)) => Some(a),
                    (acc, None) => acc,
                }
            })
            .unwrap_or(GateAction::Resume)
    }
}

/// A decision consumed as a [`ContactGate`]: contacts may trigger interaction tasks only while
/// the robot complies.
impl ContactGate for GateAction {
    fn allows(&mut self, _: &str, _: &[Contact]) -> bool {
        *self == GateAction::Comply
    }
}

/// A gate that lets every contact through.
#[derive(Debug, Clone, Copy, Default)]
pub struct AllowAll;

impl ContactGate for AllowAll {
    fn allows(&mut self, _: &str, _: &[Contact]) -> bool {
        true
    }
}

impl<F: FnMut(&str, &[Contact]) -> bool> ContactGate for F {
    fn allows(&mut self, link: &str, contacts: &[Contact]) -> bool {
        self(link, contacts)
    }
}

/// Settings of the interaction tasks (SI units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HriParams {
    /// Top speed of task 1, m/s (0.3 in the thesis' experiment).
    pub v_max: f64,
    /// Contact force (mean over the contact) at which task 1 starts, newtons.
    pub force_min: f64,
    /// Contact force at which task 1 reaches `v_max`, newtons.
    pub force_max: f64,
    /// Normals cancel when the norm of their (unit) sum is under this: a two-hand grasp.
    pub zeta: f64,
    /// Joint speed per newton-metre of torque, rad/s per N m (tasks 2 and 3).
    pub torque_gain: f64,
}

impl Default for HriParams {
    fn default() -> Self {
        HriParams {
            v_max: 0.3,
            force_min: 1.0,
            force_max: 20.0,
            zeta: 0.5,
            torque_gain: 0.2,
        }
    }
}

/// Which interaction task triggered.
#[derive(Debug, Clone, PartialEq)]
pub enum HriKind {
    /// Task 1, on this link.
    MoveAlongPush {
        /// The touched link.
        link: String,
    },
    /// Task 2: turn this joint (the held link's own joint).
    TurnLink {
        /// Index of the joint in the chain.
        joint: usize,
    },
    /// Task 3: bend this joint (between two touched links).
    BendJoint {
        /// Index of the joint in the chain.
        joint: usize,
    },
}

fn usable(c: &Contact) -> bool {
    c.point.coords.iter().all(|v| v.is_finite())
        && c.normal.iter().all(|v| v.is_finite())
        && c.force.is_finite()
}

/// Index of the joint that moves `link` (its parent joint), if it is one of the chain's links.
fn joint_of(chain: &Chain, link: &str) -> Option<usize> {
    chain.joints().iter().position(|j| j.link == link)
}

/// Torque of the contacts (forces pushing into the skin, along minus the outward normal) about
/// joint `joint`'s axis at `q`.
fn torque(chain: &Chain, joint: usize, q: &[f64], contacts: &[Contact]) -> Result<f64, KinematicsError> {
    let pose = chain.link_poses(q)?[joint];
    let axis = pose.rotation * chain.joints()[joint].axis.into_inner();
    let origin = pose.translation.vector;
    Ok(contacts
        .iter()
        .map(|c| {
            (c.point.coords - origin)
                .cross(&(-c.normal.into_inner() * c.force))
                .dot(&axis)
        })
        .sum())
}

/// A joint-space task moving joint `joint` alone at `speed`.
fn joint_task(n: usize, joint: usize, speed: f64) -> Task {
    let mut j = DMatrix::zeros(1, n);
    j[(0, joint)] = 1.0;
    Task {
        jacobian: j,
        reference: DVector::from_element(1, speed),
        activation: 1.0,
    }
}

/// The interaction task the contacts call for, if any (see the module documentation).
pub fn interaction_task(
    chain: &Chain,
    q: &[f64],
    touched: &[LinkContacts],
    gate: &mut dyn ContactGate,
    params: &HriParams,
) -> Result<Option<(HriKind, Task)>, KinematicsError> {
    let n = chain.dof();
    // Links whose (usable) contacts the gate lets through.
    let mut live: Vec<(usize, &str, Vec<Contact>)> = Vec::new();
    for lc in touched {
        let contacts: Vec<Contact> = lc
            .contacts
            .iter()
            .copied()
            .filter(usable)
            .filter(|c| c.force > 0.0)
            .collect();
        if contacts.is_empty() || !gate.allows(&lc.link, &contacts) {
            continue;
        }
        let Some(joint) = joint_of(chain, &lc.link) else {
            return Err(KinematicsError::UnknownLink {
                name: lc.link.clone(),
                place: "the chain's moving links".into(),
                available: chain
                    .joints()
                    .iter()
                    .map(|j| j.link.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        live.push((joint, lc.link.as_str(), contacts));
    }
    live.sort_by_key(|l| l.0);
    // Task 3: two adjacent links touched.
    if let Some(w) = live.windows(2).find(|w| w[1].0 == w[0].0 + 1) {
        let joint = w[1].0;
        let speed = params.torque_gain * torque(chain, joint, q, &w[1].2)?;
        return Ok(Some((HriKind::BendJoint { joint }, joint_task(n, joint, speed))));
    }
    if live.len() != 1 {
        return Ok(None);
    }
    let (joint, link, contacts) = &live[0];
    // Task 2: a two-hand grasp, the normals cancelling.
    let sum: Vector3<f64> = contacts.iter().map(|c| c.normal.into_inner()).sum();
    if contacts.len() >= 2 && sum.norm() < params.zeta {
        let speed = params.torque_gain * torque(chain, *joint, q, contacts)?;
        return Ok(Some((
            HriKind::TurnLink { joint: *joint },
            joint_task(n, *joint, speed),
        )));
    }
    // Task 1: move the contact centroid along the mean normal, inwards.
    let k = sum.try_normalize(1e-9).unwrap_or_else(Vector3::zeros);
    let mean_force = contacts.iter().map(|c| c.force).sum::<f64>() / contacts.len() as f64;
    let span = (params.force_max - params.force_min).max(1e-9);
    let v = params.v_max * ((mean_force - params.force_min) / span).clamp(0.0, 1.0);
    let centroid =
        Point3::from(contacts.iter().map(|c| c.point.coords).sum::<Vector3<f64>>() / contacts.len() as f64);
    let at = chain.posture(q)?;
    let local = at.link_pose(link)?.inverse() * centroid;
    let mut reference = DVector::zeros(6);
    reference.rows_mut(0, 3).copy_from(&(-k * v));
    Ok(Some((
        HriKind::MoveAlongPush {
            link: link.to_string(),
        },
        Task {
            jacobian: at.jacobian(link, &local)?,
            reference,
            activation: 1.0,
        },
    )))
}

/// The gate as a configuration file writes it: actions by name, `[gate]` as a table of class
/// names (and `border`).
#[cfg(feature = "serde")]
mod config {
    use super::{BorderRule, ClassGate, GateAction};
    use serde::de::{self, Deserializer, MapAccess, Visitor};
    use serde::ser::{SerializeMap, Serializer};
    use std::fmt;

    /// An action is read by its name ([`str::parse`]), so a wrong one is named with the names
    /// there are.
    impl<'de> serde::Deserialize<'de> for GateAction {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<GateAction, D::Error> {
            let name = std::borrow::Cow::<'de, str>::deserialize(d)?;
            name.parse().map_err(de::Error::custom)
        }
    }

    /// An action is written as its name.
    impl serde::Serialize for GateAction {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            s.serialize_str(self.name())
        }
    }

    /// The keys of a `[gate]` table that are not a class's: the border rule, the force limits.
    const BORDER: &str = "border";
    const FORCE: &str = "force_n";

    /// `[gate]`: `border` is the border rule, `force_n` the force limits by class, every other
    /// key a class's name and its action.
    impl<'de> serde::Deserialize<'de> for ClassGate {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<ClassGate, D::Error> {
            d.deserialize_map(GateVisitor)
        }
    }

    struct GateVisitor;

    impl<'de> Visitor<'de> for GateVisitor {
        type Value = ClassGate;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(
                "a table of class names and actions (stop, comply, slow or resume), border and force_n",
            )
        }

        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ClassGate, A::Error> {
            let mut gate = ClassGate::default();
            while let Some(key) = map.next_key::<String>()? {
                if key == BORDER {
                    gate.border = Some(map.next_value::<BorderRule>()?);
                } else if key == FORCE {
                    gate.force_n = map.next_value::<ForceLimits>()?.0;
                } else {
                    let action = map.next_value_seed(ActionOf(&key))?;
                    gate.actions.insert(key, action);
                }
            }
            Ok(gate)
        }
    }

    /// `force_n = { class = newtons, ... }`, each limit's error naming its class.
    struct ForceLimits(std::collections::BTreeMap<String, f64>);

    impl<'de> serde::Deserialize<'de> for ForceLimits {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<ForceLimits, D::Error> {
            d.deserialize_map(LimitsVisitor)
        }
    }

    struct LimitsVisitor;

    impl<'de> Visitor<'de> for LimitsVisitor {
        type Value = ForceLimits;

        fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
            f.write_str(
                "force_n: a table of class names and force limits in newtons (force_n = { hand = 140 })",
            )
        }

        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ForceLimits, A::Error> {
            let mut limits = std::collections::BTreeMap::new();
            while let Some(class) = map.next_key::<String>()? {
                let n = map.next_value_seed(LimitOf(&class))?;
                limits.insert(class, n);
            }
            Ok(ForceLimits(limits))
        }
    }

    /// A class's force limit, its error naming the class.
    struct LimitOf<'k>(&'k str);

    impl<'de> de::DeserializeSeed<'de> for LimitOf<'_> {
        type Value = f64;

        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<f64, D::Error> {
            <f64 as serde::Deserialize>::deserialize(d).map_err(|e| {
                let class: String = self.0.chars().take(40).collect();
                de::Error::custom(format_args!("force_n.{class}: {e} (a force limit in newtons)"))
            })
        }
    }

    /// A class's action, read inside the value so that the file's line is the action's, and the
    /// error names the class whose action it is.
    struct ActionOf<'k>(&'k str);

    impl<'de> de::DeserializeSeed<'de> for ActionOf<'_> {
        type Value = GateAction;

        fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<GateAction, D::Error> {
            let name = <std::borrow::Cow<'de, str> as serde::Deserialize>::deserialize(d)?;
            name.parse().map_err(|e| {
                let class: String = self.0.chars().take(40).collect();
                de::Error::custom(format_args!("{class} = {e}"))
            })
        }
    }

    /// Written as it is read: the classes' actions, then `border` and `force_n`.
    impl serde::Serialize for ClassGate {
        fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
            let mut map = s.serialize_map(None)?;
            for (class, action) in &self.actions {
                map.serialize_entry(class, action)?;
            }
            if let Some(border) = &self.border {
                map.serialize_entry(BORDER, border)?;
            }
            if !self.force_n.is_empty() {
                map.serialize_entry(FORCE, &self.force_n)?;
            }
            map.end()
        }
    }
}

//! The scene file of the simulations: the obstacles, the goals and the starting postures (JSON).
//!
//! ```json
//! {
//!   "obstacles": [
//!     {"type": "capsule", "a": [0.5, -0.2, 0.3], "b": [0.5, 0.2, 0.3], "radius": 0.04},
//!     {"type": "box", "center": [0.6, 0.0, 0.1], "half_extents": [0.05, 0.2, 0.1], "rpy": [0, 0, 0.3]}
//!   ],
//!   "goals": [[0.65, 0.0, 0.2]],
//!   "random_starts": 10,
//!   "seed": 7
//! }
//! ```
//!
//! Every length is in metres, angles in radians, the base frame of the robot. An obstacle's size is
//! its outer size, padding included: the padding is what the linear spring model (Eq. 8.1)
//! compresses. Optional fields and their defaults:
//!
//! | field | default | meaning |
//! |---|---|---|
//! | `starts` | none | explicit starting postures, one joint vector each, used for every goal |
//! | `random_starts` | 10 | otherwise: this many random starts per goal (1 to 10000), drawn with `seed` |
//! | `seed` | 0 | seed of the random starts |
//! | `home` | arm7 reaching forward | centre of the random starts |
//! | `start_spread` | 0.25 | each joint uniformly within +-spread (rad) of `home` |
//! | `face_goal` | true | turn the first joint of `home` towards the goal's azimuth |
//! | `blocked_starts` | false | only accept random starts whose hand-to-goal segment crosses an obstacle |
//! | `stiffness` | 1000 | K of the spring model, N/m |
//! | `rate` | 200 | control and simulation rate, Hz |
//! | `max_speed` | 1.0 | joint speed limit, rad/s |
//! | `hand_speed` | 0.1 | top speed of the hand towards the goal, m/s |
//! | `timeout` | 60 | seconds of simulated time before a trial is given up |
//! | `stall_time` | 4 | a trial has stalled when the hand got no closer than 2 mm over this long (s) |
//! | `tolerance` | 0.005 | success radius around the goal, m |
//! | `urdf` | built-in 7-DOF arm | the robot, relative to the scene file |
//! | `base`, `tip` | `base`, `tool` | chain ends in the URDF |
//! | `radii` | 0.045 ... 0.03 | capsule radius of each moving link, m (one per joint) |

use nalgebra::{Point3, Vector3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The 7-DOF arm the project ships (`fixtures/arm7/arm7.urdf`), used when a scene names none.
pub const ARM7_URDF: &str = include_str!("../../../fixtures/arm7/arm7.urdf");

/// The default scene, modelled on the thesis' Fig. 8.4: five goals, each behind a padded bar.
pub const FIG_8_4: &str = include_str!("../../scenes/fig8_4.json");

/// What is wrong with a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Not valid scene JSON (the message names line and column).
    #[error("{origin}: {source}")]
    Json {
        /// The file, or "scene".
        origin: String,
        /// Why.
        source: serde_json::Error,
    },
    /// A field with an impossible value.
    #[error("{origin}: {field}: {why}")]
    Field {
        /// The file, or "scene".
        origin: String,
        /// Which field, e.g. `obstacles[2].radius`.
        field: String,
        /// Why.
        why: String,
    },
}

/// The text of a scene or URDF file, as every file read whole is read
/// ([`skin_core::format::read_text`]: bounded, byte-order mark skipped, encodings named).
fn read_text(path: &Path) -> Result<String, SceneError> {
    skin_core::format::read_text(path).map_err(|e| match e {
        skin_core::Error::Io { path, source } => SceneError::Io { path, source },
        skin_core::Error::Invalid { path, place, message } => SceneError::Field {
            origin: path.display().to_string(),
            field: place,
            why: message,
        },
        e => SceneError::Field {
            origin: path.display().to_string(),
            field: "file".into(),
            why: e.to_string(),
        },
    })
}

/// An obstacle, padding included.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum Obstacle {
    /// A padded bar: all points within `radius` of the segment a-b.
    Capsule {
        /// One end of the axis.
        a: [f64; 3],
        /// The other end.
        b: [f64; 3],
        /// Outer radius, m.
        radius: f64,
    },
    /// A box.
    Box {
        /// Centre.
        center: [f64; 3],
        /// Half the size along each of its axes, m.
        half_extents: [f64; 3],
        /// Roll, pitch, yaw of its axes, rad.
        #[serde(default)]
        rpy: [f64; 3],
    },
}

fn default_random_starts() -> usize {
    10
}
fn default_spread() -> f64 {
    0.25
}
fn default_true() -> bool {
    true
}
fn default_stiffness() -> f64 {
    1000.0
}
fn default_rate() -> f64 {
    200.0
}
fn default_max_speed() -> f64 {
    1.0
}
fn default_hand_speed() -> f64 {
    0.1
}
fn default_timeout() -> f64 {
    60.0
}
fn default_stall() -> f64 {
    4.0
}
fn default_tolerance() -> f64 {
    0.005
}
fn default_base() -> String {
    "base".into()
}
fn default_tip() -> String {
    "tool".into()
}

/// A scene, as read from its JSON file.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Obstacles.
    #[serde(default)]
    pub obstacles: Vec<Obstacle>,
    /// Goal positions of the hand.
    pub goals: Vec<[f64; 3]>,
    /// Explicit starting postures.
    #[serde(default)]
    pub starts: Option<Vec<Vec<f64>>>,
    /// Random starts per goal when `starts` is absent.
    #[serde(default = "default_random_starts")]
    pub random_starts: usize,
    /// Seed of the random starts.
    #[serde(default)]
    pub seed: u64,
    /// Centre of the random starts.
    #[serde(default)]
    pub home: Option<Vec<f64>>,
    /// Half-width of the random starts around `home`, rad.
    #[serde(default = "default_spread")]
    pub start_spread: f64,
    /// Turn the first joint of `home` towards each goal.
    #[serde(default = "default_true")]
    pub face_goal: bool,
    /// Accept only random starts whose straight hand-to-goal path crosses an obstacle.
    #[serde(default)]
    pub blocked_starts: bool,
    /// Spring stiffness K of the contact model, N/m.
    #[serde(default = "default_stiffness")]
    pub stiffness: f64,
    /// Control and simulation rate, Hz.
    #[serde(default = "default_rate")]
    pub rate: f64,
    /// Joint speed limit, rad/s.
    #[serde(default = "default_max_speed")]
    pub max_speed: f64,
    /// Top hand speed towards the goal, m/s.
    #[serde(default = "default_hand_speed")]
    pub hand_speed: f64,
    /// Simulated seconds before a trial times out.
    #[serde(default = "default_timeout")]
    pub timeout: f64,
    /// Seconds without 2 mm of progress that count as a stall.
    #[serde(default = "default_stall")]
    pub stall_time: f64,
    /// Success radius, m.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// The robot's URDF (relative to the scene file); the built-in arm when absent.
    #[serde(default)]
    pub urdf: Option<PathBuf>,
    /// Base link of the chain.
    #[serde(default = "default_base")]
    pub base: String,
    /// Tip link (the hand) of the chain.
    #[serde(default = "default_tip")]
    pub tip: String,
    /// Capsule radius of each moving link.
    #[serde(default)]
    pub radii: Option<Vec<f64>>,
    /// Where the scene was read from (for relative paths).
    #[serde(skip)]
    pub origin: Option<PathBuf>,
    /// How messages name the scene.
    #[serde(skip)]
    pub label: String,
}

impl Scene {
    /// Reads and checks a scene file.
    pub fn from_file(path: &Path) -> Result<Scene, SceneError> {
        let text = read_text(path)?;
        let mut scene = Scene::parse(&text, &path.display().to_string())?;
        scene.origin = Some(path.into());
        Ok(scene)
    }

    /// Parses and checks scene JSON; `origin` names it in errors.
    pub fn parse(text: &str, origin: &str) -> Result<Scene, SceneError> {
        let scene: Scene = serde_json::from_str(text).map_err(|source| SceneError::Json {
            origin: origin.into(),
            source,
        })?;
        scene.check(origin)?;
        let mut scene = scene;
        scene.label = origin.into();
        Ok(scene)
    }

    /// The default scene (Fig. 8.4).
    pub fn fig_8_4() -> Result<Scene, SceneError> {
        Scene::parse(FIG_8_4, "fig8_4.json (built in)")
    }

    /// The origin name used in messages.
    pub fn name(&self) -> String {
        self.label.clone()
    }

    /// The URDF text and its name.
    pub fn urdf_text(&self) -> Result<(String, String), SceneError> {
        match &self.urdf {
            None => Ok((ARM7_URDF.into(), "arm7.urdf (built in)".into())),
            Some(p) => {
                let path = match &self.origin {
                    Some(o) if p.is_relative() => o.parent().unwrap_or(Path::new(".")).join(p),
                    _ => p.clone(),
                };
                let text = read_text(&path)?;
                Ok((text, path.display().to_string()))
            }
        }
    }

    /// Goals as points.
    pub fn goal_points(&self) -> Vec<Point3<f64>> {
        self.goals.iter().map(|g| Point3::from(*g)).collect()
    }

    fn check(&self, origin: &str) -> Result<(), SceneError> {
        let bad = |field: String, why: &str| SceneError::Field {
            origin: origin.into(),
            field,
            why: why.into(),
        };
        self.check_obstacles(&bad)?;
        self.check_trials(&bad)?;
        self.check_settings(&bad)
    }

    /// Obstacles within the world's bounds, with positive sizes.
    fn check_obstacles(&self, bad: &dyn Fn(String, &str) -> SceneError) -> Result<(), SceneError> {
        for (i, o) in self.obstacles.iter().enumerate() {
            match o {
                Obstacle::Capsule { a, b, radius } => {
                    if !within_world(a) || !within_world(b) {
                        return Err(bad(
                            format!("obstacles[{i}]"),
                            "end points must be finite, within 100 m",
                        ));
                    }
                    if !positive_within_world(*radius) {
                        return Err(bad(
                            format!("obstacles[{i}].radius"),
                            "must be positive, at most 100 m",
                        ));
                    }
                }
                Obstacle::Box {
                    center,
                    half_extents,
                    rpy,
                } => {
                    if !within_world(center) || !within_world(rpy) {
                        return Err(bad(
                            format!("obstacles[{i}]"),
                            "centre and rpy must be finite, within 100 m",
                        ));
                    }
                    if !half_extents.iter().all(|&h| positive_within_world(h)) {
                        return Err(bad(
                            format!("obstacles[{i}].half_extents"),
                            "must be positive, at most 100 m",
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    /// Goals and starts: how many (a study of thousands of trials is hours already), and each
    /// within the world's bounds.
    fn check_trials(&self, bad: &dyn Fn(String, &str) -> SceneError) -> Result<(), SceneError> {
        if self.goals.is_empty() || self.goals.len() > MAX_TRIALS {
            return Err(bad("goals".into(), &format!("give 1 to {MAX_TRIALS} goals")));
        }
        if !(1..=MAX_TRIALS).contains(&self.random_starts) {
            return Err(bad(
                "random_starts".into(),
                &format!("must be 1 to {MAX_TRIALS} starts per goal"),
            ));
        }
        for (i, g) in self.goals.iter().enumerate() {
            if !within_world(g) {
                return Err(bad(format!("goals[{i}]"), "must be finite, within 100 m"));
            }
        }
        if let Some(starts) = &self.starts {
            if starts.is_empty() {
                return Err(bad("starts".into(), "empty; leave it out for random starts"));
            }
            if starts.len() > MAX_TRIALS {
                return Err(bad("starts".into(), &format!("at most {MAX_TRIALS} starts")));
            }
            for (i, s) in starts.iter().enumerate() {
                if !within_world(s) {
                    return Err(bad(format!("starts[{i}]"), "must be finite, within 100 rad"));
                }
            }
        }
        Ok(())
    }

    /// The robot's home and radii, and the simulation's settings, each in its range.
    fn check_settings(&self, bad: &dyn Fn(String, &str) -> SceneError) -> Result<(), SceneError> {
        if let Some(h) = &self.home
            && !within_world(h)
        {
            return Err(bad("home".into(), "must be finite, within 100 rad"));
        }
        if let Some(r) = &self.radii
            && !r.iter().all(|&x| positive_within_world(x))
        {
            return Err(bad("radii".into(), "must be positive, at most 100 m"));
        }
        for (name, v, max) in [
            ("stiffness", self.stiffness, 1e9),
            ("rate", self.rate, 10_000.0),
            ("max_speed", self.max_speed, 100.0),
            ("hand_speed", self.hand_speed, 100.0),
            ("timeout", self.timeout, 3600.0),
            ("stall_time", self.stall_time, 3600.0),
            ("tolerance", self.tolerance, 10.0),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= max) {
                return Err(bad(name.into(), &format!("must be positive, at most {max}")));
            }
        }
        if self.rate * self.timeout > MAX_STEPS {
            return Err(bad(
                "rate".into(),
                &format!(
                    "rate x timeout is {:.0} steps a trial; at most {MAX_STEPS:.0}",
                    self.rate * self.timeout
                ),
            ));
        }
        if !(self.start_spread.is_finite() && (0.0..=WORLD_M).contains(&self.start_spread)) {
            return Err(bad("start_spread".into(), "must be from 0 to 100 rad"));
        }
        Ok(())
    }
}

// Bounds keep the collision geometry (parry) and the simulation loop in the range they are made
// for: a 1e100 m capsule makes parry's penetration search index out of bounds, a 1e9 Hz rate runs
// for hours.

/// Every value finite and within [`WORLD_M`].
fn within_world(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite() && x.abs() <= WORLD_M)
}

/// Finite, positive and at most [`WORLD_M`].
fn positive_within_world(x: f64) -> bool {
    x.is_finite() && x > 0.0 && x <= WORLD_M
}

/// The largest coordinate or length a scene may hold, m (and angle, rad).
pub const WORLD_M: f64 = 100.0;
/// The most simulation steps one trial may take (`rate` x `timeout`).
const MAX_STEPS: f64 = 2e6;
/// The most goals, and starts per goal, a scene may ask for: a study of thousands of trials is
/// hours already.
const MAX_TRIALS: usize = 10_000;

/// Roll-pitch-yaw to a rotation, as URDF.
pub(crate) fn rpy(r: &[f64; 3]) -> nalgebra::UnitQuaternion<f64> {
    nalgebra::UnitQuaternion::from_euler_angles(r[0], r[1], r[2])
}

/// A vector from an array.
pub(crate) fn v3(a: &[f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0], a[1], a[2])
}

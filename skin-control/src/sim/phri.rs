//! Experiment 2 of the thesis' Ch. 9.3, simulated: the arm follows a path at 0.03 m/s (low
//! priority); something bumps its forearm by accident, which the gate must ignore; then a hand
//! pushes the forearm, the gate lets it through and task 1 (move along the push, V_max 0.3 m/s)
//! takes over until the hand lets go, after which the path is picked up again.
//!
//! The touches are scripted solids: the bump a large rounded body (a shoulder), the push three
//! finger-sized capsules across the forearm, 3.5 cm apart, that advance into it at a hand's speed
//! and then withdraw. The gate of the run is [`FingerGate`], a stand-in for the hand classifier
//! (Ch. 4): it calls a touch a hand when at least three separate contacts are on the link, and
//! only once they have lasted the classifier's latency (0.07 s in the thesis, acquisition
//! included). Any [`ContactGate`] can be used instead.

use super::reach::integrate;
use super::scene::{Scene, SceneError};
use super::world::{BodyPart, Solid, World};
use crate::contact_tasks::Contact;
use crate::hri::{ContactGate, HriKind, HriParams, interaction_task};
use crate::path_following::{PathFollowing, PathReference};
use crate::task_stack::{Regularisation, Task, TaskStack};
use nalgebra::{DMatrix, DVector, Point3, Vector3};

/// Distance between the simulated fingers, metres: far enough apart on 10 mm taxels for the
/// skin to see three contacts, close enough for all three to stay on one 15 cm link.
const FINGER_SPACING: f64 = 0.035;

/// The gate of the simulated experiment: a hand is at least `fingers` separate contacts on the
/// link, lasting `latency` seconds.
#[derive(Debug, Clone)]
pub struct FingerGate {
    /// Separate contacts needed.
    pub fingers: usize,
    /// How long they must last before the gate opens, seconds.
    pub latency: f64,
    dt: f64,
    held: f64,
}

impl FingerGate {
    /// A gate for a control loop running every `dt` seconds.
    pub fn new(fingers: usize, latency: f64, dt: f64) -> FingerGate {
        FingerGate {
            fingers,
            latency,
            dt,
            held: 0.0,
        }
    }

    /// Advances the gate's clock by one cycle in which no contact was offered.
    fn idle(&mut self) {
        self.held = 0.0;
    }
}

impl ContactGate for FingerGate {
    fn allows(&mut self, _link: &str, contacts: &[Contact]) -> bool {
        if contacts.len() >= self.fingers {
            self.held += self.dt;
        } else {
            self.held = 0.0;
        }
        self.held + 1e-12 >= self.latency
    }
}

/// One control cycle of the run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time, seconds.
    pub t: f64,
    /// Largest contact force on the arm (spring model), newtons.
    pub force: f64,
    /// Contacts the skin reports on the arm.
    pub contacts: usize,
    /// True while task 1 (move along the push) is active.
    pub task1: bool,
    /// Task 1's reference speed of the contact centroid, m/s (0 when inactive).
    pub reference_speed: f64,
    /// The speed the centroid actually got, m/s (0 when inactive).
    pub centroid_speed: f64,
    /// Distance from the hand to the path, metres.
    pub path_error: f64,
    /// Progress along the path, metres.
    pub progress: f64,
}

/// What touches the arm and when.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhriScript {
    /// Path speed, m/s.
    pub path_speed: f64,
    /// When the accidental bump starts and how long it lasts, seconds.
    pub bump: (f64, f64),
    /// How deep the bump presses into the skin at most, metres.
    pub bump_depth: f64,
    /// When the hand push starts and how long the hand keeps advancing, seconds.
    pub push: (f64, f64),
    /// The hand's speed while it pushes, m/s.
    pub push_speed: f64,
    /// Length of the run, seconds.
    pub duration: f64,
}

impl Default for PhriScript {
    fn default() -> Self {
        // The thesis' timeline: bump at about 2.9 s to 3.6 s, push from about 6 s.
        PhriScript {
            path_speed: 0.03,
            bump: (2.9, 0.7),
            bump_depth: 0.015,
            push: (6.0, 2.5),
            push_speed: 0.1,
            duration: 14.0,
        }
    }
}

/// The run's record.
#[derive(Debug, Clone, PartialEq)]
pub struct PhriRun {
    /// Every control cycle.
    pub samples: Vec<Sample>,
    /// The script that was played.
    pub script: PhriScript,
    /// The link that was touched.
    pub link: String,
}

impl PhriRun {
    /// Samples within [from, to).
    pub fn between(&self, from: f64, to: f64) -> impl Iterator<Item = &Sample> {
        self.samples.iter().filter(move |s| s.t >= from && s.t < to)
    }

    /// When task 1 first became active at or after `from`.
    pub fn task1_from(&self, from: f64) -> Option<f64> {
        self.samples.iter().find(|s| s.t >= from && s.task1).map(|s| s.t)
    }
}

/// The link the touches are aimed at: the forearm (the second-to-last link with a capsule of
/// length, in the thesis the one carrying the skin of the experiment).
fn forearm(world: &World) -> Option<usize> {
    let parts = world.parts();
    // The longest part among the last three (the forearm of a 7-DOF arm).
    let start = parts.len().saturating_sub(3);
    (start..parts.len()).max_by(|&a, &b| {
        let la = (parts[a].b - parts[a].a).norm();
        let lb = (parts[b].b - parts[b].a).norm();
        la.total_cmp(&lb)
    })
}

/// Plays `script` on the scene's robot, starting at `start` (joint values).
pub fn run(scene: &Scene, start: &[f64], script: &PhriScript) -> Result<PhriRun, SceneError> {
    let world = World::from_scene(scene)?;
    let chain = world.chain();
    let n = chain.dof();
    let bad = |field: &str, why: String| SceneError::Field {
        origin: scene.name(),
        field: field.into(),
        why,
    };
    if start.len() != n {
        return Err(bad(
            "start",
            format!("{} joint values for {n} joints", start.len()),
        ));
    }
    let dt = 1.0 / scene.rate;
    let limits: Vec<(f64, f64)> = chain.joints().iter().map(|j| j.limits).collect();
    let at0 = chain.posture(start).map_err(|e| bad("start", e.to_string()))?;
    let hand0 = world.hand(&at0);
    // The path: three sides of a 20 x 10 cm rectangle in the vertical plane across the arm,
    // from the hand (open, so that the nearest path point is never its far end).
    let side = Vector3::new(-hand0.y, hand0.x, 0.0)
        .try_normalize(1e-9)
        .unwrap_or(Vector3::y());
    let up = Vector3::z();
    let mut path = rectangle_path(hand0, side, up, script.path_speed).map_err(|e| bad("path", e))?;
    let f = forearm(&world).ok_or_else(|| bad("robot", "no link to touch".into()))?;
    let part = world.parts()[f].clone();
    let mut stack = TaskStack::new(n, Regularisation::default());
    let mut gate = FingerGate::new(3, 0.07, dt);
    let params = push_params();
    let mut q = start.to_vec();
    let mut samples = Vec::new();
    let mut touches = Touches::default();
    let steps = (script.duration / dt).round() as usize;
    for k in 0..steps {
        let t = k as f64 * dt;
        let at = chain.posture(&q).map_err(|e| bad("start", e.to_string()))?;
        let pose = at
            .link_pose(&part.link)
            .map_err(|e| bad("robot", e.to_string()))?;
        let touching = touches.solids(script, t, &pose, &part, side);
        let sensing = world.sense(&at, &touching);
        let hand = world.hand(&at);
        let path_ref = path.reference(&hand);
        // The path task: the hand's linear velocity.
        let hand_jac = at
            .jacobian(world.tip(), &Point3::origin())
            .map_err(|e| bad("robot", e.to_string()))?;
        let touched = &sensing.contacts;
        if touched.is_empty() {
            gate.idle();
        }
        let hri = interaction_task(chain, &q, touched, &mut gate, &params)
            .map_err(|e| bad("robot", e.to_string()))?;
        let mut sample = Sample {
            t,
            force: sensing.max_force,
            contacts: touched.iter().map(|l| l.contacts.len()).sum(),
            task1: false,
            reference_speed: 0.0,
            centroid_speed: 0.0,
            path_error: path_ref.error,
            progress: path_ref.progress,
        };
        let (tasks, task1) = step_tasks(hri, &hand_jac, &path_ref);
        let qdot = stack.solve(&tasks).unwrap_or_else(|_| DVector::zeros(n));
        if let Some((jac, speed)) = task1 {
            sample.task1 = true;
            sample.reference_speed = speed;
            sample.centroid_speed = (jac * &qdot).norm();
        }
        samples.push(sample);
        integrate(&mut q, &qdot, dt, scene.max_speed, &limits);
    }
    Ok(PhriRun {
        samples,
        script: *script,
        link: part.link,
    })
}

/// Task 1's speed: from 0 at 1 N (mean contact force) to V_max = 0.3 m/s at 10 N.
fn push_params() -> HriParams {
    HriParams {
        v_max: 0.3,
        force_min: 1.0,
        force_max: 10.0,
        ..HriParams::default()
    }
}

/// The path of the run: three sides of a 20 x 10 cm rectangle from `hand0`, along `side` and
/// down `up`, followed at `speed`.
fn rectangle_path(
    hand0: Point3<f64>,
    side: Vector3<f64>,
    up: Vector3<f64>,
    speed: f64,
) -> Result<PathFollowing, String> {
    PathFollowing::new(
        &[
            hand0,
            hand0 + side * 0.2,
            hand0 + side * 0.2 - up * 0.1,
            hand0 - up * 0.1,
        ],
        speed,
        2.0,
    )
    .map_err(|e| e.to_string())
}

/// The scripted touches. Each is placed where the forearm is when it starts, and stays there.
#[derive(Default)]
struct Touches {
    bump_at: Option<(Point3<f64>, Vector3<f64>)>,
    push_at: Option<(Point3<f64>, Vector3<f64>, Vector3<f64>)>,
}

impl Touches {
    /// The solids touching the forearm `part` (at `pose`) at time `t`: the bump, the push's
    /// fingers, or neither.
    fn solids(
        &mut self,
        script: &PhriScript,
        t: f64,
        pose: &nalgebra::Isometry3<f64>,
        part: &BodyPart,
        side: Vector3<f64>,
    ) -> Vec<Solid> {
        let up = Vector3::z();
        // Forearm mid-point, axis, and the horizontal direction across it (towards the path's
        // side, so the push helps nothing by accident).
        let mid = pose * Point3::from((part.a.coords + part.b.coords) / 2.0);
        let axis = (pose.rotation * (part.b - part.a)).normalize();
        let across = axis.cross(&up).try_normalize(1e-9).unwrap_or(side);
        let mut touching: Vec<Solid> = Vec::new();
        let (b0, bd) = script.bump;
        if t >= b0 && t < b0 + bd {
            let (c, dir) = *self.bump_at.get_or_insert((mid, across));
            // In and out along a half sine, `bump_depth` at the middle.
            let depth = script.bump_depth * (std::f64::consts::PI * (t - b0) / bd).sin();
            let r = 0.1;
            let centre = c + dir * (part.radius + r - depth);
            touching.push(Solid::capsule(&(centre - up * 0.1), &(centre + up * 0.1), r));
        }
        let (p0, pd) = script.push;
        if t >= p0 && t < p0 + pd {
            let (c, ax, dir) = *self.push_at.get_or_insert((mid, axis, -across));
            // The fingers start 5 mm off the skin, advance at push_speed, then let go.
            let r = 0.008;
            let travel = script.push_speed * (t - p0);
            let front = c + dir * (part.radius + r + 0.005 - travel);
            for i in 0..3 {
                let along = ax * (FINGER_SPACING * (i as f64 - 1.0));
                let across_fingers = ax.cross(&dir).normalize() * 0.05;
                touching.push(Solid::capsule(
                    &(front + along - across_fingers),
                    &(front + along + across_fingers),
                    r,
                ));
            }
        }
        touching
    }
}

/// One step's tasks, by priority: the interaction task when the gate let a touch lead, then the
/// path (the hand's linear velocity). With them, task 1's Jacobian rows and reference speed when
/// it moves the arm along a push, for the sample.
fn step_tasks(
    hri: Option<(HriKind, Task)>,
    hand_jac: &DMatrix<f64>,
    path_ref: &PathReference,
) -> (Vec<Task>, Option<(DMatrix<f64>, f64)>) {
    let mut tasks: Vec<Task> = Vec::new();
    let mut task1: Option<(DMatrix<f64>, f64)> = None;
    if let Some((kind, task)) = hri {
        if matches!(kind, HriKind::MoveAlongPush { .. }) {
            let speed = task.reference.rows(0, 3).norm();
            task1 = Some((task.jacobian.rows(0, 3).into_owned(), speed));
        }
        tasks.push(task);
    }
    tasks.push(Task {
        jacobian: hand_jac.rows(0, 3).into_owned(),
        reference: DVector::from_column_slice(path_ref.velocity.as_slice()),
        activation: 1.0,
    });
    (tasks, task1)
}

/// The starting posture of the run on the built-in arm: the hand in front at shoulder height.
pub fn default_start(n: usize) -> Vec<f64> {
    let mut q = vec![0.0; n];
    for (i, v) in [0.0, 0.3, 0.0, 1.4, 0.0, 0.6, 0.0].iter().enumerate().take(n) {
        q[i] = *v;
    }
    q
}

/// The scene of the run when none is given: the built-in arm, no obstacles.
pub fn default_scene() -> Result<Scene, SceneError> {
    Scene::parse(r#"{"goals": [[0.5, 0.0, 0.5]]}"#, "phri (built in: no obstacles)")
}

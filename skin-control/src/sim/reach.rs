//! The reach-through-clutter experiment (thesis Ch. 8.5-8.6): from each starting posture, drive
//! the hand to the goal with the [`SkinController`]; success is the hand within the tolerance
//! (5 mm) of the goal without any contact force above F_thresh. A trial fails by
//! **force** (F_thresh exceeded: stopped at once, as on the robot), **stall** (a local minimum:
//! the hand got no closer by 2 mm over `stall_time`) or **timeout**.
//!
//! The simulation is kinematic, at the velocity level, as the controller commands it: each step
//! the skin is read at the current posture, the controller gives joint velocities, they are
//! scaled down uniformly if any exceeds the joint speed limit, integrated over 1/rate, and the
//! joints clamped to their limits. Deterministic: the same scene and seed give the same trials.

use super::scene::{Scene, SceneError};
use super::world::World;
use crate::contact_tasks::Gains;
use crate::controller::{ForceGuard, ReachGoal, SkinController};
use crate::escape::Escape;
use crate::task_stack::Regularisation;
use nalgebra::{DVector, Point3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How a trial ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Outcome {
    /// Reached the goal within tolerance, no force above the threshold.
    Success,
    /// A contact force exceeded the threshold.
    Force,
    /// No progress (a local minimum).
    Stall,
    /// Out of time.
    Timeout,
}

impl Outcome {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Outcome::Success => "success",
            Outcome::Force => "force",
            Outcome::Stall => "stall",
            Outcome::Timeout => "timeout",
        }
    }
}

/// One trial's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trial {
    /// Goal index in the scene.
    pub goal: usize,
    /// Start index for that goal.
    pub start: usize,
    /// How it ended.
    pub outcome: Outcome,
    /// Largest contact force during the trial (spring model), newtons.
    pub max_force: f64,
    /// Largest force any taxel reported, newtons.
    pub max_skin_force: f64,
    /// Simulated time at the end, seconds.
    pub time: f64,
    /// Hand-to-goal distance at the end, metres.
    pub distance: f64,
}

/// Settings of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReachOptions {
    /// F_thresh of the activations and of the success criterion, newtons.
    pub threshold: f64,
    /// Run without the skin: the controller gets no contacts (the baseline).
    pub no_skin: bool,
    /// Task gains.
    pub gains: Gains,
    /// Regularisation of the task stack.
    pub regularisation: Regularisation,
    /// Slow the reach near F_thresh ([`ForceGuard`]); `None` is the thesis' controller.
    pub guard: Option<ForceGuard>,
    /// Step out of local minima ([`Escape`]); `None` is the thesis' controller.
    pub escape: Option<Escape>,
}

impl ReachOptions {
    /// The thesis' controller as published (Ch. 8): no force guard, no escape.
    pub fn thesis() -> ReachOptions {
        ReachOptions {
            guard: None,
            escape: None,
            ..ReachOptions::default()
        }
    }
}

impl Default for ReachOptions {
    fn default() -> Self {
        ReachOptions {
            threshold: 15.0,
            no_skin: false,
            gains: Gains {
                contact: 5.0,
                ..Gains::default()
            },
            regularisation: Regularisation::default(),
            guard: Some(ForceGuard::default()),
            escape: Some(Escape::default()),
        }
    }
}

/// The experiment: a scene, its world and the starting postures of every goal.
#[derive(Debug, Clone)]
pub struct ReachExperiment {
    scene: Scene,
    world: World,
    /// starts[goal][trial]
    starts: Vec<Vec<Vec<f64>>>,
}

/// Random starting postures tried per accepted one before giving up.
const START_ATTEMPTS: usize = 2000;

impl ReachExperiment {
    /// Prepares the experiment: `trials` starts per goal (`None`: the scene's own count), from the
    /// scene's explicit starts or drawn at random with its seed.
    pub fn new(scene: &Scene, trials: Option<usize>) -> Result<ReachExperiment, SceneError> {
        let world = World::from_scene(scene)?;
        let n = world.chain().dof();
        let bad = |field: &str, why: String| SceneError::Field {
            origin: scene.name(),
            field: field.into(),
            why,
        };
        let goals = scene.goal_points();
        let starts = match &scene.starts {
            Some(list) => {
                for (i, s) in list.iter().enumerate() {
                    if s.len() != n {
                        return Err(bad(
                            &format!("starts[{i}]"),
                            format!("{} joint values for a chain of {n} joints", s.len()),
                        ));
                    }
                }
                let count = trials.unwrap_or(list.len());
                if count > list.len() {
                    return Err(bad(
                        "starts",
                        format!("{count} trials asked for, the scene lists {} starts", list.len()),
                    ));
                }
                vec![list[..count].to_vec(); goals.len()]
            }
            None => {
                let count = trials.unwrap_or(scene.random_starts);
                let home = match &scene.home {
                    Some(h) if h.len() != n => {
                        return Err(bad("home", format!("{} joint values for {n} joints", h.len())));
                    }
                    Some(h) => h.clone(),
                    None => default_home(n),
                };
                let mut all = Vec::new();
                for (g, goal) in goals.iter().enumerate() {
                    all.push(random_starts(scene, &world, &home, g, goal, count)?);
                }
                all
            }
        };
        Ok(ReachExperiment {
            scene: scene.clone(),
            world,
            starts,
        })
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Starting postures of goal `goal`.
    pub fn starts(&self, goal: usize) -> &[Vec<f64>] {
        self.starts.get(goal).map_or(&[], |s| s.as_slice())
    }

    /// Every (goal, start) pair, in table order.
    pub fn trials(&self) -> Vec<(usize, usize)> {
        (0..self.starts.len())
            .flat_map(|g| (0..self.starts[g].len()).map(move |s| (g, s)))
            .collect()
    }

    /// The controller of a trial: the thesis' task stack with the options' gains, guard and the
    /// scene's hand speed.
    fn controller(&self, options: &ReachOptions) -> Result<SkinController, crate::KinematicsError> {
        Ok(SkinController::new(
            self.world.chain().clone(),
            self.world.tip(),
            options.regularisation,
            Gains {
                max_speed: self.scene.hand_speed,
                ..options.gains
            },
            options.threshold,
        )?
        .with_force_guard(options.guard))
    }

    /// Runs one trial.
    pub fn run(&self, goal: usize, start: usize, options: &ReachOptions) -> Result<Trial, SceneError> {
        let bad = |why: String| SceneError::Field {
            origin: self.scene.name(),
            field: "goals".into(),
            why,
        };
        let q0 = self
            .starts
            .get(goal)
            .and_then(|s| s.get(start))
            .ok_or_else(|| bad(format!("no trial {start} of goal {goal}")))?;
        let target = Point3::from(self.scene.goals[goal]);
        let mut controller = self.controller(options).map_err(|e| bad(e.to_string()))?;
        let mut escaping = options.escape.map(|e| e.start());
        let mut reach = ReachGoal {
            goal: target,
            hand: Point3::origin(),
            tool_axis: Vector3::z_axis(),
        };
        let dt = 1.0 / self.scene.rate;
        let limits: Vec<(f64, f64)> = self.world.chain().joints().iter().map(|j| j.limits).collect();
        let mut q = q0.clone();
        let mut t = 0.0;
        let mut max_force: f64 = 0.0;
        let mut max_skin: f64 = 0.0;
        // Best distance so far and when it last improved by 2 mm.
        let mut best = f64::INFINITY;
        let mut best_at = 0.0;
        let finish = |outcome, t, max_force, max_skin, distance| Trial {
            goal,
            start,
            outcome,
            max_force,
            max_skin_force: max_skin,
            time: t,
            distance,
        };
        loop {
            let at = self.world.chain().posture(&q).map_err(|e| bad(e.to_string()))?;
            let sensing = self.world.sense(&at, &[]);
            max_force = max_force.max(sensing.max_force);
            max_skin = max_skin.max(sensing.skin_max);
            let distance = (self.world.hand(&at) - target).norm();
            if sensing.max_force > options.threshold {
                return Ok(finish(Outcome::Force, t, max_force, max_skin, distance));
            }
            if distance <= self.scene.tolerance {
                return Ok(finish(Outcome::Success, t, max_force, max_skin, distance));
            }
            // An escape is a detour, not a stall: the clock runs from its end.
            let escaping_now = escaping.as_ref().is_some_and(|e| e.escaping());
            if distance < best - 0.002 || escaping_now {
                best = distance;
                best_at = t;
            } else if t - best_at > self.scene.stall_time {
                return Ok(finish(Outcome::Stall, t, max_force, max_skin, distance));
            }
            if t >= self.scene.timeout {
                return Ok(finish(Outcome::Timeout, t, max_force, max_skin, distance));
            }
            let contacts = if options.no_skin {
                &[][..]
            } else {
                &sensing.contacts[..]
            };
            if let Some(e) = &mut escaping {
                reach.goal = e.target(t, &self.world.hand(&at), &target, contacts);
            }
            let qdot = controller
                .step(&q, contacts, Some(&reach))
                .map_err(|e| bad(e.to_string()))?;
            integrate(&mut q, &qdot, dt, self.scene.max_speed, &limits);
            t += dt;
        }
    }
}

/// q += dt q_dot, q_dot scaled down uniformly so no joint exceeds `max_speed`, then clamped to
/// the joint limits.
pub(crate) fn integrate(q: &mut [f64], qdot: &DVector<f64>, dt: f64, max_speed: f64, limits: &[(f64, f64)]) {
    let peak = qdot.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let scale = if peak > max_speed { max_speed / peak } else { 1.0 };
    for ((qi, v), (lo, hi)) in q.iter_mut().zip(qdot.iter()).zip(limits) {
        if v.is_finite() {
            *qi = (*qi + v * scale * dt).clamp(*lo, *hi);
        }
    }
}

/// The built-in arm's home: shoulder and elbow bent, the hand forward at about 0.5 m height.
fn default_home(n: usize) -> Vec<f64> {
    let mut h = vec![0.0; n];
    for (i, v) in [0.0, 0.5, 0.0, 1.3, 0.0, 0.6, 0.0].iter().enumerate().take(n) {
        h[i] = *v;
    }
    h
}

/// `count` random starts for goal `g`: `home` (its first joint turned to face the goal if the
/// scene asks), each joint within +-start_spread, clear of every obstacle (no contact), and, when
/// the scene asks, with the straight hand-to-goal path blocked.
fn random_starts(
    scene: &Scene,
    world: &World,
    home: &[f64],
    g: usize,
    goal: &Point3<f64>,
    count: usize,
) -> Result<Vec<Vec<f64>>, SceneError> {
    let mut rng = ChaCha8Rng::seed_from_u64(scene.seed);
    rng.set_stream(g as u64);
    let mut centre = home.to_vec();
    if scene.face_goal && !centre.is_empty() {
        centre[0] = goal.y.atan2(goal.x);
    }
    let limits: Vec<(f64, f64)> = world.chain().joints().iter().map(|j| j.limits).collect();
    let mut out = Vec::with_capacity(count);
    let mut attempts = 0;
    while out.len() < count {
        attempts += 1;
        if attempts > START_ATTEMPTS * count.max(1) {
            return Err(SceneError::Field {
                origin: scene.name(),
                field: format!("goals[{g}]"),
                why: format!(
                    "found only {} of {count} usable random starts (clear of obstacles{}) in {} tries",
                    out.len(),
                    if scene.blocked_starts {
                        ", path to the goal blocked"
                    } else {
                        ""
                    },
                    attempts - 1
                ),
            });
        }
        let q: Vec<f64> = centre
            .iter()
            .zip(&limits)
            .map(|(c, (lo, hi))| {
                let d = if scene.start_spread > 0.0 {
                    rng.random_range(-scene.start_spread..=scene.start_spread)
                } else {
                    0.0
                };
                (c + d).clamp(*lo, *hi)
            })
            .collect();
        let Ok(at) = world.chain().posture(&q) else {
            continue;
        };
        if world.sense(&at, &[]).max_force > 0.0 {
            continue;
        }
        if scene.blocked_starts && !world.blocked(&world.hand(&at), goal) {
            continue;
        }
        out.push(q);
    }
    Ok(out)
}

//! A way out of the local minima between obstacles, which the thesis' controller lacks.
//!
//! The reach of Ch. 8 pulls the hand straight at the goal while the contact tasks push each
//! touched link off its obstacle. Where the two balance (the arm pinned against a bar that lies
//! between the hand and the goal) the arm stops: the "local minima" the thesis names as its
//! controller's failures (Ch. 8.6). Here, when the hand has got no closer to the goal by
//! [`Escape::progress`] over [`Escape::after`] seconds, the goal is replaced for a while by a via
//! point [`Escape::distance`] from the hand, across the obstacle: perpendicular to the contacts'
//! force-weighted normal, on the goal's side, and a little back from the obstacle. The reach
//! returns to the goal once the hand is within 1 cm of the via point or [`Escape::time`] has
//! passed. The first escape heads across on the goal's side (upwards where the goal lies straight
//! behind the obstacle); each further one of the same reach turns a quarter turn further about
//! the normal, so four escapes try four sides of the obstacle; at most [`Escape::tries`].
//!
//! The caller's own stall rule should give an escape time to act: judge progress from the end of
//! an escape, and allow more than [`Escape::after`] without it (the reach simulation allows 4 s).
//!
//! Only the goal moves: the task stack, its priorities and the contact tasks are the thesis'.

use crate::controller::LinkContacts;
use nalgebra::{Point3, Vector3};

/// Settings of the escape (defaults: the figures the reach experiment was tuned with).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Escape {
    /// Progress that counts, metres.
    pub progress: f64,
    /// Seconds without progress before an escape.
    pub after: f64,
    /// How far the via point lies from the hand, metres.
    pub distance: f64,
    /// How far back from the obstacle, as a fraction of `distance`.
    pub back: f64,
    /// The longest an escape lasts, seconds.
    pub time: f64,
    /// Escapes per reach.
    pub tries: usize,
}

impl Default for Escape {
    fn default() -> Self {
        Escape {
            progress: 0.002,
            after: 1.0,
            distance: 0.1,
            back: 0.2,
            time: 1.5,
            tries: 6,
        }
    }
}

/// One reach's escapes: call [`Escaping::target`] every cycle for the point to reach.
#[derive(Debug, Clone, PartialEq)]
pub struct Escaping {
    escape: Escape,
    best: f64,
    best_at: f64,
    via: Option<(f64, Point3<f64>)>,
    tries: usize,
}

impl Escape {
    /// The escapes of a new reach; its clock starts at the first [`Escaping::target`].
    pub fn start(&self) -> Escaping {
        Escaping {
            escape: *self,
            best: f64::INFINITY,
            best_at: 0.0,
            via: None,
            tries: 0,
        }
    }
}

impl Escaping {
    /// The point the hand should head for at time `t` (seconds, increasing), with the hand at
    /// `hand`, the goal at `goal` and the skin's `contacts` (base frame): the goal, or a via
    /// point while an escape is under way.
    pub fn target(
        &mut self,
        t: f64,
        hand: &Point3<f64>,
        goal: &Point3<f64>,
        contacts: &[LinkContacts],
    ) -> Point3<f64> {
        let e = self.escape;
        if let Some((until, via)) = self.via {
            // Time running backwards (a restarted clock) ends the escape too.
            if t < until && t >= until - e.time && (hand - via).norm() >= 0.01 {
                return via;
            }
            // Back to the goal, with the progress clock restarted from here.
            self.via = None;
            self.best = (goal - hand).norm();
            self.best_at = t;
            return *goal;
        }
        let distance = (goal - hand).norm();
        if distance < self.best - e.progress || !self.best.is_finite() {
            self.best = distance;
            self.best_at = t;
        } else if self.tries < e.tries
            && t - self.best_at > e.after
            && let Some(via) = via_point(&e, hand, goal, contacts, self.tries)
        {
            self.via = Some((t + e.time, via));
            self.tries += 1;
            return via;
        }
        *goal
    }

    /// Escapes made so far.
    pub fn tries(&self) -> usize {
        self.tries
    }

    /// Whether an escape is under way.
    pub fn escaping(&self) -> bool {
        self.via.is_some()
    }
}

/// The via point of escape number `k` from `hand`; `None` without a usable contact (nothing to
/// escape from: the arm is stopped by something else, such as a joint limit).
fn via_point(
    e: &Escape,
    hand: &Point3<f64>,
    goal: &Point3<f64>,
    contacts: &[LinkContacts],
    k: usize,
) -> Option<Point3<f64>> {
    // The contacts' force-weighted outward normal: the obstacle lies that way. Contacts pushing
    // from opposite sides (a link between two bars) leave no clear side to escape to.
    let mut n = Vector3::zeros();
    let mut total = 0.0;
    for c in contacts.iter().flat_map(|l| &l.contacts) {
        if c.force.is_finite() && c.force > 0.0 && c.normal.iter().all(|v| v.is_finite()) {
            n += c.normal.into_inner() * c.force;
            total += c.force;
        }
    }
    if !(total > 0.0) || n.norm() < 0.2 * total {
        return None;
    }
    let n = n.normalize();
    let up = Vector3::z();
    let g = (goal - hand).try_normalize(1e-12).unwrap_or(up);
    // Across the obstacle on the goal's side, else (the goal straight behind it, where the
    // goal's side is noise) upwards, else anything across.
    let across = |v: Vector3<f64>| {
        let a = v - n * n.dot(&v);
        (a.norm() >= 0.2).then(|| a.normalize())
    };
    let mut dir = across(g)
        .or_else(|| across(up))
        .or_else(|| across(Vector3::x()))?;
    // Each further escape a quarter turn about the normal.
    for _ in 0..k % 4 {
        dir = n.cross(&dir);
    }
    Some(hand + (dir - n * e.back) * e.distance)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)] // a failed set-up should stop the test
mod tests {
    use super::*;
    use crate::contact_tasks::Contact;
    use nalgebra::Unit;

    fn pressed(normal: Vector3<f64>, force: f64) -> Vec<LinkContacts> {
        vec![LinkContacts {
            link: "forearm".into(),
            contacts: vec![Contact {
                point: Point3::new(0.3, 0.0, 0.4),
                normal: Unit::new_normalize(normal),
                force,
                stiffness: 1000.0,
            }],
        }]
    }

    /// Runs `target` every 5 ms from 0 to `until` with the hand held still.
    fn held(
        e: &mut Escaping,
        until: f64,
        hand: Point3<f64>,
        goal: Point3<f64>,
        c: &[LinkContacts],
    ) -> Vec<(f64, Point3<f64>)> {
        (0..=(until / 0.005).round() as usize)
            .map(|i| {
                let t = i as f64 * 0.005;
                (t, e.target(t, &hand, &goal, c))
            })
            .collect()
    }

    #[test]
    fn a_pinned_hand_heads_across_the_obstacle_on_the_goals_side_after_a_second() {
        // The obstacle is ahead (+x, the skin's outward normal), the goal ahead and a little up.
        let hand = Point3::origin();
        let goal = Point3::new(0.3, 0.0, 0.1);
        let c = pressed(Vector3::x(), 5.0);
        let e = Escape::default();
        let mut run = e.start();
        let targets = held(&mut run, 1.2, hand, goal, &c);
        for (t, p) in &targets {
            if *t <= e.after {
                assert_eq!(*p, goal, "no escape before {} s (t = {t})", e.after);
            }
        }
        let (_, via) = *targets.last().unwrap();
        assert_ne!(via, goal);
        assert_eq!(run.tries(), 1);
        assert!(run.escaping());
        // distance across (+z, the goal's side of the obstacle), back from it by `back`.
        let want = hand + (Vector3::z() - Vector3::x() * e.back) * e.distance;
        assert!((via - want).norm() < 1e-12, "{via} vs {want}");
    }

    #[test]
    fn each_further_escape_turns_a_quarter_turn_about_the_normal_and_they_end() {
        let hand = Point3::origin();
        let goal = Point3::new(0.3, 0.0, 0.1);
        let c = pressed(Vector3::x(), 5.0);
        let e = Escape {
            tries: 3,
            ..Escape::default()
        };
        let mut run = e.start();
        let mut vias = Vec::new();
        for (_, p) in held(&mut run, 20.0, hand, goal, &c) {
            if p != goal && vias.last() != Some(&p) {
                vias.push(p);
            }
        }
        assert_eq!(vias.len(), 3, "{vias:?}");
        assert_eq!(run.tries(), 3);
        let across: Vec<Vector3<f64>> = vias
            .iter()
            .map(|v| (v - hand + Vector3::x() * e.back * e.distance) / e.distance)
            .collect();
        // +z, then x cross z = -y, then -z.
        for (a, want) in across.iter().zip([Vector3::z(), -Vector3::y(), -Vector3::z()]) {
            assert!((a - want).norm() < 1e-12, "{a} vs {want}");
        }
        // After the last, the goal for good.
        assert!(!run.escaping());
        assert_eq!(run.target(30.0, &hand, &goal, &c), goal);
    }

    #[test]
    fn progress_or_no_contact_means_no_escape_and_an_escape_ends_near_its_via_point() {
        let goal: Point3<f64> = Point3::new(0.3, 0.0, 0.1);
        let c = pressed(Vector3::x(), 5.0);
        let e = Escape::default();
        // The hand moving 1 cm a second towards the goal: never an escape.
        let mut run = e.start();
        for i in 0..2000 {
            let t = i as f64 * 0.005;
            let s: f64 = (t * 0.01 / goal.coords.norm()).min(1.0);
            let hand = Point3::from(goal.coords * s);
            assert_eq!(run.target(t, &hand, &goal, &c), goal, "t = {t}");
        }
        // Stuck with nothing touching (a joint limit, say): nothing to escape from.
        let mut run = e.start();
        assert!(
            held(&mut run, 5.0, Point3::origin(), goal, &[])
                .iter()
                .all(|(_, p)| *p == goal)
        );
        assert_eq!(run.tries(), 0);
        // Non-finite contacts are ignored the same way.
        let bad = pressed(Vector3::x(), f64::NAN);
        let mut run = e.start();
        assert!(
            held(&mut run, 5.0, Point3::origin(), goal, &bad)
                .iter()
                .all(|(_, p)| *p == goal)
        );
        // Reaching the via point ends the escape at once.
        let mut run = e.start();
        let via = held(&mut run, 1.1, Point3::origin(), goal, &c).last().unwrap().1;
        assert_ne!(via, goal);
        assert_eq!(run.target(1.2, &via, &goal, &c), goal);
        assert!(!run.escaping());
    }

    #[test]
    fn a_goal_straight_behind_the_obstacle_escapes_upwards_and_opposed_contacts_not_at_all() {
        let hand = Point3::origin();
        // The goal dead ahead, behind the obstacle, but for a hair to the side.
        let goal = Point3::new(0.3, 1e-5, 0.0);
        let c = pressed(Vector3::x(), 5.0);
        let e = Escape::default();
        let mut run = e.start();
        let (_, via) = *held(&mut run, 1.1, hand, goal, &c).last().unwrap();
        let want = hand + (Vector3::z() - Vector3::x() * e.back) * e.distance;
        assert!((via - want).norm() < 1e-12, "{via} vs {want}");
        // Pushed equally from both sides: no side to escape to.
        let mut both = pressed(Vector3::x(), 5.0);
        both.extend(pressed(-Vector3::x(), 5.0));
        let mut run = e.start();
        assert!(
            held(&mut run, 5.0, hand, goal, &both)
                .iter()
                .all(|(_, p)| *p == goal)
        );
    }

    #[test]
    fn the_fifth_escape_repeats_the_first_and_a_clock_run_backwards_ends_an_escape() {
        let hand = Point3::origin();
        let goal = Point3::new(0.3, 0.0, 0.1);
        let c = pressed(Vector3::x(), 5.0);
        let e = Escape::default();
        let mut run = e.start();
        let mut vias = Vec::new();
        for (_, p) in held(&mut run, 40.0, hand, goal, &c) {
            if p != goal && vias.last() != Some(&p) {
                vias.push(p);
            }
        }
        assert_eq!(vias.len(), e.tries);
        assert_eq!(vias[4], vias[0]);
        assert_eq!(vias[5], vias[1]);
        let mut run = e.start();
        let (t, via) = *held(&mut run, 1.1, hand, goal, &c).last().unwrap();
        assert_ne!(via, goal);
        assert_eq!(run.target(t - 10.0, &hand, &goal, &c), goal);
        assert!(!run.escaping());
    }
}

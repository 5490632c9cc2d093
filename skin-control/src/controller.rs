//! One control cycle of a skin-covered arm (thesis Ch. 8.3): a contact task for every link the
//! skin reports touched, the end-effector's reaching task, priorities sorted by contact force
//! (largest first, Ch. 8.3), solved by the [`TaskStack`] into joint velocities.
//!
//! Above them all, joint-limit tasks (as inequality tasks in Simetti and Casalino's framework):
//! a joint within `margin` of a limit gets a one-joint task pushing it back, its activation
//! rising smoothly from 0 at the margin to 1 at the limit. Without them the arm would drive a
//! joint into its stop, where the velocity it was given is lost and a contact it was meant to
//! relieve is not; with them the other joints take over.

use crate::contact_tasks::{Contact, Gains, activation, contact_twist, reach_twist};
use crate::kinematics::{Chain, KinematicsError};
use crate::task_stack::{Regularisation, Task, TaskStack};
use nalgebra::{DVector, Point3, Unit, Vector3};

/// The contacts the skin reports on one link (base frame).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkContacts {
    /// Link name, as in the chain's URDF.
    pub link: String,
    /// Its contacts.
    pub contacts: Vec<Contact>,
}

/// Where the end-effector should go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReachGoal {
    /// Goal position, base frame, metres.
    pub goal: Point3<f64>,
    /// The hand point x_h, in the tip link's frame.
    pub hand: Point3<f64>,
    /// The tool axis w, in the tip link's frame.
    pub tool_axis: Unit<Vector3<f64>>,
}

/// A skin-driven velocity controller for one chain.
#[derive(Debug, Clone)]
pub struct SkinController {
    chain: Chain,
    tip: String,
    stack: TaskStack,
    gains: Gains,
    threshold: f64,
    limit_margin: f64,
    guard: Option<ForceGuard>,
}

/// Slows the reach as a contact force nears F_thresh, which the thesis' controller does not: its
/// contact tasks come in with (F / F_thresh)^4, a third of their strength at 0.75 F_thresh, so a
/// reach that drives a link into an obstacle can overrun the threshold before they act (the
/// "force" failures of Tables 8.1/8.2, most of them at a low F_thresh). With the guard, the hand's
/// top speed falls linearly from full at `slow_from` x F_thresh to zero at `stop_at` x F_thresh
/// (the largest force on any link): its gains and top speed are scaled; the contact tasks are
/// unchanged and take the force back down. With `stop_at` at or below `slow_from`, the reach
/// runs at full speed up to `stop_at` and stops there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceGuard {
    /// Fraction of F_thresh where the reach starts to slow.
    pub slow_from: f64,
    /// Fraction of F_thresh where the reach stops.
    pub stop_at: f64,
}

impl Default for ForceGuard {
    fn default() -> Self {
        ForceGuard {
            slow_from: 0.6,
            stop_at: 0.85,
        }
    }
}

impl ForceGuard {
    /// The factor on the hand's top speed with `force` the largest contact force.
    pub fn factor(&self, force: f64, threshold: f64) -> f64 {
        if !(force.is_finite() && threshold.is_finite() && threshold > 0.0) {
            return 1.0;
        }
        let x = force / threshold;
        let span = (self.stop_at - self.slow_from).max(1e-9);
        ((self.stop_at - x) / span).clamp(0.0, 1.0)
    }
}

/// Margin of the joint-limit tasks, radians (or metres for a prismatic joint).
pub const JOINT_LIMIT_MARGIN: f64 = 0.15;

/// Smooth step: 0 at x <= 0, 1 at x >= 1, C1 in between.
fn smoothstep(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * (3.0 - 2.0 * x)
}

impl SkinController {
    /// A controller for `chain` whose end-effector is link `tip`, with the contact-force threshold
    /// F_thresh (newtons) of the activations.
    pub fn new(
        chain: Chain,
        tip: &str,
        regularisation: Regularisation,
        gains: Gains,
        threshold: f64,
    ) -> Result<SkinController, KinematicsError> {
        chain.link_pose(tip, &vec![0.0; chain.dof()])?;
        Ok(SkinController {
            stack: TaskStack::new(chain.dof(), regularisation),
            chain,
            tip: tip.into(),
            gains,
            threshold,
            limit_margin: JOINT_LIMIT_MARGIN,
            guard: None,
        })
    }

    /// Slows the reach near F_thresh (see [`ForceGuard`]); `None` is the thesis' controller.
    pub fn with_force_guard(mut self, guard: Option<ForceGuard>) -> SkinController {
        self.guard = guard;
        self
    }

    /// Sets the margin of the joint-limit tasks (0 turns them off).
    pub fn with_limit_margin(mut self, margin: f64) -> SkinController {
        self.limit_margin = if margin.is_finite() { margin.max(0.0) } else { 0.0 };
        self
    }

    /// Joint-limit tasks at `q`: one per joint inside its margin, pushing it back out at the
    /// position gain's rate.
    fn limit_tasks(&self, q: &[f64]) -> Vec<Task> {
        let n = q.len();
        let m = self.limit_margin;
        if m <= 0.0 {
            return Vec::new();
        }
        let mut out = Vec::new();
        for (i, (j, &qi)) in self.chain.joints().iter().zip(q).enumerate() {
            let (lo, hi) = j.limits;
            // Depth into the margin, signed: positive near the lower limit (push up).
            let depth = if qi - lo < m {
                m - (qi - lo)
            } else if hi - qi < m {
                -(m - (hi - qi))
            } else {
                continue;
            };
            if !depth.is_finite() {
                continue;
            }
            let mut jac = nalgebra::DMatrix::zeros(1, n);
            jac[(0, i)] = 1.0;
            out.push(Task {
                jacobian: jac,
                reference: DVector::from_element(1, self.gains.position * depth),
                activation: smoothstep(depth.abs() / m),
            });
        }
        out
    }

    /// The reach's gains this cycle: the guard, if any, scales its pull towards the goal (gains
    /// and top speed) by the largest contact force on any link.
    fn reach_gains(&self, contacts: &[LinkContacts]) -> Gains {
        let largest = contacts
            .iter()
            .flat_map(|lc| &lc.contacts)
            .map(|c| c.force)
            .filter(|f| f.is_finite())
            .fold(0.0, f64::max);
        match self.guard.map(|g| g.factor(largest, self.threshold)) {
            Some(k) if k < 1.0 => Gains {
                position: self.gains.position * k,
                orientation: self.gains.orientation * k,
                // 0 x an unlimited speed is no speed, not NaN.
                max_speed: if k > 0.0 { self.gains.max_speed * k } else { 0.0 },
                ..self.gains
            },
            _ => self.gains,
        }
    }

    /// The chain.
    pub fn chain(&self) -> &Chain {
        &self.chain
    }

    /// Joint velocities for one cycle at joint values `q`. Non-finite joint values give zero
    /// velocity (never garbage); an unknown link in `contacts` is an error.
    pub fn step(
        &mut self,
        q: &[f64],
        contacts: &[LinkContacts],
        goal: Option<&ReachGoal>,
    ) -> Result<DVector<f64>, KinematicsError> {
        let n = self.chain.dof();
        if q.len() != n {
            return Err(KinematicsError::Joints(format!(
                "{} joint values for a chain of {n} joints",
                q.len()
            )));
        }
        if q.iter().any(|v| !v.is_finite()) {
            return Ok(DVector::zeros(n));
        }
        // Forward kinematics once for every pose and Jacobian of this cycle.
        let at = self.chain.posture(q)?;
        // (priority force, task)
        let mut tasks: Vec<(f64, Task)> = Vec::new();
        let mut tip_contacts: Vec<Contact> = Vec::new();
        for lc in contacts {
            if lc.link == self.tip {
                tip_contacts.extend(lc.contacts.iter().copied());
                continue;
            }
            let pose = at.link_pose(&lc.link)?;
            let origin = Point3::from(pose.translation.vector);
            let f_max = lc
                .contacts
                .iter()
                .map(|c| c.force)
                .filter(|f| f.is_finite())
                .fold(0.0, f64::max);
            let a = activation(f_max, self.threshold);
            if a == 0.0 {
                continue;
            }
            let rho = contact_twist(&origin, &lc.contacts, &self.gains);
            tasks.push((
                f_max,
                Task {
                    jacobian: at.jacobian(&lc.link, &Point3::origin())?,
                    reference: DVector::from_iterator(6, rho.iter().copied()),
                    activation: a,
                },
            ));
        }
        let tip_pose = at.link_pose(&self.tip)?;
        let tip_origin = Point3::from(tip_pose.translation.vector);
        let tip_force = tip_contacts
            .iter()
            .map(|c| c.force)
            .filter(|f| f.is_finite())
            .fold(0.0, f64::max);
        let reach_gains = self.reach_gains(contacts);
        let tip_rho = match goal {
            Some(g) => reach_twist(
                &tip_origin,
                &(tip_pose * g.hand),
                &Unit::new_normalize(tip_pose.rotation * g.tool_axis.into_inner()),
                &g.goal,
                &tip_contacts,
                &reach_gains,
            ),
            None => contact_twist(&tip_origin, &tip_contacts, &self.gains),
        };
        tasks.push((
            tip_force,
            Task {
                jacobian: at.jacobian(&self.tip, &Point3::origin())?,
                reference: DVector::from_iterator(6, tip_rho.iter().copied()),
                activation: 1.0,
            },
        ));
        // Largest contact force first (Ch. 8.3); stable, so equal forces keep the chain's order.
        tasks.sort_by(|a, b| b.0.total_cmp(&a.0));
        let mut stack = self.limit_tasks(q);
        stack.extend(tasks.into_iter().map(|(_, t)| t));
        let tasks = stack;
        Ok(self
            .stack
            .solve(&tasks)
            .unwrap_or_else(|_| DVector::from_element(n, 0.0)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_guard_slows_the_reach_linearly_between_its_two_fractions_of_the_threshold() {
        let g = ForceGuard::default();
        let th = 7.5;
        assert_eq!(g.factor(0.0, th), 1.0);
        assert_eq!(g.factor(g.slow_from * th, th), 1.0);
        assert!((g.factor(0.5 * (g.slow_from + g.stop_at) * th, th) - 0.5).abs() < 1e-12);
        assert_eq!(g.factor(g.stop_at * th, th), 0.0);
        assert_eq!(g.factor(2.0 * th, th), 0.0);
        // Nothing known: no slowing (the controller's own checks handle bad input).
        assert_eq!(g.factor(f64::NAN, th), 1.0);
        assert_eq!(g.factor(1.0, 0.0), 1.0);
    }
}

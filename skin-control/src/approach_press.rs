//! Approach-then-press: the probe's controller of the self-touch calibration (thesis Ch. 7.2.3).
//!
//! The probe tip first moves above the target along its normal (Align), then down the normal
//! until the skin reports contact (Approach), then holds its position in the tangent plane while
//! regulating the force along the normal (Press): hybrid position/force control, with a selection
//! of the normal direction for force and of the tangent plane for position (as in Fisher and
//! Mujtaba, 1992). The controller outputs a Cartesian velocity for the tip; the robot's own
//! velocity controller turns it into joint velocities.
//!
//! Force control by velocity: along the normal the tip moves at `force_gain (F_ref - F)`. Against
//! a surface of stiffness k this makes the force settle exponentially with time constant
//! 1 / (k force_gain), without overshoot, whatever k is, as long as the step is short against it.

use nalgebra::{Point3, Unit, Vector3};

/// Gains and limits, in SI units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PressOptions {
    /// Force to hold, newtons (5 N in the thesis).
    pub force_n: f64,
    /// A measured force above this means contact, newtons.
    pub contact_n: f64,
    /// Distance above the target where the approach starts, metres.
    pub standoff_m: f64,
    /// Speed of the approach along the normal, m/s.
    pub approach_speed: f64,
    /// Velocity per newton of force error along the normal, (m/s)/N.
    pub force_gain: f64,
    /// Velocity per metre of position error (align and tangent plane), 1/s.
    pub position_gain: f64,
    /// Speed limit of the tip, m/s.
    pub max_speed: f64,
    /// The force is settled once within this of `force_n` for `settle_steps` steps, newtons.
    pub settle_n: f64,
    /// See `settle_n`.
    pub settle_steps: usize,
}

impl Default for PressOptions {
    fn default() -> Self {
        PressOptions {
            force_n: 5.0,
            contact_n: 0.3,
            standoff_m: 0.02,
            approach_speed: 0.02,
            force_gain: 0.002,
            position_gain: 5.0,
            max_speed: 0.1,
            settle_n: 0.1,
            settle_steps: 20,
        }
    }
}

/// Where the press is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Moving to the standoff point above the target.
    Align,
    /// Moving down the normal until contact.
    Approach,
    /// Regulating the force; holding position in the tangent plane.
    Press,
    /// The force has settled: the contact can be recorded.
    Settled,
}

/// One press at a target point along its outward normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ApproachPress {
    target: Point3<f64>,
    normal: Unit<Vector3<f64>>,
    options: PressOptions,
    phase: Phase,
    settled_for: usize,
}

impl ApproachPress {
    /// A press at `target` (on the skin) along the outward `normal` there.
    pub fn new(target: Point3<f64>, normal: Unit<Vector3<f64>>, options: PressOptions) -> Self {
        ApproachPress {
            target,
            normal,
            options,
            phase: Phase::Align,
            settled_for: 0,
        }
    }

    /// The current phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The tip velocity (m/s) for this control step, given the tip position and the contact force
    /// the skin reports (newtons, pushing back along the normal). Non-finite inputs give zero
    /// velocity.
    pub fn step(&mut self, tip: &Point3<f64>, force_n: f64) -> Vector3<f64> {
        if !(tip.coords.iter().all(|v| v.is_finite()) && force_n.is_finite()) {
            return Vector3::zeros();
        }
        let o = self.options;
        let n = self.normal.into_inner();
        let error = self.target - tip;
        let tangential = error - n * error.dot(&n);
        let v = match self.phase {
            Phase::Align => {
                let above = self.target + n * o.standoff_m;
                let e = above - tip;
                if e.norm() < 1e-3 {
                    self.phase = Phase::Approach;
                }
                e * o.position_gain
            }
            Phase::Approach => {
                if force_n > o.contact_n {
                    self.phase = Phase::Press;
                }
                tangential * o.position_gain - n * o.approach_speed
            }
            Phase::Press | Phase::Settled => {
                if (force_n - o.force_n).abs() < o.settle_n {
                    self.settled_for += 1;
                    if self.settled_for >= o.settle_steps {
                        self.phase = Phase::Settled;
                    }
                } else {
                    self.settled_for = 0;
                }
                // Selection: force along the normal, position in the tangent plane.
                tangential * o.position_gain - n * (o.force_gain * (o.force_n - force_n))
            }
        };
        let speed = v.norm();
        if speed > o.max_speed {
            v * (o.max_speed / speed)
        } else {
            v
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Presses a spring-like surface z = 0 of stiffness `k` from 5 cm above a target, 1 ms steps.
    fn press(k: f64) -> (Vec<f64>, Point3<f64>, usize) {
        let target = Point3::new(0.1, -0.05, 0.0);
        let mut c = ApproachPress::new(target, Vector3::z_axis(), PressOptions::default());
        let mut tip = Point3::new(0.12, -0.03, 0.05);
        let (mut force, mut forces, mut steps) = (0.0, Vec::new(), 0);
        while c.phase() != Phase::Settled && steps < 50_000 {
            tip += c.step(&tip, force) * 0.001;
            force = k * (-tip.z).max(0.0);
            forces.push(force);
            steps += 1;
        }
        (forces, tip, steps)
    }

    #[test]
    fn the_force_settles_at_5_n_without_overshoot_and_the_tip_stays_on_target() {
        for k in [2_000.0, 10_000.0, 50_000.0] {
            let (forces, tip, steps) = press(k);
            assert!(steps < 50_000, "k = {k}: never settled");
            let peak = forces.iter().copied().fold(0.0, f64::max);
            assert!(peak < 5.0 + 0.5, "k = {k}: overshoot to {peak} N");
            assert!((forces[forces.len() - 1] - 5.0).abs() < 0.1);
            // Tangent position held on the target while pressing.
            assert!(
                (tip.x - 0.1).abs() < 1e-4 && (tip.y + 0.05).abs() < 1e-4,
                "k = {k}: {tip}"
            );
        }
    }

    #[test]
    fn nan_input_commands_zero_velocity() {
        let mut c = ApproachPress::new(Point3::origin(), Vector3::z_axis(), PressOptions::default());
        assert_eq!(c.step(&Point3::new(f64::NAN, 0.0, 0.1), 0.0), Vector3::zeros());
        assert_eq!(c.step(&Point3::new(0.0, 0.0, 0.1), f64::NAN), Vector3::zeros());
    }
}

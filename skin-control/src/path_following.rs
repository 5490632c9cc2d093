//! Path following (thesis Ch. 9.3, Experiment 2): move a point of the arm along a polyline at a
//! constant speed, as the low-priority task that an interaction task may interrupt.
//!
//! This is path *following*, not trajectory tracking: the reference is taken from the point of
//! the path closest to where the arm is, not from a clock. When a push moves the arm off the
//! path, it returns to the nearest point and carries on from there instead of racing to catch
//! up with a timetable. The reference velocity is
//!
//! ```text
//! v = speed * t(s*) + gain * (p(s*) - x)
//! ```
//!
//! with s* the arc length of the closest path point, t its unit tangent and p the path. The
//! closest point is searched from the segment of the previous one onwards, never on earlier
//! segments, so a path that comes back near itself is still followed in order (within a segment
//! a push backwards is followed back: the arm resumes where it was pushed to). Near the end the along-path speed ramps down so that the point settles on the last
//! waypoint instead of overshooting it.

use nalgebra::{Point3, Vector3};

/// Why a path cannot be followed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PathError {
    /// Fewer than two distinct waypoints.
    #[error("a path needs at least two distinct waypoints")]
    TooShort,
    /// A waypoint is not finite.
    #[error("waypoint {0} is not finite")]
    NotFinite(usize),
    /// Speed or gain is not a finite positive number.
    #[error("{0} must be finite and positive")]
    Parameter(&'static str),
}

/// A polyline to follow at a constant speed.
#[derive(Debug, Clone, PartialEq)]
pub struct PathFollowing {
    points: Vec<Point3<f64>>,
    /// Arc length at each waypoint.
    arc: Vec<f64>,
    speed: f64,
    gain: f64,
    /// Segment the closest point was on last time.
    segment: usize,
}

/// The reference of one cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathReference {
    /// Reference linear velocity of the point, m/s.
    pub velocity: Vector3<f64>,
    /// Distance from the point to the path, metres.
    pub error: f64,
    /// Arc length travelled along the path (of the closest point), metres.
    pub progress: f64,
    /// True once the point is within 1 mm of the last waypoint.
    pub done: bool,
}

impl PathFollowing {
    /// Follow `waypoints` at `speed` (m/s), pulling back onto the path with `gain` (1/s).
    /// Repeated consecutive waypoints are merged.
    pub fn new(waypoints: &[Point3<f64>], speed: f64, gain: f64) -> Result<PathFollowing, PathError> {
        for (i, p) in waypoints.iter().enumerate() {
            if !p.coords.iter().all(|v| v.is_finite()) {
                return Err(PathError::NotFinite(i));
            }
        }
        if !(speed.is_finite() && speed > 0.0) {
            return Err(PathError::Parameter("speed"));
        }
        if !(gain.is_finite() && gain > 0.0) {
            return Err(PathError::Parameter("gain"));
        }
        let mut points: Vec<Point3<f64>> = Vec::with_capacity(waypoints.len());
        for p in waypoints {
            if points.last().is_none_or(|q| (p - q).norm() > 1e-9) {
                points.push(*p);
            }
        }
        if points.len() < 2 {
            return Err(PathError::TooShort);
        }
        let mut arc = vec![0.0];
        for w in points.windows(2) {
            arc.push(arc[arc.len() - 1] + (w[1] - w[0]).norm());
        }
        Ok(PathFollowing {
            points,
            arc,
            speed,
            gain,
            segment: 0,
        })
    }

    /// Total length of the path, metres.
    pub fn length(&self) -> f64 {
        self.arc[self.arc.len() - 1]
    }

    /// The path point at arc length `s` (clamped to the path).
    pub fn point_at(&self, s: f64) -> Point3<f64> {
        let s = s.clamp(0.0, self.length());
        let k = self
            .arc
            .partition_point(|&a| a <= s)
            .clamp(1, self.points.len() - 1)
            - 1;
        let len = self.arc[k + 1] - self.arc[k];
        self.points[k] + (self.points[k + 1] - self.points[k]) * ((s - self.arc[k]) / len)
    }

    /// Start again from the first waypoint.
    pub fn restart(&mut self) {
        self.segment = 0;
    }

    /// The reference velocity for a point at `x`. A non-finite `x` gives zero velocity.
    pub fn reference(&mut self, x: &Point3<f64>) -> PathReference {
        if !x.coords.iter().all(|v| v.is_finite()) {
            return PathReference {
                velocity: Vector3::zeros(),
                error: f64::NAN,
                progress: self.arc[self.segment],
                done: false,
            };
        }
        // Closest point, searching this segment and the ones after it: progress never goes
        // backwards, so a path that passes near itself is still followed in order.
        let mut best = (f64::INFINITY, self.segment, 0.0);
        for k in self.segment..self.points.len() - 1 {
            let a = self.points[k];
            let d = self.points[k + 1] - a;
            let t = ((x - a).dot(&d) / d.norm_squared()).clamp(0.0, 1.0);
            let dist = (a + d * t - x).norm();
            if dist < best.0 - 1e-12 {
                best = (dist, k, t);
            }
        }
        let (error, mut k, mut t) = best;
        // At the end of a segment, go on with the next one (its direction, not a stop).
        if t >= 1.0 - 1e-12 && k + 2 < self.points.len() {
            k += 1;
            t = 0.0;
        }
        self.segment = k;
        let a = self.points[k];
        let d = self.points[k + 1] - a;
        let closest = a + d * t;
        let s = self.arc[k] + t * d.norm();
        let remaining = self.length() - s;
        // Slow down over the last speed/gain metres, so the end is reached without overshoot.
        let along = self.speed.min(self.gain * remaining);
        let velocity = d.normalize() * along + (closest - x) * self.gain;
        let end = self.points[self.points.len() - 1];
        PathReference {
            velocity,
            error,
            progress: s,
            done: (end - x).norm() < 1e-3,
        }
    }
}

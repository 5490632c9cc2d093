//! Eq. 6.6, the cost of a joint's placement, with its gradient and Gauss-Newton Hessian.

use super::{Joint, JointMode, Placement};
use crate::tactile_map::TactileMap;
use argmin::core::{CostFunction, Gradient};
use nalgebra::{Point2, Rotation2, Vector2};

pub(super) fn centroid2(points: impl Iterator<Item = Point2<f64>>) -> Vector2<f64> {
    let (mut sum, mut n) = (Vector2::zeros(), 0usize);
    for p in points {
        sum += p.coords;
        n += 1;
    }
    sum / n.max(1) as f64
}

/// Eq. 6.6 for one joint, in solver units: millimetres, and the angle times the RMS radius of the
/// child's boundary taxels about their centroid c (the child turns about c).
#[derive(Debug, Clone)]
pub(super) struct Eq66 {
    /// Per edge: parent point u_A, child point u_B minus c (both mm), and the 3D length (mm).
    edges: Vec<(Vector2<f64>, Vector2<f64>, f64)>,
    /// Child boundary centroid, mm.
    c: Vector2<f64>,
    /// Angle scale: RMS radius of the child's edge points about c, mm.
    rho: f64,
    /// `Some(angle)`: translation only, at this angle.
    fixed_angle: Option<f64>,
    /// The best point the solver has evaluated (cost in mm^2, parameters): every iterate is
    /// usable, so whatever stops the solver, this is the answer.
    /// Shared by the clone the solver runs on, so it survives a solver error.
    pub(super) best: std::rc::Rc<std::cell::RefCell<(f64, Vec<f64>)>>,
}

impl Eq66 {
    pub(super) fn new(
        parent: &TactileMap,
        child: &TactileMap,
        joint: &Joint,
        edges: &[(usize, usize, f64)],
    ) -> Eq66 {
        let c = centroid2(edges.iter().map(|e| child.points[joint.child[e.1]])) * 1e3;
        let list: Vec<(Vector2<f64>, Vector2<f64>, f64)> = edges
            .iter()
            .map(|&(a, b, d)| {
                (
                    parent.points[joint.parent[a]].coords * 1e3,
                    child.points[joint.child[b]].coords * 1e3 - c,
                    d * 1e3,
                )
            })
            .collect();
        let rho = (list.iter().map(|e| e.1.norm_squared()).sum::<f64>() / list.len().max(1) as f64)
            .sqrt()
            .max(1.0);
        let fixed_angle = match joint.mode {
            JointMode::Full => None,
            JointMode::TranslationOnly { angle } => Some(angle),
        };
        Eq66 {
            edges: list,
            c,
            rho,
            fixed_angle,
            best: std::rc::Rc::new(std::cell::RefCell::new((f64::INFINITY, Vec::new()))),
        }
    }

    /// (angle, s) from solver parameters: the child point u goes to R(angle)(u - c) + c + s.
    fn split(&self, p: &[f64]) -> (f64, Vector2<f64>) {
        match self.fixed_angle {
            Some(a) => (a, Vector2::new(p[0], p[1])),
            None => (p[0] / self.rho, Vector2::new(p[1], p[2])),
        }
    }

    pub(super) fn param_of(&self, placement: &Placement) -> Vec<f64> {
        // offset (mm) = c + s - R c  =>  s = offset - c + R c
        let angle = self.fixed_angle.unwrap_or(placement.angle);
        let s = placement.offset * 1e3 - self.c + Rotation2::new(angle) * self.c;
        match self.fixed_angle {
            Some(_) => vec![s.x, s.y],
            None => vec![angle * self.rho, s.x, s.y],
        }
    }

    pub(super) fn placement_of(&self, p: &[f64]) -> Placement {
        let (angle, s) = self.split(p);
        Placement {
            angle,
            offset: (self.c + s - Rotation2::new(angle) * self.c) * 1e-3,
        }
    }

    pub(super) fn cost_mm2(&self, p: &[f64]) -> f64 {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        0.5 * self
            .edges
            .iter()
            .map(|(ua, ub, dx)| {
                let du = (ua - (r * ub + self.c + s)).norm();
                (dx - du).powi(2)
            })
            .sum::<f64>()
    }

    /// The inverse of the Gauss-Newton Hessian sum J^T J at `p` (J: derivatives of the 2D edge
    /// lengths), lightly damped: BFGS's first step is then a Gauss-Newton step, which is what lets
    /// a warm start converge in a few iterations.
    pub(super) fn gauss_newton_inverse(&self, p: &[f64]) -> Vec<Vec<f64>> {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        let (sin, cos) = angle.sin_cos();
        let n = p.len();
        let mut h = nalgebra::DMatrix::<f64>::zeros(n, n);
        for (ua, ub, _) in &self.edges {
            let v = ua - (r * ub + self.c + s);
            let du = v.norm().max(1e-12);
            let dir = v / du;
            let dr = Vector2::new(-sin * ub.x - cos * ub.y, cos * ub.x - sin * ub.y);
            // d|v|/dp for p = (angle * rho, sx, sy) or (sx, sy).
            let j: Vec<f64> = match self.fixed_angle {
                Some(_) => vec![-dir.x, -dir.y],
                None => vec![-dir.dot(&dr) / self.rho, -dir.x, -dir.y],
            };
            for a in 0..n {
                for b in 0..n {
                    h[(a, b)] += j[a] * j[b];
                }
            }
        }
        let damping = 1e-3 * (h.trace() / n as f64).max(1e-9);
        for a in 0..n {
            h[(a, a)] += damping;
        }
        let inv = h
            .try_inverse()
            .unwrap_or_else(|| nalgebra::DMatrix::identity(n, n) / (self.edges.len().max(1) as f64));
        (0..n).map(|a| (0..n).map(|b| inv[(a, b)]).collect()).collect()
    }

    pub(super) fn cost_m2(&self, p: &[f64]) -> f64 {
        self.cost_mm2(p) * 1e-6
    }

    pub(super) fn gradient_mm(&self, p: &[f64]) -> Vec<f64> {
        let (angle, s) = self.split(p);
        let r = Rotation2::new(angle);
        let (sin, cos) = angle.sin_cos();
        let (mut ga, mut gs) = (0.0, Vector2::zeros());
        for (ua, ub, dx) in &self.edges {
            let v = ua - (r * ub + self.c + s);
            let du = v.norm().max(1e-12);
            // d/dp of 1/2 (dx - |v|)^2 = -(dx - |v|) * (v / |v|) . dv/dp, with dv/ds = -I and
            // dv/dangle = -R'(angle) ub.
            let k = -(dx - du) / du;
            gs += -v * k;
            let dr = Vector2::new(-sin * ub.x - cos * ub.y, cos * ub.x - sin * ub.y);
            ga += -k * v.dot(&dr);
        }
        match self.fixed_angle {
            Some(_) => vec![gs.x, gs.y],
            None => vec![ga / self.rho, gs.x, gs.y],
        }
    }
}

impl CostFunction for Eq66 {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> std::result::Result<f64, argmin::core::Error> {
        let c = self.cost_mm2(p);
        // A non-finite point (a degenerate BFGS update) stops the solver instead of sending its
        // line search after a NaN for ever; the best point so far is kept.
        if !c.is_finite() || p.iter().any(|v| !v.is_finite()) {
            return Err(argmin::core::Error::msg("non-finite cost"));
        }
        let mut best = self.best.borrow_mut();
        if c < best.0 {
            best.0 = c;
            best.1.clear();
            best.1.extend_from_slice(p);
        }
        Ok(c)
    }
}

impl Gradient for Eq66 {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> std::result::Result<Vec<f64>, argmin::core::Error> {
        let g = self.gradient_mm(p);
        if g.iter().any(|v| !v.is_finite()) {
            return Err(argmin::core::Error::msg("non-finite gradient"));
        }
        Ok(g)
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

    use super::*;

    #[test]
    fn the_gradient_matches_finite_differences() {
        let problem = Eq66 {
            edges: vec![
                (Vector2::new(10.0, 3.0), Vector2::new(-4.0, 2.0), 12.0),
                (Vector2::new(-5.0, 8.0), Vector2::new(6.0, -1.0), 9.0),
                (Vector2::new(2.0, -7.0), Vector2::new(1.0, 5.0), 15.0),
            ],
            c: Vector2::new(30.0, -20.0),
            rho: 4.0,
            fixed_angle: None,
            best: Default::default(),
        };
        let p = vec![0.3, 1.5, -2.0];
        let g = problem.gradient_mm(&p);
        for i in 0..3 {
            let (mut up, mut down) = (p.clone(), p.clone());
            up[i] += 1e-6;
            down[i] -= 1e-6;
            let fd = (problem.cost_mm2(&up) - problem.cost_mm2(&down)) / 2e-6;
            assert!((fd - g[i]).abs() < 1e-5, "{i}: {fd} vs {}", g[i]);
        }
    }
}

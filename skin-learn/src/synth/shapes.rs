//! Contact patches in the plane of a tactile map: a shape, a pressure profile and a part label.
//!
//! Every shape gives a normalised distance rho (0 at its core, 1 on its outline); the pressure is
//! peak * (1 - rho^2)^gamma inside, 0 outside. gamma = 0.5 is a rigid dome pressed into the
//! skin (Hertz), small gamma a flat plate, gamma near 1 a soft body that spreads its load.

use nalgebra::{Point2, Vector2};

/// The outline of a patch, metres in map coordinates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Shape {
    /// All points within `r` of the segment a-b (a finger phalanx, an edge, a bar).
    Capsule { a: Point2<f64>, b: Point2<f64>, r: f64 },
    /// An ellipse with semi-axes (`u`, `v`), `u` along the unit vector `dir`.
    Ellipse {
        c: Point2<f64>,
        dir: Vector2<f64>,
        u: f64,
        v: f64,
    },
    /// A rectangle with half sides (`u`, `v`), `u` along the unit vector `dir`; rho is the
    /// larger of the two normalised coordinates, so the profile is flat along the sides.
    Rect {
        c: Point2<f64>,
        dir: Vector2<f64>,
        u: f64,
        v: f64,
    },
}

impl Shape {
    /// Normalised distance from the core: < 1 inside.
    pub(crate) fn rho(&self, p: Point2<f64>) -> f64 {
        match *self {
            Shape::Capsule { a, b, r } => {
                let ab = b - a;
                let len2 = ab.norm_squared();
                let t = if len2 > 0.0 {
                    ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                (p - (a + ab * t)).norm() / r
            }
            Shape::Ellipse { c, dir, u, v } => {
                let (x, y) = local(p, c, dir);
                ((x / u).powi(2) + (y / v).powi(2)).sqrt()
            }
            Shape::Rect { c, dir, u, v } => {
                let (x, y) = local(p, c, dir);
                (x.abs() / u).max(y.abs() / v)
            }
        }
    }

    /// A point of the shape's core (for gradients and bookkeeping).
    pub(crate) fn centre(&self) -> Point2<f64> {
        match *self {
            Shape::Capsule { a, b, .. } => nalgebra::center(&a, &b),
            Shape::Ellipse { c, .. } | Shape::Rect { c, .. } => c,
        }
    }

    /// The shape moved by a rigid motion (rotation `rot` about the origin, then `shift`).
    pub(crate) fn moved(&self, rot: &nalgebra::Rotation2<f64>, shift: Vector2<f64>) -> Shape {
        let m = |p: Point2<f64>| rot * p + shift;
        match *self {
            Shape::Capsule { a, b, r } => Shape::Capsule { a: m(a), b: m(b), r },
            Shape::Ellipse { c, dir, u, v } => Shape::Ellipse {
                c: m(c),
                dir: rot * dir,
                u,
                v,
            },
            Shape::Rect { c, dir, u, v } => Shape::Rect {
                c: m(c),
                dir: rot * dir,
                u,
                v,
            },
        }
    }

    /// The shape mirrored across the y axis (a left hand from a right one).
    pub(crate) fn mirrored(&self) -> Shape {
        let m = |p: Point2<f64>| Point2::new(-p.x, p.y);
        let d = |v: Vector2<f64>| Vector2::new(-v.x, v.y);
        match *self {
            Shape::Capsule { a, b, r } => Shape::Capsule { a: m(a), b: m(b), r },
            Shape::Ellipse { c, dir, u, v } => Shape::Ellipse {
                c: m(c),
                dir: d(dir),
                u,
                v,
            },
            Shape::Rect { c, dir, u, v } => Shape::Rect {
                c: m(c),
                dir: d(dir),
                u,
                v,
            },
        }
    }
}

/// Coordinates of `p` in the frame at `c` with x along `dir` (unit) and y 90 degrees from it.
fn local(p: Point2<f64>, c: Point2<f64>, dir: Vector2<f64>) -> (f64, f64) {
    let d = p - c;
    (d.dot(&dir), d.dot(&Vector2::new(-dir.y, dir.x)))
}

/// One pressing region: shape, peak pressure, profile exponent, a linear pressure gradient
/// (relative change per metre from `origin`: the hand's or object's centre, so that a push
/// loads one side of the whole hand) and the hand part it belongs to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Patch {
    pub(crate) shape: Shape,
    pub(crate) peak: f64,
    pub(crate) gamma: f64,
    pub(crate) gradient: Vector2<f64>,
    pub(crate) origin: Point2<f64>,
    pub(crate) label: u8,
}

impl Patch {
    pub(crate) fn new(shape: Shape, peak: f64, gamma: f64, label: u8) -> Self {
        Patch {
            shape,
            peak,
            gamma,
            gradient: Vector2::zeros(),
            origin: shape.centre(),
            label,
        }
    }

    /// Pressure at `p` (0 outside the shape).
    pub(crate) fn pressure(&self, p: Point2<f64>) -> f64 {
        let rho = self.shape.rho(p);
        if rho >= 1.0 {
            return 0.0;
        }
        let tilt = (1.0 + self.gradient.dot(&(p - self.origin))).clamp(0.1, 2.0);
        self.peak * (1.0 - rho * rho).powf(self.gamma) * tilt
    }
}

/// The pressure and label at `p`: the patch pressing hardest there wins the label.
pub(crate) fn press(patches: &[Patch], p: Point2<f64>) -> (f64, u8) {
    patches.iter().fold((0.0, 0), |(best, label), patch| {
        let v = patch.pressure(p);
        if v > best { (v, patch.label) } else { (best, label) }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation2;

    #[test]
    fn capsule_distance_is_to_the_segment() {
        let s = Shape::Capsule {
            a: Point2::new(0.0, 0.0),
            b: Point2::new(1.0, 0.0),
            r: 0.5,
        };
        assert!((s.rho(Point2::new(0.5, 0.25)) - 0.5).abs() < 1e-12);
        assert!((s.rho(Point2::new(-0.5, 0.0)) - 1.0).abs() < 1e-12);
        assert!((s.rho(Point2::new(1.0, 0.0))).abs() < 1e-12);
    }

    #[test]
    fn ellipse_and_rect_outlines() {
        let dir = Vector2::new(0.0, 1.0); // long axis along y
        let e = Shape::Ellipse {
            c: Point2::origin(),
            dir,
            u: 2.0,
            v: 1.0,
        };
        assert!((e.rho(Point2::new(0.0, 2.0)) - 1.0).abs() < 1e-12);
        assert!((e.rho(Point2::new(1.0, 0.0)) - 1.0).abs() < 1e-12);
        let r = Shape::Rect {
            c: Point2::origin(),
            dir,
            u: 2.0,
            v: 1.0,
        };
        assert!((r.rho(Point2::new(1.0, 2.0)) - 1.0).abs() < 1e-12);
        assert!(r.rho(Point2::new(0.9, -1.9)) < 1.0);
        assert!(r.rho(Point2::new(1.1, 0.0)) > 1.0);
    }

    #[test]
    fn moving_a_shape_moves_its_pressure() {
        let rot = Rotation2::new(0.7);
        let shift = Vector2::new(0.3, -0.2);
        let shapes = [
            Shape::Capsule {
                a: Point2::new(0.0, 0.0),
                b: Point2::new(0.05, 0.01),
                r: 0.01,
            },
            Shape::Ellipse {
                c: Point2::new(0.01, 0.02),
                dir: Vector2::new(0.6, 0.8),
                u: 0.03,
                v: 0.01,
            },
            Shape::Rect {
                c: Point2::new(-0.01, 0.0),
                dir: Vector2::new(0.8, -0.6),
                u: 0.02,
                v: 0.01,
            },
        ];
        for s in shapes {
            let m = s.moved(&rot, shift);
            for k in 0..50 {
                let p = Point2::new(-0.03 + 0.0013 * k as f64, 0.02 - 0.0009 * k as f64);
                assert!((s.rho(p) - m.rho(rot * p + shift)).abs() < 1e-9);
                let q = Point2::new(-p.x, p.y);
                assert!((s.rho(p) - s.mirrored().rho(q)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn dome_profile_and_winning_label() {
        let a = Patch::new(
            Shape::Ellipse {
                c: Point2::origin(),
                dir: Vector2::x(),
                u: 1.0,
                v: 1.0,
            },
            10.0,
            0.5,
            2,
        );
        let mut b = a;
        b.shape = Shape::Ellipse {
            c: Point2::new(1.0, 0.0),
            dir: Vector2::x(),
            u: 1.0,
            v: 1.0,
        };
        b.label = 3;
        assert!((a.pressure(Point2::new(0.6, 0.0)) - 8.0).abs() < 1e-12);
        assert_eq!(press(&[a, b], Point2::new(0.4, 0.0)).1, 2);
        assert_eq!(press(&[a, b], Point2::new(0.6, 0.0)).1, 3);
        assert_eq!(press(&[a, b], Point2::new(5.0, 0.0)), (0.0, 0));
    }
}

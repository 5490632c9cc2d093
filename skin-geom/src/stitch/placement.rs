//! Where a map lies in the stitched plane.

use nalgebra::{Point2, Rotation2, Vector2};

/// Where a map lies in the stitched plane: p' = R(angle) p + offset (metres, radians).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Rotation, radians, counter-clockwise.
    pub angle: f64,
    /// Translation, metres.
    pub offset: Vector2<f64>,
}

impl Placement {
    /// No rotation, no translation.
    pub const IDENTITY: Placement = Placement {
        angle: 0.0,
        offset: Vector2::new(0.0, 0.0),
    };

    /// The placed position of map point `p`.
    pub fn apply(&self, p: &Point2<f64>) -> Point2<f64> {
        Rotation2::new(self.angle) * p + self.offset
    }

    /// `self` after `inner`: p -> self(inner(p)).
    pub fn compose(&self, inner: &Placement) -> Placement {
        Placement {
            angle: self.angle + inner.angle,
            offset: Rotation2::new(self.angle) * inner.offset + self.offset,
        }
    }

    /// The map point placed at `q`.
    pub fn invert(&self, q: &Point2<f64>) -> Point2<f64> {
        Rotation2::new(-self.angle) * (q - self.offset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_compose_and_invert() {
        let a = Placement {
            angle: 0.4,
            offset: Vector2::new(0.1, -0.2),
        };
        let b = Placement {
            angle: -1.1,
            offset: Vector2::new(0.03, 0.05),
        };
        let p = Point2::new(0.2, 0.7);
        assert!((a.compose(&b).apply(&p) - a.apply(&b.apply(&p))).norm() < 1e-12);
        assert!((a.invert(&a.apply(&p)) - p).norm() < 1e-12);
    }
}

//! The fixed 2D chart of a joint region, chosen once at set-up (plane or unrolled cylinder), in
//! which the boundary taxels of both links are triangulated every cycle.

use crate::Result;
use crate::chart::{Chart, choose_chart};
use crate::tactile_map::TactileMap;
use nalgebra::{Point2, Point3, Unit, Vector3};

/// Fixed 2D chart of a joint region, in the parent link's frame.
#[derive(Debug, Clone, Copy)]
pub(super) struct JointChart {
    pub(super) chart: Chart,
    centre: Point3<f64>,
    e1: Vector3<f64>,
    e2: Vector3<f64>,
}

impl JointChart {
    pub(super) fn project(&self, p: &Point3<f64>) -> Point2<f64> {
        match self.chart {
            Chart::Plane { .. } => {
                let d = p - self.centre;
                Point2::new(d.dot(&self.e1), d.dot(&self.e2))
            }
            Chart::Cylinder { axis, centre, radius } => {
                let axis = Vector3::from(axis);
                let d = p - Point3::from(centre);
                let along = d.dot(&axis);
                let angle = d.dot(&self.e2).atan2(d.dot(&self.e1));
                Point2::new(radius * angle, along)
            }
        }
    }
}

/// Outward unit normals of a map's taxels, from its 3D triangles (counter-clockwise on the map,
/// so their 3D normals point out of the skin); a taxel in no triangle gets the mean normal.
pub(super) fn taxel_normals(map: &TactileMap) -> Vec<Unit<Vector3<f64>>> {
    let mut sums = vec![Vector3::zeros(); map.positions.len()];
    for f in &map.faces {
        let [a, b, c] = f.map(|i| map.positions[i]);
        let n = (b - a).cross(&(c - a)); // area-weighted
        for &i in f {
            sums[i] += n;
        }
    }
    let mean: Vector3<f64> = sums.iter().sum();
    sums.into_iter()
        .map(|n| {
            if n.norm() > 0.0 {
                Unit::new_normalize(n)
            } else if mean.norm() > 0.0 {
                Unit::new_normalize(mean)
            } else {
                Vector3::z_axis()
            }
        })
        .collect()
}

pub(super) fn fixed_chart(points: &[Point3<f64>], normals: &[Unit<Vector3<f64>>]) -> Result<JointChart> {
    let (chart, _) = choose_chart(points, normals)?;
    let (centre, _, axes) = crate::chart::principal_axes(points);
    let (e1, e2) = match chart {
        Chart::Plane { normal } => {
            let n = Vector3::from(normal);
            let e1 = (axes[2] - n * axes[2].dot(&n)).normalize();
            (e1, n.cross(&e1))
        }
        Chart::Cylinder { axis, .. } => {
            let a = Vector3::from(axis);
            let b = if a.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let e1 = (b - a * b.dot(&a)).normalize();
            (e1, a.cross(&e1))
        }
    };
    Ok(JointChart {
        chart,
        centre,
        e1,
        e2,
    })
}

/// Cuts the unrolled angles at the widest empty sector, so the region is in one piece.
pub(super) fn unwrap_angles(coords: &mut [Point2<f64>], radius: f64) {
    if coords.is_empty() || radius <= 0.0 {
        return;
    }
    let tau = std::f64::consts::TAU;
    let mut angles: Vec<f64> = coords.iter().map(|c| c.x / radius).collect();
    angles.sort_by(f64::total_cmp);
    let mut cut = angles[0] + tau;
    let mut widest = angles[0] + tau - angles[angles.len() - 1];
    for w in angles.windows(2) {
        if w[1] - w[0] > widest {
            widest = w[1] - w[0];
            cut = w[1];
        }
    }
    for c in coords.iter_mut() {
        let mut a = c.x / radius;
        while a < cut {
            a += tau;
        }
        while a >= cut + tau {
            a -= tau;
        }
        c.x = a * radius;
    }
}

//! A 2D chart of a taxel cloud, used only to triangulate it (thesis Ch. 3.2, Fig. 3.1c).
//!
//! Delaunay triangulation needs the points in a plane. A skin patch on a link is close either to a
//! plane or to a piece of a cylinder (forearm, upper arm). [`choose_chart`] picks the best-fit plane
//! when the cloud is flat (thinner than 2% of its width, whatever its normals say) or every taxel
//! normal is within 60 degrees of the plane normal (then projecting cannot fold the surface onto
//! itself), and otherwise unrolls the best-fit cylinder: angle around the axis times the radius,
//! and position along the axis.

use crate::{Error, Result};
use nalgebra::{Matrix3, Point2, Point3, SymmetricEigen, Unit, Vector3};

/// The chart a point cloud was triangulated in.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Chart {
    /// Projection onto the best-fit plane with this unit normal.
    Plane {
        /// Plane normal, oriented like the taxel normals.
        normal: [f64; 3],
    },
    /// Unrolled best-fit cylinder.
    Cylinder {
        /// Unit axis direction.
        axis: [f64; 3],
        /// A point on the axis, metres.
        centre: [f64; 3],
        /// Radius, metres.
        radius: f64,
    },
}

impl std::fmt::Display for Chart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Chart::Plane { normal } => write!(
                f,
                "best-fit plane (normal {:.3} {:.3} {:.3})",
                normal[0], normal[1], normal[2]
            ),
            Chart::Cylinder { axis, radius, .. } => write!(
                f,
                "unrolled best-fit cylinder (radius {:.1} mm, axis {:.3} {:.3} {:.3})",
                radius * 1e3,
                axis[0],
                axis[1],
                axis[2]
            ),
        }
    }
}

/// Principal axes of a point cloud: centroid, eigenvalues (ascending) and unit eigenvectors.
pub(crate) fn principal_axes(points: &[Point3<f64>]) -> (Point3<f64>, [f64; 3], [Vector3<f64>; 3]) {
    let n = points.len().max(1) as f64;
    let centroid = Point3::from(points.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n);
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - centroid;
        cov += d * d.transpose();
    }
    cov /= n;
    sorted_eigen(cov, centroid)
}

fn sorted_eigen(m: Matrix3<f64>, centroid: Point3<f64>) -> (Point3<f64>, [f64; 3], [Vector3<f64>; 3]) {
    let eig = SymmetricEigen::new(m);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let vals = order.map(|k| eig.eigenvalues[k]);
    let vecs = order.map(|k| eig.eigenvectors.column(k).into_owned());
    (centroid, vals, vecs)
}

/// A cloud thinner than this share of its second principal extent (RMS) is taken as a plane.
const FLAT_THICKNESS: f64 = 0.02;

/// Whether the cloud is thinner than [`FLAT_THICKNESS`] of its second extent: a plane.
pub(crate) fn is_flat(points: &[Point3<f64>]) -> bool {
    is_flat_axes(&principal_axes(points).1)
}

fn is_flat_axes(vals: &[f64; 3]) -> bool {
    vals[0] <= FLAT_THICKNESS * FLAT_THICKNESS * vals[1]
}

/// Checks that the cloud spans a surface, then returns the chart and each point's 2D coordinates.
pub fn choose_chart(
    points: &[Point3<f64>],
    normals: &[Unit<Vector3<f64>>],
) -> Result<(Chart, Vec<Point2<f64>>)> {
    if points.len() < 3 {
        return Err(Error::TooFewTaxels(format!(
            "{} distinct taxel position(s): a surface needs at least 3",
            points.len()
        )));
    }
    let (centroid, vals, vecs) = principal_axes(points);
    let scale = vals[2].max(f64::MIN_POSITIVE);
    if vals[1] <= 1e-10 * scale {
        return Err(Error::TooFewTaxels(
            "all taxels lie on one line: they span no surface".into(),
        ));
    }
    let mean_normal: Vector3<f64> = normals.iter().map(|n| n.into_inner()).sum();
    let mut plane_normal = vecs[0];
    if plane_normal.dot(&mean_normal) < 0.0 {
        plane_normal = -plane_normal;
    }
    let cos60 = 0.5;
    // The cloud's own geometry first: a cloud whose thickness (RMS distance to its best-fit
    // plane) is under 2% of its second extent is a plane, whatever its normals say (real files
    // give a flat foot sole normals that are not the plane's). Otherwise the plane serves when
    // every normal is within 60 degrees of it (projecting cannot fold the surface then).
    let flat = is_flat_axes(&vals);
    let flat_enough = flat || normals.iter().all(|n| n.dot(&plane_normal) >= cos60);
    if flat_enough {
        return Ok((
            Chart::Plane {
                normal: plane_normal.into(),
            },
            plane_coordinates(points, centroid, plane_normal, vecs[2]),
        ));
    }
    cylinder_chart(points, normals, centroid).map_or_else(
        // No usable cylinder: fall back to the plane and let edge pruning remove folds.
        || {
            Ok((
                Chart::Plane {
                    normal: plane_normal.into(),
                },
                plane_coordinates(points, centroid, plane_normal, vecs[2]),
            ))
        },
        Ok,
    )
}

fn plane_coordinates(
    points: &[Point3<f64>],
    centroid: Point3<f64>,
    normal: Vector3<f64>,
    major: Vector3<f64>,
) -> Vec<Point2<f64>> {
    let e1 = (major - normal * major.dot(&normal)).normalize();
    // (e1, e2, normal) is right-handed, so counter-clockwise in the chart is counter-clockwise
    // seen from outside the skin.
    let e2 = normal.cross(&e1);
    points
        .iter()
        .map(|p| {
            let d = p - centroid;
            Point2::new(d.dot(&e1), d.dot(&e2))
        })
        .collect()
}

/// Unrolls the best-fit cylinder. The axis is the direction most perpendicular to all normals
/// (smallest eigenvector of sum n n^T); the circle is the algebraic (Kasa) fit of the points
/// projected along the axis.
fn cylinder_chart(
    points: &[Point3<f64>],
    normals: &[Unit<Vector3<f64>>],
    centroid: Point3<f64>,
) -> Option<(Chart, Vec<Point2<f64>>)> {
    let mut nn = Matrix3::zeros();
    for n in normals {
        nn += n.into_inner() * n.into_inner().transpose();
    }
    let (_, _, nvecs) = sorted_eigen(nn, centroid);
    let axis = nvecs[0];
    let b1 = if axis.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = (b1 - axis * b1.dot(&axis)).normalize();
    let e2 = axis.cross(&e1);
    // Kasa fit: x^2 + y^2 + D x + E y + F = 0, linear least squares in (D, E, F).
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    let proj: Vec<(f64, f64, f64)> = points
        .iter()
        .map(|p| {
            let d = p - centroid;
            (d.dot(&e1), d.dot(&e2), d.dot(&axis))
        })
        .collect();
    for &(x, y, _) in &proj {
        let row = Vector3::new(x, y, 1.0);
        ata += row * row.transpose();
        atb -= row * (x * x + y * y);
    }
    let sol = ata.lu().solve(&atb)?;
    let (cx, cy) = (-sol.x / 2.0, -sol.y / 2.0);
    let r2 = cx * cx + cy * cy - sol.z;
    if !(r2.is_finite() && r2 > 0.0) {
        return None;
    }
    let radius = r2.sqrt();
    // Angles around the axis, cut at the widest empty sector so the unrolled patch is in one piece.
    let mut angles: Vec<f64> = proj.iter().map(|&(x, y, _)| (y - cy).atan2(x - cx)).collect();
    let mut sorted = angles.clone();
    sorted.sort_by(f64::total_cmp);
    let mut cut = sorted[0] + std::f64::consts::TAU;
    let mut widest = sorted[0] + std::f64::consts::TAU - sorted[sorted.len() - 1];
    for w in sorted.windows(2) {
        if w[1] - w[0] > widest {
            widest = w[1] - w[0];
            cut = w[1];
        }
    }
    for a in &mut angles {
        while *a < cut {
            *a += std::f64::consts::TAU;
        }
        while *a >= cut + std::f64::consts::TAU {
            *a -= std::f64::consts::TAU;
        }
    }
    let coords = angles
        .iter()
        .zip(&proj)
        .map(|(a, &(_, _, z))| Point2::new(a * radius, z))
        .collect();
    let centre = centroid + e1 * cx + e2 * cy;
    Some((
        Chart::Cylinder {
            axis: axis.into(),
            centre: centre.coords.into(),
            radius,
        },
        coords,
    ))
}

//! How far a tactile map is from the 3D skin it flattens.

use nalgebra::{Point2, Point3};
use std::collections::HashSet;

/// Distortion of a flattening, over all triangles of the mesh.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct DistortionReport {
    /// Mean absolute difference between each triangle corner's angle in 3D and on the map, degrees.
    pub angle_error_mean_deg: f64,
    /// 95th percentile of that difference, degrees.
    pub angle_error_p95_deg: f64,
    /// Map length / 3D length over all edges: 5th percentile.
    pub edge_ratio_p5: f64,
    /// Median edge-length ratio.
    pub edge_ratio_p50: f64,
    /// 95th percentile edge-length ratio.
    pub edge_ratio_p95: f64,
    /// Total map area / total 3D area (1 after the flattening's scaling).
    pub area_ratio: f64,
    /// Per-triangle area ratio, 5th percentile.
    pub face_area_ratio_p5: f64,
    /// Per-triangle area ratio, 95th percentile.
    pub face_area_ratio_p95: f64,
    /// Triangles whose orientation on the map is reversed (or of zero area).
    pub flipped_faces: usize,
    /// The least mean angle error any flattening of this mesh can have, degrees: at an interior
    /// vertex the 3D angles sum to 2 pi minus the angle defect (discrete Gaussian curvature) while
    /// map angles sum to exactly 2 pi, so the corner errors there add up to at least the defect.
    /// Sum of |defect| over interior vertices, over the number of corners.
    pub angle_error_bound_deg: f64,
}

impl DistortionReport {
    /// Measures the map `uv` of the mesh (`xyz`, `faces`).
    pub fn measure(xyz: &[Point3<f64>], uv: &[Point2<f64>], faces: &[[usize; 3]]) -> DistortionReport {
        let mut angle_err = Vec::with_capacity(faces.len() * 3);
        let mut area_ratio = Vec::with_capacity(faces.len());
        let mut edges = HashSet::with_capacity(faces.len() * 2);
        let (mut a3_total, mut a2_total) = (0.0, 0.0);
        let mut flipped = 0;
        let mut angle_sum = vec![0.0f64; xyz.len()];
        let mut edge_uses: std::collections::HashMap<(usize, usize), u8> =
            std::collections::HashMap::with_capacity(faces.len() * 2);
        for f in faces {
            let p = f.map(|i| xyz[i]);
            let q = f.map(|i| uv[i]);
            let a3 = 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm();
            let d1 = q[1] - q[0];
            let d2 = q[2] - q[0];
            let a2 = 0.5 * (d1.x * d2.y - d1.y * d2.x);
            if a2 <= 0.0 {
                flipped += 1;
            }
            a3_total += a3;
            a2_total += a2;
            if a3 > 0.0 {
                area_ratio.push(a2 / a3);
            }
            for k in 0..3 {
                let ang3 = (p[(k + 1) % 3] - p[k]).angle(&(p[(k + 2) % 3] - p[k]));
                let ang2 = (q[(k + 1) % 3] - q[k]).angle(&(q[(k + 2) % 3] - q[k]));
                angle_err.push((ang3 - ang2).abs().to_degrees());
                angle_sum[f[k]] += ang3;
                let (a, b) = (f[k], f[(k + 1) % 3]);
                edges.insert((a.min(b), a.max(b)));
                *edge_uses.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let mut edge_ratio: Vec<f64> = edges
            .iter()
            .filter_map(|&(a, b)| {
                let l3 = (xyz[a] - xyz[b]).norm();
                (l3 > 0.0).then(|| (uv[a] - uv[b]).norm() / l3)
            })
            .collect();
        let mut interior = vec![false; xyz.len()];
        for f in faces {
            for &v in f {
                interior[v] = true;
            }
        }
        for (&(a, b), &n) in &edge_uses {
            if n == 1 {
                interior[a] = false;
                interior[b] = false;
            }
        }
        let defect_sum: f64 = (0..xyz.len())
            .filter(|&v| interior[v])
            .map(|v| (std::f64::consts::TAU - angle_sum[v]).abs().to_degrees())
            .sum();
        let mean = |v: &[f64]| {
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        DistortionReport {
            angle_error_mean_deg: mean(&angle_err),
            angle_error_p95_deg: percentile(&mut angle_err, 95.0),
            edge_ratio_p5: percentile(&mut edge_ratio, 5.0),
            edge_ratio_p50: percentile(&mut edge_ratio, 50.0),
            edge_ratio_p95: percentile(&mut edge_ratio, 95.0),
            area_ratio: if a3_total > 0.0 { a2_total / a3_total } else { 0.0 },
            face_area_ratio_p5: percentile(&mut area_ratio, 5.0),
            face_area_ratio_p95: percentile(&mut area_ratio, 95.0),
            flipped_faces: flipped,
            angle_error_bound_deg: if faces.is_empty() {
                0.0
            } else {
                defect_sum / (3 * faces.len()) as f64
            },
        }
    }

    /// Spread of edge lengths: 95th over 5th percentile of the edge-length ratio (1 = no stretch).
    pub fn edge_ratio_spread(&self) -> f64 {
        self.edge_ratio_p95 / self.edge_ratio_p5
    }
}

/// Percentile by linear interpolation between order statistics (sorts `v`).
pub(crate) fn percentile(v: &mut [f64], pct: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let pos = pct / 100.0 * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

impl std::fmt::Display for DistortionReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "angle error        mean {:.4} deg, 95th percentile {:.4} deg (no flattening of this mesh can average under {:.4} deg)",
            self.angle_error_mean_deg, self.angle_error_p95_deg, self.angle_error_bound_deg
        )?;
        writeln!(
            f,
            "edge-length ratio  p5 {:.4}, p50 {:.4}, p95 {:.4} (p95/p5 {:.4})",
            self.edge_ratio_p5,
            self.edge_ratio_p50,
            self.edge_ratio_p95,
            self.edge_ratio_spread()
        )?;
        writeln!(
            f,
            "area ratio         total {:.4}, per triangle p5 {:.4}, p95 {:.4}",
            self.area_ratio, self.face_area_ratio_p5, self.face_area_ratio_p95
        )?;
        write!(f, "flipped triangles  {}", self.flipped_faces)
    }
}

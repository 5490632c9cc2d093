//! The start of a reset: the parent's map extended over the child's boundary taxels, and the
//! child map fitted onto those points (Kabsch in 2D).

use super::{Placement, Stitcher};
use nalgebra::{Isometry3, Point3, Rotation2, Vector2, Vector3};

impl Stitcher {
    /// Where the parent map, extended, would put the child's boundary taxels, and the child-map
    /// placement that best fits them (Kabsch in 2D; only the offset when the angle is fixed).
    pub(super) fn extension_start(
        &self,
        j: usize,
        to_parent: &Isometry3<f64>,
        fixed: Option<f64>,
    ) -> Option<Placement> {
        let joint = &self.joints[j];
        let (pm, cm) = (&self.maps[j], &self.maps[j + 1]);
        let parent3: Vec<Point3<f64>> = joint.parent.iter().map(|&i| pm.positions[i]).collect();
        let k = 6.min(parent3.len());
        if k < 4 {
            return None;
        }
        let mut from = Vec::new();
        let mut to = Vec::new();
        for &c in &joint.child {
            let q = to_parent * cm.positions[c];
            let mut near: Vec<(f64, usize)> = parent3
                .iter()
                .enumerate()
                .map(|(i, p)| ((p - q).norm_squared(), i))
                .collect();
            near.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
            // Affine map [x y z 1] -> map point, least squares with a little ridge (the points are
            // nearly coplanar, so their normal direction is unconstrained).
            let centre = near[..k]
                .iter()
                .fold(Vector3::zeros(), |s, &(_, i)| s + parent3[i].coords)
                / k as f64;
            let mut ata = nalgebra::Matrix4::<f64>::zeros();
            let mut atb = nalgebra::Matrix4x2::<f64>::zeros();
            for &(_, i) in &near[..k] {
                let d = (parent3[i].coords - centre) * 1e3; // mm
                let row = nalgebra::Vector4::new(d.x, d.y, d.z, 1.0);
                let u = pm.points[joint.parent[i]].coords * 1e3;
                ata += row * row.transpose();
                atb += row * u.transpose();
            }
            for r in 0..3 {
                ata[(r, r)] += 1e-3;
            }
            let coef = ata.cholesky()?.solve(&atb);
            let d = (q.coords - centre) * 1e3;
            let u = coef.transpose() * nalgebra::Vector4::new(d.x, d.y, d.z, 1.0) * 1e-3;
            from.push(cm.points[c].coords);
            to.push(u);
        }
        let n = from.len() as f64;
        let cf = from.iter().sum::<Vector2<f64>>() / n;
        let ct = to.iter().sum::<Vector2<f64>>() / n;
        let angle = fixed.unwrap_or_else(|| {
            let (mut sxx, mut sxy) = (0.0, 0.0);
            for (f, t) in from.iter().zip(&to) {
                let (a, b) = (f - cf, t - ct);
                sxx += a.x * b.x + a.y * b.y;
                sxy += a.x * b.y - a.y * b.x;
            }
            sxy.atan2(sxx)
        });
        let placement = Placement {
            angle,
            offset: ct - Rotation2::new(angle) * cf,
        };
        (placement.angle.is_finite() && placement.offset.iter().all(|v| v.is_finite())).then_some(placement)
    }
}

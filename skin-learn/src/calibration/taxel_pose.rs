//! One taxel's pose from its samples (thesis Ch. 7.2.4): a plane through the contacts that made
//! it answer, the contacts projected into that plane, the Gaussian fit there, and the centre taken
//! back to 3D.

use super::gaussian_fit::{FitOptions, GaussianFit};
use super::{CalibrationOptions, Status};
use nalgebra::{Matrix3, Point3, Unit, Vector3};

/// A fitted pose, or why there is none.
pub(crate) struct Pose {
    pub status: Status,
    pub position: Option<Point3<f64>>,
    pub normal: Option<Unit<Vector3<f64>>>,
    pub fit: Option<GaussianFit>,
    pub centre_sd_mm: Option<f64>,
    pub open_angle_deg: Option<f64>,
}

impl Pose {
    fn flagged(status: Status) -> Pose {
        Pose {
            status,
            position: None,
            normal: None,
            fit: None,
            centre_sd_mm: None,
            open_angle_deg: None,
        }
    }
}

/// The widest angle around `centre` with no sample in it, counting the samples at least `min_mm`
/// from it (closer ones say nothing of a direction), in degrees, and the direction (radians, in
/// the samples' plane) of its middle: 360 with none, under 180 when the samples surround it.
pub(crate) fn open_angle(xs: &[[f64; 2]], centre: [f64; 2], min_mm: f64) -> (f64, f64) {
    let mut angles: Vec<f64> = xs
        .iter()
        .map(|x| [x[0] - centre[0], x[1] - centre[1]])
        .filter(|d| d[0].hypot(d[1]) >= min_mm)
        .map(|d| d[1].atan2(d[0]))
        .collect();
    if angles.is_empty() {
        return (360.0, 0.0);
    }
    angles.sort_by(f64::total_cmp);
    let tau = std::f64::consts::TAU;
    let last = angles[angles.len() - 1];
    let (mut gap, mut middle) = (angles[0] + tau - last, last + (angles[0] + tau - last) / 2.0);
    for w in angles.windows(2) {
        if w[1] - w[0] > gap {
            gap = w[1] - w[0];
            middle = (w[0] + w[1]) / 2.0;
        }
    }
    (gap.to_degrees(), middle)
}

/// A plane fitted to points: centroid, orthonormal basis (v1, v2, v3) with v3 the normal (the
/// direction of least spread), and the RMS distance of the points to the plane.
pub(crate) type Plane = (Point3<f64>, [Vector3<f64>; 3], f64);

/// The plane through `points`, or why they span none.
pub(crate) fn plane(points: &[Point3<f64>]) -> Result<Plane, String> {
    let n = points.len() as f64;
    let mean = points.iter().fold(Vector3::zeros(), |m, p| m + p.coords) / n;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p.coords - mean;
        cov += d * d.transpose();
    }
    cov /= n;
    let eig = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let (l1, l2, l3) = (
        eig.eigenvalues[order[0]].max(0.0),
        eig.eigenvalues[order[1]].max(0.0),
        eig.eigenvalues[order[2]].max(0.0),
    );
    // Spreads under a micrometre, or a second direction a thousand times thinner than the first,
    // leave the in-plane axes undetermined.
    if l1.sqrt() < 1e-6 {
        return Err("all its contacts are at one point".into());
    }
    if l2.sqrt() < 1e-3 * l1.sqrt() || l2.sqrt() < 1e-6 {
        return Err("its contacts lie on a line (no plane to fit)".into());
    }
    let v1 = eig.eigenvectors.column(order[0]).into_owned();
    let v2 = eig.eigenvectors.column(order[1]).into_owned();
    let v3 = v1.cross(&v2).normalize();
    Ok((Point3::from(mean), [v1, v2, v3], l3.sqrt()))
}

/// Which side of a fitted plane is outside.
pub(crate) enum Outward {
    /// Along this direction.
    Along(Vector3<f64>),
    /// Away from this point (the centroid of all contacts of a curved patch).
    AwayFrom(Point3<f64>),
}

/// The plane fitted to the contacts, its normal turned to the outside: the mean centroid and a
/// right-handed frame (v1, v2 in the plane, v3 outward); or why there is no plane.
fn oriented_plane(
    centroids: &[Point3<f64>],
    outward: &Outward,
) -> Result<(Point3<f64>, [Vector3<f64>; 3]), String> {
    let (mean, [v1, _, mut v3], _) = plane(centroids)?;
    let side = match outward {
        Outward::Along(d) => v3.dot(d),
        Outward::AwayFrom(c) => v3.dot(&(mean - c)),
    };
    if side < 0.0 {
        v3 = -v3;
    }
    let v2 = v3.cross(&v1); // keep (v1, v2, v3) right-handed after a flip
    Ok((mean, [v1, v2, v3]))
}

/// Why the fitted centre is not a measurement, when it lies farther than the options allow from
/// the nearest contact (`xs`, mm in the plane).
///
/// A centre far outside the contacts that made the taxel answer is an extrapolation, not a
/// measurement. This is checked before convergence: a fit that ran off far from its contacts
/// cannot be placed by them whether or not it stopped within the budget (where a runaway stops
/// is rounding, so the verdict must not depend on it), and more iterations would not help.
fn ran_off(xs: &[[f64; 2]], fit: &GaussianFit, options: &CalibrationOptions) -> Option<String> {
    let reach = xs
        .iter()
        .map(|x| ((x[0] - fit.beta[0]).powi(2) + (x[1] - fit.beta[1]).powi(2)).sqrt())
        .fold(f64::INFINITY, f64::min);
    // Not `<=`: a NaN distance is no evidence of a runaway.
    if !(reach > options.max_extrapolation_mm) {
        return None;
    }
    Some(if fit.converged {
        format!("the fitted centre is {reach:.1} mm from the nearest contact")
    } else {
        format!(
            "the fit ran off {reach:.1} mm from the nearest contact (not converged after {} iterations)",
            fit.iterations
        )
    })
}

/// The pose of one taxel from its samples (responses all non-zero).
pub(crate) fn estimate(
    centroids: &[Point3<f64>],
    responses: &[f64],
    outward: &Outward,
    options: &CalibrationOptions,
) -> Pose {
    let have = centroids.len();
    if have < options.min_responses.max(5) {
        return Pose::flagged(Status::TooFewResponses {
            have,
            need: options.min_responses.max(5),
        });
    }
    let (mean, [v1, v2, v3]) = match oriented_plane(centroids, outward) {
        Ok(p) => p,
        Err(why) => return Pose::flagged(Status::Degenerate(why)),
    };
    // Millimetres about the mean, responses relative to the largest: the stopping rule then means
    // the same for every taxel.
    let t_max = responses.iter().copied().fold(0.0, f64::max);
    if !(t_max > 0.0) {
        return Pose::flagged(Status::Degenerate("no positive response".into()));
    }
    let xs: Vec<[f64; 2]> = centroids
        .iter()
        .map(|p| {
            let d = p - mean;
            [1e3 * v1.dot(&d), 1e3 * v2.dot(&d)]
        })
        .collect();
    let ts: Vec<f64> = responses.iter().map(|t| t / t_max).collect();
    let start = GaussianFit::start(&xs, &ts);
    let fit_options = FitOptions {
        epsilon: options.epsilon,
        max_iterations: options.max_iterations,
    };
    let Some(fit) = GaussianFit::fit(&xs, &ts, start, &fit_options) else {
        return Pose::flagged(Status::Degenerate("the fit left the real numbers".into()));
    };
    if let Some(why) = ran_off(&xs, &fit, options) {
        return Pose {
            fit: Some(fit),
            ..Pose::flagged(Status::Degenerate(why))
        };
    }
    if !fit.converged {
        return Pose {
            fit: Some(fit),
            ..Pose::flagged(Status::NotConverged {
                iterations: fit.iterations,
            })
        };
    }
    let centre_sd_mm = fit.centre_sd(&xs, &ts);
    // A centre its contacts do not surround (the edge of what was probed) is extrapolated from
    // one side, where the response's true shape differs from the Gaussian's: on a 524-taxel patch
    // probed only inside its outermost taxels, such centres fell up to 7.5 mm off while their
    // fits' own uncertainty said 0.3 mm for some (calibration_tests.rs).
    let (open, middle) = open_angle(&xs, [fit.beta[0], fit.beta[1]], 1.0);
    if open > options.max_open_angle_deg {
        let toward = Unit::new_normalize(v1 * middle.cos() + v2 * middle.sin());
        return Pose {
            fit: Some(fit),
            centre_sd_mm,
            open_angle_deg: Some(open),
            ..Pose::flagged(Status::NotSurrounded {
                open_deg: open,
                toward,
            })
        };
    }
    // Back to 3D: x~ = [v1 v2 v3] [b1, b2, 0]^T + v3 v3^T x*, with x* the mean centroid.
    let position = mean + (v1 * fit.beta[0] + v2 * fit.beta[1]) * 1e-3;
    Pose {
        status: Status::Fitted,
        position: Some(position),
        normal: Some(Unit::new_normalize(v3)),
        fit: Some(fit),
        centre_sd_mm,
        open_angle_deg: Some(open),
    }
}

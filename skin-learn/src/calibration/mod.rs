//! Spatial calibration: where each taxel sits, from a probe pressing the skin (thesis Ch. 7).
//!
//! Skins are glued on by hand, so the CAD positions of the taxels are off by millimetres. The
//! robot presses its own skin with a probe at known contact centroids; every taxel's position is
//! then fitted from its own responses alone (Ch. 7.2.4), independently of every other taxel:
//!
//! 1. the contacts that made the taxel answer are fitted with a plane (normal v3);
//! 2. they are projected into it, `x_hat = [v1 v2]^T (I - v3 v3^T) x`;
//! 3. the 2D Gaussian of Eq. 7.2 is fitted to the responses by Newton-Raphson (Eq. 7.4), falling
//!    back to gradient descent where the Hessian is not positive definite ([`GaussianFit`]),
//!    starting at (mean of the contacts, their largest standard deviation, largest response) and
//!    stopping when ||b_l - b_(l-1)|| < epsilon (in millimetres and fractions of the largest
//!    response);
//! 4. the centre goes back to 3D, `x~ = [v1 v2 v3] [b1, b2, 0]^T + v3 v3^T x*`, x* the mean
//!    contact; the taxel's normal is v3;
//! 5. the centre's uncertainty comes from the fit (the Gauss-Newton covariance of b1, b2:
//!    [`TaxelEstimate::centre_sd_mm`]), and a centre its contacts do not surround, the edge of
//!    what was probed, is flagged ([`Status::NotSurrounded`]) rather than extrapolated: on a
//!    524-taxel patch probed only inside its border such centres fell up to 7.5 mm off.
//!
//! The uncertainty is the fit's own, from the scatter of the responses. It leaves out the error
//! of the contact centroids the robot reports, so on simulated patches with 0.5-0.7 mm of
//! centroid noise the real error is about 1.5 to 2 times it (median).
//!
//! Around the fit, the self-touch procedure as pieces a robot stack calls: finding the body in an
//! RGB-D frame and a target with its normal ([`body_detection`], Ch. 7.2.1-7.2.2), and choosing
//! the next probe point where taxels still lack samples ([`exploration`]).
//!
//! A taxel that cannot be calibrated is flagged with the reason ([`Status`]), never guessed.
//! Taxels are solved in parallel (rayon); the results do not depend on the number of threads.
//!
//! ```
//! use skin_learn::calibration::{calibrate, CalibrationOptions, ProbeDataset, ProbeSimulator};
//! use skin_core::{LinkSkin, Taxel, TaxelId};
//! use nalgebra::{Point3, Unit, Vector3};
//!
//! // Nine taxels 8 mm apart on a plane, pressed 400 times by the simulated probe.
//! let taxels = (0..9)
//!     .map(|k| Taxel {
//!         id: TaxelId(k),
//!         position: Point3::new(0.008 * f64::from(k % 3), 0.008 * f64::from(k / 3), 0.0),
//!         normal: Unit::new_normalize(Vector3::z()),
//!     })
//!     .collect();
//! let patch = LinkSkin::new("patch", taxels);
//! let probes: ProbeDataset = ProbeSimulator::default().run(&patch, 400, 7);
//! let report = calibrate(&probes, &CalibrationOptions::default());
//! let centre = report.taxel(TaxelId(4)).and_then(|t| t.position).expect("fitted");
//! assert!((centre - Point3::new(0.008, 0.008, 0.0)).norm() < 0.002); // within 2 mm
//! ```

pub mod body_detection;
mod dataset;
pub mod exploration;
mod gaussian_fit;
mod metrics;
mod probe_sim;
mod report_text;
mod taxel_pose;

pub use dataset::{CSV_HEADER, ProbeContact, ProbeDataset, TaxelSamples};
pub use gaussian_fit::{FitOptions, GaussianFit};
pub use metrics::{CalibrationErrors, CurvePoint, convergence_curve, curve_svg};
pub use probe_sim::{ProbeSession, ProbeSimulator};
pub use report_text::{CURVE_SAMPLES, curve_table};

use nalgebra::{Point3, Unit, Vector3};
use rayon::prelude::*;
use skin_core::{LinkSkin, Taxel, TaxelId};

/// The header line of [`CalibrationReport::to_tsv`].
pub const REPORT_HEADER: &str = "taxel\tstatus\tsamples\tx_m\ty_m\tz_m\tcentre_sd_mm\topen_angle_deg";

/// Settings of [`calibrate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationOptions {
    /// Fewer answered contacts than this and the taxel is flagged (default 8; never under 5,
    /// the number of parameters of Eq. 7.2).
    pub min_responses: usize,
    /// Stopping threshold on ||b_l - b_(l-1)||, in millimetres and fractions of the largest
    /// response (default 1e-6).
    pub epsilon: f64,
    /// Iteration budget per taxel (default 200).
    pub max_iterations: usize,
    /// A fitted centre farther than this from every contact that made the taxel answer is
    /// flagged, not reported (default 8 mm, a taxel pitch).
    pub max_extrapolation_mm: f64,
    /// A fitted centre with a wider angle than this around it free of the contacts that made
    /// the taxel answer is flagged: its contacts do not surround it (default 170 degrees; 180 is
    /// the centre just outside them, and the 10 degrees below it catch the few contacts that
    /// stand barely past the line).
    pub max_open_angle_deg: f64,
    /// Which side of a taxel's fitted plane is outside, if known (a direction in the dataset's
    /// frame): contacts alone give a plane, not its side. Without it, on a flat patch (all
    /// contacts within 2 mm of a plane) normals take that plane's side of +z; otherwise they point
    /// away from the centroid of all contacts, which is outward on a convex link.
    pub outward: Option<Vector3<f64>>,
}

impl Default for CalibrationOptions {
    fn default() -> Self {
        CalibrationOptions {
            min_responses: 8,
            epsilon: 1e-6,
            max_iterations: 200,
            max_extrapolation_mm: 8.0,
            max_open_angle_deg: 170.0,
            outward: None,
        }
    }
}

/// What became of one taxel.
#[derive(Debug, Clone, PartialEq)]
pub enum Status {
    /// Position and normal fitted.
    Fitted,
    /// Not enough answered contacts.
    TooFewResponses {
        /// Contacts with a non-zero response.
        have: usize,
        /// Contacts needed.
        need: usize,
    },
    /// The taxel answered, but every response was zero.
    NoResponse,
    /// The contacts cannot determine a pose (at one point, on a line, or a fit whose centre is,
    /// or ran off, farther than `max_extrapolation_mm` from every contact).
    Degenerate(String),
    /// The contacts that made the taxel answer do not surround its fitted centre: an angle of
    /// `open_deg` around it has none (the edge of what was probed). Probe beyond it to place it.
    NotSurrounded {
        /// The widest angle without a contact, degrees.
        open_deg: f64,
        /// The middle of that angle, in the taxel's plane: where to press next
        /// ([`exploration::beyond_edges`]).
        toward: Unit<Vector3<f64>>,
    },
    /// The fit did not meet the stopping rule within the iteration budget, while still near its
    /// contacts.
    NotConverged {
        /// Iterations spent.
        iterations: usize,
    },
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Status::Fitted => write!(f, "fitted"),
            Status::TooFewResponses { have, need } => write!(f, "too few responses ({have}, need {need})"),
            Status::NoResponse => write!(f, "every response is zero"),
            Status::Degenerate(why) => write!(f, "degenerate: {why}"),
            Status::NotSurrounded { open_deg, .. } => write!(
                f,
                "not surrounded by its contacts ({open_deg:.0} deg around its centre without one: probe beyond it)"
            ),
            Status::NotConverged { iterations } => write!(f, "not converged after {iterations} iterations"),
        }
    }
}

/// One taxel's result.
#[derive(Debug, Clone, PartialEq)]
pub struct TaxelEstimate {
    /// The taxel.
    pub id: TaxelId,
    /// Fitted, or why not.
    pub status: Status,
    /// Fitted position, metres (only when fitted).
    pub position: Option<Point3<f64>>,
    /// Fitted outward normal (only when fitted).
    pub normal: Option<Unit<Vector3<f64>>>,
    /// Contacts with a non-zero response.
    pub samples: usize,
    /// The Gaussian fit, when one was made (also for a fit that was then rejected).
    pub fit: Option<GaussianFit>,
    /// Standard deviation of the fitted centre along its least certain direction, millimetres
    /// ([`GaussianFit::centre_sd`]); a fitted taxel whose fit leaves it undetermined has none.
    pub centre_sd_mm: Option<f64>,
    /// The widest angle around the fitted centre without a contact that made the taxel answer,
    /// degrees (contacts within 1 mm of the centre left out): under 180 when its contacts
    /// surround it, more at the edge of what was probed.
    pub open_angle_deg: Option<f64>,
}

/// The result of [`calibrate`]: one estimate per taxel seen in the dataset, in id order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CalibrationReport {
    /// Per taxel, in increasing id order.
    pub taxels: Vec<TaxelEstimate>,
}

impl CalibrationReport {
    /// The estimate of taxel `id`.
    pub fn taxel(&self, id: TaxelId) -> Option<&TaxelEstimate> {
        self.taxels
            .binary_search_by_key(&id, |t| t.id)
            .ok()
            .map(|k| &self.taxels[k])
    }

    /// Taxels that could not be calibrated.
    pub fn flagged(&self) -> impl Iterator<Item = &TaxelEstimate> {
        self.taxels.iter().filter(|t| t.status != Status::Fitted)
    }

    /// One line per taxel, tab-separated, after the header [`REPORT_HEADER`]: id, status (the
    /// reason for a flagged one), samples, fitted position (metres; empty when flagged), the
    /// centre's standard deviation (mm) and the open angle around it (degrees) where a fit gave
    /// them.
    pub fn to_tsv(&self) -> String {
        use std::fmt::Write as _;
        let mut out = format!("{REPORT_HEADER}\n");
        let opt = |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
        for t in &self.taxels {
            let [x, y, z] = match t.position {
                Some(p) => [p.x, p.y, p.z].map(|v| format!("{v:.6}")),
                None => [String::new(), String::new(), String::new()],
            };
            let _ = writeln!(
                out,
                "{}\t{}\t{}\t{x}\t{y}\t{z}\t{}\t{}",
                t.id.0,
                t.status,
                t.samples,
                opt(t.centre_sd_mm, 3),
                opt(t.open_angle_deg, 0)
            );
        }
        out
    }

    /// The fitted taxels as a link skin (no faces: the layout's mesh is rebuilt from the new
    /// positions). Flagged taxels are left out.
    pub fn to_link(&self, name: &str) -> LinkSkin {
        LinkSkin::new(
            name,
            self.taxels
                .iter()
                .filter_map(|t| {
                    Some(Taxel {
                        id: t.id,
                        position: t.position?,
                        normal: t.normal?,
                    })
                })
                .collect(),
        )
    }
}

/// Fits every taxel of `dataset` (Ch. 7.2.4).
pub fn calibrate(dataset: &ProbeDataset, options: &CalibrationOptions) -> CalibrationReport {
    calibrate_taxels(dataset.by_taxel(), &outward_of(dataset, options), options)
}

/// The outward rule: the given direction, or away from the centroid of all contacts.
pub(crate) fn outward_of(dataset: &ProbeDataset, options: &CalibrationOptions) -> taxel_pose::Outward {
    match options.outward {
        Some(d) => taxel_pose::Outward::Along(d),
        None => {
            let points: Vec<Point3<f64>> = dataset.contacts.iter().map(|c| c.centroid).collect();
            match taxel_pose::plane(&points) {
                // A flat patch (every contact within 2 mm of one plane): that plane's normal, on
                // the side of +z. Away-from-centroid would be decided by noise there.
                Ok((_, [_, _, n], thickness)) if thickness < 2e-3 => {
                    taxel_pose::Outward::Along(if n.z < 0.0 { -n } else { n })
                }
                Ok((centre, _, _)) => taxel_pose::Outward::AwayFrom(centre),
                Err(_) => taxel_pose::Outward::Along(Vector3::z()),
            }
        }
    }
}

/// Fits the given per-taxel samples, in parallel, in id order.
pub(crate) fn calibrate_taxels(
    by_taxel: std::collections::BTreeMap<TaxelId, TaxelSamples>,
    outward: &taxel_pose::Outward,
    options: &CalibrationOptions,
) -> CalibrationReport {
    let by_taxel: Vec<(TaxelId, TaxelSamples)> = by_taxel.into_iter().collect();
    let taxels = by_taxel
        .par_iter()
        .map(|(id, samples)| {
            let pose = if samples.centroids.is_empty() {
                taxel_pose::Pose {
                    status: Status::NoResponse,
                    position: None,
                    normal: None,
                    fit: None,
                    centre_sd_mm: None,
                    open_angle_deg: None,
                }
            } else {
                taxel_pose::estimate(&samples.centroids, &samples.responses, outward, options)
            };
            TaxelEstimate {
                id: *id,
                status: pose.status,
                position: pose.position,
                normal: pose.normal,
                samples: samples.centroids.len(),
                fit: pose.fit,
                centre_sd_mm: pose.centre_sd_mm,
                open_angle_deg: pose.open_angle_deg,
            }
        })
        .collect();
    CalibrationReport { taxels }
}

//! A calibration in words: what was fitted and flagged ([`CalibrationReport::summary`]), the
//! errors against a true layout beside the thesis' Table 7.1 ([`CalibrationErrors::table`]), and
//! the error against samples per taxel ([`curve_table`], as Fig. 7.9).

use super::{CalibrationErrors, CalibrationReport, CurvePoint, Status};
use std::fmt;
use std::path::Path;

/// The samples per taxel of the thesis' convergence curve (Fig. 7.9).
pub const CURVE_SAMPLES: [usize; 8] = [6, 8, 10, 12, 16, 20, 24, 32];

/// Flagged taxels listed by [`CalibrationReport::summary`] before "... and N more".
const LISTED: usize = 20;

impl CalibrationReport {
    /// Taxels fitted.
    pub fn fitted(&self) -> usize {
        self.taxels.iter().filter(|t| t.status == Status::Fitted).count()
    }

    /// What was fitted from `contacts` contacts of the dataset `source`: a line of counts (with
    /// the median samples per taxel), the first flagged taxels with their reason, and the
    /// fitted centres' uncertainty. Lines end with a line end but the last.
    pub fn summary<'a>(&'a self, source: &'a Path, contacts: usize) -> impl fmt::Display + 'a {
        Summary {
            report: self,
            source,
            contacts,
        }
    }
}

struct Summary<'a> {
    report: &'a CalibrationReport,
    source: &'a Path,
    contacts: usize,
}

impl fmt::Display for Summary<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = self.report;
        let fitted = r.fitted();
        let mut samples: Vec<usize> = r.taxels.iter().map(|t| t.samples).collect();
        samples.sort_unstable();
        write!(
            f,
            "{}: {} contacts, {} taxels answered (median {} samples per taxel): {fitted} fitted, {} flagged",
            self.source.display(),
            self.contacts,
            r.taxels.len(),
            samples.get(samples.len() / 2).copied().unwrap_or(0),
            r.taxels.len() - fitted
        )?;
        for t in r.flagged().take(LISTED) {
            write!(f, "\n  taxel {}: {}", t.id, t.status)?;
        }
        let flagged = r.flagged().count();
        if flagged > LISTED {
            write!(f, "\n  ... and {} more", flagged - LISTED)?;
        }
        let mut sds: Vec<f64> = r
            .taxels
            .iter()
            .filter(|t| t.status == Status::Fitted)
            .filter_map(|t| t.centre_sd_mm)
            .collect();
        sds.sort_by(f64::total_cmp);
        if let (Some(mid), Some(top)) = (sds.get(sds.len() / 2), sds.last()) {
            write!(
                f,
                "\ncentre uncertainty of the fitted taxels (1 sd, from the fit; the contacts' own error adds to it): median {mid:.2} mm, largest {top:.2} mm"
            )?;
        }
        Ok(())
    }
}

impl CalibrationErrors {
    /// The errors (Eq. 7.5-7.8) as a table beside the thesis' row of Table 7.1, after a blank
    /// line; the last line without a line end.
    pub fn table(&self) -> impl fmt::Display + '_ {
        Table(self)
    }
}

struct Table<'a>(&'a CalibrationErrors);

impl fmt::Display for Table<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        writeln!(f)?;
        writeln!(
            f,
            "              mean e    sigma     mean normal error   e max     taxels"
        )?;
        writeln!(
            f,
            "this dataset  {:>5.2} mm  {:>5.2} mm  {:>5.3} rad ({:>4.1} deg)  {:>5.2} mm  {}{}",
            e.mean_mm,
            e.std_mm,
            e.mean_normal_rad,
            e.mean_normal_rad.to_degrees(),
            e.max_mm,
            e.compared,
            if e.missing > 0 {
                format!(" ({} of the truth not fitted)", e.missing)
            } else {
                String::new()
            }
        )?;
        write!(
            f,
            "thesis ABS     1.90 mm   0.80 mm  0.060 rad ( 3.4 deg)   4.00 mm  61 (Table 7.1)"
        )
    }
}

/// The convergence curve as a table after a blank line: samples per taxel, mean error, its
/// sigma, taxels fitted (means over `trials` subsets); the last line without a line end.
pub fn curve_table(curve: &[CurvePoint], trials: usize) -> impl fmt::Display + '_ {
    Curve(curve, trials)
}

struct Curve<'a>(&'a [CurvePoint], usize);

impl fmt::Display for Curve<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f)?;
        write!(
            f,
            "samples/taxel  mean e    sigma    taxels (mean of {} subsets)",
            self.1
        )?;
        for p in self.0 {
            write!(
                f,
                "\n{:>13}  {:>5.2} mm  {:>5.2} mm  {:>6.1}",
                p.samples, p.mean_mm, p.std_mm, p.fitted
            )?;
        }
        Ok(())
    }
}

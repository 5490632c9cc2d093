//! What a run of Experiment 2 shows: its timeline in words ([`PhriRun::report`]), every control
//! cycle as CSV ([`PhriRun::to_csv`]) and, with the `plot` feature, as an SVG of three panels
//! ([`PhriRun::to_svg`]).

use super::phri::PhriRun;
use std::fmt;

/// The header of [`PhriRun::to_csv`].
pub const PHRI_CSV_HEADER: &str =
    "t_s,force_n,contacts,task1,reference_speed_m_s,centroid_speed_m_s,path_error_m,progress_m";

impl PhriRun {
    /// The timeline in words, a line per event of the script (bump, push, release): whether the
    /// gate let task 1 act, the forces, the centroid's tracking, the path error.
    pub fn report(&self) -> PhriReport<'_> {
        PhriReport(self)
    }

    /// Every control cycle as CSV, with the header [`PHRI_CSV_HEADER`].
    pub fn to_csv(&self) -> String {
        let mut text = format!("{PHRI_CSV_HEADER}\n");
        for s in &self.samples {
            text.push_str(&format!(
                "{:.3},{:.4},{},{},{:.5},{:.5},{:.6},{:.5}\n",
                s.t,
                s.force,
                s.contacts,
                u8::from(s.task1),
                s.reference_speed,
                s.centroid_speed,
                s.path_error,
                s.progress
            ));
        }
        text
    }

    fn peak_force(&self, from: f64, to: f64) -> f64 {
        self.between(from, to).map(|x| x.force).fold(0.0, f64::max)
    }

    fn peak_error(&self, from: f64, to: f64) -> f64 {
        self.between(from, to).map(|x| x.path_error).fold(0.0, f64::max)
    }
}

/// [`PhriRun::report`]: its lines, the last without a line end.
#[derive(Debug, Clone, Copy)]
pub struct PhriReport<'a>(&'a PhriRun);

impl fmt::Display for PhriReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let run = self.0;
        let s = &run.script;
        let (b0, bd) = s.bump;
        writeln!(
            f,
            "path following at {} m/s, touches on {}; times in s, forces in N",
            s.path_speed, run.link
        )?;
        let bump_task1 = run.between(b0, b0 + bd + 0.1).any(|x| x.task1);
        writeln!(
            f,
            "{b0:>5.2}  bump (not a hand) for {bd} s: peak force {:.1}, task 1 {}, path error at most {:.1} mm",
            run.peak_force(b0, b0 + bd),
            if bump_task1 {
                "ACTIVATED"
            } else {
                "not activated (ignored)"
            },
            1000.0 * run.peak_error(b0, b0 + bd + 0.1)
        )?;
        self.push(f)?;
        let release = s.push.0 + s.push.1;
        let back = run
            .samples
            .iter()
            .find(|x| x.t > release && x.path_error < 0.001)
            .map(|x| x.t);
        write!(
            f,
            "{release:>5.2}  hand lets go: path error {:.1} mm, back under 1 mm {}",
            1000.0 * run.peak_error(release, release + 0.02),
            back.map_or("never".to_string(), |t| format!("after {:.2} s", t - release))
        )
    }
}

impl PhriReport<'_> {
    /// The push's line: when task 1 took over, and how the centroid tracked its reference.
    fn push(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let run = self.0;
        let (p0, pd) = run.script.push;
        let Some(t) = run.task1_from(p0) else {
            return writeln!(f, "{p0:>5.2}  hand push: task 1 NEVER activated");
        };
        let active: Vec<_> = run.between(p0, p0 + pd).filter(|x| x.task1).collect();
        let n = active.len().max(1) as f64;
        let tracking = active
            .iter()
            .map(|x| (x.reference_speed - x.centroid_speed).abs())
            .sum::<f64>()
            / n;
        let top = active.iter().map(|x| x.centroid_speed).fold(0.0, f64::max);
        writeln!(
            f,
            "{p0:>5.2}  hand push at {} m/s for {pd} s: task 1 active after {:.2} s; centroid speed up to {:.3} m/s (V_max 0.3), |reference - actual| {:.1} mm/s on average; peak force {:.1}",
            run.script.push_speed,
            t - p0,
            top,
            1000.0 * tracking,
            run.peak_force(p0, p0 + pd)
        )
    }
}

/// Drawing the timeline failed (plotters' error, in words).
#[cfg(feature = "plot")]
#[derive(Debug, thiserror::Error)]
#[error("cannot draw the timeline: {0}")]
pub struct PlotError(String);

#[cfg(feature = "plot")]
mod plot {
    use super::PlotError;
    use crate::sim::phri::PhriRun;
    use plotters::coord::Shift;
    use plotters::coord::types::RangedCoordf64;
    use plotters::prelude::*;

    type Panel<'a, 'b> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

    fn err(e: impl std::fmt::Display) -> PlotError {
        PlotError(e.to_string())
    }

    impl PhriRun {
        /// The timeline as SVG (900 x 720): contact force with task 1's activity shaded, the
        /// contact centroid's speed against its reference, and the path error, over time.
        pub fn to_svg(&self) -> Result<String, PlotError> {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (900, 720)).into_drawing_area();
                root.fill(&WHITE).map_err(err)?;
                let panels = root.split_evenly((3, 1));
                self.draw(&panels).map_err(err)?;
                root.present().map_err(err)?;
            }
            Ok(svg)
        }

        /// The three panels.
        fn draw(&self, panels: &[DrawingArea<SVGBackend<'_>, Shift>]) -> Result<(), PlotError> {
            let t_end = self.script.duration;
            let s = &self.samples;
            let fmax = s.iter().map(|x| x.force).fold(1.0, f64::max) * 1.1;
            let vmax = s
                .iter()
                .map(|x| x.reference_speed.max(x.centroid_speed))
                .fold(0.05, f64::max)
                * 1.1;
            let emax = s.iter().map(|x| x.path_error * 1000.0).fold(1.0, f64::max) * 1.1;
            let [p0, p1, p2] = panels else {
                return Err(PlotError("three panels expected".into()));
            };
            let mut force = panel(p0, "contact force (N); shaded: task 1 active", t_end, fmax)?;
            force
                .draw_series(s.iter().filter(|x| x.task1).map(|x| {
                    Rectangle::new(
                        [(x.t, 0.0), (x.t + 0.005, fmax)],
                        RGBColor(220, 235, 255).filled(),
                    )
                }))
                .map_err(err)?;
            force
                .draw_series(LineSeries::new(s.iter().map(|x| (x.t, x.force)), &RED))
                .map_err(err)?;
            let caption = "contact centroid speed (m/s): reference (black), actual (blue)";
            let mut speed = panel(p1, caption, t_end, vmax)?;
            speed
                .draw_series(LineSeries::new(
                    s.iter().map(|x| (x.t, x.reference_speed)),
                    &BLACK,
                ))
                .map_err(err)?;
            speed
                .draw_series(LineSeries::new(s.iter().map(|x| (x.t, x.centroid_speed)), &BLUE))
                .map_err(err)?;
            let mut error = panel(p2, "path error (mm)", t_end, emax)?;
            error
                .draw_series(LineSeries::new(
                    s.iter().map(|x| (x.t, x.path_error * 1000.0)),
                    &GREEN,
                ))
                .map_err(err)?;
            Ok(())
        }
    }

    /// One panel of the timeline: time (0..t_end s) across, 0..ymax up, with its caption and
    /// grid.
    fn panel<'a, 'b>(
        area: &'a DrawingArea<SVGBackend<'b>, Shift>,
        caption: &str,
        t_end: f64,
        ymax: f64,
    ) -> Result<Panel<'a, 'b>, PlotError> {
        let mut chart = ChartBuilder::on(area)
            .caption(caption, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..t_end, 0.0..ymax)
            .map_err(err)?;
        chart.configure_mesh().x_desc("time (s)").draw().map_err(err)?;
        Ok(chart)
    }
}

//! `skin phri`: the physical-interaction experiment in simulation (thesis Ch. 9.3, Experiment 2).

use anyhow::Result;
use plotters::prelude::*;
use skin_control::sim::phri::{self, PhriRun, PhriScript};
use std::path::PathBuf;

/// Simulate Experiment 2 of the thesis' Ch. 9.3 and print its timeline.
///
/// The arm's hand follows a path at 0.03 m/s (three sides of a 20 x 10 cm rectangle across the
/// arm) as its only task. At 2.9 s a large body bumps the forearm by accident for 0.7 s: one
/// broad contact, which the gate must not take for a hand, so the arm carries on. At 6 s three
/// fingers push the forearm at 0.1 m/s for 2.5 s: once the gate has seen three separate
/// contacts for its latency (0.07 s, as the thesis' classifier), task 1 takes over and moves
/// the contact centroid along the push, V_max = 0.3 m/s scaled by the mean contact force (1 N to
/// 10 N); the path task carries on in what task 1 leaves free, and picks the path up again when
/// the hand lets go.
///
/// The gate is a stand-in for the hand classifier (three or more separate contacts on one link);
/// any classifier can take its place through the library's ContactGate trait.
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Scene JSON: its robot and obstacles are used (default: the built-in arm, no obstacles).
    #[arg(long, value_name = "SCENE.json")]
    scene: Option<PathBuf>,
    /// Plot the timeline (force, centroid speed against its reference, path error) to this SVG.
    #[arg(long, value_name = "TIMELINE.svg")]
    svg: Option<PathBuf>,
    /// Also write every control cycle as CSV.
    #[arg(long, value_name = "TIMELINE.csv")]
    csv: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let inputs = crate::output::Inputs::new(args.scene.as_ref());
    inputs.check_outputs(&[("--svg", args.svg.as_deref()), ("--csv", args.csv.as_deref())])?;
    crate::output::replaceable(&inputs, args.svg.as_deref(), crate::output::Kind::Svg)?;
    crate::output::replaceable(
        &inputs,
        args.csv.as_deref(),
        crate::output::Kind::Table("t_s,force_n"),
    )?;
    let scene = match &args.scene {
        Some(p) => skin_control::sim::Scene::from_file(p)?,
        None => phri::default_scene()?,
    };
    let world = skin_control::sim::World::from_scene(&scene)?;
    let start = match &scene.home {
        Some(h) => h.clone(),
        None => phri::default_start(world.chain().dof()),
    };
    let script = PhriScript::default();
    let run = phri::run(&scene, &start, &script)?;
    report(&run);
    if let Some(path) = &args.svg {
        let svg = plot(&run)?;
        crate::output::write_file(path, svg.as_bytes(), &inputs)?;
        crate::say!("timeline plotted to {}", path.display());
    }
    if let Some(path) = &args.csv {
        let mut text = String::from(
            "t_s,force_n,contacts,task1,reference_speed_m_s,centroid_speed_m_s,path_error_m,progress_m\n",
        );
        for s in &run.samples {
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
        crate::output::write_file(path, text.as_bytes(), &inputs)?;
    }
    Ok(())
}

fn report(run: &PhriRun) {
    let s = &run.script;
    let (b0, bd) = s.bump;
    let (p0, pd) = s.push;
    let peak = |from: f64, to: f64| run.between(from, to).map(|x| x.force).fold(0.0, f64::max);
    let err = |from: f64, to: f64| run.between(from, to).map(|x| x.path_error).fold(0.0, f64::max);
    crate::say!(
        "path following at {} m/s, touches on {}; times in s, forces in N",
        s.path_speed,
        run.link
    );
    let bump_task1 = run.between(b0, b0 + bd + 0.1).any(|x| x.task1);
    crate::say!(
        "{b0:>5.2}  bump (not a hand) for {bd} s: peak force {:.1}, task 1 {}, path error at most {:.1} mm",
        peak(b0, b0 + bd),
        if bump_task1 {
            "ACTIVATED"
        } else {
            "not activated (ignored)"
        },
        1000.0 * err(b0, b0 + bd + 0.1)
    );
    match run.task1_from(p0) {
        Some(t) => {
            let active: Vec<_> = run.between(p0, p0 + pd).filter(|x| x.task1).collect();
            let n = active.len().max(1) as f64;
            let tracking = active
                .iter()
                .map(|x| (x.reference_speed - x.centroid_speed).abs())
                .sum::<f64>()
                / n;
            let top = active.iter().map(|x| x.centroid_speed).fold(0.0, f64::max);
            crate::say!(
                "{p0:>5.2}  hand push at {} m/s for {pd} s: task 1 active after {:.2} s; centroid speed up to {:.3} m/s (V_max 0.3), |reference - actual| {:.1} mm/s on average; peak force {:.1}",
                s.push_speed,
                t - p0,
                top,
                1000.0 * tracking,
                peak(p0, p0 + pd)
            );
        }
        None => crate::say!("{p0:>5.2}  hand push: task 1 NEVER activated"),
    }
    let release = p0 + pd;
    let back = run
        .samples
        .iter()
        .find(|x| x.t > release && x.path_error < 0.001)
        .map(|x| x.t);
    crate::say!(
        "{release:>5.2}  hand lets go: path error {:.1} mm, back under 1 mm {}",
        1000.0
            * run
                .between(release, release + 0.02)
                .map(|x| x.path_error)
                .fold(0.0, f64::max),
        back.map_or("never".to_string(), |t| format!("after {:.2} s", t - release))
    );
}

/// The timeline as SVG: three panels over time.
fn plot(run: &PhriRun) -> Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (900, 720)).into_drawing_area();
        root.fill(&WHITE)?;
        let panels = root.split_evenly((3, 1));
        let t_end = run.script.duration;
        let s = &run.samples;
        let fmax = s.iter().map(|x| x.force).fold(1.0, f64::max) * 1.1;
        let vmax = s
            .iter()
            .map(|x| x.reference_speed.max(x.centroid_speed))
            .fold(0.05, f64::max)
            * 1.1;
        let emax = s.iter().map(|x| x.path_error * 1000.0).fold(1.0, f64::max) * 1.1;
        let mut force = panel(
            &panels[0],
            "contact force (N); shaded: task 1 active",
            t_end,
            fmax,
        )?;
        force.draw_series(s.iter().filter(|x| x.task1).map(|x| {
            Rectangle::new(
                [(x.t, 0.0), (x.t + 0.005, fmax)],
                RGBColor(220, 235, 255).filled(),
            )
        }))?;
        force.draw_series(LineSeries::new(s.iter().map(|x| (x.t, x.force)), &RED))?;
        let mut speed = panel(
            &panels[1],
            "contact centroid speed (m/s): reference (black), actual (blue)",
            t_end,
            vmax,
        )?;
        speed.draw_series(LineSeries::new(
            s.iter().map(|x| (x.t, x.reference_speed)),
            &BLACK,
        ))?;
        speed.draw_series(LineSeries::new(s.iter().map(|x| (x.t, x.centroid_speed)), &BLUE))?;
        let mut error = panel(&panels[2], "path error (mm)", t_end, emax)?;
        error.draw_series(LineSeries::new(
            s.iter().map(|x| (x.t, x.path_error * 1000.0)),
            &GREEN,
        ))?;
        root.present()?;
    }
    Ok(svg)
}

/// One panel of the timeline: time (0..t_end s) across, 0..ymax up, with its caption and grid.
fn panel<'a, 'b>(
    area: &'a DrawingArea<SVGBackend<'b>, plotters::coord::Shift>,
    caption: &str,
    t_end: f64,
    ymax: f64,
) -> Result<
    ChartContext<
        'a,
        SVGBackend<'b>,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
> {
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(50)
        .build_cartesian_2d(0.0..t_end, 0.0..ymax)?;
    chart.configure_mesh().x_desc("time (s)").draw()?;
    Ok(chart)
}

//! `skin phri`: the physical-interaction experiment in simulation (thesis Ch. 9.3, Experiment 2).

use anyhow::Result;
use skin_control::sim::phri::{self, PhriScript};
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
    crate::say!("{}", run.report());
    if let Some(path) = &args.svg {
        crate::output::write_file(path, run.to_svg()?.as_bytes(), &inputs)?;
        crate::say!("timeline plotted to {}", path.display());
    }
    if let Some(path) = &args.csv {
        crate::output::write_file(path, run.to_csv().as_bytes(), &inputs)?;
    }
    Ok(())
}

//! `skin reach`: the reach-through-clutter experiment in simulation (thesis Ch. 8.5-8.6).

use anyhow::Result;
use rayon::prelude::*;
use skin_control::sim::{ReachExperiment, ReachOptions, Scene, Trial, stats};
use std::path::PathBuf;

/// Reach goals behind padded obstacles with skin feedback, in a headless simulation.
///
/// Prints a table like the thesis' Tables 8.1/8.2. Every goal of the scene is tried from every starting posture (--trials per goal). A trial
/// succeeds when the hand is within the scene's tolerance (default 5 mm) of the goal without any
/// contact force above --threshold; it fails by "force" (threshold exceeded: stopped at once),
/// "stall" (no 2 mm of progress for the scene's stall_time, a local minimum) or "timeout".
/// The force columns are over the successful trials: the mean of each trial's largest contact
/// force with its 95% t interval, the smallest and the largest; the success rate has Wilson's
/// 95% interval. --no-skin runs the same trials with the contact tasks disabled (the baseline).
///
/// The simulation is kinematic and deterministic: the same scene and seed give the same table,
/// byte for byte. Without --scene the built-in scene modelled on Fig. 8.4 is used (5 goals, each
/// behind a padded bar that blocks the straight path; see skin-control/scenes/fig8_4.json for
/// the format).
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Scene JSON (obstacles, goals, starts); the built-in Fig. 8.4 scene by default.
    #[arg(long, value_name = "SCENE.json")]
    scene: Option<PathBuf>,
    /// F_thresh: the largest contact force allowed, newtons (also scales the activations).
    #[arg(long, default_value_t = 15.0, value_name = "NEWTONS", value_parser = crate::numbers::above(0.0, 1e6))]
    threshold: f64,
    /// Starting postures per goal (default: the scene's random_starts, or its list of starts).
    #[arg(long, value_name = "N", value_parser = crate::numbers::count::<1, 100_000>)]
    trials: Option<usize>,
    /// Seed of the random starting postures (default: the scene's).
    #[arg(long)]
    seed: Option<u64>,
    /// Baseline: the same trials with the skin's contact tasks disabled.
    #[arg(long)]
    no_skin: bool,
    /// Also write every trial as CSV (goal, start, outcome, forces, time, distance).
    #[arg(long, value_name = "TRIALS.csv")]
    csv: Option<PathBuf>,
}

pub(crate) fn load_scene(path: &Option<PathBuf>) -> Result<Scene> {
    Ok(match path {
        Some(p) => Scene::from_file(p)?,
        None => Scene::fig_8_4()?,
    })
}

pub fn run(args: Args) -> Result<()> {
    let inputs = crate::output::Inputs::new(args.scene.as_ref());
    inputs.check_outputs(&[("--csv", args.csv.as_deref())])?;
    crate::output::replaceable(
        &inputs,
        args.csv.as_deref(),
        crate::output::Kind::Table("goal,start,outcome"),
    )?;
    let mut scene = load_scene(&args.scene)?;
    if let Some(seed) = args.seed {
        scene.seed = seed;
    }
    let experiment = ReachExperiment::new(&scene, args.trials)?;
    let options = ReachOptions {
        threshold: args.threshold,
        no_skin: args.no_skin,
        ..ReachOptions::default()
    };
    // Trials are independent and deterministic: run them in parallel, report in order.
    let trials: Vec<Trial> = experiment
        .trials()
        .par_iter()
        .map(|&(g, s)| experiment.run(g, s, &options))
        .collect::<Result<_, _>>()?;
    crate::say!(
        "{} ({} goals x {} starts, seed {})",
        scene.name(),
        scene.goals.len(),
        experiment.starts(0).len(),
        scene.seed
    );
    crate::say!(
        "{}",
        stats::table(&trials, scene.goals.len(), args.threshold, args.no_skin).trim_end()
    );
    if let Some(path) = &args.csv {
        let mut text = String::from("goal,start,outcome,max_force_n,max_skin_force_n,time_s,distance_m\n");
        for t in &trials {
            text.push_str(&format!(
                "{},{},{},{:.4},{:.4},{:.3},{:.5}\n",
                stats::goal_name(t.goal),
                t.start,
                t.outcome.name(),
                t.max_force,
                t.max_skin_force,
                t.time,
                t.distance
            ));
        }
        crate::output::write_file(path, text.as_bytes(), &inputs)?;
    }
    Ok(())
}

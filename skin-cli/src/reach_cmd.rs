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
/// --seeds N runs N seeds from --seed on, each with starting postures of its own: the table pools
/// them, and a second table gives each seed's success rate, all of them pooled (Wilson's 95%
/// interval) and the mean over seeds (Student's t 95% interval: the seeds are the independent
/// samples). --baseline also runs every trial without the skin and prints it beside.
///
/// Beyond the thesis' controller, two things are on by default (--thesis turns both off): a
/// force guard that slows the reach from 0.6 F_thresh and stops it at 0.85 F_thresh, leaving
/// the contact tasks to take the force back down (the thesis' activation, (F/F_thresh)^4, comes
/// in too late at a low threshold), and an escape from local minima: after 1 s without 2 mm of
/// progress the hand heads for a via point 10 cm across the obstacle holding it (on the goal's
/// side, or upwards when the goal lies straight behind it), for up to 1.5 s, at most 6 times a
/// trial, each a quarter turn further about the contact normal. A detour is not a stall: the
/// stall clock restarts when an escape ends.
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
    #[arg(long, conflicts_with = "baseline")]
    no_skin: bool,
    /// Seeds to run, from --seed on (each its own random starts).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = crate::numbers::count::<1, 10_000>)]
    seeds: usize,
    /// Also run every trial without the skin and print both.
    #[arg(long)]
    baseline: bool,
    /// The thesis' controller as published: no force guard, no escape from local minima.
    #[arg(long)]
    thesis: bool,
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
        crate::output::Kind::Table("seed,skin,goal,start,outcome"),
    )?;
    let mut scene = load_scene(&args.scene)?;
    let first = args.seed.unwrap_or(scene.seed);
    let last = first.checked_add(args.seeds as u64 - 1).ok_or_else(|| {
        anyhow::anyhow!(
            "--seed {first} and --seeds {}: the last seed overflows",
            args.seeds
        )
    })?;
    let (runs, starts) = run_seeds(&mut scene, first..=last, &args)?;
    let seeds = if first == last {
        format!("seed {first}")
    } else {
        format!("seeds {first}-{last}")
    };
    crate::say!(
        "{} ({} goals x {starts} starts, {seeds})",
        scene.name(),
        scene.goals.len(),
    );
    let trials: Vec<Trial> = runs.iter().flat_map(|r| r.skin.iter().cloned()).collect();
    crate::say!(
        "{}",
        stats::table(&trials, scene.goals.len(), args.threshold, args.no_skin).trim_end()
    );
    if let Some(base) = args.baseline.then(|| {
        runs.iter()
            .flat_map(|r| r.baseline.iter().flatten().cloned())
            .collect::<Vec<_>>()
    }) {
        crate::say!(
            "{}",
            stats::table(&base, scene.goals.len(), args.threshold, true).trim_end()
        );
    }
    if args.seeds > 1 || args.baseline {
        crate::say!("{}", stats::seeds_table(&runs, args.threshold).trim_end());
    }
    if let Some(path) = &args.csv {
        crate::output::write_file(path, trials_csv(&runs, args.no_skin).as_bytes(), &inputs)?;
    }
    Ok(())
}

/// Every trial of each seed (with the skin, and without it with --baseline), and the starts per
/// goal.
fn run_seeds(
    scene: &mut Scene,
    seeds: std::ops::RangeInclusive<u64>,
    args: &Args,
) -> Result<(Vec<stats::SeedRun>, usize)> {
    let options = ReachOptions {
        threshold: args.threshold,
        no_skin: args.no_skin,
        ..if args.thesis {
            ReachOptions::thesis()
        } else {
            ReachOptions::default()
        }
    };
    let baseline = ReachOptions {
        no_skin: true,
        ..options
    };
    let mut runs = Vec::new();
    let mut starts = 0;
    for seed in seeds {
        scene.seed = seed;
        let experiment = ReachExperiment::new(scene, args.trials)?;
        starts = experiment.starts(0).len();
        // Trials are independent and deterministic: run them in parallel, report in order.
        let run = |options: &ReachOptions| -> Result<Vec<Trial>> {
            Ok(experiment
                .trials()
                .par_iter()
                .map(|&(g, s)| experiment.run(g, s, options))
                .collect::<Result<_, _>>()?)
        };
        runs.push(stats::SeedRun {
            seed,
            skin: run(&options)?,
            baseline: if args.baseline {
                Some(run(&baseline)?)
            } else {
                None
            },
        });
    }
    Ok((runs, starts))
}

/// The trials as CSV: seed, skin (1 with, 0 without), goal, start, outcome, forces, time, distance.
fn trials_csv(runs: &[stats::SeedRun], no_skin: bool) -> String {
    let mut text =
        String::from("seed,skin,goal,start,outcome,max_force_n,max_skin_force_n,time_s,distance_m\n");
    for r in runs {
        let with = std::iter::repeat(!no_skin).zip(&r.skin);
        let without = std::iter::repeat(false).zip(r.baseline.iter().flatten());
        for (skin, t) in with.chain(without) {
            text.push_str(&format!(
                "{},{},{},{},{},{:.4},{:.4},{:.3},{:.5}\n",
                r.seed,
                u8::from(skin),
                stats::goal_name(t.goal),
                t.start,
                t.outcome.name(),
                t.max_force,
                t.max_skin_force,
                t.time,
                t.distance
            ));
        }
    }
    text
}

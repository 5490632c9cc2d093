//! Reach through clutter with skin feedback (thesis Ch. 8.5), in the headless simulation: the
//! control loop a robot stack would run, with the simulated world standing in for the robot.
//!
//! ```text
//! cargo run --release -p skin-examples --example reach_through_clutter
//! ```
//! Each cycle the skin is read at the current posture (taxel forces grouped into contacts per
//! link), the controller turns contacts and goal into joint velocities, and the joints move by
//! one step. The hand goes to goal B of the default scene (Fig. 8.4), which a padded bar blocks:
//! the links that touch the bar back off while the hand slides around it. The same trial without
//! the skin drives straight into the bar until the force exceeds the threshold.

use skin_control::contact_tasks::Gains;
use skin_control::sim::{ReachExperiment, ReachOptions, Scene};
use skin_control::{ReachGoal, Regularisation, SkinController};

fn main() -> anyhow::Result<()> {
    let scene = Scene::fig_8_4()?;
    let experiment = ReachExperiment::new(&scene, Some(1))?;
    let world = experiment.world();
    let (goal, threshold) = (1, 15.0);
    let target = nalgebra::Point3::from(scene.goals[goal]);

    // The loop, written out: sense, control, move.
    let mut controller = SkinController::new(
        world.chain().clone(),
        world.tip(),
        Regularisation::default(),
        Gains {
            contact: 5.0,
            max_speed: scene.hand_speed,
            ..Gains::default()
        },
        threshold,
    )?;
    let reach = ReachGoal {
        goal: target,
        hand: nalgebra::Point3::origin(),
        tool_axis: nalgebra::Vector3::z_axis(),
    };
    let dt = 1.0 / scene.rate;
    let mut q = experiment.starts(goal)[0].clone();
    let limits: Vec<(f64, f64)> = world.chain().joints().iter().map(|j| j.limits).collect();
    let mut peak: f64 = 0.0;
    for step in 0..(20.0 / dt) as usize {
        let at = world.chain().posture(&q)?;
        let skin = world.sense(&at, &[]);
        peak = peak.max(skin.max_force);
        let distance = (world.hand(&at) - target).norm();
        if step % 200 == 0 || distance < scene.tolerance {
            let links: Vec<&str> = skin.contacts.iter().map(|l| l.link.as_str()).collect();
            println!(
                "t = {:5.2} s  hand {:5.1} mm from the goal  largest force {:5.2} N  touched: {}",
                step as f64 * dt,
                distance * 1000.0,
                skin.max_force,
                if links.is_empty() {
                    "-".to_string()
                } else {
                    links.join(", ")
                }
            );
        }
        if distance < scene.tolerance {
            break;
        }
        let qdot = controller.step(&q, &skin.contacts, Some(&reach))?;
        // Joint speed limit (uniform scaling keeps the direction), then position limits.
        let top = qdot.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        let scale = if top > scene.max_speed {
            scene.max_speed / top
        } else {
            1.0
        };
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = (*qi + qdot[i] * scale * dt).clamp(limits[i].0, limits[i].1);
        }
    }
    println!("largest contact force on the way: {peak:.2} N (threshold {threshold} N)\n");

    // The same trial through the experiment runner, with and without the skin.
    for no_skin in [false, true] {
        let options = ReachOptions {
            threshold,
            no_skin,
            ..ReachOptions::default()
        };
        let trial = experiment.run(goal, 0, &options)?;
        println!(
            "{}: {} after {:.2} s, largest force {:.2} N",
            if no_skin { "without skin" } else { "with skin   " },
            trial.outcome.name(),
            trial.time,
            trial.max_force
        );
    }
    Ok(())
}

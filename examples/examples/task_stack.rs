//! Drive an arm with skin feedback: one control cycle after another of the skin-driven task stack
//! (thesis Ch. 8 and App. D).
//!
//! ```text
//! cargo run --release -p skin-examples --example task_stack
//! ```
//! The fixture's 7-DOF arm reaches for a goal behind an obstacle that presses on its forearm.
//! As the contact force rises through the threshold (15 N), the contact task fades in
//! (activation (F/15 N)^4) and takes priority over reaching: the joint velocities change
//! smoothly, and the forearm backs off before the hand goes on.

use nalgebra::{Point3, Unit, Vector3};
use skin_control::contact_tasks::{Contact, Gains};
use skin_control::{Chain, LinkContacts, ReachGoal, Regularisation, SkinController};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let urdf = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    let chain = Chain::from_urdf(&urdf, "base", "tool")?;
    let mut controller =
        SkinController::new(chain, "tool", Regularisation::default(), Gains::default(), 15.0)?;
    let q = [0.2, 0.6, -0.1, 1.2, 0.1, 0.5, 0.0];

    // The forearm's frame and a contact on its side; the goal lies beyond the obstacle.
    let forearm = controller.chain().link_pose("link5", &q)?;
    let normal = Unit::new_normalize(forearm.rotation * Vector3::y());
    let hand = controller.chain().link_pose("tool", &q)?.translation.vector;
    let goal = ReachGoal {
        goal: Point3::from(hand + normal.into_inner() * 0.2),
        hand: Point3::origin(),
        tool_axis: Vector3::z_axis(),
    };
    println!("contact force -> joint velocities (rad/s)");
    for force in [0.0, 5.0, 10.0, 12.0, 13.0, 14.0, 14.5, 14.9, 15.0, 20.0] {
        let contact = Contact {
            point: forearm * Point3::new(0.0, 0.04, 0.05),
            normal,
            force,
            stiffness: 2000.0,
        };
        let touched = [LinkContacts {
            link: "link5".into(),
            contacts: vec![contact],
        }];
        let qdot = controller.step(&q, &touched, Some(&goal))?;
        let shown: Vec<String> = qdot.iter().map(|v| format!("{v:+.3}")).collect();
        println!("{force:>5.1} N: [{}]", shown.join(", "));
    }
    Ok(())
}

//! Fuzzing of skin-control's readers, scenes (JSON) and robot chains (URDF): arbitrary text and
//! hostile edits of valid files (see `skin_test_support::mutate`) give `Ok` or an error, never a
//! panic; a scene that is accepted builds its world and senses contacts at its home posture
//! without a panic (parry's penetration search is where huge numbers used to end).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use proptest::prelude::*;
use skin_control::Chain;

use mutate::{arbitrary_text, config, mutated};
use skin_test_support::mutate;

/// An accepted chain gives finite poses and Jacobians at its zero posture.
fn check_urdf(text: &str) -> Result<(), TestCaseError> {
    let Ok(chain) = Chain::from_urdf_str(text, "base", "tool") else {
        return Ok(());
    };
    let q = vec![0.0; chain.dof()];
    if let Ok(poses) = chain.link_poses(&q) {
        prop_assert!(
            poses
                .iter()
                .all(|p| p.translation.vector.iter().all(|v| v.is_finite()))
        );
    }
    if let Ok(at) = chain.posture(&q)
        && let Ok(j) = at.jacobian("tool", &nalgebra::Point3::origin())
    {
        prop_assert!(j.iter().all(|v| v.is_finite()));
    }
    Ok(())
}

/// The built-in arm (the same file as `skin_control::sim::scene::ARM7_URDF`).
const ARM7_URDF: &str = include_str!("../../fixtures/arm7/arm7.urdf");

#[test]
fn the_valid_urdf_reads() {
    assert_eq!(Chain::from_urdf_str(ARM7_URDF, "base", "tool").unwrap().dof(), 7);
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn urdfs(text in prop_oneof![mutated(ARM7_URDF), arbitrary_text()]) {
        check_urdf(&text)?;
    }
}

#[test]
fn a_joint_origin_out_of_range_is_refused_naming_the_joint() {
    let huge = ARM7_URDF.replacen("xyz=\"0 0 0.3\"", "xyz=\"0 0 1e300\"", 1);
    assert_ne!(huge, ARM7_URDF, "the fixture arm changed: update this test");
    let e = Chain::from_urdf_str(&huge, "base", "tool")
        .unwrap_err()
        .to_string();
    assert!(e.contains("origin xyz") && e.contains("joint"), "{e}");
}

#[cfg(feature = "sim")]
mod scenes {
    use super::*;
    use skin_control::sim::scene::FIG_8_4;
    use skin_control::sim::{ReachExperiment, Scene, World};

    /// The world of an accepted scene senses finite forces at its home posture.
    fn check_scene(text: &str) -> Result<(), TestCaseError> {
        let Ok(scene) = Scene::parse(text, "scene.json") else {
            return Ok(());
        };
        let Ok(world) = World::from_scene(&scene) else {
            return Ok(());
        };
        let q = scene
            .home
            .clone()
            .unwrap_or_else(|| vec![0.0; world.chain().dof()]);
        if let Ok(at) = world.chain().posture(&q) {
            let sensed = world.sense(&at, &[]);
            prop_assert!(
                sensed.max_force.is_finite() && sensed.max_force >= 0.0,
                "{}",
                sensed.max_force
            );
        }
        Ok(())
    }

    #[test]
    fn the_valid_scene_reads() {
        let scene = Scene::parse(FIG_8_4, "fig8_4.json").unwrap();
        World::from_scene(&scene).unwrap();
    }

    #[test]
    fn a_runaway_trial_count_is_refused_with_its_field() {
        for (field, text) in [
            (
                "random_starts",
                FIG_8_4.replace("\"random_starts\": 10", "\"random_starts\": 1000000000000"),
            ),
            (
                "random_starts",
                FIG_8_4.replace("\"random_starts\": 10", "\"random_starts\": 0"),
            ),
        ] {
            let e = Scene::parse(&text, "scene.json").unwrap_err().to_string();
            assert!(e.contains(field), "{e}");
        }
    }

    proptest! {
        #![proptest_config(config())]

        #[test]
        fn scenes(text in prop_oneof![mutated(FIG_8_4), arbitrary_text()]) {
            check_scene(&text)?;
        }
    }

    proptest! {
        // Drawing random starts solves inverse kinematics: fewer cases, still every mutation kind.
        #![proptest_config(ProptestConfig { cases: 64, ..config() })]

        #[test]
        fn accepted_scenes_prepare_their_trials(text in mutated(FIG_8_4)) {
            if let Ok(scene) = Scene::parse(&text, "scene.json") {
                let _ = ReachExperiment::new(&scene, Some(1));
            }
        }
    }
}

//! The simulation (feature `sim`): the scene format and its errors, the spring contact model and
//! the skin that reads it, and the reach experiment's acceptance figures on the default scene.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Isometry3, Point3, Vector3};
use skin_control::sim::stats::{counts, table, wilson};
use skin_control::sim::{Outcome, ReachExperiment, ReachOptions, Scene, SceneError, Solid, Trial, World};

fn run_all(e: &ReachExperiment, options: &ReachOptions) -> Vec<Trial> {
    // Two threads: the trials are independent.
    let all = e.trials();
    let (a, b) = all.split_at(all.len() / 2);
    std::thread::scope(|s| {
        let h = s.spawn(|| {
            a.iter()
                .map(|&(g, t)| e.run(g, t, options).unwrap())
                .collect::<Vec<_>>()
        });
        let mut out: Vec<Trial> = b.iter().map(|&(g, t)| e.run(g, t, options).unwrap()).collect();
        let mut first = h.join().unwrap();
        first.append(&mut out);
        first
    })
}

#[test]
fn the_default_scene_reaches_the_thesis_success_rates_and_the_skin_is_what_makes_it_work() {
    let scene = Scene::fig_8_4().unwrap();
    assert_eq!(scene.goals.len(), 5);
    assert_eq!(scene.obstacles.len(), 5);
    let e = ReachExperiment::new(&scene, None).unwrap();
    // Every start of every goal has its straight path to the goal blocked by a bar.
    for g in 0..5 {
        assert_eq!(e.starts(g).len(), 10);
        for q in e.starts(g) {
            let at = e.world().chain().posture(q).unwrap();
            assert!(
                e.world()
                    .blocked(&e.world().hand(&at), &Point3::from(scene.goals[g]))
            );
        }
    }
    // The thesis' controller as published: its figures (Tables 8.1/8.2: 43/50 and 37/50).
    let at = |threshold: f64, no_skin: bool| {
        let options = ReachOptions {
            threshold,
            no_skin,
            ..ReachOptions::thesis()
        };
        counts(&run_all(&e, &options))
    };
    let high = at(15.0, false);
    let low = at(7.5, false);
    let baseline = at(15.0, true);
    assert!(high.success >= 43, "15 N: {high:?}");
    assert!(low.success >= 37, "7.5 N: {low:?}");
    // Without the skin the arm pushes straight through the bars: the threshold is exceeded.
    assert!(baseline.success <= 5, "no skin: {baseline:?}");
    assert!(baseline.force >= 40, "no skin: {baseline:?}");
}

#[test]
fn the_force_guard_and_the_escape_beat_the_thesis_controller_at_a_low_threshold() {
    // Four seeds pooled (200 trials): one seed's 50 are too few to tell 7 points apart. These
    // are seeds the guard and escape were tuned on; `skin reach --seed 1001 --seeds 10` gives
    // the figures on seeds they never saw (README).
    let (mut ours, mut thesis) = (Vec::new(), Vec::new());
    for seed in 1..=4 {
        let mut scene = Scene::fig_8_4().unwrap();
        scene.seed = seed;
        let e = ReachExperiment::new(&scene, None).unwrap();
        let low = |o: ReachOptions| ReachOptions { threshold: 7.5, ..o };
        ours.extend(run_all(&e, &low(ReachOptions::default())));
        thesis.extend(run_all(&e, &low(ReachOptions::thesis())));
    }
    let (ours, thesis) = (counts(&ours), counts(&thesis));
    // The thesis' controller overruns 7.5 N on about one trial in six and stalls on as many. The
    // guard all but ends the overruns (some of them become stalls); the escape frees more trials
    // than that.
    assert!(thesis.force >= 20, "thesis: {thesis:?}");
    assert!(ours.force * 5 <= thesis.force, "ours {ours:?}, thesis {thesis:?}");
    assert!(
        ours.success >= thesis.success + 10,
        "ours {ours:?}, thesis {thesis:?}"
    );
}

#[test]
fn with_no_obstacles_every_goal_is_reached_and_the_same_seed_gives_the_same_table() {
    let mut scene = Scene::fig_8_4().unwrap();
    scene.obstacles.clear();
    scene.blocked_starts = false;
    scene.random_starts = 4;
    let e = ReachExperiment::new(&scene, None).unwrap();
    let options = ReachOptions::default();
    let trials = run_all(&e, &options);
    for t in &trials {
        assert_eq!(t.outcome, Outcome::Success, "{t:?}");
        assert_eq!(t.max_force, 0.0);
    }
    let again = run_all(&ReachExperiment::new(&scene, None).unwrap(), &options);
    assert_eq!(table(&trials, 5, 15.0, false), table(&again, 5, 15.0, false));
    // Another seed, other starts.
    scene.seed += 1;
    let other = ReachExperiment::new(&scene, None).unwrap();
    assert_ne!(other.starts(0), e.starts(0));
}

#[test]
fn the_spring_model_gives_k_times_the_depth_and_the_skin_reads_it() {
    let scene = Scene::parse(r#"{"goals": [[0.5, 0, 0.5]]}"#, "test").unwrap();
    let world = World::from_scene(&scene).unwrap();
    let q = [0.0, 0.5, 0.0, 1.3, 0.0, 0.6, 0.0];
    let at = world.chain().posture(&q).unwrap();
    let tool = at.link_pose("tool").unwrap();
    let tip = world.hand(&at);
    let axis = tool.rotation * Vector3::z();
    for depth in [0.001, 0.004, 0.01] {
        // A wall across the tool's axis, pressed `depth` into the hand's tip.
        let centre = tip + axis * (0.05 - depth);
        let wall = Solid::cuboid(
            &Vector3::new(0.2, 0.2, 0.05),
            &Isometry3::from_parts(centre.coords.into(), tool.rotation),
        );
        let s = world.sense(&at, &[wall]);
        let want = world.stiffness() * depth;
        assert!(
            (s.max_force - want).abs() < 1e-6 * want.max(1.0),
            "{} vs {want}",
            s.max_force
        );
        // The pole taxel sits on the tip: the skin reads the same force.
        assert!(
            (s.skin_max - want).abs() < 1e-6 * want.max(1.0),
            "{} vs {want}",
            s.skin_max
        );
        assert_eq!(s.contacts.len(), 1);
        assert_eq!(s.contacts[0].link, "tool");
        // Per taxel: K times its own depth behind the wall's face, so never more than the tip's.
        let face = centre - axis * 0.05;
        for t in &s.taxels[0].contacts {
            let depth_here = (t.point - face).dot(&axis);
            assert!(
                (t.force - world.stiffness() * depth_here).abs() < 1e-6,
                "{} vs {depth_here}",
                t.force
            );
        }
        assert_eq!(s.taxels_in_contact, s.taxels[0].contacts.len());
        // One contact, its normal along the tool axis (pressed from the front).
        let c = &s.contacts[0].contacts;
        assert_eq!(c.len(), 1);
        assert!(c[0].normal.dot(&axis) > 0.99, "{}", c[0].normal.into_inner());
    }
    // Clear of the wall: nothing.
    let wall = Solid::cuboid(
        &Vector3::new(0.2, 0.2, 0.05),
        &Isometry3::from_parts((tip + axis * 0.051).coords.into(), tool.rotation),
    );
    let s = world.sense(&at, &[wall]);
    assert_eq!((s.max_force, s.skin_max, s.contacts.len()), (0.0, 0.0, 0));
}

#[test]
fn every_point_of_a_link_surface_is_near_a_taxel() {
    let world = World::from_scene(&Scene::fig_8_4().unwrap()).unwrap();
    let q = [0.0; 7];
    let at = world.chain().posture(&q).unwrap();
    // Probe each part with a small ball touching its surface all around: the skin notices.
    for part in world.parts() {
        let pose = at.link_pose(&part.link).unwrap();
        let axis = part.b - part.a;
        let side = axis
            .cross(&Vector3::x())
            .try_normalize(1e-9)
            .unwrap_or(Vector3::y());
        for k in 0..8 {
            let along = part.a + axis * (k as f64 / 7.0);
            let dir = nalgebra::UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                k as f64 * 0.9,
            ) * side;
            // A 1 cm ball pressed 3 mm into the skin.
            let centre = pose * (along + dir * (part.radius + 0.01 - 0.003));
            let ball = Solid::capsule(&centre, &centre, 0.01);
            let s = world.sense(&at, &[ball]);
            assert!(s.max_force > 2.9, "{}: {}", part.link, s.max_force);
            assert!(s.skin_max > 0.0, "{} at {k}: no taxel felt it", part.link);
        }
    }
}

#[test]
fn bad_scenes_are_refused_with_the_field_at_fault() {
    let err = |text: &str| Scene::parse(text, "s.json").unwrap_err().to_string();
    assert!(err("{\"goals\": [[0,0,0]],\n \"obstacles\": [{\"type\": \"sphere\"}]}").contains("line 2"));
    assert!(
        err(r#"{"goals": [[0,0,0]], "obstacles": [{"type": "capsule", "a": [0,0,0], "b": [0,0,1], "radius": -1}]}"#)
            .contains("obstacles[0].radius")
    );
    assert!(err(r#"{"goals": []}"#).contains("goals"));
    assert!(err(r#"{"goals": [[0,0,0]], "stiffness": 0}"#).contains("stiffness"));
    assert!(err(r#"{"goals": [[0,0,0]], "speed": 1}"#).contains("unknown field"));
    let scene = Scene::parse(r#"{"goals": [[0.5,0,0.5]], "tip": "gripper"}"#, "s.json").unwrap();
    let e = World::from_scene(&scene).unwrap_err();
    assert!(e.to_string().contains("gripper"), "{e}");
    let scene = Scene::parse(r#"{"goals": [[0.5,0,0.5]], "starts": [[0, 0, 0]]}"#, "s.json").unwrap();
    let e = ReachExperiment::new(&scene, None).unwrap_err();
    assert!(
        matches!(e, SceneError::Field { .. }) && e.to_string().contains("starts[0]"),
        "{e}"
    );
    // A goal no random start can have blocked.
    let scene = Scene::parse(
        r#"{"goals": [[0.5,0,0.5]], "blocked_starts": true, "random_starts": 2}"#,
        "s.json",
    )
    .unwrap();
    assert!(
        ReachExperiment::new(&scene, None)
            .unwrap_err()
            .to_string()
            .contains("goals[0]")
    );
}

#[test]
fn wilson_intervals_match_published_values() {
    // Newcombe (1998), Table I: 81/263 -> 0.2553 to 0.3662.
    let (lo, hi) = wilson(81, 263);
    assert!(
        (lo - 0.2553).abs() < 5e-4 && (hi - 0.3662).abs() < 5e-4,
        "{lo} {hi}"
    );
    // 0/10 -> 0 to 0.2775; 10/10 -> 0.7225 to 1.
    let (lo, hi) = wilson(0, 10);
    assert!(lo == 0.0 && (hi - 0.2775).abs() < 5e-4);
    let (lo, hi) = wilson(10, 10);
    assert!((lo - 0.7225).abs() < 5e-4 && (hi - 1.0).abs() < 1e-12);
}

#[test]
fn a_bump_is_ignored_and_a_hand_push_takes_over_then_the_path_is_picked_up_again() {
    use skin_control::sim::phri::{self, PhriScript};
    let scene = phri::default_scene().unwrap();
    let script = PhriScript::default();
    let run = phri::run(&scene, &phri::default_start(7), &script).unwrap();
    let (b0, bd) = script.bump;
    let (p0, pd) = script.push;
    // The bump presses, but task 1 stays off and the hand stays on its path.
    let bump: Vec<_> = run.between(b0, b0 + bd).collect();
    assert!(bump.iter().any(|s| s.force > 5.0), "the bump never pressed");
    assert!(bump.iter().all(|s| !s.task1));
    assert!(bump.iter().all(|s| s.path_error < 1e-3));
    // The push: task 1 within 0.2 s (the gate's 0.07 s latency plus the first millimetres).
    let on = run.task1_from(p0).expect("task 1 never activated");
    assert!(on - p0 < 0.2, "task 1 after {} s", on - p0);
    let active: Vec<_> = run.between(on, p0 + pd).collect();
    assert!(
        active.iter().all(|s| s.task1),
        "task 1 dropped out during the push"
    );
    for s in &active {
        assert!(s.reference_speed <= 0.3 + 1e-9);
        // The centroid follows its reference (within 25 %: the joint speed limit scales
        // all joints down together when one would exceed it).
        assert!(
            (s.centroid_speed - s.reference_speed).abs() <= 0.25 * s.reference_speed + 1e-3,
            "t = {}: {} vs {}",
            s.t,
            s.centroid_speed,
            s.reference_speed
        );
    }
    // The arm yielded: it moved off its path by several centimetres, and after the hand lets go
    // it is back on the path within 3 s.
    let off = run.between(p0, p0 + pd).map(|s| s.path_error).fold(0.0, f64::max);
    assert!(off > 0.03, "{off}");
    let end = run
        .between(p0 + pd + 3.0, script.duration)
        .map(|s| s.path_error)
        .fold(0.0, f64::max);
    assert!(end < 1e-3, "{end}");
}

#[test]
fn the_finger_gate_needs_three_contacts_for_its_latency() {
    use skin_control::contact_tasks::Contact;
    use skin_control::hri::ContactGate;
    use skin_control::sim::phri::FingerGate;
    let c = Contact {
        point: Point3::origin(),
        normal: Vector3::z_axis(),
        force: 5.0,
        stiffness: 1000.0,
    };
    let mut gate = FingerGate::new(3, 0.07, 0.005);
    // One broad contact: never a hand.
    for _ in 0..100 {
        assert!(!gate.allows("link5", &[c]));
    }
    // Three: after 0.07 s (14 cycles), not before.
    for k in 1..=20 {
        assert_eq!(gate.allows("link5", &[c, c, c]), k >= 14, "cycle {k}");
    }
    // A gap resets it.
    assert!(!gate.allows("link5", &[c]));
    assert!(!gate.allows("link5", &[c, c, c]));
}

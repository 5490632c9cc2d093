//! The interaction tasks of Ch. 9.2 on the 7-DOF fixture arm: which task a touch triggers, which
//! way it moves the arm, and the gate's veto.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Unit, Vector3};
use skin_control::contact_tasks::Contact;
use skin_control::hri::{AllowAll, HriKind, HriParams, interaction_task};
use skin_control::{Chain, LinkContacts, Regularisation, TaskStack};
use std::path::Path;

fn chain() -> Chain {
    Chain::from_urdf(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf"),
        "base",
        "tool",
    )
    .unwrap()
}

const Q: [f64; 7] = [0.2, 0.6, -0.1, 1.2, 0.1, 0.5, 0.0];

/// A contact on `link` at `local` (link frame), skin normal `n` (link frame), force `f`.
fn touch(chain: &Chain, link: &str, local: [f64; 3], n: [f64; 3], f: f64) -> Contact {
    let pose = chain.link_pose(link, &Q).unwrap();
    Contact {
        point: pose * Point3::from(local),
        normal: Unit::new_normalize(pose.rotation * Vector3::from(n)),
        force: f,
        stiffness: 2000.0,
    }
}

#[test]
fn a_push_moves_the_touched_point_along_the_push() {
    let c = chain();
    let contact = touch(&c, "link5", [0.0, 0.05, 0.05], [0.0, 1.0, 0.0], 12.0);
    let touched = [LinkContacts {
        link: "link5".into(),
        contacts: vec![contact],
    }];
    let (kind, task) = interaction_task(&c, &Q, &touched, &mut AllowAll, &HriParams::default())
        .unwrap()
        .unwrap();
    assert_eq!(kind, HriKind::MoveAlongPush { link: "link5".into() });
    let qdot = TaskStack::new(7, Regularisation::default())
        .solve(std::slice::from_ref(&task))
        .unwrap();
    let v = (&task.jacobian * qdot).rows(0, 3).into_owned();
    // Yields: moves against the outward normal, at up to (12 - 1) / (20 - 1) of 0.3 m/s (the task
    // also asks for no rotation, which five joints cannot always grant exactly).
    let speed = 0.3 * 11.0 / 19.0;
    let along = -v.dot(&contact.normal);
    assert!(
        along > 0.9 * v.norm() && v.norm() <= speed * 1.01 && along > 0.5 * speed,
        "{v}"
    );
}

#[test]
fn two_hands_turn_a_link_and_touches_on_two_neighbours_bend_their_joint() {
    let c = chain();
    // Two hands on link3 from opposite sides, off-centre: a torque about its joint.
    let grasp = vec![
        touch(&c, "link3", [0.05, 0.0, 0.1], [1.0, 0.0, 0.0], 10.0),
        touch(&c, "link3", [-0.05, 0.0, 0.1], [-1.0, 0.0, 0.0], 10.0),
    ];
    let held = [LinkContacts {
        link: "link3".into(),
        contacts: grasp.clone(),
    }];
    let (kind, task) = interaction_task(&c, &Q, &held, &mut AllowAll, &HriParams::default())
        .unwrap()
        .unwrap();
    assert_eq!(kind, HriKind::TurnLink { joint: 2 });
    assert_eq!(task.jacobian.nrows(), 1);
    // Opposite forces along x at the same axis point: no torque about link3's z axis; twist them.
    let twist = vec![
        touch(&c, "link3", [0.05, 0.03, 0.1], [1.0, 0.0, 0.0], 10.0),
        touch(&c, "link3", [-0.05, -0.03, 0.1], [-1.0, 0.0, 0.0], 10.0),
    ];
    let held = [LinkContacts {
        link: "link3".into(),
        contacts: twist,
    }];
    let (_, task) = interaction_task(&c, &Q, &held, &mut AllowAll, &HriParams::default())
        .unwrap()
        .unwrap();
    assert!(
        task.reference[0].abs() > 0.01,
        "a twisting grasp turns the joint: {}",
        task.reference[0]
    );
    // Touches on link4 and link5: bend joint 4 (between them).
    let both = [
        LinkContacts {
            link: "link4".into(),
            contacts: vec![touch(&c, "link4", [0.0, 0.05, 0.1], [0.0, 1.0, 0.0], 8.0)],
        },
        LinkContacts {
            link: "link5".into(),
            contacts: vec![touch(&c, "link5", [0.0, 0.05, 0.1], [0.0, 1.0, 0.0], 8.0)],
        },
    ];
    let (kind, task) = interaction_task(&c, &Q, &both, &mut AllowAll, &HriParams::default())
        .unwrap()
        .unwrap();
    assert_eq!(kind, HriKind::BendJoint { joint: 4 });
    assert!(task.reference[0] != 0.0);
}

#[test]
fn the_gate_can_veto_a_contact_and_nan_is_ignored() {
    let c = chain();
    let contact = touch(&c, "link5", [0.0, 0.05, 0.05], [0.0, 1.0, 0.0], 12.0);
    let touched = [LinkContacts {
        link: "link5".into(),
        contacts: vec![contact],
    }];
    let mut not_a_hand = |_: &str, _: &[Contact]| false;
    assert!(
        interaction_task(&c, &Q, &touched, &mut not_a_hand, &HriParams::default())
            .unwrap()
            .is_none()
    );
    let mut nan = contact;
    nan.force = f64::NAN;
    let touched = [LinkContacts {
        link: "link5".into(),
        contacts: vec![nan],
    }];
    assert!(
        interaction_task(&c, &Q, &touched, &mut AllowAll, &HriParams::default())
            .unwrap()
            .is_none()
    );
    let elsewhere = [LinkContacts {
        link: "elbow".into(),
        contacts: vec![contact],
    }];
    assert!(interaction_task(&c, &Q, &elsewhere, &mut AllowAll, &HriParams::default()).is_err());
}

#[test]
fn the_class_gate_keeps_the_latest_action_and_stop_wins() {
    use skin_control::hri::{ClassGate, GateAction};
    let gate = ClassGate::new([("non_hand", GateAction::Slow)]);
    // A class without an action leaves the decision to the others.
    assert_eq!(gate.decide(["hand"]), GateAction::Resume);
    assert_eq!(gate.decide(["non_hand", "hand"]), GateAction::Slow);
    let gate = ClassGate::new([("hand", GateAction::Comply), ("non_hand", GateAction::Stop)]);
    assert_eq!(gate.decide(["hand", "hand"]), GateAction::Comply);
    assert_eq!(gate.decide(["hand", "non_hand", "hand"]), GateAction::Stop);
}

#[test]
fn the_gate_maps_any_number_of_classes_by_name() {
    use skin_control::hri::{ClassGate, GateAction};
    // A classifier of four classes: each its own action, one without.
    let gate = ClassGate::new([
        ("palm", GateAction::Comply),
        ("object", GateAction::Slow),
        ("elbow", GateAction::Stop),
    ]);
    assert_eq!(gate.decide(["palm"]), GateAction::Comply);
    assert_eq!(gate.decide(["palm", "object"]), GateAction::Slow);
    assert_eq!(gate.decide(["object", "palm"]), GateAction::Comply);
    assert_eq!(gate.decide(["finger"]), GateAction::Resume);
    assert_eq!(gate.decide(["palm", "elbow", "object"]), GateAction::Stop);
    assert_eq!(gate.action("object"), Some(GateAction::Slow));
    assert_eq!(gate.action("Object"), None, "names are matched exactly");
}

#[test]
fn gate_actions_are_read_by_name_and_a_wrong_one_lists_them() {
    use skin_control::hri::GateAction;
    for action in GateAction::ALL {
        assert_eq!(action.name().parse::<GateAction>(), Ok(action));
        assert_eq!(action.to_string(), action.name());
    }
    let e = "Stop".parse::<GateAction>().unwrap_err().to_string();
    assert_eq!(e, "\"Stop\": expected stop, comply, slow or resume");
    // A long text is cut in the message.
    let e = "x".repeat(1000).parse::<GateAction>().unwrap_err().to_string();
    assert!(e.len() < 100, "{e}");
}

#[test]
fn an_unsure_hand_at_the_border_gets_the_border_rules_action() {
    use skin_control::hri::{BorderRule, ClassGate, GateAction, GateTouch};
    let rule = BorderRule {
        within_mm: 15.0,
        hand_below: 0.9,
        action: GateAction::Stop,
    };
    let gate = ClassGate {
        border: Some(rule),
        ..ClassGate::new([("palm", GateAction::Comply), ("other", GateAction::Slow)])
    };
    // The hand is whichever class the classifier says it is (here "palm").
    let hand = |probability: f64, border_mm: f64| GateTouch {
        class: "palm",
        hand: true,
        probability,
        border_mm,
        force_n: None,
    };
    // Within the distance (inclusive) and under the bar: the rule's action.
    assert_eq!(gate.decide([hand(0.6, 0.0)]), GateAction::Stop);
    assert_eq!(gate.decide([hand(0.89, 15.0)]), GateAction::Stop);
    // A probability that is not a number is not a sure hand.
    assert_eq!(gate.decide([hand(f64::NAN, 3.0)]), GateAction::Stop);
    // Sure enough, or far enough from the border: the hand's action.
    assert_eq!(gate.decide([hand(0.9, 0.0)]), GateAction::Comply);
    assert_eq!(gate.decide([hand(0.6, 15.1)]), GateAction::Comply);
    // The rule is about hands: anything else keeps its own action at the border.
    let other = GateTouch {
        class: "other",
        hand: false,
        probability: 0.55,
        border_mm: 0.0,
        force_n: None,
    };
    assert_eq!(gate.decide([other]), GateAction::Slow);
    // The rule's action is weighed with the others': stop still wins.
    assert_eq!(gate.decide([other, hand(0.6, 1.0)]), GateAction::Stop);
    // Without a rule, a hand is a hand wherever it touches.
    let plain = ClassGate { border: None, ..gate };
    assert_eq!(plain.decide([hand(0.51, 0.0)]), GateAction::Comply);
}

#[test]
fn a_touch_past_its_class_force_limit_stops_the_arm() {
    use skin_control::hri::{ClassGate, GateAction, GateTouch};
    let mut gate = ClassGate::new([("hand", GateAction::Comply), ("non_hand", GateAction::Slow)]);
    gate.force_n.insert("hand".into(), 140.0);
    gate.force_n.insert("non_hand".into(), 65.0);
    let touch = |class, force_n| GateTouch {
        class,
        hand: class == "hand",
        probability: 1.0,
        border_mm: 50.0,
        force_n,
    };
    // At the limit the class's action holds; past it, stop, and the limit is named.
    assert_eq!(gate.decide([touch("hand", Some(140.0))]), GateAction::Comply);
    assert_eq!(gate.decide([touch("hand", Some(140.5))]), GateAction::Stop);
    assert_eq!(gate.force_crossed(&touch("hand", Some(140.5))), Some(140.0));
    assert_eq!(gate.decide([touch("non_hand", Some(70.0))]), GateAction::Stop);
    assert_eq!(gate.decide([touch("non_hand", Some(60.0))]), GateAction::Slow);
    // Unweighed, a NaN force, or a class without a limit: the class's action.
    assert_eq!(gate.decide([touch("hand", None)]), GateAction::Comply);
    assert_eq!(gate.decide([touch("hand", Some(f64::NAN))]), GateAction::Comply);
    let other = GateTouch {
        class: "elbow",
        ..touch("hand", Some(1e4))
    };
    assert_eq!(gate.force_crossed(&other), None);
    // Stop for force wins over a hand guiding the arm at the same time.
    assert_eq!(
        gate.decide([touch("hand", Some(20.0)), touch("non_hand", Some(80.0))]),
        GateAction::Stop
    );
    assert!(gate.check_force().is_ok());
    gate.force_n.insert("hand".into(), -3.0);
    assert_eq!(gate.check_force().unwrap_err().0, "hand");
}

#[test]
fn a_border_rule_out_of_bounds_is_named() {
    use skin_control::hri::BorderRule;
    assert!(BorderRule::default().check().is_ok());
    let far = BorderRule {
        within_mm: -1.0,
        ..BorderRule::default()
    };
    assert_eq!(far.check().map_err(|e| e.0), Err("[gate] border.within_mm"));
    for p in [1.5, f64::NAN, -0.1] {
        let odd = BorderRule {
            hand_below: p,
            ..BorderRule::default()
        };
        assert_eq!(odd.check().map_err(|e| e.0), Err("[gate] border.hand_below"));
    }
}

//! A control cycle of the 7-DOF fixture arm: it reaches, it backs off a contact, it sorts its tasks
//! by force, and it never returns garbage.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Unit, Vector3};
use skin_control::contact_tasks::{Contact, Gains};
use skin_control::{Chain, LinkContacts, ReachGoal, Regularisation, SkinController};
use std::path::Path;

fn controller() -> SkinController {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    let chain = Chain::from_urdf(&path, "base", "tool").unwrap();
    SkinController::new(chain, "tool", Regularisation::default(), Gains::default(), 15.0).unwrap()
}

const Q: [f64; 7] = [0.2, 0.6, -0.1, 1.2, 0.1, 0.5, 0.0];

fn goal(at: Point3<f64>) -> ReachGoal {
    ReachGoal {
        goal: at,
        hand: Point3::origin(),
        tool_axis: Vector3::z_axis(),
    }
}

#[test]
fn without_contact_the_hand_heads_for_the_goal() {
    let mut c = controller();
    let hand = c.chain().link_pose("tool", &Q).unwrap().translation.vector;
    let target = Point3::from(hand + Vector3::new(0.05, -0.03, 0.02));
    let qdot = c.step(&Q, &[], Some(&goal(target))).unwrap();
    let j = c.chain().jacobian("tool", &Point3::origin(), &Q).unwrap();
    let v = (j * &qdot).rows(0, 3).into_owned();
    let want = target.coords - hand;
    assert!(v.dot(&want) / (v.norm() * want.norm()) > 0.95, "{v} vs {want}");
}

#[test]
fn a_hard_contact_on_the_forearm_is_backed_off_first() {
    let mut c = controller();
    let pose = c.chain().link_pose("link5", &Q).unwrap();
    // A bar pressing the forearm sideways (skin normal +y in the link frame) with 20 N.
    let normal = Unit::new_normalize(pose.rotation * Vector3::y());
    let point = pose * Point3::new(0.0, 0.04, 0.05);
    let contact = Contact {
        point,
        normal,
        force: 20.0,
        stiffness: 2000.0,
    };
    let hand = c.chain().link_pose("tool", &Q).unwrap().translation.vector;
    let target = Point3::from(hand + normal.into_inner() * 0.2); // the goal is behind the bar
    let contacts = [LinkContacts {
        link: "link5".into(),
        contacts: vec![contact],
    }];
    let qdot = c.step(&Q, &contacts, Some(&goal(target))).unwrap();
    // The contact point moves away from the bar: its force falls.
    let local = pose.inverse() * point;
    let j = c.chain().jacobian("link5", &local, &Q).unwrap();
    let v = (j * &qdot).rows(0, 3).into_owned();
    assert!(v.dot(&normal) < 0.0, "the forearm pushes into the bar: {v}");
}

#[test]
fn nan_joints_give_zero_velocity_and_unknown_links_an_error() {
    let mut c = controller();
    let mut q = Q;
    q[3] = f64::NAN;
    assert!(
        c.step(&q, &[], Some(&goal(Point3::new(0.3, 0.0, 0.5))))
            .unwrap()
            .iter()
            .all(|v| *v == 0.0)
    );
    let bad = [LinkContacts {
        link: "elbow".into(),
        contacts: vec![],
    }];
    assert!(c.step(&Q, &bad, None).is_err());
    assert!(c.step(&Q[..6], &[], None).is_err());
}

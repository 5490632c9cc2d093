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

/// The largest change of the joint velocities between two cycles as a contact force on the forearm
/// rises from 0 to 20 N in steps of 5 mN, the goal lying behind the obstacle (so the reaching task
/// pulls hard against the contact task that fades in).
fn largest_step(regularisation: Regularisation) -> f64 {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    let chain = Chain::from_urdf(&path, "base", "tool").unwrap();
    let mut c = SkinController::new(chain, "tool", regularisation, Gains::default(), 15.0).unwrap();
    let pose = c.chain().link_pose("link5", &Q).unwrap();
    let normal = Unit::new_normalize(pose.rotation * Vector3::y());
    let hand = c.chain().link_pose("tool", &Q).unwrap().translation.vector;
    let g = goal(Point3::from(hand + normal.into_inner() * 0.2));
    let mut last: Option<nalgebra::DVector<f64>> = None;
    let mut worst: f64 = 0.0;
    for k in 0..=4000 {
        let force = 20.0 * f64::from(k) / 4000.0;
        let contact = Contact {
            point: pose * Point3::new(0.0, 0.04, 0.05),
            normal,
            force,
            stiffness: 2000.0,
        };
        let qdot = c
            .step(
                &Q,
                &[LinkContacts {
                    link: "link5".into(),
                    contacts: vec![contact],
                }],
                Some(&g),
            )
            .unwrap();
        if let Some(prev) = &last {
            worst = worst.max((&qdot - prev).norm());
        }
        last = Some(qdot);
    }
    worst
}

#[test]
fn joint_velocities_stay_continuous_while_a_strong_lower_task_gives_way() {
    let aware = largest_step(Regularisation::default());
    // Without the penalty on directions the contact task is claiming, the reaching task uses them
    // with large gains until the very end of the fade-in: a jump.
    let no_penalty = largest_step(Regularisation::ActivationAware {
        lambda: 0.05,
        threshold: 0.01,
        eta: 0.0,
    });
    assert!(aware < 0.01, "largest change per 5 mN step: {aware}");
    assert!(no_penalty > 3.0 * aware, "{no_penalty} vs {aware}");
}

#[test]
fn a_joint_at_its_limit_is_pushed_back_whatever_the_goal() {
    let c = controller();
    let (_, hi) = c.chain().joints()[3].limits;
    let mut q = Q;
    q[3] = hi; // the elbow at its stop
    let hand = c.chain().link_pose("tool", &q).unwrap().translation.vector;
    let mut driven_on = 0;
    for k in 0..26 {
        // Goals 10 cm away in 26 directions.
        let a = k as f64 * 0.7;
        let b = k as f64 * 1.3;
        let dir = Vector3::new(a.cos() * b.sin(), a.sin() * b.sin(), b.cos());
        let target = Point3::from(hand + dir * 0.1);
        let unguarded = controller()
            .with_limit_margin(0.0)
            .step(&q, &[], Some(&goal(target)))
            .unwrap();
        if unguarded[3] > 1e-3 {
            driven_on += 1;
        }
        let qdot = controller().step(&q, &[], Some(&goal(target))).unwrap();
        assert!(
            qdot[3] < 0.0,
            "goal {k}: the elbow is not pushed back out: {qdot}"
        );
    }
    // Without the limit task, some of those goals drive the elbow into its stop.
    assert!(driven_on > 0);
}

#[test]
fn nan_forces_are_ignored_and_the_velocities_stay_finite() {
    let pose = controller().chain().link_pose("link5", &Q).unwrap();
    let mut bad = Contact {
        point: pose * Point3::new(0.0, 0.04, 0.05),
        normal: Unit::new_normalize(pose.rotation * Vector3::y()),
        force: f64::NAN,
        stiffness: 1000.0,
    };
    let hand = controller()
        .chain()
        .link_pose("tool", &Q)
        .unwrap()
        .translation
        .vector;
    let target = goal(Point3::from(hand + Vector3::new(0.05, 0.0, 0.0)));
    let clean = controller().step(&Q, &[], Some(&target)).unwrap();
    for (force, point) in [(f64::NAN, bad.point), (5.0, Point3::new(f64::NAN, 0.0, 0.0))] {
        bad.force = force;
        bad.point = point;
        let contacts = [LinkContacts {
            link: "link5".into(),
            contacts: vec![bad],
        }];
        let qdot = controller().step(&Q, &contacts, Some(&target)).unwrap();
        assert!(qdot.iter().all(|v| v.is_finite()), "{qdot}");
        if force.is_nan() {
            assert_eq!(qdot, clean, "a NaN force must count as no contact");
        }
    }
}

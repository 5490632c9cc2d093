//! The skin's tasks (thesis Ch. 8.4): contact forces fall under the contact task, reaching does not
//! undo it, and the activation is continuous.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::{Point3, Unit, Vector3, Vector6};
use proptest::prelude::*;
use skin_control::contact_tasks::{Contact, Gains, activation, contact_twist, group_contacts, reach_twist};

/// The rate of change of each contact force under a link twist (Eq. 8.10, 8.13):
/// f_dot = -K n^T (x_L dot + omega x r), n = minus the skin normal.
fn force_rates(origin: &Point3<f64>, contacts: &[Contact], rho: &Vector6<f64>) -> Vec<f64> {
    let (v, w) = (
        rho.fixed_rows::<3>(0).into_owned(),
        rho.fixed_rows::<3>(3).into_owned(),
    );
    contacts
        .iter()
        .map(|c| {
            let xdot = v + w.cross(&(c.point - origin));
            -c.stiffness * (-c.normal.into_inner()).dot(&xdot)
        })
        .collect()
}

fn contact(p: [f64; 3], n: [f64; 3], force: f64) -> Contact {
    Contact {
        point: Point3::from(p),
        normal: Unit::new_normalize(Vector3::from(n)),
        force,
        stiffness: 2000.0,
    }
}

#[test]
fn a_single_contact_pushes_the_link_away_from_the_obstacle() {
    let origin = Point3::origin();
    let c = [contact([0.1, 0.0, 0.05], [0.0, 0.0, 1.0], 8.0)];
    let rho = contact_twist(&origin, &c, &Gains::default());
    let rates = force_rates(&origin, &c, &rho);
    assert!(rates[0] < 0.0, "{rates:?}");
    // The contact point moves into the link's side, away from what presses on it.
    let xdot = rho.fixed_rows::<3>(0) + rho.fixed_rows::<3>(3).cross(&(c[0].point - origin));
    assert!(xdot.z < 0.0, "{xdot}");
}

#[test]
fn reaching_without_contact_heads_for_the_goal_and_turns_the_tool_towards_it() {
    let origin = Point3::new(0.5, 0.0, 0.3);
    let hand = Point3::new(0.6, 0.0, 0.3);
    let goal = Point3::new(0.6, 0.2, 0.3);
    let axis = Unit::new_normalize(Vector3::x());
    let rho = reach_twist(&origin, &hand, &axis, &goal, &[], &Gains::default());
    let v_hand = rho.fixed_rows::<3>(0) + rho.fixed_rows::<3>(3).cross(&(hand - origin));
    assert!(
        (v_hand - (goal - hand) * Gains::default().position).norm() < 1e-4,
        "{v_hand}"
    );
    // The tool axis x turns towards +y: a positive rotation about z.
    assert!(rho[5] > 0.0, "{rho}");
}

#[test]
fn reaching_with_a_contact_does_not_undo_the_contact_task() {
    let origin = Point3::new(0.5, 0.0, 0.3);
    let hand = Point3::new(0.6, 0.0, 0.3);
    let goal = Point3::new(0.9, 0.0, 0.3);
    let axis = Unit::new_normalize(Vector3::x());
    let c = [contact([0.55, 0.0, 0.34], [0.0, 0.0, 1.0], 5.0)];
    let gains = Gains::default();
    let with_goal = reach_twist(&origin, &hand, &axis, &goal, &c, &gains);
    let contact_only = contact_twist(&origin, &c, &gains);
    // The contact force falls as fast as under the contact task alone: reaching is in its null
    // space.
    let (a, b) = (
        force_rates(&origin, &c, &with_goal)[0],
        force_rates(&origin, &c, &contact_only)[0],
    );
    assert!(a < 0.0 && (a - b).abs() < 1e-3 * b.abs(), "{a} vs {b}");
    // ... and the hand still moves towards the goal.
    let v_hand = with_goal.fixed_rows::<3>(0) + with_goal.fixed_rows::<3>(3).cross(&(hand - origin));
    assert!(v_hand.x > 0.05, "{v_hand}");
}

#[test]
fn the_activation_rises_continuously_and_saturates() {
    let mut last = 0.0;
    for k in 0..=2000 {
        let f = 30.0 * f64::from(k) / 2000.0;
        let a = activation(f, 15.0);
        assert!((0.0..=1.0).contains(&a) && a >= last && a - last < 0.01);
        last = a;
    }
    assert_eq!(activation(15.0, 15.0), 1.0);
    assert_eq!(activation(7.5, 15.0), 1.0 / 16.0);
    assert_eq!(activation(f64::NAN, 15.0), 0.0);
    assert_eq!(activation(5.0, 0.0), 0.0);
}

#[test]
fn nan_contacts_are_ignored_not_propagated() {
    let origin = Point3::origin();
    let mut bad = contact([0.1, 0.0, 0.0], [0.0, 0.0, 1.0], f64::NAN);
    assert_eq!(
        contact_twist(&origin, &[bad], &Gains::default()),
        Vector6::zeros()
    );
    bad.force = 3.0;
    bad.point.x = f64::INFINITY;
    let good = contact([0.0, 0.1, 0.0], [1.0, 0.0, 0.0], 3.0);
    let rho = contact_twist(&origin, &[bad, good], &Gains::default());
    assert!(rho.iter().all(|v| v.is_finite()) && rho.norm() > 0.0);
    let nan_goal = Point3::new(f64::NAN, 0.0, 0.0);
    let r = reach_twist(
        &origin,
        &origin,
        &Vector3::x_axis(),
        &nan_goal,
        &[good],
        &Gains::default(),
    );
    assert_eq!(r, Vector6::zeros());
}

proptest! {
    /// Eq. 8.16: under the contact task, V_dot = sum f_j f_dot_j is never positive.
    #[test]
    fn the_squared_forces_never_rise(
        raw in prop::collection::vec((prop::array::uniform3(-0.2f64..0.2), prop::array::uniform3(-1.0f64..1.0), 0.0f64..30.0), 1..6),
    ) {
        let contacts: Vec<Contact> = raw
            .iter()
            .filter(|(_, n, _)| Vector3::from(*n).norm() > 0.1)
            .map(|&(p, n, f)| contact(p, n, f))
            .collect();
        prop_assume!(!contacts.is_empty());
        let origin = Point3::origin();
        let rho = contact_twist(&origin, &contacts, &Gains::default());
        let rates = force_rates(&origin, &contacts, &rho);
        let v_dot: f64 = contacts.iter().zip(&rates).map(|(c, r)| c.force * r).sum();
        prop_assert!(v_dot <= 1e-9, "V_dot = {}", v_dot);
    }
}

fn taxel(x: f64, y: f64, normal: Vector3<f64>, force: f64) -> Contact {
    Contact {
        point: Point3::new(x, y, 0.0),
        normal: Unit::new_normalize(normal),
        force,
        stiffness: 1000.0,
    }
}

#[test]
fn taxels_of_one_patch_make_one_contact_with_the_mean_normal() {
    // Two patches 10 cm apart: three taxels 1 cm apart, and one alone.
    let taxels = [
        taxel(0.00, 0.0, Vector3::new(-0.2, 0.0, 1.0), 1.0),
        taxel(0.01, 0.0, Vector3::new(0.0, 0.0, 1.0), 2.0),
        taxel(0.02, 0.0, Vector3::new(0.2, 0.0, 1.0), 1.0),
        taxel(0.12, 0.0, Vector3::new(1.0, 0.0, 0.0), 0.5),
        taxel(0.30, 0.0, Vector3::new(1.0, 0.0, 0.0), 0.0), // no force: not a contact
    ];
    let contacts = group_contacts(&taxels, 0.015);
    assert_eq!(contacts.len(), 2);
    let c = &contacts[0];
    assert!(
        (c.point - Point3::new(0.01, 0.0, 0.0)).norm() < 1e-12,
        "{}",
        c.point
    );
    assert!(
        (c.normal.into_inner() - Vector3::z()).norm() < 1e-12,
        "{}",
        c.normal.into_inner()
    );
    assert_eq!(c.force, 2.0);
    assert_eq!(contacts[1].force, 0.5);
    // Chained: taxels 1 cm apart join even though the ends are 2 cm apart.
    assert_eq!(group_contacts(&taxels[..3], 0.011).len(), 1);
    assert_eq!(group_contacts(&taxels[..3], 0.009).len(), 3);
}

//! URDF chains: forward kinematics and geometric Jacobians, checked against finite differences
//! on the project's 7-DOF arm and the Baxter arm.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test

use nalgebra::Point3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use skin_control::{Chain, KinematicsError};
use std::path::Path;

use skin_test_support::shared_data;

fn arm7() -> Chain {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    Chain::from_urdf(&path, "base", "tool").unwrap()
}

/// Jacobian columns against central differences of the point's position and the link's
/// orientation, at random joint values.
fn check_against_finite_differences(chain: &Chain, links: &[&str], seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = chain.dof();
    for _ in 0..20 {
        let q: Vec<f64> = (0..n).map(|_| rng.random_range(-1.5..1.5)).collect();
        for link in links {
            let point = Point3::new(
                rng.random_range(-0.1..0.1),
                rng.random_range(-0.1..0.1),
                rng.random_range(-0.1..0.1),
            );
            let jac = chain.jacobian(link, &point, &q).unwrap();
            let h = 1e-6;
            for i in 0..n {
                let (mut up, mut down) = (q.clone(), q.clone());
                up[i] += h;
                down[i] -= h;
                let (tu, td) = (
                    chain.link_pose(link, &up).unwrap(),
                    chain.link_pose(link, &down).unwrap(),
                );
                let v = ((tu * point) - (td * point)) / (2.0 * h);
                // Angular velocity from the rotation difference.
                let w = (tu.rotation * td.rotation.inverse()).scaled_axis() / (2.0 * h);
                let col = jac.column(i);
                let err_v = (col.fixed_rows::<3>(0) - v).norm();
                let err_w = (col.fixed_rows::<3>(3) - w).norm();
                assert!(
                    err_v < 1e-6 && err_w < 1e-6,
                    "{link}, joint {i}: linear off by {err_v}, angular by {err_w}"
                );
            }
        }
    }
}

#[test]
fn the_arm7_jacobians_match_finite_differences() {
    let chain = arm7();
    assert_eq!(chain.dof(), 7);
    check_against_finite_differences(&chain, &["link3", "link5", "tool", "base"], 1);
    // A link early in the chain does not move with later joints.
    let jac = chain.jacobian("link3", &Point3::origin(), &[0.1; 7]).unwrap();
    assert!(jac.columns(3, 4).iter().all(|v| *v == 0.0));
    // The straight arm reaches 1.15 m up.
    let tool = chain.link_pose("tool", &[0.0; 7]).unwrap();
    assert!((tool.translation.vector.z - 1.15).abs() < 1e-12);
}

#[test]
fn the_baxter_arm_jacobians_match_finite_differences() {
    let Some(path) = shared_data::shared("baxter/urdf/baxter.urdf") else {
        return;
    };
    let chain = Chain::from_urdf(&path, "base", "left_hand").unwrap();
    let names: Vec<&str> = chain.joints().iter().map(|j| j.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "left_s0", "left_s1", "left_e0", "left_e1", "left_w0", "left_w1", "left_w2"
        ]
    );
    check_against_finite_differences(
        &chain,
        &["left_lower_forearm", "left_hand", "left_upper_elbow"],
        2,
    );
}

#[test]
fn bad_input_is_an_error() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/arm7/arm7.urdf");
    let err = Chain::from_urdf(&path, "base", "gripper").unwrap_err();
    assert!(
        matches!(err, KinematicsError::UnknownLink { ref name, .. } if name == "gripper"),
        "{err}"
    );
    assert!(err.to_string().contains("link \"gripper\" is not in"));
    let chain = arm7();
    assert!(chain.jacobian("link9", &Point3::origin(), &[0.0; 7]).is_err());
    assert!(
        chain
            .link_poses(&[0.0; 6])
            .unwrap_err()
            .to_string()
            .contains("6 joint values for a chain of 7")
    );
    assert!(
        chain
            .link_poses(&[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0])
            .is_err()
    );
    assert!(Chain::from_urdf_str("<robot", "a", "b").is_err());
    assert!(matches!(
        Chain::from_urdf(&path, "tool", "base"),
        Err(KinematicsError::NoPath { .. })
    ));
}

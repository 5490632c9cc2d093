//! Contacts on a real patch's geometry: fingertips pressed side by side on the curved Cyskin
//! patch of the real recordings (`../shared/data`, 7.3 mm median taxel pitch), where the count
//! of fingers is known because the presses are drawn, not recorded.

#![allow(clippy::unwrap_used)]

use nalgebra::{Point3, Vector3};
use skin_core::{ContactFinder, Separation};

use skin_test_support::shared_data;

/// A small deterministic generator (the test needs no statistics, only spread placements).
struct Lcg(u64);

impl Lcg {
    fn unit(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `k` fingertips in a row on the patch: each centre is the taxel nearest to the last one moved
/// `spacing` along a direction in the skin's tangent plane at the first. Returns the centres,
/// or None where the row runs off the patch.
fn row(
    positions: &[Point3<f64>],
    normals: &[Vector3<f64>],
    first: usize,
    angle: f64,
    k: usize,
    spacing: f64,
) -> Option<Vec<usize>> {
    let n = normals[first];
    let a = if n.x.abs() < 0.9 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let u = n.cross(&a).normalize();
    let v = n.cross(&u);
    let dir = u * angle.cos() + v * angle.sin();
    let mut centres = vec![first];
    for _ in 1..k {
        let target = positions[*centres.last().unwrap()] + dir * spacing;
        let (best, d) = positions
            .iter()
            .enumerate()
            .map(|(i, p)| (i, (p - target).norm()))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .unwrap();
        // Off the patch, or snapped back onto a centre already used.
        if d > 0.005 || centres.contains(&best) {
            return None;
        }
        centres.push(best);
    }
    Some(centres)
}

#[test]
fn fingertips_side_by_side_on_the_real_patch_are_counted() {
    let Some(path) = shared_data::shared("cyskin/curved_gesture_patch.json") else {
        return;
    };
    let link = skin_core::format::load_link(&path).unwrap().value;
    let positions: Vec<_> = link.taxels.iter().map(|t| t.position).collect();
    let normals: Vec<_> = link.taxels.iter().map(|t| t.normal.into_inner()).collect();
    let faces = link.faces.clone().unwrap();
    let mut split = ContactFinder::new(&positions, &normals, &faces, &path)
        .unwrap()
        .with_separation(Separation::FINGERS);
    let mut connected = ContactFinder::new(&positions, &normals, &faces, &path).unwrap();
    let mut rng = Lcg(7);
    // Fingertips: contact sigma 4 mm, centres 18 mm apart (fingers side by side), each pressing
    // between 60% and 100% of the hardest; the threshold is a tenth of the hardest press.
    let (sigma, spacing) = (0.004, 0.018);
    for k in 1..=4 {
        let (mut placed, mut right, mut joined) = (0, 0, 0);
        let mut tries = 0;
        while placed < 100 && tries < 20_000 {
            tries += 1;
            let first = (rng.unit() * positions.len() as f64) as usize % positions.len();
            let angle = rng.unit() * std::f64::consts::TAU;
            let Some(centres) = row(&positions, &normals, first, angle, k, spacing) else {
                continue;
            };
            let heights: Vec<f64> = centres.iter().map(|_| 0.6 + 0.4 * rng.unit()).collect();
            let pressures: Vec<f32> = positions
                .iter()
                .map(|p| {
                    centres
                        .iter()
                        .zip(&heights)
                        .map(|(&c, h)| {
                            let d2 = (p - positions[c]).norm_squared();
                            h * (-d2 / (2.0 * sigma * sigma)).exp()
                        })
                        .sum::<f64>() as f32
                })
                .collect();
            placed += 1;
            let got = split.find(&pressures, 0.1, 2).unwrap().len();
            right += usize::from(got == k);
            joined += usize::from(connected.find(&pressures, 0.1, 2).unwrap().len() == 1);
        }
        assert_eq!(placed, 100, "{k} fingertips: too few rows fit on the patch");
        eprintln!("{k} fingertip(s): {right} of 100 counted right ({joined} one connected patch)");
        assert!(right >= 90, "{k} fingertip(s): {right} of 100 counted right");
        if k > 1 {
            // The presses touch: without splitting most rows would be one contact.
            assert!(
                joined >= 50,
                "{k} fingertips: only {joined} of 100 rows are one patch"
            );
        }
    }
}

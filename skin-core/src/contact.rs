//! Contacts: the connected patches of pressed taxels in one frame.
//!
//! Two pressed taxels belong to the same contact when an edge of the skin's triangle mesh joins
//! them (the mesh of the tactile map, so neighbours are neighbours on the skin, not across a
//! gap). Each contact gets its taxels, its pressure-weighted centroid and mean normal in the link
//! frame, and its mean and peak pressure. [`ContactFinder`] builds the neighbour lists once; a
//! call to [`ContactFinder::find`] then reuses its buffers and allocates nothing once it has seen
//! as many contacts, as large, as the frame holds.

use crate::contact_peaks::{Flooding, Separation};
use crate::{Error, Result};
use nalgebra::{Point3, Unit, Vector3};
use std::path::Path;

/// One patch of pressed, connected taxels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Contact {
    /// Layout indices of its taxels, ascending.
    pub taxels: Vec<usize>,
    /// Pressure-weighted mean of their positions, metres in the link frame.
    pub centroid: Point3<f64>,
    /// Pressure-weighted mean of their normals, normalised (the outward normal under the contact).
    pub normal: Option<Unit<Vector3<f64>>>,
    /// Mean pressure over its taxels, in the frame's units.
    pub mean_pressure: f32,
    /// Largest pressure, in the frame's units.
    pub peak_pressure: f32,
    /// Its force, newtons: the sum of its taxels' forces ([`ContactFinder::weigh`], with a
    /// [`ForceModel`](crate::force::ForceModel)); none on a skin without a force calibration,
    /// never a guess.
    pub force_n: Option<f64>,
}

/// Finds the contacts of a link's frames; built once per link.
#[derive(Debug, Clone)]
pub struct ContactFinder {
    positions: Vec<Point3<f64>>,
    normals: Vec<Vector3<f64>>,
    /// Neighbours of taxel i: `neighbours[start[i]..start[i + 1]]` (compressed rows).
    start: Vec<usize>,
    neighbours: Vec<usize>,
    /// Per-taxel visit mark of the current frame (`frame` when visited).
    seen: Vec<u32>,
    frame: u32,
    stack: Vec<usize>,
    contacts: Vec<Contact>,
    /// How many of `contacts` the last frame found.
    found: usize,
    /// The patch being found, before it becomes one contact or several.
    patch: Vec<usize>,
    separation: Separation,
    flooding: Flooding,
}

impl ContactFinder {
    /// A finder over taxels at `positions` (metres) with outward `normals` (same length, or
    /// empty), joined by the edges of `faces` (indices into `positions`). `source` names the
    /// mesh in errors.
    pub fn new(
        positions: &[Point3<f64>],
        normals: &[Vector3<f64>],
        faces: &[[usize; 3]],
        source: &Path,
    ) -> Result<ContactFinder> {
        let n = positions.len();
        if !normals.is_empty() && normals.len() != n {
            return Err(Error::invalid(
                source,
                "normals",
                format!("{} normals for {n} taxels", normals.len()),
            ));
        }
        let mut lists: Vec<Vec<usize>> = vec![Vec::new(); n];
        for (f, face) in faces.iter().enumerate() {
            if let Some(&bad) = face.iter().find(|&&v| v >= n) {
                return Err(Error::invalid(
                    source,
                    format!("face {f}"),
                    format!("taxel index {bad}, the skin has {n} taxels"),
                ));
            }
            for k in 0..3 {
                let (a, b) = (face[k], face[(k + 1) % 3]);
                lists[a].push(b);
                lists[b].push(a);
            }
        }
        let mut start = Vec::with_capacity(n + 1);
        let mut neighbours = Vec::new();
        start.push(0);
        for mut list in lists {
            list.sort_unstable();
            list.dedup();
            neighbours.extend(list);
            start.push(neighbours.len());
        }
        Ok(ContactFinder {
            positions: positions.to_vec(),
            normals: normals.to_vec(),
            start,
            neighbours,
            seen: vec![0; n],
            frame: 0,
            stack: Vec::with_capacity(n),
            contacts: Vec::new(),
            found: 0,
            patch: Vec::with_capacity(n),
            separation: Separation::Connected,
            flooding: Flooding::new(n),
        })
    }

    /// The finder with patches split into contacts as `separation` says (default: each
    /// connected patch is one contact).
    pub fn with_separation(mut self, separation: Separation) -> ContactFinder {
        self.separation = separation;
        self
    }

    /// Number of taxels the finder expects per frame.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True for a skin without taxels.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// The contacts of one frame of `pressures` (one per taxel, layout order): taxels above
    /// `threshold` joined by mesh edges, patches of fewer than `min_taxels` left out (a lone
    /// noisy taxel is not a touch). Largest total pressure first.
    pub fn find(&mut self, pressures: &[f32], threshold: f32, min_taxels: usize) -> Result<&[Contact]> {
        if pressures.len() != self.positions.len() {
            return Err(Error::invalid(
                Path::new("frame"),
                "pressures",
                format!(
                    "{} readings, the skin has {} taxels",
                    pressures.len(),
                    self.positions.len()
                ),
            ));
        }
        self.frame = self.frame.wrapping_add(1);
        if self.frame == 0 {
            self.seen.fill(0);
            self.frame = 1;
        }
        let mut count = 0;
        for seed in 0..pressures.len() {
            if self.seen[seed] == self.frame || !(pressures[seed] > threshold) {
                continue;
            }
            self.grow_patch(seed, pressures, threshold);
            if self.patch.len() < min_taxels.max(1) {
                continue;
            }
            let parts = self.split_patch(pressures, count);
            for contact in &mut self.contacts[count..count + parts] {
                describe(contact, pressures, &self.positions, &self.normals);
            }
            count += parts;
        }
        let contacts = &mut self.contacts[..count];
        contacts.sort_unstable_by(|a, b| {
            let total = |c: &Contact| c.mean_pressure as f64 * c.taxels.len() as f64;
            total(b).total_cmp(&total(a))
        });
        self.found = count;
        Ok(&self.contacts[..count])
    }

    /// The patch of taxels above `threshold` joined to `seed` by mesh edges, into `self.patch`
    /// (depth first; each taxel marked seen in this frame).
    fn grow_patch(&mut self, seed: usize, pressures: &[f32], threshold: f32) {
        self.seen[seed] = self.frame;
        self.patch.clear();
        self.stack.clear();
        self.stack.push(seed);
        while let Some(i) = self.stack.pop() {
            self.patch.push(i);
            for &j in &self.neighbours[self.start[i]..self.start[i + 1]] {
                if self.seen[j] != self.frame && pressures[j] > threshold {
                    self.seen[j] = self.frame;
                    self.stack.push(j);
                }
            }
        }
    }

    /// Splits `self.patch` into contacts as the separation rule says, written from
    /// `self.contacts[count]` on (taxels only); returns how many.
    fn split_patch(&mut self, pressures: &[f32], count: usize) -> usize {
        let parts = match self.separation {
            Separation::Connected => 1,
            Separation::Peaks {
                min_dip,
                min_distance_m,
            } => self.flooding.split(
                &self.patch,
                pressures,
                &self.positions,
                &self.start,
                &self.neighbours,
                min_dip,
                min_distance_m,
            ),
        };
        while self.contacts.len() < count + parts {
            self.contacts.push(Contact::default());
        }
        if parts == 1 {
            // The patch is the contact: swap buffers rather than copy (the flooding's
            // labels of a patch it left whole are cleared all the same).
            std::mem::swap(&mut self.contacts[count].taxels, &mut self.patch);
            if matches!(self.separation, Separation::Peaks { .. }) {
                for &i in &self.contacts[count].taxels {
                    self.flooding.take_basin(i);
                }
            }
        } else {
            for c in &mut self.contacts[count..count + parts] {
                c.taxels.clear();
            }
            for &i in &self.patch {
                let part = self.flooding.take_basin(i);
                self.contacts[count + part].taxels.push(i);
            }
        }
        parts
    }

    /// The contacts [`Self::find`] returned last (none before the first frame).
    pub fn last(&self) -> &[Contact] {
        &self.contacts[..self.found]
    }

    /// Gives each contact of the last frame its force: the sum of its taxels' `forces` (N, one
    /// per taxel, layout order; see [`ForceModel::forces`](crate::force::ForceModel::forces)).
    pub fn weigh(&mut self, forces: &[f64]) -> Result<&[Contact]> {
        if forces.len() != self.positions.len() {
            return Err(Error::Length {
                what: "forces for the skin's taxels",
                got: forces.len(),
                expected: self.positions.len(),
            });
        }
        for c in &mut self.contacts[..self.found] {
            c.force_n = Some(c.taxels.iter().map(|&i| forces[i]).sum());
        }
        Ok(&self.contacts[..self.found])
    }
}

/// Fills a contact's centroid, normal, mean and peak from its taxels (sorted here).
fn describe(contact: &mut Contact, pressures: &[f32], positions: &[Point3<f64>], normals: &[Vector3<f64>]) {
    contact.taxels.sort_unstable();
    let (mut sum, mut peak) = (0.0f64, 0.0f32);
    let mut moment = Vector3::zeros();
    let mut normal = Vector3::zeros();
    for &i in &contact.taxels {
        let p = pressures[i];
        sum += f64::from(p);
        peak = peak.max(p);
        moment += positions[i].coords * f64::from(p);
        if let Some(n) = normals.get(i) {
            normal += n * f64::from(p);
        }
    }
    contact.centroid = Point3::from(moment / sum);
    contact.normal = Unit::try_new(normal, 1e-12);
    contact.mean_pressure = (sum / contact.taxels.len() as f64) as f32;
    contact.peak_pressure = peak;
    contact.force_n = None;
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test
    use super::*;
    use proptest::prelude::*;

    /// A strip of `n` x 2 taxels, 8 mm apart, triangulated.
    fn strip(n: usize) -> (Vec<Point3<f64>>, Vec<[usize; 3]>) {
        let mut p = Vec::new();
        for i in 0..n {
            p.push(Point3::new(0.008 * i as f64, 0.0, 0.0));
            p.push(Point3::new(0.008 * i as f64, 0.008, 0.0));
        }
        let mut f = Vec::new();
        for i in 0..n - 1 {
            let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            f.push([a, c, b]);
            f.push([b, c, d]);
        }
        (p, f)
    }

    #[test]
    fn two_separate_patches_are_two_contacts_with_weighted_centroids() {
        let (p, f) = strip(10);
        let mut finder = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
        let mut pressure = vec![0.0f32; 20];
        // Columns 0-1 pressed (3 taxels), column 7 pressed (2 taxels, harder).
        pressure[0] = 10.0;
        pressure[1] = 30.0;
        pressure[2] = 10.0;
        pressure[14] = 100.0;
        pressure[15] = 100.0;
        let c = finder.find(&pressure, 5.0, 1).unwrap();
        assert_eq!(c.len(), 2);
        // Largest total first: 200 > 50.
        assert_eq!(c[0].taxels, vec![14, 15]);
        assert!((c[0].centroid - Point3::new(0.056, 0.004, 0.0)).norm() < 1e-12);
        assert_eq!(c[1].taxels, vec![0, 1, 2]);
        // (10 * (0,0) + 30 * (0,8) + 10 * (8,0)) / 50 mm
        assert!((c[1].centroid - Point3::new(0.0016, 0.0048, 0.0)).norm() < 1e-12);
        assert!((c[1].mean_pressure - 50.0 / 3.0).abs() < 1e-5);
        assert_eq!(c[1].peak_pressure, 30.0);
    }

    #[test]
    fn a_contact_weighs_the_sum_of_its_taxels_forces_and_only_once_weighed() {
        let (p, f) = strip(10);
        let mut finder = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
        let mut pressure = vec![0.0f32; 20];
        pressure[0] = 10.0;
        pressure[1] = 30.0;
        pressure[14] = 100.0;
        let found = finder.find(&pressure, 5.0, 1).unwrap();
        assert!(
            found.iter().all(|c| c.force_n.is_none()),
            "no force before weighing"
        );
        let mut forces = vec![0.0; 20];
        forces[0] = 0.25;
        forces[1] = 0.5;
        forces[14] = 2.0;
        forces[9] = 7.0; // not in a contact
        let c = finder.weigh(&forces).unwrap();
        assert_eq!(c[0].force_n, Some(2.0));
        assert_eq!(c[1].force_n, Some(0.75));
        assert!(finder.weigh(&forces[..3]).is_err());
        // The next frame's contacts start unweighed.
        assert!(
            finder
                .find(&pressure, 5.0, 1)
                .unwrap()
                .iter()
                .all(|c| c.force_n.is_none())
        );
    }

    #[test]
    fn threshold_and_minimum_size_drop_noise() {
        let (p, f) = strip(10);
        let mut finder = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
        let mut pressure = vec![3.0f32; 20];
        pressure[9] = 50.0;
        assert_eq!(finder.find(&pressure, 5.0, 1).unwrap().len(), 1);
        assert_eq!(finder.find(&pressure, 5.0, 2).unwrap().len(), 0);
        assert_eq!(finder.find(&pressure, 2.0, 2).unwrap().len(), 1, "all 20 joined");
    }

    #[test]
    fn wrong_frame_length_and_bad_faces_are_errors() {
        let (p, f) = strip(3);
        let mut finder = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
        let e = finder.find(&[1.0; 5], 0.0, 1).unwrap_err().to_string();
        assert!(e.contains("5 readings") && e.contains("6 taxels"), "{e}");
        let e = ContactFinder::new(&p, &[], &[[0, 1, 9]], Path::new("m.json"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("m.json") && e.contains("face 0") && e.contains('9'),
            "{e}"
        );
    }

    /// A `cols` x `rows` grid of taxels `pitch` apart, triangulated.
    fn grid(cols: usize, rows: usize, pitch: f64) -> (Vec<Point3<f64>>, Vec<[usize; 3]>) {
        let p = (0..rows * cols)
            .map(|i| Point3::new((i % cols) as f64 * pitch, (i / cols) as f64 * pitch, 0.0))
            .collect();
        let mut f = Vec::new();
        for r in 0..rows - 1 {
            for c in 0..cols - 1 {
                let a = r * cols + c;
                f.push([a, a + 1, a + cols + 1]);
                f.push([a, a + cols + 1, a + cols]);
            }
        }
        (p, f)
    }

    /// Gaussian presses (centre x, y in metres, peak, sigma in metres) on the taxels at `p`.
    fn presses(p: &[Point3<f64>], presses: &[(f64, f64, f32, f64)]) -> Vec<f32> {
        p.iter()
            .map(|q| {
                presses
                    .iter()
                    .map(|&(x, y, peak, s)| {
                        let d2 = (q.x - x).powi(2) + (q.y - y).powi(2);
                        peak * (-d2 / (2.0 * s * s)).exp() as f32
                    })
                    .sum()
            })
            .collect()
    }

    #[test]
    fn two_fingertips_side_by_side_are_two_contacts_one_broad_press_is_one() {
        // 4 mm pitch; two fingertips (sigma 4 mm) 16 mm apart: closer than a finger is wide, one
        // connected patch, but the pressure falls to a quarter of the peaks between them.
        let (p, f) = grid(20, 12, 0.004);
        let two = presses(&p, &[(0.028, 0.020, 100.0, 0.004), (0.044, 0.020, 90.0, 0.004)]);
        let mut connected = ContactFinder::new(&p, &[], &f, Path::new("grid")).unwrap();
        assert_eq!(
            connected.find(&two, 5.0, 2).unwrap().len(),
            1,
            "one connected patch"
        );
        let mut split = ContactFinder::new(&p, &[], &f, Path::new("grid"))
            .unwrap()
            .with_separation(Separation::FINGERS);
        let c = split.find(&two, 5.0, 2).unwrap().to_vec();
        assert_eq!(c.len(), 2, "{c:?}");
        // Each centroid near its fingertip, the harder one first.
        assert!(
            (c[0].centroid - Point3::new(0.028, 0.020, 0.0)).norm() < 0.002,
            "{:?}",
            c[0].centroid
        );
        assert!(
            (c[1].centroid - Point3::new(0.044, 0.020, 0.0)).norm() < 0.002,
            "{:?}",
            c[1].centroid
        );
        // A hand's four fingertips in a row are four contacts: nothing caps the count.
        let four: Vec<(f64, f64, f32, f64)> = (0..4)
            .map(|k| (0.012 + 0.016 * k as f64, 0.020, 100.0 - 5.0 * k as f32, 0.004))
            .collect();
        let four = presses(&p, &four);
        assert_eq!(connected.find(&four, 5.0, 2).unwrap().len(), 1);
        assert_eq!(split.find(&four, 5.0, 2).unwrap().len(), 4);
        // One broad press (a palm, sigma 12 mm) and one fingertip alone stay one contact each.
        for one in [
            presses(&p, &[(0.036, 0.020, 100.0, 0.012)]),
            presses(&p, &[(0.036, 0.020, 100.0, 0.004)]),
        ] {
            assert_eq!(split.find(&one, 5.0, 2).unwrap().len(), 1);
        }
        // Two peaks closer than the minimum distance, or without a deep enough dip, are one.
        let near = presses(&p, &[(0.028, 0.020, 100.0, 0.002), (0.036, 0.020, 100.0, 0.002)]);
        assert_eq!(connected.find(&near, 5.0, 2).unwrap().len(), 1);
        assert_eq!(split.find(&near, 5.0, 2).unwrap().len(), 1, "8 mm apart");
        let shallow = presses(&p, &[(0.028, 0.020, 100.0, 0.006), (0.044, 0.020, 100.0, 0.006)]);
        assert_eq!(
            split.find(&shallow, 5.0, 2).unwrap().len(),
            1,
            "the pressure dips by less than half"
        );
    }

    proptest! {
        /// Split or not, every pressed taxel of a kept patch is in exactly one contact, each
        /// contact lies within one connected patch, and splitting never joins patches.
        #[test]
        fn split_contacts_partition_the_connected_patches(
            values in proptest::collection::vec(0.0f32..10.0, 40),
            threshold in 0.0f32..10.0,
            min_dip in 0.0f32..1.0,
            min_distance_m in 0.0f64..0.03,
        ) {
            let (p, f) = strip(20);
            let mut connected = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
            let mut split = ContactFinder::new(&p, &[], &f, Path::new("strip"))
                .unwrap()
                .with_separation(Separation::Peaks { min_dip, min_distance_m });
            let patches = connected.find(&values, threshold, 1).unwrap().to_vec();
            let parts = split.find(&values, threshold, 1).unwrap().to_vec();
            prop_assert!(parts.len() >= patches.len());
            let mut patch_of = vec![usize::MAX; 40];
            for (k, c) in patches.iter().enumerate() {
                for &i in &c.taxels {
                    patch_of[i] = k;
                }
            }
            let mut seen = [false; 40];
            for c in &parts {
                prop_assert!(!c.taxels.is_empty());
                let k = patch_of[c.taxels[0]];
                for &i in &c.taxels {
                    prop_assert!(!seen[i]);
                    seen[i] = true;
                    prop_assert_eq!(patch_of[i], k);
                }
            }
            prop_assert_eq!(seen.iter().filter(|&&s| s).count(), patch_of.iter().filter(|&&k| k != usize::MAX).count());
        }
    }

    proptest! {
        /// Every pressed taxel of a kept contact is above threshold, no taxel is in two
        /// contacts, and no mesh edge joins two different contacts.
        #[test]
        fn contacts_are_maximal_connected_components(
            values in proptest::collection::vec(0.0f32..10.0, 40),
            threshold in 0.0f32..10.0,
        ) {
            let (p, f) = strip(20);
            let mut finder = ContactFinder::new(&p, &[], &f, Path::new("strip")).unwrap();
            let contacts = finder.find(&values, threshold, 1).unwrap().to_vec();
            let mut owner = vec![usize::MAX; 40];
            for (k, c) in contacts.iter().enumerate() {
                for &i in &c.taxels {
                    prop_assert!(values[i] > threshold);
                    prop_assert_eq!(owner[i], usize::MAX);
                    owner[i] = k;
                }
            }
            let pressed = values.iter().filter(|&&v| v > threshold).count();
            prop_assert_eq!(owner.iter().filter(|&&o| o != usize::MAX).count(), pressed);
            for face in &f {
                for e in 0..3 {
                    let (a, b) = (face[e], face[(e + 1) % 3]);
                    if owner[a] != usize::MAX && owner[b] != usize::MAX {
                        prop_assert_eq!(owner[a], owner[b]);
                    }
                }
            }
        }
    }
}

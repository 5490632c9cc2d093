//! Force from counts: what a calibrated taxel's reading stands for in newtons, and the wrench a
//! link's taxels add up to.
//!
//! A taxel reading `c` counts above its baseline stands for the stress `s` under it through a
//! saturating response that the whole skin shares, scaled by the taxel's own gain `g_i` (a
//! capacitive cell stiffens as it is pressed, so equal steps of stress read ever smaller steps
//! of counts):
//!
//! ```text
//! c = g_i * C * s / (s + s_half)        C: full scale, counts; s_half: half-scale stress, kPa
//! s = s_half * c / (g_i * C - c)        (the inverse, used per frame)
//! f_i = s * A_i                         A_i: the skin area the taxel stands for, m²
//! ```
//!
//! `A_i` is a third of the area of every mesh triangle the taxel is a corner of (its barycentric
//! cell): the cells tile the mesh, so a uniform stress over a patch sums to stress times the
//! patch's area. Each taxel's force acts along its inward normal; a link's [`Wrench`] is their
//! sum and their moment about the link frame's origin (Ch. 8.2: a contact's equivalent force is
//! the sum of its taxels' forces).
//!
//! A reading at or past [`ForceModel::SATURATION`] of `g_i * C` is past what the curve can
//! invert well: it is taken at that fraction of full scale and counted as saturated, so a force
//! built on it is a lower bound ([`ForceModel::forces`] returns the count, and a session's
//! wrench carries it).
//!
//! ```
//! use skin_core::force::{ForceModel, ResponseCurve, taxel_areas};
//! use skin_core::nalgebra::Point3;
//!
//! // Two triangles making a 10 mm square: each corner stands for its share of 1 cm².
//! let points = [[0.0, 0.0], [0.01, 0.0], [0.01, 0.01], [0.0, 0.01]].map(|[x, y]| Point3::new(x, y, 0.0));
//! let areas = taxel_areas(&points, &[[0, 1, 2], [0, 2, 3]])?;
//! assert!((areas.iter().sum::<f64>() - 1e-4).abs() < 1e-12);
//!
//! // 10 kPa under every taxel is 1 N over the square.
//! let curve = ResponseCurve { full_scale: 4095.0, half_scale_kpa: 150.0 };
//! let model = ForceModel::new(curve, vec![1.0; 4], areas)?;
//! let counts = curve.counts(10.0, 1.0) as f32;
//! let mut forces = [0.0; 4];
//! let saturated = model.forces(&[counts; 4], &mut forces)?;
//! assert_eq!(saturated, 0);
//! assert!((forces.iter().sum::<f64>() - 1.0).abs() < 1e-3);
//! # Ok::<(), skin_core::force::ForceError>(())
//! ```

use nalgebra::{Point3, Vector3};

/// The response every taxel of a skin shares, before its own gain: `c = g * C * s / (s + s_half)`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseCurve {
    /// `C`: the counts a taxel of gain 1 nears under a load it cannot take.
    pub full_scale: f64,
    /// `s_half`: the stress at which a taxel of gain 1 reads half of full scale, kPa.
    pub half_scale_kpa: f64,
}

impl ResponseCurve {
    /// The counts above the baseline that a taxel of `gain` reads under `stress_kpa` (the forward
    /// model: a simulator's, or a test's).
    pub fn counts(&self, stress_kpa: f64, gain: f64) -> f64 {
        let s = stress_kpa.max(0.0);
        gain * self.full_scale * s / (s + self.half_scale_kpa)
    }

    /// The stress, kPa, under a taxel of `gain` reading `counts` above its baseline, and whether
    /// the reading was past what the curve inverts (then the stress at
    /// [`ForceModel::SATURATION`] of full scale: a lower bound).
    pub fn stress_kpa(&self, counts: f64, gain: f64) -> (f64, bool) {
        let top = gain * self.full_scale;
        let c = counts.max(0.0);
        let limit = ForceModel::SATURATION * top;
        let (c, saturated) = if c >= limit { (limit, true) } else { (c, false) };
        (self.half_scale_kpa * c / (top - c), saturated)
    }

    fn check(&self) -> Result<(), ForceError> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        match (ok(self.full_scale), ok(self.half_scale_kpa)) {
            (true, true) => Ok(()),
            (false, _) => Err(ForceError::Curve {
                field: "full_scale",
                value: self.full_scale,
            }),
            (true, false) => Err(ForceError::Curve {
                field: "half_scale_kpa",
                value: self.half_scale_kpa,
            }),
        }
    }
}

/// Why a force model, or the areas it is built on, was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ForceError {
    /// A field of the response curve that is not a positive, finite number.
    #[error("the response curve's {field} is {value}: it must be a positive number")]
    Curve {
        /// The field (`full_scale`, `half_scale_kpa`).
        field: &'static str,
        /// Its value.
        value: f64,
    },
    /// A taxel's gain that is not a positive, finite number, or an area that is negative or
    /// not finite.
    #[error("taxel {taxel} (layout index)'s {what} is {value}: {}", if *what == "area" { "it must be a finite number, 0 or more" } else { "it must be a positive number" })]
    Taxel {
        /// Layout index of the taxel.
        taxel: usize,
        /// `gain` or `area`.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Lists that should have one entry per taxel and do not.
    #[error("{what}: {got} given for {taxels} taxels")]
    Length {
        /// What was given (`gains`, `areas`, `pressures`, `forces`).
        what: &'static str,
        /// How many were given.
        got: usize,
        /// How many taxels the model has.
        taxels: usize,
    },
    /// A triangle naming a taxel the skin does not have.
    #[error("triangle {face} names taxel {taxel}; the skin has {taxels} taxels")]
    Face {
        /// The triangle's index.
        face: usize,
        /// The index it names.
        taxel: usize,
        /// How many taxels there are.
        taxels: usize,
    },
}

/// The skin area each taxel stands for, m²: a third of the area of every triangle of `faces`
/// it is a corner of. A taxel on no triangle (isolated in the mesh) gets 0: it adds no force.
pub fn taxel_areas(positions: &[Point3<f64>], faces: &[[usize; 3]]) -> Result<Vec<f64>, ForceError> {
    let n = positions.len();
    let mut areas = vec![0.0; n];
    for (f, face) in faces.iter().enumerate() {
        if let Some(&taxel) = face.iter().find(|&&v| v >= n) {
            return Err(ForceError::Face {
                face: f,
                taxel,
                taxels: n,
            });
        }
        let [a, b, c] = face.map(|v| positions[v]);
        let third = (b - a).cross(&(c - a)).norm() / 6.0;
        for &v in face {
            areas[v] += third;
        }
    }
    Ok(areas)
}

/// A link's force model: the shared [`ResponseCurve`], each taxel's gain and area. Built once;
/// [`ForceModel::forces`] then allocates nothing.
#[derive(Debug, Clone, PartialEq)]
pub struct ForceModel {
    curve: ResponseCurve,
    gains: Vec<f64>,
    areas: Vec<f64>,
}

impl ForceModel {
    /// The fraction of a taxel's full scale past which its reading is taken as saturated: the
    /// curve's inverse grows without bound as `c` nears `g * C`, where a count of noise would be
    /// a newton.
    pub const SATURATION: f64 = 0.95;

    /// A model of `gains.len()` taxels; every gain positive and every area (m²) 0 or more,
    /// all finite.
    pub fn new(curve: ResponseCurve, gains: Vec<f64>, areas: Vec<f64>) -> Result<ForceModel, ForceError> {
        curve.check()?;
        if areas.len() != gains.len() {
            return Err(ForceError::Length {
                what: "areas",
                got: areas.len(),
                taxels: gains.len(),
            });
        }
        for (what, values, least) in [("gain", &gains, f64::MIN_POSITIVE), ("area", &areas, 0.0)] {
            if let Some((taxel, &value)) = values
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v >= least))
            {
                return Err(ForceError::Taxel { taxel, what, value });
            }
        }
        Ok(ForceModel { curve, gains, areas })
    }

    /// The shared response curve.
    pub fn curve(&self) -> ResponseCurve {
        self.curve
    }

    /// Each taxel's gain, layout order.
    pub fn gains(&self) -> &[f64] {
        &self.gains
    }

    /// Each taxel's area, m², layout order.
    pub fn areas(&self) -> &[f64] {
        &self.areas
    }

    /// Taxels.
    pub fn len(&self) -> usize {
        self.gains.len()
    }

    /// Whether the model has no taxels.
    pub fn is_empty(&self) -> bool {
        self.gains.is_empty()
    }

    /// Taxel `i`'s force, N, reading `counts` above its baseline, and whether it saturated.
    pub fn force(&self, i: usize, counts: f64) -> (f64, bool) {
        let (s, saturated) = self.curve.stress_kpa(counts, self.gains[i]);
        (s * 1e3 * self.areas[i], saturated)
    }

    /// Every taxel's force, N, from its `pressures` (counts above the baseline, layout order)
    /// into `out`; the number of saturated taxels (their forces are lower bounds).
    pub fn forces(&self, pressures: &[f32], out: &mut [f64]) -> Result<usize, ForceError> {
        for (what, got) in [("pressures", pressures.len()), ("forces", out.len())] {
            if got != self.len() {
                return Err(ForceError::Length {
                    what,
                    got,
                    taxels: self.len(),
                });
            }
        }
        let mut saturated = 0;
        for (i, (&p, f)) in pressures.iter().zip(out.iter_mut()).enumerate() {
            let (force, sat) = self.force(i, f64::from(p));
            *f = force;
            saturated += usize::from(sat);
        }
        Ok(saturated)
    }
}

/// What a link's taxels press on it with, in the link's frame: newtons and newton-metres.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Wrench {
    /// Sum of the taxels' forces, each along its inward normal (the load on the link), N.
    pub force: Vector3<f64>,
    /// Their moment about the link frame's origin, N m.
    pub torque: Vector3<f64>,
    /// Force-weighted mean of the taxels' positions, metres; none with no force.
    pub cop: Option<Point3<f64>>,
    /// Sum of the taxels' force magnitudes, N (what a load cell under the skin reads for a load
    /// square to it).
    pub magnitude: f64,
}

impl Wrench {
    /// The wrench of taxels `which` (layout indices) at `positions` with outward `normals`,
    /// pressed with `forces` (N, layout order; see [`ForceModel::forces`]). An index past any
    /// of the lists is skipped.
    pub fn of_taxels(
        positions: &[Point3<f64>],
        normals: &[Vector3<f64>],
        forces: &[f64],
        which: impl IntoIterator<Item = usize>,
    ) -> Wrench {
        let mut w = Wrench::default();
        let mut weighted = Vector3::zeros();
        for i in which {
            let (Some(p), Some(n), Some(&f)) = (positions.get(i), normals.get(i), forces.get(i)) else {
                continue;
            };
            let load = -n * f;
            w.force += load;
            w.torque += p.coords.cross(&load);
            weighted += p.coords * f;
            w.magnitude += f;
        }
        if w.magnitude > 0.0 {
            w.cop = Some(Point3::from(weighted / w.magnitude));
        }
        w
    }
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)] // a failed set-up should stop the test
    use super::*;
    use proptest::prelude::*;

    const CURVE: ResponseCurve = ResponseCurve {
        full_scale: 4095.0,
        half_scale_kpa: 150.0,
    };

    /// A flat grid of `n x n` taxels `pitch` apart in z = 0, normals +z, two triangles a cell.
    fn grid(n: usize, pitch: f64) -> (Vec<Point3<f64>>, Vec<[usize; 3]>) {
        let points = (0..n * n)
            .map(|i| Point3::new((i % n) as f64 * pitch, (i / n) as f64 * pitch, 0.0))
            .collect();
        let mut faces = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                let i = r * n + c;
                faces.push([i, i + 1, i + n + 1]);
                faces.push([i, i + n + 1, i + n]);
            }
        }
        (points, faces)
    }

    #[test]
    fn the_cells_tile_the_mesh() {
        let (points, faces) = grid(10, 0.005);
        let areas = taxel_areas(&points, &faces).unwrap();
        // 9 x 9 cells of 5 mm: 2025 mm².
        assert!((areas.iter().sum::<f64>() - 81.0 * 25e-6).abs() < 1e-12);
        // An inner taxel stands for one whole cell, a corner with two triangles for a third.
        assert!((areas[55] - 25e-6).abs() < 1e-15);
        assert!((areas[0] - 25e-6 / 3.0).abs() < 1e-15);
        assert!(matches!(
            taxel_areas(&points, &[[0, 1, 100]]),
            Err(ForceError::Face { taxel: 100, .. })
        ));
    }

    #[test]
    fn half_scale_reads_half_the_gain_and_saturation_is_a_lower_bound() {
        assert!((CURVE.counts(150.0, 1.0) - 2047.5).abs() < 1e-9);
        assert!((CURVE.counts(150.0, 0.8) - 1638.0).abs() < 1e-9);
        assert_eq!(CURVE.stress_kpa(0.0, 1.0), (0.0, false));
        let (s, sat) = CURVE.stress_kpa(4095.0, 1.0);
        assert!(sat && (s - 150.0 * 0.95 / 0.05).abs() < 1e-9, "{s}");
        let (s, sat) = CURVE.stress_kpa(-5.0, 1.0);
        assert_eq!((s, sat), (0.0, false), "below the baseline is no load");
    }

    #[test]
    fn a_uniform_load_sums_to_stress_times_area() {
        let (points, faces) = grid(8, 0.004);
        let areas = taxel_areas(&points, &faces).unwrap();
        let gains: Vec<f64> = (0..64).map(|i| 0.85 + 0.3 * (i as f64 / 63.0)).collect();
        let model = ForceModel::new(CURVE, gains.clone(), areas.clone()).unwrap();
        let stress = 40.0; // kPa
        let counts: Vec<f32> = gains.iter().map(|&g| CURVE.counts(stress, g) as f32).collect();
        let mut forces = vec![0.0; 64];
        assert_eq!(model.forces(&counts, &mut forces).unwrap(), 0);
        let total: f64 = forces.iter().sum();
        let expected = stress * 1e3 * areas.iter().sum::<f64>();
        assert!(
            (total - expected).abs() < 1e-4 * expected,
            "{total} vs {expected}"
        );
    }

    #[test]
    fn the_wrench_is_force_times_lever_arm() {
        // 2 N pressing down on a taxel at (0.1, 0, 0) with normal +z: the load is -2 z, and its
        // moment about the origin is r x F = (0.1, 0, 0) x (0, 0, -2) = (0, 0.2, 0).
        let positions = [Point3::new(0.1, 0.0, 0.0), Point3::new(0.0, 0.1, 0.0)];
        let normals = [Vector3::z(), Vector3::z()];
        let w = Wrench::of_taxels(&positions, &normals, &[2.0, 0.0], 0..2);
        assert!((w.force - Vector3::new(0.0, 0.0, -2.0)).norm() < 1e-12);
        assert!((w.torque - Vector3::new(0.0, 0.2, 0.0)).norm() < 1e-12);
        assert_eq!(w.cop, Some(positions[0]));
        assert_eq!(
            Wrench::of_taxels(&positions, &normals, &[0.0, 0.0], 0..2).cop,
            None
        );
        assert_eq!(
            Wrench::of_taxels(&positions, &normals, &[1.0], 5..9),
            Wrench::default()
        );
    }

    #[test]
    fn bad_models_are_named() {
        let bad_curve = ResponseCurve {
            half_scale_kpa: f64::NAN,
            ..CURVE
        };
        assert!(matches!(
            ForceModel::new(bad_curve, vec![1.0], vec![1.0]),
            Err(ForceError::Curve {
                field: "half_scale_kpa",
                ..
            })
        ));
        let e = ForceModel::new(CURVE, vec![1.0, 1.0], vec![1.0, -1.0]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "taxel 1 (layout index)'s area is -1: it must be a finite number, 0 or more"
        );
        let isolated = ForceModel::new(CURVE, vec![1.0, 1.0], vec![1e-5, 0.0]).unwrap();
        assert_eq!(isolated.force(1, 1000.0).0, 0.0);
        let e = ForceModel::new(CURVE, vec![1.0, -1.0], vec![1.0, 1.0]).unwrap_err();
        assert!(matches!(
            e,
            ForceError::Taxel {
                taxel: 1,
                what: "gain",
                ..
            }
        ));
        let model = ForceModel::new(CURVE, vec![1.0; 2], vec![1e-5; 2]).unwrap();
        assert!(matches!(
            model.forces(&[1.0], &mut [0.0; 2]),
            Err(ForceError::Length {
                what: "pressures",
                got: 1,
                taxels: 2
            })
        ));
    }

    proptest! {
        /// The inverse undoes the forward model below saturation, for every gain.
        #[test]
        fn stress_round_trips(stress in 0.0f64..2000.0, gain in 0.1f64..3.0) {
            let (back, saturated) = CURVE.stress_kpa(CURVE.counts(stress, gain), gain);
            prop_assume!(!saturated);
            prop_assert!((back - stress).abs() <= 1e-9 * (1.0 + stress), "{back} vs {stress}");
        }

        /// Forces are never negative, never NaN, whatever the counts (a NaN reads as no load).
        #[test]
        fn forces_are_finite_and_non_negative(counts in proptest::collection::vec(any::<f32>(), 4)) {
            let model = ForceModel::new(CURVE, vec![1.0; 4], vec![1e-5; 4]).unwrap();
            let mut out = [0.0; 4];
            model.forces(&counts, &mut out).unwrap();
            prop_assert!(out.iter().all(|f| f.is_finite() && *f >= 0.0), "{out:?}");
        }
    }
}

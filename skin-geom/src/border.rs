//! Where a tactile map's skin ends: each taxel's distance from the border, for rules that treat
//! a touch cut by the edge of the skin differently (an object overhanging the edge leaves only
//! part of its print, so its image is less certain).

use crate::TactileMap;
use nalgebra::Point2;
use std::collections::HashMap;

impl TactileMap {
    /// Each taxel's distance from the skin's border on the map, metres: from the nearest edge of
    /// the triangulation that bounds one triangle only (the outline, and the rim of any hole).
    /// A taxel on the border is 0 from it; a taxel in no triangle, off the imaged skin, is 0 too.
    /// Computed once (every taxel against every border edge), not per frame.
    ///
    /// ```
    /// use nalgebra::Point2;
    /// use skin_core::TaxelId;
    /// use skin_geom::{FlattenReport, TactileMap};
    /// // A 2 x 2 cm square of four triangles around a centre taxel.
    /// let map = TactileMap {
    ///     name: "patch".into(),
    ///     ids: (0..5).map(TaxelId).collect(),
    ///     positions: Vec::new(),
    ///     points: vec![
    ///         Point2::new(0.0, 0.0), Point2::new(0.02, 0.0), Point2::new(0.02, 0.02),
    ///         Point2::new(0.0, 0.02), Point2::new(0.01, 0.01),
    ///     ],
    ///     faces: vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
    ///     report: FlattenReport::default(),
    ///     zeroed: Vec::new(),
    /// };
    /// let d = map.border_distances();
    /// assert_eq!(d[0], 0.0); // a corner
    /// assert!((d[4] - 0.01).abs() < 1e-12); // the centre: 1 cm from each side
    /// ```
    pub fn border_distances(&self) -> Vec<f64> {
        let mut count: HashMap<(usize, usize), u32> = HashMap::new();
        for f in &self.faces {
            for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
                *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let border: Vec<(Point2<f64>, Point2<f64>)> = count
            .into_iter()
            .filter(|&(_, n)| n == 1)
            .filter_map(|((a, b), _)| Some((*self.points.get(a)?, *self.points.get(b)?)))
            .collect();
        let mut in_face = vec![false; self.points.len()];
        for f in &self.faces {
            for &t in f {
                if let Some(x) = in_face.get_mut(t) {
                    *x = true;
                }
            }
        }
        self.points
            .iter()
            .zip(&in_face)
            .map(|(p, &inside)| {
                if !inside {
                    return 0.0;
                }
                border
                    .iter()
                    .map(|&(a, b)| segment_distance(*p, a, b))
                    .fold(f64::INFINITY, f64::min)
            })
            .map(|d| if d.is_finite() { d } else { 0.0 })
            .collect()
    }
}

/// Distance from `p` to the segment `a`-`b`.
fn segment_distance(p: Point2<f64>, a: Point2<f64>, b: Point2<f64>) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(&ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `n` x `n` taxels `step` apart, two triangles a cell, without the cells listed in
    /// `holes` (row, column of their lower-left corner).
    fn grid(n: usize, step: f64, holes: &[(usize, usize)]) -> TactileMap {
        let points = (0..n * n)
            .map(|i| Point2::new((i % n) as f64 * step, (i / n) as f64 * step))
            .collect();
        let mut faces = Vec::new();
        for r in 0..n - 1 {
            for c in 0..n - 1 {
                if holes.contains(&(r, c)) {
                    continue;
                }
                let i = r * n + c;
                faces.push([i, i + 1, i + n + 1]);
                faces.push([i, i + n + 1, i + n]);
            }
        }
        map(points, faces)
    }

    fn map(points: Vec<Point2<f64>>, faces: Vec<[usize; 3]>) -> TactileMap {
        TactileMap {
            name: "grid".into(),
            ids: (0..points.len() as u32).map(skin_core::TaxelId).collect(),
            positions: Vec::new(),
            points,
            faces,
            report: crate::FlattenReport::default(),
            zeroed: Vec::new(),
        }
    }

    #[test]
    fn on_a_square_grid_the_distance_is_the_way_to_the_nearest_side() {
        let (n, step) = (9, 0.01);
        let d = grid(n, step, &[]).border_distances();
        for (i, &di) in d.iter().enumerate() {
            let (r, c) = (i / n, i % n);
            let want = r.min(c).min(n - 1 - r).min(n - 1 - c) as f64 * step;
            assert!((di - want).abs() < 1e-12, "taxel ({r}, {c}): {di} against {want}");
        }
    }

    #[test]
    fn a_hole_in_the_skin_is_a_border_too() {
        // The centre cell of a 9 x 9 grid missing: its four corners are on a border.
        let d = grid(9, 0.01, &[(4, 4)]).border_distances();
        for i in [4 * 9 + 4, 4 * 9 + 5, 5 * 9 + 4, 5 * 9 + 5] {
            assert_eq!(d[i], 0.0, "taxel {i}");
        }
        // Without the hole they were 4 cells from the outline.
        assert!((grid(9, 0.01, &[]).border_distances()[4 * 9 + 4] - 0.04).abs() < 1e-12);
    }

    #[test]
    fn a_taxel_in_no_triangle_is_off_the_imaged_skin() {
        let mut lone = grid(3, 0.01, &[]);
        lone.points.push(Point2::new(0.5, 0.5));
        assert_eq!(lone.border_distances()[9], 0.0);
        assert_eq!(map(Vec::new(), Vec::new()).border_distances(), Vec::<f64>::new());
    }
}

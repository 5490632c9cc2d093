//! Normals for taxels whose file gives none (iCub `*_nomesh.txt` positions with all-zero
//! normals): each estimated from the surface its neighbours span, then oriented consistently.
//!
//! The surface normal at a taxel is the direction of least spread of its `K` nearest
//! neighbours (the smallest principal axis of their scatter; Hoppe et al., "Surface
//! reconstruction from unorganized points", 1992). Its sign is free: a neighbour whose normal
//! the file gives fixes it (the sum of the given normals around), and where none is given the
//! sign travels from taxel to neighbouring taxel (breadth first over the neighbour graph,
//! flipping each to agree with the one it was reached from), starting in each connected piece
//! from the taxel farthest from the cloud's centre, oriented away from it: outward on a link
//! that is convex seen from its axis, as skin is.

use nalgebra::{Matrix3, Point3, SymmetricEigen, Unit, Vector3};
use std::collections::VecDeque;

/// Neighbours a normal is estimated from.
const K: usize = 8;

/// The normals of `positions`, where `given[i]` is the file's normal of taxel `i` (kept as it
/// is) or `None` (estimated). `given` shorter than `positions` counts as `None` beyond its end.
pub fn estimate_normals(
    positions: &[Point3<f64>],
    given: &[Option<Unit<Vector3<f64>>>],
) -> Vec<Unit<Vector3<f64>>> {
    let n = positions.len();
    let known = |i: usize| given.get(i).copied().flatten();
    let neighbours: Vec<Vec<usize>> = (0..n).map(|i| nearest(positions, i)).collect();
    let centre = Point3::from(positions.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n.max(1) as f64);
    // Unsigned directions first.
    let mut normals: Vec<Vector3<f64>> = (0..n)
        .map(|i| match known(i) {
            Some(g) => g.into_inner(),
            None => least_spread(positions, i, &neighbours[i]).unwrap_or_else(|| away(positions[i], centre)),
        })
        .collect();
    // Signs from given neighbours where there are some.
    let mut fixed: Vec<bool> = (0..n).map(|i| known(i).is_some()).collect();
    for i in 0..n {
        if fixed[i] {
            continue;
        }
        let around: Vector3<f64> = neighbours[i]
            .iter()
            .filter_map(|&j| known(j))
            .map(|g| g.into_inner())
            .sum();
        if around.norm() > 0.0 {
            if normals[i].dot(&around) < 0.0 {
                normals[i] = -normals[i];
            }
            fixed[i] = true;
        }
    }
    // The rest from neighbour to neighbour, over a symmetric neighbour graph.
    let mut graph: Vec<Vec<usize>> = neighbours.clone();
    for (i, ns) in neighbours.iter().enumerate() {
        for &j in ns {
            graph[j].push(i);
        }
    }
    let mut queue = VecDeque::new();
    loop {
        // Each piece starts from its fixed taxels, or from its farthest taxel, turned outward.
        queue.extend((0..n).filter(|&i| fixed[i] && graph[i].iter().any(|&j| !fixed[j])));
        if queue.is_empty() {
            let Some(seed) = (0..n).filter(|&i| !fixed[i]).max_by(|&a, &b| {
                (positions[a] - centre)
                    .norm()
                    .total_cmp(&(positions[b] - centre).norm())
            }) else {
                break;
            };
            if normals[seed].dot(&(positions[seed] - centre)) < 0.0 {
                normals[seed] = -normals[seed];
            }
            fixed[seed] = true;
            queue.push_back(seed);
        }
        while let Some(i) = queue.pop_front() {
            for &j in &graph[i] {
                if !fixed[j] {
                    if normals[j].dot(&normals[i]) < 0.0 {
                        normals[j] = -normals[j];
                    }
                    fixed[j] = true;
                    queue.push_back(j);
                }
            }
        }
    }
    normals
        .into_iter()
        .enumerate()
        .map(|(i, v)| {
            known(i).unwrap_or_else(|| Unit::try_new(v, 1e-12).unwrap_or(Unit::new_unchecked(Vector3::z())))
        })
        .collect()
}

/// The `K` nearest other taxels of taxel `i` (fewer in a smaller cloud).
fn nearest(positions: &[Point3<f64>], i: usize) -> Vec<usize> {
    let mut d: Vec<(f64, usize)> = positions
        .iter()
        .enumerate()
        .filter(|&(j, _)| j != i)
        .map(|(j, p)| ((p - positions[i]).norm_squared(), j))
        .collect();
    let k = K.min(d.len());
    if k < d.len() {
        d.select_nth_unstable_by(k, |a, b| a.0.total_cmp(&b.0));
    }
    d.truncate(k);
    d.into_iter().map(|(_, j)| j).collect()
}

/// The direction of least spread of taxel `i` and its neighbours; `None` where they span no
/// surface (fewer than three, or all on one line).
fn least_spread(positions: &[Point3<f64>], i: usize, neighbours: &[usize]) -> Option<Vector3<f64>> {
    let pts: Vec<Point3<f64>> = std::iter::once(i)
        .chain(neighbours.iter().copied())
        .map(|j| positions[j])
        .collect();
    if pts.len() < 3 {
        return None;
    }
    let mean = pts.iter().map(|p| p.coords).sum::<Vector3<f64>>() / pts.len() as f64;
    let mut cov = Matrix3::zeros();
    for p in &pts {
        let d = p.coords - mean;
        cov += d * d.transpose();
    }
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    // A line has two vanishing spreads: its normal is not determined.
    if eig.eigenvalues[order[1]] <= 1e-12 * eig.eigenvalues[order[2]].max(f64::MIN_POSITIVE) {
        return None;
    }
    Some(eig.eigenvectors.column(order[0]).into_owned())
}

/// The unit direction from `centre` to `p` (z where they coincide).
fn away(p: Point3<f64>, centre: Point3<f64>) -> Vector3<f64> {
    (p - centre).try_normalize(1e-12).unwrap_or(Vector3::z())
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // a failed set-up should stop the test
    use super::*;

    /// Taxels on a half cylinder (radius 40 mm, axis x), 8 mm apart.
    fn half_cylinder() -> (Vec<Point3<f64>>, Vec<Vector3<f64>>) {
        let (mut p, mut n) = (Vec::new(), Vec::new());
        for i in 0..20 {
            for k in 0..16 {
                let a = std::f64::consts::PI * k as f64 / 15.0;
                let (y, z) = (a.cos(), a.sin());
                p.push(Point3::new(i as f64 * 0.008, 0.04 * y, 0.04 * z));
                n.push(Vector3::new(0.0, y, z));
            }
        }
        (p, n)
    }

    #[test]
    fn normals_of_a_half_cylinder_come_back_outward_from_positions_alone() {
        let (p, truth) = half_cylinder();
        let est = estimate_normals(&p, &[]);
        let angles: Vec<f64> = est
            .iter()
            .zip(&truth)
            .map(|(e, t)| e.dot(t).clamp(-1.0, 1.0).acos().to_degrees())
            .collect();
        let worst = angles.iter().fold(0.0f64, |m, &a| m.max(a));
        let mean = angles.iter().sum::<f64>() / angles.len() as f64;
        // Every one outward; a border taxel's neighbours lie on one side, which tilts it.
        assert!(
            worst < 15.0 && mean < 4.0,
            "angle to the true outward normal: worst {worst:.1} deg, mean {mean:.2} deg"
        );
    }

    #[test]
    fn a_given_neighbour_fixes_the_sign_and_given_normals_are_kept() {
        // A flat patch whose given normals point down (-z): the estimated ones follow them.
        let p: Vec<Point3<f64>> = (0..36)
            .map(|i| Point3::new((i % 6) as f64 * 0.01, (i / 6) as f64 * 0.01, 0.0))
            .collect();
        let down = Unit::new_normalize(-Vector3::z());
        let given: Vec<_> = (0..36).map(|i| (i % 5 == 0).then_some(down)).collect();
        let est = estimate_normals(&p, &given);
        assert!(est.iter().all(|n| n.dot(&down) > 0.999), "{est:?}");
        let tilted = Unit::new_normalize(Vector3::new(1.0, 0.0, -1.0));
        let mut given = given;
        given[0] = Some(tilted);
        assert_eq!(estimate_normals(&p, &given)[0], tilted);
    }

    #[test]
    fn degenerate_clouds_give_unit_normals_without_panic() {
        for p in [
            vec![],
            vec![Point3::origin()],
            vec![Point3::origin(); 4],
            (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect(),
        ] {
            let est = estimate_normals(&p, &[]);
            assert_eq!(est.len(), p.len());
            assert!(
                est.iter()
                    .all(|n| (n.norm() - 1.0).abs() < 1e-9 && n.iter().all(|v| v.is_finite()))
            );
        }
    }
}

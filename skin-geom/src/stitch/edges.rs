//! Eq. 6.1-6.2: the cross-boundary Delaunay triangulation of a joint region, its edges joining
//! the two links with their 3D lengths, and its bridge triangles.

use super::joint_chart::unwrap_angles;
use super::{BridgeTriangle, Stitcher};
use crate::chart::Chart;
use crate::triangulate::delaunay;
use crate::{Error, Result};
use nalgebra::{Isometry3, Point2};

impl Stitcher {
    /// Eq. 6.1-6.2 for joint `j`: edges (parent boundary index, child boundary index, 3D length)
    /// of the cross-boundary Delaunay triangulation, at most `max_edge` long.
    pub(super) fn edges(&mut self, j: usize, to_parent: &Isometry3<f64>) -> Result<Vec<(usize, usize, f64)>> {
        let joint = &self.joints[j];
        let (parent_map, child_map) = (&self.maps[j], &self.maps[j + 1]);
        self.world.clear();
        self.world
            .extend(joint.parent.iter().map(|&i| parent_map.positions[i]));
        self.world
            .extend(joint.child.iter().map(|&i| to_parent * child_map.positions[i]));
        let chart = joint.chart;
        self.chart_points.clear();
        self.chart_points
            .extend(self.world.iter().map(|p| chart.project(p)));
        if let Chart::Cylinder { radius, .. } = chart.chart {
            unwrap_angles(&mut self.chart_points, radius);
        }
        let triangles = cross_delaunay(&self.chart_points)?;
        let np = joint.parent.len();
        let max_edge = self.options.max_edge;
        let corner = |v: usize| {
            if v < np {
                (j, joint.parent[v])
            } else {
                (j + 1, joint.child[v - np])
            }
        };
        let bridges: Vec<BridgeTriangle> = triangles
            .iter()
            .filter(|t| {
                let mixed = t.iter().any(|&v| v < np) && t.iter().any(|&v| v >= np);
                mixed && (0..3).all(|k| (self.world[t[k]] - self.world[t[(k + 1) % 3]]).norm() <= max_edge)
            })
            .map(|t| BridgeTriangle::new(t.map(corner)))
            .collect();
        // Each cross edge, once (an inner edge belongs to two triangles).
        let mut pairs: Vec<(usize, usize)> = triangles
            .iter()
            .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .filter(|&(a, b)| a < np && b >= np)
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        let edges: Vec<(usize, usize, f64)> = pairs
            .into_iter()
            .map(|(a, b)| (a, b - np, (self.world[a] - self.world[b]).norm()))
            .filter(|e| e.2 <= max_edge)
            .collect();
        self.joints[j].bridges = bridges;
        Ok(edges)
    }
}

/// Delaunay triangles of the joint region: spade's bulk loading (several times faster than
/// inserting point by point, which the set-up of a map can afford but a control cycle cannot),
/// keeping the input order; points that coincide fall back to incremental insertion, which
/// merges them.
fn cross_delaunay(points: &[Point2<f64>]) -> Result<Vec<[usize; 3]>> {
    use spade::{DelaunayTriangulation, Triangulation};
    let vertices: Vec<spade::Point2<f64>> = points.iter().map(|p| spade::Point2::new(p.x, p.y)).collect();
    let tri = DelaunayTriangulation::<spade::Point2<f64>>::bulk_load_stable(vertices)
        .map_err(|e| Error::TooFewTaxels(format!("joint region cannot be triangulated: {e:?}")))?;
    if tri.num_vertices() < points.len() {
        return delaunay(points);
    }
    Ok(tri
        .inner_faces()
        .map(|f| f.vertices().map(|v| v.fix().index()))
        .collect())
}

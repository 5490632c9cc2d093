//! Delaunay triangulation of a taxel cloud in its chart (spade), and removal of the triangles that
//! do not lie on the skin: those bridging holes and the slivers of the outer concavity.

use crate::{Error, Result};
use nalgebra::{Point2, Point3, Unit, Vector3};
use spade::{DelaunayTriangulation, Triangulation};
use std::collections::HashMap;

/// Delaunay triangles of 2D points, counter-clockwise, as indices into `points`.
pub(crate) fn delaunay(points: &[Point2<f64>]) -> Result<Vec<[usize; 3]>> {
    let mut tri: DelaunayTriangulation<spade::Point2<f64>> = DelaunayTriangulation::new();
    let mut vertex_of_handle: Vec<usize> = Vec::with_capacity(points.len());
    for (i, p) in points.iter().enumerate() {
        let handle = tri
            .insert(spade::Point2::new(p.x, p.y))
            .map_err(|e| Error::TooFewTaxels(format!("vertex {i} cannot be triangulated: {e:?}")))?;
        // Points that coincide in the chart come back with the earlier handle: keep the first.
        if handle.index() == vertex_of_handle.len() {
            vertex_of_handle.push(i);
        }
    }
    Ok(tri
        .inner_faces()
        .map(|f| f.vertices().map(|v| vertex_of_handle[v.fix().index()]))
        .collect())
}

/// What [`prune`] removes (the fields of `MeshOptions` of the same names).
pub(crate) struct PruneLimits {
    /// A triangle tilted further than this from the normals at its corners, degrees.
    pub max_normal_deviation_deg: f64,
    /// An edge longer than this many local taxel pitches bridges a gap.
    pub max_edge_pitches: f64,
    /// A border triangle with a smaller angle than this is a sliver, degrees.
    pub min_border_angle_deg: f64,
}

/// Removes from `faces` (triangles over `vertices`, metres) the triangles that cut across the
/// surface, those bridging gaps (an edge longer than `max_edge_pitches` times the local taxel
/// pitch), then peels border slivers (an angle under `min_border_angle_deg`) until none is left.
/// Returns how many triangles were removed.
pub(crate) fn prune(
    vertices: &[Point3<f64>],
    faces: &mut Vec<[usize; 3]>,
    normals: &[Unit<Vector3<f64>>],
    options: &PruneLimits,
) -> usize {
    let before = faces.len();
    // A triangle whose plane is far from the skin's normals at its corners cuts across the
    // surface (over a fold or an edge of the link) instead of lying on it.
    let cos_max = options.max_normal_deviation_deg.to_radians().cos();
    let vs = vertices;
    faces.retain(|f| {
        let n = (vs[f[1]] - vs[f[0]]).cross(&(vs[f[2]] - vs[f[0]]));
        let m = normals[f[0]].into_inner() + normals[f[1]].into_inner() + normals[f[2]].into_inner();
        n.dot(&m).abs() >= cos_max * n.norm() * m.norm()
    });
    let v = vertices;
    let len = |a: usize, b: usize| (v[a] - v[b]).norm();
    // Local pitch: distance to the nearest neighbour along a Delaunay edge (the Delaunay graph
    // contains the nearest-neighbour graph).
    let mut pitch = vec![f64::INFINITY; v.len()];
    for f in faces.iter() {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            let l = len(a, b);
            pitch[a] = pitch[a].min(l);
            pitch[b] = pitch[b].min(l);
        }
    }
    faces.retain(|f| {
        let local = f.iter().map(|&i| pitch[i]).fold(0.0, f64::max);
        let longest = len(f[0], f[1]).max(len(f[1], f[2])).max(len(f[2], f[0]));
        longest <= options.max_edge_pitches * local
    });

    let min_angle = options.min_border_angle_deg.to_radians();
    loop {
        let mut edge_count: HashMap<(usize, usize), u8> = HashMap::with_capacity(faces.len() * 2);
        for f in faces.iter() {
            for k in 0..3 {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                *edge_count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let on_border = |f: &[usize; 3]| {
            (0..3).any(|k| {
                let (a, b) = (f[k], f[(k + 1) % 3]);
                edge_count.get(&(a.min(b), a.max(b))) == Some(&1)
            })
        };
        let n = faces.len();
        faces.retain(|f| !(on_border(f) && smallest_angle(vertices, f) < min_angle));
        if faces.len() == n {
            break;
        }
    }
    before - faces.len()
}

fn smallest_angle(v: &[Point3<f64>], f: &[usize; 3]) -> f64 {
    (0..3)
        .map(|k| {
            let p = v[f[k]];
            let a = v[f[(k + 1) % 3]] - p;
            let b = v[f[(k + 2) % 3]] - p;
            a.angle(&b)
        })
        .fold(f64::INFINITY, f64::min)
}

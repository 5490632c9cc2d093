//! Flattening a link's mesh into its tactile map with LSCM (thesis Ch. 3.2), piece by piece:
//! each edge-connected piece oriented, pinned at its two farthest boundary vertices, solved,
//! scaled to its 3D area and laid beside the previous one; taxels in no triangle extrapolated.

use crate::distortion::DistortionReport;
use crate::flatten::Lscm;
use crate::mesh::SkinMesh;
use crate::tactile_map::{FlattenOptions, FlattenReport, TactileMap};
use crate::{Error, Result};
use nalgebra::{Matrix2, Point2, Point3, Rotation2, Vector2, Vector3};
use skin_core::{LinkSkin, TaxelId};
use std::collections::HashMap;

impl TactileMap {
    /// Builds the mesh of `link` and flattens it with LSCM.
    pub fn flatten(link: &LinkSkin, options: &FlattenOptions) -> Result<TactileMap> {
        let mesh = SkinMesh::build(link, &options.mesh)?;
        Self::from_mesh(&link.name, &mesh)
    }

    /// Flattens a prepared mesh with LSCM, piece by piece.
    pub fn from_mesh(name: &str, sm: &SkinMesh) -> Result<TactileMap> {
        let verts = &sm.mesh.vertices;
        let nv = verts.len();
        let (pieces, faces, pinch_faces) = pieces(&sm.mesh.faces, nv);
        if pieces.is_empty() {
            return Err(Error::TooFewTaxels("the mesh has no triangle".into()));
        }
        let (uv, out_faces) = flatten_pieces(sm, &pieces, &faces)?;
        let vertex_uv = extend_to_isolated(verts, uv, &out_faces)?;
        let distortion = DistortionReport::measure(verts, &vertex_uv, &out_faces);
        let points: Vec<Point2<f64>> = sm.taxel_vertex.iter().map(|&v| vertex_uv[v]).collect();
        let positions: Vec<Point3<f64>> = sm.taxel_vertex.iter().map(|&v| verts[v]).collect();
        Ok(TactileMap {
            name: name.to_string(),
            ids: sm.ids.clone(),
            positions,
            points,
            faces: out_faces.iter().map(|f| f.map(|v| sm.vertex_taxel[v])).collect(),
            report: FlattenReport {
                source: Some(sm.source),
                mesh: sm.report.clone(),
                components: pieces.len(),
                pinch_faces,
                distortion,
            },
            zeroed: Vec::new(),
        })
    }
}

/// Edge-connected pieces of a mesh. A vertex where pieces touch (a pinch) is kept by the piece
/// with the most triangles around it; the other pieces' triangles at that vertex are dropped, since
/// a piece hinged on one vertex has no unique flattening. Returns the pieces (largest first), the
/// remaining faces and the number of dropped triangles.
fn pieces(faces: &[[usize; 3]], nv: usize) -> (Vec<Vec<usize>>, Vec<[usize; 3]>, usize) {
    let mut faces = faces.to_vec();
    let mut dropped = 0;
    loop {
        let comp = edge_components(&faces);
        let ncomp = comp.iter().copied().max().map_or(0, |m| m + 1);
        // For each vertex, triangles per piece.
        let mut count: HashMap<(usize, usize), usize> = HashMap::new();
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                *count.entry((v, comp[f])).or_default() += 1;
            }
        }
        let mut owner: Vec<Option<(usize, usize)>> = vec![None; nv];
        let mut keys: Vec<_> = count.iter().collect();
        keys.sort();
        for (&(v, c), &n) in keys {
            match owner[v] {
                Some((_, m)) if m >= n => {}
                _ => owner[v] = Some((c, n)),
            }
        }
        let before = faces.len();
        let keep: Vec<bool> = faces
            .iter()
            .enumerate()
            .map(|(f, face)| face.iter().all(|&v| owner[v].is_none_or(|(c, _)| c == comp[f])))
            .collect();
        if keep.iter().all(|&k| k) {
            let mut groups: Vec<Vec<usize>> = vec![Vec::new(); ncomp];
            for (f, &c) in comp.iter().enumerate() {
                groups[c].push(f);
            }
            groups.sort_by(|a, b| b.len().cmp(&a.len()).then(a[0].cmp(&b[0])));
            return (groups, faces, dropped);
        }
        let mut k = keep.iter();
        faces.retain(|_| *k.next().unwrap_or(&true));
        dropped += before - faces.len();
    }
}

/// Piece number of each face (faces sharing an edge are in one piece), numbered from 0.
fn edge_components(faces: &[[usize; 3]]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..faces.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    let mut first: HashMap<(usize, usize), usize> = HashMap::with_capacity(faces.len() * 2);
    for (f, face) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            match first.entry((a.min(b), a.max(b))) {
                std::collections::hash_map::Entry::Occupied(e) => {
                    let (ra, rb) = (find(&mut parent, *e.get()), find(&mut parent, f));
                    parent[ra.max(rb)] = ra.min(rb);
                }
                std::collections::hash_map::Entry::Vacant(e) => {
                    e.insert(f);
                }
            }
        }
    }
    let mut label = HashMap::new();
    (0..faces.len())
        .map(|f| {
            let r = find(&mut parent, f);
            let next = label.len();
            *label.entry(r).or_insert(next)
        })
        .collect()
}

fn reindex(faces: &[[usize; 3]]) -> (Vec<[usize; 3]>, Vec<usize>) {
    let mut local: HashMap<usize, usize> = HashMap::new();
    let mut global = Vec::new();
    let faces = faces
        .iter()
        .map(|f| {
            f.map(|v| {
                *local.entry(v).or_insert_with(|| {
                    global.push(v);
                    global.len() - 1
                })
            })
        })
        .collect();
    (faces, global)
}

/// Winds all triangles of a piece the same way (neighbours traverse their shared edge in opposite
/// directions), outward as the taxel normals say.
fn orient(
    faces: &[[usize; 3]],
    verts: &[Point3<f64>],
    normals: &[Vector3<f64>],
    global: &[usize],
    ids: &[TaxelId],
    vertex_taxel: &[usize],
) -> Result<Vec<[usize; 3]>> {
    let mut by_edge: HashMap<(usize, usize), Vec<usize>> = HashMap::with_capacity(faces.len() * 2);
    for (f, face) in faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            by_edge.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    let mut out = faces.to_vec();
    let mut done = vec![false; faces.len()];
    let mut stack = vec![0usize];
    done[0] = true;
    let directed = |f: &[usize; 3], a: usize, b: usize| (0..3).any(|k| f[k] == a && f[(k + 1) % 3] == b);
    while let Some(f) = stack.pop() {
        let face = out[f];
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            for &g in &by_edge[&(a.min(b), a.max(b))] {
                if g == f {
                    continue;
                }
                if !done[g] {
                    if directed(&out[g], a, b) {
                        out[g].swap(1, 2);
                    }
                    done[g] = true;
                    stack.push(g);
                } else if directed(&out[g], a, b) {
                    return Err(Error::NotFlattenable(format!(
                        "the triangles around the edge between taxels {} and {} cannot be oriented consistently (the surface is one-sided)",
                        ids[vertex_taxel[global[a]]], ids[vertex_taxel[global[b]]]
                    )));
                }
            }
        }
    }
    let agreement: f64 = out
        .iter()
        .map(|f| {
            let n = (verts[f[1]] - verts[f[0]]).cross(&(verts[f[2]] - verts[f[0]]));
            n.dot(&(normals[f[0]] + normals[f[1]] + normals[f[2]]))
        })
        .sum();
    if agreement < 0.0 {
        for f in &mut out {
            f.swap(1, 2);
        }
    }
    Ok(out)
}

/// The two boundary vertices farthest apart (exact below 4000 boundary vertices, otherwise a
/// double sweep), or `None` for a closed surface.
fn farthest_boundary_pair(faces: &[[usize; 3]], verts: &[Point3<f64>]) -> Option<[usize; 2]> {
    let mut count: HashMap<(usize, usize), u8> = HashMap::with_capacity(faces.len() * 2);
    for f in faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut boundary: Vec<usize> = count
        .iter()
        .filter(|(_, c)| **c == 1)
        .flat_map(|(&(a, b), _)| [a, b])
        .collect();
    boundary.sort_unstable();
    boundary.dedup();
    if boundary.len() < 2 {
        return None;
    }
    let d2 = |a: usize, b: usize| (verts[a] - verts[b]).norm_squared();
    let far_from = |a: usize| {
        boundary
            .iter()
            .copied()
            .max_by(|&x, &y| d2(a, x).total_cmp(&d2(a, y)).then(y.cmp(&x)))
            .unwrap_or(a)
    };
    if boundary.len() > 4000 {
        let a = far_from(boundary[0]);
        return Some([a, far_from(a)]);
    }
    let mut best = (0.0, [boundary[0], boundary[1]]);
    for (i, &a) in boundary.iter().enumerate() {
        for &b in &boundary[i + 1..] {
            let d = d2(a, b);
            if d > best.0 {
                best = (d, [a, b]);
            }
        }
    }
    Some(best.1)
}

/// Scales the map to the 3D area, rotates its principal axis onto u, and moves its bounding box
/// to start at (u_offset, 0).
fn normalise(pts: &mut [Point2<f64>], verts: &[Point3<f64>], faces: &[[usize; 3]], u_offset: f64) {
    let (mut a3, mut a2) = (0.0, 0.0);
    for f in faces {
        a3 += 0.5
            * (verts[f[1]] - verts[f[0]])
                .cross(&(verts[f[2]] - verts[f[0]]))
                .norm();
        let (d1, d2) = (pts[f[1]] - pts[f[0]], pts[f[2]] - pts[f[0]]);
        a2 += 0.5 * (d1.x * d2.y - d1.y * d2.x);
    }
    let scale = if a2 > 0.0 { (a3 / a2).sqrt() } else { 1.0 };
    let n = pts.len() as f64;
    let c: Vector2<f64> = pts.iter().map(|p| p.coords).sum::<Vector2<f64>>() / n;
    let mut cov = Matrix2::zeros();
    for p in pts.iter() {
        let d = p.coords - c;
        cov += d * d.transpose();
    }
    // Angle of the major axis of the 2x2 covariance, in closed form.
    let angle = 0.5 * (2.0 * cov[(0, 1)]).atan2(cov[(0, 0)] - cov[(1, 1)]);
    let rot = Rotation2::new(-angle);
    for p in pts.iter_mut() {
        *p = Point2::from(rot * ((p.coords - c) * scale));
    }
    let lo = pts
        .iter()
        .fold(Point2::new(f64::INFINITY, f64::INFINITY), |lo, p| lo.inf(p));
    for p in pts.iter_mut() {
        *p = Point2::new(p.x - lo.x + u_offset, p.y - lo.y);
    }
}

/// Applies the affine map of a triangle (3D -> map) to a point off the triangle, after projecting
/// it onto the triangle's plane.
fn extrapolate(x: Point3<f64>, tri: [Point3<f64>; 3], map: [Point2<f64>; 3]) -> Point2<f64> {
    let (d1, d2) = (tri[1] - tri[0], tri[2] - tri[0]);
    let g = nalgebra::Matrix2::new(d1.dot(&d1), d1.dot(&d2), d1.dot(&d2), d2.dot(&d2));
    let r = nalgebra::Vector2::new(d1.dot(&(x - tri[0])), d2.dot(&(x - tri[0])));
    let ab = g.lu().solve(&r).unwrap_or_default();
    map[0] + (map[1] - map[0]) * ab.x + (map[2] - map[0]) * ab.y
}

fn median_edge(verts: &[Point3<f64>], faces: &[[usize; 3]]) -> f64 {
    let mut l: Vec<f64> = faces.iter().map(|f| (verts[f[0]] - verts[f[1]]).norm()).collect();
    crate::distortion::percentile(&mut l, 50.0)
}

/// The map point of each vertex, where one is placed yet.
type Placed = Vec<Option<Point2<f64>>>;

/// Each piece of `faces` oriented, pinned at its two farthest boundary vertices, solved by LSCM,
/// normalised and laid beside the previous one: the map point of every vertex in a piece, and
/// the pieces' faces, oriented.
fn flatten_pieces(
    sm: &SkinMesh,
    pieces: &[Vec<usize>],
    faces: &[[usize; 3]],
) -> Result<(Placed, Vec<[usize; 3]>)> {
    let verts = &sm.mesh.vertices;
    let nv = verts.len();
    let gap = 2.0 * median_edge(verts, faces);
    let mut uv: Vec<Option<Point2<f64>>> = vec![None; nv];
    let mut out_faces: Vec<[usize; 3]> = Vec::with_capacity(faces.len());
    let mut u_offset = 0.0;
    for piece in pieces {
        let piece_faces: Vec<[usize; 3]> = piece.iter().map(|&f| faces[f]).collect();
        let (local_faces, global) = reindex(&piece_faces);
        let local_verts: Vec<Point3<f64>> = global.iter().map(|&v| verts[v]).collect();
        let local_normals: Vec<Vector3<f64>> = global.iter().map(|&v| sm.normals[v].into_inner()).collect();
        let oriented = orient(
            &local_faces,
            &local_verts,
            &local_normals,
            &global,
            &sm.ids,
            &sm.vertex_taxel,
        )?;
        let pins = farthest_boundary_pair(&oriented, &local_verts).ok_or_else(|| {
            Error::NotFlattenable(format!(
                "the piece containing taxel {} is a closed surface: cut it (remove a strip of triangles) before flattening",
                sm.ids[sm.vertex_taxel[global[0]]]
            ))
        })?;
        let d = (local_verts[pins[0]] - local_verts[pins[1]]).norm();
        let lscm = Lscm::new(local_verts.len(), &oriented, pins)?;
        let mut pts = lscm.solve(&local_verts, [Point2::origin(), Point2::new(d, 0.0)])?;
        normalise(&mut pts, &local_verts, &oriented, u_offset);
        let max_u = pts.iter().map(|p| p.x).fold(f64::NEG_INFINITY, f64::max);
        u_offset = max_u + gap;
        for (l, &g) in global.iter().enumerate() {
            uv[g] = Some(pts[l]);
        }
        out_faces.extend(oriented.iter().map(|f| f.map(|l| global[l])));
    }
    Ok((uv, out_faces))
}

/// The map points of every vertex: those in no triangle get the affine map of the nearest
/// placed vertex's triangle, extended to them.
fn extend_to_isolated(
    verts: &[Point3<f64>],
    mut uv: Vec<Option<Point2<f64>>>,
    out_faces: &[[usize; 3]],
) -> Result<Vec<Point2<f64>>> {
    let nv = verts.len();
    // Vertices in no triangle: extend the affine map of the nearest triangle to them.
    let placed: Vec<usize> = (0..nv).filter(|&v| uv[v].is_some()).collect();
    let mut incident: HashMap<usize, usize> = HashMap::new();
    for (f, face) in out_faces.iter().enumerate() {
        for &v in face {
            incident.entry(v).or_insert(f);
        }
    }
    for v in 0..nv {
        if uv[v].is_some() {
            continue;
        }
        let nearest = placed
            .iter()
            .copied()
            .min_by(|&a, &b| {
                (verts[a] - verts[v])
                    .norm()
                    .total_cmp(&(verts[b] - verts[v]).norm())
            })
            .ok_or_else(|| Error::TooFewTaxels("no flattened vertex".into()))?;
        let face = incident
            .get(&nearest)
            .map(|&f| out_faces[f])
            .ok_or_else(|| Error::TooFewTaxels("a flattened vertex is in no triangle".into()))?;
        uv[v] = Some(extrapolate(
            verts[v],
            face.map(|i| verts[i]),
            face.map(|i| uv[i].unwrap_or_default()),
        ));
    }
    Ok(uv.into_iter().map(|p| p.unwrap_or_default()).collect())
}

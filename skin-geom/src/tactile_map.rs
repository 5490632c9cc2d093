//! The tactile map M* = ({m_1..m_N}, F): one 2D point per taxel (thesis Ch. 3.2, Fig. 3.2a).

use crate::distortion::DistortionReport;
use crate::flatten::Lscm;
use crate::mesh::{MeshOptions, MeshReport, MeshSource, SkinMesh};
use crate::{Error, Result};
use nalgebra::{Matrix2, Point2, Point3, Rotation2, Vector2, Vector3};
use skin_core::format::cyskin::CyskinTactileMap;
use skin_core::format::{MAX_POSITION_M, excerpt};
use skin_core::{LinkSkin, TaxelId};
use std::collections::HashMap;
use std::path::Path;

/// Options for [`TactileMap::flatten`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FlattenOptions {
    /// How the mesh over the taxels is built.
    pub mesh: MeshOptions,
}

/// What flattening did besides the map itself.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct FlattenReport {
    /// Where the triangles came from (given, or triangulated in which chart). `None` for a map
    /// read from a file that does not say.
    pub source: Option<MeshSource>,
    /// Repairs made while building the mesh.
    pub mesh: MeshReport,
    /// Number of edge-connected pieces, each flattened on its own and laid side by side.
    pub components: usize,
    /// Triangles dropped because they touched another piece at a single vertex only.
    pub pinch_faces: usize,
    /// Distortion of the map.
    pub distortion: DistortionReport,
}

/// A flattened link: a 2D point per taxel (metres) and triangles over the taxels.
///
/// The map is as seen from outside the skin (triangles counter-clockwise), its area equals the 3D
/// area of the mesh, it is rotated so that its longest extent runs along u, and its bounding box
/// starts at (0, 0).
#[derive(Debug, Clone, PartialEq)]
pub struct TactileMap {
    /// Name of the link.
    pub name: String,
    /// Taxel ids in layout order.
    pub ids: Vec<TaxelId>,
    /// 3D position of each taxel, metres (empty when the map was read without them).
    pub positions: Vec<Point3<f64>>,
    /// 2D position of each taxel on the map, metres.
    pub points: Vec<Point2<f64>>,
    /// Triangles as taxel indices, counter-clockwise on the map.
    pub faces: Vec<[usize; 3]>,
    /// How the map was made and how much it distorts.
    pub report: FlattenReport,
    /// Taxels whose readings count as zero (blind spots, thesis Ch. 5.2): they stay in the
    /// triangulation, and tactile images ignore what they report. Layout indices, increasing.
    pub zeroed: Vec<usize>,
}

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
        let gap = 2.0 * median_edge(verts, &faces);
        let mut uv: Vec<Option<Point2<f64>>> = vec![None; nv];
        let mut out_faces: Vec<[usize; 3]> = Vec::with_capacity(faces.len());
        let mut u_offset = 0.0;
        for piece in &pieces {
            let piece_faces: Vec<[usize; 3]> = piece.iter().map(|&f| faces[f]).collect();
            let (local_faces, global) = reindex(&piece_faces);
            let local_verts: Vec<Point3<f64>> = global.iter().map(|&v| verts[v]).collect();
            let local_normals: Vec<Vector3<f64>> =
                global.iter().map(|&v| sm.normals[v].into_inner()).collect();
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
        let vertex_uv: Vec<Point2<f64>> = uv.into_iter().map(|p| p.unwrap_or_default()).collect();
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

    /// Width and height of the map's bounding box, metres.
    pub fn extent(&self) -> (f64, f64) {
        let (lo, hi) = self.bounds();
        (hi.x - lo.x, hi.y - lo.y)
    }

    /// Lower and upper corners of the bounding box of the points that are in a triangle.
    pub fn bounds(&self) -> (Point2<f64>, Point2<f64>) {
        let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for f in &self.faces {
            for &t in f {
                let p = self.points[t];
                lo = lo.inf(&p);
                hi = hi.sup(&p);
            }
        }
        (lo, hi)
    }

    /// The map in Cyskin's `tactile_maps` form.
    pub fn to_cyskin(&self) -> CyskinTactileMap {
        CyskinTactileMap {
            name: self.name.clone(),
            kind: "lscm".into(),
            ids: self.ids.clone(),
            points: self.points.iter().map(|p| [p.x, p.y]).collect(),
            faces: self.faces.clone(),
        }
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

/// The project's own tactile-map file, `skin-tactile-map/1`.
#[derive(serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    format: String,
    units: String,
    name: String,
    ids: Vec<TaxelId>,
    #[serde(default)]
    positions: Vec<[f64; 3]>,
    points: Vec<[f64; 2]>,
    faces: Vec<[usize; 3]>,
    #[serde(default)]
    report: FlattenReport,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    zeroed: Vec<TaxelId>,
}

/// Format tag of the project's tactile-map files.
pub const MAP_FORMAT: &str = "skin-tactile-map/1";

impl TactileMap {
    /// The map as the project's JSON (`skin-tactile-map/1`, metres).
    pub fn to_json(&self) -> String {
        let file = MapFile {
            format: MAP_FORMAT.into(),
            units: "m".into(),
            name: self.name.clone(),
            ids: self.ids.clone(),
            positions: self.positions.iter().map(|p| [p.x, p.y, p.z]).collect(),
            points: self.points.iter().map(|p| [p.x, p.y]).collect(),
            faces: self.faces.clone(),
            report: self.report.clone(),
            zeroed: self.zeroed.iter().map(|&i| self.ids[i]).collect(),
        };
        serde_json::to_string_pretty(&file).unwrap_or_default()
    }

    /// Reads a map: the project's JSON or a Cyskin `tactile_maps` file.
    pub fn read(path: &Path) -> Result<TactileMap> {
        TactileMap::parse(&skin_core::format::read_text(path)?, path)
    }

    /// Parses a map (the project's JSON or a Cyskin `tactile_maps` file) and checks it: ids
    /// unique, points and positions finite and within [`MAX_POSITION_M`] metres, faces of three
    /// distinct taxels. `path` is used in error messages.
    pub fn parse(text: &str, path: &Path) -> Result<TactileMap> {
        let bad = |place: String, msg: String| Error::Core(skin_core::Error::invalid(path, place, msg));
        if text.contains("\"tactile_maps\"") {
            let m = skin_core::format::cyskin::parse_tactile_map(text, path)?;
            let map = TactileMap {
                name: m.name,
                ids: m.ids,
                positions: Vec::new(),
                points: m.points.iter().map(|p| Point2::new(p[0], p[1])).collect(),
                faces: m.faces,
                report: FlattenReport::default(),
                zeroed: Vec::new(),
            };
            map.check(
                |i| format!("taxel {} (tactile_maps.taxels[{i}])", map.ids[i]),
                |f| format!("tactile_maps.faces[{f}]"),
            )
            .map_err(|(place, msg)| bad(place, msg))?;
            return Ok(map);
        }
        let file: MapFile = serde_json::from_str(text).map_err(|e| skin_core::Error::json(path, &e))?;
        if file.format != MAP_FORMAT {
            return Err(bad(
                "field \"format\"".into(),
                format!("expected \"{MAP_FORMAT}\", found \"{}\"", excerpt(&file.format)),
            ));
        }
        if file.units != "m" {
            return Err(bad(
                "field \"units\"".into(),
                format!("only metres are supported, found \"{}\"", excerpt(&file.units)),
            ));
        }
        let n = file.ids.len();
        if file.points.len() != n || (!file.positions.is_empty() && file.positions.len() != n) {
            return Err(bad(
                "field \"points\"".into(),
                format!(
                    "{} ids but {} points and {} positions",
                    n,
                    file.points.len(),
                    file.positions.len()
                ),
            ));
        }
        let map = TactileMap {
            name: file.name,
            ids: file.ids,
            positions: file
                .positions
                .iter()
                .map(|p| Point3::new(p[0], p[1], p[2]))
                .collect(),
            points: file.points.iter().map(|p| Point2::new(p[0], p[1])).collect(),
            faces: file.faces,
            report: file.report,
            zeroed: Vec::new(),
        };
        map.check(
            |i| format!("taxel {} (index {i})", map.ids[i]),
            |f| format!("faces[{f}]"),
        )
        .map_err(|(place, msg)| bad(place, msg))?;
        let index: std::collections::HashMap<TaxelId, usize> =
            map.ids.iter().enumerate().map(|(i, id)| (*id, i)).collect();
        let mut zeroed = Vec::with_capacity(file.zeroed.len());
        for id in &file.zeroed {
            match index.get(id) {
                Some(&i) => zeroed.push(i),
                None => {
                    return Err(bad(
                        "field \"zeroed\"".into(),
                        format!("taxel {id} is not among the map's ids"),
                    ));
                }
            }
        }
        zeroed.sort_unstable();
        zeroed.dedup();
        Ok(TactileMap { zeroed, ..map })
    }

    /// What a map read from a file must hold before anything sizes a grid or indexes by it; the
    /// error is (place, message), placed by `taxel(i)` and `face(f)`.
    fn check(
        &self,
        taxel: impl Fn(usize) -> String,
        face: impl Fn(usize) -> String,
    ) -> std::result::Result<(), (String, String)> {
        let mut seen = std::collections::HashMap::with_capacity(self.ids.len());
        for (i, id) in self.ids.iter().enumerate() {
            if let Some(first) = seen.insert(*id, i) {
                return Err((taxel(i), format!("id already used at index {first}")));
            }
        }
        let near = |v: f64| v.is_finite() && v.abs() <= MAX_POSITION_M;
        if let Some(i) = self.points.iter().position(|p| !(near(p.x) && near(p.y))) {
            return Err((
                taxel(i),
                format!(
                    "map point {:?} is not finite metres within {MAX_POSITION_M} m",
                    [self.points[i].x, self.points[i].y]
                ),
            ));
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| !p.coords.iter().all(|&v| near(v)))
        {
            return Err((
                taxel(i),
                format!(
                    "position {:?} is not finite metres within {MAX_POSITION_M} m",
                    self.positions[i].coords.as_slice()
                ),
            ));
        }
        let n = self.ids.len();
        for (f, t) in self.faces.iter().enumerate() {
            if let Some(v) = t.iter().find(|&&v| v >= n) {
                return Err((face(f), format!("index {v} is out of range ({n} taxels)")));
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err((face(f), format!("face {t:?} repeats a taxel")));
            }
        }
        Ok(())
    }

    /// The report of the flattening that made this map: mesh, repairs, pieces, size and
    /// distortion, a line each (`Display`; what `skin flatten` prints).
    pub fn flattening(&self) -> Flattening<'_> {
        Flattening { map: self }
    }

    /// An SVG drawing of the map (millimetres): triangles, and a dot per taxel.
    pub fn to_svg(&self) -> String {
        use std::fmt::Write as _;
        let (lo, hi) = self.bounds();
        let margin = 5.0;
        let mm = |v: f64| v * 1e3;
        let (w, h) = (mm(hi.x - lo.x) + 2.0 * margin, mm(hi.y - lo.y) + 2.0 * margin);
        // SVG's y axis points down: flip v so the drawing is the map as seen from outside.
        let x = |p: &Point2<f64>| mm(p.x - lo.x) + margin;
        let y = |p: &Point2<f64>| mm(hi.y - p.y) + margin;
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.1}mm" height="{h:.1}mm" viewBox="0 0 {w:.2} {h:.2}">"#
        );
        let _ = writeln!(
            s,
            r#"<title>tactile map {} ({} taxels, {} triangles)</title>"#,
            self.name,
            self.ids.len(),
            self.faces.len()
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(s, r##"<g fill="#dde8f5" stroke="#4a6fa5" stroke-width="0.2">"##);
        for f in &self.faces {
            let p = f.map(|t| self.points[t]);
            let _ = writeln!(
                s,
                r#"<polygon points="{:.2},{:.2} {:.2},{:.2} {:.2},{:.2}"/>"#,
                x(&p[0]),
                y(&p[0]),
                x(&p[1]),
                y(&p[1]),
                x(&p[2]),
                y(&p[2])
            );
        }
        let _ = writeln!(s, "</g>");
        let _ = writeln!(s, r##"<g fill="#c0392b">"##);
        for (p, id) in self.points.iter().zip(&self.ids) {
            let _ = writeln!(
                s,
                r#"<circle cx="{:.2}" cy="{:.2}" r="1.2"><title>taxel {id}</title></circle>"#,
                x(p),
                y(p)
            );
        }
        let _ = writeln!(s, "</g>\n</svg>");
        s
    }
}

/// What flattening made of a link, as `skin flatten` prints it ([`TactileMap::flattening`]).
#[derive(Debug, Clone, Copy)]
pub struct Flattening<'a> {
    map: &'a TactileMap,
}

impl std::fmt::Display for Flattening<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let map = self.map;
        let r = &map.report;
        let (w, h) = map.extent();
        match r.source {
            Some(MeshSource::Triangulated { chart }) => writeln!(
                f,
                "mesh: {} triangles, Delaunay in the {chart}; {} triangles bridging holes or the outer concavity removed",
                map.faces.len(),
                r.mesh.bridging_faces
            )?,
            _ => writeln!(f, "mesh: {} triangles as given", map.faces.len())?,
        }
        if !r.mesh.welded.is_empty() {
            writeln!(
                f,
                "taxels at the same position (sharing one map point): {}",
                r.mesh
                    .welded
                    .iter()
                    .map(|g| format!("{:?}", g.iter().map(|t| t.0).collect::<Vec<_>>()))
                    .collect::<Vec<_>>()
                    .join(" ")
            )?;
        }
        if r.mesh.degenerate_faces + r.mesh.duplicate_faces + r.pinch_faces > 0 {
            writeln!(
                f,
                "dropped triangles: {} of zero area, {} repeated, {} pinched to another piece at one vertex",
                r.mesh.degenerate_faces, r.mesh.duplicate_faces, r.pinch_faces
            )?;
        }
        if !r.mesh.normals_off_plane.is_empty() {
            writeln!(
                f,
                "{} taxel normal(s) lie more than 60 deg off the flat skin's plane: the mesh takes the plane's normal there",
                r.mesh.normals_off_plane.len()
            )?;
        }
        if !r.mesh.isolated.is_empty() {
            writeln!(
                f,
                "taxels in no triangle (map point extrapolated from the nearest triangle): {:?}",
                r.mesh.isolated.iter().map(|t| t.0).collect::<Vec<_>>()
            )?;
        }
        if r.components > 1 {
            writeln!(
                f,
                "{} separate pieces, flattened one by one and laid side by side",
                r.components
            )?;
        }
        writeln!(
            f,
            "map: {:.1} x {:.1} mm (LSCM, area-preserving scale)",
            w * 1e3,
            h * 1e3
        )?;
        write!(f, "{}", r.distortion)
    }
}

//! The triangle mesh S* = (T, F) over a link's taxels (thesis Ch. 3.2).
//!
//! [`SkinMesh::build`] takes the triangles a file gives (Cyskin `faces`) or triangulates the taxel
//! cloud (Delaunay in a 2D [`Chart`], then triangles that bridge holes or the outer
//! concavity removed). Either way it repairs what it safely can and says so in a [`MeshReport`]:
//! taxels at the same position share one vertex, zero-area and repeated triangles are dropped.
//! What it cannot repair (an edge shared by three triangles) is an error naming the taxels.

use crate::chart::{Chart, choose_chart};
use crate::triangulate::{PruneLimits, delaunay, prune};
use crate::{Error, Result};
use nalgebra::{Point3, Unit, Vector3};
use skin_core::{LinkSkin, TaxelId};
use std::collections::HashMap;

/// A triangle mesh: vertices in metres and counter-clockwise triangles indexing them.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TriMesh {
    /// Vertex positions, metres.
    pub vertices: Vec<Point3<f64>>,
    /// Triangles as vertex indices.
    pub faces: Vec<[usize; 3]>,
}

impl TriMesh {
    /// Area of triangle `f`, square metres.
    pub fn face_area(&self, f: usize) -> f64 {
        let [a, b, c] = self.faces[f];
        let (a, b, c) = (self.vertices[a], self.vertices[b], self.vertices[c]);
        0.5 * (b - a).cross(&(c - a)).norm()
    }

    /// Total area, square metres.
    pub fn area(&self) -> f64 {
        (0..self.faces.len()).map(|f| self.face_area(f)).sum()
    }
}

/// Where the triangles came from.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum MeshSource {
    /// The triangles given with the layout (Cyskin `faces`) or by a user mesh file.
    Given,
    /// Delaunay triangulation in this chart.
    Triangulated {
        /// The chart used.
        chart: Chart,
    },
}

/// What building the mesh repaired or left out.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct MeshReport {
    /// Groups of taxels found at one position (within 1 µm): they share the first one's vertex.
    pub welded: Vec<Vec<TaxelId>>,
    /// Triangles dropped because their area is zero (collinear or merged corners).
    pub degenerate_faces: usize,
    /// Triangles dropped because an identical one came before.
    pub duplicate_faces: usize,
    /// Triangulated meshes: triangles removed because they bridge a hole or the outer concavity.
    pub bridging_faces: usize,
    /// Taxels that are in no triangle: their map point is extrapolated from the nearest triangle.
    pub isolated: Vec<TaxelId>,
    /// Taxels of a flat cloud whose given normal is more than 60 degrees off the cloud's plane
    /// (a flat foot sole with normals that are not the plane's): the mesh takes the plane's
    /// normal at them instead.
    pub normals_off_plane: Vec<TaxelId>,
}

/// Options for [`SkinMesh::build`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshOptions {
    /// Use the triangles given with the layout when there are any (default `true`).
    pub use_given_faces: bool,
    /// A triangulated edge longer than this many local taxel pitches bridges a gap (default 3.0).
    pub max_edge_pitches: f64,
    /// Triangles on the border with a smaller angle than this are slivers of the outer
    /// concavity and are peeled off, degrees (default 15).
    pub min_border_angle_deg: f64,
    /// A triangulated triangle whose plane is further than this from the taxel normals at its
    /// corners cuts across the surface and is removed, degrees (default 45).
    pub max_normal_deviation_deg: f64,
}

impl Default for MeshOptions {
    fn default() -> Self {
        MeshOptions {
            use_given_faces: true,
            max_edge_pitches: 3.0,
            min_border_angle_deg: 15.0,
            max_normal_deviation_deg: 45.0,
        }
    }
}

/// A link's taxels with a mesh over their distinct positions.
#[derive(Debug, Clone, PartialEq)]
pub struct SkinMesh {
    /// The mesh: one vertex per distinct taxel position.
    pub mesh: TriMesh,
    /// Outward normal per vertex (the first taxel's at that position).
    pub normals: Vec<Unit<Vector3<f64>>>,
    /// For each taxel (layout order), its vertex.
    pub taxel_vertex: Vec<usize>,
    /// For each vertex, the taxel (layout index) it was made from.
    pub vertex_taxel: Vec<usize>,
    /// Taxel ids in layout order.
    pub ids: Vec<TaxelId>,
    /// How the triangles were obtained.
    pub source: MeshSource,
    /// What was repaired.
    pub report: MeshReport,
}

/// Distance under which two taxels are taken to be at the same position, metres.
pub const WELD_DISTANCE: f64 = 1e-6;

impl SkinMesh {
    /// Builds the mesh of a link.
    pub fn build(link: &LinkSkin, options: &MeshOptions) -> Result<SkinMesh> {
        let ids: Vec<TaxelId> = link.taxels.iter().map(|t| t.id).collect();
        let positions: Vec<Point3<f64>> = link.taxels.iter().map(|t| t.position).collect();
        if let Some(i) = positions
            .iter()
            .position(|p| !p.coords.iter().all(|v| v.is_finite()))
        {
            return Err(Error::TooFewTaxels(format!(
                "taxel {} has a position that is not finite",
                ids[i]
            )));
        }
        let (taxel_vertex, vertex_taxel, welded) = weld(&positions, &ids);
        let vertices: Vec<Point3<f64>> = vertex_taxel.iter().map(|&t| positions[t]).collect();
        let mut normals: Vec<Unit<Vector3<f64>>> =
            vertex_taxel.iter().map(|&t| link.taxels[t].normal).collect();
        if vertices.len() < 3 {
            return Err(Error::TooFewTaxels(format!(
                "{} distinct taxel position(s) ({} taxels): a surface needs at least 3",
                vertices.len(),
                ids.len()
            )));
        }
        let mut report = MeshReport {
            welded,
            ..MeshReport::default()
        };
        let (faces, source) = match (&link.faces, options.use_given_faces) {
            (Some(given), true) if !given.is_empty() => {
                (given_faces(given, &taxel_vertex)?, MeshSource::Given)
            }
            _ => {
                let welded = Welded {
                    ids: &ids,
                    vertex_taxel: &vertex_taxel,
                };
                triangulated(&vertices, &mut normals, welded, &mut report)?
            }
        };
        let mut mesh = TriMesh { vertices, faces };
        clean_faces(&mut mesh, &mut report);
        if let MeshSource::Triangulated { .. } = source {
            let limits = PruneLimits {
                max_normal_deviation_deg: options.max_normal_deviation_deg,
                max_edge_pitches: options.max_edge_pitches,
                min_border_angle_deg: options.min_border_angle_deg,
            };
            report.bridging_faces = prune(&mesh.vertices, &mut mesh.faces, &normals, &limits);
        }
        if mesh.faces.is_empty() {
            return Err(Error::TooFewTaxels(
                "no triangle of non-zero area can be made over the taxels (are they all collinear?)".into(),
            ));
        }
        check_manifold(&mesh, &ids, &vertex_taxel)?;
        report.isolated = isolated(&mesh, &ids, &vertex_taxel);
        Ok(SkinMesh {
            mesh,
            normals,
            taxel_vertex,
            vertex_taxel,
            ids,
            source,
            report,
        })
    }
}

/// Given triangles (taxel indices), checked and turned into vertex indices.
fn given_faces(given: &[[usize; 3]], taxel_vertex: &[usize]) -> Result<Vec<[usize; 3]>> {
    for (f, face) in given.iter().enumerate() {
        if let Some(&bad) = face.iter().find(|&&v| v >= taxel_vertex.len()) {
            return Err(Error::FaceIndex {
                face: f,
                index: bad,
                taxels: taxel_vertex.len(),
            });
        }
    }
    Ok(given.iter().map(|f| f.map(|t| taxel_vertex[t])).collect())
}

/// The ids of the taxels and the taxel of each welded vertex.
#[derive(Clone, Copy)]
struct Welded<'a> {
    ids: &'a [TaxelId],
    vertex_taxel: &'a [usize],
}

/// Delaunay triangles of the vertices in the chart that fits them; on a flat cloud, normals far
/// off its plane take the plane's (reported).
fn triangulated(
    vertices: &[Point3<f64>],
    normals: &mut [Unit<Vector3<f64>>],
    welded: Welded<'_>,
    report: &mut MeshReport,
) -> Result<(Vec<[usize; 3]>, MeshSource)> {
    let (chart, uv) = choose_chart(vertices, normals)?;
    // A flat cloud is its plane, whatever its normals say: a normal far off the plane would make
    // every triangle look as if it cut across the surface.
    if let Chart::Plane { normal } = chart
        && crate::chart::is_flat(vertices)
    {
        let plane = Unit::new_normalize(Vector3::from(normal));
        for (v, n) in normals.iter_mut().enumerate() {
            if n.dot(&plane) < 0.5 {
                *n = plane;
                report.normals_off_plane.push(welded.ids[welded.vertex_taxel[v]]);
            }
        }
    }
    let faces = delaunay(&uv)?;
    Ok((faces, MeshSource::Triangulated { chart }))
}

/// The taxels of the vertices in no triangle.
fn isolated(mesh: &TriMesh, ids: &[TaxelId], vertex_taxel: &[usize]) -> Vec<TaxelId> {
    let mut used = vec![false; mesh.vertices.len()];
    for f in &mesh.faces {
        for &v in f {
            used[v] = true;
        }
    }
    used.iter()
        .enumerate()
        .filter(|(_, u)| !**u)
        .map(|(v, _)| ids[vertex_taxel[v]])
        .collect()
}

/// Merges taxels closer than [`WELD_DISTANCE`] into one vertex.
fn weld(positions: &[Point3<f64>], ids: &[TaxelId]) -> (Vec<usize>, Vec<usize>, Vec<Vec<TaxelId>>) {
    let cell = |p: &Point3<f64>| {
        (
            (p.x / WELD_DISTANCE).floor() as i64,
            (p.y / WELD_DISTANCE).floor() as i64,
            (p.z / WELD_DISTANCE).floor() as i64,
        )
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::with_capacity(positions.len());
    let mut taxel_vertex = vec![0usize; positions.len()];
    let mut vertex_taxel: Vec<usize> = Vec::with_capacity(positions.len());
    let mut groups: HashMap<usize, Vec<TaxelId>> = HashMap::new();
    for (t, p) in positions.iter().enumerate() {
        let (cx, cy, cz) = cell(p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(vs) = grid.get(&(cx + dx, cy + dy, cz + dz)) {
                        for &v in vs {
                            if (positions[vertex_taxel[v]] - p).norm() <= WELD_DISTANCE {
                                found = Some(v);
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        match found {
            Some(v) => {
                taxel_vertex[t] = v;
                groups
                    .entry(v)
                    .or_insert_with(|| vec![ids[vertex_taxel[v]]])
                    .push(ids[t]);
            }
            None => {
                let v = vertex_taxel.len();
                vertex_taxel.push(t);
                taxel_vertex[t] = v;
                grid.entry((cx, cy, cz)).or_default().push(v);
            }
        }
    }
    let mut welded: Vec<(usize, Vec<TaxelId>)> = groups.into_iter().collect();
    welded.sort_by_key(|(v, _)| *v);
    (
        taxel_vertex,
        vertex_taxel,
        welded.into_iter().map(|(_, g)| g).collect(),
    )
}

/// Drops zero-area and repeated triangles.
fn clean_faces(mesh: &mut TriMesh, report: &mut MeshReport) {
    let mut seen = std::collections::HashSet::with_capacity(mesh.faces.len());
    let vertices = &mesh.vertices;
    mesh.faces.retain(|&[a, b, c]| {
        if a == b || b == c || a == c {
            report.degenerate_faces += 1;
            return false;
        }
        let (pa, pb, pc) = (vertices[a], vertices[b], vertices[c]);
        let longest = (pb - pa)
            .norm_squared()
            .max((pc - pb).norm_squared())
            .max((pa - pc).norm_squared());
        let twice_area = (pb - pa).cross(&(pc - pa)).norm();
        // Height over the longest edge below a millionth of that edge: no surface there.
        if !(twice_area > 1e-6 * longest) {
            report.degenerate_faces += 1;
            return false;
        }
        let mut key = [a, b, c];
        key.sort_unstable();
        if !seen.insert(key) {
            report.duplicate_faces += 1;
            return false;
        }
        true
    });
}

fn check_manifold(mesh: &TriMesh, ids: &[TaxelId], vertex_taxel: &[usize]) -> Result<()> {
    let mut edges: HashMap<(usize, usize), Vec<usize>> = HashMap::with_capacity(mesh.faces.len() * 2);
    for (f, face) in mesh.faces.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            edges.entry((a.min(b), a.max(b))).or_default().push(f);
        }
    }
    let mut worst: Option<(&(usize, usize), &Vec<usize>)> = None;
    for (e, fs) in &edges {
        if fs.len() > 2 && worst.is_none_or(|(w, _)| e < w) {
            worst = Some((e, fs));
        }
    }
    if let Some((&(a, b), fs)) = worst {
        return Err(Error::NonManifoldEdge {
            a: ids[vertex_taxel[a]],
            b: ids[vertex_taxel[b]],
            count: fs.len(),
            faces: fs.iter().take(4).copied().collect(),
        });
    }
    Ok(())
}
